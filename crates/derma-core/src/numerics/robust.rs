//! Robust scale: the standard deviation a set of residuals would have were they normal, from their
//! median absolute deviation (Hampel 1974; Rousseeuw & Croux 1993 §1: σ ≈ 1.4826 × MAD).

/// 1/Φ⁻¹(¾): the factor that makes the median absolute deviation estimate σ of normal errors.
pub const MAD_TO_SIGMA: f64 = 1.4826;

/// 1.4826 × the median of `abs` (absolute residuals; reordered in place; the upper median for an
/// even count), or `None` when there are none.
pub fn mad_sigma(abs: &mut [f64]) -> Option<f64> {
    if abs.is_empty() {
        return None;
    }
    let mid = abs.len() / 2;
    Some(MAD_TO_SIGMA * *abs.select_nth_unstable_by(mid, f64::total_cmp).1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scale_of_normal_quantiles_is_their_sigma() {
        // |residuals| at the normal's quartile points scaled by σ = 2: the median |r| is
        // Φ⁻¹(¾)·σ = 0.6745·2, so the estimate is 2 (to the constant's 4 digits).
        let mut r = vec![0.3, 2.0 * 0.674_49, 5.0, 0.1, 9.0];
        assert!((mad_sigma(&mut r).unwrap() - 2.0).abs() < 1e-3);
        // The upper median of an even count, whatever the order.
        assert_eq!(
            mad_sigma(&mut [4.0, 1.0, 3.0, 2.0]),
            Some(MAD_TO_SIGMA * 3.0)
        );
        assert_eq!(mad_sigma(&mut []), None);
    }
}
