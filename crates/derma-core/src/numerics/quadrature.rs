//! Numerical quadrature: composite Simpson's rule over an interval (one rule for the whole
//! workspace: the saccade profile's normaliser, the blink pauses' mean).

/// ∫ f over [a, b] by the composite Simpson's rule on `n` panels (`n` even, ≥ 2): h/3 (f₀ + 4f₁ +
/// 2f₂ + … + 4fₙ₋₁ + fₙ) with h = (b − a)/n; exact for cubics.
pub fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    debug_assert!(
        n >= 2 && n.is_multiple_of(2),
        "Simpson's rule needs an even number of panels"
    );
    let h = (b - a) / n as f64;
    let mut s = f(a) + f(b);
    for i in 1..n {
        s += if i % 2 == 1 { 4.0 } else { 2.0 } * f(a + h * i as f64);
    }
    s * (b - a) / (3.0 * n as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn simpson_is_exact_for_cubics_and_converges_on_a_gaussian() {
        let cubic = simpson(|x| 2.0 * x * x * x - x + 1.0, -1.0, 2.0, 2);
        // ∫ = [x⁴/2 − x²/2 + x] from −1 to 2 = (8 − 2 + 2) − (½ − ½ − 1) = 9.
        assert!((cubic - 9.0).abs() < 1e-12, "{cubic}");
        let g = simpson(|x| (-0.5 * x * x).exp(), -8.0, 8.0, 256);
        assert!(
            (g - (2.0 * std::f64::consts::PI).sqrt()).abs() < 1e-9,
            "{g}"
        );
    }
}
