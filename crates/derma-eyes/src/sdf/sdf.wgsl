// Screen-space distance fields on the GPU (derma-eyes sdf/gpu.rs): jump flooding (Rong & Tan
// 2006) and the thesis' three samplers (§4.4.1–4.4.3) — the same algorithms, hash and
// sample positions as the CPU reference in exact.rs/jfa.rs and samplers.rs.

struct Params {
    width: u32,
    height: u32,
    focal: f32,
    range: f32,
    step: u32,
    n: u32,
    steps: u32,
    refine: u32,
};

@group(0) @binding(0) var<uniform> p: Params;
@group(0) @binding(1) var<storage, read> mask: array<u32>;
@group(0) @binding(2) var<storage, read> depth: array<f32>;
@group(0) @binding(3) var<storage, read> seeds_in: array<u32>;
@group(0) @binding(4) var<storage, read_write> seeds_out: array<u32>;
@group(0) @binding(5) var<storage, read_write> dist: array<f32>;
@group(0) @binding(6) var<storage, read_write> acc: array<u32>;
@group(0) @binding(7) var<storage, read_write> offs: array<vec2<f32>>;

const NONE: u32 = 0xffffffffu;
const SKIN: u32 = 1u;
const EYE: u32 = 2u;
const TAU: f32 = 6.28318530717958647692;
const PI: f32 = 3.14159265358979323846;
const ROTATION_SALT: u32 = 0x51u;
const INF: f32 = 0x1p+127;

fn index(gid: vec3<u32>) -> u32 {
    return gid.x + gid.y * 65535u * 64u;
}

fn hash01(x: u32, y: u32, salt: u32) -> f32 {
    var v = x * 1664525u + y * 22695477u + salt * 2654435761u;
    v = v * 747796405u + 2891336453u;
    let w = ((v >> ((v >> 28u) + 4u)) ^ v) * 277803737u;
    return f32((w >> 22u) ^ w) * (1.0 / 4294967296.0);
}

fn is_skin(x: i32, y: i32) -> bool {
    if (x < 0 || y < 0 || x >= i32(p.width) || y >= i32(p.height)) {
        return false;
    }
    return mask[u32(y) * p.width + u32(x)] == SKIN;
}

fn dist2(s: u32, x: u32, y: u32) -> u32 {
    if (s == NONE) {
        return 0xffffffffu;
    }
    let dx = i32(s % p.width) - i32(x);
    let dy = i32(s / p.width) - i32(y);
    return u32(dx * dx + dy * dy);
}

@compute @workgroup_size(64)
fn jfa_init(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = index(gid);
    if (i >= p.width * p.height) {
        return;
    }
    seeds_out[i] = select(NONE, i, mask[i] == SKIN);
}

@compute @workgroup_size(64)
fn jfa_step(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = index(gid);
    if (i >= p.width * p.height) {
        return;
    }
    let x = i % p.width;
    let y = i / p.width;
    let k = i32(p.step);
    var best = seeds_in[i];
    var bd = dist2(best, x, y);
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let nx = i32(x) + dx * k;
            let ny = i32(y) + dy * k;
            if (nx < 0 || ny < 0 || nx >= i32(p.width) || ny >= i32(p.height)) {
                continue;
            }
            let s = seeds_in[u32(ny) * p.width + u32(nx)];
            let d = dist2(s, x, y);
            if (d < bd) {
                bd = d;
                best = s;
            }
        }
    }
    seeds_out[i] = best;
}

@compute @workgroup_size(64)
fn jfa_distance(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = index(gid);
    if (i >= p.width * p.height) {
        return;
    }
    let s = seeds_in[i];
    if (mask[i] != EYE || s == NONE) {
        dist[i] = INF;
        return;
    }
    let ppm = p.focal / max(depth[i], 1e-3);
    dist[i] = sqrt(f32(dist2(s, i % p.width, i / p.width))) / ppm;
}

// One pixel's search state.
var<private> px: vec2<f32>;
var<private> ppm: f32;
var<private> accesses: u32;

fn skin_at(dir: vec2<f32>, d: f32) -> bool {
    accesses += 1u;
    let sx = i32(floor(px.x + dir.x * d * ppm));
    let sy = i32(floor(px.y + dir.y * d * ppm));
    return is_skin(sx, sy);
}

fn centre_distance(dir: vec2<f32>, d: f32) -> f32 {
    let sx = floor(px.x + dir.x * d * ppm) + 0.5;
    let sy = floor(px.y + dir.y * d * ppm) + 0.5;
    let dx = sx - px.x;
    let dy = sy - px.y;
    return sqrt(dx * dx + dy * dy) / ppm;
}

