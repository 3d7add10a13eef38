//! The non-rigid registration of the template's cage to a scan: optimal-step non-rigid ICP
//! (Amberg, Romdhani & Vetter 2007, §3), stiffness from stiff to flexible, each step's normal
//! equations factorised once and re-solved for new matches; then the eye and mouth corners
//! found again where the registration put them and held through a last flexible step.

use super::align;
use super::nicp::{self, Affines, Pattern, Problem};
use super::options::{FitError, FitOptions};
use super::scan::Scan;
use super::template::Template;
use derma_core::progress::{Progress, Unit};
use glam::Vec3;
use rayon::prelude::*;

/// Half-width (mm) of the band along the lid and lip margins left unmatched, on scans fine
/// enough to show the margins (median edge within [`FINE_SCAN_MM`]).
pub const MARGIN_BAND_MM: f32 = 3.0;
/// The band on coarser scans (a face mask whose eyes and mouth are closed surfaces of 5–10 mm
/// triangles): on MediaPipe's canonical face the 3 mm band leaves 346 triangles turned over at
/// the canthi and mouth corners, 6 mm none.
pub const COARSE_MARGIN_BAND_MM: f32 = 6.0;
/// Median edge (mm) up to which a scan counts as fine: projected onto, with the narrow band.
pub const FINE_SCAN_MM: f32 = 3.0;

/// A point pinned to a place on the scan: its combination of control vertices, and where.
pub type Pin = (Vec<(u32, f32)>, Vec3);

/// What the registration matches and holds.
pub struct Registration<'a> {
    tpl: &'a Template,
    scan: &'a Scan,
    /// The placed cage (template mm → scan mm by the similarity).
    pub control: Vec<Vec3>,
    rows: Vec<Vec<(u32, f32)>>,
    outer_ids: Vec<usize>,
    is_face: Vec<bool>,
    near_margin: Vec<bool>,
    face_matchable: usize,
    /// Whether the scan is fine (its margins shown, projected onto).
    pub fine_scan: bool,
}

/// How the last iteration went: RMS distance (mm) of matched face points, and the share of the
/// matchable face matched.
pub type Residual = (f32, f32);

/// A registration's result.
pub struct Registered {
    /// The cage's affine maps.
    pub x: Affines,
    /// The last iteration's residual.
    pub residual: Residual,
    /// Iterations run.
    pub iterations: usize,
}

