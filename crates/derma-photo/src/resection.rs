//! Camera resection from 2D–3D correspondences (Tarini et al. 2002 §3: 12–15 feature points per
//! photo): the normalised direct linear transform (Hartley & Zisserman 2004, §7.1 and §4.4.4)
//! starts a Levenberg–Marquardt refinement of pose and intrinsics, optionally shared by all photos.

use crate::camera::{rotation_vector, Camera};
use crate::error::{PhotoError, Result};
use derma_core::numerics::dense::{matrix_from_rows, svd};
use derma_core::numerics::levenberg_marquardt::{levenberg_marquardt, LmOptions, ResidualFn};
use derma_core::numerics::robust::mad_sigma;
use glam::{DMat3, DVec2, DVec3};
use serde::Serialize;

/// One feature point: where it is on the mesh and where it is in the photo.
#[derive(Clone, Debug, PartialEq)]
pub struct Correspondence {
    /// Its name (a landmark name, `v123` for a vertex, `mp123` for a MediaPipe id).
    pub label: String,
    /// Pixel coordinates (origin at the top-left corner of the image).
    pub pixel: DVec2,
    /// Position on the mesh (mesh units).
    pub world: DVec3,
}

/// The feature points of one photo.
#[derive(Clone, Debug, PartialEq)]
pub struct PhotoPoints {
    /// The photo's name (its file), for messages.
    pub name: String,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// A known focal length in pixels (from EXIF or the user); fixed in the fit.
    pub focal_px: Option<f64>,
    /// The correspondences.
    pub points: Vec<Correspondence>,
}

/// What the refinement may change besides the pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ResectionOptions {
    /// One set of intrinsics for all photos (one camera body and lens).
    pub shared_intrinsics: bool,
    /// Refine the focal length (unless a photo gives it).
    pub refine_focal: bool,
    /// Refine the principal point (poorly pinned by a face alone; off by default).
    pub refine_principal: bool,
    /// Refine radial distortion k₁, k₂ (off by default: 12–15 points overfit it).
    pub refine_distortion: bool,
    /// A point is an outlier when its reprojection error exceeds this many pixels and three
    /// robust standard deviations (1.4826 × median) of its photo's errors.
    pub outlier_px: f64,
    /// With per-photo intrinsics: the relative standard deviation of each photo's focal length
    /// around the one shared camera's, fitted first — a log-normal prior, so each photo's
    /// focal length is a maximum a posteriori estimate (a face's points pin it poorly alone);
    /// `f64::INFINITY`: no prior. Default 0.1 (authored: zoom and refocus change a lens's focal
    /// length by a few percent between shots).
    pub focal_deviation: f64,
}

impl Default for ResectionOptions {
    fn default() -> Self {
        Self {
            shared_intrinsics: true,
            refine_focal: true,
            refine_principal: false,
            refine_distortion: false,
            outlier_px: 4.0,
            focal_deviation: 0.1,
        }
    }
}

/// A point's reprojection error under the final camera.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct PointError {
    /// The point's label.
    pub label: String,
    /// Reprojection error in pixels.
    pub error_px: f64,
    /// Left out of the final fit as an outlier.
    pub outlier: bool,
}

/// A resected photo.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Resection {
    /// The photo's name.
    pub photo: String,
    /// The camera.
    pub camera: Camera,
    /// Focal length of the DLT start, pixels.
    pub dlt_focal_px: f64,
    /// RMS reprojection error of the inliers, pixels.
    pub rms_px: f64,
    /// Every point's error.
    pub points: Vec<PointError>,
    /// Standard error of the focal length (pixels) from the fit's covariance σ²(JᵀJ)⁻¹;
    /// `None` where the focal length was given.
    pub focal_se_px: Option<f64>,
    /// Standard error of the camera's distance to the mesh's origin (mesh units).
    pub distance_se: f64,
}

/// A prior on a photo's focal length: ln f ~ N(ln `focal_px`, `relative`²), weighed against
/// reprojection residuals of standard deviation `noise_px`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct FocalPrior {
    focal_px: f64,
    relative: f64,
    noise_px: f64,
}

/// A fitted camera's standard errors.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Spread {
    focal: Option<f64>,
    distance: f64,
}

