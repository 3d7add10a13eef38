//! Render BRDF models as the model matcher sees them (thesis §4.6: a material model is a map
//! M : [P] → (Ω → Ω → R+)), split into shape parameters θ and weights that enter linearly:
//! f_c(ωi, ωo) = offset(θ) + kd_c · diffuse(θ) + Σ_k s_k · lobe_k(θ), for colour channel c.
//!
//! The split lets the fitter solve the linear weights exactly for every θ it tries (variable
//! projection) and anneal only over θ. Directions are in the local frame, z = surface normal.
//! The models themselves live one per module; [`crate::model_kind`] lists them.

/// Refractive index of the skin surface, the stratum corneum's 1.55 (BioSpec, Krishnaswamy &
/// Baranoski 2004; as in the optics): the Fresnel terms [`Dirs`] caches for the skin model.
pub const SKIN_SURFACE_INDEX: f64 = derma_optics::specimen::LAYER_INDEX[0];

/// At most this many shared linear lobes.
pub const MAX_LOBES: usize = 3;

/// The cosines a BRDF needs, for light direction l and view direction v (both leaving the
/// surface, unit length, z up) and their half vector h.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dirs {
    /// cos θ of the light direction.
    pub n_l: f64,
    /// cos θ of the view direction.
    pub n_v: f64,
    /// cos θ of the half vector.
    pub n_h: f64,
    /// h·l = h·v.
    pub h_l: f64,
    /// Exact Fresnel reflectance of the skin surface (index [`SKIN_SURFACE_INDEX`]) at h·l,
    /// n·l and n·v: geometry only, so
    /// computed once per direction pair rather than at every fit step.
    pub skin_fresnel: [f64; 3],
    /// ln sinθh (−∞ at the normal), for the sheen distribution's power of sinθh.
    pub ln_sin_h: f64,
}

impl Dirs {
    /// From light direction `l` and view direction `v` (unit, leaving the surface, z up).
    pub fn new(l: [f64; 3], v: [f64; 3]) -> Self {
        let s = [l[0] + v[0], l[1] + v[1], l[2] + v[2]];
        let len = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt().max(1e-300);
        let h = s.map(|x| x / len);
        Self::from_cosines(
            l[2],
            v[2],
            h[2],
            (h[0] * l[0] + h[1] * l[1] + h[2] * l[2]).clamp(0.0, 1.0),
        )
    }

    /// From the four cosines.
    pub fn from_cosines(n_l: f64, n_v: f64, n_h: f64, h_l: f64) -> Self {
        let f = |c: f64| crate::fresnel::fresnel_unpolarised(c, 1.0, SKIN_SURFACE_INDEX);
        Self {
            n_l,
            n_v,
            n_h,
            h_l,
            skin_fresnel: [f(h_l), f(n_l), f(n_v)],
            ln_sin_h: (1.0 - n_h * n_h).max(0.0).sqrt().ln(),
        }
    }

    /// Light at zenith `theta_i` in the x–z plane, view at zenith `theta_o` and azimuth `phi`
    /// from the light's azimuth (φ = π is the mirror direction).
    pub fn from_angles(theta_i: f64, theta_o: f64, phi: f64) -> Self {
        let l = [theta_i.sin(), 0.0, theta_i.cos()];
        let v = [
            theta_o.sin() * phi.cos(),
            theta_o.sin() * phi.sin(),
            theta_o.cos(),
        ];
        Self::new(l, v)
    }
}

/// The model's terms at one pair of directions, for one θ.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Basis {
    /// Term with no linear weight (white).
    pub offset: f64,
    /// Multiplies the diffuse colour kd_c.
    pub diffuse: f64,
    /// Multiply the shared (white) lobe weights s_k.
    pub lobes: [f64; MAX_LOBES],
}

/// One shape parameter and its search range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapeParam {
    /// Name in tables ("alpha").
    pub name: &'static str,
    /// Lower bound.
    pub lo: f64,
    /// Upper bound.
    pub hi: f64,
    /// Anneal in log space (for parameters spanning decades).
    pub log: bool,
}

/// A render BRDF model.
pub trait RenderModel: Send + Sync {
    /// Command-line name ("ggx").
    fn name(&self) -> &'static str;
    /// Shape parameters θ.
    fn shape(&self) -> &'static [ShapeParam];
    /// Names and upper bounds of the shared linear lobe weights (lower bound 0).
    fn lobes(&self) -> &'static [(&'static str, f64)];
    /// Upper bound of the diffuse colour kd.
    fn kd_max(&self) -> f64 {
        1.5
    }
    /// The terms at `d` for shape `theta`.
    fn basis(&self, theta: &[f64], d: &Dirs) -> Basis;
}

