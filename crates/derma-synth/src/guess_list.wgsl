
// The coherent guesses of a window (Canvas::coherent_guess), shared by guesses.wgsl and
// patch_pass.wgsl (appended to each): a list in `windows` from index `at`, without repeats.

// The candidate that continues source texel s (y · ex_width + x) of the texel at offset d in
// the window: the source moved back by d, clamped to the candidates (cand_w × cand_h).
fn continuation(s: u32, d: vec2<u32>, ex_width: u32, cand_w: u32, cand_h: u32) -> u32 {
    let sx = s % ex_width;
    let sy = s / ex_width;
    let gx = min(select(0u, sx - d.x, sx >= d.x), cand_w - 1u);
    let gy = min(select(0u, sy - d.y, sy >= d.y), cand_h - 1u);
    return gy * cand_w + gx;
}

// Appends guess g to the `count` guesses at `at` unless it is there; the new count.
fn add_guess(at: u32, count: u32, g: u32) -> u32 {
    for (var i = 0u; i < count; i++) {
        if (windows[at + i] == g) { return count; }
    }
    windows[at + count] = g;
    return count + 1u;
}

// Ends the list of `count` guesses at `at` in `room` words: [0] when there is none, NONE after
// the last.
fn close_guesses(at: u32, count: u32, room: u32) {
    var n = count;
    if (n == 0u) {
        windows[at] = 0u;
        n = 1u;
    }
    for (var i = n; i < room; i++) { windows[at + i] = NONE; }
}
