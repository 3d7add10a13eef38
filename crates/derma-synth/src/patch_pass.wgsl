// The patch pass of derma-synth kept on the GPU (patch_pass.rs: Shen et al. §3.2 in wavefronts,
// with the occurrence penalty after Kaspar et al. 2015 §4.2 and the clash rounds), appended to
// search.wgsl, whose search it runs. Several wavefronts per submission: `advance` starts the
// next one when the last has settled (else it stops the submission's remaining work, and the
// host adds rounds), `gather` reads its patches' windows, masks and coherent guesses from the
// canvas kept here; then each round builds the
// penalties from the occurrence counts (`penalty_rows`, `penalty_table`, `bar`), searches the
// patches live in it (`prepare_round`, then search.wgsl's steps), accepts in scanline order those
// that do not clash with a window accepted earlier in the wavefront (`accept`, one thread) and
// pastes them, updating the counts (`paste`). The rounds follow clash_rounds.rs: the first
// searches every patch, each later one the first LATER_ROUND_PATCHES pending. The same integers
// as the CPU decide every step.

// The canvas: codes (one per word, channels interleaved) and sources (exemplar texel, NONE
// where none); one exemplar.
@group(0) @binding(11) var<storage, read_write> canvas: array<u32>;
@group(0) @binding(12) var<storage, read_write> canvas_src: array<u32>;
// Per exemplar texel: output texels drawn from it.
@group(0) @binding(13) var<storage, read_write> counts: array<atomic<u32>>;
// [total drawn, pending patches, windows accepted in the wavefront, the wavefront, stalled
// (1: a wavefront did not settle in its rounds, so nothing more runs), its patches, whether they
// overlap, its rounds so far, the most rounds any wavefront took, the first accepted window in
// force in the round (patch_pass.rs, `penalties_excluding`), the first candidate no window in
// force bars (NONE: none), then per patch its status (PENDING, PASTE, DONE), then the accepted
// windows' (x, y)].
@group(0) @binding(14) var<storage, read_write> state: array<atomic<u32>>;
// Per exemplar row and candidate column: counts summed over a row of n texels.
@group(0) @binding(15) var<storage, read_write> row_sums: array<u32>;
// Per wavefront (first patch, patches, overlap), then per patch (x, y, salt); `p.fronts`
// wavefronts.
@group(0) @binding(16) var<storage, read_write> plan: array<u32>;

const PENDING: u32 = 0u;
const PASTE: u32 = 1u;
const DONE: u32 = 2u;
const STATE_TOTAL: u32 = 0u;
const STATE_PENDING: u32 = 1u;
const STATE_ACCEPTED: u32 = 2u;
const STATE_WAVEFRONT: u32 = 3u;
const STATE_STALLED: u32 = 4u;
const STATE_COUNT: u32 = 5u;
const STATE_OVERLAP: u32 = 6u;
const STATE_ROUNDS: u32 = 7u;
const STATE_MAX_ROUNDS: u32 = 8u;
const STATE_FROM: u32 = 9u;
const STATE_FREE: u32 = 10u;
const STATE_STATUS: u32 = 11u;
// Patches searched in each round after the first (clash_rounds.rs, LATER_ROUND_PATCHES).
const LATER_ROUND_PATCHES: u32 = 4u;

fn stalled() -> bool {
    return atomicLoad(&state[STATE_STALLED]) != 0u;
}

// The next wavefront, if the last one settled: its patches go into `windows` (with `gather`),
// all pending. Otherwise nothing more runs in this submission.
@compute @workgroup_size(1)
fn advance() {
    if (stalled()) { return; }
    if (atomicLoad(&state[STATE_PENDING]) != 0u) {
        atomicStore(&state[STATE_STALLED], 1u);
        return;
    }
    let w = atomicLoad(&state[STATE_WAVEFRONT]) + 1u;
    if (w >= p.fronts) { return; }
    let count = plan[3u * w + 1u];
    atomicStore(&state[STATE_WAVEFRONT], w);
    atomicStore(&state[STATE_COUNT], count);
    atomicStore(&state[STATE_OVERLAP], plan[3u * w + 2u]);
    atomicStore(&state[STATE_PENDING], count);
    atomicStore(&state[STATE_ACCEPTED], 0u);
    atomicStore(&state[STATE_ROUNDS], 0u);
    for (var q = 0u; q < p.n_queries; q++) {
        atomicStore(&state[STATE_STATUS + q], select(DONE, PENDING, q < count));
    }
}