fn bisect(dir: vec2<f32>, lo_in: f32, hi_in: f32, best: f32) -> f32 {
    var lo = lo_in;
    var hi = hi_in;
    let half_px = 0.5 / ppm;
    for (var s = 0u; s < p.steps; s++) {
        if (p.refine > 0u && (hi - lo < half_px || lo >= best)) {
            break;
        }
        let mid = 0.5 * (lo + hi);
        if (skin_at(dir, mid)) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    return hi;
}

fn unit(a: f32) -> vec2<f32> {
    return vec2<f32>(cos(a), sin(a));
}

@compute @workgroup_size(64)
fn backtrack(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = index(gid);
    if (i >= p.width * p.height) {
        return;
    }
    if (mask[i] != EYE) {
        dist[i] = INF;
        acc[i] = 0u;
        return;
    }
    let rot = hash01(i % p.width, i / p.width, ROTATION_SALT);
    begin(i);
    accesses = 1u;
    let range = p.range;
    var best = INF;
    var best_angle = 0.0;
    var reach = range;
    if (p.refine > 0u) {
        reach = range / cos(PI / f32(p.n));
    }
    for (var k = 0u; k < p.n; k++) {
        let a = TAU * (f32(k) + rot) / f32(p.n);
        let dir = unit(a);
        if (!skin_at(dir, reach)) {
            continue;
        }
        var d = bisect(dir, 0.0, reach, best);
        d = centre_distance(dir, d);
        if (d < best) {
            best = d;
            best_angle = a;
        }
    }
    if (p.refine > 0u && best < INF) {
        var spacing = TAU / f32(p.n);
        for (var level = 0u; level < p.refine; level++) {
            spacing *= 0.5;
            let centre = best_angle;
            for (var side = 0u; side < 2u; side++) {
                let s = select(0.5, -0.5, side == 0u);
                let a = centre + s * spacing;
                let dir = unit(a);
                if (!skin_at(dir, best)) {
                    continue;
                }
                let floor_d = best * cos(spacing);
                var d: f32;
                if (skin_at(dir, floor_d)) {
                    d = bisect(dir, 0.0, floor_d, best);
                } else {
                    d = bisect(dir, floor_d, best, best);
                }
                d = centre_distance(dir, d);
                if (d < best) {
                    best = d;
                    best_angle = a;
                }
            }
        }
    }
    dist[i] = best;
    acc[i] = accesses;
}

// 2^k exactly (the CPU's powi), where pow() may round.
fn powi2(k: u32) -> f32 {
    var v = 1.0;
    for (var j = 0u; j < k; j++) {
        v *= 2.0;
    }
    return v;
}

fn begin(i: u32) {
    let x = i % p.width;
    let y = i / p.width;
    px = vec2<f32>(f32(x) + 0.5, f32(y) + 0.5);
    ppm = p.focal / max(depth[i], 1e-3);
}

// §4.4.1: n equiangular directions, one sample each at a random distance in (0, Λ].
@compute @workgroup_size(64)
fn equiangular(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = index(gid);
    if (i >= p.width * p.height) {
        return;
    }
    if (mask[i] != EYE) {
        dist[i] = INF;
        acc[i] = 0u;
        return;
    }
    let x = i % p.width;
    let y = i / p.width;
    let rot = hash01(x, y, ROTATION_SALT);
    begin(i);
    accesses = 1u;
    var best = INF;
    for (var k = 0u; k < p.n; k++) {
        let dir = unit(TAU * (f32(k) + rot) / f32(p.n));
        let d = p.range * (1.0 - hash01(x, y, 0x100u + k));
        if (skin_at(dir, d)) {
            best = min(best, centre_distance(dir, d));
        }
    }
    dist[i] = best;
    acc[i] = accesses;
}

fn skin_at_px(o: vec2<f32>) -> bool {
    return is_skin(i32(floor(px.x + o.x)), i32(floor(px.y + o.y)));
}

// §4.4.2 pass 1: growing then shrinking steps along the pixel's rotated axis, both ways; the
// offset (texels) to the centre of the nearest skin texel found.
@compute @workgroup_size(64)
fn exp_pass1(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = index(gid);
    if (i >= p.width * p.height) {
        return;
    }
    if (mask[i] != EYE) {
        offs[i] = vec2<f32>(INF, INF);
        acc[i] = 0u;
        return;
    }
    let x = i % p.width;
    let y = i / p.width;
    let a = TAU * hash01(x, y, ROTATION_SALT);
    begin(i);
    var count = 1u;
    var best = vec2<f32>(INF, INF);
    var best_d = INF;
    let mu = 2.0;
    let h0 = p.range * (mu - 1.0) / (powi2((p.steps + 1u) / 2u) - 1.0);
    for (var side = 0u; side < 2u; side++) {
        let sgn = select(-1.0, 1.0, side == 0u);
        let dir = vec2<f32>(sgn * cos(a), sgn * sin(a));
        var pos = 0.0;
        var step = h0;
        var found = false;
        var dr = 1.0;
        var d = INF;
        for (var k = 0u; k < p.steps; k++) {
            if (!found) {
                pos += step;
                if (pos > p.range * 1.0001) {
                    break;
                }
                count += 1u;
                if (skin_at_px(vec2<f32>(dir.x * pos * ppm, dir.y * pos * ppm))) {
                    found = true;
                    d = pos;
                    dr = -1.0;
                } else {
                    step *= mu;
                    continue;
                }
            } else {
                pos += dr * step;
                count += 1u;
                if (skin_at_px(vec2<f32>(dir.x * pos * ppm, dir.y * pos * ppm))) {
                    d = min(d, pos);
                    dr = -1.0;
                } else {
                    dr = 1.0;
                }
            }
            step /= mu;
        }
        if (d < INF) {
            let cx = floor(px.x + dir.x * d * ppm) + 0.5 - px.x;
            let cy = floor(px.y + dir.y * d * ppm) + 0.5 - px.y;
            let dc = sqrt(cx * cx + cy * cy) / ppm;
            if (dc < best_d) {
                best_d = dc;
                best = vec2<f32>(cx, cy);
            }
        }
    }
    offs[i] = best;
    acc[i] = count;
}

fn exp_probe(dir: vec2<f32>, t: f32, x: u32, y: u32) -> f32 {
    let ox = dir.x * t * ppm;
    let oy = dir.y * t * ppm;
    let sx = i32(floor(px.x + ox));
    let sy = i32(floor(px.y + oy));
    let cx = floor(px.x + ox) - f32(x);
    let cy = floor(px.y + oy) - f32(y);
    if (sx < 0 || sy < 0 || sx >= i32(p.width) || sy >= i32(p.height)) {
        return INF;
    }
    let j = u32(sy) * p.width + u32(sx);
    if (mask[j] == SKIN) {
        return sqrt(cx * cx + cy * cy) / ppm;
    }
    let o = offs[j];
    if (mask[j] == EYE && o.x < 1e30) {
        let ex = cx + o.x;
        let ey = cy + o.y;
        return sqrt(ex * ex + ey * ey) / ppm;
    }
    return INF;
}

// §4.4.2 pass 2: perpendicular, minimising the distance to the skin points pass 1 found at the
// samples (eq. 4.13 with the stored offsets).
@compute @workgroup_size(64)
fn exp_pass2(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = index(gid);
    if (i >= p.width * p.height) {
        return;
    }
    if (mask[i] != EYE) {
        dist[i] = INF;
        return;
    }
    let x = i % p.width;
    let y = i / p.width;
    let a = TAU * hash01(x, y, ROTATION_SALT) + PI / 2.0;
    begin(i);
    let own = offs[i];
    var best = INF;
    if (own.x < 1e30) {
        best = sqrt(own.x * own.x + own.y * own.y) / ppm;
    }
    var count = 0u;
    let mu = 2.0;
    let h0 = p.range * (mu - 1.0) / (powi2((p.steps + 1u) / 2u) - 1.0);
    for (var side = 0u; side < 2u; side++) {
        let sgn = select(-1.0, 1.0, side == 0u);
        let dir = vec2<f32>(sgn * cos(a), sgn * sin(a));
        var pos = 0.0;
        var step = h0;
        var growing = true;
        var dr = 1.0;
        var last = INF;
        for (var k = 0u; k < p.steps; k++) {
            pos = clamp(pos + dr * step, 0.0, p.range);
            count += 2u;
            let m = exp_probe(dir, pos, x, y);
            best = min(best, m);
            if (growing) {
                if (m < 1e30 && m > last) {
                    growing = false;
                    dr = -dr;
                    step /= mu;
                } else if (m < 1e30 && m == 0.0) {
                    growing = false;
                    dr = -1.0;
                    step /= mu;
                } else {
                    step *= mu;
                }
            } else {
                step /= mu;
                if (m > last || m == 0.0) {
                    dr = -dr;
                }
            }
            last = m;
        }
    }
    dist[i] = best;
    acc[i] = acc[i] + count;
}
