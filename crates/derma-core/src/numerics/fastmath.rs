//! Elementary functions for per-texel loops: e^x and ∛x in f32 without branches, calls or
//! tables, so loops over texels or lanes vectorise (the standard library's calls do not).
//!
//! Methods: e^x by Cody–Waite range reduction (x = n·ln2 + r, |r| ≤ ln2/2, ln2 split in a
//! high part exact in f32 and a low part; Cody & Waite 1980, "Software Manual for the
//! Elementary Functions", ch. 6) and the degree-6 Taylor polynomial of e^r (truncation below
//! |r|⁷/7! ≈ 1.2·10⁻⁷), scaled by 2ⁿ through the exponent bits. ∛x from the exponent-thirding
//! bit estimate (Kahan 1991, "Computing a real cube root") refined by three Newton steps
//! y ← y − (y³ − x)/(3y²). Both are deterministic: the same bits on every machine and lane.

/// ln 2 split for Cody–Waite reduction: `LN2_HI` has 16 significant bits, so n·LN2_HI is
/// exact in f32 for |n| < 2⁸; `LN2_HI + LN2_LO` = ln 2 to f32 precision twice over.
pub(crate) const LN2_HI: f32 = 0.693_145_75;
pub(crate) const LN2_LO: f32 = 1.428_606_8e-6;

/// Taylor coefficients of e^r, 1/k! for k = 0…6 (evaluated by Horner's rule).
pub(crate) const EXP_POLY: [f32; 7] = [
    1.0,
    1.0,
    0.5,
    1.0 / 6.0,
    1.0 / 24.0,
    1.0 / 120.0,
    1.0 / 720.0,
];

/// Added to a third of x's bits, the first estimate of ∛x (Kahan 1991's exponent thirding: a
/// third of the bias 127 in the exponent field, tuned so the estimate is within ~3 %).
pub(crate) const CBRT_BIAS: u32 = 0x2a51_67a8;

/// 1.5 · 2²³: adding and subtracting it rounds an f32 of magnitude below 2²² to an integer,
/// ties to even, in the current (round-to-nearest) mode.
pub(crate) const ROUND_MAGIC: f32 = 12_582_912.0;

/// `x` rounded to the nearest integer, ties to even, for |x| < 2²² (the magic-number trick:
/// two additions, so it vectorises on every x86-64 and lanes give the same bits,
/// [`super::lanes`]; `f32::round` is a library call without SSE4.1).
#[inline(always)]
pub fn round_ties_even(x: f32) -> f32 {
    (x + ROUND_MAGIC) - ROUND_MAGIC
}

/// e^x for x in [−87, 88] (outside, clamped: ≈ 1.6·10⁻³⁸ and ≈ 1.65·10³⁸), relative error
/// below 3·10⁻⁷.
#[inline(always)]
pub fn exp_f32(x: f32) -> f32 {
    let x = x.clamp(-87.0, 88.0);
    let n = round_ties_even(x * std::f32::consts::LOG2_E);
    let r = (x - n * LN2_HI) - n * LN2_LO;
    let mut p = EXP_POLY[EXP_POLY.len() - 1];
    for &c in EXP_POLY[..EXP_POLY.len() - 1].iter().rev() {
        p = c + r * p;
    }
    let scale = f32::from_bits(((n as i32 + 127) as u32) << 23);
    p * scale
}

/// ∛x for x in [10⁻³⁰, 10³⁰] (callers clamp; at 0 and below it returns a small positive
/// number, not 0), relative error below 2·10⁻⁷.
#[inline(always)]
pub fn cbrt_f32(x: f32) -> f32 {
    // Thirding the biased exponent (and the mantissa bits with it) gives ∛x within ~3 %.
    let mut y = f32::from_bits(x.to_bits() / 3 + CBRT_BIAS);
    for _ in 0..3 {
        y -= (y * y * y - x) / (3.0 * y * y);
    }
    y
}

/// ∛x for finite x > 0 in f64, relative error below 10⁻¹³: the exponent thirded (within ~3 %),
/// then two Halley steps y ← y (y³ + 2x) / (2y³ + x) (cubic convergence); 0 at 0. About 3× libm's
/// `cbrt` here, which dominated CIELAB conversions.
#[inline(always)]
pub fn cbrt_f64(x: f64) -> f64 {
    if x <= 0.0 {
        return if x == 0.0 { 0.0 } else { -cbrt_f64(-x) };
    }
    let mut y = f64::from_bits(x.to_bits() / 3 + 0x2A9F_7893_782D_A1CE);
    for _ in 0..2 {
        let y3 = y * y * y;
        y *= (y3 + 2.0 * x) / (2.0 * y3 + x);
    }
    y
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points spread geometrically and linearly over a range, ends included.
    fn samples(lo: f32, hi: f32, n: usize) -> impl Iterator<Item = f32> {
        (0..=n).map(move |i| lo + (hi - lo) * i as f32 / n as f32)
    }

    #[test]
    fn cbrt_f64_matches_the_standard_library() {
        for k in -300..300 {
            for m in [1.0, 1.37, 2.9, 5.5, 9.99] {
                let x = m * 10f64.powi(k);
                let (a, b) = (cbrt_f64(x), x.cbrt());
                assert!(((a - b) / b).abs() < 1e-13, "∛{x}: {a} vs {b}");
                assert!(((cbrt_f64(-x) + b) / b).abs() < 1e-13);
            }
        }
        assert_eq!(cbrt_f64(0.0), 0.0);
    }

    #[test]
    fn exp_matches_the_standard_library() {
        let mut worst = 0.0f64;
        for x in samples(-87.0, 88.0, 200_000).chain(samples(-1.0, 1.0, 20_000)) {
            let want = (x as f64).exp();
            let rel = ((exp_f32(x) as f64 - want) / want).abs();
            worst = worst.max(rel);
        }
        assert!(worst < 3e-7, "worst relative error {worst:e}");
        assert_eq!(exp_f32(0.0), 1.0);
        // Round trip with the logarithm over the reflectances the match table stores.
        for v in samples(1e-4, 1.0, 10_000) {
            let back = exp_f32(v.ln());
            assert!((back - v).abs() <= 4e-7 * v, "{v} → {back}");
        }
    }

    #[test]
    fn cbrt_matches_the_standard_library() {
        let mut worst = 0.0f64;
        let geometric = (0..=20_000).map(|i| 10f32.powf(-30.0 + 60.0 * i as f32 / 20_000.0));
        for x in geometric.chain(samples(1e-4, 1.0, 50_000)) {
            let want = (x as f64).cbrt();
            let rel = ((cbrt_f32(x) as f64 - want) / want).abs();
            worst = worst.max(rel);
        }
        assert!(worst < 2e-7, "worst relative error {worst:e}");
        assert!((cbrt_f32(0.125) - 0.5).abs() < 1e-7);
        assert!((cbrt_f32(0.005) - 0.005f64.cbrt() as f32).abs() < 1e-7);
    }
}
