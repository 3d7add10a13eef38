//! Fitting the built-in head to a user's head or face mesh: a similarity from landmarks or the
//! nose tip, optimal-step non-rigid ICP of the skin (Amberg et al. 2007), then everything the
//! head carries (landmarks, regions, face units, globes, teeth, tongue, lashes) follows.
//!
//! The result is a head like the built-in one, with the same topology and UVs, in the scan's
//! frame (mm): every command that takes a head takes it ([`crate::fitted::open`]).

pub mod align;
pub mod frame;
pub mod job;
pub mod nicp;
pub mod onto;
pub mod options;
pub mod scan;
pub mod store;
pub mod template;
pub mod transfer;

pub use options::{Alignment, FitError, FitOptions, FitReport, Similarity, SCALE_RANGE};

use crate::asset::{self, Asset, EyeSphere, SparseTarget};
use crate::Head;
use derma_core::mesh::TriMesh;
use derma_core::progress::{Progress, Unit};
use glam::{Mat3, Vec3};
use nicp::{Affines, Pattern, Problem};
use rayon::prelude::*;
use scan::Scan;
use std::collections::HashMap;
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

/// Half-width (mm) of the band along the lid and lip margins left unmatched, on scans fine
/// enough to show the margins (median edge within [`FINE_SCAN_MM`]).
pub const MARGIN_BAND_MM: f32 = 3.0;
/// The band on coarser scans (a face mask whose eyes and mouth are closed surfaces of 5–10 mm
/// triangles): on MediaPipe's canonical face the 3 mm band leaves 346 triangles turned over at
/// the canthi and mouth corners, 6 mm none.
pub const COARSE_MARGIN_BAND_MM: f32 = 6.0;
/// Median edge (mm) up to which a scan counts as fine: projected onto, with the narrow band.
pub const FINE_SCAN_MM: f32 = 3.0;

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
    let lm = |n: &str| tpl.landmark(n);
    let ear_z = 0.5 * (lm("ear_left").z + lm("ear_right").z);
    let (y_lo, y_hi) = (lm("menton").y - 5.0, lm("hairline").y + 5.0);
    let face1: Vec<usize> = (0..l1.len())
        .filter(|&i| tpl.outer1[i] && l1[i].z > ear_z + 20.0 && (y_lo..y_hi).contains(&l1[i].y))
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

