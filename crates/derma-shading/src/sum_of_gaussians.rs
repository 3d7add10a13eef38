//! A radial diffusion profile as a sum of Gaussians (d'Eon, Luebke & Enderton 2007, "Efficient
//! rendering of human skin", EGSR; GPU Gems 3 ch. 14): R(r) ≈ Σ_k w_k G(v_k, r),
//! G(v, r) = e^{−r²/(2v)} / (2πv), variances shared by the colour channels, weights per channel,
//! fitted by minimising ∫ r (R − Σ)² dr as they do.

use derma_core::numerics::{levenberg_marquardt, nnls_normal, LmOptions};
use derma_optics::tally::ProfileBins;

/// d'Eon et al. 2007's six variances (mm²) for skin's three-layer profile (GPU Gems 3,
/// ch. 14, table 14-1): the starting point of the fit.
pub const DEON_VARIANCES_MM2: [f64; 6] = [0.0064, 0.0484, 0.187, 0.567, 1.99, 7.41];

/// A fitted sum of Gaussians.
#[derive(Clone, Debug, PartialEq)]
pub struct SogFit {
    /// Variances v_k, mm².
    pub variances_mm2: Vec<f64>,
    /// Weights [k][channel].
    pub weights: Vec<[f64; 3]>,
    /// RMS of the r-weighted residual relative to the r-weighted data (all channels).
    pub relative_rms: f64,
}

/// Energy of G(v, ·) inside radius r: 1 − e^{−r²/(2v)}.
fn gauss_cdf(r: f64, v: f64) -> f64 {
    1.0 - (-r * r / (2.0 * v)).exp()
}

/// Evaluates the fitted sum at radius r for channel c (mm⁻²).
pub fn eval(fit: &SogFit, r: f64, c: usize) -> f64 {
    fit.variances_mm2
        .iter()
        .zip(&fit.weights)
        .map(|(v, w)| w[c] * (-r * r / (2.0 * v)).exp() / (2.0 * std::f64::consts::PI * v))
        .sum()
}

struct Problem<'a> {
    bins: &'a ProfileBins,
    sw: Vec<f64>,
    data: &'a [[f64; 3]],
}

impl Problem<'_> {
    /// Ring-average design matrix columns (per Gaussian) for variances `v`.
    fn design(&self, v: &[f64]) -> Vec<Vec<f64>> {
        let dr = self.bins.d_max_mm / self.bins.bins as f64;
        v.iter()
            .map(|&var| {
                (0..self.bins.bins)
                    .map(|i| {
                        let (a, b) = (i as f64 * dr, (i + 1) as f64 * dr);
                        (gauss_cdf(b, var) - gauss_cdf(a, var)) / self.bins.ring_area(i)
                    })
                    .collect()
            })
            .collect()
    }

    /// Best non-negative weights per channel for variances `v`, and the residual vector.
    fn solve(&self, v: &[f64], r: &mut [f64]) -> Vec<[f64; 3]> {
        let cols = self.design(v);
        let k = v.len();
        let n = self.bins.bins;
        let mut ata = vec![0.0; k * k];
        for a in 0..k {
            for b in 0..k {
                ata[a * k + b] = (0..n)
                    .map(|i| self.sw[i] * self.sw[i] * cols[a][i] * cols[b][i])
                    .sum();
            }
        }
        let mut w = vec![[0.0; 3]; k];
        for c in 0..3 {
            let atb: Vec<f64> = (0..k)
                .map(|a| {
                    (0..n)
                        .map(|i| self.sw[i] * self.sw[i] * cols[a][i] * self.data[i][c])
                        .sum()
                })
                .collect();
            let x = nnls_normal(&ata, &atb, k);
            for a in 0..k {
                w[a][c] = x[a];
            }
            for i in 0..n {
                let m: f64 = (0..k).map(|a| x[a] * cols[a][i]).sum();
                r[c * n + i] = self.sw[i] * (m - self.data[i][c]);
            }
        }
        w
    }
}

