//! The skin surface as a Smith microsurface: Trowbridge–Reitz (GGX) normals, sampled in
//! proportion to their visible area (Heitz 2018), shadowed and masked by the Smith model, with the
//! light that masking catches scattered again by the dielectric random walk of Heitz, Hanika,
//! d'Eon & Dachsbacher 2016 ("Multiple-scattering microfacet BSDFs with the Smith model", §4–5,
//! uniform heights), so the surface neither loses energy nor piles it up at grazing angles.
//!
//! Directions here are local to one side of the surface: z along the macro normal on that side.

/// Most events of one walk; beyond it the ray leaves along the macro normal of the side it is on
/// (Heitz et al. 2016 stop their walks too; at α = 0.75 a walk of more than 20 events was not
/// seen in 10⁷ walks).
pub const MAX_EVENTS: u32 = 256;

/// A zero draw is taken as the smallest non-zero one (2⁻²⁴, the draws' resolution), here and
/// in the WGSL port, so a height never collapses to the bottom of the distribution.
const MIN_DRAW: f64 = 1.0 / 16_777_216.0;

type V3 = [f64; 3];

#[inline]
fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
fn normalise(a: V3) -> V3 {
    let l = dot(a, a).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}

#[inline]
fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The GGX / Trowbridge–Reitz normal distribution D(m) for micro-normals with cosine `cos_m` to
/// the macro normal (Walter et al. 2007 eq. 33; Trowbridge & Reitz 1975: the normals of
/// spheroids with aspect α).
pub fn d_ggx(cos_m: f64, alpha: f64) -> f64 {
    if cos_m <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let c2 = cos_m * cos_m;
    let t = c2 * (a2 - 1.0) + 1.0;
    a2 / (std::f64::consts::PI * t * t)
}

/// Smith's Λ for a direction with cosine `cos` (> 0) to the macro normal, GGX (Heitz 2014,
/// "Understanding the masking-shadowing function", eq. 72): (−1 + √(1 + α² tan²θ)) / 2.
pub fn lambda(cos: f64, alpha: f64) -> f64 {
    if cos >= 1.0 {
        return 0.0;
    }
    if cos <= 0.0 {
        return f64::INFINITY;
    }
    let tan2 = (1.0 - cos * cos) / (cos * cos);
    0.5 * (-1.0 + (1.0 + alpha * alpha * tan2).sqrt())
}