/// Points needed by the DLT (11 unknowns, two equations per point).
pub const MIN_POINTS: usize = 6;

/// A camera from the normalised DLT with square pixels (the mean of the two focal lengths of
/// the decomposition) and no distortion. Errors on too few, degenerate (coplanar or collinear)
/// points and on points behind the camera.
pub fn dlt(photo: &PhotoPoints) -> Result<Camera> {
    let err = |detail: String| PhotoError::Camera {
        photo: photo.name.clone(),
        detail,
    };
    let n = photo.points.len();
    if n < MIN_POINTS {
        return Err(err(format!(
            "{n} correspondences; the DLT needs at least {MIN_POINTS} (12–15 recommended)"
        )));
    }
    // Hartley normalisation: centroid at the origin, mean distance √2 (image) and √3 (world).
    let c2 = photo.points.iter().map(|p| p.pixel).sum::<DVec2>() / n as f64;
    let c3 = photo.points.iter().map(|p| p.world).sum::<DVec3>() / n as f64;
    let d2 = photo
        .points
        .iter()
        .map(|p| (p.pixel - c2).length())
        .sum::<f64>()
        / n as f64;
    let d3 = photo
        .points
        .iter()
        .map(|p| (p.world - c3).length())
        .sum::<f64>()
        / n as f64;
    if d2 < 1e-9 || d3 < 1e-9 {
        return Err(err("all correspondences coincide".into()));
    }
    let (s2, s3) = (2f64.sqrt() / d2, 3f64.sqrt() / d3);
    let mut a = Vec::with_capacity(2 * n * 12);
    for p in &photo.points {
        let x = (p.pixel - c2) * s2;
        let w = (p.world - c3) * s3;
        let wh = [w.x, w.y, w.z, 1.0];
        a.extend(wh);
        a.extend([0.0; 4]);
        a.extend(wh.map(|v| -x.x * v));
        a.extend([0.0; 4]);
        a.extend(wh);
        a.extend(wh.map(|v| -x.y * v));
    }
    let m = matrix_from_rows(2 * n, 12, &a)?;
    let d = svd(&m)?;
    // Rank 11 is needed; coplanar or collinear points leave a larger null space.
    if d.s[10] < 1e-7 * d.s[0] {
        return Err(err(format!(
            "the {n} points are degenerate for the DLT (coplanar or collinear: singular values {:.2e} … {:.2e}); pick points at different depths (nose tip, ears, chin)",
            d.s[0], d.s[10]
        )));
    }
    let pn: Vec<f64> = (0..12).map(|i| d.v[(i, 11)]).collect();
    // Undo the normalisation: P = T₂⁻¹ Pₙ T₃.
    let mut p = [[0.0f64; 4]; 3];
    let t3 = |row: [f64; 4]| -> [f64; 4] {
        [
            row[0] * s3,
            row[1] * s3,
            row[2] * s3,
            row[3] - s3 * (row[0] * c3.x + row[1] * c3.y + row[2] * c3.z),
        ]
    };
    let rows: [[f64; 4]; 3] =
        std::array::from_fn(|r| t3([pn[4 * r], pn[4 * r + 1], pn[4 * r + 2], pn[4 * r + 3]]));
    for k in 0..4 {
        p[0][k] = rows[0][k] / s2 + c2.x * rows[2][k];
        p[1][k] = rows[1][k] / s2 + c2.y * rows[2][k];
        p[2][k] = rows[2][k];
    }
    // Sign: most points in front of the camera.
    let depth =
        |p: &[[f64; 4]; 3], w: DVec3| p[2][0] * w.x + p[2][1] * w.y + p[2][2] * w.z + p[2][3];
    let front = photo
        .points
        .iter()
        .filter(|c| depth(&p, c.world) > 0.0)
        .count();
    if 2 * front < n {
        for row in &mut p {
            for v in row.iter_mut() {
                *v = -*v;
            }
        }
    }
    // Decompose M = K R with K upper triangular (zero skew).
    let m1 = DVec3::new(p[0][0], p[0][1], p[0][2]);
    let m2 = DVec3::new(p[1][0], p[1][1], p[1][2]);
    let m3 = DVec3::new(p[2][0], p[2][1], p[2][2]);
    let scale = m3.length();
    let r3 = m3 / scale;
    let (cx, cy) = (m1.dot(r3) / scale, m2.dot(r3) / scale);
    let a1 = m1 / scale - cx * r3;
    let a2 = m2 / scale - cy * r3;
    let (fx, fy) = (a1.length(), a2.length());
    let (mut r1, r2) = (a1 / fx, a2 / fy);
    let mut r = DMat3::from_cols(r1, r2, r3).transpose();
    if r.determinant() < 0.0 {
        // A mirrored solution: flip x (fx then comes out negative in K, folded back here).
        r1 = -r1;
        r = DMat3::from_cols(r1, r2, r3).transpose();
    }
    // Nearest rotation (polar decomposition through the SVD).
    let rm = matrix_from_rows(3, 3, &r.transpose().to_cols_array())?;
    let rs = svd(&rm)?;
    let u = DMat3::from_cols_array(&std::array::from_fn(|i| rs.u[(i % 3, i / 3)]));
    let v = DMat3::from_cols_array(&std::array::from_fn(|i| rs.v[(i % 3, i / 3)]));
    let mut rot = u * v.transpose();
    if rot.determinant() < 0.0 {
        rot = -rot;
    }
    let f = 0.5 * (fx + fy);
    let p4 = DVec3::new(p[0][3], p[1][3], p[2][3]) / scale;
    // p₄ = K t with K = [[f, 0, cx], [0, f, cy], [0, 0, 1]].
    let tz = p4.z;
    let t = DVec3::new((p4.x - cx * tz) / fx, (p4.y - cy * tz) / fy, tz);
    let cam = Camera {
        width: photo.width,
        height: photo.height,
        rotation: rotation_vector(rot),
        translation: t.to_array(),
        focal_px: f,
        principal: [cx, cy],
        k1: 0.0,
        k2: 0.0,
    };
    check_in_front(photo, &cam)?;
    Ok(cam)
}

