//! A user's head or face mesh read in derma's frame — millimetres, +Y up, facing +Z — by the one
//! function every command uses: a fitted head's frame (its `head.json`: unit, axes, part) when
//! there is one, else a unit given or the one that makes the mesh head-sized (docs/head.md,
//! "Meshes as they come").

use crate::error::{CoreError, Result};
use crate::mesh::{LengthUnit, TriMesh, HEAD_EXTENT_MM, NOMINAL_HEAD_EXTENT_MM};
use crate::mesh_parts::PartChoice;
use crate::progress::{Note, Progress};
use glam::{Mat3, Vec3};
use std::path::Path;

/// How a mesh file's coordinates become derma's: `p ↦ rotation · (mm_per_unit · p)`, and which
/// of its parts are read.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MeshFrame {
    /// The length unit, or `None` when the scale is not a unit (found from the face, or fitted
    /// to [`NOMINAL_HEAD_EXTENT_MM`]).
    pub unit: Option<LengthUnit>,
    /// Millimetres per mesh unit.
    pub mm_per_unit: f32,
    /// The rotation from the file's axes to derma's (identity for a mesh already +Y up and
    /// facing +Z).
    #[serde(default = "identity")]
    pub rotation: Mat3,
    /// The part of the file read: a node, mesh or material name, or `None` for the automatic
    /// choice ([`crate::mesh_parts::choose`]).
    #[serde(default)]
    pub part: Option<String>,
}

fn identity() -> Mat3 {
    Mat3::IDENTITY
}

impl MeshFrame {
    /// A frame of scale only.
    pub fn scaled(unit: Option<LengthUnit>, mm_per_unit: f32) -> MeshFrame {
        MeshFrame {
            unit,
            mm_per_unit,
            rotation: Mat3::IDENTITY,
            part: None,
        }
    }

    /// Puts a mesh read in the file's units into derma's frame.
    pub fn apply(&self, mesh: &mut TriMesh) {
        for p in &mut mesh.positions {
            *p = self.rotation * (*p * self.mm_per_unit);
        }
        for n in &mut mesh.normals {
            *n = self.rotation * *n;
        }
    }

    /// A point of the file in derma's frame.
    pub fn point(&self, p: Vec3) -> Vec3 {
        self.rotation * (p * self.mm_per_unit)
    }

    /// A point of derma's frame in the file's coordinates.
    pub fn to_file(&self, p: Vec3) -> Vec3 {
        self.rotation.transpose() * p / self.mm_per_unit
    }

    /// The part choice it records.
    pub fn part_choice(&self) -> PartChoice {
        match &self.part {
            Some(n) => PartChoice::Named(n.clone()),
            None => PartChoice::Auto,
        }
    }

    /// The file's own up and facing axes in words ("+Z up, facing −Y"), or "turned" for a
    /// rotation that is not a permutation of axes.
    pub fn axes_in_words(&self) -> String {
        let file = |d: Vec3| axis_name(self.rotation.transpose() * d);
        match (file(Vec3::Y), file(Vec3::Z)) {
            (Some(up), Some(front)) => format!("{up} up, facing {front}"),
            _ => "turned off the axes".into(),
        }
    }
}

/// The rotation (file → derma) that turns the file's `up` to +Y and `front` to +Z (both unit
/// axes, at right angles).
pub fn upright(up: Vec3, front: Vec3) -> Mat3 {
    Mat3::from_cols(up.cross(front), up, front).transpose()
}

/// A mesh's axes as words give them, `UP,FRONT` ("+Z,-Y": the file's +Z is up and its face
/// looks along −Y): the rotation to derma's frame.
pub fn parse_axes(s: &str) -> Result<Mat3> {
    let axis = |t: &str| -> Option<Vec3> {
        let t = t.trim();
        let (sign, name) = match t.strip_prefix('-').or_else(|| t.strip_prefix('−')) {
            Some(rest) => (-1.0, rest),
            None => (1.0, t.strip_prefix('+').unwrap_or(t)),
        };
        let v = match name.to_ascii_uppercase().as_str() {
            "X" => Vec3::X,
            "Y" => Vec3::Y,
            "Z" => Vec3::Z,
            _ => return None,
        };
        Some(v * sign)
    };
    let bad = || {
        CoreError::from(crate::Invalid::new(
            "the mesh's axes",
            "UP,FRONT as two of ±X, ±Y, ±Z at right angles, e.g. +Z,-Y",
            format!("'{s}'"),
        ))
    };
    let (u, f) = s.split_once(',').ok_or_else(bad)?;
    let (up, front) = (axis(u).ok_or_else(bad)?, axis(f).ok_or_else(bad)?);
    if up.dot(front) != 0.0 {
        return Err(bad());
    }
    Ok(upright(up, front))
}

