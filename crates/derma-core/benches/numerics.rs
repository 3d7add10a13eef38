//! The hand-written small solver against the general dense LU and Cholesky on the systems the model matcher solves: the
//! damped normal equations of its Levenberg–Marquardt fits (symmetric positive definite, 3–12
//! unknowns). Whole fits with each solver: `cargo bench -p derma-shading --bench fits`.
//!
//! `cargo bench -p derma-core --bench numerics`

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use derma_core::numerics::dense::{cholesky_solve, lu_solve, matrix_from_rows, solve};
use derma_core::numerics::levenberg_marquardt::LinearSolve;

/// A symmetric positive definite n × n system like JᵀJ + λ diag(JᵀJ) (row-major) and its
/// right-hand side.
fn system(n: usize) -> (Vec<f64>, Vec<f64>) {
    let m = 3 * n;
    let j: Vec<f64> = (0..m * n)
        .map(|i| ((i * 7919 % 113) as f64 / 113.0 - 0.3) * (1.0 + (i % n) as f64))
        .collect();
    let mut a = vec![0.0; n * n];
    for r in 0..m {
        for p in 0..n {
            for q in 0..n {
                a[p * n + q] += j[r * n + p] * j[r * n + q];
            }
        }
    }
    for p in 0..n {
        a[p * n + p] *= 1.001;
    }
    let b = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
    (a, b)
}

fn lu(a: &[f64], b: &[f64], n: usize) -> Option<Vec<f64>> {
    lu_solve(&matrix_from_rows(n, n, a).ok()?, b).ok()
}

fn cholesky(a: &[f64], b: &[f64], n: usize) -> Option<Vec<f64>> {
    cholesky_solve(&matrix_from_rows(n, n, a).ok()?, b).ok()
}

const SOLVERS: [(&str, LinearSolve); 3] =
    [("elimination", solve), ("LU", lu), ("Cholesky", cholesky)];

fn solves(c: &mut Criterion) {
    let mut g = c.benchmark_group("solve");
    for n in [3, 6, 9, 12] {
        let (a, b) = system(n);
        for (name, f) in SOLVERS {
            g.bench_function(format!("{name} n={n}"), |bench| {
                bench.iter(|| f(black_box(&a), black_box(&b), n))
            });
        }
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(30)
        .warm_up_time(std::time::Duration::from_millis(300))
        .measurement_time(std::time::Duration::from_secs(1));
    targets = solves
}
criterion_main!(benches);
