//! What every pass of the synthesis needs besides the canvas (Shen et al. §3.2–3.3): the
//! exemplars, the matcher that runs the searches, the guide, progress and the seed.

use crate::exemplar::ExemplarSet;
use crate::guide::Guide;
use crate::matcher::Matcher;
use derma_core::progress::Progress;

/// The shared inputs of the patch pass and the optimisation passes.
pub(crate) struct PassContext<'a> {
    pub set: &'a ExemplarSet,
    pub matcher: &'a dyn Matcher,
    pub guide: Option<&'a Guide>,
    pub progress: &'a dyn Progress,
    pub seed: u64,
}
