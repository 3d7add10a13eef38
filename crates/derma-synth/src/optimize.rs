//! Global optimisation of Shen et al. §3.3: Kwatra et al. (2005) texture energy E = Σ_p ω_p ‖x_p − z_p‖²
//! over overlapping neighbourhoods, one pass per neighbourhood size, each a quarter of the last.
//!
//! One pass with windows of side w every w/2 texels (each texel in four windows):
//! 1. M-step: z_p = best match of each window x_p (the exact search of [`crate::search`]).
//! 2. Weights ω_p = ‖x_p − z_p‖^(r−2), r = 0.8 (Kwatra's robust exponent), ‖·‖ the RMS code
//!    difference per value in units of the code range, floored at one code.
//! 3. E-step, in two bands ([`crate::bands`]): each texel becomes Σ ω_p L(z_p) / Σ ω_p over the
//!    windows covering it, L the exemplar's low band, plus H(z_b), the high band of the covering
//!    window b of least distance ‖x_b − z_b‖ (the first in a fixed order among equals), whose
//!    exemplar texel becomes its source.
//!
//! Step 3 is where we depart from the paper. Shen's eq. 3 takes Kwatra's E-step, the weighted
//! mean of the whole values, with a factor of its own in the weight, ω_p = P(x_p) · ‖x_p −
//! z_p‖^(r−2), which the paper says is there to eliminate high-frequency information. On skin that is the pores and the grain: every pass
//! fed the next a smoother canvas, whose best matches were the exemplar's smoothest windows, and
//! P (the share of matches landing in the same exemplar region) favoured those popular ones.
//! Taking the whole texel of the best window instead keeps the grain but leaves hard edges
//! where neighbouring windows' shading differs. Blending the low band and choosing the high
//! band is Burt & Adelson's multiresolution spline in two bands: shading joins across the
//! windows' overlap, the grain is never averaged. Measured at 1024² on skin crops, tuned and
//! held out, in docs/synth.md.
//!
//! Steps 1 and 3 run where a `PassSteps` says: on the host, or, with the GPU's matcher, on the
//! GPU, whose path (`gpu_optimize.rs`) keeps the blended canvas there between passes and brings
//! it back once after the last; the host's `Canvas` holds no GPU state.

use crate::canvas::{origins, Canvas};
use crate::coherence::{Candidates, RANDOM};
use crate::e_step::{e_step, Windows};
use crate::error::Result;
use crate::exemplar::ExemplarSet;
use crate::pass_context::{PassContext, PassSteps};
use crate::search::{Match, Search, Tolerance, WindowQuery};
use crate::settle::Settled;
use derma_core::progress::Unit;
use derma_core::rng::Philox;
use rayon::prelude::*;
use std::time::Instant;

/// Kwatra et al. 2005, §3 (robust norm exponent), as adopted by Shen et al. §3.3.
pub const KWATRA_R: f32 = 0.8;

/// Philox stream of the salts of the tie-breaking choice (one sub-stream per window side).
const PICK_STREAM: u32 = 0x5e_0003;

/// The optimisation passes, one per window side of `sides` in order, leaving their result in
/// the canvas. With the GPU's matcher they run on the GPU, which keeps the canvas there between
/// passes (`gpu_optimize.rs`); otherwise on the host.
/// `settle`: the self-adaptive skip's factor ([`crate::settle`]; 0 searches every window).
pub(crate) fn optimise(
    canvas: &mut Canvas,
    ctx: &PassContext,
    sides: &[usize],
    settle: f32,
) -> Result<Vec<PassStats>> {
    #[cfg(feature = "gpu")]
    if let Some(gpu) = crate::gpu::GpuMatcher::behind(ctx.matcher) {
        let steps = crate::gpu_optimize::GpuSteps::new(gpu);
        return passes(canvas, ctx, sides, settle, steps);
    }
    passes(canvas, ctx, sides, settle, HostSteps)
}

