//! The library's entry point: a builder over [`synthesize`] with documented defaults, which
//! also picks the matcher for a [`Device`] (Shen et al. §3.4's search on the CPU or the GPU,
//! with identical answers on both).
//!
//! ```no_run
//! # fn main() -> derma_synth::Result<()> {
//! use derma_synth::{Synthesizer, Texture};
//! let exemplar = Texture::new(64, 64, 1, vec![0.5; 64 * 64])?;
//! let out = Synthesizer::new(exemplar).size(512, 512).seed(7).tile(true).run()?;
//! println!("{}×{} on {}", out.texture.width, out.texture.height, out.matcher);
//! # Ok(())
//! # }
//! ```

use crate::error::Result;
use crate::exemplar::ExemplarSet;
#[cfg(feature = "gpu")]
use crate::gpu::GpuMatcher;
use crate::guide::Guide;
use crate::matcher::{CpuMatcher, Matcher};
use crate::synthesize::{synthesize, SynthOptions, Synthesis};
use crate::texture::Texture;
use derma_core::gpu::Device;
use derma_core::progress::{Progress, Silent};

/// The matcher that runs the searches on `device` (`Auto`: a hardware GPU when one opens, else
/// the CPU).
pub fn matcher_for(device: Device) -> Result<Box<dyn Matcher>> {
    Ok(match device.resolve()? {
        #[cfg(feature = "gpu")]
        Device::Gpu => Box::new(GpuMatcher::new()?),
        _ => Box::new(CpuMatcher),
    })
}

/// Grows a texture from exemplars. Defaults: those of [`SynthOptions`] (512², patch N = 32,
/// three optimisation passes, ε = 0.1, λ = 1, seed 1, not tileable), one exemplar, no guide,
/// [`Device::Auto`], no progress shown.
pub struct Synthesizer<'a> {
    exemplars: Vec<Texture>,
    options: SynthOptions,
    guide: Option<Guide>,
    device: Device,
    progress: &'a dyn Progress,
}

impl<'a> Synthesizer<'a> {
    /// A synthesis from one exemplar (its channels are synthesised jointly).
    pub fn new(exemplar: Texture) -> Self {
        Self {
            exemplars: vec![exemplar],
            options: SynthOptions::default(),
            guide: None,
            device: Device::Auto,
            progress: &Silent,
        }
    }

    /// Adds another exemplar of the same channel layout (a [`Self::guide`] chooses among them).
    pub fn exemplar(mut self, exemplar: Texture) -> Self {
        self.exemplars.push(exemplar);
        self
    }

    /// Every option at once.
    pub fn options(mut self, options: SynthOptions) -> Self {
        self.options = options;
        self
    }

    /// Output size in texels (default 512 × 512).
    pub fn size(mut self, width: usize, height: usize) -> Self {
        self.options.width = width;
        self.options.height = height;
        self
    }

    /// Random seed (default 1): the same seed gives the same texture on any device and thread
    /// count.
    pub fn seed(mut self, seed: u64) -> Self {
        self.options.seed = seed;
        self
    }

    /// A tileable output that wraps at its edges (default off).
    pub fn tile(mut self, tile: bool) -> Self {
        self.options.tile = tile;
        self
    }

    /// Patch side N, even (default 32; §3.2).
    pub fn patch(mut self, patch: usize) -> Self {
        self.options.patch = patch;
        self
    }

    /// Optimisation passes (default 3; §3.3).
    pub fn passes(mut self, passes: usize) -> Self {
        self.options.passes = passes;
        self
    }

    /// Tolerance ε of the choice among near-best patches (default 0.1; 0 = best only).
    pub fn tolerance(mut self, tolerance: f64) -> Self {
        self.options.tolerance = tolerance;
        self
    }

    /// Weight λ of the occurrence penalty (default 1; 0 = off).
    pub fn occurrence(mut self, occurrence: f64) -> Self {
        self.options.occurrence = occurrence;
        self
    }

    /// The self-adaptive optimisation's factor (default [`crate::settle::DEFAULT_FACTOR`];
    /// 0 searches every window every pass; §3.3, [`crate::settle`]).
    pub fn settle(mut self, factor: f32) -> Self {
        self.options.settle = factor;
        self
    }

    /// Which positions each search verifies (default: the k-coherence candidates; or every
    /// position; see [`crate::coherence::Scope`]).
    pub fn search(mut self, scope: crate::coherence::Scope) -> Self {
        self.options.search = scope;
        self
    }

    /// A guide map choosing the exemplar per output region (default none).
    pub fn guide(mut self, guide: Guide) -> Self {
        self.guide = Some(guide);
        self
    }

    /// Where the searches run (default [`Device::Auto`]); the result is the same on each.
    pub fn device(mut self, device: Device) -> Self {
        self.device = device;
        self
    }

    /// Where progress goes (default nowhere): a stage per pass, in windows.
    pub fn progress(mut self, progress: &'a dyn Progress) -> Self {
        self.progress = progress;
        self
    }

    /// Runs the synthesis.
    pub fn run(self) -> Result<Synthesis> {
        let set = ExemplarSet::new(self.exemplars, self.options.patch)?;
        self.options.validate(set.channels())?;
        let matcher = matcher_for(self.device)?;
        synthesize(
            &set,
            &self.options,
            self.guide.as_ref(),
            matcher.as_ref(),
            self.progress,
        )
    }
}
