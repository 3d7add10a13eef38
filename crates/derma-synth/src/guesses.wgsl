// Coherent starting guesses of an optimisation pass's windows (Ashikhmin 2001's continuation of
// a texel's source, as canvas.rs's `coherent_guess`) from the canvas's sources kept on the GPU
// by the E-step: the same guesses, in the same order, as the host makes from its copy. The
// list itself is guess_list.wgsl's (appended).

struct Params {
    // Window side and windows of the batch.
    w: u32,
    n_queries: u32,
    // Words per window row in `windows` (x, y, salt, then the guesses).
    stride: u32,
    // The searched exemplar: its index, width and candidate grid.
    exemplar: u32,
    ex_width: u32,
    cand_w: u32,
    cand_h: u32,
    // The canvas, and whether it wraps.
    canvas_w: u32,
    canvas_h: u32,
    wrap: u32,
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var<uniform> p: Params;
@group(0) @binding(1) var<storage, read> sources: array<u32>;
@group(0) @binding(2) var<storage, read> source_exemplars: array<u32>;
@group(0) @binding(3) var<storage, read_write> windows: array<u32>;

const NONE: u32 = 0xffffffffu;
const WORKGROUP: u32 = 64u;
const PROBES: u32 = 5u;

// Offset of probe j in a window of side w: the centre, then the corners (optimize.rs, `probes`).
fn probe(j: u32) -> vec2<u32> {
    let e = p.w - 1u;
    switch j {
        case 0u: { return vec2<u32>(p.w / 2u, p.w / 2u); }
        case 1u: { return vec2<u32>(0u, 0u); }
        case 2u: { return vec2<u32>(e, 0u); }
        case 3u: { return vec2<u32>(0u, e); }
        default: { return vec2<u32>(e, e); }
    }
}

@compute @workgroup_size(64)
fn guesses(@builtin(global_invocation_id) gid: vec3<u32>) {
    let q = gid.x + gid.y * 65535u * WORKGROUP;
    if (q >= p.n_queries) { return; }
    let row = q * p.stride;
    let px = windows[row];
    let py = windows[row + 1u];
    var n = 0u;
    for (var j = 0u; j < PROBES; j++) {
        let d = probe(j);
        var x = px + d.x;
        var y = py + d.y;
        if (p.wrap != 0u) {
            x = x % p.canvas_w;
            y = y % p.canvas_h;
        }
        let t = y * p.canvas_w + x;
        let s = sources[t];
        if (s == NONE || source_exemplars[t] != p.exemplar) { continue; }
        n = add_guess(row + 3u, n, continuation(s, d, p.ex_width, p.cand_w, p.cand_h));
    }
    close_guesses(row + 3u, n, p.stride - 3u);
}