/// "+X", "−Z", … for a unit axis (within 1e-3), else None.
pub fn axis_name(d: Vec3) -> Option<&'static str> {
    const NAMES: [(Vec3, &str); 6] = [
        (Vec3::X, "+X"),
        (Vec3::NEG_X, "−X"),
        (Vec3::Y, "+Y"),
        (Vec3::NEG_Y, "−Y"),
        (Vec3::Z, "+Z"),
        (Vec3::NEG_Z, "−Z"),
    ];
    NAMES
        .iter()
        .find(|(a, _)| a.distance(d) < 1e-3)
        .map(|(_, n)| *n)
}

/// The unit a user's head mesh is read in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum HeadUnit {
    /// The fitted head's, else the unit that makes the mesh head-sized
    /// ([`LengthUnit::for_head`]), else a fit.
    #[default]
    Auto,
    /// Scaled so its largest extent is [`NOMINAL_HEAD_EXTENT_MM`].
    Fit,
    /// A given unit.
    Length(LengthUnit),
}

impl HeadUnit {
    /// `auto`, `fit`, `mm`, `cm` or `m`.
    pub fn parse(s: &str) -> Option<HeadUnit> {
        Some(match s {
            "auto" => HeadUnit::Auto,
            "fit" => HeadUnit::Fit,
            "mm" => HeadUnit::Length(LengthUnit::Mm),
            "cm" => HeadUnit::Length(LengthUnit::Cm),
            "m" => HeadUnit::Length(LengthUnit::M),
            _ => return None,
        })
    }
}

/// How a user's head mesh is read: the unit and part asked for, and the frame a fit of it
/// found (which then decides, and which a different explicit unit or part contradicts).
#[derive(Clone, Debug, Default)]
pub struct HeadRead<'a> {
    /// The unit asked for.
    pub unit: HeadUnit,
    /// The part asked for.
    pub part: PartChoice,
    /// The frame of the fitted head this mesh was fitted to (`--head`), if any.
    pub fitted: Option<&'a MeshFrame>,
}

/// Loads a user's head or face mesh with UVs in derma's frame (mm, +Y up, facing +Z): the one
/// loader every command uses. `progress` is told how it was read.
pub fn load_head_mesh(
    path: &Path,
    how: &HeadRead,
    progress: &dyn Progress,
) -> Result<(TriMesh, MeshFrame)> {
    let (mesh, frame) = load_head_geometry(path, how, progress)?;
    mesh.require_uvs(path)?;
    Ok((mesh, frame))
}

/// [`load_head_mesh`] for meshes that need no UVs (a scan to fit the head to).
pub fn load_head_geometry(
    path: &Path,
    how: &HeadRead,
    progress: &dyn Progress,
) -> Result<(TriMesh, MeshFrame)> {
    let mut frame = match how.fitted {
        Some(f) => agree(path, how, f)?,
        None => MeshFrame::scaled(None, 1.0),
    };
    if how.fitted.is_none() {
        frame.part = how.part.name();
    }
    let (mut mesh, chosen) = TriMesh::load_part(path, &frame.part_choice())?;
    if let Some(n) = chosen.note {
        progress.note(Note::info(format!("mesh '{}': {n}", path.display())));
    }
    match how.fitted {
        Some(f) => progress.note(Note::info(format!(
            "mesh '{}': read in its fitted head's frame ({} mm per unit, {})",
            path.display(),
            f.mm_per_unit,
            f.axes_in_words()
        ))),
        None => frame = unit_by_size(path, &mesh, how.unit, progress, frame.part)?,
    }
    frame.apply(&mut mesh);
    Ok((mesh, frame))
}

/// The fitted head's frame, unless what was asked for contradicts it (an error naming both).
fn agree(path: &Path, how: &HeadRead, f: &MeshFrame) -> Result<MeshFrame> {
    let what = format!("how to read '{}'", path.display());
    let conflict = |expected: String, got: String| {
        CoreError::from(crate::Invalid::new(what.clone(), expected, got))
    };
    let asked = match how.unit {
        HeadUnit::Length(u) => Some((u.name(), u.to_mm())),
        // "Made head-sized" agrees with a fit that found no named unit (its scale is the
        // head's), not with one that read the mesh in mm, cm or m.
        HeadUnit::Fit if f.unit.is_none() => None,
        HeadUnit::Fit => Some(("fit", f32::NAN)),
        HeadUnit::Auto => None,
    };
    if let Some((name, mm)) = asked {
        if !((mm - f.mm_per_unit).abs() <= 1e-4 * f.mm_per_unit) {
            return Err(conflict(
                format!(
                    "the unit its fitted head read it in, {} mm per unit ({}, head.json) — ask for none, or fit the head again in that unit",
                    f.mm_per_unit,
                    f.unit.map(|u| u.long_name()).unwrap_or("no named unit")
                ),
                format!("the unit {name}"),
            ));
        }
    }
    if let PartChoice::Named(n) = &how.part {
        if f.part.as_deref().is_none_or(|p| !p.eq_ignore_ascii_case(n)) {
            return Err(conflict(
                format!(
                    "the part its fitted head was fitted to, {} — ask for none, or fit the head again to that part",
                    f.part
                        .as_deref()
                        .map(|p| format!("'{p}'"))
                        .unwrap_or_else(|| "the automatically chosen one".into())
                ),
                format!("the part '{n}'"),
            ));
        }
    }
    Ok(f.clone())
}

