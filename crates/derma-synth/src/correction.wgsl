// The texel-level coherent correction of derma-synth on the GPU (correction.rs: Ashikhmin 2001
// §3's coherent candidates, run in parallel as Lefebvre & Hoppe 2005 §3.3–3.4), deciding exactly
// what the CPU decides: for texel p of this subpass's parity, each of the 3 × 3 neighbours q with
// a source proposes S(q) + (p − q), clamped so its 5 × 5 neighbourhood lies in the exemplar; p
// takes the proposal of least integer L2 distance over the 5 × 5 codes, ties to the lower
// (exemplar, texel). `decide` reads the canvas as it was before the subpass and writes the
// choices; `apply` then copies the chosen exemplar texels' codes and sources.

struct Params {
    width: u32,
    height: u32,
    channels: u32,
    wrap: u32,        // 1: the canvas is a torus
    has_guide: u32,   // 1: `want` holds the exemplar each texel must draw from
    ox: u32,          // this subpass's parity: texels (ox + 2i, oy + 2j)
    oy: u32,
    cols: u32,        // texels of the parity per row
    count: u32,       // texels of the parity
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<uniform> p: Params;
// Per exemplar: width, height, offset of its first code in `ex_codes`, unused.
@group(0) @binding(1) var<storage, read> ex_info: array<vec4<u32>>;
// All exemplars' codes, one per word, texels row-major, channels interleaved.
@group(0) @binding(2) var<storage, read> ex_codes: array<u32>;
// Per texel: the exemplar it must draw from (when has_guide).
@group(0) @binding(3) var<storage, read> want: array<u32>;
// The canvas: codes (one per word), sources (exemplar texel, NONE where none) and source
// exemplars (bit 31 set once the correction has decided the texel).
@group(0) @binding(4) var<storage, read_write> codes: array<u32>;
@group(0) @binding(5) var<storage, read_write> src: array<u32>;
@group(0) @binding(6) var<storage, read_write> src_ex: array<u32>;
// Per texel of the parity: the chosen (exemplar, texel), or NONE in x.
@group(0) @binding(7) var<storage, read_write> choice: array<vec2<u32>>;

const NONE: u32 = 0xffffffffu;
const DECIDED: u32 = 0x80000000u;
const RADIUS: i32 = 2;

// Output texel (x + dx, y + dy), wrapping on a torus; NONE off a plane (Canvas::neighbour).
fn neighbour(x: u32, y: u32, dx: i32, dy: i32) -> u32 {
    let w = i32(p.width);
    let h = i32(p.height);
    var nx = i32(x) + dx;
    var ny = i32(y) + dy;
    if (p.wrap == 1u) {
        nx = ((nx % w) + w) % w;
        ny = ((ny % h) + h) % h;
    } else if (nx < 0 || ny < 0 || nx >= w || ny >= h) {
        return NONE;
    }
    return u32(ny) * p.width + u32(nx);
}

fn thread_of(gid: vec3<u32>) -> u32 {
    return gid.x + gid.y * 65535u * 64u;
}

// The texel of the parity a thread serves.
fn texel_of(i: u32) -> vec2<u32> {
    return vec2<u32>(p.ox + 2u * (i % p.cols), p.oy + 2u * (i / p.cols));
}

// The 5 × 5 distance of exemplar `e`'s texel `s` to the neighbourhood of (x, y).
fn distance(x: u32, y: u32, e: u32, s: u32) -> u32 {
    let info = ex_info[e];
    let ew = i32(info.x);
    let sx = i32(s) % ew;
    let sy = i32(s) / ew;
    var d = 0u;
    for (var dy = -RADIUS; dy <= RADIUS; dy++) {
        for (var dx = -RADIUS; dx <= RADIUS; dx++) {
            let q = neighbour(x, y, dx, dy);
            if (q == NONE) { continue; }
            let es = u32((sy + dy) * ew + sx + dx);
            for (var k = 0u; k < p.channels; k++) {
                let diff = i32(codes[q * p.channels + k]) - i32(ex_codes[info.z + es * p.channels + k]);
                d += u32(diff * diff);
            }
        }
    }
    return d;
}

@compute @workgroup_size(64)
fn decide(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = thread_of(gid);
    if (i >= p.count) { return; }
    let t = texel_of(i);
    let x = t.x;
    let y = t.y;
    var wanted = NONE;
    if (p.has_guide == 1u) { wanted = want[y * p.width + x]; }
    // Proposals in the CPU's order (rows, then columns, of the 3 × 3), without repeats.
    var prop_ex: array<u32, 9>;
    var prop_s: array<u32, 9>;
    var n = 0u;
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let q = neighbour(x, y, dx, dy);
            if (q == NONE || src[q] == NONE) { continue; }
            let e = src_ex[q] & 0xffu;
            if (wanted != NONE && wanted != e) { continue; }
            let info = ex_info[e];
            let ew = i32(info.x);
            let eh = i32(info.y);
            let s = i32(src[q]);
            let sx = clamp(s % ew - dx, RADIUS, ew - 1 - RADIUS);
            let sy = clamp(s / ew - dy, RADIUS, eh - 1 - RADIUS);
            let cand = u32(sy * ew + sx);
            var seen = false;
            for (var j = 0u; j < n; j++) {
                if (prop_ex[j] == e && prop_s[j] == cand) { seen = true; }
            }
            if (!seen) {
                prop_ex[n] = e;
                prop_s[n] = cand;
                n++;
            }
        }
    }
    var best = vec3<u32>(NONE, NONE, NONE);
    for (var j = 0u; j < n; j++) {
        let d = distance(x, y, prop_ex[j], prop_s[j]);
        // Least distance; ties to the lower (exemplar, texel).
        let better = d < best.x
            || (d == best.x && (prop_ex[j] < best.y || (prop_ex[j] == best.y && prop_s[j] < best.z)));
        if (best.y == NONE || better) {
            best = vec3<u32>(d, prop_ex[j], prop_s[j]);
        }
    }
    choice[i] = best.yz;
}

@compute @workgroup_size(64)
fn apply(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = thread_of(gid);
    if (i >= p.count) { return; }
    let c = choice[i];
    if (c.x == NONE) { return; }
    let t = texel_of(i);
    let texel = t.y * p.width + t.x;
    let base = ex_info[c.x].z;
    for (var k = 0u; k < p.channels; k++) {
        codes[texel * p.channels + k] = ex_codes[base + c.y * p.channels + k];
    }
    src[texel] = c.y;
    src_ex[texel] = c.x | DECIDED;
}