/// A micro-normal drawn from the distribution of normals visible from `wi` (unit, either
/// hemisphere): D_wi(m) ∝ ⟨wi, m⟩⁺ D(m), for uniform `u1`, `u2` (Heitz 2018, "Sampling the GGX
/// distribution of visible normals", JCGT 7(4), §3: stretch to the unit hemisphere, sample its
/// projection, unstretch). Below the horizon the projected hemisphere is a half-disk less a
/// half-ellipse, which the same warp covers.
pub fn sample_visible_normal(wi: V3, alpha: f64, u1: f64, u2: f64) -> V3 {
    let vh = normalise([alpha * wi[0], alpha * wi[1], wi[2]]);
    let len2 = vh[0] * vh[0] + vh[1] * vh[1];
    let t1 = if len2 > 0.0 {
        let l = len2.sqrt();
        [-vh[1] / l, vh[0] / l, 0.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let t2 = cross(vh, t1);
    let r = u1.sqrt();
    let phi = std::f64::consts::TAU * u2;
    let (sp, cp) = phi.sin_cos();
    let p1 = r * cp;
    let s = 0.5 * (1.0 + vh[2]);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * sp;
    let p3 = (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
    let nh = [
        p1 * t1[0] + p2 * t2[0] + p3 * vh[0],
        p1 * t1[1] + p2 * t2[1] + p3 * vh[1],
        p1 * t1[2] + p2 * t2[2] + p3 * vh[2],
    ];
    normalise([alpha * nh[0], alpha * nh[1], nh[2].max(1e-9)])
}

/// Where a walk ended: the direction it leaves in, in the frame of the side it started on (z > 0:
/// back out on that side; z < 0: through to the other side), and its events.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Exit {
    /// Unit direction of travel, local to the starting side.
    pub dir: V3,
    /// Reflections and refractions on the way.
    pub events: u32,
}

/// A ray arriving along `d` (local to its side: d.z < 0, travelling into the surface) from a
/// medium of index `n1` onto a rough interface with a medium of index `n2` walks over the
/// microsurface until it escapes on either side (Heitz et al. 2016 §5, dielectric, with uniform
/// heights: C₁(h) = (h + 1)/2 on [−1, 1]). Each event draws a height, a visible normal and a
/// Fresnel choice (unpolarised, `fresnel(cos, n1, n2)`) from `uniform`.
pub fn walk(
    d: V3,
    n1: f64,
    n2: f64,
    alpha: f64,
    fresnel: impl Fn(f64, f64, f64) -> f64,
    mut uniform: impl FnMut() -> f64,
) -> Exit {
    // Directions in the starting side's frame; `flip` says whether the ray is on the other side
    // (whose frame has z reversed), `c1` is C₁ of its height in the frame of the side it is on.
    let mut dir = d;
    let mut flip = false;
    let mut c1 = 1.0f64;
    let (mut na, mut nb) = (n1, n2);
    for events in 0..MAX_EVENTS {
        let z = if flip { -dir[2] } else { dir[2] };
        let u = uniform();
        if z > 0.0 {
            // Upwards: escapes with probability C₁^Λ, else meets the surface higher up.
            let lam = lambda(z, alpha);
            if 1.0 - u <= c1.powf(lam) {
                return Exit { dir, events };
            }
            c1 /= ((1.0 - u).ln() / lam).exp();
        } else {
            // Downwards: always meets it, lower down.
            let lam = lambda(-z, alpha);
            c1 *= (u.max(MIN_DRAW).ln() / (1.0 + lam)).exp();
        }
        // The facet it meets, seen from wi = −dir in the frame of the side it is on.
        let wi_local = [-dir[0], -dir[1], -z];
        let mut m = sample_visible_normal(wi_local, alpha, uniform(), uniform());
        if flip {
            m[2] = -m[2];
        }
        let wi = [-dir[0], -dir[1], -dir[2]];
        let cos_i = dot(wi, m).max(0.0);
        if uniform() < fresnel(cos_i, na, nb) {
            dir = normalise([
                -wi[0] + 2.0 * cos_i * m[0],
                -wi[1] + 2.0 * cos_i * m[1],
                -wi[2] + 2.0 * cos_i * m[2],
            ]);
        } else {
            let eta = na / nb;
            let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
            let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
            let k = eta * cos_i - cos_t;
            dir = normalise([
                eta * dir[0] + k * m[0],
                eta * dir[1] + k * m[1],
                eta * dir[2] + k * m[2],
            ]);
            // Through to the other side: its heights mirror (C₁(−h) = 1 − C₁(h)).
            flip = !flip;
            c1 = 1.0 - c1;
            std::mem::swap(&mut na, &mut nb);
        }
    }
    Exit {
        dir: [0.0, 0.0, if flip { -1.0 } else { 1.0 }],
        events: MAX_EVENTS,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, TAU};

    /// ∫ f(m) dm over the upper hemisphere (midpoint rule in θ, φ).
    fn hemisphere(f: impl Fn(V3) -> f64, n: usize) -> f64 {
        let (dt, dp) = (FRAC_PI_2 / n as f64, TAU / (2 * n) as f64);
        let mut s = 0.0;
        for i in 0..n {
            let t = (i as f64 + 0.5) * dt;
            let (st, ct) = t.sin_cos();
            for j in 0..2 * n {
                let p = (j as f64 + 0.5) * dp;
                s += f([st * p.cos(), st * p.sin(), ct]) * st * dt * dp;
            }
        }
        s
    }

    fn dir(theta: f64) -> V3 {
        [theta.sin(), 0.0, theta.cos()]
    }

    #[test]
    fn d_is_normalised_and_lambda_gives_the_projected_area() {
        for alpha in [0.2, 0.5, 0.75, 1.0] {
            // ∫ D(m) cos θm dm = 1 (Walter et al. 2007 eq. 4).
            let one = hemisphere(|m| d_ggx(m[2], alpha) * m[2], 400);
            assert!((one - 1.0).abs() < 2e-3, "α {alpha}: {one}");
            // ∫ ⟨ω, m⟩⁺ D(m) dm = cos θ (1 + Λ(ω)) above the horizon, |cos θ| Λ(−ω) below
            // (Heitz 2014 eqs. 21, 29): the Smith Λ against the distribution it belongs to.
            for theta in [0.3, 1.0, 1.4, 1.5] {
                let w = dir(theta);
                let area = hemisphere(|m| dot(w, m).max(0.0) * d_ggx(m[2], alpha), 400);
                let want = theta.cos() * (1.0 + lambda(theta.cos(), alpha));
                assert!(
                    (area / want - 1.0).abs() < 5e-3,
                    "α {alpha} θ {theta}: {area} vs {want}"
                );
                let below = [w[0], w[1], -w[2]];
                let area = hemisphere(|m| dot(below, m).max(0.0) * d_ggx(m[2], alpha), 400);
                let want = theta.cos() * lambda(theta.cos(), alpha);
                assert!(
                    (area / want - 1.0).abs() < 1e-2,
                    "below, α {alpha} θ {theta}: {area} vs {want}"
                );
            }
        }
    }

    #[test]
    fn visible_normals_follow_their_distribution_above_and_below_the_horizon() {
        let mut rng = crate::photon_rng::PhotonRng::new(7, 1);
        let mut next = || rng.uniform();
        for alpha in [0.3, 0.75] {
            for (theta, up) in [
                (0.2, true),
                (1.2, true),
                (1.52, true),
                (1.0, false),
                (1.45, false),
            ] {
                let w = if up {
                    dir(theta)
                } else {
                    let d = dir(theta);
                    [d[0], d[1], -d[2]]
                };
                // Quadrature of the mean of m.z and of m.x under D_w.
                let wgt = |m: V3| dot(w, m).max(0.0) * d_ggx(m[2], alpha);
                let norm = hemisphere(wgt, 300);
                let mz = hemisphere(|m| wgt(m) * m[2], 300) / norm;
                let mx = hemisphere(|m| wgt(m) * m[0], 300) / norm;
                let n = 200_000;
                let (mut sz, mut sx) = (0.0, 0.0);
                for _ in 0..n {
                    let m = sample_visible_normal(w, alpha, next(), next());
                    assert!(m[2] > 0.0, "a micro-normal below the surface");
                    assert!(dot(w, m) >= -1e-9, "a micro-normal facing away from ω");
                    sz += m[2];
                    sx += m[0];
                }
                let (sz, sx) = (sz / n as f64, sx / n as f64);
                assert!(
                    (sz - mz).abs() < 4e-3,
                    "α {alpha} θ {theta} up {up}: E[m.z] {sz} vs {mz}"
                );
                assert!(
                    (sx - mx).abs() < 6e-3,
                    "α {alpha} θ {theta} up {up}: E[m.x] {sx} vs {mx}"
                );
            }
        }
    }

    #[test]
    fn a_walk_always_leaves_and_a_smooth_limit_is_fresnel() {
        let fresnel = crate::fresnel::fresnel_unpolarised;
        let mut rng = crate::photon_rng::PhotonRng::new(3, 2);
        let mut next = || rng.uniform();
        // A nearly smooth surface reflects at normal incidence with Fresnel's ((n−1)/(n+1))².
        let n = 100_000;
        let mut refl = 0usize;
        for _ in 0..n {
            let e = walk([0.0, 0.0, -1.0], 1.0, 1.5, 0.01, fresnel, &mut next);
            assert!((dot(e.dir, e.dir) - 1.0).abs() < 1e-9);
            if e.dir[2] > 0.0 {
                refl += 1;
            }
        }
        let r = refl as f64 / n as f64;
        assert!((r - 0.04).abs() < 0.003, "reflectance {r}");
        // …and at grazing incidence (83°) with Fresnel's value there.
        let d = dir(1.45);
        let mut refl = 0usize;
        for _ in 0..n {
            let e = walk([d[0], d[1], -d[2]], 1.0, 1.4, 0.01, fresnel, &mut next);
            refl += (e.dir[2] > 0.0) as usize;
        }
        let (r, want) = (refl as f64 / n as f64, fresnel(1.45f64.cos(), 1.0, 1.4));
        assert!(
            (r - want).abs() < 0.01,
            "grazing reflectance {r} vs Fresnel {want}"
        );
        // Rough (the skin's α): every walk ends before the cap; some scatter several times (the
        // light masking caught), and more so at grazing incidence than at normal incidence.
        let mean_events = |d: V3, next: &mut dyn FnMut() -> f64| {
            let (mut most, mut total) = (0u32, 0u64);
            for _ in 0..n {
                let e = walk(d, 1.0, 1.4, 0.75, fresnel, &mut *next);
                assert!(e.events < MAX_EVENTS);
                most = most.max(e.events);
                total += e.events as u64;
            }
            (most, total as f64 / n as f64)
        };
        let (most, grazing) = mean_events([d[0], d[1], -d[2]], &mut next);
        let (_, normal) = mean_events([0.0, 0.0, -1.0], &mut next);
        assert!(most >= 3, "no walk scattered more than twice ({most})");
        assert!(
            normal >= 1.0 && grazing > normal + 0.3,
            "events per walk: {normal} at 0°, {grazing} at 83°"
        );
    }
}
