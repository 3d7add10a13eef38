//! Small dense least-squares tools for the model matcher: a symmetric solver, non-negative least
//! squares (Lawson & Hanson 1974, "Solving Least Squares Problems", ch. 23) and a bounded
//! Levenberg–Marquardt polish (Marquardt 1963, with the diagonal scaling of Moré 1978).

/// Solves A x = b for a small symmetric positive (semi)definite A by Gaussian elimination with
/// partial pivoting; `None` if singular.
pub fn solve(a: &[f64], b: &[f64], n: usize) -> Option<Vec<f64>> {
    let mut m = a.to_vec();
    let mut x = b.to_vec();
    for col in 0..n {
        let piv =
            (col..n).max_by(|&i, &j| m[i * n + col].abs().total_cmp(&m[j * n + col].abs()))?;
        let scale = (0..n)
            .map(|k| m[k * n + k].abs())
            .fold(0.0, f64::max)
            .max(1e-300);
        if m[piv * n + col].abs() <= 1e-14 * scale {
            return None;
        }
        if piv != col {
            for k in 0..n {
                m.swap(piv * n + k, col * n + k);
            }
            x.swap(piv, col);
        }
        for r in col + 1..n {
            let f = m[r * n + col] / m[col * n + col];
            if f != 0.0 {
                for k in col..n {
                    m[r * n + k] -= f * m[col * n + k];
                }
                x[r] -= f * x[col];
            }
        }
    }
    for col in (0..n).rev() {
        let mut s = x[col];
        for k in col + 1..n {
            s -= m[col * n + k] * x[k];
        }
        x[col] = s / m[col * n + col];
    }
    Some(x)
}

/// Minimises ‖A x − b‖² subject to x ≥ 0 given the normal equations (AᵀA as `ata`, Aᵀb as
/// `atb`), by an active-set method: solve on the free set, move back to feasibility, free the
/// variable with the most negative gradient; ends in at most 3n steps for the small n used here.
pub fn nnls_normal(ata: &[f64], atb: &[f64], n: usize) -> Vec<f64> {
    let mut x = vec![0.0; n];
    let mut free = vec![false; n];
    for _ in 0..3 * n + 3 {
        // Gradient of ½‖Ax−b‖²: AᵀA x − Aᵀb.
        let grad: Vec<f64> = (0..n)
            .map(|i| (0..n).map(|j| ata[i * n + j] * x[j]).sum::<f64>() - atb[i])
            .collect();
        let scale = atb.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
        let Some(k) = (0..n)
            .filter(|&i| !free[i] && grad[i] < -1e-12 * scale)
            .min_by(|&i, &j| grad[i].total_cmp(&grad[j]))
        else {
            break;
        };
        free[k] = true;
        loop {
            let idx: Vec<usize> = (0..n).filter(|&i| free[i]).collect();
            let m = idx.len();
            let sub: Vec<f64> = idx
                .iter()
                .flat_map(|&i| idx.iter().map(move |&j| ata[i * n + j]))
                .collect();
            let rhs: Vec<f64> = idx.iter().map(|&i| atb[i]).collect();
            let Some(z) = solve(&sub, &rhs, m) else {
                free[k] = false;
                break;
            };
            if z.iter().all(|&v| v > 0.0) {
                for (t, &i) in idx.iter().enumerate() {
                    x[i] = z[t];
                }
                break;
            }
            // Step from x towards z until the first free variable hits zero.
            let mut alpha = 1.0f64;
            for (t, &i) in idx.iter().enumerate() {
                if z[t] <= 0.0 {
                    let d = x[i] - z[t];
                    if d > 0.0 {
                        alpha = alpha.min(x[i] / d);
                    } else {
                        alpha = 0.0;
                    }
                }
            }
            for (t, &i) in idx.iter().enumerate() {
                x[i] += alpha * (z[t] - x[i]);
                if x[i] <= 1e-15 || (z[t] <= 0.0 && alpha == 0.0) {
                    x[i] = 0.0;
                    free[i] = false;
                }
            }
            if !idx.iter().any(|&i| free[i]) {
                break;
            }
        }
    }
    x
}

