//! Photometric registration of the photos: each camera's pose and focal length are nudged so that
//! the detail it puts on the surface lands where the other photos put it (after Zhou & Koltun
//! 2014, "Color Map Optimization for 3D Reconstruction with Consumer Depth Cameras", §4).
//!
//! Cameras resected from a few dozen clicked points are off by about a pixel (issue 38's ground
//! truth: 0.6–1.4 px RMS from 1.5 px clicks); 1–2 mm freckles are a few pixels across, so each
//! photo paints them a little elsewhere. Zhou & Koltun refine every camera's pose by
//! Gauss–Newton on the disagreement between its colours and the surface's consensus. The
//! colour compared here is a *signal* per photo (the de-lit luminance: the photo's luminance
//! over its shading at the vertex, which [`crate::delight`] found) with one gain per photo
//! fitted alongside the pose and focal length; each photo is refined against the other photos' weighted mean
//! (all photos from the same consensus, each moving (n − 1)/n of its correction, so their order
//! does not matter and they meet at their mean), coarse to fine over an image pyramid, with
//! Cauchy weights. The corrections are kept for all photos or none: refused when one moves the
//! surface by more than [`RegisterOptions::max_shift_px`] or when the photos' misfits together
//! do not fall.
//! Comparing local contrast of the lit photos instead was tried and rejected: under key lights
//! that differ per view, shadow edges outweigh the skin's detail and the cameras drift.

use crate::camera::{pixel_distance, rodrigues, rotation_vector, Camera, Prepared};
use crate::photo::RgbImage;
use derma_core::image::Grey;
use derma_core::numerics::dense::solve;
use derma_core::numerics::robust::mad_sigma;
use derma_core::pyramid::{gaussian_pyramid, BURT_ADELSON};
use glam::{DVec2, DVec3, Vec3};
use rayon::prelude::*;
use serde::Serialize;

/// Settings of [`register`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegisterOptions {
    /// Pyramid levels (the coarsest first; each halves the resolution).
    pub levels: usize,
    /// Levenberg–Marquardt iterations per level.
    pub iterations: usize,
    /// The largest RMS displacement (pixels) of the surface's points a correction may make; a
    /// larger one refuses the registration (the calibration, not the registration, is then
    /// wrong).
    pub max_shift_px: f64,
}

impl Default for RegisterOptions {
    /// Authored: three levels (an 8 px error at full resolution is 2 px at the coarsest, within
    /// the reach of a one-pixel gradient); eight iterations a level (each stops early once a
    /// step gains less than 10⁻⁶ of the cost); 12 px, about ten times the clicked cameras'
    /// 0.6–1.4 px errors.
    fn default() -> Self {
        Self {
            levels: 3,
            iterations: 8,
            max_shift_px: 12.0,
        }
    }
}

/// The registration of one photo.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Registration {
    /// The refined camera (the one given when the correction was refused).
    pub camera: Camera,
    /// RMS displacement of the surface's points in the photo (pixels) from the camera given:
    /// the correction made, or where it was refused, the one that was tried.
    pub shift_px: f64,
    /// Robust misfit (mean Cauchy cost) of its de-lit signal, gain-matched, against the other
    /// photos' at full resolution, before and after.
    pub misfit: [f64; 2],
    /// Whether the registration was kept (for all photos or none).
    pub kept: bool,
}

/// The luminance (the channels' sum) of an image as a pyramid of `levels` levels, the signal
/// [`register`] compares.
pub fn luminance_pyramid(image: &RgbImage, levels: usize) -> Vec<Grey> {
    let lum = Grey::from_fn(image.width, image.height, |i| {
        [image.data[i].iter().sum::<f32>()]
    });
    gaussian_pyramid(lum, levels.max(1), &BURT_ADELSON)
}

/// A level-0 pixel in level `l`'s coordinates (pixel centres at i + ½ on both).
fn at_level(px: DVec2, l: usize) -> DVec2 {
    (px - DVec2::splat(0.5)) / (1u32 << l) as f64 + DVec2::splat(0.5)
}

/// The camera moved by θ = (ω, τ, φ) in its own frame, X_c' = exp(ω)(R X + t) + τ, with its
/// focal length scaled by e^φ.
fn moved(c: &Camera, theta: &[f64; 7]) -> Camera {
    let d = rodrigues([theta[0], theta[1], theta[2]]);
    let r = d * c.rotation_matrix();
    let t = d * DVec3::from(c.translation) + DVec3::new(theta[3], theta[4], theta[5]);
    Camera {
        rotation: rotation_vector(r),
        translation: t.to_array(),
        focal_px: c.focal_px * theta[6].exp(),
        ..*c
    }
}