/// What an optimisation pass did: its window side, windows, and how many it searched (the rest
/// inherited their settled matches).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PassStats {
    /// Window side.
    pub w: usize,
    /// Windows of the pass.
    pub windows: usize,
    /// Windows searched.
    pub searched: usize,
}

/// The passes of `sides` with `steps`, then [`PassSteps::finish`].
fn passes<S: PassSteps>(
    canvas: &mut Canvas,
    ctx: &PassContext,
    sides: &[usize],
    settle: f32,
    mut steps: S,
) -> Result<Vec<PassStats>> {
    let mut prev = None;
    let mut stats = Vec::new();
    for &w in sides {
        let (windows, inherited, st) = optimise_pass(canvas, &mut steps, ctx, w, prev.as_ref())?;
        stats.push(st);
        prev = (settle > 0.0).then(|| crate::settle::settle(windows, &inherited, ctx.set, settle));
    }
    steps.finish(canvas)?;
    Ok(stats)
}

/// The steps on the host: the matcher searches the windows of the host's canvas and the CPU
/// blends it ([`crate::e_step`]); nothing is kept elsewhere.
struct HostSteps;

impl PassSteps for HostSteps {
    fn guesses_on_host(&self) -> bool {
        true
    }

    fn window_matches(
        &self,
        canvas: &Canvas,
        ctx: &PassContext,
        s: &Search,
        queries: &[WindowQuery],
    ) -> Result<Vec<Match>> {
        ctx.matcher
            .window_matches(ctx.set, s, &canvas.plane(), queries, ctx.progress)
    }

    fn e_step(
        &mut self,
        canvas: &mut Canvas,
        set: &ExemplarSet,
        matched: &Windows,
        bands: &[(Vec<f32>, Vec<f32>)],
    ) -> Result<()> {
        e_step(canvas, set, matched, bands);
        Ok(())
    }

    fn finish(self, _canvas: &mut Canvas) -> Result<()> {
        Ok(())
    }
}

/// One optimisation pass with windows of side `w`, its search and E-step run by `steps`; the
/// windows held by a settled window of `prev` inherit its match unsearched. Returns the pass's
/// windows with which were inherited, and its counts.
fn optimise_pass(
    canvas: &mut Canvas,
    steps: &mut impl PassSteps,
    ctx: &PassContext,
    w: usize,
    prev: Option<&Settled>,
) -> Result<(Windows, Vec<bool>, PassStats)> {
    let (set, guide, progress) = (ctx.set, ctx.guide, ctx.progress);
    let rng = Philox::new(ctx.seed, PICK_STREAM);
    let (xs, ys) = window_origins(canvas, w);
    let windows: Vec<(usize, usize)> = ys
        .iter()
        .flat_map(|&y| xs.iter().map(move |&x| (x, y)))
        .collect();
    let probes = probes(w);
    let t0 = Instant::now();
    let exemplar_of: Vec<usize> = windows
        .par_iter()
        .map(|&(px, py)| guide.map_or(0, |g| g.at(canvas, px + w / 2, py + w / 2)))
        .collect();
    // The self-adaptive skip: windows inside settled ones keep their match.
    let inherited = match prev {
        Some(p) => crate::settle::inherit(p, &xs, &ys, w, &exemplar_of, set),
        None => vec![None; windows.len()],
    };
    let to_search: Vec<usize> = (0..windows.len())
        .filter(|&k| inherited[k].is_none())
        .collect();
    progress.stage(
        &format!("optimisation {w}×{w}"),
        to_search.len() as u64,
        Unit::Windows,
    );

    // M-step: every other window's best match, searched where the steps keep the canvas.
    let guesses_on_host = steps.guesses_on_host();
    let queries: Vec<WindowQuery> = to_search
        .par_iter()
        .map(|&k| {
            let (px, py) = windows[k];
            let ex = exemplar_of[k];
            WindowQuery {
                exemplar: ex as u32,
                x: px as u32,
                y: py as u32,
                // Where the sources are kept elsewhere, the search makes the same guesses there.
                guesses: if guesses_on_host {
                    canvas.coherent_guess(set, ex, px, py, w, &probes)
                } else {
                    Vec::new()
                },
                salt: rng.u32x4_sub(k as u64, w as u32)[0],
            }
        })
        .collect();
    let coherence = ctx.coherence.map(|t| t.of(set, w));
    let search = Search {
        w,
        tol: Tolerance(0),
        penalty: None,
        prepared: None,
        coherence: coherence.as_deref().map(|tables| Candidates {
            tables,
            random: RANDOM,
        }),
    };
    let t1 = Instant::now();
    let searched = steps.window_matches(canvas, ctx, &search, &queries)?;
    drop(queries);
    let mut matches: Vec<Match> = inherited.iter().map(|m| m.unwrap_or_default()).collect();
    for (&k, m) in to_search.iter().zip(searched) {
        matches[k] = m;
    }
    let t2 = Instant::now();

    let matched = matched_windows(set, canvas.channels, (w, xs, ys), &matches, &exemplar_of);
    let bands = crate::bands::bands(set, w);
    let t3 = Instant::now();
    steps.e_step(canvas, set, &matched, &bands)?;
    let ms = |a: Instant, b: Instant| (b - a).as_secs_f64() * 1e3;
    tracing::debug!(
        "optimisation {w}×{w}: queries {:.1} ms, search {:.1} ms, weights and bands {:.1} ms, E-step {:.1} ms",
        ms(t0, t1),
        ms(t1, t2),
        ms(t2, t3),
        ms(t3, Instant::now())
    );
    let stats = PassStats {
        w,
        windows: windows.len(),
        searched: to_search.len(),
    };
    let inherited = inherited.iter().map(Option::is_some).collect();
    Ok((matched, inherited, stats))
}