/// Fits `k` Gaussians (k ≤ 6, started from d'Eon's variances) to ring averages `data`; `lm`
/// sets the Levenberg–Marquardt fit of the variances.
pub fn fit(bins: &ProfileBins, data: &[[f64; 3]], k: usize, lm: LmOptions) -> SogFit {
    let k = k.clamp(1, DEON_VARIANCES_MM2.len());
    let n = bins.bins;
    let dr = bins.d_max_mm / n as f64;
    let prob = Problem {
        bins,
        sw: (0..n)
            .map(|i| ((i as f64 + 0.5) * dr * dr).sqrt())
            .collect(),
        data,
    };
    // Variances fitted in log space with the weights solved inside (variable projection).
    let start: Vec<f64> = if k == 6 {
        DEON_VARIANCES_MM2.iter().map(|v| v.ln()).collect()
    } else {
        (0..k)
            .map(|i| 0.0064f64.ln() + (7.41f64 / 0.0064).ln() * i as f64 / (k - 1).max(1) as f64)
            .collect()
    };
    let m = 3 * n;
    let mut tmp = vec![0.0; m];
    let mut res = |p: &[f64], r: &mut [f64], jac: Option<&mut [f64]>| {
        let v: Vec<f64> = p.iter().map(|x| x.exp()).collect();
        prob.solve(&v, r);
        if let Some(j) = jac {
            for a in 0..k {
                let mut q = p.to_vec();
                q[a] += 1e-6;
                let vq: Vec<f64> = q.iter().map(|x| x.exp()).collect();
                prob.solve(&vq, &mut tmp);
                for i in 0..m {
                    j[i * k + a] = (tmp[i] - r[i]) / 1e-6;
                }
            }
        }
    };
    let lo = vec![(1e-4f64).ln(); k];
    let hi = vec![(100.0f64).ln(); k];
    let (p, cost) = levenberg_marquardt(&mut res, &start, &lo, &hi, m, lm);
    let mut v: Vec<f64> = p.iter().map(|x| x.exp()).collect();
    v.sort_by(f64::total_cmp);
    let mut r = vec![0.0; m];
    let weights = prob.solve(&v, &mut r);
    let data_sq: f64 = (0..n)
        .map(|i| {
            (0..3)
                .map(|c| (prob.sw[i] * data[i][c]).powi(2))
                .sum::<f64>()
        })
        .sum();
    SogFit {
        variances_mm2: v,
        weights,
        relative_rms: (cost / data_sq.max(1e-300)).sqrt(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_sum_of_gaussians() {
        let bins = ProfileBins {
            bins: 64,
            d_max_mm: 8.0,
        };
        let truth = SogFit {
            variances_mm2: vec![0.02, 0.3, 2.0],
            weights: vec![[0.2, 0.25, 0.3], [0.2, 0.1, 0.05], [0.15, 0.02, 0.0]],
            relative_rms: 0.0,
        };
        let prob = Problem {
            bins: &bins,
            sw: vec![1.0; 64],
            data: &[],
        };
        let cols = prob.design(&truth.variances_mm2);
        let data: Vec<[f64; 3]> = (0..64)
            .map(|i| {
                std::array::from_fn(|c| (0..3).map(|k| truth.weights[k][c] * cols[k][i]).sum())
            })
            .collect();
        let f = fit(&bins, &data, 3, LmOptions::default());
        assert!(f.relative_rms < 1e-3, "{f:?}");
        for (a, b) in f.variances_mm2.iter().zip(&truth.variances_mm2) {
            assert!(((a - b) / b).abs() < 0.01, "{f:?}");
        }
        // The ring average of a Gaussian equals its value at the ring's centre for wide ones.
        assert!(
            (eval(&truth, 0.0, 0)
                - (0.2 / 0.02 + 0.2 / 0.3 + 0.15 / 2.0) / (2.0 * std::f64::consts::PI))
                .abs()
                < 1e-9
        );
    }
}
