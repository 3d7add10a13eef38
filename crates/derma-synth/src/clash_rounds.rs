//! The clash rounds of the patch pass: no exemplar window twice among a wavefront's recent
//! windows (a rule of derma's on Shen et al. §3.2's patch order, patch_pass.rs), round by round.
//!
//! The first round searches all of a wavefront's patches at once; in scanline order each match
//! is accepted unless it lies within half a patch (each way) of a window accepted earlier in
//! the wavefront and still in force. The clashing patches are searched again with the windows
//! in force barred, but each later round searches only the first [`LATER_ROUND_PATCHES`] still
//! pending: searching them all again, most would pick the same new window and clash again, and
//! the rounds cost the square of the wavefront's length. A round's first patch is always
//! accepted, so the rounds end. Every accepted window is in force until the exemplar has no
//! candidate left that none bars; then the oldest drop out until one is free
//! (`patch_pass.rs`, `penalties_excluding`): a small exemplar has room for only so many windows
//! apart, and the patches accepted longest ago lie farthest along the wavefront. The GPU's
//! `penalty_table`, `bar`, `live`, `prepare_round` and `accept` (patch_pass.wgsl) follow the
//! same rules.

/// An exemplar window: (exemplar, x, y) of its top-left texel.
pub(crate) type Window = (u32, usize, usize);

/// Patches searched in each round after the first (the GPU's copy, patch_pass.wgsl's
/// LATER_ROUND_PATCHES, is checked against it by a test): measured against 1, 2 and all in
/// BENCHMARKS.md, "Synthesis grows linearly". A round's searches run side by side, and at most
/// three are lost when they clash with its first.
pub(crate) const LATER_ROUND_PATCHES: usize = 4;

/// The state of one wavefront's rounds.
pub(crate) struct ClashRounds {
    /// The patches not yet accepted, in scanline order.
    pending: Vec<usize>,
    accepted: Vec<Window>,
    rounds: usize,
    /// Whether the next offer is the round's first.
    first: bool,
}

impl ClashRounds {
    /// The rounds of a wavefront of `patches` patches (indices 0..patches in scanline order).
    pub(crate) fn new(patches: usize) -> Self {
        Self {
            pending: (0..patches).collect(),
            accepted: Vec::new(),
            rounds: 0,
            first: true,
        }
    }

    /// Starts the next round: the patches to search in it, in scanline order (each to be
    /// [`Self::offer`]ed its match, in that order); `None` when every patch is accepted.
    pub(crate) fn next_live(&mut self) -> Option<Vec<usize>> {
        if self.pending.is_empty() {
            return None;
        }
        let live = if self.rounds == 0 {
            self.pending.len()
        } else {
            LATER_ROUND_PATCHES.min(self.pending.len())
        };
        self.rounds += 1;
        self.first = true;
        Some(self.pending[..live].to_vec())
    }

    /// The windows accepted so far in the wavefront, to bar in the next round's searches.
    pub(crate) fn accepted(&self) -> &[Window] {
        &self.accepted
    }

