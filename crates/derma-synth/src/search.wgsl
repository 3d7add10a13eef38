// The best-match search of derma-synth on the GPU (Shen et al. §3.4: one thread per exemplar
// position, then a reduction), computing exactly the search defined in search.rs:
//   cost(p) = Σ over known texels and channels (code_e − code_q)²  +  penalty[p] · known
//   d* = min cost;  T = d* + ⌊d*·ε₁₆/2¹⁶⌋;  answer = argmin over cost ≤ T of pick_key(salt, p)
// Pass `min_cost` reduces d* with atomicMin (pruning with the guesses' cost, an upper bound
// of d*), `settle` copies d*'s limit T out of the atomics, and `pick` reduces the least key.
// Positions whose quadrant block-sum bound already exceeds the limit are skipped (a safe lower
// bound, so the answer is unchanged). Integers decide: CPU and GPU agree exactly.
//
// A query's window is read from `source`, a plane of codes: either the windows the host
// uploaded, stacked one under the other (the patch pass's, with unknown texels), or the
// canvas itself, kept on the GPU for an optimisation pass, with each query's window at its
// origin (wrapping on a torus). For the canvas, `prepare` computes on the GPU the info the host
// computes for uploaded windows (quadrant sums, the guesses' cost), and `finish` turns each
// answer's key back into a position and its cost, for either source.

