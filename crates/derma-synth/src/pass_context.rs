//! What every pass of the synthesis needs besides the canvas (Shen et al. §3.2–3.3): the
//! exemplars, the matcher that runs the searches, the guide, progress and the seed; and where an
//! optimisation pass's search and E-step run ([`PassSteps`]).

use crate::canvas::Canvas;
use crate::e_step::Windows;
use crate::error::Result;
use crate::exemplar::ExemplarSet;
use crate::guide::Guide;
use crate::matcher::Matcher;
use crate::search::{Match, Search, WindowQuery};
use derma_core::progress::Progress;

/// The shared inputs of the patch pass and the optimisation passes.
pub(crate) struct PassContext<'a> {
    pub set: &'a ExemplarSet,
    pub matcher: &'a dyn Matcher,
    pub guide: Option<&'a Guide>,
    pub progress: &'a dyn Progress,
    pub seed: u64,
    /// The k-coherence tables where the searches run over candidates (`None`: exhaustive).
    pub coherence: Option<&'a crate::coherence::Tables>,
}

/// Where the optimisation passes search and blend, and where each E-step leaves the canvas: on
/// the host (`optimize::HostSteps`), or on a device that keeps it there between passes (the
/// GPU's, `gpu_optimize::GpuSteps`), which owns whatever it keeps. The host's canvas is current
/// where [`PassSteps::guesses_on_host`] holds, and again once [`PassSteps::finish`] has run.
pub(crate) trait PassSteps {
    /// Whether the host makes the windows' coherent guesses from the canvas's sources; where
    /// not, the search makes them from the sources kept where it runs (the queries carry none).
    fn guesses_on_host(&self) -> bool;
    /// The M-step: the answer of each window query of the canvas, in order.
    fn window_matches(
        &self,
        canvas: &Canvas,
        ctx: &PassContext,
        s: &Search,
        queries: &[WindowQuery],
    ) -> Result<Vec<Match>>;
    /// The E-step: the canvas blended anew from the `matched` windows and the exemplars'
    /// `bands` ((low, high) per exemplar).
    fn e_step(
        &mut self,
        canvas: &mut Canvas,
        set: &ExemplarSet,
        matched: &Windows,
        bands: &[(Vec<f32>, Vec<f32>)],
    ) -> Result<()>;
    /// After the last pass: brings what the steps keep elsewhere back into the canvas.
    fn finish(self, canvas: &mut Canvas) -> Result<()>;
}