/// Fits the built-in head to `scan` (mm, in derma's frame: +Y up, facing +Z; see
/// [`frame::search`] for a scan in any unit and orientation).
pub fn fit(scan: TriMesh, opts: &FitOptions, progress: &dyn Progress) -> Result<Fitted, FitError> {
    let mut seconds: Vec<(String, f64)> = Vec::new();
    let mut clock = Instant::now();
    let mut lap = |name: &str, seconds: &mut Vec<(String, f64)>| {
        seconds.push((name.into(), clock.elapsed().as_secs_f64()));
        clock = Instant::now();
    };
    progress.stage("prepare the scan", 1, Unit::Steps);
    let asset = asset::parse();
    let tpl = Template::of(&asset);
    let scan = Scan::new(scan);
    lap("prepare", &mut seconds);

    // The template's face points (once subdivided) for the alignment.
    let (face_pts, face_nrm, face1) = face_points(&tpl);
    let lm = |n: &str| tpl.landmark(n);
    let ear_z = 0.5 * (lm("ear_left").z + lm("ear_right").z);
    let (y_lo, y_hi) = (lm("menton").y - 5.0, lm("hairline").y + 5.0);

    progress.stage("align", 1, Unit::Steps);
    // Landmarks: the fine vertex of each named landmark, as a combination of control vertices.
    let local: HashMap<u32, u32> = tpl
        .coarse_ids
        .iter()
        .enumerate()
        .map(|(i, &v)| (v, i as u32))
        .collect();
    let mut given: Vec<(String, Vec3, Vec3)> = Vec::new(); // name, template, scan
    let start = match &opts.alignment {
        Alignment::Landmarks(l) => {
            let named: Vec<(String, Vec3)> = l
                .points
                .iter()
                .filter(|(n, _)| !n.starts_with("eye_centre"))
                .map(|(n, p)| (n.clone(), *p))
                .collect();
            align::check_on_surface(&scan, &named, 10.0)?;
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
    };
    check_orientation(&scan, &face_pts, &face_nrm, &start)?;
    let (sim, share) = align::icp(&scan, &face_pts, &face_nrm, start, 15, 30.0);
    let nose = sim.apply(lm("nose_tip"));
    let nose_gap = scan
        .bvh
        .closest(nose, f32::INFINITY)
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
            "no face found on the scan: after alignment {:.0} % of the template's face lies within reach of it and the nose tip is {nose_gap:.1} mm from it (a face needs ≥ 50 % and ≤ 8 mm); a head faces +Z with +Y up, or give landmarks",
            share * 100.0
        )));
    }
    // The eye and mouth corners, found on the scan near where the placement puts them.
    let detected: [Option<Vec3>; 6] = match opts.alignment {
        Alignment::Auto(_) => {
            align::detect_corners(&scan, &align::CORNERS.map(|n| sim.apply(lm(n))))
        }
        Alignment::Landmarks(_) => [None; 6],
    };
    // The skin's margin vertices (fine level), where the openings' corners lie.
    let margin2 = Template::margin(&tpl.level2, &tpl.outer2);
    lap("align", &mut seconds);

    // Non-rigid registration of the control cage.
    let control: Vec<Vec3> = tpl.coarse.positions.iter().map(|p| sim.apply(*p)).collect();
    let rows: Vec<Vec<(u32, f32)>> = (0..tpl.level1.positions.len())
        .filter(|&i| tpl.outer1[i])
        .map(|i| tpl.stencils1.rows[i].clone())
        .collect();
    let outer_ids: Vec<usize> = (0..tpl.level1.positions.len())
        .filter(|&i| tpl.outer1[i])
        .collect();
    let is_face: Vec<bool> = {
        let f: std::collections::HashSet<usize> = face1.iter().copied().collect();
        outer_ids.iter().map(|i| f.contains(i)).collect()
    };
    // The lid and lip margins are not matched: a scan's eyes may be closed or bulge where the
    // template's openings are, and its mouth shut; they follow their surroundings.
    let fine_scan = scan.median_edge_mm() <= FINE_SCAN_MM;
    let band = if fine_scan {
        MARGIN_BAND_MM
    } else {
        COARSE_MARGIN_BAND_MM
    };
    let near_margin = tpl.margin_band(&tpl.stencils1.apply(&tpl.coarse.positions), band);
    // The face points the fit may match (the margin band is left out on purpose).
    let face_matchable = outer_ids
        .iter()
        .zip(&is_face)
        .filter(|(&i, &f)| f && !near_margin[i])
        .count();
    // The hairline is a soft boundary: it places the template, it does not pin it.
    let mut lm_rows: Vec<(Vec<(u32, f32)>, Vec3)> = given
        .iter()
        .filter(|g| g.0 != "hairline")
        .map(|(n, _, q)| (tpl.stencils2.rows[tpl.landmarks[n]].clone(), *q))
        .collect();
    // Detected corners hold the template's corner of the same opening (its margin's extreme
    // vertex, found by the same rule), like given landmarks.
    let template_corners = align::CORNERS.map(lm);
    for (k, q) in detected.iter().enumerate() {
        let corner = align::opening_corner(&tpl.level2.positions, &margin2, &template_corners, k);
        if let (Some(q), Some(v)) = (q, corner) {
            lm_rows.push((tpl.stencils2.rows[v].clone(), *q));
        }
    }
    let extra: Vec<Vec<(u32, f32)>> = lm_rows.iter().map(|r| r.0.clone()).collect();
    let problem = Problem {
        control: &control,
        edges: &tpl.edges,
        points: &rows,
    };
    let pattern = Pattern::new(&problem, &extra)?;
    let frame = Affines::identity(&control);
    let mut x = frame.clone();
    let alpha0 = opts.stiffness.first().copied().unwrap_or(1.0);
    let total = (opts.stiffness.len() * opts.iterations) as u64;
    progress.stage("non-rigid registration", total, Unit::Steps);
    let mut iterations = 0;
    let mut last: (f32, f32) = (f32::INFINITY, 0.0);
    for &alpha in &opts.stiffness {
        let tau = (opts.max_distance_mm * (alpha / alpha0).sqrt() as f32).max(6.0);
        let mut system: Option<nicp::System> = None;
        for it in 0..opts.iterations {
            let all = nicp::positions(&problem, &x, &tpl.stencils1);
            let normals = Template::normals(&tpl.level1, &all);
            let found: Vec<Option<Vec3>> = outer_ids
                .par_iter()
                .map(|&i| {
                    if near_margin[i] {
                        return None;
                    }
                    scan.matched(all[i], normals[i], tau).map(|c| c.point)
                })
                .collect();
            let (mut sum, mut n, mut matched) = (0.0f64, 0usize, 0usize);
            for (k, t) in found.iter().enumerate() {
                if is_face[k] {
                    if let Some(q) = t {
                        sum += (all[outer_ids[k]] - *q).length_squared() as f64;
                        n += 1;
                    }
                    matched += t.is_some() as usize;
                }
            }
            // No matched face point: the fit has lost the scan (an infinite residual).
            let rms = if n == 0 {
                f32::INFINITY
            } else {
                (sum / n as f64).sqrt() as f32
            };
            last = (rms, matched as f32 / face_matchable.max(1) as f32);
            // A point matched at the stiffness's first iteration and unmatched later is held
            // where it is.
            let targets: Vec<Vec3> = found
                .iter()
                .zip(&outer_ids)
                .map(|(t, &i)| t.unwrap_or(all[i]))
                .collect();
            if system.is_none() {
                let weights = found.iter().map(|t| t.is_some() as u8 as f32).collect();
                system = Some(nicp::System::new(
                    &problem,
                    &pattern,
                    &frame,
                    alpha,
                    weights,
                    &extra,
                    nicp::LANDMARK_WEIGHT,
                )?);
            }
            let mut next = system.as_ref().expect("built").solve(&targets, &lm_rows)?;
            let change = next.change(&x);
            if it > 0 {
                next.relax(&x, nicp::RELAXATION);
            }
            x = next;
            iterations += 1;
            progress.advance(1);
            if change < 1e-4 {
                progress.advance((opts.iterations - it - 1) as u64);
                break;
            }
        }
    }
    lap("non-rigid registration", &mut seconds);
    // Converged: close to the scan, with most of the face on it.
    if !(last.0 <= opts.max_residual_mm) || last.1 < 0.5 {
        return Err(FitError::NoConvergence {
            rms_mm: last.0,
            iterations,
            limit_mm: opts.max_residual_mm,
        });
    }

    progress.stage("project and transfer", 1, Unit::Steps);
    let moved: Vec<Vec3> = (0..control.len()).map(|j| x.moved(j, control[j])).collect();
    let mut fine = tpl.stencils2.apply(&moved);
    let template_fine: Vec<Vec3> = tpl.stencils2.apply(&control);
    // Onto a scan at least as fine as the skin (its median edge within 3 mm; the skin's are
    // about 1.5 mm); a coarser scan's facets are not the face's shape.
    let projected = fine_scan;
    if projected {
        project(&scan, &tpl, &mut fine);
    }
    untangle(&tpl, &mut fine, &template_fine);
    let flipped = flipped_quads(&tpl, &fine, &template_fine);
    // The detected corners against the fitted skin's corners of the same openings.
    let fitted_corners = align::CORNERS.map(|n| fine[tpl.landmarks[n]]);
    let corner_gap_mm: Vec<(String, f32)> = (0..6)
        .filter_map(|k| {
            let q = detected[k]?;
            let v = align::opening_corner(&fine, &margin2, &fitted_corners, k)?;
            Some((align::CORNERS[k].to_string(), fine[v].distance(q)))
        })
        .collect();
    let face2: Vec<usize> = (0..fine.len())
        .filter(|&i| {
            let p = tpl.level2.positions[i];
            tpl.outer2[i] && p.z > ear_z + 20.0 && (y_lo..y_hi).contains(&p.y)
        })
        .collect();
    let mut dist: Vec<f32> = face2
        .par_iter()
        .filter_map(|&i| scan.bvh.closest(fine[i], 10.0).map(|c| c.distance))
        .collect();
    dist.sort_by(f32::total_cmp);
    let Some(&median) = dist.get(dist.len() / 2) else {
        return Err(FitError::NoConvergence {
            rms_mm: f32::INFINITY,
            iterations,
            limit_mm: opts.max_residual_mm,
        });
    };

    // Parts and globes follow the local maps; face units by deformation transfer.
    let map = transfer::LocalMap {
        affines: &x,
        control: &control,
    };
    let mut positions = asset.positions.clone();
    for (j, &v) in tpl.coarse_ids.iter().enumerate() {
        positions[v as usize] = moved[j];
    }
    let is_skin = |v: u32| local.contains_key(&v);
    // Each part vertex's local map, once: its position and, for the face units, its offsets.
    let part_maps: HashMap<u32, Mat3> = (0..asset.positions.len() as u32)
        .into_par_iter()
        .filter(|&v| !is_skin(v))
        .map(|v| {
            let p = sim.apply(asset.positions[v as usize]);
            (v, map.linear(p))
        })
        .collect();
    for (v, p) in positions.iter_mut().enumerate() {
        if !is_skin(v as u32) {
            *p = map.point(sim.apply(asset.positions[v]));
        }
    }
    let eye = |side: &str| {
        let e = asset.meta.eyes[side];
        let c = sim.apply(Vec3::from(e.centre));
        let l = map.linear(c);
        EyeSphere {
            centre: map.point(c).to_array(),
            radius: e.radius * sim.scale * l.determinant().abs().cbrt(),
        }
    };
    let mut eyes = [eye("left"), eye("right")];
    let forward = sim.rotation * Vec3::Z;
    for e in &mut eyes {
        seat_globe(e, &fine, &tpl.outer2, forward);
    }
    let triangles: Vec<[u32; 3]> = tpl
        .coarse
        .quads
        .iter()
        .flat_map(|q| [[q[0].0, q[1].0, q[2].0], [q[0].0, q[2].0, q[3].0]])
        .collect();
    let sr = sim.rotation * sim.scale;
    let targets: Vec<SparseTarget> = asset
        .targets
        .par_iter()
        .map(|t| -> Result<SparseTarget, FitError> {
            let skin: HashMap<u32, Vec3> = t
                .offsets
                .iter()
                .filter_map(|&(v, d)| local.get(&v).map(|&l| (l, sr * d)))
                .collect();
            let mut offsets: Vec<(u32, Vec3)> =
                transfer::deformation_transfer(&triangles, &control, &moved, &skin)?
                    .into_iter()
                    .filter(|(_, d)| d.length_squared() > 1e-10)
                    .map(|(l, d)| (tpl.coarse_ids[l as usize], d))
                    .collect();
            for &(v, d) in &t.offsets {
                if let Some(l) = part_maps.get(&v) {
                    offsets.push((v, *l * (sr * d)));
                }
            }
            offsets.sort_by_key(|o| o.0);
            Ok(SparseTarget {
                name: t.name.clone(),
                offsets,
            })
        })
        .collect::<Result<_, _>>()?;
    lap("project and transfer", &mut seconds);

    let landmark_mm = given
        .iter()
        .map(|(n, _, q)| (n.clone(), (fine[tpl.landmarks[n]] - *q).length()))
        .collect();
    Ok(Fitted {
        positions,
        fine,
        eyes,
        targets,
        report: FitReport {
            alignment: match &opts.alignment {
                Alignment::Landmarks(_) => format!("landmarks: {}", given.len()),
                Alignment::Auto(_) => {
                    "auto (the face found at every orientation and size, then similarity ICP; eye and mouth corners)".into()
                }
            },
            scale: sim.scale,
            iterations,
            rms_mm: last.0,
            median_mm: median,
            matched: last.1,
            projected,
            flipped,
            landmark_mm,
            detected: align::CORNERS
                .iter()
                .zip(&detected)
                .filter_map(|(n, p)| Some((n.to_string(), p.as_ref()?.to_array())))
                .collect(),
            corner_gap_mm,
            seconds,
            frame: None,
        },
        similarity: sim,
    })
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

