//! What a fit of the built-in head to a user's mesh takes and reports: options, errors and the
//! residuals that say how well it went (Amberg et al. 2007's optimal-step non-rigid ICP, §3).

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Scales of the template a face may need: adult head breadths and face heights span about
/// ±15 % around the mean (Farkas 1994, "Anthropometry of the Head and Face"), with a margin.
pub const SCALE_RANGE: (f32, f32) = (0.7, 1.4);

/// How the template is first placed on the scan.
#[derive(Clone, Debug)]
pub enum Alignment {
    /// From named landmarks on the scan (mm, the scan's frame): every name of
    /// [`crate::landmarks::NAMES`] that is given is used; at least the canthi, nose tip and
    /// mouth corners.
    Landmarks(crate::Landmarks),
    /// Found on the mesh: the template's face placed where [`super::frame::search`] found a face
    /// (this similarity, template mm → scan mm), then refined by a similarity ICP.
    Auto(Similarity),
    /// As [`Alignment::Auto`], the face searched for on the scan (in mm, upright) first: what a
    /// caller that has not searched gets.
    Search,
}

impl Alignment {
    /// Whether the placement is found on the mesh (eye and mouth corners then detected).
    pub fn is_automatic(&self) -> bool {
        !matches!(self, Alignment::Landmarks(_))
    }
}

/// Options of a fit.
#[derive(Clone, Debug)]
pub struct FitOptions {
    /// Initial alignment.
    pub alignment: Alignment,
    /// Stiffness schedule α (Amberg et al. 2007, §3.3): from stiff to flexible.
    pub stiffness: Vec<f64>,
    /// Iterations at most per stiffness.
    pub iterations: usize,
    /// Largest distance (mm) a template point may be from the scan and still be matched.
    pub max_distance_mm: f32,
    /// Largest residual (mm, RMS over matched face points) a fit may end with.
    pub max_residual_mm: f32,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            alignment: Alignment::Search,
            stiffness: vec![40.0, 20.0, 10.0, 5.0, 2.5, 1.2, 0.6],
            iterations: 10,
            max_distance_mm: 25.0,
            max_residual_mm: 3.0,
        }
    }
}

/// Why a fit failed.
#[derive(Debug, thiserror::Error)]
pub enum FitError {
    /// The scan is not a face this fit can use.
    #[error("{0}")]
    Scan(String),
    /// A landmark is unusable.
    #[error("landmark '{name}': {detail}")]
    Landmark {
        /// Its name.
        name: String,
        /// What is wrong.
        detail: String,
    },
    /// The registration ended far from the scan.
    #[error("the fit did not converge: the face's RMS distance to the scan is {rms_mm:.2} mm after {iterations} iterations (at most {limit_mm:.2} mm accepted, with at least half of the face on the scan); check the scan's orientation (+Y up, facing +Z) or give landmarks")]
    NoConvergence {
        /// RMS residual (mm) over matched face points.
        rms_mm: f32,
        /// Iterations run.
        iterations: usize,
        /// The accepted limit.
        limit_mm: f32,
    },
    /// A solve failed.
    #[error("the registration's linear system: {0}")]
    Numerics(#[from] derma_core::numerics::NumericsError),
}

/// How a fit went (written to the fitted head's `head.json`).
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct FitReport {
    /// How the template was first placed ("landmarks: N" or "auto").
    pub alignment: String,
    /// The similarity's scale (template mm → scan mm).
    pub scale: f32,
    /// Non-rigid iterations run.
    pub iterations: usize,
    /// RMS distance (mm) of matched face points to the scan before the final projection.
    pub rms_mm: f32,
    /// Median distance (mm) of the fitted skin's face vertices to the scan.
    pub median_mm: f32,
    /// Share of the face's template points matched to the scan in the last iteration.
    pub matched: f32,
    /// Whether the fitted skin was projected onto the scan (scans finer than about 3 mm).
    pub projected: bool,
    /// Triangles of the fitted skin whose orientation flipped against the template (0 when
    /// the fit is clean).
    pub flipped: usize,
    /// Landmark residuals (mm), by name, where landmarks were given.
    pub landmark_mm: Vec<(String, f32)>,
    /// Eye and mouth corners detected on the scan (the scan read in mm) by an automatic
    /// alignment ([`super::align::detect_corners`]); the registration holds the template's
    /// corners of the same openings to them.
    #[serde(default)]
    pub detected: Vec<(String, [f32; 3])>,
    /// Per detected corner, its distance (mm) from the fitted skin's corner of the same
    /// opening ([`super::align::opening_corner`]): how closely the registration honoured it
    /// (near 0; a large gap means the rest of the face pulled against it). It does not tell a
    /// misdetected corner, which the fit follows; `detected` says where each was found.
    #[serde(default)]
    pub corner_gap_mm: Vec<(String, f32)>,
    /// The corners of the fitted skin's eye and mouth openings (mm, the fitted head's frame):
    /// where its lid and lip margins meet on the surface ([`super::align::opening_corner`]).
    #[serde(default)]
    pub opening_corners: Vec<(String, [f32; 3])>,
    /// Seconds per stage.
    pub seconds: Vec<(String, f64)>,
    /// The scan's unit and axes as found (`derma head fit` on files).
    #[serde(default)]
    pub frame: Option<FrameReport>,
}

/// The scan's frame as `derma head fit` found it (docs/head.md, "Meshes as they come").
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct FrameReport {
    /// Millimetres per scan unit.
    pub mm_per_unit: f32,
    /// The unit's name, or None when the scale came from the face's size.
    pub unit: Option<String>,
    /// The face's size relative to the template's, read so.
    pub face_scale: f32,
    /// The scan's own axes ("+Z up, facing −Y").
    pub axes: String,
    /// Placements the search tried (1 with landmarks).
    pub placements_tried: usize,
    /// How well the template's face fits where it was found (of at most 4; a face needs
    /// [`super::frame::MIN_SCORE`]).
    pub face_score: f32,
}

/// A similarity transform x ↦ s R x + t.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Similarity {
    /// Uniform scale.
    pub scale: f32,
    /// Rotation (columns).
    pub rotation: glam::Mat3,
    /// Translation.
    pub translation: Vec3,
}

impl Similarity {
    /// The identity.
    pub const IDENTITY: Similarity = Similarity {
        scale: 1.0,
        rotation: glam::Mat3::IDENTITY,
        translation: Vec3::ZERO,
    };

    /// Applies it to a point.
    pub fn apply(&self, p: Vec3) -> Vec3 {
        self.scale * (self.rotation * p) + self.translation
    }

    /// `self` after `first`.
    pub fn after(&self, first: &Similarity) -> Similarity {
        Similarity {
            scale: self.scale * first.scale,
            rotation: self.rotation * first.rotation,
            translation: self.apply(first.translation),
        }
    }
}
