//! `derma head fit` on files (docs/head.md, "Fitting your head"): read the scan (any unit, any
//! axes, the skin among its parts) and its landmarks, find its frame from the face, fit, and
//! write the fitted head directory with that frame; refuses before any work what would
//! overwrite an input.

use super::frame;
use super::options::{Alignment, FitError, FitOptions, FitReport};
use super::scan::Scan;
use super::store::{self, ScanInfo, StoreError};
use derma_core::head_mesh::HeadUnit;
use derma_core::mesh::TriMesh;
use derma_core::mesh_parts::PartChoice;
use derma_core::progress::{Note, Progress, Unit};
use glam::Vec3;
use std::path::{Path, PathBuf};

/// Where the landmarks come from.
#[derive(Clone, Debug)]
pub enum LandmarkSource {
    /// None: found on the mesh.
    Auto,
    /// The scan has MediaPipe's 468-vertex topology (vertex index = landmark id).
    MediaPipe,
    /// A JSON file {"name": [x, y, z]} in the scan's units.
    File(PathBuf),
}

/// A fit of files.
pub struct FitJob {
    /// The scan (OBJ, glTF or GLB).
    pub mesh: PathBuf,
    /// Its unit (`Auto`: found from the face).
    pub unit: HeadUnit,
    /// Which of its parts to fit to.
    pub part: PartChoice,
    /// Its axes (the rotation to derma's frame), when given; else found from the face.
    pub axes: Option<glam::Mat3>,
    /// Its landmarks.
    pub landmarks: LandmarkSource,
    /// The fitted head directory to write.
    pub out: PathBuf,
}