impl<'a> Registration<'a> {
    /// The registration of `tpl` placed by `sim` on `scan`; `face1` are the face's level-1
    /// vertices (the residual is measured there).
    pub fn new(
        tpl: &'a Template,
        scan: &'a Scan,
        sim: &super::options::Similarity,
        face1: &[usize],
    ) -> Registration<'a> {
        let control: Vec<Vec3> = tpl.coarse.positions.iter().map(|p| sim.apply(*p)).collect();
        let outer_ids: Vec<usize> = (0..tpl.level1.positions.len())
            .filter(|&i| tpl.outer1[i])
            .collect();
        let rows = outer_ids
            .iter()
            .map(|&i| tpl.stencils1.rows[i].clone())
            .collect();
        let is_face: Vec<bool> = {
            let f: std::collections::HashSet<usize> = face1.iter().copied().collect();
            outer_ids.iter().map(|i| f.contains(i)).collect()
        };
        // The lid and lip margins are not matched: a scan's eyes may be closed or bulge where
        // the template's openings are, and its mouth shut; they follow their surroundings.
        let fine_scan = scan.median_edge_mm() <= FINE_SCAN_MM;
        let band = if fine_scan {
            MARGIN_BAND_MM
        } else {
            COARSE_MARGIN_BAND_MM
        };
        let near_margin = tpl.margin_band(&tpl.stencils1.apply(&tpl.coarse.positions), band);
        let face_matchable = outer_ids
            .iter()
            .zip(&is_face)
            .filter(|(&i, &f)| f && !near_margin[i])
            .count();
        Registration {
            tpl,
            scan,
            control,
            rows,
            outer_ids,
            is_face,
            near_margin,
            face_matchable,
            fine_scan,
        }
    }

    fn problem(&self) -> Problem<'_> {
        Problem {
            control: &self.control,
            edges: &self.tpl.edges,
            points: &self.rows,
        }
    }

    /// Runs the stiffness schedule with `pins` held; returns the affine maps, the last residual
    /// and the iterations run.
    pub fn run(
        &self,
        opts: &FitOptions,
        pins: &[Pin],
        progress: &dyn Progress,
    ) -> Result<(Affines, Residual, usize), FitError> {
        let total = (opts.stiffness.len() * opts.iterations) as u64;
        progress.stage("non-rigid registration", total, Unit::Steps);
        let alpha0 = opts.stiffness.first().copied().unwrap_or(1.0);
        let mut x = Affines::identity(&self.control);
        let (mut last, mut iterations) = ((f32::INFINITY, 0.0), 0);
        let pattern = self.pattern(pins)?;
        for &alpha in &opts.stiffness {
            let tau = (opts.max_distance_mm * (alpha / alpha0).sqrt() as f32).max(6.0);
            let step = self.step(&pattern, pins, alpha, tau, x, opts.iterations, progress)?;
            (x, last) = (step.0, step.1);
            iterations += step.2;
        }
        Ok((x, last, iterations))
    }

    /// The normal equations' pattern with `pins` as extra rows.
    fn pattern(&self, pins: &[Pin]) -> Result<Pattern, FitError> {
        let extra: Vec<Vec<(u32, f32)>> = pins.iter().map(|r| r.0.clone()).collect();
        Ok(Pattern::new(&self.problem(), &extra)?)
    }

    /// One stiffness: up to `iterations` rounds of matching and solving, the system factorised
    /// once (its weights from the first round's matches).
    #[allow(clippy::too_many_arguments)]
    fn step(
        &self,
        pattern: &Pattern,
        pins: &[Pin],
        alpha: f64,
        tau: f32,
        mut x: Affines,
        iterations: usize,
        progress: &dyn Progress,
    ) -> Result<(Affines, Residual, usize), FitError> {
        let problem = self.problem();
        let frame = Affines::identity(&self.control);
        let extra: Vec<Vec<(u32, f32)>> = pins.iter().map(|r| r.0.clone()).collect();
        let mut system: Option<nicp::System> = None;
        let mut last = (f32::INFINITY, 0.0);
        for it in 0..iterations {
            let all = nicp::positions(&problem, &x, &self.tpl.stencils1);
            let found = self.matches(&all, tau);
            last = self.residual(&all, &found);
            // A point matched at the stiffness's first iteration and unmatched later is held
            // where it is.
            let targets: Vec<Vec3> = found
                .iter()
                .zip(&self.outer_ids)
                .map(|(t, &i)| t.unwrap_or(all[i]))
                .collect();
            if system.is_none() {
                let weights = found.iter().map(|t| t.is_some() as u8 as f32).collect();
                system = Some(nicp::System::new(
                    &problem,
                    pattern,
                    &frame,
                    alpha,
                    weights,
                    &extra,
                    nicp::LANDMARK_WEIGHT,
                )?);
            }
            let mut next = system.as_ref().expect("built").solve(&targets, pins)?;
            let change = next.change(&x);
            if it > 0 {
                next.relax(&x, nicp::RELAXATION);
            }
            x = next;
            progress.advance(1);
            if change < 1e-4 {
                progress.advance((iterations - it - 1) as u64);
                return Ok((x, last, it + 1));
            }
        }
        Ok((x, last, iterations))
    }

    /// Each outer level-1 point's match on the scan within `tau` (none in the margin band).
    fn matches(&self, all: &[Vec3], tau: f32) -> Vec<Option<Vec3>> {
        let normals = Template::normals(&self.tpl.level1, all);
        self.outer_ids
            .par_iter()
            .map(|&i| {
                if self.near_margin[i] {
                    return None;
                }
                self.scan.matched(all[i], normals[i], tau).map(|c| c.point)
            })
            .collect()
    }

    /// RMS distance of the matched face points and the share of the face matched (an infinite
    /// residual when none is: the fit has lost the scan).
    fn residual(&self, all: &[Vec3], found: &[Option<Vec3>]) -> Residual {
        let (mut sum, mut n) = (0.0f64, 0usize);
        for (k, t) in found.iter().enumerate() {
            if let (true, Some(q)) = (self.is_face[k], t) {
                sum += (all[self.outer_ids[k]] - *q).length_squared() as f64;
                n += 1;
            }
        }
        let rms = if n == 0 {
            f32::INFINITY
        } else {
            (sum / n as f64).sqrt() as f32
        };
        (rms, n as f32 / self.face_matchable.max(1) as f32)
    }

    /// The eye and mouth corners found on the scan again, around where the registration put
    /// the skin's opening corners (closer than the first placement's guess), and held through
    /// one more round at the last stiffness with the other pins. Returns the refined maps and
    /// the corners found (None where none is).
    pub fn refine_corners(
        &self,
        x: Affines,
        pins: &[Pin],
        opts: &FitOptions,
        progress: &dyn Progress,
    ) -> Result<(Registered, [Option<Vec3>; 6]), FitError> {
        let moved: Vec<Vec3> = (0..self.control.len())
            .map(|j| x.moved(j, self.control[j]))
            .collect();
        let fine = self.tpl.stencils2.apply(&moved);
        let margin2 = Template::margin(&self.tpl.level2, &self.tpl.outer2);
        let landmarks = align::CORNERS.map(|n| fine[self.tpl.landmarks[n]]);
        let corner = |k: usize| align::opening_corner(&fine, &margin2, &landmarks, k);
        let placed: [Vec3; 6] =
            std::array::from_fn(|k| corner(k).map(|v| fine[v]).unwrap_or(landmarks[k]));
        let found = align::detect_corners(self.scan, &placed);
        let mut held = pins.to_vec();
        for (k, q) in found.iter().enumerate() {
            if let (Some(q), Some(v)) = (q, corner(k)) {
                held.push((self.tpl.stencils2.rows[v].clone(), *q));
            }
        }
        let alpha = opts.stiffness.last().copied().unwrap_or(1.0);
        let alpha0 = opts.stiffness.first().copied().unwrap_or(1.0);
        let tau = (opts.max_distance_mm * (alpha / alpha0).sqrt() as f32).max(6.0);
        let pattern = self.pattern(&held)?;
        let (x, residual, iterations) =
            self.step(&pattern, &held, alpha, tau, x, opts.iterations, progress)?;
        Ok((
            Registered {
                x,
                residual,
                iterations,
            },
            found,
        ))
    }
}
