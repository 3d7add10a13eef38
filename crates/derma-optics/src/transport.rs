//! One photon through a layered specimen: BioSpec's path tracer (thesis §4.4) with the thesis'
//! modifications (§4.5): Trowbridge–Reitz micro-normals for both the Fresnel test and the
//! reflection/refraction at the skin surface, full unpolarised Fresnel, Henyey–Greenstein
//! scattering inside layers.
//!
//! Photons carry a weight (implicit capture, as MCML: Wang, Jacques & Zheng 1995): at each
//! interaction the absorbed fraction μa/μt of the weight is deposited and the rest scatters, so
//! every photon contributes to absorption per layer and per chromophore instead of one in many.
//! Below a weight of 10⁻⁴ a photon plays Russian roulette (survives with probability 1/10 and
//! weight ×10), which keeps the estimate unbiased; the weight roulette creates or destroys is
//! booked so that R + T + A balances the launched weight exactly. Interfaces are stochastic
//! (reflect with probability F), except the first entry through a smooth surface, where the
//! specular part is split off deterministically (MCML's R_sp).

use crate::fresnel::fresnel_unpolarised;
use crate::layer::{Bottom, Stack, Surface, N_ABSORBERS};
use crate::microfacet::tr_cos_zenith;
use crate::microsurface;
use crate::photon_rng::PhotonRng;
use crate::tally::{BrdfBins, ProfileBins, Tally, ABSORBED, R_DIFFUSE, R_SPECULAR, TRANSMITTED};
use std::f64::consts::TAU;

/// Russian roulette threshold and survival odds (MCML defaults, Wang et al. 1995 §3.9).
pub const ROULETTE_WEIGHT: f64 = 1e-4;
/// See [`ROULETTE_WEIGHT`].
pub const ROULETTE_CHANCE: f64 = 0.1;
/// Interactions after which a photon is abandoned (never reached in practice; bounds GPU loops).
pub const MAX_STEPS: u64 = 100_000_000;
/// Tries at drawing a micro-normal that faces the ray before falling back to the macro normal.
const FACING_TRIES: u32 = 8;

/// How light arrives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Incidence {
    /// A pencil beam along the normal.
    Normal,
    /// Zenith θi = arcsin ρ for uniform ρ (thesis §4.5.2): every incidence the BRDF needs,
    /// weighted by cosθi as diffuse illumination is.
    ArcsinZenith,
}

/// A stack flattened for the inner loop: per-layer arrays (structure of arrays).
pub struct Prepared {
    /// Depths of the layer boundaries, mm (layers + 1 values, from 0).
    pub z: Vec<f64>,
    /// Total interaction coefficient μt = μa + μs per layer, mm⁻¹.
    pub mut_: Vec<f64>,
    /// Albedo complement μa / μt per layer.
    pub mua_over_mut: Vec<f64>,
    /// 1 / μt per layer (0 for a clear layer).
    pub inv_mut: Vec<f64>,
    /// Henyey–Greenstein anisotropy per layer.
    pub g: Vec<f64>,
    /// Refractive index per layer.
    pub n: Vec<f64>,
    /// Share of each absorber class in μa per layer.
    pub share: Vec<[f64; N_ABSORBERS]>,
    /// Index of the medium above.
    pub n_above: f64,
    /// What lies below.
    pub bottom: Bottom,
    /// The top surface.
    pub surface: Surface,
}

impl Prepared {
    /// Flattens `s`.
    pub fn new(s: &Stack) -> Self {
        let mut_: Vec<f64> = s.layers.iter().map(|l| l.mua + l.mus).collect();
        Self {
            z: s.boundaries(),
            mua_over_mut: s
                .layers
                .iter()
                .zip(&mut_)
                .map(|(l, &t)| if t > 0.0 { l.mua / t } else { 0.0 })
                .collect(),
            inv_mut: mut_
                .iter()
                .map(|&t| if t > 0.0 { 1.0 / t } else { 0.0 })
                .collect(),
            mut_,
            g: s.layers.iter().map(|l| l.g).collect(),
            n: s.layers.iter().map(|l| l.n).collect(),
            share: s.layers.iter().map(|l| l.absorber_share).collect(),
            n_above: s.n_above,
            bottom: s.bottom,
            surface: s.surface,
        }
    }
}

