//! Runs many photons on a backend and merges their tallies deterministically: photons are cut
//! into fixed batches (sized by the photon count only), each batch is tallied on its own, and
//! batches are merged in index order, so results do not depend on the number of threads.

use crate::error::{OpticsError, Result};
use crate::layer::Stack;
use crate::tally::{BrdfBins, ProfileBins, Tally};
use crate::transport::{trace, Incidence, Prepared, Recorder};
use derma_core::progress::Progress;
use rayon::prelude::*;

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

    /// Checks the stacks, counts and bins; the error says which is wrong.
    pub fn validate(&self) -> Result<()> {
        if self.stacks.is_empty() {
            return Err(OpticsError::Invalid("no stacks to simulate".into()));
        }
        if self.photons == 0 {
            return Err(OpticsError::Invalid(
                "photon count must be at least 1".into(),
            ));
        }
        let layers = self.stacks[0].layers.len();
        for (i, s) in self.stacks.iter().enumerate() {
            s.validate()
                .map_err(|e| OpticsError::Invalid(format!("wavelength sample {i}: {e}")))?;
            if s.layers.len() != layers {
                return Err(OpticsError::Invalid(
                    "every wavelength must have the same number of layers".into(),
                ));
            }
        }
        if let Some(b) = self.brdf {
            if b.is_empty() {
                return Err(OpticsError::Invalid("BRDF bins must all be ≥ 1".into()));
            }
            let most = crate::tally::MAX_BRDF_BINS;
            if b.theta_in > most || b.theta_out > most || b.phi > most {
                return Err(OpticsError::Invalid(format!(
                    "BRDF bins {}×{}×{}: at most {most} per angle",
                    b.theta_in, b.theta_out, b.phi
                )));
            }
        }
        if let Some(p) = self.profile {
            if p.bins == 0 || p.bins > crate::tally::MAX_PROFILE_BINS || !(p.d_max_mm > 0.0) {
                return Err(OpticsError::Invalid(
                    "radial profile needs ≥ 1 bin and D_max > 0".into(),
                ));
            }
        }
        if !self.channel_weights.is_empty() && self.channel_weights.len() != self.stacks.len() {
            return Err(OpticsError::Invalid(
                "one set of channel weights per wavelength is needed".into(),
            ));
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

/// Tallies photons `range` of `run` on this thread.
pub fn trace_range(run: &Run, prepared: &[Prepared], range: std::ops::Range<u64>) -> Tally {
    let mut t = run.empty_tally();
    let one = [1.0];
    let nl = prepared.len() as u64;
    for k in range {
        let lambda = (k % nl) as usize;
        let rec = Recorder {
            brdf: run.brdf,
            profile: run.profile,
            channel_weights: run
                .channel_weights
                .get(lambda)
                .map_or(&one[..], |c| c.as_slice()),
            lambda,
        };
        trace(&prepared[lambda], run.seed, k, run.incidence, &rec, &mut t);
    }
    t
}

/// Runs on the CPU with rayon; `progress` advances by the photons of each finished batch.
/// Slab runs ([`crate::transport_lanes::eligible`]) walk photons in SIMD lanes, the rest one
/// photon at a time ([`crate::transport::trace`]).
pub fn run_cpu(run: &Run, progress: &dyn Progress) -> Result<Tally> {
    run.validate()?;
    let prepared: Vec<Prepared> = run.stacks.iter().map(Prepared::new).collect();
    let bs = run.batch_size();
    let batches = run.photons.div_ceil(bs);
    let lanes = crate::transport_lanes::eligible(run);
    let mut total = run.empty_tally();
    // Merge in groups so memory stays bounded for runs with many batches.
    let group = 64u64;
    let mut g0 = 0;
    while g0 < batches {
        let g1 = (g0 + group).min(batches);
        let parts: Vec<Tally> = (g0..g1)
            .into_par_iter()
            .map(|b| {
                let r = b * bs..((b + 1) * bs).min(run.photons);
                let n = r.end - r.start;
                let t = if lanes {
                    crate::transport_lanes::trace_range_lanes(run, &prepared[0], r)
                } else {
                    trace_range(run, &prepared, r)
                };
                progress.advance(n);
                t
            })
            .collect();
        for p in &parts {
            total.merge(p);
        }
        g0 = g1;
    }
    Ok(total)
}
