//! The model matcher's fits with each solver of the Levenberg–Marquardt normal equations
//! (derma-core's hand-written elimination against the dense Cholesky): time per table, and the
//! residuals each reaches, on a small precompute table simulated in the setup (2 × 2 nodes of
//! melanin and blood, 2·10⁴ photons each, the default BRDF and profile bins).
//!
//! `cargo bench -p derma-shading --bench fits`

use criterion::{criterion_group, criterion_main, Criterion};
use derma_core::gpu::Device;
use derma_core::numerics::{DenseSolver, LmOptions};
use derma_core::progress::Silent;
use derma_optics::precompute::{self, Grid, Shard};
use derma_shading::brdf_fit::FitOptions;
use derma_shading::match_table::{fit_table, MatchOptions};

const GRID: &str = "photons = 20000\nseed = 3\naxes = { melanin = [0.02, 0.2], pheomelanin = [0.3], blood = [0.01, 0.08], oxygenation = [0.75], stratum_corneum_um = [15.0], epidermis_um = [60.0] }\n";

fn fits(c: &mut Criterion) {
    let dir = std::env::temp_dir().join(format!("derma-bench-fits-{}", std::process::id()));
    let grid = Grid::parse(GRID, std::path::Path::new("bench grid")).unwrap();
    let shard = Shard::parse("1/1").unwrap();
    precompute::run_shard(&dir, &grid, shard, Device::Cpu, &Silent).unwrap();
    let pre = precompute::merge(std::slice::from_ref(&dir)).unwrap();
    let mut g = c.benchmark_group("fit_table");
    g.sample_size(10);
    for solver in [DenseSolver::Elimination, DenseSolver::Cholesky] {
        let opts = MatchOptions {
            fit: FitOptions {
                lm: LmOptions {
                    solver,
                    ..LmOptions::default()
                },
                ..FitOptions::default()
            },
            ..MatchOptions::default()
        };
        let (_, summary) = fit_table(&pre, &opts, &Silent).unwrap();
        for s in &summary {
            eprintln!(
                "{solver:?}: {} mean relative RMS residual {:.5} (max {:.5})",
                s.name, s.mean, s.max
            );
        }
        g.bench_function(format!("{solver:?}, 4 entries"), |b| {
            b.iter(|| fit_table(&pre, &opts, &Silent).unwrap())
        });
    }
    g.finish();
    let _ = std::fs::remove_dir_all(&dir);
}

criterion_group!(benches, fits);
criterion_main!(benches);
