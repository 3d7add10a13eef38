//! Bounded Levenberg–Marquardt (Marquardt 1963, "An algorithm for least-squares estimation of
//! nonlinear parameters", with the diagonal scaling of Moré 1978): steps clipped to a box.

use super::dense::solve;

/// Residual function of [`levenberg_marquardt`]: fills r (length m) and, when given, the m × n
/// Jacobian row-major.
pub type ResidualFn<'a> = dyn FnMut(&[f64], &mut [f64], Option<&mut [f64]>) + 'a;

/// A solver of the damped normal equations: (A row-major n × n, b, n) → x, `None` if singular.
pub type LinearSolve = fn(&[f64], &[f64], usize) -> Option<Vec<f64>>;

/// Which solver [`levenberg_marquardt`] uses for its damped normal equations.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DenseSolver {
    /// Gaussian elimination with partial pivoting ([`solve`]): fastest for the model matcher's
    /// few unknowns (BENCHMARKS.md, "Numerics").
    #[default]
    Elimination,
    /// Cholesky factorisation ([`crate::numerics::dense::cholesky_solve`]): for badly scaled
    /// systems whose pivots the elimination rejects.
    Cholesky,
}

impl DenseSolver {
    /// The solver as a function.
    pub fn function(self) -> LinearSolve {
        match self {
            DenseSolver::Elimination => solve,
            DenseSolver::Cholesky => cholesky,
        }
    }
}

fn cholesky(a: &[f64], b: &[f64], n: usize) -> Option<Vec<f64>> {
    let m = super::dense::matrix_from_rows(n, n, a).ok()?;
    super::dense::cholesky_solve(&m, b).ok()
}

/// Options of [`levenberg_marquardt`].
#[derive(Clone, Copy, Debug)]
pub struct LmOptions {
    /// Most outer iterations (each one Jacobian evaluation).
    pub max_iterations: usize,
    /// Stop when the relative decrease of the cost falls below this.
    pub tolerance: f64,
    /// The solver of the damped normal equations.
    pub solver: DenseSolver,
}

impl Default for LmOptions {
    fn default() -> Self {
        Self {
            max_iterations: 40,
            tolerance: 1e-10,
            solver: DenseSolver::Elimination,
        }
    }
}

/// Minimises ½‖r(p)‖² within the box [lo, hi] (steps are clipped to it). `residuals(p, r, jac)`
/// fills r (length m) and, when `jac` is given, the m × n Jacobian row-major. Returns the best
/// parameters and ‖r‖². `opts.solver` solves the damped normal equations.
pub fn levenberg_marquardt(
    residuals: &mut ResidualFn,
    p0: &[f64],
    lo: &[f64],
    hi: &[f64],
    m: usize,
    opts: LmOptions,
) -> (Vec<f64>, f64) {
    let linear_solve = opts.solver.function();
    let n = p0.len();
    let mut p: Vec<f64> = (0..n).map(|i| p0[i].clamp(lo[i], hi[i])).collect();
    let mut r = vec![0.0; m];
    let mut j = vec![0.0; m * n];
    residuals(&p, &mut r, Some(&mut j));
    let mut cost: f64 = r.iter().map(|v| v * v).sum();
    let mut lambda = 1e-3;
    let mut trial = vec![0.0; n];
    let mut rt = vec![0.0; m];
    for _ in 0..opts.max_iterations {
        // Normal equations JᵀJ δ = −Jᵀr.
        let mut jtj = vec![0.0; n * n];
        let mut jtr = vec![0.0; n];
        for row in 0..m {
            let jr = &j[row * n..row * n + n];
            for a in 0..n {
                jtr[a] += jr[a] * r[row];
                for b in a..n {
                    jtj[a * n + b] += jr[a] * jr[b];
                }
            }
        }
        for a in 0..n {
            for b in 0..a {
                jtj[a * n + b] = jtj[b * n + a];
            }
        }
        let mut improved = false;
        for _ in 0..12 {
            let mut damped = jtj.clone();
            for a in 0..n {
                damped[a * n + a] += lambda * jtj[a * n + a].max(1e-12);
            }
            let rhs: Vec<f64> = jtr.iter().map(|v| -v).collect();
            let Some(delta) = linear_solve(&damped, &rhs, n) else {
                lambda *= 10.0;
                continue;
            };
            for a in 0..n {
                trial[a] = (p[a] + delta[a]).clamp(lo[a], hi[a]);
            }
            residuals(&trial, &mut rt, None);
            let c: f64 = rt.iter().map(|v| v * v).sum();
            if c.is_finite() && c < cost {
                let rel = (cost - c) / cost.max(1e-300);
                p.copy_from_slice(&trial);
                cost = c;
                lambda = (lambda * 0.3).max(1e-12);
                improved = true;
                if rel < opts.tolerance {
                    return (p, cost);
                }
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
        residuals(&p, &mut r, Some(&mut j));
    }
    (p, cost)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// y = 2 e^{−1.5 t} sampled at 20 points, as residuals with their Jacobian.
    fn exponential() -> impl FnMut(&[f64], &mut [f64], Option<&mut [f64]>) {
        let t: Vec<f64> = (0..20).map(|i| i as f64 * 0.1).collect();
        let y: Vec<f64> = t.iter().map(|t| 2.0 * (-1.5 * t).exp()).collect();
        move |p: &[f64], r: &mut [f64], j: Option<&mut [f64]>| {
            for i in 0..t.len() {
                r[i] = p[0] * (-p[1] * t[i]).exp() - y[i];
            }
            if let Some(j) = j {
                for i in 0..t.len() {
                    let e = (-p[1] * t[i]).exp();
                    j[i * 2] = e;
                    j[i * 2 + 1] = -p[0] * t[i] * e;
                }
            }
        }
    }

    #[test]
    fn lm_fits_an_exponential() {
        // Recover (2, 1.5) from (1, 1).
        let (p, c) = levenberg_marquardt(
            &mut exponential(),
            &[1.0, 1.0],
            &[0.0, 0.0],
            &[10.0, 10.0],
            20,
            LmOptions::default(),
        );
        assert!(
            (p[0] - 2.0).abs() < 1e-6 && (p[1] - 1.5).abs() < 1e-6,
            "{p:?} {c}"
        );
    }

    #[test]
    fn the_box_is_respected() {
        // The optimum (2, 1.5) lies outside p₀ ≤ 1.8: the fit stops on the bound.
        let (p, _) = levenberg_marquardt(
            &mut exponential(),
            &[1.0, 1.0],
            &[0.0, 0.0],
            &[1.8, 10.0],
            20,
            LmOptions::default(),
        );
        assert_eq!(p[0], 1.8);
        assert!(p[1] > 0.0 && p[1] < 10.0);
    }
}
