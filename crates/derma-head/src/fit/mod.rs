//! Fitting the built-in head to a user's head or face mesh: a similarity from landmarks or the
//! nose tip, optimal-step non-rigid ICP of the skin (Amberg et al. 2007), then everything the
//! head carries (landmarks, regions, face units, globes, teeth, tongue, lashes) follows.
//!
//! The result is a head like the built-in one, with the same topology and UVs, in the scan's
//! frame (mm): every command that takes a head takes it ([`crate::fitted::open`]).

pub mod align;
pub mod finish;
pub mod frame;
pub mod job;
pub mod nicp;
pub mod onto;
pub mod options;
pub mod place;
pub mod register;
pub mod scan;
pub mod store;
pub mod template;
pub mod transfer;

pub use options::{Alignment, FitError, FitOptions, FitReport, Similarity, SCALE_RANGE};

use crate::asset::{self, Asset, EyeSphere, SparseTarget};
use crate::Head;
use derma_core::mesh::TriMesh;
use derma_core::progress::{Progress, Unit};
use glam::Vec3;
use rayon::prelude::*;
use scan::Scan;
use std::time::Instant;
use template::Template;

/// A head fitted to a scan: what differs from the built-in head, and the correspondence.
pub struct Fitted {
    /// Every asset vertex's position (mm, the scan's frame): the skin's control cage and the
    /// parts.
    pub positions: Vec<Vec3>,
    /// The twice-subdivided skin's positions (per topological vertex), projected onto the scan.
    pub fine: Vec<Vec3>,
    /// Eye globes: left, right.
    pub eyes: [EyeSphere; 2],
    /// The 52 face units, transferred (asset vertex, offset in mm).
    pub targets: Vec<SparseTarget>,
    /// How it went.
    pub report: FitReport,
    /// The template's first placement (template mm → scan mm).
    pub similarity: Similarity,
}

/// A point on a mesh: triangle and barycentric weights of its corners 1 and 2 (`None` where
/// nothing lies close).
pub type SurfacePoint = Option<(u32, [f32; 2])>;

impl Fitted {
    /// The fitted head.
    pub fn head(&self) -> Head {
        let mut a = asset::parse();
        self.apply(&mut a);
        Head::from_asset(a, Some(&self.fine))
    }

    /// Puts the fit into an asset of the built-in head.
    pub(crate) fn apply(&self, a: &mut Asset) {
        a.positions.clone_from(&self.positions);
        for (side, e) in ["left", "right"].iter().zip(&self.eyes) {
            a.meta.eyes.insert((*side).into(), *e);
        }
        a.targets.clone_from(&self.targets);
    }
}

/// Template → scan: where each vertex of the fitted head's skin lies on the scan (within 5 mm).
pub fn template_to_scan(head: &Head, scan: &TriMesh) -> Vec<SurfacePoint> {
    let bvh = derma_core::bvh::Bvh::new(&scan.positions, &scan.triangles);
    head.skin
        .positions
        .par_iter()
        .map(|p| bvh.closest(*p, 5.0).map(|c| (c.triangle, c.bary)))
        .collect()
}

/// Scan → template: where each scan vertex lies on the fitted head's skin (within 10 mm), the
/// thesis' B map (EyeMove, eq. 3.4) for the user's own mesh.
pub fn scan_to_template(head: &Head, scan: &TriMesh) -> Vec<SurfacePoint> {
    let bvh = derma_core::bvh::Bvh::new(&head.skin.positions, &head.skin.triangles);
    scan.positions
        .par_iter()
        .map(|p| bvh.closest(*p, 10.0).map(|c| (c.triangle, c.bary)))
        .collect()
}

