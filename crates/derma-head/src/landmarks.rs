//! Named landmarks of a head (mm): the points regions, default fields and the eye and photo
//! work are anchored on. Anthropometric names follow Farkas (1994, "Anthropometry of the Head
//! and Face"): canthi (en/ex), lid margins, pronasale, subnasale, cheilion, pogonion, menton,
//! trichion; ears are the middle of the auricle's lateral face.

use glam::Vec3;
use std::collections::BTreeMap;

/// Every landmark name, in a fixed order; `_left`/`_right` are the head's own sides (+x left).
pub const NAMES: [&str; 20] = [
    "eye_centre_left",
    "eye_centre_right",
    "canthus_inner_left",
    "canthus_inner_right",
    "canthus_outer_left",
    "canthus_outer_right",
    "lid_upper_left",
    "lid_upper_right",
    "lid_lower_left",
    "lid_lower_right",
    "glabella",
    "nose_tip",
    "subnasale",
    "mouth_corner_left",
    "mouth_corner_right",
    "chin",
    "menton",
    "ear_left",
    "ear_right",
    "hairline",
];

/// Landmark positions by name.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Landmarks {
    /// Name → position (mm).
    pub points: BTreeMap<String, Vec3>,
}

/// Errors of a landmark set.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum LandmarkError {
    /// A landmark the regions need is missing.
    #[error("landmark '{0}' is missing; the regions need all of: {all}", all = NAMES.join(", "))]
    Missing(String),
}

impl Landmarks {
    /// The position of `name`; panics on an unknown name (use [`Landmarks::check`] first for
    /// user-supplied sets).
    pub fn get(&self, name: &str) -> Vec3 {
        self.points[name]
    }

    /// Checks that every landmark of [`NAMES`] is present.
    pub fn check(&self) -> Result<(), LandmarkError> {
        match NAMES.iter().find(|n| !self.points.contains_key(**n)) {
            Some(n) => Err(LandmarkError::Missing((*n).into())),
            None => Ok(()),
        }
    }

    /// Mirror sign of a side name: +1 for "left" (+x), −1 for "right".
    pub fn side_sign(side: &str) -> f32 {
        if side == "left" {
            1.0
        } else {
            -1.0
        }
    }
}
