//! Orchestration of the two passes of Shen et al. §3: noise, patch pass, then optimisation
//! passes with shrinking neighbourhoods; options, guidance and progress reporting.

use crate::canvas::Canvas;
use crate::correction::correct;
use crate::error::{invalid, Result};
use crate::exemplar::ExemplarSet;
use crate::guide::Guide;
use crate::matcher::Matcher;
use crate::optimize::optimise;
use crate::pass_context::PassContext;
use crate::patch_pass::{initialise_noise, patch_pass};
use crate::search::{window_fits, Tolerance};
use crate::texture::Texture;
use derma_core::progress::{Job, Progress, Timing};

/// Peak bytes per output texel: the canvas (values f32, codes u8, source u32 and exemplar u8 per
/// texel), the output texture (f32 per channel) and the optimisation's weighted sums (f64 per
/// channel and a weight), rounded up.
fn bytes_per_texel(channels: usize) -> f64 {
    (4 + 1 + 4 + 8) as f64 * channels as f64 + 16.0
}

/// What to synthesise.
#[derive(Clone, Debug)]
pub struct SynthOptions {
    /// Output width in texels.
    pub width: usize,
    /// Output height in texels.
    pub height: usize,
    /// Patch side N (even); the displacement is D = N/2 (§3.2).
    pub patch: usize,
    /// Optimisation passes (§3.3: at least three); pass k uses windows of side N/2ᵏ.
    pub passes: usize,
    /// Tolerance of the patch pass's choice among near-best patches (image quilting's ε,
    /// Efros & Freeman 2001 §2.1: 0.1); 0 takes the best match only.
    pub tolerance: f64,
    /// Weight λ of the patch pass's occurrence penalty (0 = off); see [`crate::patch_pass`].
    pub occurrence: f64,
    /// Random seed: the same seed gives the same texture on any device and thread count.
    pub seed: u64,
    /// Tileable output: the texture wraps at its edges.
    pub tile: bool,
    /// Texel-level coherent correction passes after the optimisation (0 = off, as the paper);
    /// see [`crate::correction`].
    pub correction: usize,
    /// The self-adaptive optimisation's factor (§3.3, [`crate::settle`]): windows inside one
    /// whose match region holds this many times the mean share are optimised once (0 = every
    /// window every pass).
    pub settle: f32,
    /// Which positions each search verifies: the k-coherence candidates (default) or every
    /// position; see [`crate::coherence`].
    pub search: crate::coherence::Scope,
}

impl Default for SynthOptions {
    fn default() -> Self {
        Self {
            width: 512,
            height: 512,
            patch: 32,
            passes: 3,
            tolerance: 0.1,
            occurrence: 1.0,
            seed: 1,
            tile: false,
            correction: 1,
            settle: crate::settle::DEFAULT_FACTOR,
            search: crate::coherence::Scope::default(),
        }
    }
}

impl SynthOptions {
    /// Window sides of the optimisation passes: N, N/2, N/4, … (area a quarter each time).
    pub fn pass_windows(&self) -> Vec<usize> {
        (0..self.passes).map(|k| self.patch >> k).collect()
    }

    /// Checks the options for exemplars of `channels` channels (before any work).
    pub(crate) fn validate(&self, channels: usize) -> Result<()> {
        if self.patch < 4 || !self.patch.is_multiple_of(2) {
            return Err(invalid(
                "patch size",
                format!("{} (expected an even number ≥ 4)", self.patch),
            ));
        }
        if !window_fits(self.patch, channels) {
            return Err(invalid(
                "patch size",
                format!(
                    "{0}×{0} patches of {channels} channels overflow the 32-bit distance; \
                     use fewer channels or a smaller patch",
                    self.patch
                ),
            ));
        }
        if let Some(&w) = self.pass_windows().last() {
            if w < 2 {
                return Err(invalid(
                    "passes",
                    format!(
                        "{} passes shrink {}-texel patches below 2 texels; use at most {}",
                        self.passes,
                        self.patch,
                        self.patch.ilog2()
                    ),
                ));
            }
        }
        if self.width == 0 || self.height == 0 {
            return Err(invalid("output size", "zero width or height"));
        }
        let texels = self.width as f64 * self.height as f64;
        if let Some((need, have)) =
            derma_core::memory::shortfall(texels * bytes_per_texel(channels))
        {
            return Err(invalid(
                "output size",
                format!(
                    "{}×{} texels of {channels} channels need about {need:.1} GiB; {have:.1} GiB are available",
                    self.width, self.height
                ),
            ));
        }
        if self.tile && (self.width < self.patch || self.height < self.patch) {
            return Err(invalid(
                "output size",
                format!(
                    "a tileable {}×{} texture needs at least the patch size {} on each side",
                    self.width, self.height, self.patch
                ),
            ));
        }
        if !(0.0..=1.0).contains(&self.tolerance) {
            return Err(invalid(
                "tolerance",
                format!("{} (expected 0 ≤ ε ≤ 1)", self.tolerance),
            ));
        }
        if !(self.occurrence >= 0.0 && self.occurrence.is_finite()) {
            return Err(invalid(
                "occurrence weight",
                format!("{} (expected a finite λ ≥ 0)", self.occurrence),
            ));
        }
        if !(self.settle >= 0.0 && self.settle.is_finite()) {
            return Err(invalid(
                "settle factor",
                format!(
                    "{} (expected a finite factor ≥ 0; 0 searches every window)",
                    self.settle
                ),
            ));
        }
        Ok(())
    }
}

