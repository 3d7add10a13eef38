//! One Monte Carlo simulation as data (the transport of thesis §4.4–4.5, docs/optics.md): the
//! stacks per wavelength, photon count, seed, incidence and what to record, and its batching.

use crate::error::{OpticsError, Result};
use crate::layer::Stack;
use crate::tally::{BrdfBins, ProfileBins, Tally};
use crate::transport::Incidence;

/// One simulation: stacks per wavelength (photon k runs in stack k mod len), and what to record.
#[derive(Clone, Debug)]
pub struct Run {
    /// One stack per wavelength sample; photon k runs in stack k mod len.
    pub stacks: Vec<Stack>,
    /// Photons to launch.
    pub photons: u64,
    /// Seed of the photons' streams.
    pub seed: u64,
    /// How light arrives.
    pub incidence: Incidence,
    /// Bins of the sampled BRDF, when recorded.
    pub brdf: Option<BrdfBins>,
    /// Bins of the radial exit profile, when recorded.
    pub profile: Option<ProfileBins>,
    /// BRDF channel weights per wavelength (`[stacks.len()][channels]`); empty → one channel
    /// of weight 1.
    pub channel_weights: Vec<Vec<f64>>,
}

impl Run {
    /// A single-wavelength run under a normal pencil beam, recording totals only.
    pub fn totals(stack: Stack, photons: u64, seed: u64) -> Self {
        Self {
            stacks: vec![stack],
            photons,
            seed,
            incidence: Incidence::Normal,
            brdf: None,
            profile: None,
            channel_weights: Vec::new(),
        }
    }

    /// A single-wavelength run under cosine-weighted incidence (thesis §4.5.2), recording the
    /// BRDF into `bins`.
    pub fn brdf(stack: Stack, photons: u64, seed: u64, bins: BrdfBins) -> Self {
        Self {
            stacks: vec![stack],
            photons,
            seed,
            incidence: Incidence::ArcsinZenith,
            brdf: Some(bins),
            profile: None,
            channel_weights: Vec::new(),
        }
    }

    /// Checks the stacks, counts and bins; the error says which is wrong.
    pub fn validate(&self) -> Result<()> {
        if self.stacks.is_empty() {
            return Err(OpticsError::Invalid(derma_core::Invalid::new(
                "stacks to simulate",
                "at least one",
                "none",
            )));
        }
        if self.photons == 0 {
            return Err(OpticsError::Invalid(derma_core::Invalid::new(
                "photons",
                "at least 1",
                self.photons,
            )));
        }
        let layers = self.stacks[0].layers.len();
        for (i, s) in self.stacks.iter().enumerate() {
            s.validate().map_err(|e| match e {
                OpticsError::Invalid(mut inv) => {
                    inv.what = format!("{} at wavelength sample {i}", inv.what);
                    OpticsError::Invalid(inv)
                }
                other => other,
            })?;
            if s.layers.len() != layers {
                return Err(OpticsError::Invalid(derma_core::Invalid::new(
                    format!("layers at wavelength sample {i}"),
                    format!("{layers} (every wavelength must have the same number of layers)"),
                    s.layers.len(),
                )));
            }
        }
        if let Some(b) = self.brdf {
            let given = format!("{}×{}×{}", b.theta_in, b.theta_out, b.phi);
            if b.is_empty() {
                return Err(OpticsError::Invalid(derma_core::Invalid::new(
                    "BRDF bins",
                    "at least 1 per angle",
                    given,
                )));
            }
            let most = crate::tally::MAX_BRDF_BINS;
            if b.theta_in > most || b.theta_out > most || b.phi > most {
                return Err(OpticsError::Invalid(derma_core::Invalid::new(
                    "BRDF bins",
                    format!("at most {most} per angle"),
                    given,
                )));
            }
        }
        if let Some(p) = self.profile {
            if p.bins == 0 || p.bins > crate::tally::MAX_PROFILE_BINS || !(p.d_max_mm > 0.0) {
                return Err(OpticsError::Invalid(derma_core::Invalid::new(
                    "radial profile",
                    format!(
                        "1 to {} bins and D_max > 0 mm",
                        crate::tally::MAX_PROFILE_BINS
                    ),
                    format!("{} bins and D_max {} mm", p.bins, p.d_max_mm),
                )));
            }
        }
        if !self.channel_weights.is_empty() && self.channel_weights.len() != self.stacks.len() {
            return Err(OpticsError::Invalid(derma_core::Invalid::new(
                "sets of channel weights",
                format!("one per wavelength sample ({})", self.stacks.len()),
                self.channel_weights.len(),
            )));
        }
        Ok(())
    }

    /// Number of BRDF channels (1 without channel weights).
    pub fn channels(&self) -> usize {
        self.channel_weights.first().map_or(1, |c| c.len())
    }

    /// An empty tally shaped for this run.
    pub fn empty_tally(&self) -> Tally {
        Tally::new(
            self.stacks[0].layers.len(),
            self.stacks.len(),
            self.brdf.map(|b| (b, self.channels())),
            self.profile,
        )
    }

    /// Photons per batch: a function of the photon count only (determinism), large enough to
    /// amortise the batch's tally, small enough to balance two or many cores.
    pub fn batch_size(&self) -> u64 {
        (self.photons / 256).clamp(1024, 1 << 16)
    }
}