fn check_in_front(photo: &PhotoPoints, cam: &Camera) -> Result<()> {
    let behind: Vec<&str> = photo
        .points
        .iter()
        .filter(|c| cam.to_camera(c.world).z <= 0.0)
        .map(|c| c.label.as_str())
        .collect();
    if behind.is_empty() {
        return Ok(());
    }
    Err(PhotoError::Camera {
        photo: photo.name.clone(),
        detail: format!(
            "points {behind:?} lie behind the camera; check that they belong to this photo and to the mesh's units"
        ),
    })
}

/// Which intrinsics the fit changes, and where they sit in the parameter vector.
#[derive(Clone, Copy)]
struct Layout {
    focal: bool,
    principal: bool,
    distortion: bool,
}

impl Layout {
    fn len(self) -> usize {
        self.focal as usize + 2 * self.principal as usize + 2 * self.distortion as usize
    }

    /// Writes the free intrinsics of `c` into `out` (in order f, cx, cy, k₁, k₂).
    fn pack(self, c: &Camera, out: &mut Vec<f64>) {
        if self.focal {
            out.push(c.focal_px);
        }
        if self.principal {
            out.extend(c.principal);
        }
        if self.distortion {
            out.extend([c.k1, c.k2]);
        }
    }

    fn bounds(self, c: &Camera, lo: &mut Vec<f64>, hi: &mut Vec<f64>) {
        let size = c.width.max(c.height) as f64;
        if self.focal {
            lo.push(0.05 * size);
            hi.push(50.0 * size);
        }
        if self.principal {
            lo.extend([0.0, 0.0]);
            hi.extend([c.width as f64, c.height as f64]);
        }
        if self.distortion {
            lo.extend([-1.0, -1.0]);
            hi.extend([1.0, 1.0]);
        }
    }

    fn unpack(self, p: &[f64], c: &mut Camera) {
        let mut k = 0;
        if self.focal {
            c.focal_px = p[k];
            k += 1;
        }
        if self.principal {
            c.principal = [p[k], p[k + 1]];
            k += 2;
        }
        if self.distortion {
            c.k1 = p[k];
            c.k2 = p[k + 1];
        }
    }
}

