//! The self-adaptive optimisation of Shen et al. §3.3: after a pass, the distribution of its best
//! matches over the exemplar; where it is high, the texture repeats and needs one optimisation.
//!
//! The paper gives the idea, not the rule. Here: the exemplar's match origins are binned into
//! cells of the pass's window side; a window is *settled* when the cell of its best match holds
//! at least `factor` times the mean count of the cells (the high-probability regions), or when it
//! was itself inherited. In the next pass, a window lying wholly inside a settled window of the
//! last one (same exemplar) is not searched: its match is the settled window's, shifted by the
//! window's offset inside it, and its cost the settled cost scaled by the area, (w'/w)² — the
//! texels keep the source they were optimised to, and the E-step blends them as any other.
//! Everything is decided on the host from the matches both backends return, so the CPU and the
//! GPU skip the same windows and stay bit-identical.

use crate::e_step::Windows;
use crate::exemplar::ExemplarSet;
use crate::search::Match;
use std::collections::HashMap;

/// The default factor: 0, the skip off. With the exhaustive search a factor of 2 saved 13–34 %
/// of the time (at 1 the patch grid's seams stayed: seam energy 0.26 against −0.11; at 4 almost
/// nothing was skipped); with the k-coherence search, the default since, the searches it skips
/// cost milliseconds, so it saves nothing, and it raised the seam energy on all six crops
/// measured (to 0.15, 0.20 and 1.67 on three of them, against −0.05, −0.01 and 0.11 without;
/// BENCHMARKS.md, issue 64's second stop).
pub const DEFAULT_FACTOR: f32 = 0.0;

/// The factor measured best with the exhaustive search (`bench/synth_adaptive.sh`).
pub const EXHAUSTIVE_FACTOR: f32 = 2.0;

/// A finished pass as the next one needs it: its windows and which of them are settled.
pub(crate) struct Settled {
    pub windows: Windows,
    pub settled: Vec<bool>,
}

/// The cell of side `w` that holds the match origin (x, y) of exemplar `ex`.
fn cell(ex: usize, x: usize, y: usize, w: usize) -> (usize, usize, usize) {
    (ex, x / w, y / w)
}

/// Which windows of a finished pass are settled: inherited ones, and those whose match falls in
/// a cell holding at least `factor` × the mean count over all the exemplars' cells.
pub(crate) fn settle(
    windows: Windows,
    inherited: &[bool],
    set: &ExemplarSet,
    factor: f32,
) -> Settled {
    let w = windows.w;
    let mut counts: HashMap<(usize, usize, usize), u32> = HashMap::new();
    for &(ex, x, y) in &windows.placed {
        *counts.entry(cell(ex, x, y, w)).or_default() += 1;
    }
    let cells: usize = set
        .exemplars
        .iter()
        .map(|e| (e.width() + 1 - w).div_ceil(w) * (e.height() + 1 - w).div_ceil(w))
        .sum();
    let mean = windows.placed.len() as f32 / cells.max(1) as f32;
    let settled = windows
        .placed
        .iter()
        .zip(inherited)
        .map(|(&(ex, x, y), &inh)| inh || counts[&cell(ex, x, y, w)] as f32 >= factor * mean)
        .collect();
    Settled { windows, settled }
}

/// For each origin of one axis, the indices of the last pass's origins `prev` (side `pw`) whose
/// window holds the window of side `w` there (no wrapping).
fn holders(origins: &[usize], w: usize, prev: &[usize], pw: usize) -> Vec<Vec<usize>> {
    origins
        .iter()
        .map(|&o| {
            (0..prev.len())
                .filter(|&j| prev[j] <= o && o + w <= prev[j] + pw)
                .collect()
        })
        .collect()
}