/// Residual function of [`levenberg_marquardt`]: fills r (length m) and, when given, the m × n
/// Jacobian row-major.
pub type ResidualFn<'a> = dyn FnMut(&[f64], &mut [f64], Option<&mut [f64]>) + 'a;

/// Options of [`levenberg_marquardt`].
#[derive(Clone, Copy, Debug)]
pub struct LmOptions {
    pub max_iterations: usize,
    /// Stop when the relative decrease of the cost falls below this.
    pub tolerance: f64,
}

impl Default for LmOptions {
    fn default() -> Self {
        Self {
            max_iterations: 40,
            tolerance: 1e-10,
        }
    }
}

/// Minimises ½‖r(p)‖² within the box [lo, hi] (steps are clipped to it). `residuals(p, r, jac)`
/// fills r (length m) and, when `jac` is given, the m × n Jacobian row-major. Returns the best
/// parameters and ‖r‖².
pub fn levenberg_marquardt(
    residuals: &mut ResidualFn,
    p0: &[f64],
    lo: &[f64],
    hi: &[f64],
    m: usize,
    opts: LmOptions,
) -> (Vec<f64>, f64) {
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
            let Some(delta) = solve(&damped, &rhs, n) else {
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

    #[test]
    fn solve_small_system() {
        let a = [4.0, 1.0, 0.0, 1.0, 3.0, 1.0, 0.0, 1.0, 2.0];
        let x = solve(&a, &[1.0, 2.0, 3.0], 3).unwrap();
        for r in 0..3 {
            let s: f64 = (0..3).map(|k| a[r * 3 + k] * x[k]).sum();
            assert!((s - [1.0, 2.0, 3.0][r]).abs() < 1e-12);
        }
        assert!(solve(&[1.0, 1.0, 1.0, 1.0], &[1.0, 1.0], 2).is_none());
    }

    #[test]
    fn nnls_matches_brute_force() {
        // A = columns (1,0,1), (0,1,1), (1,1,0); b with a negative unconstrained solution.
        let a = [[1.0, 0.0, 1.0], [0.0, 1.0, 1.0], [1.0, 1.0, 0.0]];
        let b = [1.0, -0.5, 0.3];
        let mut ata = [0.0; 9];
        let mut atb = [0.0; 3];
        for i in 0..3 {
            for j in 0..3 {
                ata[i * 3 + j] = (0..3).map(|k| a[i][k] * a[j][k]).sum();
            }
            atb[i] = (0..3).map(|k| a[i][k] * b[k]).sum();
        }
        let x = nnls_normal(&ata, &atb, 3);
        let cost = |x: &[f64]| -> f64 {
            (0..3)
                .map(|k| {
                    let v: f64 = (0..3).map(|i| a[i][k] * x[i]).sum::<f64>() - b[k];
                    v * v
                })
                .sum()
        };
        assert!(x.iter().all(|&v| v >= 0.0));
        // Brute force over a fine non-negative grid.
        let mut best = f64::MAX;
        for i in 0..60 {
            for j in 0..60 {
                for k in 0..60 {
                    best = best.min(cost(&[i as f64 * 0.02, j as f64 * 0.02, k as f64 * 0.02]));
                }
            }
        }
        assert!(cost(&x) <= best + 1e-9, "{x:?}: {} vs {best}", cost(&x));
    }

    #[test]
    fn lm_fits_an_exponential() {
        // y = 2 e^{−1.5 t}: recover (2, 1.5) from (1, 1).
        let t: Vec<f64> = (0..20).map(|i| i as f64 * 0.1).collect();
        let y: Vec<f64> = t.iter().map(|t| 2.0 * (-1.5 * t).exp()).collect();
        let mut f = |p: &[f64], r: &mut [f64], j: Option<&mut [f64]>| {
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
        };
        let (p, c) = levenberg_marquardt(
            &mut f,
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
}
