//! The clash rounds of the patch pass: no exemplar window twice in one wavefront (a rule of
//! derma's on Shen et al. §3.2's patch order, patch_pass.rs), decided round by round.
//!
//! The first round searches all of a wavefront's patches at once; in scanline order each match
//! is accepted unless it lies within half a patch (each way) of a window accepted earlier in
//! the wavefront. The clashing patches are searched again with those windows barred, but each
//! later round searches only the first [`LATER_ROUND_PATCHES`] still pending: searching them
//! all again, most would pick the same new window and clash again, and the rounds cost the
//! square of the wavefront's length (a 2048² output from a 128² exemplar took ten times as long
//! as four 1024² ones). A round's first patch is always accepted, and a match is accepted
//! whatever it overlaps once the accepted windows bar every candidate of its exemplar — a
//! search again could not avoid them. The GPU's `accept` and `prepare_round`
//! (patch_pass.wgsl) follow the same rules.

/// An exemplar window: (exemplar, x, y) of its top-left texel.
pub(crate) type Window = (u32, usize, usize);

/// Patches searched in each round after the first. Of 1, 2, 4 and all, four gave the fastest
/// patch pass from the 128² bench crops at 1024² and 2048², with patch SWD within 0.0001 of the
/// best (BENCHMARKS.md, "Synthesis grows linearly"): a round's searches run side by side, and
/// at most three are lost when they clash with its first.
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

    /// Offers patch `k`'s match `w`; whether it is accepted (else `k` stays pending). `open`:
    /// whether the windows accepted before the round left any candidate of `w`'s exemplar
    /// unbarred; `d`: half the patch side.
    pub(crate) fn offer(&mut self, k: usize, w: Window, d: usize, open: bool) -> bool {
        let clash = !self.first
            && open
            && self
                .accepted
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

    /// Plays a wavefront whose patches all want window (0, 0, 0) until barred, then the next
    /// free one along x, `d` apart: every round's searches, in order.
    fn play(patches: usize, open_after: usize) -> (Vec<Vec<usize>>, Vec<Window>) {
        let d = 4;
        let mut r = ClashRounds::new(patches);
        let mut log = Vec::new();
        while let Some(live) = r.next_live() {
            let taken = r.accepted().len();
            log.push(live.clone());
            for k in live {
                // A search barred from the accepted windows finds the next one along x.
                let open = taken < open_after;
                let x = if open { taken * d } else { 0 };
                r.offer(k, (0, x, 0), d, open);
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
    fn once_every_candidate_is_barred_clashes_are_accepted() {
        // After two windows the exemplar has no candidate left unbarred: from the round that
        // sees that, every live patch is accepted, clash or not.
        let b = LATER_ROUND_PATCHES;
        let (log, accepted) = play(6, 2);
        assert_eq!(log[0], vec![0, 1, 2, 3, 4, 5]);
        assert_eq!(log[1], (1..(1 + b).min(6)).collect::<Vec<_>>());
        // Rounds 3 on take the four left, b at a time, all accepted.
        assert_eq!(log.len(), 2 + 4usize.div_ceil(b));
        assert_eq!(log[2][0], 2);
        assert_eq!(accepted.len(), 6);
        assert_eq!(accepted.iter().filter(|w| w.1 == 0).count(), 5);
    }

    #[test]
    fn a_match_apart_from_every_accepted_window_is_accepted_in_the_first_round() {
        let mut r = ClashRounds::new(3);
        assert_eq!(r.next_live(), Some(vec![0, 1, 2]));
        assert!(r.offer(0, (0, 0, 0), 8, true));
        // 8 apart along x: no clash (within d means closer than d).
        assert!(r.offer(1, (0, 8, 0), 8, true));
        // Another exemplar's window never clashes.
        assert!(r.offer(2, (1, 0, 0), 8, true));
        assert_eq!(r.next_live(), None);
    }
}