/// The matches the windows of side `w` at `xs × ys` (rows of `xs`) inherit from the settled
/// windows of `prev`: per window, the first settled holder of the same exemplar (in the last
/// pass's order) gives its match shifted by the offset, its cost scaled by (w / w_prev)²; none
/// where no settled window holds it.
pub(crate) fn inherit(
    prev: &Settled,
    xs: &[usize],
    ys: &[usize],
    w: usize,
    exemplar_of: &[usize],
    set: &ExemplarSet,
) -> Vec<Option<Match>> {
    let p = &prev.windows;
    let (hx, hy) = (holders(xs, w, &p.xs, p.w), holders(ys, w, &p.ys, p.w));
    let mut out = Vec::with_capacity(xs.len() * ys.len());
    for (iy, &y) in ys.iter().enumerate() {
        for (ix, &x) in xs.iter().enumerate() {
            let ex = exemplar_of[out.len()];
            let found = hy[iy].iter().find_map(|&jy| {
                hx[ix].iter().find_map(|&jx| {
                    let k = jy * p.xs.len() + jx;
                    let (pex, mx, my) = p.placed[k];
                    (prev.settled[k] && pex == ex).then(|| {
                        let (sx, sy) = (mx + x - p.xs[jx], my + y - p.ys[jy]);
                        let cw = set.exemplars[ex].width() + 1 - w;
                        let scale = (w * w) as f64 / (p.w * p.w) as f64;
                        Match {
                            cost: (p.costs[k] as f64 * scale).round() as u32,
                            index: (sy * cw + sx) as u32,
                        }
                    })
                })
            });
            out.push(found);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::texture::Texture;

    fn set(w: usize, h: usize) -> ExemplarSet {
        let t = Texture::new(w, h, 1, (0..w * h).map(|i| (i % 7) as f32).collect()).unwrap();
        ExemplarSet::new(vec![t], 4).unwrap()
    }

    /// Four windows of side 8 at x 0, 4, 8, 12 (y 0) on an exemplar of 40 × 8: match origins
    /// span 33 × 1, five cells of side 8, mean count 0.8.
    fn pass(placed: Vec<(usize, usize, usize)>) -> Windows {
        Windows {
            w: 8,
            xs: vec![0, 4, 8, 12],
            ys: vec![0],
            costs: vec![100, 200, 300, 400],
            weights: vec![1.0; 4],
            placed,
        }
    }

    #[test]
    fn a_window_settles_where_its_cell_holds_factor_times_the_mean() {
        // Three matches in cell 0 (3 ≥ 2 × 0.8), one alone in cell 3 (1 < 1.6).
        let w = pass(vec![(0, 1, 0), (0, 5, 0), (0, 7, 0), (0, 25, 0)]);
        let s = settle(w, &[false; 4], &set(40, 8), 2.0);
        assert_eq!(s.settled, vec![true, true, true, false]);
        // Inherited windows stay settled whatever their cell.
        let w = pass(vec![(0, 1, 0), (0, 5, 0), (0, 7, 0), (0, 25, 0)]);
        let s = settle(w, &[false, false, false, true], &set(40, 8), 2.0);
        assert!(s.settled[3]);
    }

    #[test]
    fn an_inherited_match_is_the_holders_shifted_by_the_offset_with_its_cost_scaled() {
        let set = set(40, 8);
        let prev = Settled {
            windows: pass(vec![(0, 1, 0), (0, 5, 0), (0, 7, 0), (0, 25, 0)]),
            settled: vec![false, true, true, false],
        };
        // Windows of side 4 at x 0, 2, 4, 6, 8, 10, 14 and y 0, 4 (rows of 32 − 4 + 1 = 37).
        let xs = [0, 2, 4, 6, 8, 10, 14];
        let ys = [0, 4];
        let got = inherit(&prev, &xs, &ys, 4, &[0; 14], &set);
        let cw = 40 + 1 - 4;
        // x 0, 2: held only by the unsettled window at 0.
        assert_eq!(got[0], None);
        assert_eq!(got[1], None);
        // x 4: held by the windows at 0 (unsettled) and 4 (settled, match x 5): 5 + 0.
        assert_eq!(got[2], Some(Match { cost: 50, index: 5 }));
        // x 6: the window at 4 first (offset 2): 7.
        assert_eq!(got[3], Some(Match { cost: 50, index: 7 }));
        // x 10 in the second row: the window at 8 (match x 7, offset 2, y 0 + 4), cost 300/4.
        assert_eq!(
            got[7 + 5],
            Some(Match {
                cost: 75,
                index: (4 * cw + 9) as u32
            })
        );
        // x 14: held by the window at 12 alone, unsettled.
        assert_eq!(got[6], None);
        // Another exemplar than the holder's: searched.
        let other = inherit(&prev, &xs, &ys, 4, &[1; 14], &set);
        assert!(other.iter().all(Option::is_none));
    }
}
