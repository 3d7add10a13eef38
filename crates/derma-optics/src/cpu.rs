//! Runs a simulation on the CPU and merges its tallies deterministically: photons are cut into
//! fixed batches (sized by the photon count only), each batch is tallied on its own, and batches
//! are merged in index order, so results do not depend on the number of threads.

use crate::error::Result;
use crate::run::Run;
use crate::tally::Tally;
use crate::transport::{trace, Prepared, Recorder};
use derma_core::progress::Progress;
use rayon::prelude::*;

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