/// Parameter vector layout shared by every model: [kd_r, kd_g, kd_b, s_1..s_K, θ_1..θ_P].
pub fn param_names(m: &dyn RenderModel) -> Vec<String> {
    let mut v: Vec<String> = ["kd_r", "kd_g", "kd_b"].map(String::from).to_vec();
    v.extend(m.lobes().iter().map(|(n, _)| n.to_string()));
    v.extend(m.shape().iter().map(|p| p.name.to_string()));
    v
}

/// Number of parameters in the full vector.
pub fn n_params(m: &dyn RenderModel) -> usize {
    3 + m.lobes().len() + m.shape().len()
}

/// Lower and upper bounds of the full parameter vector.
pub fn bounds(m: &dyn RenderModel) -> (Vec<f64>, Vec<f64>) {
    let mut lo = vec![0.0; 3];
    let mut hi = vec![m.kd_max(); 3];
    for &(_, h) in m.lobes() {
        lo.push(0.0);
        hi.push(h);
    }
    for p in m.shape() {
        lo.push(p.lo);
        hi.push(p.hi);
    }
    (lo, hi)
}

/// Combines a basis with the linear weights of `params` into RGB.
#[inline]
pub fn combine(b: &Basis, params: &[f64], n_lobes: usize) -> [f64; 3] {
    let mut white = b.offset;
    for k in 0..n_lobes {
        white += params[3 + k] * b.lobes[k];
    }
    [0, 1, 2].map(|c| white + params[c] * b.diffuse)
}

/// Evaluates model `m` with full parameter vector `params` (see [`param_names`]) → RGB BRDF (sr⁻¹).
pub fn eval(m: &dyn RenderModel, params: &[f64], d: &Dirs) -> [f64; 3] {
    let nl = m.lobes().len();
    let b = m.basis(&params[3 + nl..], d);
    combine(&b, params, nl)
}

#[cfg(test)]
pub(crate) mod checks {
    //! Property checks every model must pass.
    use super::*;

    /// A fixed spread of direction pairs over the upper hemisphere.
    pub fn direction_pairs() -> Vec<(f64, f64, f64)> {
        let mut v = Vec::new();
        for i in 0..8 {
            for o in 0..8 {
                for p in 0..7 {
                    v.push((
                        0.05 + i as f64 * 0.19,
                        0.07 + o as f64 * 0.185,
                        p as f64 * 0.52,
                    ));
                }
            }
        }
        v
    }

    /// f(l, v) = f(v, l) for every pair.
    pub fn assert_reciprocal(m: &dyn RenderModel, params: &[f64]) {
        for (ti, to, phi) in direction_pairs() {
            let a = eval(m, params, &Dirs::from_angles(ti, to, phi));
            let b = eval(m, params, &Dirs::from_angles(to, ti, phi));
            for c in 0..3 {
                let tol = 1e-9 * a[c].abs().max(1.0);
                assert!(
                    (a[c] - b[c]).abs() <= tol,
                    "{} not reciprocal at ({ti}, {to}, {phi}): {a:?} vs {b:?}",
                    m.name()
                );
            }
        }
    }

    /// Directional albedo ∫ f cosθo dωo at incidence `theta_i`, by a midpoint rule in
    /// (cos²θo, φ) fine enough for lobes with α ≥ 0.1.
    pub fn albedo(m: &dyn RenderModel, params: &[f64], theta_i: f64) -> [f64; 3] {
        let (nu, np) = (400, 400);
        let mut sum = [0.0; 3];
        for a in 0..nu {
            // u = sin²θo uniform: cosθo dω = ½ du dφ.
            let u = (a as f64 + 0.5) / nu as f64;
            let to = u.sqrt().asin();
            for b in 0..np {
                let phi = (b as f64 + 0.5) / np as f64 * std::f64::consts::TAU;
                let f = eval(m, params, &Dirs::from_angles(theta_i, to, phi));
                for c in 0..3 {
                    sum[c] += f[c];
                }
            }
        }
        let w = 0.5 / nu as f64 * std::f64::consts::TAU / np as f64;
        sum.map(|s| s * w)
    }
}