/// Refines the cameras of `photos` (starting from `cams`) over the inlier points `use_point`:
/// a pose each, intrinsics per photo or shared, the focal length under `prior` where given.
/// Returns each camera's standard errors.
fn refine(
    photos: &[PhotoPoints],
    cams: &mut [Camera],
    use_point: &[Vec<bool>],
    opts: &ResectionOptions,
    prior: Option<FocalPrior>,
) -> Vec<Spread> {
    let mut spread = vec![Spread::default(); photos.len()];
    let fixed_focal = photos.iter().any(|p| p.focal_px.is_some());
    let layout = Layout {
        focal: opts.refine_focal && !fixed_focal,
        principal: opts.refine_principal,
        distortion: opts.refine_distortion,
    };
    let nk = layout.len();
    let groups: Vec<Vec<usize>> = if opts.shared_intrinsics {
        vec![(0..photos.len()).collect()]
    } else {
        (0..photos.len()).map(|i| vec![i]).collect()
    };
    for group in groups {
        let mut p0 = Vec::new();
        let (mut lo, mut hi) = (Vec::new(), Vec::new());
        let first = cams[group[0]];
        layout.pack(&first, &mut p0);
        layout.bounds(&first, &mut lo, &mut hi);
        for &i in &group {
            p0.extend(cams[i].rotation);
            p0.extend(cams[i].translation);
            lo.extend([-10.0; 3]);
            hi.extend([10.0; 3]);
            lo.extend([-1e12; 3]);
            hi.extend([1e12; 3]);
        }
        let prior = prior.filter(|_| layout.focal);
        let m: usize = group
            .iter()
            .map(|&i| 2 * use_point[i].iter().filter(|u| **u).count())
            .sum::<usize>()
            + prior.is_some() as usize;
        let base: Vec<Camera> = group.iter().map(|&i| cams[i]).collect();
        let eval = |p: &[f64], r: &mut [f64]| {
            let mut row = 0;
            for (g, &i) in group.iter().enumerate() {
                let mut c = base[g];
                layout.unpack(&p[..nk], &mut c);
                let o = nk + 6 * g;
                c.rotation = [p[o], p[o + 1], p[o + 2]];
                c.translation = [p[o + 3], p[o + 4], p[o + 5]];
                let rot = c.rotation_matrix();
                let t = DVec3::from(c.translation);
                for (pt, _) in photos[i]
                    .points
                    .iter()
                    .zip(&use_point[i])
                    .filter(|(_, u)| **u)
                {
                    let q = rot * pt.world + t;
                    // Behind the camera: a large, smooth penalty instead of a projection.
                    let px = if q.z > 1e-9 {
                        c.pixel_of_camera_point(q)
                    } else {
                        pt.pixel + DVec2::splat(1e6)
                    };
                    r[row] = px.x - pt.pixel.x;
                    r[row + 1] = px.y - pt.pixel.y;
                    row += 2;
                }
            }
            if let Some(q) = prior {
                // The prior as one more residual, in pixels of the points' noise.
                r[row] = q.noise_px * (p[0] / q.focal_px).ln() / q.relative;
            }
        };
        let n = p0.len();
        let mut residuals = |p: &[f64], r: &mut [f64], jac: Option<&mut [f64]>| {
            eval(p, r);
            if let Some(j) = jac {
                // Central differences, steps relative to each parameter's size.
                let mut q = p.to_vec();
                let (mut rp, mut rm) = (vec![0.0; r.len()], vec![0.0; r.len()]);
                for k in 0..n {
                    let h = 1e-6 * p[k].abs().max(1e-3);
                    q[k] = p[k] + h;
                    eval(&q, &mut rp);
                    q[k] = p[k] - h;
                    eval(&q, &mut rm);
                    q[k] = p[k];
                    for row in 0..r.len() {
                        j[row * n + k] = (rp[row] - rm[row]) / (2.0 * h);
                    }
                }
            }
        };
        let (p, _) = levenberg_marquardt(
            &mut residuals,
            &p0,
            &lo,
            &hi,
            m,
            LmOptions {
                max_iterations: 100,
                tolerance: 1e-14,
                ..Default::default()
            },
        );
        let cov = covariance(&mut residuals, &p, m);
        for (g, &i) in group.iter().enumerate() {
            let c = &mut cams[i];
            layout.unpack(&p[..nk], c);
            let o = nk + 6 * g;
            c.rotation = [p[o], p[o + 1], p[o + 2]];
            c.translation = [p[o + 3], p[o + 4], p[o + 5]];
            if let Some(cov) = &cov {
                // The distance |t| to the origin: its gradient is t/|t| in the translation.
                let t = DVec3::from(c.translation);
                let u = t / t.length().max(1e-12);
                let mut var = 0.0;
                for a in 0..3 {
                    for b in 0..3 {
                        var += u[a] * u[b] * cov[(o + 3 + a) * n + o + 3 + b];
                    }
                }
                spread[i] = Spread {
                    focal: layout.focal.then(|| cov[0].max(0.0).sqrt()),
                    distance: var.max(0.0).sqrt(),
                };
            }
        }
    }
    spread
}

