//! Table 4.1 reproduced: each sampler and the exact baselines on one G-buffer — median time over
//! repeated runs, texture accesses per relevant texel and error against the exact transform.

use super::samplers::{self, Sampler};
use super::{error_percent, exact, jfa, material, GBuffer};
use serde::Serialize;
use std::time::Instant;

/// The lake's range Λ (mm) the table uses: derma-render's lake.
pub const RANGE_MM: f32 = derma_render::lake::RANGE_MM;

/// The samplers of the table: the thesis' settings (64 samples at most per texel) and derma's
/// refined backtracking.
pub const SAMPLERS: [Sampler; 6] = [
    Sampler::Equiangular { n: 64 },
    Sampler::Exponential { steps: 8 },
    Sampler::Backtracking {
        n: 8,
        steps: 8,
        refine: 0,
    },
    Sampler::Backtracking {
        n: 6,
        steps: 8,
        refine: 2,
    },
    DEFAULT,
    Sampler::Backtracking {
        n: 5,
        steps: 8,
        refine: 4,
    },
];

/// The sampler the lake uses by default: backtracking over 6 directions with three levels of
/// refinement (Table 4.1's goal: ≤ 0.37 % error at ≤ 46 accesses per texel).
pub const DEFAULT: Sampler = Sampler::Backtracking {
    n: 6,
    steps: 8,
    refine: 3,
};

/// One row.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// Method.
    pub method: String,
    /// Median wall time (ms) over the runs, on the CPU threads rayon has.
    pub ms: f64,
    /// Texture accesses per relevant texel.
    pub accesses: f64,
    /// Mean |λ − λ*| over relevant texels, % of Λ.
    pub error_percent: f64,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn timed<T>(runs: usize, f: impl Fn() -> T) -> (T, f64) {
    let mut times = Vec::new();
    let mut out = None;
    for _ in 0..runs.max(1) {
        let t = Instant::now();
        out = Some(f());
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    (out.expect("one run"), median(times))
}

/// The area of relevancy: globe texels within `range` of skin by the exact field.
fn relevant(g: &GBuffer, truth: &super::Field, range: f32) -> Vec<bool> {
    truth
        .distance
        .iter()
        .zip(&g.mask)
        .map(|(d, m)| *m == material::EYE && *d < range)
        .collect()
}

/// Measures every method on `g` with range `range`, each `runs` times.
pub fn measure(g: &GBuffer, range: f32, runs: usize) -> Vec<Row> {
    let (truth, ms) = timed(runs, || exact::field(g));
    let relevant = relevant(g, &truth, range);
    let mut rows = vec![Row {
        method: "exact EDT (Felzenszwalb–Huttenlocher)".into(),
        ms,
        accesses: truth.accesses_per_texel(&relevant),
        error_percent: 0.0,
    }];
    let (j, ms) = timed(runs, || jfa::field(g));
    rows.push(Row {
        method: "jump flooding (JFA+1)".into(),
        ms,
        accesses: j.accesses_per_texel(&relevant),
        error_percent: error_percent(&j.distance, &truth.distance, range),
    });
    for s in SAMPLERS {
        let (f, ms) = timed(runs, || samplers::field(g, s, range));
        rows.push(Row {
            method: s.name(),
            ms,
            accesses: f.accesses_per_texel(&relevant),
            error_percent: error_percent(&f.distance, &truth.distance, range),
        });
    }
    rows
}

/// The rows as a Markdown table.
pub fn markdown(rows: &[Row], w: usize, h: usize) -> String {
    let mut s = format!(
        "| method ({w}×{h}, Λ = {RANGE_MM} mm) | time (ms) | accesses / texel | error (% of Λ) |\n|---|---:|---:|---:|\n"
    );
    for r in rows {
        s.push_str(&format!(
            "| {} | {:.2} | {:.1} | {:.3} |\n",
            r.method, r.ms, r.accesses, r.error_percent
        ));
    }
    s
}

#[cfg(feature = "gpu")]
/// The GPU rows: jump flooding and every sampler on the device, each the mean of `runs`
/// back-to-back dispatches after a warm-up (device time without transfers), with their errors.
pub fn measure_gpu(g: &GBuffer, range: f32, runs: usize) -> crate::Result<Vec<Row>> {
    let gpu = super::gpu::GpuFields::new(g)?;
    let truth = exact::field(g);
    let relevant = relevant(g, &truth, range);
    let name = derma_core::gpu::context()?.name.clone();
    let (j, _) = gpu.jfa()?;
    let mut rows = vec![Row {
        method: format!("jump flooding (JFA+1), GPU: {name}"),
        ms: gpu.time_jfa(runs)?,
        accesses: j.accesses_per_texel(&relevant),
        error_percent: error_percent(&j.distance, &truth.distance, range),
    }];
    for s in SAMPLERS {
        let f = gpu.sampled(s, range)?;
        rows.push(Row {
            method: format!("{}, GPU: {name}", s.name()),
            ms: gpu.time_sampled(s, range, runs)?,
            accesses: f.accesses_per_texel(&relevant),
            error_percent: error_percent(&f.distance, &truth.distance, range),
        });
    }
    Ok(rows)
}