/// Why a fit of files failed.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// Reading the scan.
    #[error(transparent)]
    Core(#[from] derma_core::CoreError),
    /// An input file.
    #[error("{path}: {detail}")]
    Input {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        detail: String,
    },
    /// The fit.
    #[error("{path}: {source}")]
    Fit {
        /// The scan.
        path: PathBuf,
        /// Why.
        source: FitError,
    },
    /// Writing.
    #[error(transparent)]
    Store(#[from] StoreError),
}

impl FitJob {
    /// Fits and writes; returns the report.
    pub fn run(&self, progress: &dyn Progress) -> Result<FitReport, JobError> {
        let outputs: Vec<PathBuf> = store::FILES.iter().map(|f| self.out.join(f)).collect();
        let mut inputs: Vec<&Path> = vec![&self.mesh];
        if let LandmarkSource::File(p) = &self.landmarks {
            inputs.push(p);
        }
        derma_core::atomic::check_inputs_spared(&outputs, &inputs)?;
        let (raw, chosen) = TriMesh::load_part(&self.mesh, &self.part)?;
        if let Some(n) = &chosen.note {
            progress.note(Note::info(format!("mesh '{}': {n}", self.mesh.display())));
        }
        let fixed_mm = self.fixed_mm(&raw)?;
        let face = super::TemplateFace::builtin();
        let named = self.named_landmarks()?;
        progress.stage("find the face", 1, Unit::Steps);
        let clock = std::time::Instant::now();
        let fit_err = |source: FitError| JobError::Fit {
            path: self.mesh.clone(),
            source,
        };
        let found = match &named {
            Some(points) => from_landmarks(points, fixed_mm).map_err(fit_err)?,
            None => {
                let given = frame::Given {
                    mm_per_unit: fixed_mm,
                    axes: self.axes,
                };
                frame::search(&Scan::new(raw.clone()), &face.view(), given).map_err(fit_err)?
            }
        };
        if let (Some(_), Some(axes)) = (&named, self.axes) {
            // The file's up and front as each says them, within 45° of each other.
            let (t, a) = (found.frame.rotation.transpose(), axes.transpose());
            let near = |v: glam::Vec3| (t * v).dot(a * v) > std::f32::consts::FRAC_1_SQRT_2;
            if !(near(glam::Vec3::Y) && near(glam::Vec3::Z)) {
                let mut asked = found.frame.clone();
                asked.rotation = axes;
                return Err(JobError::Input {
                    path: self.mesh.clone(),
                    detail: format!(
                        "its landmarks put its face {}, the axes given say {}: give one or the other",
                        found.frame.axes_in_words(),
                        asked.axes_in_words()
                    ),
                });
            }
        }
        let search_seconds = clock.elapsed().as_secs_f64();
        let mut frame = found.frame.clone();
        frame.part = self.part.name();
        progress.note(Note::info(format!(
            "mesh '{}': {}, {}; unit: {}",
            self.mesh.display(),
            if named.is_some() {
                "placed by its landmarks"
            } else {
                "face found"
            },
            frame.axes_in_words(),
            found.unit_in_words()
        )));
        let mut scan = raw;
        frame.apply(&mut scan);
        let alignment = match named {
            Some(points) => Alignment::Landmarks(crate::Landmarks {
                points: points
                    .into_iter()
                    .map(|(n, p)| (n, frame.point(p)))
                    .collect(),
            }),
            None => Alignment::Auto(found.start),
        };
        let opts = FitOptions {
            alignment,
            ..FitOptions::default()
        };
        let mut fitted = super::fit(scan.clone(), &opts, progress).map_err(fit_err)?;
        fitted
            .report
            .seconds
            .insert(0, ("find the face".into(), search_seconds));
        fitted.report.frame = Some(super::options::FrameReport {
            mm_per_unit: frame.mm_per_unit,
            unit: frame.unit.map(|u| u.name().to_string()),
            face_scale: found.face_scale,
            axes: frame.axes_in_words(),
            placements_tried: found.tried,
            face_score: found.score,
        });
        let name = self.mesh.display().to_string();
        store::write(
            &fitted,
            &ScanInfo {
                name: &name,
                frame: &frame,
                mesh: &scan,
            },
            &self.out,
        )?;
        Ok(fitted.report)
    }

    /// Millimetres per unit when the unit is given (`fit`: the mesh's largest extent made a
    /// nominal head's).
    fn fixed_mm(&self, raw: &TriMesh) -> Result<Option<f32>, JobError> {
        Ok(match self.unit {
            HeadUnit::Auto => None,
            HeadUnit::Length(u) => Some(u.to_mm()),
            HeadUnit::Fit => {
                let e = raw.extent();
                if !(e > 0.0 && e.is_finite()) {
                    return Err(JobError::Input {
                        path: self.mesh.clone(),
                        detail: format!("its largest extent is {e}; expected a positive size"),
                    });
                }
                Some(derma_core::mesh::NOMINAL_HEAD_EXTENT_MM / e)
            }
        })
    }

    /// The landmarks given, by name, in the scan's own coordinates (MediaPipe's eye centres
    /// and its mask-edge points left out: they are not those points).
    fn named_landmarks(&self) -> Result<Option<Vec<(String, Vec3)>>, JobError> {
        let input = |path: &Path, detail: String| JobError::Input {
            path: path.to_path_buf(),
            detail,
        };
        let points = match &self.landmarks {
            LandmarkSource::Auto => return Ok(None),
            LandmarkSource::MediaPipe => {
                // In file order (a loader may reorder vertices to share UVs).
                let raw = derma_core::mesh_file::file_positions(&self.mesh, &self.part)?;
                if raw.len() != 468 && raw.len() != 478 {
                    return Err(input(
                        &self.mesh,
                        format!(
                            "{} vertices; MediaPipe's face mesh topology has 468 (or 478 with the irises): give landmarks of another kind, or none",
                            raw.len()
                        ),
                    ));
                }
                crate::landmarks::MEDIAPIPE
                    .iter()
                    .filter(|(n, _)| !n.starts_with("ear_") && !n.starts_with("lid_"))
                    .map(|&(n, i)| (n.to_string(), raw[i]))
                    .collect()
            }
            LandmarkSource::File(p) => {
                let text = std::fs::read_to_string(p)
                    .map_err(|e| input(p, format!("cannot read the landmarks ({e})")))?;
                crate::Landmarks::raw_from_json(&text, &super::align::REQUIRED)
                    .map_err(|e| input(p, e.to_string()))?
                    .points
                    .into_iter()
                    .filter(|(n, _)| !n.starts_with("eye_centre"))
                    .collect()
            }
        };
        Ok(Some(points))
    }
}

/// The frame the landmarks imply: the similarity from the template's landmarks to them.
fn from_landmarks(
    points: &[(String, Vec3)],
    fixed_mm: Option<f32>,
) -> Result<frame::Found, FitError> {
    let tpl = super::template::Template::of(&crate::asset::parse());
    let pairs: Vec<(Vec3, Vec3)> = points
        .iter()
        .filter(|(n, _)| tpl.landmarks.contains_key(n))
        .map(|(n, p)| (tpl.landmark(n), *p))
        .collect();
    let src: Vec<Vec3> = pairs.iter().map(|p| p.0).collect();
    let dst: Vec<Vec3> = pairs.iter().map(|p| p.1).collect();
    let s = super::align::umeyama(&src, &dst, &vec![1.0; src.len()]).ok_or_else(|| FitError::Landmark {
        name: points.iter().map(|p| p.0.as_str()).collect::<Vec<_>>().join(", "),
        detail: "these do not fix a placement; give at least the canthi, the nose tip and the mouth corners".into(),
    })?;
    Ok(frame::from_landmarks(&s, fixed_mm))
}