/// The template's face as the search for a face sees it ([`frame::Face`]): the once-subdivided
/// outer skin between menton and hairline, 20 mm in front of the ears, with its normals.
pub struct TemplateFace {
    /// Points (template mm).
    pub points: Vec<Vec3>,
    /// Their normals.
    pub normals: Vec<Vec3>,
    /// The nose tip.
    pub nose: Vec3,
    /// Menton to hairline (mm).
    pub height: f32,
    /// Points of the whole head above the chin (the face, cranium and ears; template mm).
    pub head_points: Vec<Vec3>,
    /// Their normals.
    pub head_normals: Vec<Vec3>,
    /// Points of the nose (the face within 25 mm of its tip).
    pub nose_points: Vec<Vec3>,
    /// Their normals.
    pub nose_normals: Vec<Vec3>,
}

impl TemplateFace {
    /// The built-in head's.
    pub fn builtin() -> TemplateFace {
        let tpl = Template::of(&asset::parse());
        let (points, normals, _) = face_points(&tpl);
        let lm = |n: &str| tpl.landmark(n);
        let l1 = tpl.stencils1.apply(&tpl.coarse.positions);
        let n1 = Template::normals(&tpl.level1, &l1);
        let head: Vec<usize> = (0..l1.len())
            .filter(|&i| tpl.outer1[i] && l1[i].y > lm("menton").y)
            .step_by(4)
            .collect();
        let nose = lm("nose_tip");
        let near_nose: Vec<usize> = (0..points.len())
            .filter(|&i| points[i].distance(nose) < 25.0)
            .collect();
        TemplateFace {
            nose_points: near_nose.iter().map(|&i| points[i]).collect(),
            nose_normals: near_nose.iter().map(|&i| normals[i]).collect(),
            points,
            normals,
            nose,
            height: lm("hairline").y - lm("menton").y,
            head_points: head.iter().map(|&i| l1[i]).collect(),
            head_normals: head.iter().map(|&i| n1[i]).collect(),
        }
    }

    /// As the search takes it.
    pub fn view(&self) -> frame::Face<'_> {
        frame::Face {
            points: &self.points,
            normals: &self.normals,
            nose: self.nose,
            height: self.height,
            head_points: &self.head_points,
            head_normals: &self.head_normals,
            nose_points: &self.nose_points,
            nose_normals: &self.nose_normals,
        }
    }
}

/// The face's once-subdivided points and normals (template mm) and their level-1 indices.
fn face_points(tpl: &Template) -> (Vec<Vec3>, Vec<Vec3>, Vec<usize>) {
    let l1 = tpl.stencils1.apply(&tpl.coarse.positions);
    let n1 = Template::normals(&tpl.level1, &l1);
    let on_face = in_face(tpl);
    let face1: Vec<usize> = (0..l1.len())
        .filter(|&i| tpl.outer1[i] && on_face(l1[i]))
        .collect();
    (
        face1.iter().map(|&i| l1[i]).collect(),
        face1.iter().map(|&i| n1[i]).collect(),
        face1,
    )
}

/// The automatic alignment of a scan already in mm (any orientation): where the search finds
/// the face ([`frame::search`] at 1 mm per unit), in the scan's own coordinates.
pub fn auto_alignment(scan: &TriMesh) -> Result<Alignment, FitError> {
    let face = TemplateFace::builtin();
    let given = frame::Given {
        mm_per_unit: Some(1.0),
        axes: None,
    };
    let found = frame::search(&Scan::new(scan.clone()), &face.view(), given)?;
    Ok(Alignment::Auto(found.placement))
}

/// Where the face search puts the template on a scan already in mm and upright.
fn search_upright(scan: &Scan) -> Result<Similarity, FitError> {
    let face = TemplateFace::builtin();
    let upright = frame::Given {
        mm_per_unit: Some(1.0),
        axes: Some(glam::Mat3::IDENTITY),
    };
    Ok(frame::search(scan, &face.view(), upright)?.start)
}

