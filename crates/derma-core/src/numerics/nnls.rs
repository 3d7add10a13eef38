//! Non-negative least squares: min ‖A x − b‖² subject to x ≥ 0, from the normal equations, by
//! the active-set method of Lawson & Hanson (1974, "Solving Least Squares Problems", ch. 23).

use super::dense::solve;

/// Minimises ‖A x − b‖² subject to x ≥ 0 given the normal equations (AᵀA as `ata`, row-major
/// n × n, and Aᵀb as `atb`), by an active-set method: solve on the free set, move back to
/// feasibility, free the variable with the most negative gradient; ends in at most 3n steps
/// for the small n it is used for (the model matcher's linear weights).
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