/// Moves the outer skin's fine vertices onto the scan along their normals (within 2.5 mm, where
/// the scan faces the same way), then undoes the move on any quad it would turn over.
fn project(scan: &Scan, tpl: &Template, fine: &mut [Vec3]) {
    let normals = Template::normals(&tpl.level2, fine);
    let moved: Vec<Option<Vec3>> = (0..fine.len())
        .into_par_iter()
        .map(|i| {
            if !tpl.outer2[i] {
                return None;
            }
            let (p, n) = (fine[i], normals[i]);
            let hit = |d: Vec3| scan.bvh.nearest(p, d, 0.0, 2.5).map(|h| (h.t, h.triangle));
            let best = match (hit(n), hit(-n)) {
                (Some(a), Some(b)) => Some(if a.0 <= b.0 {
                    (a.0, a.1, n)
                } else {
                    (b.0, b.1, -n)
                }),
                (Some(a), None) => Some((a.0, a.1, n)),
                (None, Some(b)) => Some((b.0, b.1, -n)),
                (None, None) => None,
            }?;
            let t = best.1 as usize;
            (!scan.on_border[t] && scan.face_normals[t].dot(n) >= scan::NORMAL_COS)
                .then(|| p + best.2 * best.0)
        })
        .collect();
    let before = fine.to_vec();
    for (f, m) in fine.iter_mut().zip(&moved) {
        if let Some(q) = m {
            *f = *q;
        }
    }
    // Undo on quads either of whose triangles turns against its pre-projection orientation
    // (or by more than 75°); repeat, as undoing one quad can turn a neighbour.
    for _ in 0..8 {
        let mut undone = false;
        for q in &tpl.level2.quads {
            let [a, b, c, d] = q.map(|c| c.0 as usize);
            let turned = [[a, b, c], [a, c, d]].iter().any(|t| {
                let n = |p: &[Vec3]| (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]);
                let (n0, n1) = (n(&before), n(fine));
                n0.dot(n1) <= 0.25 * n0.length() * n1.length()
            });
            if turned {
                for v in [a, b, c, d] {
                    if fine[v] != before[v] {
                        fine[v] = before[v];
                        undone = true;
                    }
                }
            }
        }
        if !undone {
            break;
        }
    }
}