/// Cauchy weight of a residual at scale s.
fn cauchy(r: f64, s: f64) -> f64 {
    1.0 / (1.0 + (r / s).powi(2))
}

/// Refines every photo's camera (see the module comment). `points` are the surface's points,
/// `weight(v, k)` the weight of point v in photo k (0 where the photo does not see it),
/// `signals[k]` photo k's signal pyramid ([`luminance_pyramid`]) and `shade(v, k)` what photo
/// k's signal at point v is divided by (its shading there). Returns one [`Registration`] per
/// photo, in order; the same at any thread count.
pub fn register(
    points: &[Vec3],
    weight: &(dyn Fn(usize, usize) -> f32 + Sync),
    shade: &(dyn Fn(usize, usize) -> f32 + Sync),
    cameras: &[Camera],
    signals: &[Vec<Grey>],
    opts: &RegisterOptions,
) -> Vec<Registration> {
    let n = cameras.len();
    let levels = opts
        .levels
        .max(1)
        .min(signals.iter().map(|p| p.len()).min().unwrap_or(1));
    // Every photo's de-lit signal at every point it sees at level l (NaN elsewhere).
    let observe = |cams: &[Camera], l: usize| -> Vec<Vec<f32>> {
        (0..n)
            .into_par_iter()
            .map(|k| {
                let cam = Prepared::new(&cams[k]);
                points
                    .iter()
                    .enumerate()
                    .map(|(v, p)| {
                        if weight(v, k) <= 0.0 {
                            return f32::NAN;
                        }
                        let s = shade(v, k);
                        if !(s > 0.0) {
                            return f32::NAN;
                        }
                        cam.project(p.as_dvec3())
                            .filter(|px| cam.camera.in_image(*px))
                            .map_or(f32::NAN, |px| signals[k][l].sample(at_level(px, l))[0] / s)
                    })
                    .collect()
            })
            .collect()
    };
    // The other photos' weighted mean at each point photo k sees: (point, mean, weight).
    let consensus = |observed: &[Vec<f32>], k: usize| -> Vec<(usize, f64, f64)> {
        (0..points.len())
            .filter_map(|v| {
                let wk = weight(v, k) as f64;
                if wk <= 0.0 || observed[k][v].is_nan() {
                    return None;
                }
                let (mut s, mut ws) = (0.0f64, 0.0f64);
                for j in (0..n).filter(|&j| j != k) {
                    let c = observed[j][v];
                    let w = weight(v, j) as f64;
                    if w > 0.0 && !c.is_nan() {
                        s += w * c as f64;
                        ws += w;
                    }
                }
                (ws > 0.0).then(|| (v, s / ws, wk * ws / (wk + ws)))
            })
            .collect()
    };
    let mut cams = cameras.to_vec();
    for l in (0..levels).rev() {
        let observed = observe(&cams, l);
        let refined: Vec<Camera> = (0..n)
            .into_par_iter()
            .map(|k| {
                let target = consensus(&observed, k);
                let inv: Vec<f64> = target
                    .iter()
                    .map(|&(v, _, _)| 1.0 / shade(v, k) as f64)
                    .collect();
                refine(
                    &cams[k],
                    &signals[k][l],
                    l,
                    points,
                    &target,
                    &inv,
                    opts.iterations,
                )
            })
            .collect();
        // Each photo moves (n − 1)/n of the way to the others' consensus: where the offsets
        // add up linearly, all then meet at their mean in one round, whatever their order.
        let alpha = (n as f64 - 1.0) / n as f64;
        for (k, c) in refined.into_iter().enumerate() {
            cams[k] = part_way(&cams[k], &c, alpha);
        }
    }
    // The misfit at full resolution before and after, on the same scale and the same points
    // (a point the refined camera loses counts as a large residual).
    let (before, after) = (observe(cameras, 0), observe(&cams, 0));
    let misfit: Vec<[f64; 2]> = (0..n)
        .map(|k| {
            let tb = consensus(&before, k);
            let mut now = vec![None; points.len()];
            for (v, t, _) in consensus(&after, k) {
                now[v] = Some(t);
            }
            let ta: Vec<(usize, f64, f64)> = tb
                .iter()
                .map(|&(v, _, w)| (v, now[v].unwrap_or(f64::NAN), w))
                .collect();
            let scale = robust_scale(&tb, &before[k]);
            [
                robust_cost(&tb, &before[k], scale),
                robust_cost(&ta, &after[k], scale),
            ]
        })
        .collect();
    let shifts: Vec<f64> = (0..n)
        .map(|k| {
            let seen = (0..points.len()).filter(|&v| weight(v, k) > 0.0);
            pixel_distance(&cameras[k], &cams[k], seen.map(|v| points[v].as_dvec3()))
        })
        .collect();
    // All or none: each photo moved on the assumption that the others moved too, so keeping
    // some would leave them half way to cameras that never moved. Kept when no photo moves
    // beyond the limit and the photos' misfits together fall.
    let total = |i: usize| misfit.iter().map(|m| m[i]).sum::<f64>();
    let kept = shifts.iter().all(|s| *s <= opts.max_shift_px) && total(1) < total(0);
    (0..n)
        .map(|k| Registration {
            camera: if kept { cams[k] } else { cameras[k] },
            shift_px: shifts[k],
            misfit: misfit[k],
            kept,
        })
        .collect()
}

