//! Texel-level coherent correction after the optimisation passes: each texel becomes an exact
//! exemplar texel again, chosen among its neighbours' coherent continuations (k-coherence).
//!
//! Why: it was added when the E-step of §3.3 averaged the whole values of the four windows
//! covering a texel, which lost about a third of the exemplar's finest grain
//! (`quality::grain_ratio` ≈ 0.6–0.7 on the skin crops). The E-step now blends only the low
//! band ([`crate::optimize`]) and the correction changes the grain little; it leaves every
//! output texel an exemplar texel. The correction is Ashikhmin's coherent candidate set (Ashikhmin 2001, "Synthesizing natural
//! textures", §3) as run in parallel by Lefebvre & Hoppe 2005 ("Parallel controllable texture
//! synthesis", §3.3–3.4): for texel p, each neighbour q in the 3 × 3 around p proposes the
//! exemplar texel S(q) + (p − q), the continuation of its source; p takes the proposal whose
//! 5 × 5 exemplar neighbourhood is nearest (integer L2 over the codes) to p's neighbourhood in
//! the output, and copies that exemplar texel's values. The texels are updated in four
//! subpasses by the parity of (x, y), each reading only the state before it, so the result
//! does not depend on thread count. Where the searches ran on the GPU, so does the correction
//! (`gpu_correction.rs`, the same decisions).

use crate::canvas::{Canvas, NO_SOURCE};
use crate::error::Result;
use crate::exemplar::ExemplarSet;
use crate::guide::Guide;
use derma_core::gpu::Device;
use derma_core::progress::{Job, Progress, Unit};
use rayon::prelude::*;

/// Half-side of the compared neighbourhood (5 × 5, Lefebvre & Hoppe 2005 §3.4).
pub const RADIUS: usize = 2;

/// Subpasses per correction pass: the four parity classes of (x, y) (Lefebvre & Hoppe 2005
/// §3.4 use 2 × 2 or 3 × 3 classes; 2 × 2 keeps every texel's nearest neighbours fixed while it
/// is decided).
const PARITIES: [(usize, usize); 4] = [(0, 0), (1, 1), (1, 0), (0, 1)];

/// One decision: texel, exemplar, exemplar texel.
type Choice = (usize, u8, u32);

/// Runs `passes` correction passes over the canvas (each a stage of `progress`), on `device`
/// (the GPU's falls back to the CPU's for a canvas larger than the adapter binds).
pub(crate) fn correct(
    canvas: &mut Canvas,
    set: &ExemplarSet,
    guide: Option<&Guide>,
    passes: usize,
    progress: &Job,
    device: Device,
) -> Result<()> {
    #[cfg(feature = "gpu")]
    if passes > 0 && device == Device::Gpu {
        if let Some(g) = crate::gpu_correction::GpuCorrection::new(canvas, set, guide)? {
            each_subpass(passes, progress, |ox, oy| g.subpass(ox, oy))?;
            return g.finish(canvas, set);
        }
    }
    #[cfg(not(feature = "gpu"))]
    let _ = device;
    each_subpass(passes, progress, |ox, oy| {
        for (t, ex, s) in decide(canvas, set, guide, ox, oy) {
            canvas.copy_texel(set, t, ex as usize, s as usize);
        }
        Ok(())
    })
}

/// Runs `subpass` for every parity class of `passes` passes, each pass a stage of `progress`.
fn each_subpass(
    passes: usize,
    progress: &Job,
    mut subpass: impl FnMut(usize, usize) -> Result<()>,
) -> Result<()> {
    for pass in 0..passes {
        progress.stage(
            &format!("correction {}", pass + 1),
            PARITIES.len() as u64,
            Unit::Steps,
        );
        for &(ox, oy) in &PARITIES {
            subpass(ox, oy)?;
            progress.advance(1);
        }
    }
    Ok(())
}

/// The choices of the texels with parity (ox, oy), from the current canvas (read only).
fn decide(
    canvas: &Canvas,
    set: &ExemplarSet,
    guide: Option<&Guide>,
    ox: usize,
    oy: usize,
) -> Vec<Choice> {
    let (w, h) = (canvas.width, canvas.height);
    (oy..h)
        .into_par_iter()
        .step_by(2)
        .flat_map_iter(|y| {
            (ox..w)
                .step_by(2)
                .filter_map(move |x| best_candidate(canvas, set, guide, x, y))
        })
        .collect()
}

/// The best coherent candidate for texel (x, y), or `None` when it has no proposal.
fn best_candidate(
    canvas: &Canvas,
    set: &ExemplarSet,
    guide: Option<&Guide>,
    x: usize,
    y: usize,
) -> Option<Choice> {
    let r = RADIUS as isize;
    let c = canvas.channels;
    let want = guide.map(|g| g.at(canvas, x, y) as u8);
    let mut proposals: [(u8, u32); 9] = [(0, NO_SOURCE); 9];
    let mut n = 0;
    for dy in -1isize..=1 {
        for dx in -1isize..=1 {
            let Some(q) = canvas.neighbour(x, y, dx, dy) else {
                continue;
            };
            if canvas.src[q] == NO_SOURCE {
                continue;
            }
            let ex = canvas.src_exemplar[q];
            if want.is_some_and(|k| k != ex) {
                continue;
            }
            let e = &set.exemplars[ex as usize];
            let (ew, eh) = (e.width() as isize, e.height() as isize);
            let s = canvas.src[q] as isize;
            // The continuation, kept where its whole neighbourhood lies in the exemplar.
            let sx = (s % ew - dx).clamp(r, ew - 1 - r);
            let sy = (s / ew - dy).clamp(r, eh - 1 - r);
            let cand = (ex, (sy * ew + sx) as u32);
            if !proposals[..n].contains(&cand) {
                proposals[n] = cand;
                n += 1;
            }
        }
    }
    let mut best: Option<(u64, u8, u32)> = None;
    for &(ex, s) in &proposals[..n] {
        let e = &set.exemplars[ex as usize];
        let ew = e.width() as isize;
        let (sx, sy) = (s as isize % ew, s as isize / ew);
        let mut d = 0u64;
        for dy in -r..=r {
            for dx in -r..=r {
                let Some(q) = canvas.neighbour(x, y, dx, dy) else {
                    continue;
                };
                let es = ((sy + dy) * ew + sx + dx) as usize;
                for k in 0..c {
                    let diff = canvas.codes[q * c + k] as i32 - e.codes[es * c + k] as i32;
                    d += (diff * diff) as u64;
                }
            }
        }
        // Least distance; ties to the lower (exemplar, texel), so the choice is unique.
        if best.is_none_or(|b| (d, ex, s) < b) {
            best = Some((d, ex, s));
        }
    }
    best.map(|(_, ex, s)| (y * canvas.width + x, ex, s))
}