fn accepted_at(i: u32) -> u32 {
    return STATE_STATUS + p.n_queries + 2u * i;
}

// Canvas texel (x + dx, y + dy), wrapping on a torus (a plane's patches never reach its edge).
fn canvas_at(x: u32, y: u32, dx: u32, dy: u32) -> u32 {
    return ((y + dy) % p.canvas_h) * p.canvas_w + (x + dx) % p.canvas_w;
}

// Patch q's window: its codes stacked in `source` (256 where not yet synthesised, unless none
// or all are: patch_pass.rs, known_mask), its info and its coherent guesses (Canvas::
// coherent_guess with the probes (0, 0), (0, d), (d, 0), (n − 1, 0)).
@compute @workgroup_size(64)
fn gather(@builtin(global_invocation_id) gid: vec3<u32>) {
    let q = thread_of(gid);
    if (stalled() || q >= atomicLoad(&state[STATE_COUNT])) { return; }
    let n = p.w;
    let c = p.channels;
    let ws = q * window_stride();
    let w = atomicLoad(&state[STATE_WAVEFRONT]);
    let at = 3u * p.fronts + 3u * (plan[3u * w] + q);
    let px = plan[at];
    let py = plan[at + 1u];
    windows[ws] = px;
    windows[ws + 1u] = py;
    windows[ws + 2u] = plan[at + 2u];
    var known = 0u;
    for (var t = 0u; t < n * n; t++) {
        if (canvas_src[canvas_at(px, py, t % n, t / n)] != NONE) { known++; }
    }
    let masked = known != 0u && known != n * n;
    var mask_known = 0u;
    for (var t = 0u; t < n * n; t++) {
        let ct = canvas_at(px, py, t % n, t / n);
        let is_known = !masked || canvas_src[ct] != NONE;
        for (var k = 0u; k < c; k++) {
            var v = 256u;
            if (is_known) { v = canvas[ct * c + k]; }
            source[(q * n * n + t) * c + k] = v;
        }
        if (is_known) { mask_known++; }
    }
    let base = q * p.info_stride;
    info[base] = mask_known;
    info[base + 1u] = windows[ws + 2u];
    info[base + INFO_ORIGIN] = 0u;
    info[base + INFO_ORIGIN + 1u] = q * n;
    info[base + INFO_FLAGS] = 0u;
    quadrant_sums(q);
    // Coherent guesses, without repeats; [0] when no probe has a source.
    let d = n / 2u;
    var probes = array<vec2<u32>, 4>(vec2<u32>(0u, 0u), vec2<u32>(0u, d), vec2<u32>(d, 0u), vec2<u32>(n - 1u, 0u));
    var count = 0u;
    for (var j = 0u; j < 4u; j++) {
        let pr = probes[j];
        let s = canvas_src[canvas_at(px, py, pr.x, pr.y)];
        if (s == NONE) { continue; }
        count = add_guess(ws + 3u, count, continuation(s, pr, p.ex_width, p.cand_w, p.cand_h));
    }
    close_guesses(ws + 3u, count, p.max_guesses);
}

fn nothing_pending() -> bool {
    return stalled() || atomicLoad(&state[STATE_PENDING]) == 0u;
}

// Counts summed over n texels along each exemplar row, at every candidate column.
@compute @workgroup_size(64)
fn penalty_rows(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = thread_of(gid);
    let ex_h = p.cand_h + p.w - 1u;
    if (i >= p.cand_w * ex_h || nothing_pending()) { return; }
    // The first window in force is the least over the candidates (`penalty_table`, which this
    // dispatch precedes).
    if (i == 0u) {
        atomicStore(&state[STATE_FROM], 0xffffffffu);
        atomicStore(&state[STATE_FREE], NONE);
    }
    let x = i % p.cand_w;
    let y = i / p.cand_w;
    var sum = 0u;
    for (var dx = 0u; dx < p.w; dx++) {
        sum += atomicLoad(&counts[y * p.ex_width + x + dx]);
    }
    row_sums[i] = sum;
}