/// The scale of a mesh with no fitted head: the unit asked for, else the one that makes its
/// bounding box head-sized, else a nominal head's size.
fn unit_by_size(
    path: &Path,
    mesh: &TriMesh,
    unit: HeadUnit,
    progress: &dyn Progress,
    part: Option<String>,
) -> Result<MeshFrame> {
    let extent = mesh.extent();
    if !(extent > 0.0 && extent.is_finite()) {
        return Err(CoreError::Mesh {
            path: path.to_path_buf(),
            detail: format!("its largest extent is {extent}; expected a positive size"),
        });
    }
    let fit = NOMINAL_HEAD_EXTENT_MM / extent;
    let (lo, hi) = HEAD_EXTENT_MM;
    let (unit, mm) = match unit {
        HeadUnit::Auto => match LengthUnit::for_head(extent) {
            Some(u) => {
                progress.note(Note::info(format!(
                    "mesh '{}': largest extent {extent:.3} units, read as {} ({:.0} mm; a head or face is {lo:.0}–{hi:.0} mm; to override, set its unit — mm, cm, m or fit — with the unit option, surface.unit in a skin config)",
                    path.display(),
                    u.long_name(),
                    extent * u.to_mm()
                )));
                (Some(u), u.to_mm())
            }
            None => {
                progress.note(Note::warning(format!(
                    "mesh '{}': largest extent {extent:.3} units is no head in mm, cm or m ({lo:.0}–{hi:.0} mm); scaled ×{fit:.4} to a nominal {NOMINAL_HEAD_EXTENT_MM:.0} mm head (to override, set its unit — mm, cm or m — with the unit option, surface.unit in a skin config; or fit the head to it, which finds the unit from the face)",
                    path.display(),
                )));
                (None, fit)
            }
        },
        HeadUnit::Fit => {
            progress.note(Note::info(format!(
                "mesh '{}': scaled ×{fit:.4} so its largest extent is {NOMINAL_HEAD_EXTENT_MM:.0} mm",
                path.display(),
            )));
            (None, fit)
        }
        HeadUnit::Length(u) => (Some(u), u.to_mm()),
    };
    let mut frame = MeshFrame::scaled(unit, mm);
    frame.part = part;
    Ok(frame)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_turns_and_scales_and_goes_back() {
        // A Z-up scan facing −Y, in centimetres: derma's +Y is the file's +Z, derma's +Z
        // (front) the file's −Y.
        let r = Mat3::from_cols(Vec3::X, Vec3::NEG_Z, Vec3::Y);
        let f = MeshFrame {
            unit: Some(LengthUnit::Cm),
            mm_per_unit: 10.0,
            rotation: r,
            part: None,
        };
        assert_eq!(f.point(Vec3::new(0.0, 0.0, 2.0)), Vec3::new(0.0, 20.0, 0.0));
        assert_eq!(
            f.point(Vec3::new(0.0, -1.0, 0.0)),
            Vec3::new(0.0, 0.0, 10.0)
        );
        let p = Vec3::new(1.0, -2.0, 3.0);
        assert!((f.to_file(f.point(p)) - p).length() < 1e-6);
        assert_eq!(f.axes_in_words(), "+Z up, facing −Y");
        assert_eq!(parse_axes("+Z,-Y").unwrap(), r);
        assert_eq!(parse_axes("z, −y").unwrap(), r);
        assert!(
            parse_axes("+Z,+Z").is_err()
                && parse_axes("up").is_err()
                && parse_axes("+W,+X").is_err()
        );
        assert_eq!(
            MeshFrame::scaled(None, 1.0).axes_in_words(),
            "+Y up, facing +Z"
        );
    }

    #[test]
    fn an_asked_unit_agrees_with_the_fit_or_is_refused_naming_both() {
        let path = Path::new("scan.glb");
        let ask = |unit: HeadUnit, f: &MeshFrame| {
            agree(
                path,
                &HeadRead {
                    unit,
                    part: PartChoice::Auto,
                    fitted: Some(f),
                },
                f,
            )
        };
        let cm = MeshFrame::scaled(Some(LengthUnit::Cm), 10.0);
        let found = MeshFrame::scaled(None, 49.4);
        assert!(ask(HeadUnit::Length(LengthUnit::Cm), &cm).is_ok());
        assert!(ask(HeadUnit::Auto, &found).is_ok());
        // Made head-sized agrees with a scale found from the face, not with a named unit.
        assert!(ask(HeadUnit::Fit, &found).is_ok());
        let e = ask(HeadUnit::Fit, &cm).unwrap_err().to_string();
        assert!(
            e.contains("scan.glb") && e.contains("fit") && e.contains("centimetre"),
            "{e}"
        );
        let e = ask(HeadUnit::Length(LengthUnit::Mm), &found)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("49.4") && e.contains("mm") && e.contains("no named unit"),
            "{e}"
        );
    }
}