/// The camera a fraction `alpha` of the way from `a` to `b` (in the pose increment of [`moved`]).
fn part_way(a: &Camera, b: &Camera, alpha: f64) -> Camera {
    let (ra, rb) = (a.rotation_matrix(), b.rotation_matrix());
    let d = rb * ra.transpose();
    let w = rotation_vector(d);
    let tau = DVec3::from(b.translation) - d * DVec3::from(a.translation);
    moved(
        a,
        &[
            alpha * w[0],
            alpha * w[1],
            alpha * w[2],
            alpha * tau.x,
            alpha * tau.y,
            alpha * tau.z,
            alpha * (b.focal_px / a.focal_px).ln(),
        ],
    )
}

/// The gain that matches `observed` to the consensus on average (weighted).
fn mean_gain(target: &[(usize, f64, f64)], observed: &[f32]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for &(v, t, w) in target {
        if !observed[v].is_nan() && !t.is_nan() {
            num += w * t;
            den += w * observed[v] as f64;
        }
    }
    if num > 0.0 && den > 0.0 {
        num / den
    } else {
        1.0
    }
}

/// 1.4826 × the median |gain × observed − consensus| (a robust standard deviation).
fn robust_scale(target: &[(usize, f64, f64)], observed: &[f32]) -> f64 {
    let g = mean_gain(target, observed);
    let mut abs: Vec<f64> = target
        .iter()
        .filter(|&&(v, _, _)| !observed[v].is_nan())
        .map(|&(v, t, _)| (g * observed[v] as f64 - t).abs())
        .collect();
    mad_sigma(&mut abs).map_or(1.0, |s| s.max(1e-9))
}

/// The weighted mean Cauchy cost ln(1 + (r/s)²) of observed (times its mean gain) against
/// consensus.
fn robust_cost(target: &[(usize, f64, f64)], observed: &[f32], scale: f64) -> f64 {
    let g = mean_gain(target, observed);
    let (mut s, mut ws) = (0.0, 0.0);
    for &(v, t, w) in target {
        let r = if observed[v].is_nan() || t.is_nan() {
            1e3 * scale
        } else {
            g * observed[v] as f64 - t
        };
        s += w * (1.0 + (r / scale).powi(2)).ln();
        ws += w;
    }
    s / ws.max(1e-30)
}

/// The fewest points a photo is refined on: eight unknowns, with a margin for the robust scale.
const MIN_POINTS: usize = 12;