/// Fits the built-in head to `scan` (mm, in derma's frame: +Y up, facing +Z; see
/// [`frame::search`] for a scan in any unit and orientation): placement, registration, the
/// corners found again and held, then the skin finished and everything else carried.
pub fn fit(scan: TriMesh, opts: &FitOptions, progress: &dyn Progress) -> Result<Fitted, FitError> {
    let mut laps = Laps::start();
    progress.stage("prepare the scan", 1, Unit::Steps);
    let asset = asset::parse();
    let tpl = Template::of(&asset);
    let scan = Scan::new(scan);
    laps.lap("prepare");
    let searched;
    let opts = match opts.alignment {
        Alignment::Search => {
            searched = FitOptions {
                alignment: Alignment::Auto(search_upright(&scan)?),
                ..opts.clone()
            };
            &searched
        }
        _ => opts,
    };

    progress.stage("align", 1, Unit::Steps);
    let (face_pts, face_nrm, face1) = face_points(&tpl);
    let placed = place::place(&tpl, &scan, &face_pts, &face_nrm, opts)?;
    laps.lap("align");

    let reg = register::Registration::new(&tpl, &scan, &placed.sim, &face1);
    let given = pins_of_landmarks(&tpl, &placed);
    let mut pins = given.clone();
    pins.extend(pins_of_corners(&tpl, &placed.detected));
    let (x, mut last, mut iterations) = reg.run(opts, &pins, progress)?;
    // Found again where the registration put the openings (automatic alignment only).
    let (x, detected) = if opts.alignment.is_automatic() {
        let (r, found) = reg.refine_corners(x, &given, opts, progress)?;
        (last, iterations) = (r.residual, iterations + r.iterations);
        (r.x, found)
    } else {
        (x, placed.detected)
    };
    laps.lap("non-rigid registration");
    // Converged: close to the scan, with most of the face on it.
    let no_convergence = |rms_mm: f32| FitError::NoConvergence {
        rms_mm,
        iterations,
        limit_mm: opts.max_residual_mm,
    };
    if !(last.0 <= opts.max_residual_mm) || last.1 < 0.5 {
        return Err(no_convergence(last.0));
    }

    progress.stage("project and transfer", 1, Unit::Steps);
    let moved: Vec<Vec3> = (0..reg.control.len())
        .map(|j| x.moved(j, reg.control[j]))
        .collect();
    let mut fine = tpl.stencils2.apply(&moved);
    let template_fine: Vec<Vec3> = tpl.stencils2.apply(&reg.control);
    // Onto a scan at least as fine as the skin (its median edge within 3 mm; the skin's are
    // about 1.5 mm); a coarser scan's facets are not the face's shape.
    if reg.fine_scan {
        finish::project(&scan, &tpl, &mut fine);
    }
    finish::untangle(&tpl, &mut fine, &template_fine);
    let median = finish::median_distance(&scan, &fine, &face_vertices(&tpl))
        .ok_or_else(|| no_convergence(f32::INFINITY))?;
    let carried = transfer::carry(&asset, &tpl, &placed.sim, &x, &reg.control, &fine)?;
    laps.lap("project and transfer");
    let report = FitReport {
        alignment: match &opts.alignment {
            Alignment::Landmarks(_) => format!("landmarks: {}", placed.given.len()),
            Alignment::Auto(_) | Alignment::Search => "auto (the face found at every orientation and size, then similarity ICP; eye and mouth corners)".into(),
        },
        scale: placed.sim.scale,
        iterations,
        rms_mm: last.0,
        median_mm: median,
        matched: last.1,
        projected: reg.fine_scan,
        flipped: finish::flipped_quads(&tpl, &fine, &template_fine),
        landmark_mm: placed
            .given
            .iter()
            .map(|(n, _, q)| (n.clone(), (fine[tpl.landmarks[n]] - *q).length()))
            .collect(),
        detected: align::CORNERS
            .iter()
            .zip(&detected)
            .filter_map(|(n, p)| Some((n.to_string(), p.as_ref()?.to_array())))
            .collect(),
        corner_gap_mm: corner_gaps(&tpl, &fine, &detected),
        opening_corners: opening_corners(&tpl, &fine),
        seconds: laps.seconds,
        frame: None,
    };
    Ok(Fitted {
        positions: carried.positions,
        fine,
        eyes: carried.eyes,
        targets: carried.targets,
        report,
        similarity: placed.sim,
    })
}