/// A synthesised texture and, per texel, the exemplar texel it came from last.
pub struct Synthesis {
    /// The texture.
    pub texture: Texture,
    /// Exemplar index of each texel's source.
    pub source_exemplar: Vec<u8>,
    /// Source texel index (y · exemplar width + x).
    pub source: Vec<u32>,
    /// Wall-clock seconds of each stage (patch pass, then each optimisation pass).
    pub timings: Vec<Timing>,
    /// Each optimisation pass's windows and how many of them were searched.
    pub passes: Vec<crate::optimize::PassStats>,
    /// What ran the searches ("CPU", "GPU (NVIDIA H200 (Vulkan))").
    pub matcher: String,
}

/// Grows a `width × height` texture from the exemplar set; reports a stage per pass.
pub fn synthesize(
    set: &ExemplarSet,
    opts: &SynthOptions,
    guide: Option<&Guide>,
    matcher: &dyn Matcher,
    progress: &dyn Progress,
) -> Result<Synthesis> {
    let c = set.channels();
    opts.validate(c)?;
    set.check_patch(opts.patch)?;
    if let Some(g) = guide {
        if let Some(&bad) = g
            .exemplar
            .iter()
            .find(|&&k| k as usize >= set.exemplars.len())
        {
            return Err(invalid(
                "guide",
                format!("selects exemplar {} of {}", bad + 1, set.exemplars.len()),
            ));
        }
    }
    // A plane smaller than a patch is grown at the patch size and cropped.
    let (w, h) = if opts.tile {
        (opts.width, opts.height)
    } else {
        (opts.width.max(opts.patch), opts.height.max(opts.patch))
    };
    let mut canvas = Canvas::new(w, h, c, opts.tile);
    initialise_noise(&mut canvas, set, opts.seed);
    let job = Job::new(progress);
    let tables = crate::coherence::Tables::default();
    let ctx = PassContext {
        set,
        matcher,
        guide,
        progress: &job,
        seed: opts.seed,
        coherence: (opts.search == crate::coherence::Scope::Coherent).then_some(&tables),
    };
    let tol = Tolerance::from_fraction(opts.tolerance);
    patch_pass(&mut canvas, &ctx, opts.patch, tol, opts.occurrence)?;
    let passes = optimise(&mut canvas, &ctx, &opts.pass_windows(), opts.settle)?;
    correct(
        &mut canvas,
        set,
        guide,
        opts.correction,
        &job,
        matcher.device(),
    )?;
    let timings = job.finish().timings;
    let (ow, oh) = (opts.width, opts.height);
    let mut data = Vec::with_capacity(ow * oh * c);
    let mut source = Vec::with_capacity(ow * oh);
    let mut source_exemplar = Vec::with_capacity(ow * oh);
    for y in 0..oh {
        data.extend_from_slice(&canvas.values[y * w * c..(y * w + ow) * c]);
        source.extend_from_slice(&canvas.src[y * w..y * w + ow]);
        source_exemplar.extend_from_slice(&canvas.src_exemplar[y * w..y * w + ow]);
    }
    Ok(Synthesis {
        texture: Texture::new(ow, oh, c, data)?,
        source_exemplar,
        source,
        timings,
        passes,
        matcher: matcher.name(),
    })
}