/// Where to record exits, and with which per-channel weights for this photon's wavelength.
pub struct Recorder<'a> {
    /// Bins of the sampled BRDF, when recorded.
    pub brdf: Option<BrdfBins>,
    /// Bins of the radial exit profile, when recorded.
    pub profile: Option<ProfileBins>,
    /// BRDF channel weights of this wavelength (e.g. its linear-sRGB share × number of
    /// wavelengths), one per channel.
    pub channel_weights: &'a [f64],
    /// The photon's wavelength sample.
    pub lambda: usize,
}

type V3 = [f64; 3];

#[inline]
fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Henyey–Greenstein cosine of the scattering angle for uniform `xi` (Henyey & Greenstein 1941;
/// inversion as in MCML, Wang et al. 1995 eq. 3.28).
#[inline]
pub fn hg_cos(g: f64, xi: f64) -> f64 {
    if g.abs() < 1e-6 {
        2.0 * xi - 1.0
    } else {
        let t = (1.0 - g * g) / (1.0 - g + 2.0 * g * xi);
        ((1.0 + g * g - t * t) / (2.0 * g)).clamp(-1.0, 1.0)
    }
}

/// Rotates direction `u` by polar cosine `ct` and azimuth `phi` (MCML eq. 3.30).
#[inline]
pub fn spin(u: V3, ct: f64, phi: f64) -> V3 {
    let st = (1.0 - ct * ct).max(0.0).sqrt();
    let (sp, cp) = phi.sin_cos();
    if u[2].abs() > 0.99999 {
        [st * cp, st * sp, ct * u[2].signum()]
    } else {
        let temp = (1.0 - u[2] * u[2]).sqrt();
        [
            st * (u[0] * u[2] * cp - u[1] * sp) / temp + u[0] * ct,
            st * (u[1] * u[2] * cp + u[0] * sp) / temp + u[1] * ct,
            -st * cp * temp + u[2] * ct,
        ]
    }
}

/// Fresnel event at an interface with unit normal `m` facing the incident side: reflects with
/// probability F(cosθi), else refracts by Snell's law (thesis §4.5.1).
#[inline]
fn interface(u: V3, m: V3, n1: f64, n2: f64, xi: f64) -> V3 {
    let cos_i = -dot(u, m);
    let f = fresnel_unpolarised(cos_i, n1, n2);
    if xi < f {
        [
            u[0] + 2.0 * cos_i * m[0],
            u[1] + 2.0 * cos_i * m[1],
            u[2] + 2.0 * cos_i * m[2],
        ]
    } else {
        let eta = n1 / n2;
        let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
        let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
        let k = eta * cos_i - cos_t;
        [
            eta * u[0] + k * m[0],
            eta * u[1] + k * m[1],
            eta * u[2] + k * m[2],
        ]
    }
}

/// A Trowbridge–Reitz micro-normal about the macro normal (0, 0, `side`) that faces the ray `u`
/// (−u·m > 0); after [`FACING_TRIES`] misses, the macro normal.
#[inline]
fn micro_normal(u: V3, sigma: f64, side: f64, rng: &mut PhotonRng) -> V3 {
    for _ in 0..FACING_TRIES {
        let c = tr_cos_zenith(rng.uniform(), sigma);
        let phi = TAU * rng.uniform();
        let s = (1.0 - c * c).max(0.0).sqrt();
        let (sp, cp) = phi.sin_cos();
        let m = [s * cp, s * sp, side * c];
        if dot(u, m) < 0.0 {
            return m;
        }
    }
    [0.0, 0.0, side]
}

/// The top surface seen by ray `u` hitting it from index `n1` into `n2`; `side` is the z of the
/// macro normal facing the ray (−1 from above, +1 from below).
#[inline]
fn top_surface(p: &Prepared, u: V3, n1: f64, n2: f64, side: f64, rng: &mut PhotonRng) -> V3 {
    let m = match p.surface {
        Surface::Smooth => [0.0, 0.0, side],
        Surface::TrowbridgeReitz { sigma } => micro_normal(u, sigma, side, rng),
        Surface::Smith { alpha } => {
            // In the frame of the side the ray comes from, z along the macro normal there.
            let d = [u[0], u[1], u[2] * side];
            let e = microsurface::walk(d, n1, n2, alpha, fresnel_unpolarised, || rng.uniform());
            return [e.dir[0], e.dir[1], e.dir[2] * side];
        }
    };
    interface(u, m, n1, n2, rng.uniform())
}

#[inline]
fn normalise(u: V3) -> V3 {
    let l = dot(u, u).sqrt();
    [u[0] / l, u[1] / l, u[2] / l]
}

/// Records weight `w` leaving through the top at `pos` along `u` (z down, so u.z < 0).
#[inline]
fn record_exit(
    t: &mut Tally,
    rec: &Recorder,
    ti: Option<usize>,
    pos: V3,
    u: V3,
    w: f64,
    diffuse: bool,
) {
    if let (Some(b), Some(ti)) = (rec.brdf, ti) {
        let (to, p) = b.out_bin([u[0], u[1], -u[2]]);
        let base = b.index(ti, to, p) * t.brdf_channels;
        for (c, &cw) in rec.channel_weights.iter().enumerate() {
            t.brdf[base + c] += w * cw;
        }
    }
    if diffuse {
        if let Some(pb) = rec.profile {
            if let Some(b) = pb.bin(pos[0].hypot(pos[1])) {
                t.profile[rec.lambda * pb.bins + b] += w;
            }
        }
    }
}

/// Traces photon `index` of a run with `seed` through `p` and adds it to `t`.
pub fn trace(
    p: &Prepared,
    seed: u64,
    index: u64,
    incidence: Incidence,
    rec: &Recorder,
    t: &mut Tally,
) {
    let mut rng = PhotonRng::new(seed, index);
    let mut out = [0.0f64; 4];
    let nl = p.mut_.len();
    // Incoming direction of travel (z points into the specimen), from the +x side.
    let (sin_i, cos_i) = match incidence {
        Incidence::Normal => (0.0, 1.0),
        Incidence::ArcsinZenith => {
            let s = rng.uniform();
            (s, (1.0 - s * s).sqrt())
        }
    };
    let ti = rec.brdf.map(|b| {
        let k = b.theta_in_bin(sin_i.asin());
        t.brdf_in[k] += 1;
        k
    });
    let mut u: V3 = [-sin_i, 0.0, cos_i];
    let mut pos: V3 = [0.0; 3];
    let mut w = 1.0f64;

    // Entry through the top surface.
    match p.surface {
        Surface::Smooth => {
            let f = fresnel_unpolarised(cos_i, p.n_above, p.n[0]);
            out[R_SPECULAR] = f;
            if f > 0.0 {
                record_exit(t, rec, ti, pos, [u[0], u[1], -u[2]], f, false);
            }
            w = 1.0 - f;
            let eta = p.n_above / p.n[0];
            let sin_t = eta * sin_i;
            u = [-sin_t, 0.0, (1.0 - sin_t * sin_t).sqrt()];
        }
        Surface::TrowbridgeReitz { .. } | Surface::Smith { .. } => {
            let v = normalise(top_surface(p, u, p.n_above, p.n[0], -1.0, &mut rng));
            if v[2] <= 0.0 {
                out[R_SPECULAR] = 1.0;
                record_exit(t, rec, ti, pos, v, 1.0, false);
                w = 0.0;
            }
            u = v;
        }
    }

    let mut layer = 0usize;
    let mut s_left = 0.0f64;
    let mut steps = 0u64;
    while w > 0.0 {
        steps += 1;
        if steps > MAX_STEPS {
            // A photon trapped this long is abandoned; its weight is booked with roulette.
            t.roulette -= w;
            break;
        }
        if s_left <= 0.0 {
            s_left = -(1.0 - rng.uniform()).ln();
        }
        let mu_t = p.mut_[layer];
        let dist = if u[2] > 0.0 {
            (p.z[layer + 1] - pos[2]) / u[2]
        } else if u[2] < 0.0 {
            (p.z[layer] - pos[2]) / u[2]
        } else {
            f64::INFINITY
        };
        if mu_t * dist <= s_left {
            // Hop to the boundary and cross it (or not).
            pos[0] += u[0] * dist;
            pos[1] += u[1] * dist;
            s_left -= mu_t * dist;
            let up = u[2] < 0.0;
            pos[2] = if up { p.z[layer] } else { p.z[layer + 1] };
            if up && layer == 0 {
                let v = normalise(top_surface(p, u, p.n[0], p.n_above, 1.0, &mut rng));
                if v[2] < 0.0 {
                    out[R_DIFFUSE] += w;
                    record_exit(t, rec, ti, pos, v, w, true);
                    w = 0.0;
                } else {
                    u = v;
                }
            } else if !up && layer == nl - 1 {
                match p.bottom {
                    Bottom::Medium { n } => {
                        let v = interface(u, [0.0, 0.0, -1.0], p.n[layer], n, rng.uniform());
                        if v[2] > 0.0 {
                            out[TRANSMITTED] += w;
                            w = 0.0;
                        } else {
                            u = v;
                        }
                    }
                    Bottom::Lambertian { albedo } => {
                        out[TRANSMITTED] += w * (1.0 - albedo);
                        w *= albedo;
                        let c = rng.uniform().sqrt();
                        let phi = TAU * rng.uniform();
                        let s = (1.0 - c * c).max(0.0).sqrt();
                        u = [s * phi.cos(), s * phi.sin(), -c];
                    }
                }
            } else {
                let next = if up { layer - 1 } else { layer + 1 };
                let (n1, n2) = (p.n[layer], p.n[next]);
                if n1 == n2 {
                    layer = next;
                } else {
                    let side = if up { 1.0 } else { -1.0 };
                    let v = interface(u, [0.0, 0.0, side], n1, n2, rng.uniform());
                    if (v[2] < 0.0) == up {
                        layer = next;
                    }
                    u = v;
                }
            }
        } else {
            // Hop inside the layer, deposit the absorbed fraction, scatter.
            let d = s_left * p.inv_mut[layer];
            s_left = 0.0;
            pos[0] += u[0] * d;
            pos[1] += u[1] * d;
            pos[2] += u[2] * d;
            let dw = w * p.mua_over_mut[layer];
            if dw > 0.0 {
                let sh = &p.share[layer];
                let a = &mut t.absorbed[layer];
                for c in 0..N_ABSORBERS {
                    a[c] += dw * sh[c];
                }
                out[ABSORBED] += dw;
                w -= dw;
            }
            let ct = hg_cos(p.g[layer], rng.uniform());
            u = spin(u, ct, TAU * rng.uniform());
            if w < ROULETTE_WEIGHT {
                if rng.uniform() < ROULETTE_CHANCE {
                    t.roulette += w * (1.0 / ROULETTE_CHANCE - 1.0);
                    w /= ROULETTE_CHANCE;
                } else {
                    t.roulette -= w;
                    w = 0.0;
                }
            }
        }
    }

    t.photons += 1;
    t.per_lambda_count[rec.lambda] += 1;
    for k in 0..4 {
        t.sum[k] += out[k];
        t.sum_sq[k] += out[k] * out[k];
        t.per_lambda[rec.lambda][k] += out[k];
    }
}
