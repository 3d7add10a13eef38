//! Multivariate linear regression (thesis §3.5: the eyelid shape and skin motion models are
//! linear maps fitted by least squares), with an intercept as the homogeneous coordinate of §3.7
//! and a small ridge so collinear inputs (a rig that never moves torsion) stay solvable.

use derma_core::numerics::{dense::cholesky_solve, Matrix};
use serde::{Deserialize, Serialize};

/// y = W [x; 1]: `outputs` rows of `inputs + 1` coefficients (the last is the intercept).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Linear {
    /// Number of inputs.
    pub inputs: usize,
    /// Coefficient rows, one per output, each `inputs + 1` long.
    pub w: Vec<Vec<f64>>,
}

/// Ridge weight relative to the mean diagonal of XᵀX: small enough not to bias a well-posed
/// fit (1e-9 relative), large enough to keep an input that never varies at zero weight.
const RIDGE: f64 = 1e-9;

impl Linear {
    /// Least-squares fit of `ys` from `xs` (same number of rows).
    pub fn fit(xs: &[Vec<f64>], ys: &[Vec<f64>]) -> crate::Result<Linear> {
        let n = xs.len();
        if n == 0 || ys.len() != n {
            return Err(derma_core::Invalid::new(
                "regression rows",
                "at least one, with as many outputs as inputs",
                format!("{} inputs, {} outputs", n, ys.len()),
            )
            .into());
        }
        let p = xs[0].len() + 1;
        let mut ata = Matrix::zeros(p, p);
        let q = ys[0].len();
        let mut atb = vec![vec![0.0; p]; q];
        let row = |x: &Vec<f64>, j: usize| if j + 1 == p { 1.0 } else { x[j] };
        for (x, y) in xs.iter().zip(ys) {
            for i in 0..p {
                let xi = row(x, i);
                for j in 0..=i {
                    ata[(i, j)] += xi * row(x, j);
                }
                for (o, yo) in y.iter().enumerate() {
                    atb[o][i] += xi * yo;
                }
            }
        }
        let mean_diag = (0..p).map(|i| ata[(i, i)]).sum::<f64>() / p as f64;
        for i in 0..p {
            for j in 0..i {
                ata[(j, i)] = ata[(i, j)];
            }
            ata[(i, i)] += RIDGE * mean_diag.max(1e-300);
        }
        let w = atb
            .iter()
            .map(|b| cholesky_solve(&ata, b))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Linear { inputs: p - 1, w })
    }

    /// y = W [x; 1].
    pub fn apply(&self, x: &[f64]) -> Vec<f64> {
        self.w
            .iter()
            .map(|r| {
                r[..self.inputs]
                    .iter()
                    .zip(x)
                    .map(|(a, b)| a * b)
                    .sum::<f64>()
                    + r[self.inputs]
            })
            .collect()
    }

    /// The composition self ∘ inner: x ↦ self(inner(x)), itself linear.
    pub fn after(&self, inner: &Linear) -> Linear {
        let w = self
            .w
            .iter()
            .map(|r| {
                let mut out = vec![0.0; inner.inputs + 1];
                for (k, ik) in inner.w.iter().enumerate() {
                    for (o, v) in out.iter_mut().zip(ik) {
                        *o += r[k] * v;
                    }
                }
                out[inner.inputs] += r[self.inputs];
                out
            })
            .collect();
        Linear {
            inputs: inner.inputs,
            w,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_an_exact_affine_map_and_composes() {
        let xs: Vec<Vec<f64>> = (0..30)
            .map(|i| {
                vec![
                    (i as f64 * 0.7).sin(),
                    (i as f64 * 0.3).cos(),
                    i as f64 * 0.1,
                ]
            })
            .collect();
        let f = |x: &[f64]| vec![2.0 * x[0] - x[1] + 0.5, 0.3 * x[2] + x[0] - 4.0];
        let ys: Vec<Vec<f64>> = xs.iter().map(|x| f(x)).collect();
        let m = Linear::fit(&xs, &ys).unwrap();
        for x in &xs {
            let (a, b) = (m.apply(x), f(x));
            assert!(
                a.iter().zip(&b).all(|(a, b)| (a - b).abs() < 1e-6),
                "{a:?} {b:?}"
            );
        }
        let g = Linear {
            inputs: 2,
            w: vec![vec![1.0, 1.0, 1.0]],
        };
        let c = g.after(&m);
        let x = [0.2, -0.4, 1.5];
        let want: f64 = f(&x).iter().sum::<f64>() + 1.0;
        assert!((c.apply(&x)[0] - want).abs() < 1e-6);
    }
}