    /// Offers patch `k`'s match `w`; whether it is accepted (else `k` stays pending). `from`:
    /// the first accepted window still in force for `w`'s exemplar at the round's start (see
    /// `patch_pass.rs`, `penalties_excluding`); `d`: half the patch side.
    pub(crate) fn offer(&mut self, k: usize, w: Window, d: usize, from: usize) -> bool {
        let clash = !self.first
            && self.accepted[from.min(self.accepted.len())..]
                .iter()
                .any(|&(e, ax, ay)| e == w.0 && ax.abs_diff(w.1) < d && ay.abs_diff(w.2) < d);
        self.first = false;
        if clash {
            return false;
        }
        self.accepted.push(w);
        self.pending.retain(|&p| p != k);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Plays a wavefront whose patches all want the free window with the least x, windows
    /// `d` apart along x (one row), in an exemplar with room for `room` of them: past that the
    /// oldest windows are dropped from force (as `penalties_excluding` does), and the search
    /// finds the one the oldest in force leaves free. Every round's searches, in order.
    fn play(patches: usize, room: usize) -> (Vec<Vec<usize>>, Vec<Window>) {
        let d = 4;
        let mut r = ClashRounds::new(patches);
        let mut log = Vec::new();
        while let Some(live) = r.next_live() {
            let taken = r.accepted().len();
            let from = taken.saturating_sub(room - 1);
            // The free slot: after `room` windows, the one the oldest in force vacated.
            let x = if taken < room {
                taken * d
            } else {
                r.accepted()[from - 1].1
            };
            log.push(live.clone());
            for k in live {
                r.offer(k, (0, x, 0), d, from);
            }
        }
        (log, r.accepted.clone())
    }

    #[test]
    fn later_rounds_search_only_the_first_pending_patches() {
        let b = LATER_ROUND_PATCHES;
        let (log, accepted) = play(6, usize::MAX);
        // Round 1 searches all six; all match window 0, so the first is accepted. Then the
        // first b pending a round: the first of each is accepted, the others clash with it.
        assert_eq!(log[0], vec![0, 1, 2, 3, 4, 5]);
        for (r, live) in log.iter().enumerate().skip(1) {
            assert_eq!(live, &(r..(r + b).min(6)).collect::<Vec<_>>(), "round {r}");
        }
        assert_eq!(log.len(), 6);
        // No window twice: each accepted one is d apart from the others.
        let xs: Vec<usize> = accepted.iter().map(|w| w.1).collect();
        assert_eq!(xs, vec![0, 4, 8, 12, 16, 20]);
        // The cost is linear: at most b searches per patch after the first round's (searching
        // every pending patch each round would take 6 + 5 + 4 + 3 + 2 + 1).
        let searches: usize = log.iter().map(Vec::len).sum();
        assert!(searches <= 6 + b * 5 && searches < 21, "{searches}");
    }

    #[test]
    fn past_the_exemplar_s_room_the_oldest_windows_come_round_again() {
        // Room for three windows apart: the fourth patch reuses the first window, the fifth
        // the second, and no window repeats among any three in a row.
        let (_, accepted) = play(7, 3);
        let xs: Vec<usize> = accepted.iter().map(|w| w.1).collect();
        assert_eq!(xs, vec![0, 4, 8, 0, 4, 8, 0]);
        // Only windows in force clash.
        let offer_third = |x: usize, from: usize| {
            let mut r = ClashRounds::new(3);
            r.next_live();
            assert!(r.offer(0, (0, 0, 0), 4, 0));
            assert!(r.offer(1, (0, 8, 0), 4, 0));
            r.offer(2, (0, x, 0), 4, from)
        };
        assert!(!offer_third(1, 0), "near window 0, in force");
        assert!(offer_third(1, 1), "near window 0, out of force");
        assert!(!offer_third(9, 1), "near window 1, in force");
    }

    #[test]
    fn the_gpu_rounds_follow_the_same_constants() {
        let wgsl = include_str!("patch_pass.wgsl");
        let want = format!("const LATER_ROUND_PATCHES: u32 = {LATER_ROUND_PATCHES}u;");
        assert!(wgsl.contains(&want), "patch_pass.wgsl lacks `{want}`");
    }

    #[test]
    fn a_match_apart_from_every_accepted_window_is_accepted_in_the_first_round() {
        let mut r = ClashRounds::new(3);
        assert_eq!(r.next_live(), Some(vec![0, 1, 2]));
        assert!(r.offer(0, (0, 0, 0), 8, 0));
        // 8 apart along x: no clash (within d means closer than d).
        assert!(r.offer(1, (0, 8, 0), 8, 0));
        // Another exemplar's window never clashes.
        assert!(r.offer(2, (1, 0, 0), 8, 0));
        assert_eq!(r.next_live(), None);
    }
}