struct Params {
    ex_width: u32,     // exemplar width
    channels: u32,
    w: u32,            // window side
    cand_w: u32,       // candidate columns = ex_width − w + 1
    cand_h: u32,
    plane_w: u32,      // block-sum plane width = ex_width − w/2 + 1
    plane_len: u32,    // block-sum plane size (one per channel)
    tol: u32,          // ε·2¹⁶
    has_penalty: u32,
    info_stride: u32,  // u32 words per query in `info`
    n_queries: u32,
    capacity: u32,     // room in `survivors`
    src_width: u32,    // the source plane's width and height (windows wrap at them)
    src_height: u32,
    max_guesses: u32,  // guesses per query in `windows`
    guarded: u32,      // 1: the compacted and uncompacted steps are all dispatched, and each
                       // runs only when the survivors fit (compacted) or overflow (uncompacted)
    canvas_w: u32,     // patch_pass.wgsl: the canvas kept on the GPU
    canvas_h: u32,
    k16_lo: u32,       // patch_pass.wgsl: the occurrence weight λ·C·v̄ in 16.16 (u64 halves)
    k16_hi: u32,
    cap: u32,          // patch_pass.wgsl: the penalty's cap per known texel
    fronts: u32,       // patch_pass.wgsl: wavefronts in `plan`
    sim_at: u32,       // k-coherence (coherence.rs): where the similarity table starts in `ex`
    sim_k: u32,        // its positions per position
    n_random: u32,     // random candidates per query
    n_cand: u32,       // candidates per query (0: every position, the exhaustive search)
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<uniform> p: Params;
// Exemplar codes, one value per word, texels row-major, channels interleaved; then, for the
// k-coherence search, the similarity table (`sim_k` positions per position, from `sim_at`).
@group(0) @binding(1) var<storage, read> ex: array<u32>;
// Per channel, sums of codes over (w/2)² blocks at every position.
@group(0) @binding(2) var<storage, read> sums: array<f32>;
// The plane the query windows are read from, one code per word, channels interleaved;
// 256 marks a texel that is not known.
@group(0) @binding(3) var<storage, read_write> source: array<u32>;
// Per candidate: occurrence penalty per known texel (when has_penalty).
@group(0) @binding(4) var<storage, read_write> penalty: array<u32>;
// Per query (canvas windows): origin x, y, salt, then `max_guesses` starting positions, NONE
// after the last.
@group(0) @binding(5) var<storage, read_write> windows: array<u32>;
// Per query: known texels, salt, quadrant mask (bit q: quadrant q fully known), the guesses'
// cost, the window's origin x and y in `source`, flags (1: not searched this time), then 4·C
// quadrant sums (f32 bits).
@group(0) @binding(6) var<storage, read_write> info: array<u32>;
// Per query: [d* (starts at the guesses' cost), least key]; after `finish`, [cost, position].
@group(0) @binding(7) var<storage, read_write> result: array<atomic<u32>>;
// Per query: the limit T of the choice (written by `settle`).
@group(0) @binding(8) var<storage, read_write> limits: array<u32>;
// Compacted search: (query, position) of the candidates that pass the bound, and their costs.
// `result[2·n_queries]` counts them; `p.capacity` is the room.
@group(0) @binding(9) var<storage, read_write> survivors: array<vec2<u32>>;
@group(0) @binding(10) var<storage, read_write> costs: array<u32>;

const INFO_ORIGIN: u32 = 4u;
const INFO_FLAGS: u32 = 6u;
const INFO_SUMS: u32 = 7u;

// Whether query q is searched in this dispatch (patch_pass.wgsl leaves settled ones out).
fn searched(q: u32) -> bool {
    return info[q * p.info_stride + INFO_FLAGS] == 0u;
}

// Whether more candidates passed the screen than `survivors` has room for.
fn overflowed() -> bool {
    return atomicLoad(&result[2u * p.n_queries]) > p.capacity;
}

fn pick_key(salt: u32, index: u32) -> u32 {
    var x = index + salt;
    x = x ^ (x >> 16u);
    x = x * 0x7feb352du;
    x = x ^ (x >> 15u);
    x = x * 0x846ca68bu;
    x = x ^ (x >> 16u);
    return x;
}

// T = d + ⌊d·ε₁₆/2¹⁶⌋, saturating, in 32-bit products only.
fn tolerance_limit(d: u32) -> u32 {
    let e = min(p.tol, 65536u);
    let hi = (d >> 16u) * e;
    let lo = ((d & 0xffffu) * e) >> 16u;
    var t = d + hi;
    if (t < d) { return 0xffffffffu; }
    let t2 = t + lo;
    if (t2 < t) { return 0xffffffffu; }
    return t2;
}

// Whether the block-sum bound of candidate (x, y) exceeds `limit` (then it cannot qualify).
fn bound_exceeds(q: u32, x: u32, y: u32, limit: u32) -> bool {
    let base = q * p.info_stride;
    let mask = info[base + 2u];
    let half = p.w / 2u;
    var bound = 0.0;
    for (var quad = 0u; quad < 4u; quad++) {
        if ((mask & (1u << quad)) == 0u) { continue; }
        let ox = (quad & 1u) * half;
        let oy = (quad >> 1u) * half;
        let at = (y + oy) * p.plane_w + x + ox;
        for (var k = 0u; k < p.channels; k++) {
            let d = sums[k * p.plane_len + at] - bitcast<f32>(info[base + INFO_SUMS + quad * p.channels + k]);
            bound += d * d;
        }
    }
    // The CPU's margin (search.rs, bound_limit): covers f32 rounding of the sum of squares.
    let area = f32(half * half);
    return bound > f32(limit) * area * (1.0 + 1.0 / 256.0) + 1.0;
}

// Index in `source` of the first code of window texel (dx, dy) at origin (ox, oy), wrapping
// at the plane's edges (a stacked upload never reaches them).
fn source_at(ox: u32, oy: u32, dx: u32, dy: u32) -> u32 {
    var x = ox + dx;
    if (x >= p.src_width) { x -= p.src_width; }
    var y = oy + dy;
    if (y >= p.src_height) { y -= p.src_height; }
    return (y * p.src_width + x) * p.channels;
}

// The exact distance, or any value above `limit` once the partial sum passes it.
fn distance(q: u32, x: u32, y: u32, limit: u32) -> u32 {
    let base = q * p.info_stride;
    let ox = info[base + INFO_ORIGIN];
    let oy = info[base + INFO_ORIGIN + 1u];
    let row_len = p.w * p.channels;
    // Rows that do not cross the plane's right edge are contiguous in `source`.
    let straight = ox + p.w <= p.src_width;
    var total = 0u;
    for (var r = 0u; r < p.w; r++) {
        let e0 = ((y + r) * p.ex_width + x) * p.channels;
        if (straight) {
            let s0 = source_at(ox, oy, 0u, r);
            for (var i = 0u; i < row_len; i++) {
                let qv = source[s0 + i];
                if (qv < 256u) {
                    let d = i32(ex[e0 + i]) - i32(qv);
                    total += u32(d * d);
                }
            }
        } else {
            for (var dx = 0u; dx < p.w; dx++) {
                let s0 = source_at(ox, oy, dx, r);
                let e1 = e0 + dx * p.channels;
                for (var k = 0u; k < p.channels; k++) {
                    let qv = source[s0 + k];
                    if (qv < 256u) {
                        let d = i32(ex[e1 + k]) - i32(qv);
                        total += u32(d * d);
                    }
                }
            }
        }
        if (total > limit) { return total; }
    }
    return total;
}

fn candidate_penalty(q: u32, index: u32) -> u32 {
    if (p.has_penalty == 0u) { return 0u; }
    return penalty[index] * info[q * p.info_stride];
}

const NONE: u32 = 0xffffffffu;

// The cost of candidate `index` for query q when it is at most `limit`, else NONE.
fn cost_within(q: u32, index: u32, limit: u32) -> u32 {
    let pen = candidate_penalty(q, index);
    if (pen > limit) { return NONE; }
    let x = index % p.cand_w;
    let y = index / p.cand_w;
    if (bound_exceeds(q, x, y, limit - pen)) { return NONE; }
    let d = distance(q, x, y, limit - pen);
    if (d > limit - pen) { return NONE; }
    return d + pen;
}

// The searches' threads: (query, j) → the position searched, or NONE. Exhaustive (n_cand 0):
// position j. k-coherence (coherence.rs, Coherence::candidates): the query's guesses (clamped
// to the positions; NONE slots skipped), each guess's `sim_k` similar positions, then
// `n_random` random ones; repeats are harmless (same position, same cost, same key).
fn position_of(q: u32, j: u32) -> u32 {
    let positions = p.cand_w * p.cand_h;
    if (p.n_cand == 0u) {
        if (j >= positions) { return NONE; }
        return j;
    }
    if (j >= p.n_cand) { return NONE; }
    let row = q * window_stride() + 3u;
    if (j < p.max_guesses) {
        let g = windows[row + j];
        if (g == NONE) { return NONE; }
        return min(g, positions - 1u);
    }
    let s = j - p.max_guesses;
    if (s < p.max_guesses * p.sim_k) {
        let g = windows[row + s / p.sim_k];
        if (g == NONE) { return NONE; }
        return ex[p.sim_at + min(g, positions - 1u) * p.sim_k + s % p.sim_k];
    }
    let r = s - p.max_guesses * p.sim_k;
    return pick_key(info[q * p.info_stride + 1u] ^ 0x5bd1e995u, r) % positions;
}

@compute @workgroup_size(64)
fn min_cost(@builtin(global_invocation_id) gid: vec3<u32>) {
    let q = gid.y;
    if (q >= p.n_queries || !searched(q)) { return; }
    let index = position_of(q, gid.x);
    if (index == NONE) { return; }
    if (p.guarded == 1u && !overflowed()) { return; }
    let c = cost_within(q, index, info[q * p.info_stride + 3u]);
    if (c != NONE) {
        atomicMin(&result[2u * q], c);
    }
}

@compute @workgroup_size(64)
fn settle(@builtin(global_invocation_id) gid: vec3<u32>) {
    let q = gid.x;
    if (q >= p.n_queries) { return; }
    limits[q] = tolerance_limit(atomicLoad(&result[2u * q]));
}

@compute @workgroup_size(64)
fn pick(@builtin(global_invocation_id) gid: vec3<u32>) {
    let q = gid.y;
    if (q >= p.n_queries || !searched(q)) { return; }
    let index = position_of(q, gid.x);
    if (index == NONE) { return; }
    if (p.guarded == 1u && !overflowed()) { return; }
    if (cost_within(q, index, limits[q]) != NONE) {
        atomicMin(&result[2u * q + 1u], pick_key(info[q * p.info_stride + 1u], index));
    }
}

// The compacted search, which keeps whole warps busy with exact distances instead of leaving
// most lanes idle behind one survivor: `screen` keeps the candidates whose bound passes the
// largest limit the answer can have (T of the guesses' cost, ≥ T of d*), `cost` computes their
// exact costs and reduces d*, `settle` gives T, `choose` reduces the least key among cost ≤ T.
// When more candidates pass than there is room for, the host reruns the batch with
// `min_cost`/`pick` above (same answer).

// Survivors of one workgroup, gathered in workgroup memory so the global counter takes one
// atomicAdd per workgroup instead of one per survivor.
var<workgroup> wg_count: atomic<u32>;
var<workgroup> wg_base: u32;

@compute @workgroup_size(64)
fn screen(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    if (lid == 0u) { atomicStore(&wg_count, 0u); }
    workgroupBarrier();
    let q = gid.y;
    var index = NONE;
    if (q < p.n_queries) { index = position_of(q, gid.x); }
    var passes = false;
    var local = 0u;
    if (q < p.n_queries && index != NONE && searched(q)) {
        let upper = tolerance_limit(info[q * p.info_stride + 3u]);
        let pen = candidate_penalty(q, index);
        if (pen <= upper && !bound_exceeds(q, index % p.cand_w, index / p.cand_w, upper - pen)) {
            passes = true;
            local = atomicAdd(&wg_count, 1u);
        }
    }
    workgroupBarrier();
    if (lid == 0u) {
        let n = atomicLoad(&wg_count);
        if (n > 0u) { wg_base = atomicAdd(&result[2u * p.n_queries], n); }
    }
    workgroupBarrier();
    if (passes) {
        let slot = wg_base + local;
        if (slot < p.capacity) {
            survivors[slot] = vec2<u32>(q, index);
        }
    }
}

// The thread's index in a two-dimensional grid of workgroups (derma_core::gpu::grid).
fn thread_of(gid: vec3<u32>) -> u32 {
    return gid.x + gid.y * 65535u * 64u;
}

@compute @workgroup_size(64)
fn cost(@builtin(global_invocation_id) gid: vec3<u32>) {
    let slot = thread_of(gid);
    if (p.guarded == 1u && overflowed()) { return; }
    let count = min(atomicLoad(&result[2u * p.n_queries]), p.capacity);
    if (slot >= count) { return; }
    let s = survivors[slot];
    let c = cost_within(s.x, s.y, tolerance_limit(info[s.x * p.info_stride + 3u]));
    costs[slot] = c;
    if (c != NONE) {
        atomicMin(&result[2u * s.x], c);
    }
}

@compute @workgroup_size(64)
fn choose(@builtin(global_invocation_id) gid: vec3<u32>) {
    let slot = thread_of(gid);
    if (p.guarded == 1u && overflowed()) { return; }
    let count = min(atomicLoad(&result[2u * p.n_queries]), p.capacity);
    if (slot >= count) { return; }
    let s = survivors[slot];
    if (costs[slot] <= limits[s.x]) {
        atomicMin(&result[2u * s.x + 1u], pick_key(info[s.x * p.info_stride + 1u], s.y));
    }
}

// The index whose key is `key` (search.rs, index_of_key): the steps of pick_key undone.
fn unshift(key: u32, s: u32) -> u32 {
    var x = key;
    var y = key;
    for (var k = s; k < 32u; k += s) {
        x = x >> s;
        y = y ^ x;
    }
    return y;
}

// Multiplicative inverse of an odd number modulo 2³² (Newton's iteration).
fn inverse_mod_2_32(a: u32) -> u32 {
    var x = a;
    for (var i = 0u; i < 5u; i++) {
        x = x * (2u - a * x);
    }
    return x;
}

fn index_of_key(salt: u32, key: u32) -> u32 {
    var x = unshift(key, 16u);
    x = x * inverse_mod_2_32(0x846ca68bu);
    x = unshift(x, 15u);
    x = x * inverse_mod_2_32(0x7feb352du);
    x = unshift(x, 16u);
    return x - salt;
}

// Query q's quadrant sums and the mask of its fully known quadrants (bit q), read from
// `source` at its origin; a quadrant with an unknown texel (256) is left out with sums 0, as
// search.rs's known_block_sums does.
fn quadrant_sums(q: u32) {
    let base = q * p.info_stride;
    let ox = info[base + INFO_ORIGIN];
    let oy = info[base + INFO_ORIGIN + 1u];
    let half = p.w / 2u;
    var mask = 0u;
    for (var quad = 0u; quad < 4u; quad++) {
        let qx = (quad & 1u) * half;
        let qy = (quad >> 1u) * half;
        var full = true;
        for (var k = 0u; k < p.channels; k++) {
            // An integer sum (at most 255·(w/2)², exact in f32, as on the CPU).
            var sum = 0u;
            for (var dy = 0u; dy < half; dy++) {
                for (var dx = 0u; dx < half; dx++) {
                    let v = source[source_at(ox, oy, qx + dx, qy + dy) + k];
                    if (v == 256u) { full = false; } else { sum += v; }
                }
            }
            info[base + INFO_SUMS + quad * p.channels + k] = bitcast<u32>(f32(sum));
        }
        if (full) {
            mask |= 1u << quad;
        } else {
            for (var k = 0u; k < p.channels; k++) { info[base + INFO_SUMS + quad * p.channels + k] = 0u; }
        }
    }
    info[base + 2u] = mask;
}

// Words per query in `windows`: origin x, y, salt, then the guesses.
fn window_stride() -> u32 {
    return 3u + p.max_guesses;
}

// The least cost among query q's guesses in `windows` (NONE after the last), clamped to the
// candidate range: an upper bound of d* (search.rs, initial_cost).
fn guesses_cost(q: u32) -> u32 {
    let at = q * window_stride() + 3u;
    let last = p.cand_w * p.cand_h - 1u;
    var first = NONE;
    for (var j = 0u; j < p.max_guesses; j++) {
        let g0 = windows[at + j];
        if (g0 == NONE) { continue; }
        let g = min(g0, last);
        first = min(first, distance(q, g % p.cand_w, g / p.cand_w, NONE) + candidate_penalty(q, g));
    }
    return first;
}

// Canvas windows: the quadrant sums (every texel is known) and the least cost among the
// guesses, clamped to the candidate range, as search.rs computes them for an uploaded query.
@compute @workgroup_size(64)
fn prepare(@builtin(global_invocation_id) gid: vec3<u32>) {
    let q = thread_of(gid);
    if (q >= p.n_queries) { return; }
    let base = q * p.info_stride;
    let ws = q * window_stride();
    let ox = windows[ws];
    let oy = windows[ws + 1u];
    info[base] = p.w * p.w;
    info[base + 1u] = windows[ws + 2u];
    info[base + INFO_ORIGIN] = ox;
    info[base + INFO_ORIGIN + 1u] = oy;
    info[base + INFO_FLAGS] = 0u;
    quadrant_sums(q);
    let first = guesses_cost(q);
    info[base + 3u] = first;
    atomicStore(&result[2u * q], first);
    atomicStore(&result[2u * q + 1u], NONE);
}

// Each answer's key back to its position, and the position's cost: [cost, position]; a
// position outside the candidates (which the search cannot give) is returned as it is, for
// the host to report.
@compute @workgroup_size(64)
fn finish(@builtin(global_invocation_id) gid: vec3<u32>) {
    let q = thread_of(gid);
    if (q >= p.n_queries || !searched(q)) { return; }
    let index = index_of_key(info[q * p.info_stride + 1u], atomicLoad(&result[2u * q + 1u]));
    var c = NONE;
    if (index < p.cand_w * p.cand_h) {
        c = distance(q, index % p.cand_w, index / p.cand_w, NONE) + candidate_penalty(q, index);
    }
    atomicStore(&result[2u * q], c);
    atomicStore(&result[2u * q + 1u], index);
}