// The penalty per known texel of each candidate (patch_pass.rs, `penalty`): the window's count
// o against the mean use, in 64-bit integers; and the first window in force, the least over
// the candidates of one past the last accepted window that bars each.
@compute @workgroup_size(64)
fn penalty_table(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = thread_of(gid);
    if (i >= p.cand_w * p.cand_h || nothing_pending()) { return; }
    let x = i % p.cand_w;
    let y = i / p.cand_w;
    let total = atomicLoad(&state[STATE_TOTAL]);
    var pen = 0u;
    if (total > 0u) {
        var o = 0u;
        for (var dy = 0u; dy < p.w; dy++) { o += row_sums[(y + dy) * p.cand_w + x]; }
        let texels = u64(p.ex_width) * u64(p.cand_h + p.w - 1u);
        let a = u64(o) * texels;
        let dd = u64(p.w * p.w) * u64(total);
        let ratio = ((a / dd) << 16u) + (((a % dd) << 16u) / dd);
        let one = 65536lu;
        let k16 = (u64(p.k16_hi) << 32u) | u64(p.k16_lo);
        if (ratio > one && k16 > 0lu) {
            let excess = ratio - one;
            // Saturating product: beyond 2⁶⁴ the penalty is past any cap.
            if (excess > 0xfffffffffffffffflu / k16) {
                pen = p.cap;
            } else {
                pen = u32(min((excess * k16) >> 32u, u64(p.cap)));
            }
        }
    }
    atomicMin(&state[STATE_FROM], last_barring(x, y));
    penalty[i] = pen;
}

// One past the last window accepted in the wavefront within half a patch (each way) of
// candidate (x, y); 0 where none is.
fn last_barring(x: u32, y: u32) -> u32 {
    let d = p.w / 2u;
    let accepted = atomicLoad(&state[STATE_ACCEPTED]);
    var last = 0u;
    for (var a = 0u; a < accepted; a++) {
        let ax = atomicLoad(&state[accepted_at(a)]);
        let ay = atomicLoad(&state[accepted_at(a) + 1u]);
        if (max(ax, x) - min(ax, x) < d && max(ay, y) - min(ay, y) < d) { last = a + 1u; }
    }
    return last;
}

// Candidates barred by a window in force pay the cap (patch_pass.rs, `penalties_excluding`);
// the first of the others is noted, a guess for the round's searches.
@compute @workgroup_size(64)
fn bar(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = thread_of(gid);
    if (i >= p.cand_w * p.cand_h || nothing_pending()) { return; }
    if (last_barring(i % p.cand_w, i / p.cand_w) > atomicLoad(&state[STATE_FROM])) {
        penalty[i] = p.cap;
    } else {
        atomicMin(&state[STATE_FREE], i);
    }
}

// Whether pending patch q is searched this round: all in the first round, then the first
// LATER_ROUND_PATCHES pending in scanline order.
fn live(q: u32) -> bool {
    if (atomicLoad(&state[STATE_ROUNDS]) == 0u) { return true; }
    var rank = 0u;
    for (var q2 = 0u; q2 < q; q2++) {
        if (atomicLoad(&state[STATE_STATUS + q2]) == PENDING) { rank++; }
    }
    return rank < LATER_ROUND_PATCHES;
}

// A round's start: patches pasted in the last round are done; the pending ones start from the
// least cost among their guesses under this round's penalties.
@compute @workgroup_size(64)
fn prepare_round(@builtin(global_invocation_id) gid: vec3<u32>) {
    let q = thread_of(gid);
    if (q == 0u) { atomicStore(&result[2u * p.n_queries], 0u); }
    if (q >= p.n_queries) { return; }
    let status = atomicLoad(&state[STATE_STATUS + q]);
    if (status == PASTE) { atomicStore(&state[STATE_STATUS + q], DONE); }
    let base = q * p.info_stride;
    if (status != PENDING || stalled() || !live(q)) {
        info[base + INFO_FLAGS] = 1u;
        return;
    }
    info[base + INFO_FLAGS] = 0u;
    // The coherent guesses' least cost, or a free candidate's where that is less: where the
    // guesses are barred, their cost includes the cap and would prune nothing (the answer is
    // the same; patch_pass.rs adds the free candidate to the guesses likewise).
    // The free candidate is the last guess slot (gather leaves it NONE: 4 probes, 5 slots),
    // so the k-coherence search also takes it and its similar positions, as patch_pass.rs does.
    let free = atomicLoad(&state[STATE_FREE]);
    windows[q * window_stride() + 3u + p.max_guesses - 1u] = free;
    let first = guesses_cost(q);
    info[base + 3u] = first;
    atomicStore(&result[2u * q], first);
    atomicStore(&result[2u * q + 1u], NONE);
}

