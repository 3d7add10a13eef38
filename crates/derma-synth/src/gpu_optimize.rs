//! The optimisation passes of Shen et al. §3.3 on the GPU: the GPU matcher searches, the E-step
//! blends there where the device can (`gpu_e_step.rs`), and the canvas it leaves stays there
//! ([`GpuCanvas`]) for the next pass's coherent guesses and search, read back once after the
//! last pass. [`GpuSteps`] owns that canvas; the host's canvas never refers to it.

use crate::canvas::Canvas;
use crate::e_step::{e_step, Windows};
use crate::error::Result;
use crate::exemplar::ExemplarSet;
use crate::gpu::GpuMatcher;
use crate::gpu_e_step;
use crate::matcher::Matcher;
use crate::pass_context::{PassContext, PassSteps};
use crate::resident::GpuCanvas;
use crate::search::{Match, Search, WindowQuery};

/// The optimisation passes' steps on the GPU, and the canvas the last E-step kept there.
pub(crate) struct GpuSteps<'m> {
    matcher: &'m GpuMatcher,
    /// The canvas as the last pass's GPU E-step left it, newer than the host's; `None` where
    /// the host's is current (before the first pass, or after an E-step on the CPU).
    kept: Option<GpuCanvas>,
}

impl<'m> GpuSteps<'m> {
    /// Steps whose searches `matcher` runs, starting from the host's canvas.
    pub(crate) fn new(matcher: &'m GpuMatcher) -> Self {
        Self {
            matcher,
            kept: None,
        }
    }
}

impl PassSteps for GpuSteps<'_> {
    fn guesses_on_host(&self) -> bool {
        self.kept.is_none()
    }

    fn window_matches(
        &self,
        canvas: &Canvas,
        ctx: &PassContext,
        s: &Search,
        queries: &[WindowQuery],
    ) -> Result<Vec<Match>> {
        match &self.kept {
            // The kept codes, and the guesses made from the kept sources.
            Some(kept) => self
                .matcher
                .kept_window_matches(ctx.set, s, kept, queries, ctx.progress),
            // The host's codes, uploaded once for the pass.
            None => self
                .matcher
                .window_matches(ctx.set, s, &canvas.plane(), queries, ctx.progress),
        }
    }

    fn e_step(
        &mut self,
        canvas: &mut Canvas,
        set: &ExemplarSet,
        matched: &Windows,
        bands: &[(Vec<f32>, Vec<f32>)],
    ) -> Result<()> {
        // Every value, code and source is blended anew: what the last pass kept is spent.
        self.kept = None;
        self.kept = gpu_e_step::e_step(canvas, set, matched, bands)?;
        if self.kept.is_none() {
            // A device that cannot blend this canvas: the CPU does, the same bits.
            e_step(canvas, set, matched, bands);
        }
        Ok(())
    }

    fn finish(self, canvas: &mut Canvas) -> Result<()> {
        self.kept.map_or(Ok(()), |kept| kept.read_into(canvas))
    }
}
