//! The modified Bessel function of the second kind K₀, which the marginal of a radially
//! exponential diffusion profile reduces to (∫ e^{−a√(x²+y²)}/√(x²+y²) dy = 2 K₀(a|x|)).
//! Polynomial approximations of Abramowitz & Stegun 1964, eqs. 9.8.1, 9.8.5 and 9.8.6.

/// I₀(x) for 0 ≤ x ≤ 3.75 (A&S 9.8.1, |ε| < 1.6·10⁻⁷).
fn i0_small(x: f64) -> f64 {
    let t = (x / 3.75).powi(2);
    1.0 + t
        * (3.5156229
            + t * (3.0899424 + t * (1.2067492 + t * (0.2659732 + t * (0.0360768 + t * 0.0045813)))))
}

/// K₀(x) for x > 0: A&S 9.8.5 below 2 (|ε| < 10⁻⁸, with 9.8.1's I₀), 9.8.6 above
/// (|ε| < 1.9·10⁻⁷ relative to e^{−x}/√x).
pub fn k0(x: f64) -> f64 {
    assert!(x > 0.0, "K0 is singular at {x}");
    if x <= 2.0 {
        let t = (x / 2.0).powi(2);
        -(x / 2.0).ln() * i0_small(x)
            + (-0.57721566
                + t * (0.42278420
                    + t * (0.23069756
                        + t * (0.03488590 + t * (0.00262698 + t * (0.00010750 + t * 0.0000074))))))
    } else {
        let t = 2.0 / x;
        (-x).exp() / x.sqrt()
            * (1.25331414
                + t * (-0.07832358
                    + t * (0.02189568
                        + t * (-0.01062446
                            + t * (0.00587872 + t * (-0.00251540 + t * 0.00053208))))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_tabulated_values_and_its_integral() {
        // A&S table 9.8 / DLMF 10.25: K0(0.5) = 0.9244190712, K0(1) = 0.4210244382,
        // K0(2) = 0.1138938727, K0(5) = 0.0036910983.
        for (x, v) in [
            (0.5, 0.9244190712),
            (1.0, 0.4210244382),
            (2.0, 0.1138938727),
            (5.0, 0.0036910983),
        ] {
            assert!(
                (k0(x) - v).abs() < 2e-7 * v.max(1e-2) * 10.0,
                "K0({x}) = {}",
                k0(x)
            );
        }
        // ∫₀^∞ K₀ = π/2 (DLMF 10.43.19 with ν = 0).
        let h = 1e-4;
        let s: f64 = (0..400_000).map(|i| k0((i as f64 + 0.5) * h) * h).sum();
        assert!((s - std::f64::consts::FRAC_PI_2).abs() < 1e-3, "{s}");
    }
}