/// Smooths away folds, locally, in two passes (what remains is reported as `flipped`):
/// 1. the corners of every triangle turned over against the template, and their ring, move to
///    their neighbours' mean (umbrella smoothing), for at most 50 rounds: small folds on the
///    surface open;
/// 2. where folds remain (an ear or a canthus the registration folded, its scan's shape unlike
///    the template's), the displacement from the placed template is smoothed instead, over a
///    region that grows by a ring at a time: the template's own shape returns there, moved
///    with its surroundings.
fn untangle(tpl: &Template, fine: &mut [Vec3], template: &[Vec3]) {
    let ring = vertex_rings(tpl, fine.len());
    for _ in 0..50 {
        let bad = folded(tpl, fine, template, 0.1);
        if bad.is_empty() {
            return;
        }
        let region = grown(&bad, &ring, 1);
        let next: Vec<Vec3> = region
            .iter()
            .map(|&v| mean(&ring[v], |u| fine[u]))
            .collect();
        for (&v, p) in region.iter().zip(next) {
            fine[v] = p;
        }
    }
    for rings in 1..=40 {
        let bad = folded(tpl, fine, template, 0.1);
        if bad.is_empty() {
            return;
        }
        let region = grown(&bad, &ring, rings);
        // Enough sweeps for the displacement to settle over the region (diffusion over k
        // rings takes about k² of them).
        for _ in 0..(4 * rings * rings).clamp(20, 400) {
            let next: Vec<Vec3> = region
                .iter()
                .map(|&v| template[v] + mean(&ring[v], |u| fine[u] - template[u]))
                .collect();
            for (&v, p) in region.iter().zip(next) {
                fine[v] = p;
            }
        }
    }
}

