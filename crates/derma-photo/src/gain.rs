//! Per-photo gain and white balance solved globally before blending (Brown & Lowe 2007,
//! "Automatic panoramic image stitching using invariant features", §6 eq. 29): each photo's
//! per-channel gain makes overlapping samples agree, with a prior pulling gains toward 1.

use derma_core::numerics::dense::solve;

/// σ_N of eq. 29: the spread of a sample's colour between photos after gain, in linear [0, 1]
/// units. The paper's 10 grey levels of 255 are for 8-bit intensities near 128; skin in linear
/// light sits near 0.1–0.4, where the same balance against the prior (I²/σ_N² ≫ 1/σ_g²) needs a
/// smaller σ_N: 0.01 lets the data equalise exposures while the prior fixes the overall level.
pub const SIGMA_N: f64 = 0.01;
/// σ_g of eq. 29: the prior spread of a gain (0.1 in the paper).
pub const SIGMA_G: f64 = 0.1;

/// Overlap statistics: for photos i ≠ j, the number of shared samples and the sum of photo i's
/// colour over them.
#[derive(Clone, Debug)]
pub struct Overlaps {
    n: usize,
    count: Vec<f64>,
    sum: Vec<[f64; 3]>,
}

impl Overlaps {
    /// Empty statistics for `n` photos.
    pub fn new(n: usize) -> Self {
        Self {
            n,
            count: vec![0.0; n * n],
            sum: vec![[0.0; 3]; n * n],
        }
    }

    /// Adds one surface point seen by several photos: (photo, colour) pairs.
    pub fn add(&mut self, samples: &[(usize, [f32; 3])]) {
        for &(i, ci) in samples {
            for &(j, _) in samples {
                if i != j {
                    self.count[i * self.n + j] += 1.0;
                    for c in 0..3 {
                        self.sum[i * self.n + j][c] += ci[c] as f64;
                    }
                }
            }
        }
    }

    /// The gains g_i per channel minimising eq. 29; photos without overlap keep gain 1.
    pub fn gains(&self) -> Vec<[f32; 3]> {
        let n = self.n;
        let mut out = vec![[1.0f32; 3]; n];
        for c in 0..3 {
            let mut a = vec![0.0; n * n];
            let mut b = vec![0.0; n];
            for i in 0..n {
                a[i * n + i] = 1e-12;
                for j in 0..n {
                    let nij = self.count[i * n + j];
                    if i == j || nij == 0.0 {
                        continue;
                    }
                    let iij = self.sum[i * n + j][c] / nij;
                    let iji = self.sum[j * n + i][c] / nij;
                    a[i * n + i] +=
                        nij * (iij * iij / (SIGMA_N * SIGMA_N) + 1.0 / (SIGMA_G * SIGMA_G));
                    a[i * n + j] -= nij * iij * iji / (SIGMA_N * SIGMA_N);
                    b[i] += nij / (SIGMA_G * SIGMA_G);
                }
                if b[i] == 0.0 {
                    // No overlap: g = 1.
                    a[i * n + i] = 1.0;
                    b[i] = 1.0;
                }
            }
            if let Some(g) = solve(&a, &b, n) {
                for i in 0..n {
                    out[i][c] = g[i] as f32;
                }
            }
        }
        out
    }
}

/// `gains` scaled per channel so that their geometric mean over the photos is 1: eq. 29's prior
/// pulls every gain toward 1 but, with differently lit views, unevenly per channel, which tints
/// the whole texture; the overall level and colour of the light are not recoverable anyway, so
/// the light is taken as neutral on average.
pub fn unit_mean(mut gains: Vec<[f32; 3]>) -> Vec<[f32; 3]> {
    for c in 0..3 {
        let logs: Vec<f64> = gains
            .iter()
            .filter(|g| g[c] > 0.0)
            .map(|g| (g[c] as f64).ln())
            .collect();
        if logs.is_empty() {
            continue;
        }
        let m = (logs.iter().sum::<f64>() / logs.len() as f64).exp() as f32;
        for g in gains.iter_mut() {
            g[c] /= m;
        }
    }
    gains
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gains_undo_exposure_and_white_balance_differences() {
        // Three photos of the same grey-ish surface: exposures 1, 1.25 and 0.8 with a warm tint
        // on the second; gains should equalise them up to a common factor near 1.
        let truth = [[1.0, 1.0, 1.0], [1.25, 1.15, 1.0], [0.8, 0.8, 0.8]];
        let mut o = Overlaps::new(3);
        for k in 0..200 {
            let albedo = 0.2 + 0.3 * ((k * 37) % 100) as f32 / 100.0;
            let s: Vec<(usize, [f32; 3])> = (0..3)
                .map(|i| (i, truth[i].map(|t: f32| t * albedo)))
                .collect();
            o.add(&s);
        }
        let g = o.gains();
        for c in 0..3 {
            let corrected: Vec<f32> = (0..3).map(|i| g[i][c] * truth[i][c]).collect();
            let spread = corrected.iter().cloned().fold(f32::MIN, f32::max)
                / corrected.iter().cloned().fold(f32::MAX, f32::min);
            // From 1.25/0.8 = 1.56 before to within 3 % (the prior keeps a little of it).
            assert!(spread < 1.03, "channel {c}: {corrected:?} from gains {g:?}");
        }
    }

    #[test]
    fn unit_mean_gains_have_no_cast() {
        let g = unit_mean(vec![[0.72, 0.88, 0.9], [0.8, 0.9, 1.0], [0.6, 0.85, 0.95]]);
        for c in 0..3 {
            let p: f32 = g.iter().map(|x| x[c]).product();
            assert!((p - 1.0).abs() < 1e-5, "channel {c}: {p}");
        }
        // Ratios between photos are kept.
        assert!((g[0][0] / g[1][0] - 0.9).abs() < 1e-5);
    }

    #[test]
    fn no_overlap_means_unit_gain() {
        let o = Overlaps::new(2);
        assert_eq!(o.gains(), vec![[1.0; 3]; 2]);
    }
}
