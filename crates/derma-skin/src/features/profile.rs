//! Profile functions þ(d) of profiled shapes (thesis §4.8.2–4.8.3, §5.3): what a feature does as
//! a function of the distance from its primitive, each pinned to the thesis' formula in tests.

/// The logistic sigmoid 1/(1+e^−x).
#[inline]
pub fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + (-x).exp())
}

/// Sigmoid profile þ_sig(d) = 1 − (sigmoid(4d/r) − ½)·2 (thesis §5.3.2): 1 at the centre, 0.036
/// at d = r, 6.7·10⁻⁴ at d = 2r, where features are cut off ([`SIGMOID_SUPPORT`]).
#[inline]
pub fn sigmoid_profile(d: f32, r: f32) -> f32 {
    1.0 - (sigmoid(4.0 * d / r) - 0.5) * 2.0
}

/// Support of the sigmoid profile in units of r (value there 6.7·10⁻⁴, negligible).
pub const SIGMOID_SUPPORT: f32 = 2.0;

/// Follicle fade between the hair stalk r_i and the outer radius r_o (thesis §5.3.4). The printed
/// formula is garbled ("(sigmoid(d·5/r) − 1)/2"); we read it as the sigmoid profile with slope 5
/// over the annulus, α = 2(1 − sigmoid(5(d − r_i)/(r_o − r_i))), which is 1 at r_i (continuous with
/// the stalk) and 0.013 at r_o, the same shape as þ_sig.
#[inline]
pub fn follicle_alpha(d: f32, r_inner: f32, r_outer: f32) -> f32 {
    if d <= r_inner {
        1.0
    } else if d >= r_outer {
        0.0
    } else {
        2.0 * (1.0 - sigmoid(5.0 * (d - r_inner) / (r_outer - r_inner)))
    }
}

/// Freckle amount a = clamp(1 − 1.2 d/r, 0, 1) (thesis §5.3.5).
#[inline]
pub fn freckle_amount(d: f32, r: f32) -> f32 {
    (1.0 - 1.2 * d / r).clamp(0.0, 1.0)
}

/// Wrinkle taper T(t, w) = 2tw for t < ½, 2(1 − t)w for t ≥ ½ (thesis §5.3.7).
#[inline]
pub fn wrinkle_taper(t: f32, w: f32) -> f32 {
    if t < 0.5 {
        2.0 * t * w
    } else {
        2.0 * (1.0 - t) * w
    }
}

/// Wrinkle cross-section þ_wrinkle as a function of x = d / T(t, w) (thesis §5.3.7). The printed
/// equation is garbled; what survives is "1 −", the ratio d/t and the exponent 0.2, restricted to
/// [0, 1]. We read it as þ(x) = 1 − x^0.2 for x < 1, else 0: a sharp crease at the fold line with
/// long shallow shoulders, which is how fine facial wrinkles look in cross-section.
#[inline]
pub fn wrinkle_profile(x: f32) -> f32 {
    if x >= 1.0 {
        0.0
    } else {
        (1.0 - x.max(0.0).powf(0.2)).clamp(0.0, 1.0)
    }
}

/// Smooth bump (1 − (d/r)²)² on d < r: the pore profile (ours; see `pore.rs`).
#[inline]
pub fn smooth_bump(d: f32, r: f32) -> f32 {
    let x = d / r;
    if x >= 1.0 {
        0.0
    } else {
        let q = 1.0 - x * x;
        q * q
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sigmoid_profile_matches_thesis_values() {
        assert!((sigmoid_profile(0.0, 1.0) - 1.0).abs() < 1e-7);
        // 1 − 2(σ(4) − ½) = 2 − 2σ(4) = 2/(1+e⁴)
        let expect = 2.0 / (1.0 + 4f32.exp());
        assert!((sigmoid_profile(1.0, 1.0) - expect).abs() < 1e-6);
        assert!((sigmoid_profile(0.5, 0.25) - 2.0 / (1.0 + 8f32.exp())).abs() < 1e-6);
        assert!(sigmoid_profile(SIGMOID_SUPPORT, 1.0) < 1e-3);
        // monotone decreasing
        let mut prev = 2.0;
        for i in 0..100 {
            let v = sigmoid_profile(i as f32 * 0.03, 1.0);
            assert!(v < prev);
            prev = v;
        }
    }

    #[test]
    fn freckle_and_taper_match_thesis() {
        assert_eq!(freckle_amount(0.0, 1.0), 1.0);
        assert!((freckle_amount(0.5, 1.0) - 0.4).abs() < 1e-6);
        assert_eq!(freckle_amount(1.0 / 1.2, 1.0), 0.0);
        assert_eq!(freckle_amount(5.0, 1.0), 0.0);
        assert_eq!(wrinkle_taper(0.0, 3.0), 0.0);
        assert!((wrinkle_taper(0.25, 3.0) - 1.5).abs() < 1e-6);
        assert!((wrinkle_taper(0.5, 3.0) - 3.0).abs() < 1e-6);
        assert!((wrinkle_taper(0.75, 3.0) - 1.5).abs() < 1e-6);
        assert_eq!(wrinkle_taper(1.0, 3.0), 0.0);
    }

    #[test]
    fn follicle_and_wrinkle_profiles_are_bounded_and_continuous() {
        assert_eq!(follicle_alpha(0.01, 0.04, 0.1), 1.0);
        assert!((follicle_alpha(0.04 + 1e-6, 0.04, 0.1) - 1.0).abs() < 1e-3);
        assert!(follicle_alpha(0.0999, 0.04, 0.1) < 0.02);
        assert_eq!(wrinkle_profile(0.0), 1.0);
        assert!((wrinkle_profile(0.5) - (1.0 - 0.5f32.powf(0.2))).abs() < 1e-6);
        assert!(wrinkle_profile(0.999) < 0.001);
        assert_eq!(wrinkle_profile(1.5), 0.0);
        assert_eq!(smooth_bump(0.0, 1.0), 1.0);
        assert_eq!(smooth_bump(1.0, 1.0), 0.0);
    }
}