/// The parameters' covariance σ²(JᵀJ)⁻¹ at `p` (row-major n × n), σ² = Σr²/(m − n); `None`
/// when there are no more residuals than parameters or JᵀJ is singular.
fn covariance(residuals: &mut ResidualFn<'_>, p: &[f64], m: usize) -> Option<Vec<f64>> {
    let n = p.len();
    if m <= n {
        return None;
    }
    let mut r = vec![0.0; m];
    let mut j = vec![0.0; m * n];
    residuals(p, &mut r, Some(&mut j));
    let sigma2 = r.iter().map(|v| v * v).sum::<f64>() / (m - n) as f64;
    let mut jtj = vec![0.0; n * n];
    for row in 0..m {
        let jr = &j[row * n..(row + 1) * n];
        for a in 0..n {
            if jr[a] == 0.0 {
                continue;
            }
            for b in 0..n {
                jtj[a * n + b] += jr[a] * jr[b];
            }
        }
    }
    let mut inv = vec![0.0; n * n];
    for k in 0..n {
        let mut e = vec![0.0; n];
        e[k] = 1.0;
        let x = derma_core::numerics::dense::solve(&jtj, &e, n)?;
        for a in 0..n {
            inv[a * n + k] = sigma2 * x[a];
        }
    }
    Some(inv)
}

fn errors(photo: &PhotoPoints, cam: &Camera) -> Vec<f64> {
    photo
        .points
        .iter()
        .map(|c| match cam.project(c.world) {
            Some(px) => (px - c.pixel).length(),
            None => f64::INFINITY,
        })
        .collect()
}

