//! Who runs the searches of Shen et al. §3.2 (eq. 1): the [`Matcher`] trait, which the passes
//! call, and the CPU's matcher. The GPU's is `gpu_matcher.rs`; what the GPU keeps between the
//! optimisation passes is the optimiser's GPU path's (`gpu_optimize.rs`), not the matcher's.

use crate::error::Result;
use crate::exemplar::ExemplarSet;
use crate::search::{best_matches_cpu, Match, Plane, Query, Search, Tolerance, WindowQuery};
use derma_core::gpu::Device;
use derma_core::progress::Progress;
use rayon::prelude::*;
use std::any::Any;

/// A patch pass for a matcher that runs it where it keeps the canvas ([`Matcher::patch_pass`]):
/// one exemplar, the canvas before it, and every wavefront's patches.
pub struct PatchPlan<'a> {
    /// Patch side N.
    pub n: usize,
    /// Near-best tolerance of the choice.
    pub tol: Tolerance,
    /// λ · C · v̄ in 16.16 fixed point (the occurrence penalty's weight; 0 = off).
    pub weight16: u64,
    /// The penalty's cap per known texel.
    pub cap: u32,
    /// Per wavefront, its patches in scanline order: (x, y, salt).
    pub wavefronts: Vec<Vec<[u32; 3]>>,
    /// Per wavefront, whether two of its patches overlap (then the later pastes last).
    pub overlaps: Vec<bool>,
    /// The canvas's codes before the pass.
    pub plane: Plane<'a>,
    /// The canvas's sources before the pass (exemplar texel or `u32::MAX`).
    pub sources: &'a [u32],
    /// The k-coherence tables where the searches run over candidates (`None`: exhaustive).
    pub coherence: Option<crate::coherence::Candidates<'a>>,
}

/// Window queries per batch of the default [`Matcher::window_matches`] (bounds the memory of
/// the gathered windows; one progress step each).
const WINDOW_BATCH: usize = 16_384;

/// Runs searches; implemented on the CPU ([`CpuMatcher`]) and on the GPU (`gpu::GpuMatcher`).
/// `Any`, so that a device's passes can tell their own matcher behind a `dyn Matcher`.
pub trait Matcher: Sync + Any {
    /// The answer of each query (all of window side `w`), in order.
    fn best_matches(&self, set: &ExemplarSet, s: &Search, queries: &[Query]) -> Result<Vec<Match>>;
    /// The answer of each window query of `plane`, in order, advancing `progress` by the
    /// queries done; the same answers as [`Self::best_matches`] of [`WindowQuery::query`].
    /// By default it gathers the windows in batches and runs those.
    fn window_matches(
        &self,
        set: &ExemplarSet,
        s: &Search,
        plane: &Plane,
        queries: &[WindowQuery],
        progress: &dyn Progress,
    ) -> Result<Vec<Match>> {
        gathered_window_matches(self, set, s, plane, queries, progress)
    }
    /// What runs the searches, for reports ("CPU", "GPU (…)").
    fn name(&self) -> String;
    /// Runs the patch pass of `plan` where the matcher keeps the canvas, advancing `progress`
    /// by the patches done, and returns the canvas's sources after it; `Ok(None)` when this
    /// matcher does not (the default), and the caller runs it round by round with
    /// [`Self::best_matches`]. Both give the same sources.
    fn patch_pass(
        &self,
        _set: &ExemplarSet,
        _plan: &PatchPlan,
        _progress: &dyn Progress,
    ) -> Result<Option<Vec<u32>>> {
        Ok(None)
    }
    /// Where the searches run; the passes that do not search (the correction) run there too.
    fn device(&self) -> Device {
        Device::Cpu
    }
}

/// [`Matcher::window_matches`] by gathering the windows on the host, in batches of
/// [`WINDOW_BATCH`], and searching those with [`Matcher::best_matches`].
pub(crate) fn gathered_window_matches<M: Matcher + ?Sized>(
    matcher: &M,
    set: &ExemplarSet,
    s: &Search,
    plane: &Plane,
    queries: &[WindowQuery],
    progress: &dyn Progress,
) -> Result<Vec<Match>> {
    let mut out = Vec::with_capacity(queries.len());
    for chunk in queries.chunks(WINDOW_BATCH) {
        let batch: Vec<Query> = chunk.par_iter().map(|q| q.query(plane, s.w)).collect();
        out.extend(matcher.best_matches(set, s, &batch)?);
        progress.advance(chunk.len() as u64);
    }
    Ok(out)
}

/// The CPU backend: queries spread over all cores with rayon; each search prunes with the
/// block-sum bounds. The exemplars' block sums are prepared once per batch of queries.
pub struct CpuMatcher;

impl Matcher for CpuMatcher {
    fn best_matches(&self, set: &ExemplarSet, s: &Search, queries: &[Query]) -> Result<Vec<Match>> {
        Ok(best_matches_cpu(set, s, queries))
    }
    fn name(&self) -> String {
        format!("CPU ({} threads)", rayon::current_num_threads())
    }
}