/// Each fine skin vertex's neighbours along quad edges.
fn vertex_rings(tpl: &Template, n: usize) -> Vec<Vec<u32>> {
    let mut ring: Vec<Vec<u32>> = vec![Vec::new(); n];
    for q in &tpl.level2.quads {
        for k in 0..4 {
            let (a, b) = (q[k].0, q[(k + 1) % 4].0);
            ring[a as usize].push(b);
            ring[b as usize].push(a);
        }
    }
    for r in &mut ring {
        r.sort_unstable();
        r.dedup();
    }
    ring
}

/// The corners of triangles turned (by more than acos `cos`) against the template's.
fn folded(tpl: &Template, fine: &[Vec3], template: &[Vec3], cos: f32) -> Vec<usize> {
    let mut bad: Vec<usize> = Vec::new();
    for q in &tpl.level2.quads {
        let [a, b, c, d] = q.map(|c| c.0 as usize);
        for t in [[a, b, c], [a, c, d]] {
            let n = |p: &[Vec3]| (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]);
            let (n0, n1) = (n(template), n(fine));
            if n0.length_squared() > 1e-12 && n0.dot(n1) <= cos * n0.length() * n1.length() {
                bad.extend(t);
            }
        }
    }
    bad.sort_unstable();
    bad.dedup();
    bad
}