/// A pass's windows of side `w` at `xs × ys` with their `matches` (in the exemplars
/// `exemplar_of`): where each match lies, its cost, and Kwatra's robust weight of the low band's
/// mean — ‖·‖ the RMS code difference per value in units of the code range, floored at one code
/// so exact matches get a large, finite weight.
fn matched_windows(
    set: &ExemplarSet,
    channels: usize,
    (w, xs, ys): (usize, Vec<usize>, Vec<usize>),
    matches: &[Match],
    exemplar_of: &[usize],
) -> Windows {
    let placed = matches
        .iter()
        .zip(exemplar_of)
        .map(|(m, &ex)| {
            let cw = set.exemplars[ex].width() + 1 - w;
            (ex, m.index as usize % cw, m.index as usize / cw)
        })
        .collect();
    let values_per_window = (w * w * channels) as f64;
    let weights = matches
        .iter()
        .map(|m| {
            let rms = (m.cost as f64 / values_per_window).sqrt() / 255.0;
            rms.max(1.0 / 255.0).powf(KWATRA_R as f64 - 2.0) as f32
        })
        .collect();
    Windows {
        w,
        xs,
        ys,
        placed,
        costs: matches.iter().map(|m| m.cost).collect(),
        weights,
    }
}

/// The windows' origins along x and along y for windows of side `w`, every w/2 texels.
pub(crate) fn window_origins(canvas: &Canvas, w: usize) -> (Vec<usize>, Vec<usize>) {
    let step = (w / 2).max(1);
    // Offset by a quarter window, so no window edge lies on the patch grid (multiples of D)
    // or on the previous pass's window edges: every seam falls inside the windows that
    // straddle it, whose best matches are coherent across it.
    let offset = w / 4;
    (
        origins(canvas.width, w, step, offset, canvas.tile),
        origins(canvas.height, w, step, offset, canvas.tile),
    )
}

/// The texels of a window of side `w` whose sources' continuations are its coherent guesses:
/// the centre, then the corners (guesses.wgsl has the same list).
pub(crate) fn probes(w: usize) -> [(usize, usize); 5] {
    [
        (w / 2, w / 2),
        (0, 0),
        (w - 1, 0),
        (0, w - 1),
        (w - 1, w - 1),
    ]
}