/// Resects every photo: DLT, then a joint Levenberg–Marquardt refinement; points whose error
/// exceeds both `opts.outlier_px` and three robust standard deviations are flagged, left out,
/// and the fit repeated once.
pub fn resect(photos: &[PhotoPoints], opts: &ResectionOptions) -> Result<Vec<Resection>> {
    if photos.is_empty() {
        return Err(PhotoError::Invalid(derma_core::Invalid::new(
            "photos to resect",
            "at least one",
            "none",
        )));
    }
    if opts.shared_intrinsics {
        if let Some(p) = photos
            .iter()
            .find(|p| (p.width, p.height) != (photos[0].width, photos[0].height))
        {
            return Err(PhotoError::Camera {
                photo: p.name.clone(),
                detail: format!(
                    "{}×{} differs from '{}' ({}×{}); shared intrinsics need one image size (use per-photo intrinsics)",
                    p.width, p.height, photos[0].name, photos[0].width, photos[0].height
                ),
            });
        }
    }
    let mut cams = Vec::with_capacity(photos.len());
    for p in photos {
        if p.width == 0 || p.height == 0 {
            return Err(PhotoError::Camera {
                photo: p.name.clone(),
                detail: "image size is zero".into(),
            });
        }
        cams.push(dlt(p)?);
    }
    let dlt_focal: Vec<f64> = cams.iter().map(|c| c.focal_px).collect();
    // Start from the known focal length, or the median of the DLT's (shared) or each DLT's.
    let mut sorted = dlt_focal.clone();
    sorted.sort_by(f64::total_cmp);
    let median_f = sorted[sorted.len() / 2];
    for (c, p) in cams.iter_mut().zip(photos) {
        c.principal = [p.width as f64 / 2.0, p.height as f64 / 2.0];
        if let Some(f) = p.focal_px {
            c.focal_px = f;
        } else if opts.shared_intrinsics {
            c.focal_px = median_f;
        }
    }
    // With the principal point moved to the centre, re-pose each camera at fixed intrinsics.
    let all: Vec<Vec<bool>> = photos.iter().map(|p| vec![true; p.points.len()]).collect();
    let pose_only = ResectionOptions {
        shared_intrinsics: false,
        refine_focal: false,
        refine_principal: false,
        refine_distortion: false,
        ..*opts
    };
    refine(photos, &mut cams, &all, &pose_only, None);
    // Per-photo focal lengths: one shared camera first, then each photo's focal length within
    // `focal_deviation` of it (a bounded deviation: the prior that keeps an ill-posed photo
    // near the others). Shared pixels need one image size; without it the bound is skipped.
    let same_size = photos
        .iter()
        .all(|p| (p.width, p.height) == (photos[0].width, photos[0].height));
    let mut prior = None;
    let scheduled = !opts.shared_intrinsics
        && opts.refine_focal
        && photos.iter().all(|p| p.focal_px.is_none())
        && photos.len() > 1
        && same_size
        && opts.focal_deviation.is_finite();
    if scheduled {
        let shared = ResectionOptions {
            shared_intrinsics: true,
            ..*opts
        };
        refine(photos, &mut cams, &all, &shared, None);
        // The points' noise per coordinate, from the shared fit's reprojection errors.
        let (mut sum, mut k) = (0.0, 0usize);
        for (p, c) in photos.iter().zip(&cams) {
            for e in errors(p, c).into_iter().filter(|e| e.is_finite()) {
                sum += e * e;
                k += 1;
            }
        }
        prior = Some(FocalPrior {
            focal_px: cams[0].focal_px,
            relative: opts.focal_deviation.max(1e-6),
            noise_px: (sum / (2 * k.max(1)) as f64).sqrt().max(1e-3),
        });
    }
    let mut spread = refine(photos, &mut cams, &all, opts, prior);
    // Flag outliers and refit without them.
    let mut inlier = all.clone();
    let mut any = false;
    for (i, p) in photos.iter().enumerate() {
        let e = errors(p, &cams[i]);
        let sigma = mad_sigma(&mut e.clone()).expect("a calibrated photo has points");
        let limit = opts.outlier_px.max(3.0 * sigma);
        for (k, &v) in e.iter().enumerate() {
            if v > limit && inlier[i].iter().filter(|u| **u).count() > MIN_POINTS {
                inlier[i][k] = false;
                any = true;
            }
        }
    }
    if any {
        spread = refine(photos, &mut cams, &inlier, opts, prior);
    }
    let mut out = Vec::with_capacity(photos.len());
    for (i, p) in photos.iter().enumerate() {
        check_in_front(p, &cams[i])?;
        let e = errors(p, &cams[i]);
        let (mut sum, mut k) = (0.0, 0);
        for (v, u) in e.iter().zip(&inlier[i]) {
            if *u {
                sum += v * v;
                k += 1;
            }
        }
        out.push(Resection {
            photo: p.name.clone(),
            camera: cams[i],
            dlt_focal_px: dlt_focal[i],
            rms_px: (sum / k.max(1) as f64).sqrt(),
            points: p
                .points
                .iter()
                .zip(e.iter().zip(&inlier[i]))
                .map(|(c, (&v, &u))| PointError {
                    label: c.label.clone(),
                    error_px: v,
                    outlier: !u,
                })
                .collect(),
            focal_se_px: spread[i].focal,
            distance_se: spread[i].distance,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use derma_core::rng::Philox;
    use glam::Vec3;

    /// 15 points spread like facial landmarks (mm): a curved mask with depth.
    fn face_points() -> Vec<DVec3> {
        (0..15)
            .map(|i| {
                let a = i as f64 / 15.0 * std::f64::consts::TAU;
                let r = 30.0 + 25.0 * ((i * 7) % 5) as f64 / 4.0;
                let (x, y) = (r * a.cos(), 1.3 * r * a.sin());
                DVec3::new(x, y, 60.0 - (x * x + y * y) / 80.0)
            })
            .collect()
    }

    fn photo(cam: &Camera, noise_px: f64, seed: u64) -> PhotoPoints {
        let rng = Philox::new(seed, 0);
        PhotoPoints {
            name: format!("p{seed}"),
            width: cam.width,
            height: cam.height,
            focal_px: None,
            points: face_points()
                .into_iter()
                .enumerate()
                .map(|(i, w)| {
                    let n = rng.normal2(i as u64, 0);
                    Correspondence {
                        label: format!("v{i}"),
                        pixel: cam.project(w).unwrap()
                            + noise_px * DVec2::new(n[0] as f64, n[1] as f64),
                        world: w,
                    }
                })
                .collect(),
        }
    }

    fn camera(az_deg: f32) -> Camera {
        let a = az_deg.to_radians();
        let eye = Vec3::new(600.0 * a.sin(), 40.0, 600.0 * a.cos());
        let mut c = Camera::look_at(3000, 2000, eye, Vec3::new(0.0, 0.0, 20.0), Vec3::Y, 4200.0);
        c.principal = [1500.0, 1000.0];
        c
    }

    #[test]
    fn dlt_recovers_an_exact_camera() {
        let cam = camera(20.0);
        let got = dlt(&photo(&cam, 0.0, 1)).unwrap();
        assert!(
            (got.focal_px / cam.focal_px - 1.0).abs() < 1e-6,
            "{}",
            got.focal_px
        );
        assert!((got.centre() - cam.centre()).length() < 1e-4);
        for p in face_points() {
            assert!((got.project(p).unwrap() - cam.project(p).unwrap()).length() < 1e-5);
        }
    }

    #[test]
    fn shared_intrinsics_pin_the_focal_length_better_than_one_dlt() {
        let cams: Vec<Camera> = [-35.0, -10.0, 10.0, 35.0].map(camera).to_vec();
        let photos: Vec<PhotoPoints> = cams
            .iter()
            .enumerate()
            .map(|(i, c)| photo(c, 1.5, 10 + i as u64))
            .collect();
        let res = resect(&photos, &ResectionOptions::default()).unwrap();
        let shared = (res[0].camera.focal_px / 4200.0 - 1.0).abs();
        let dlt_mean = res
            .iter()
            .map(|r| (r.dlt_focal_px / 4200.0 - 1.0).abs())
            .sum::<f64>()
            / 4.0;
        assert!(shared < 0.05, "shared focal error {shared}");
        assert!(shared < dlt_mean, "shared {shared} vs DLT {dlt_mean}");
        for (r, c) in res.iter().zip(&cams) {
            assert!(r.rms_px < 2.5, "{} rms {}", r.photo, r.rms_px);
            assert!((r.camera.centre() - c.centre()).length() < 0.05 * 600.0);
        }
    }

    #[test]
    fn per_photo_focal_lengths_stay_near_the_shared_fit_and_report_their_spread() {
        // Five views from 1.8 m (a telephoto portrait: little perspective, so focal length and
        // distance trade off) whose focal lengths differ by up to 8 % (zoom, refocus), 15
        // clicked points each with 1.5 px noise: per photo, a focal length is ill-posed alone.
        let truth = [0.92, 0.96, 1.0, 1.04, 1.08].map(|k| 12_600.0 * k);
        let cams: Vec<Camera> = [-35.0f32, -15.0, 0.0, 15.0, 35.0]
            .iter()
            .zip(truth)
            .map(|(&az, f)| {
                let a = az.to_radians();
                let eye = Vec3::new(1800.0 * a.sin(), 40.0, 1800.0 * a.cos());
                let mut c = Camera::look_at(3000, 2000, eye, Vec3::new(0.0, 0.0, 20.0), Vec3::Y, f);
                c.principal = [1500.0, 1000.0];
                c
            })
            .collect();
        let photos: Vec<PhotoPoints> = cams
            .iter()
            .enumerate()
            .map(|(i, c)| photo(c, 1.5, 30 + i as u64))
            .collect();
        let run = |deviation: f64| {
            let o = ResectionOptions {
                shared_intrinsics: false,
                focal_deviation: deviation,
                ..Default::default()
            };
            let res = resect(&photos, &o).unwrap();
            let err: Vec<f64> = res
                .iter()
                .zip(truth)
                .map(|(r, f)| (r.camera.focal_px / f - 1.0).abs())
                .collect();
            (res, err)
        };
        let (free, free_err) = run(f64::INFINITY);
        let (with_prior, prior_err) = run(0.1);
        let mean = |e: &[f64]| e.iter().sum::<f64>() / e.len() as f64;
        let worst = |e: &[f64]| e.iter().cloned().fold(0.0, f64::max);
        println!("no prior {free_err:?}\nprior {prior_err:?}");
        assert!(
            mean(&prior_err) <= mean(&free_err),
            "{prior_err:?} vs {free_err:?}"
        );
        assert!(
            worst(&prior_err) < worst(&free_err),
            "{prior_err:?} vs {free_err:?}"
        );
        // The reported standard errors are honest: each photo's focal error within 3.5 of them,
        // and the per-photo fits without the prior are the ill-determined ones.
        for (r, f) in free.iter().zip(truth) {
            let se = r.focal_se_px.unwrap();
            println!(
                "{}: f {:.0} (true {f:.0}) ± {se:.0}",
                r.photo, r.camera.focal_px
            );
            assert!(
                (r.camera.focal_px - f).abs() < 3.5 * se,
                "{}: {} vs {f} ± {se}",
                r.photo,
                r.camera.focal_px
            );
        }
        assert!(free
            .iter()
            .any(|r| r.focal_se_px.unwrap() > 0.05 * r.camera.focal_px));
        assert!(with_prior.iter().all(|r| r.distance_se > 0.0));
        // One shared camera of the earlier test's views pins f to well under 5 %.
        let same: Vec<PhotoPoints> = [-35.0, -10.0, 10.0, 35.0]
            .map(camera)
            .iter()
            .enumerate()
            .map(|(i, c)| photo(c, 1.5, 10 + i as u64))
            .collect();
        let shared = resect(&same, &ResectionOptions::default()).unwrap();
        let se = shared[0].focal_se_px.unwrap();
        assert!(se < 0.05 * shared[0].camera.focal_px, "{se}");
        assert!(
            (shared[0].camera.focal_px - 4200.0).abs() < 3.5 * se,
            "{se}"
        );
    }

    #[test]
    fn a_wrong_point_is_flagged_and_left_out() {
        let cam = camera(0.0);
        let mut p = photo(&cam, 0.5, 3);
        p.points[4].pixel += DVec2::new(60.0, -40.0);
        let r = &resect(&[p], &ResectionOptions::default()).unwrap()[0];
        let flagged: Vec<&str> = r
            .points
            .iter()
            .filter(|e| e.outlier)
            .map(|e| e.label.as_str())
            .collect();
        assert_eq!(flagged, ["v4"]);
        assert!(r.rms_px < 1.5, "{}", r.rms_px);
    }

    #[test]
    fn too_few_and_coplanar_points_are_clear_errors() {
        let cam = camera(0.0);
        let mut p = photo(&cam, 0.0, 4);
        p.points.truncate(5);
        let e = dlt(&p).unwrap_err().to_string();
        assert!(e.contains("5 correspondences") && e.contains("p4"), "{e}");
        let mut flat = photo(&cam, 0.0, 5);
        for c in &mut flat.points {
            c.world.z = 0.0;
            c.pixel = cam.project(c.world).unwrap();
        }
        let e = dlt(&flat).unwrap_err().to_string();
        assert!(e.contains("coplanar"), "{e}");
    }

    #[test]
    fn points_behind_the_camera_are_named() {
        let cam = camera(0.0);
        let mut p = photo(&cam, 0.0, 6);
        // Move one point behind the camera (its pixel as if mirrored).
        p.points[2].world = DVec3::new(0.0, 0.0, 1200.0);
        p.points[2].pixel = DVec2::new(1500.0, 1000.0);
        let r = resect(&[p], &ResectionOptions::default());
        match r {
            Err(e) => assert!(
                e.to_string().contains("behind the camera") || e.to_string().contains("v2"),
                "{e}"
            ),
            Ok(r) => assert!(
                r[0].points[2].outlier,
                "the impossible point must at least be an outlier"
            ),
        }
    }
}
