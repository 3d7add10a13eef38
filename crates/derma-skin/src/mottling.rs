//! Centimetre-scale mottling: the uneven blood and pigment of a real face — blotches of
//! erythema and of pigment a few millimetres to centimetres across — as a multiplicative,
//! band-limited modulation of the dermal blood and the epidermal melanin.
//!
//! Why: facial colour is not uniform within a region; cheek images resolved into melanin and
//! hemoglobin maps show heterogeneity at millimetre to centimetre sizes, more in the hemoglobin of
//! Caucasian than of Asian skin ("Image analysis of skin color heterogeneity focusing on skin
//! chromophores and the age-related changes in facial skin", 194 women's cheeks), and that
//! heterogeneity is what people read as age and health (Matts et al. 2007, J Am Acad Dermatol
//! 57:977). The sizes here (wavelengths 20, 10 and 5 mm) span that band. The amplitudes are
//! authored and kept subtle (blood e^±0.7, melanin e^±0.15): the face's coarse redness comes
//! first from its regions (regional.rs: cheeks and nose), and random blotches strong enough to
//! carry it alone read as a rash (docs/head.md). Because the modulation multiplies the
//! chromophores, the colour contrast it makes falls with melanin, as the physics of the optics
//! says it must. Its mean factor is within about 1 % of 1, which the ITA° calibration (on mean
//! texels) neglects.

use crate::noise::{BandNoise, NoiseCache, CHANNELS};
use glam::Vec3;

/// Philox stream of the mottling's noise seed (the baseline noise is 100, the relief 101).
pub const MOTTLING_STREAM: u32 = 102;

/// The mottling of one skin: its noise and log amplitudes.
pub struct Mottling {
    noise: BandNoise,
    blood: f32,
    melanin: f32,
}

/// Factor of a log amplitude `a` at noise value `n` ∈ [0, 1]: exp(a (2n − 1)), so ln(factor)
/// spans ±a and the median factor is 1.
#[inline]
pub fn factor(a: f32, n: f32) -> f32 {
    (a * (2.0 * n - 1.0)).exp()
}

impl Mottling {
    /// The mottling of `seed` at `wavelengths_mm` (coarse to fine), with log amplitudes of the
    /// blood and the melanin; `period_mm` makes it tile with a tileable patch.
    pub fn new(
        seed: u64,
        wavelengths_mm: [f32; 3],
        blood: f32,
        melanin: f32,
        period_mm: Option<[f32; 2]>,
    ) -> Mottling {
        Mottling {
            noise: BandNoise::new(seed, wavelengths_mm, period_mm),
            blood,
            melanin,
        }
    }

    /// Factors on the blood and the melanin at surface point `p` (mm). Two independent channels:
    /// vascular blotches and pigment blotches are not the same blotches.
    #[inline]
    pub fn factors(&self, p: Vec3, cache: &mut NoiseCache) -> [f32; 2] {
        self.factors_of(&self.noise.eval_cached(p, cache))
    }

    /// The noise behind the factors (for evaluating many points at once).
    pub fn noise(&self) -> &BandNoise {
        &self.noise
    }

    /// [`Mottling::factors`] from the noise's value at the point.
    #[inline]
    pub fn factors_of(&self, n: &[f32; CHANNELS]) -> [f32; 2] {
        [factor(self.blood, n[0]), factor(self.melanin, n[1])]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_factor_is_log_symmetric_about_one() {
        assert_eq!(factor(0.4, 0.5), 1.0);
        assert!((factor(0.4, 1.0) * factor(0.4, 0.0) - 1.0).abs() < 1e-6);
        assert!((factor(0.4, 1.0).ln() - 0.4).abs() < 1e-6);
        assert_eq!(factor(0.0, 0.9), 1.0);
    }

    #[test]
    fn blotches_are_centimetres_across_and_the_channels_differ() {
        // Along a line, the blood factor's autocorrelation falls to ½ over millimetres to
        // centimetres, not over a texel and not over the whole face; blood and melanin differ.
        let m = Mottling::new(7, [40.0, 16.0, 6.0], 0.5, 0.2, None);
        let mut cache = NoiseCache::default();
        let xs: Vec<[f32; 2]> = (0..4000)
            .map(|i| m.factors(Vec3::new(i as f32 * 0.25, 3.0, 1.0), &mut cache))
            .collect();
        let b: Vec<f64> = xs.iter().map(|f| (f[0] as f64).ln()).collect();
        let mean = b.iter().sum::<f64>() / b.len() as f64;
        let var = b.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / b.len() as f64;
        let corr = |lag: usize| {
            (0..b.len() - lag)
                .map(|i| (b[i] - mean) * (b[i + lag] - mean))
                .sum::<f64>()
                / (b.len() - lag) as f64
                / var
        };
        // Lags in 0.25 mm steps: 1 mm still correlated, 30 mm mostly not.
        assert!(corr(4) > 0.8, "{}", corr(4));
        let half = (1..400).find(|&l| corr(l) < 0.5).expect("decorrelates") as f32 * 0.25;
        assert!((2.0..20.0).contains(&half), "half-correlation at {half} mm");
        assert!(xs.iter().any(|f| (f[0] - f[1]).abs() > 0.05));
        assert!(xs.iter().all(|f| f[0] > 0.0 && f[1] > 0.0));
    }
}
