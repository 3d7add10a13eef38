//! Kubelka–Munk two-flux theory for layered turbid media: the reflectance and transmittance of
//! one layer (Kubelka 1948, "New contributions to the optics of intensely light-scattering
//! materials, part I", JOSA 38) and the composition of stacked layers (Kubelka 1954, part II).

/// Reflectance and transmittance of a layer for diffuse light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LayerRT {
    /// Diffuse reflectance R.
    pub r: f64,
    /// Diffuse transmittance T.
    pub t: f64,
}

/// One homogeneous layer with KM absorption `k` and scattering `s` (per mm) and thickness `d` (mm):
/// a = (S+K)/S, b = √(a²−1), R = sinh(bSd) / (a sinh(bSd) + b cosh(bSd)),
/// T = b / (a sinh(bSd) + b cosh(bSd)) (Kubelka 1948, eqs. for a finite layer).
pub fn layer(k: f64, s: f64, d: f64) -> LayerRT {
    if s <= 1e-12 {
        return LayerRT {
            r: 0.0,
            t: (-k * d).exp(),
        };
    }
    if k <= 1e-12 {
        // Non-absorbing limit: R = Sd/(1+Sd), T = 1/(1+Sd).
        return LayerRT {
            r: s * d / (1.0 + s * d),
            t: 1.0 / (1.0 + s * d),
        };
    }
    let a = (s + k) / s;
    let b = (a * a - 1.0).sqrt();
    let x = b * s * d;
    // Divide numerator and denominator by cosh to stay finite for thick layers.
    let th = x.tanh();
    let denom = a * th + b;
    LayerRT {
        r: th / denom,
        t: b / (denom * x.cosh()),
    }
}

/// Layer `top` over layer `bottom` with multiple inter-reflections (Kubelka 1954):
/// R = R₁ + T₁² R₂ / (1 − R₁R₂), T = T₁T₂ / (1 − R₁R₂).
pub fn stack(top: LayerRT, bottom: LayerRT) -> LayerRT {
    let m = 1.0 / (1.0 - top.r * bottom.r);
    LayerRT {
        r: top.r + top.t * top.t * bottom.r * m,
        t: top.t * bottom.t * m,
    }
}

/// KM coefficients from transport coefficients by the diffusion correspondence K = 2 μa,
/// S = ¾ μs′ (van Gemert & Star 1987, "Relations between the Kubelka–Munk and the transport
/// equation models for anisotropic scattering", Lasers Life Sci. 1).
pub fn km_from_transport(mu_a: f64, mu_s_reduced: f64) -> (f64, f64) {
    (2.0 * mu_a, 0.75 * mu_s_reduced)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thick_layer_tends_to_r_infinity() {
        // R∞ = 1 + K/S − √((K/S)² + 2K/S) (Kubelka 1948).
        let (k, s) = (0.3, 5.0);
        let q: f64 = k / s;
        let r_inf = 1.0 + q - (q * q + 2.0 * q).sqrt();
        let l = layer(k, s, 100.0);
        assert!((l.r - r_inf).abs() < 1e-9 && l.t < 1e-9);
    }

    #[test]
    fn energy_is_conserved_and_absorption_vanishes_without_k() {
        for &(k, s, d) in &[
            (0.0, 3.0, 0.5),
            (0.1, 3.0, 0.5),
            (2.0, 0.5, 0.2),
            (1e-6, 10.0, 1.0),
        ] {
            let l = layer(k, s, d);
            assert!(l.r >= 0.0 && l.t >= 0.0 && l.r + l.t <= 1.0 + 1e-12);
            if k == 0.0 {
                assert!((l.r + l.t - 1.0).abs() < 1e-12);
            }
        }
        // Stacking two halves equals the whole layer.
        let whole = layer(0.4, 6.0, 0.3);
        let half = layer(0.4, 6.0, 0.15);
        let st = stack(half, half);
        assert!((st.r - whole.r).abs() < 1e-12 && (st.t - whole.t).abs() < 1e-12);
    }
}
