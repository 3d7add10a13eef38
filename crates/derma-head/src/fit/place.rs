//! The template's first placement on a scan (docs/head.md, "Fitting your head", step 2): from
//! given landmarks (Umeyama 1991) or where the face search put it, refined by a trimmed
//! similarity ICP of the face, checked to be a face the right way out, with the eye and mouth
//! corners found near where it puts them.

use super::align;
use super::options::{Alignment, FitError, FitOptions, Similarity, SCALE_RANGE};
use super::scan::Scan;
use super::template::Template;
use glam::Vec3;

/// Where the template goes, and what holds it there.
pub struct Placement {
    /// The similarity (template mm → scan mm).
    pub sim: Similarity,
    /// Given landmarks: name, the template's position, the scan's.
    pub given: Vec<(String, Vec3, Vec3)>,
    /// The eye and mouth corners found on the scan ([`align::CORNERS`]; automatic alignment).
    pub detected: [Option<Vec3>; 6],
}

/// Places the template's face (`pts`, `nrm`: template mm) on the scan.
pub fn place(
    tpl: &Template,
    scan: &Scan,
    pts: &[Vec3],
    nrm: &[Vec3],
    opts: &FitOptions,
) -> Result<Placement, FitError> {
    let lm = |n: &str| tpl.landmark(n);
    let mut given: Vec<(String, Vec3, Vec3)> = Vec::new();
    let start = match &opts.alignment {
        Alignment::Landmarks(l) => {
            let named: Vec<(String, Vec3)> = l
                .points
                .iter()
                .filter(|(n, _)| !n.starts_with("eye_centre"))
                .map(|(n, p)| (n.clone(), *p))
                .collect();
            align::check_on_surface(scan, &named, 10.0)?;
            for (n, p) in named {
                if tpl.landmarks.contains_key(&n) {
                    given.push((n.clone(), lm(&n), p));
                }
            }
            let src: Vec<Vec3> = given.iter().map(|g| g.1).collect();
            let dst: Vec<Vec3> = given.iter().map(|g| g.2).collect();
            align::umeyama(&src, &dst, &vec![1.0; src.len()]).ok_or_else(|| FitError::Landmark {
                name: given.iter().map(|g| g.0.as_str()).collect::<Vec<_>>().join(", "),
                detail: "these do not fix a placement; give at least the canthi, the nose tip and the mouth corners".into(),
            })?
        }
        Alignment::Auto(start) => *start,
        // `fit` runs the search first ([`Alignment::Search`] never reaches here).
        Alignment::Search => {
            return Err(FitError::Scan(
                "the face was not searched for before the placement".into(),
            ))
        }
    };
    check_orientation(scan, pts, nrm, &start)?;
    let (sim, share) = align::icp(scan, pts, nrm, start, 15, 30.0);
    check_face(scan, &sim, share, lm("nose_tip"))?;
    // The eye and mouth corners, found on the scan near where the placement puts them.
    let detected = if opts.alignment.is_automatic() {
        align::detect_corners(scan, &align::CORNERS.map(|n| sim.apply(lm(n))))
    } else {
        [None; 6]
    };
    Ok(Placement {
        sim,
        given,
        detected,
    })
}

/// Refuses a placement that is no face: a scale outside another adult's, too little of the
/// face on the scan (`share`), or the nose tip off it.
fn check_face(scan: &Scan, sim: &Similarity, share: f32, nose_tip: Vec3) -> Result<(), FitError> {
    let nose_gap = scan
        .bvh
        .closest(sim.apply(nose_tip), f32::INFINITY)
        .map(|c| c.distance)
        .unwrap_or(f32::INFINITY);
    if !(SCALE_RANGE.0..=SCALE_RANGE.1).contains(&sim.scale) {
        return Err(FitError::Scan(format!(
            "no face found on the scan: matching the template's face to it would scale the head ×{:.2} (another adult's head is within ×{}–{} once the scan is in mm); check the scan's unit, or give landmarks",
            sim.scale, SCALE_RANGE.0, SCALE_RANGE.1
        )));
    }
    if share < 0.5 || nose_gap > 8.0 {
        return Err(FitError::Scan(format!(
            "no face found on the scan: after alignment {:.0} % of the template's face lies within reach of it and the nose tip is {nose_gap:.1} mm from it (a face needs ≥ 50 % and ≤ 8 mm); give its axes or landmarks",
            share * 100.0
        )));
    }
    Ok(())
}

/// Refuses a scan whose triangles face inward: near the placed template's face, most closest
/// scan triangles face against the template's normals.
fn check_orientation(
    scan: &Scan,
    pts: &[Vec3],
    normals: &[Vec3],
    s: &Similarity,
) -> Result<(), FitError> {
    let (mut with, mut against) = (0usize, 0usize);
    for (p, n) in pts.iter().zip(normals).step_by(4) {
        if let Some(c) = scan.bvh.closest(s.apply(*p), 15.0) {
            let d = scan.face_normals[c.triangle as usize].dot(s.rotation * *n);
            with += (d > 0.5) as usize;
            against += (d < -0.5) as usize;
        }
    }
    if against > 2 * with && against > 20 {
        return Err(FitError::Scan(format!(
            "the scan's triangles face inward ({against} of {} face points near the template face against it): flip its normals (reverse the winding) and try again",
            with + against
        )));
    }
    Ok(())
}