/// Levenberg–Marquardt on one photo's pose, log focal length and log gain against `target`
/// ((point, consensus, weight)), its signal at a point times `inv` (1 / shading) and the gain, at
/// pyramid level `l`; returns the refined camera (the one given where there is too little to fit).
/// Marquardt's damping of the normal equations' diagonal (Marquardt 1963; the schedule — start
/// 10⁻³, ×0.3 on a step that lowers the cost, ×10 on one that does not, six tries — is ours) with
/// iteratively reweighted Cauchy residuals, so the step is taken on the robust cost itself.
/// At least [`MIN_POINTS`] points are needed.
fn refine(
    camera: &Camera,
    image: &Grey,
    l: usize,
    points: &[Vec3],
    target: &[(usize, f64, f64)],
    inv: &[f64],
    iterations: usize,
) -> Camera {
    const P: usize = 8;
    if target.len() < MIN_POINTS {
        return *camera;
    }
    let sample = |cam: &Prepared, v: usize| -> Option<DVec2> {
        cam.project(points[v].as_dvec3())
            .filter(|px| cam.camera.in_image(*px))
            .map(|px| at_level(px, l))
    };
    let value = |q: DVec2| image.sample(q)[0] as f64;
    // The gain that matches the consensus on average to start from.
    let start = Prepared::new(camera);
    let at_start: Vec<Option<f64>> = target
        .iter()
        .map(|&(v, _, _)| sample(&start, v).map(value))
        .collect();
    let (mut num, mut den) = (0.0, 0.0);
    for ((&(_, t, w), s), val) in target.iter().zip(inv).zip(&at_start) {
        if let Some(val) = val {
            num += w * t;
            den += w * val * s;
        }
    }
    if !(num > 0.0 && den > 0.0) {
        return *camera;
    }
    let mut log_gain = (num / den).ln();
    // The residuals' scale: 1.4826 × the median |r| at the start (fixed for this level).
    let gain0 = log_gain.exp();
    let mut abs: Vec<f64> = target
        .iter()
        .zip(inv)
        .zip(&at_start)
        .filter_map(|((&(_, t, _), s), val)| val.map(|val| (gain0 * val * s - t).abs()))
        .collect();
    if abs.len() < MIN_POINTS {
        return *camera;
    }
    let scale = mad_sigma(&mut abs).map_or(1.0, |s| s.max(1e-6));
    let cost = |cam: &Camera, lg: f64| -> f64 {
        let p = Prepared::new(cam);
        let gain = lg.exp();
        let (mut c, mut ws) = (0.0, 0.0);
        for (&(v, t, w), s) in target.iter().zip(inv) {
            // A point leaving the image counts as a large residual (10³ scales: it dominates a
            // Cauchy cost of in-image residuals, which grows only as their logarithm).
            let r2 = sample(&p, v).map_or(1e6, |q| ((gain * value(q) * s - t) / scale).powi(2));
            c += w * (1.0 + r2).ln();
            ws += w;
        }
        c / ws.max(1e-30)
    };
    let mut cam = *camera;
    let mut cur = cost(&cam, log_gain);
    let mut mu = 1e-3;
    // Steps of the finite differences: 10⁻⁶ rad, 10⁻⁴ mesh units and 10⁻⁶ of the focal length.
    let h = [1e-6, 1e-6, 1e-6, 1e-4, 1e-4, 1e-4, 1e-6];
    for _ in 0..iterations {
        let base = Prepared::new(&cam);
        let nudged: Vec<Prepared> = (0..7)
            .map(|j| {
                let mut th = [0.0; 7];
                th[j] = h[j];
                Prepared::new(&moved(&cam, &th))
            })
            .collect();
        let gain = log_gain.exp();
        let (mut a, mut b) = ([0.0f64; P * P], [0.0f64; P]);
        for (&(v, t, w), s) in target.iter().zip(inv) {
            let Some(q) = sample(&base, v) else { continue };
            let model = gain * value(q) * s;
            let r = model - t;
            // The image's gradient by central differences over one pixel of this level.
            let g = DVec2::new(
                value(q + DVec2::X * 0.5) - value(q - DVec2::X * 0.5),
                value(q + DVec2::Y * 0.5) - value(q - DVec2::Y * 0.5),
            ) * (gain * s);
            let mut jrow = [0.0f64; P];
            for (j, cam_j) in nudged.iter().enumerate() {
                let Some(qj) = sample(cam_j, v) else { continue };
                jrow[j] = g.dot((qj - q) / h[j]);
            }
            jrow[7] = model;
            let rw = w * cauchy(r, scale);
            for i in 0..P {
                b[i] += rw * jrow[i] * r;
                for j in 0..P {
                    a[i * P + j] += rw * jrow[i] * jrow[j];
                }
            }
        }
        let mut improved = false;
        for _ in 0..6 {
            let mut m = a;
            for i in 0..P {
                m[i * P + i] += mu * a[i * P + i].max(1e-12);
            }
            let Some(d) = solve(&m, &b.map(|x| -x), P) else {
                mu *= 10.0;
                continue;
            };
            let next = moved(&cam, &[d[0], d[1], d[2], d[3], d[4], d[5], d[6]]);
            let c = cost(&next, log_gain + d[7]);
            if c < cur {
                let gained = cur - c;
                cam = next;
                log_gain += d[7];
                cur = c;
                mu = (mu * 0.3).max(1e-9);
                improved = gained > 1e-6 * cur;
                break;
            }
            mu *= 10.0;
        }
        if !improved {
            break;
        }
    }
    cam
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A textured plane facing the camera: random blobs of contrast.
    fn scene() -> (Vec<Vec3>, Camera, RgbImage) {
        let cam = Camera::look_at(
            480,
            360,
            Vec3::new(0.0, 0.0, 500.0),
            Vec3::ZERO,
            Vec3::Y,
            900.0,
        );
        let mut points = Vec::new();
        for j in 0..60 {
            for i in 0..80 {
                points.push(Vec3::new(
                    i as f32 * 3.0 - 120.0,
                    j as f32 * 3.0 - 90.0,
                    0.0,
                ));
            }
        }
        // The texture on the plane: spots of 4–8 units over a smooth gradient (shading).
        let spots: Vec<(f32, f32, f32)> = (0..300)
            .map(|s| {
                let a = ((s * 7919) % 1000) as f32 / 1000.0;
                let b = ((s * 104_729) % 1000) as f32 / 1000.0;
                (
                    a * 300.0 - 150.0,
                    b * 220.0 - 110.0,
                    2.0 + 2.0 * ((s % 3) as f32),
                )
            })
            .collect();
        let albedo = |x: f32, y: f32| -> f32 {
            let mut v = 0.6;
            for &(sx, sy, r) in &spots {
                let d2 = (x - sx).powi(2) + (y - sy).powi(2);
                v -= 0.25 * (-d2 / (r * r)).exp();
            }
            v
        };
        let prepared = Prepared::new(&cam);
        let image = RgbImage::from_fn(480, 360, |i| {
            let px = DVec2::new((i % 480) as f64 + 0.5, (i / 480) as f64 + 0.5);
            // Back-project the pixel onto z = 0.
            let ray = prepared.rotation.transpose()
                * DVec3::new(
                    (px.x - cam.principal[0]) / cam.focal_px,
                    (px.y - cam.principal[1]) / cam.focal_px,
                    1.0,
                );
            let o = prepared.centre;
            let s = -o.z / ray.z;
            let p = o + ray * s;
            let shade = 0.5 + 0.4 * (p.x as f32 + 200.0) / 400.0;
            [albedo(p.x as f32, p.y as f32) * shade; 3]
        });
        (points, cam, image)
    }

    /// Two photos registered, every point weighted 1 and unshaded.
    fn two(
        points: &[Vec3],
        cameras: [Camera; 2],
        images: [&RgbImage; 2],
        max_shift_px: f64,
    ) -> Vec<Registration> {
        let w = |_: usize, _: usize| 1.0f32;
        let signals = images.map(|im| luminance_pyramid(im, 3));
        let opts = RegisterOptions {
            max_shift_px,
            ..Default::default()
        };
        register(points, &w, &w, &cameras, &signals, &opts)
    }

    #[test]
    fn a_camera_nudged_off_is_brought_back() {
        let (points, truth, image) = scene();
        // Photo 0: the true camera; photo 1: the same image with its camera turned by ~0.4°
        // and moved 1 unit (about 4–5 px at this distance), exposure doubled (the gain).
        let off = moved(&truth, &[0.004, -0.003, 0.002, 1.0, -0.5, 0.0, 0.0]);
        let brighter = RgbImage::from_fn(480, 360, |i| image.data[i].map(|v| 2.0 * v));
        let regs = two(&points, [truth, off], [&image, &brighter], 12.0);
        let pts = || points.iter().map(|p| p.as_dvec3());
        let apart = |a: &Camera, b: &Camera| pixel_distance(a, b, pts());
        let relative = apart(&regs[0].camera, &regs[1].camera);
        let (before, e0, e1) = (
            apart(&truth, &off),
            apart(&truth, &regs[0].camera),
            apart(&truth, &regs[1].camera),
        );
        assert!(before > 3.0, "{before}");
        assert!(regs.iter().all(|r| r.kept), "{regs:?}");
        // The two photos now agree to a fraction of a pixel, and they met half way (the
        // consensus of two is their mean; nothing tells which one was right).
        assert!(relative < 0.3, "photos still {relative} px apart");
        assert!((e0 - 0.5 * before).abs() < 0.3 && (e1 - 0.5 * before).abs() < 0.3);
        assert!(
            regs.iter().all(|r| r.misfit[1] < 0.5 * r.misfit[0]),
            "{regs:?}"
        );
    }

    #[test]
    fn a_correction_beyond_the_limit_is_refused() {
        let (points, truth, image) = scene();
        let off = moved(&truth, &[0.004, -0.003, 0.002, 1.0, -0.5, 0.0, 0.0]);
        let regs = two(&points, [truth, off], [&image, &image], 0.5);
        assert!(!regs[1].kept);
        assert_eq!(regs[1].camera, off);
        // The correction tried is reported (the bake names it in its warning).
        assert!(regs[1].shift_px > 0.5, "{regs:?}");
    }
}