/// `seed` and its `k`-ring.
fn grown(seed: &[usize], ring: &[Vec<u32>], k: usize) -> Vec<usize> {
    let mut region = seed.to_vec();
    for _ in 0..k {
        region = region
            .iter()
            .flat_map(|&v| ring[v].iter().map(|&u| u as usize).chain([v]))
            .collect();
        region.sort_unstable();
        region.dedup();
    }
    region
}

/// The mean of `f` over a ring.
fn mean(ring: &[u32], f: impl Fn(usize) -> Vec3) -> Vec3 {
    ring.iter().map(|&u| f(u as usize)).sum::<Vec3>() / ring.len().max(1) as f32
}

/// Triangles of the fitted skin turned over against the template's (placed) orientation.
fn flipped_quads(tpl: &Template, fine: &[Vec3], template: &[Vec3]) -> usize {
    tpl.level2
        .quads
        .iter()
        .flat_map(|q| {
            let [a, b, c, d] = q.map(|c| c.0 as usize);
            [[a, b, c], [a, c, d]]
        })
        .filter(|t| {
            let n = |p: &[Vec3]| (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]);
            let (n0, n1) = (n(template), n(fine));
            n0.length_squared() > 1e-12 && n0.dot(n1) <= 0.0
        })
        .count()
}

/// Pushes a globe back along the head's forward axis until no outer skin vertex lies within
/// 0.3 mm inside it (a lid resting on the globe, not through it).
fn seat_globe(e: &mut EyeSphere, fine: &[Vec3], outer: &[bool], forward: Vec3) {
    let c = Vec3::from(e.centre);
    let worst = fine
        .iter()
        .zip(outer)
        .filter(|(p, o)| **o && (**p - c).length() < 2.0 * e.radius)
        .map(|(p, _)| (*p - c).length() - e.radius)
        .fold(f32::INFINITY, f32::min);
    if worst < 0.3 {
        e.centre = (c - forward * (0.3 - worst)).to_array();
    }
}