/// Seconds per stage, from the fit's start.
struct Laps {
    seconds: Vec<(String, f64)>,
    since: Instant,
}

impl Laps {
    fn start() -> Laps {
        Laps {
            seconds: Vec::new(),
            since: Instant::now(),
        }
    }

    fn lap(&mut self, name: &str) {
        self.seconds
            .push((name.into(), self.since.elapsed().as_secs_f64()));
        self.since = Instant::now();
    }
}

/// Given landmarks as pins: each landmark's fine vertex held where it was given (the hairline,
/// a soft boundary, places the template but is not pinned).
fn pins_of_landmarks(tpl: &Template, placed: &place::Placement) -> Vec<register::Pin> {
    placed
        .given
        .iter()
        .filter(|g| g.0 != "hairline")
        .map(|(n, _, q)| (tpl.stencils2.rows[tpl.landmarks[n]].clone(), *q))
        .collect()
}

/// Detected corners as pins: each holds the template's corner of the same opening (its
/// margin's extreme vertex, found by the same rule).
fn pins_of_corners(tpl: &Template, detected: &[Option<Vec3>; 6]) -> Vec<register::Pin> {
    let margin2 = Template::margin(&tpl.level2, &tpl.outer2);
    let corners = align::CORNERS.map(|n| tpl.landmark(n));
    (0..6)
        .filter_map(|k| {
            let q = detected[k]?;
            let v = align::opening_corner(&tpl.level2.positions, &margin2, &corners, k)?;
            Some((tpl.stencils2.rows[v].clone(), q))
        })
        .collect()
}

/// The fitted skin's opening corners: per corner of [`align::CORNERS`], its margin vertex.
fn opening_corner_vertices(tpl: &Template, fine: &[Vec3]) -> [Option<usize>; 6] {
    let margin2 = Template::margin(&tpl.level2, &tpl.outer2);
    let fitted = align::CORNERS.map(|n| fine[tpl.landmarks[n]]);
    std::array::from_fn(|k| align::opening_corner(fine, &margin2, &fitted, k))
}

/// The corners of the fitted skin's openings, where its lid and lip margins meet on the surface
/// (derma's canthus landmarks lie inside the socket, where the lids meet the globe).
fn opening_corners(tpl: &Template, fine: &[Vec3]) -> Vec<(String, [f32; 3])> {
    let v = opening_corner_vertices(tpl, fine);
    (0..6)
        .filter_map(|k| Some((align::CORNERS[k].to_string(), fine[v[k]?].to_array())))
        .collect()
}

/// Each detected corner's distance from the fitted skin's corner of the same opening.
fn corner_gaps(tpl: &Template, fine: &[Vec3], detected: &[Option<Vec3>; 6]) -> Vec<(String, f32)> {
    let v = opening_corner_vertices(tpl, fine);
    (0..6)
        .filter_map(|k| {
            Some((
                align::CORNERS[k].to_string(),
                fine[v[k]?].distance(detected[k]?),
            ))
        })
        .collect()
}

/// The fitted skin's face vertices (fine level): outer skin between menton and hairline, 20 mm
/// in front of the ears.
fn face_vertices(tpl: &Template) -> Vec<usize> {
    let on_face = in_face(tpl);
    (0..tpl.level2.positions.len())
        .filter(|&i| tpl.outer2[i] && on_face(tpl.level2.positions[i]))
        .collect()
}

/// Whether a template point (mm) lies on the face: 20 mm in front of the ears, from 5 mm
/// below the menton to 5 mm above the hairline.
fn in_face(tpl: &Template) -> impl Fn(Vec3) -> bool {
    let lm = |n: &str| tpl.landmark(n);
    let ear_z = 0.5 * (lm("ear_left").z + lm("ear_right").z);
    let (y_lo, y_hi) = (lm("menton").y - 5.0, lm("hairline").y + 5.0);
    move |p| p.z > ear_z + 20.0 && (y_lo..y_hi).contains(&p.y)
}
