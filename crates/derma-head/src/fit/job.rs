//! `derma head fit` on files (docs/head.md, "Fitting your head"): read the scan (any unit) and
//! its landmarks, fit, and write the fitted head directory; refuses before any work what would
//! overwrite an input.

use super::options::{Alignment, FitError, FitOptions, FitReport};
use super::store::{self, ScanInfo, StoreError};
use derma_core::mesh::{load_head_geometry, HeadUnit};
use derma_core::progress::Progress;
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
    /// Its unit.
    pub unit: HeadUnit,
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
        let (scan, scale) = load_head_geometry(&self.mesh, self.unit, progress)?;
        let input = |path: &Path, detail: String| JobError::Input {
            path: path.to_path_buf(),
            detail,
        };
        let alignment = match &self.landmarks {
            LandmarkSource::Auto => Alignment::Auto,
            LandmarkSource::MediaPipe => {
                // In file order (a loader may reorder vertices to share UVs).
                let raw: Vec<glam::Vec3> = derma_core::mesh::file_positions(&self.mesh)?
                    .into_iter()
                    .map(|p| p * scale.mm_per_unit)
                    .collect();
                // MediaPipe's face mesh has 468 vertices (478 with the irises).
                if raw.len() != 468 && raw.len() != 478 {
                    return Err(input(
                        &self.mesh,
                        format!(
                            "{} vertices; MediaPipe's face mesh topology has 468 (or 478 with the irises)",
                            raw.len()
                        ),
                    ));
                }
                let mut lm = crate::Landmarks::mediapipe(&raw)
                    .map_err(|e| input(&self.mesh, e.to_string()))?;
                // MediaPipe's "ears" and "hairline" are the mask's edges, not those points.
                lm.points.retain(|n, _| {
                    !n.starts_with("ear_") && n != "hairline" && !n.starts_with("lid_")
                });
                Alignment::Landmarks(lm)
            }
            LandmarkSource::File(p) => {
                let text = std::fs::read_to_string(p)
                    .map_err(|e| input(p, format!("cannot read the landmarks ({e})")))?;
                Alignment::Landmarks(
                    crate::Landmarks::from_json_with(
                        &text,
                        scale.mm_per_unit,
                        &super::align::REQUIRED,
                    )
                    .map_err(|e| input(p, e.to_string()))?,
                )
            }
        };
        let opts = FitOptions {
            alignment,
            ..FitOptions::default()
        };
        let fitted = super::fit(scan.clone(), &opts, progress).map_err(|source| JobError::Fit {
            path: self.mesh.clone(),
            source,
        })?;
        let name = self.mesh.display().to_string();
        store::write(
            &fitted,
            &ScanInfo {
                name: &name,
                mm_per_unit: scale.mm_per_unit,
                mesh: &scan,
            },
            &self.out,
        )?;
        Ok(fitted.report)
    }
}
