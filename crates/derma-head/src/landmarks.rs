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
    /// A landmark is NaN or infinite (after scaling to millimetres).
    #[error("landmark '{0}' is {1:?} mm; expected finite coordinates")]
    NotFinite(String, [f32; 3]),
    /// A landmark name derma does not know.
    #[error("unknown landmark '{0}'; expected names: {all}", all = NAMES.join(", "))]
    Unknown(String),
    /// The landmark file is not the expected JSON.
    #[error("landmarks: {0}; expected a JSON object {{\"name\": [x, y, z], …}}")]
    Json(String),
    /// The mesh does not have MediaPipe's topology.
    #[error("not MediaPipe's topology: the mesh has {0} vertices, MediaPipe's face mesh 468 (478 with the irises; vertex index = landmark id)")]
    Topology(usize),
    /// The landmarks contradict the axis convention.
    #[error("landmarks: {0}")]
    Orientation(String),
}

impl Landmarks {
    /// The position of `name`; panics on an unknown name (use [`Landmarks::check`] first for
    /// user-supplied sets).
    pub fn get(&self, name: &str) -> Vec3 {
        self.points[name]
    }

    /// Checks that every landmark of [`NAMES`] is present and finite.
    pub fn check(&self) -> Result<(), LandmarkError> {
        if let Some(n) = NAMES.iter().find(|n| !self.points.contains_key(**n)) {
            return Err(LandmarkError::Missing((*n).into()));
        }
        match self.points.iter().find(|(_, p)| !p.is_finite()) {
            Some((n, p)) => Err(LandmarkError::NotFinite(n.clone(), p.to_array())),
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

/// Landmark ids of MediaPipe's 468-point face mesh (vertex index = landmark id; checked against
/// `canonical_face_model.obj`, whose +x is the subject's left): name → id. Eye centres are not
/// among the 468 points; they are placed 6 mm behind the middle of the canthi (the built-in head's
/// canthi lie 6 mm in front of its eye centres).
pub const MEDIAPIPE: [(&str, usize); 17] = [
    ("canthus_inner_left", 362),
    ("canthus_inner_right", 133),
    ("canthus_outer_left", 263),
    ("canthus_outer_right", 33),
    ("lid_upper_left", 386),
    ("lid_upper_right", 159),
    ("lid_lower_left", 374),
    ("lid_lower_right", 145),
    ("glabella", 9),
    ("nose_tip", 4),
    ("subnasale", 164),
    ("mouth_corner_left", 291),
    ("mouth_corner_right", 61),
    ("chin", 199),
    ("menton", 152),
    // The mask's lateral edge at the tragus: the closest the 468 points come to the ears.
    ("ear_left", 454),
    ("ear_right", 234),
];

/// The hairline of a MediaPipe mesh: the top of its forehead (id 10).
pub const MEDIAPIPE_HAIRLINE: usize = 10;

/// Depth of the eye centre behind the middle of the canthi (mm), as on the built-in head.
pub const EYE_CENTRE_BEHIND_CANTHI_MM: f32 = 6.0;

impl Landmarks {
    /// Landmarks of a mesh in MediaPipe's 468-point topology, from its vertex positions in
    /// file order (mm, +Y up, facing +Z).
    pub fn mediapipe(positions: &[Vec3]) -> Result<Landmarks, LandmarkError> {
        if positions.len() != 468 && positions.len() != 478 {
            return Err(LandmarkError::Topology(positions.len()));
        }
        let mut points: BTreeMap<String, Vec3> = MEDIAPIPE
            .iter()
            .map(|&(n, i)| (n.to_string(), positions[i]))
            .collect();
        points.insert("hairline".into(), positions[MEDIAPIPE_HAIRLINE]);
        for side in ["left", "right"] {
            let mid = 0.5
                * (points[&format!("canthus_inner_{side}")]
                    + points[&format!("canthus_outer_{side}")]);
            points.insert(
                format!("eye_centre_{side}"),
                mid - Vec3::Z * EYE_CENTRE_BEHIND_CANTHI_MM,
            );
        }
        let lm = Landmarks { points };
        let not_mediapipe = |e: LandmarkError| {
            LandmarkError::Orientation(format!(
                "{e} — with 468 vertices but not MediaPipe's vertex order, this is likely not MediaPipe's topology"
            ))
        };
        lm.check().map_err(not_mediapipe)?;
        lm.check_orientation().map_err(not_mediapipe)?;
        Ok(lm)
    }

    /// Landmarks from JSON: `{"name": [x, y, z], …}` in the mesh's units, scaled by
    /// `mm_per_unit`; every name of [`NAMES`] is required.
    pub fn from_json(text: &str, mm_per_unit: f32) -> Result<Landmarks, LandmarkError> {
        Self::from_json_in(text, &|p| p * mm_per_unit)
    }

    /// As [`Landmarks::from_json`] for a mesh read in another frame: `to_mm` maps the file's
    /// coordinates into derma's (mm, +Y up, facing +Z; a fitted head's `MeshFrame::point`).
    pub fn from_json_in(
        text: &str,
        to_mm: &dyn Fn(Vec3) -> Vec3,
    ) -> Result<Landmarks, LandmarkError> {
        let mut lm = Self::raw_from_json(text, &NAMES)?;
        for p in lm.points.values_mut() {
            *p = to_mm(*p);
        }
        if let Some((n, p)) = lm.points.iter().find(|(_, p)| !p.is_finite()) {
            return Err(LandmarkError::NotFinite(n.clone(), p.to_array()));
        }
        lm.check_orientation()?;
        lm.check()?;
        Ok(lm)
    }

    /// Landmarks from JSON as written, in the file's own units and axes (no orientation is
    /// assumed: a fit finds the frame from them); names known, `required` present, finite.
    pub fn raw_from_json(text: &str, required: &[&str]) -> Result<Landmarks, LandmarkError> {
        let raw: BTreeMap<String, [f32; 3]> =
            serde_json::from_str(text).map_err(|e| LandmarkError::Json(e.to_string()))?;
        if let Some(unknown) = raw.keys().find(|k| !NAMES.contains(&k.as_str())) {
            return Err(LandmarkError::Unknown(unknown.clone()));
        }
        let lm = Landmarks {
            points: raw.into_iter().map(|(k, v)| (k, Vec3::from(v))).collect(),
        };
        if let Some(n) = required.iter().find(|n| !lm.points.contains_key(**n)) {
            return Err(LandmarkError::Missing((*n).into()));
        }
        if let Some((n, p)) = lm.points.iter().find(|(_, p)| !p.is_finite()) {
            return Err(LandmarkError::NotFinite(n.clone(), p.to_array()));
        }
        Ok(lm)
    }

    /// Checks the convention the regions assume: +Y up, the face towards +Z, +X the head's left
    /// (each test on the landmarks present).
    pub fn check_orientation(&self) -> Result<(), LandmarkError> {
        let p = |n: &str| self.points.get(n).copied();
        let pair = [
            "eye_centre",
            "canthus_outer",
            "canthus_inner",
            "mouth_corner",
        ]
        .iter()
        .find_map(|n| Some((p(&format!("{n}_left"))?, p(&format!("{n}_right"))?)));
        if let Some((l, r)) = pair {
            if !(l.x > r.x) {
                return Err(LandmarkError::Orientation(
                    "the left eye is not at +x of the right one (+X must be the head's left)"
                        .into(),
                ));
            }
        }
        if let (Some(h), Some(n), Some(m)) = (p("hairline"), p("nose_tip"), p("menton")) {
            if !(h.y > n.y && n.y > m.y) {
                return Err(LandmarkError::Orientation(
                    "hairline, nose tip and menton are not in descending y (+Y must be up)".into(),
                ));
            }
        } else if let (Some(n), Some(l), Some(r)) = (
            p("nose_tip"),
            p("mouth_corner_left"),
            p("mouth_corner_right"),
        ) {
            if !(n.y > 0.5 * (l.y + r.y)) {
                return Err(LandmarkError::Orientation(
                    "the nose tip is not above the mouth corners (+Y must be up)".into(),
                ));
            }
        }
        if let (Some(n), Some(l), Some(r)) = (p("nose_tip"), p("ear_left"), p("ear_right")) {
            if !(n.z > 0.5 * (l.z + r.z)) {
                return Err(LandmarkError::Orientation(
                    "the nose tip is not in front of the ears (the face must look towards +Z)"
                        .into(),
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn json_of(lm: &Landmarks) -> String {
        let m: BTreeMap<&str, [f32; 3]> = lm
            .points
            .iter()
            .map(|(k, v)| (k.as_str(), v.to_array()))
            .collect();
        serde_json::to_string(&m).unwrap()
    }

    #[test]
    fn json_landmarks_round_trip_and_bad_ones_are_named() {
        let head = crate::Head::builtin();
        let text = json_of(&head.landmarks);
        // In centimetres: scaled back to mm.
        let cm: BTreeMap<String, [f32; 3]> = serde_json::from_str(&text).unwrap();
        let cm: BTreeMap<String, [f32; 3]> = cm
            .into_iter()
            .map(|(k, v)| (k, v.map(|x| x / 10.0)))
            .collect();
        let back = Landmarks::from_json(&serde_json::to_string(&cm).unwrap(), 10.0).unwrap();
        for (k, v) in &head.landmarks.points {
            assert!((back.get(k) - *v).length() < 1e-3, "{k}");
        }
        let mut missing = head.landmarks.clone();
        missing.points.remove("chin");
        assert_eq!(
            Landmarks::from_json(&json_of(&missing), 1.0),
            Err(LandmarkError::Missing("chin".into()))
        );
        let mut unknown = head.landmarks.clone();
        unknown.points.insert("nose".into(), Vec3::ZERO);
        assert_eq!(
            Landmarks::from_json(&json_of(&unknown), 1.0),
            Err(LandmarkError::Unknown("nose".into()))
        );
        // Upside down: named as an orientation error.
        let mut flipped = head.landmarks.clone();
        flipped.points.values_mut().for_each(|p| p.y = -p.y);
        assert!(matches!(
            Landmarks::from_json(&json_of(&flipped), 1.0),
            Err(LandmarkError::Orientation(_))
        ));
    }

    #[test]
    fn mediapipe_ids_land_on_the_canonical_face() {
        let Some(path) = derma_test_support::shared_data("canonical_face_model.obj") else {
            return;
        };
        let pts = derma_core::mesh_file::file_positions(&path, &Default::default()).unwrap();
        // The canonical model is in centimetres.
        let pts: Vec<Vec3> = pts.iter().map(|p| *p * 10.0).collect();
        let lm = Landmarks::mediapipe(&pts).unwrap();
        // Anthropometry of the canonical face (Farkas 1994 adult ranges, generous): fissure
        // width en–ex 25–35 mm, mouth width ch–ch 40–60 mm, nose tip the most prominent point.
        let fissure = (lm.get("canthus_outer_left") - lm.get("canthus_inner_left")).length();
        assert!((25.0..35.0).contains(&fissure), "{fissure}");
        let mouth = (lm.get("mouth_corner_left") - lm.get("mouth_corner_right")).length();
        assert!((40.0..60.0).contains(&mouth), "{mouth}");
        let tip = lm.get("nose_tip").z;
        assert!(lm.points.values().all(|p| p.z <= tip + 1e-3));
        assert!(Landmarks::mediapipe(&pts[..400]).is_err());
    }
}