// In scanline order, a patch searched this round is accepted unless its match lies within half
// a patch (each way) of a window accepted earlier in the wavefront and in force (from the
// round's first in force on); the round's first always is.
@compute @workgroup_size(1)
fn accept() {
    if (nothing_pending()) { return; }
    // The rounds this wavefront has taken, and the most any has (the host records that many).
    let rounds = atomicLoad(&state[STATE_ROUNDS]) + 1u;
    let in_force = atomicLoad(&state[STATE_FROM]);
    var searched = 0u;
    atomicStore(&state[STATE_ROUNDS], rounds);
    atomicMax(&state[STATE_MAX_ROUNDS], rounds);
    let d = p.w / 2u;
    var first = true;
    var accepted = atomicLoad(&state[STATE_ACCEPTED]);
    var pending = 0u;
    for (var q = 0u; q < p.n_queries; q++) {
        if (atomicLoad(&state[STATE_STATUS + q]) != PENDING) { continue; }
        // Not searched this round (`live`): still pending.
        if (rounds > 1u && searched >= LATER_ROUND_PATCHES) {
            pending++;
            continue;
        }
        searched++;
        let index = atomicLoad(&result[2u * q + 1u]);
        let mx = index % p.cand_w;
        let my = index / p.cand_w;
        var clash = false;
        if (!first) {
            for (var a = in_force; a < accepted; a++) {
                let ax = atomicLoad(&state[accepted_at(a)]);
                let ay = atomicLoad(&state[accepted_at(a) + 1u]);
                if (max(ax, mx) - min(ax, mx) < d && max(ay, my) - min(ay, my) < d) { clash = true; }
            }
        }
        first = false;
        if (clash) {
            pending++;
            continue;
        }
        atomicStore(&state[accepted_at(accepted)], mx);
        atomicStore(&state[accepted_at(accepted) + 1u], my);
        accepted++;
        atomicStore(&state[STATE_STATUS + q], PASTE);
    }
    atomicStore(&state[STATE_ACCEPTED], accepted);
    atomicStore(&state[STATE_PENDING], pending);
}

// Copies the accepted patches' matches over their windows (one thread per texel), moving each
// texel's count from its old source to its new one.
@compute @workgroup_size(64)
fn paste(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = thread_of(gid);
    let n = p.w;
    let q = i / (n * n);
    if (q >= p.n_queries || stalled()) { return; }
    if (atomicLoad(&state[STATE_STATUS + q]) != PASTE) { return; }
    let t = i % (n * n);
    let ws = q * window_stride();
    let ct = canvas_at(windows[ws], windows[ws + 1u], t % n, t / n);
    // Where patches overlap (a plane's last patch pulled in to its edge, a small torus), the
    // later one in scanline order pastes last on the CPU: so only it writes the texel, and
    // the counts move from the source before the round to its source, as on the CPU.
    if (atomicLoad(&state[STATE_OVERLAP]) == 1u) {
        let cx = ct % p.canvas_w;
        let cy = ct / p.canvas_w;
        for (var q2 = q + 1u; q2 < p.n_queries; q2++) {
            if (atomicLoad(&state[STATE_STATUS + q2]) != PASTE) { continue; }
            let w2 = q2 * window_stride();
            let dx = (cx + p.canvas_w - windows[w2]) % p.canvas_w;
            let dy = (cy + p.canvas_h - windows[w2 + 1u]) % p.canvas_h;
            if (dx < n && dy < n) { return; }
        }
    }
    let index = atomicLoad(&result[2u * q + 1u]);
    let s = (index / p.cand_w + t / n) * p.ex_width + index % p.cand_w + t % n;
    let old = canvas_src[ct];
    if (old == NONE) {
        atomicAdd(&state[STATE_TOTAL], 1u);
    } else {
        atomicSub(&counts[old], 1u);
    }
    atomicAdd(&counts[s], 1u);
    canvas_src[ct] = s;
    for (var k = 0u; k < p.channels; k++) {
        canvas[ct * p.channels + k] = ex[s * p.channels + k];
    }
}
