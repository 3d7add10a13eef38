//! Unpolarised Fresnel reflectance at a dielectric interface and its hemispherical (diffuse)
//! average, used for the internal reflection of diffuse light at the skin surface.

/// Unpolarised Fresnel reflectance for light going from index `n1` into `n2` at incidence cosine
/// `cos_i` (Born & Wolf, §1.5.2): ½(r_s² + r_p²); 1 beyond the critical angle.
pub fn fresnel_unpolarised(cos_i: f64, n1: f64, n2: f64) -> f64 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin_t = n1 / n2 * (1.0 - cos_i * cos_i).max(0.0).sqrt();
    if sin_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin_t * sin_t).sqrt();
    let rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    let rp = (n1 * cos_t - n2 * cos_i) / (n1 * cos_t + n2 * cos_i);
    0.5 * (rs * rs + rp * rp)
}

/// Hemispherical reflectance of a Lambertian radiance field at the interface, seen from the side
/// of index `n1`: r = ∫ F(θ) 2 cosθ sinθ dθ over [0, π/2], by the midpoint rule (2000 steps).
pub fn diffuse_reflectance(n1: f64, n2: f64) -> f64 {
    let steps = 2000;
    let h = std::f64::consts::FRAC_PI_2 / steps as f64;
    (0..steps)
        .map(|k| {
            let t = (k as f64 + 0.5) * h;
            fresnel_unpolarised(t.cos(), n1, n2) * 2.0 * t.cos() * t.sin() * h
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_incidence_and_critical_angle() {
        // ((n−1)/(n+1))² at normal incidence.
        assert!((fresnel_unpolarised(1.0, 1.0, 1.4) - (0.4f64 / 2.4).powi(2)).abs() < 1e-12);
        // Reciprocal at normal incidence, total internal reflection beyond asin(1/1.4).
        assert!(
            (fresnel_unpolarised(1.0, 1.4, 1.0) - fresnel_unpolarised(1.0, 1.0, 1.4)).abs() < 1e-12
        );
        let crit = (1.0f64 / 1.4).asin();
        assert_eq!(fresnel_unpolarised((crit + 0.01).cos(), 1.4, 1.0), 1.0);
        assert!(fresnel_unpolarised(0.0, 1.0, 1.4) > 0.999);
    }

    #[test]
    fn diffuse_reflectance_matches_published_values() {
        // Internal diffuse reflectance for n = 1.4 relative to air: r_i ≈ 0.596 (e.g. Egan &
        // Hilgeman 1979 tables; also 1 − (1 − r_e)/n² with r_e ≈ 0.0744 external, Stokes relation).
        let ri = diffuse_reflectance(1.4, 1.0);
        let re = diffuse_reflectance(1.0, 1.4);
        assert!((re - 0.0744).abs() < 0.003, "external {re}");
        assert!(
            (ri - (1.0 - (1.0 - re) / 1.96)).abs() < 1e-3,
            "internal {ri}"
        );
    }
}
