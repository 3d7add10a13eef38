//! `derma.Rig`: dynamic facial colour (Jimenez et al. 2010; docs/rig.md) from Python — a rig
//! built from a texture set or loaded from its directory, evaluated per frame into arrays.

use crate::array::Array;
use crate::errors::message;
use crate::progress::Callback;
use derma_rig::from_files::{self, BuildFiles, CharacterFiles, SetFiles};
use derma_rig::weights::{frame_weights, GlobalScale, Normalization, WeightSpec};
use derma_rig::{evaluate, BasisOptions};
use derma_shading::SkinColorLut;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// A rig in memory with the skin-colour LUT that colours its frames.
#[pyclass(module = "derma._derma", frozen)]
pub struct Rig {
    rig: derma_rig::Rig,
    lut: SkinColorLut,
}

#[pymethods]
impl Rig {
    /// Builds a rig on the texture set in `set_dir` (its hemoglobin and melanin maps; frames
    /// keep its skin) with built-in library entries (`builtin`: names or ["all"]) and target
    /// maps ({name: file}), saves it into `out` and returns it.
    #[staticmethod]
    #[pyo3(signature = (set_dir, out, *, radius, builtin=None, targets=None, mask=None,
        basis_size=derma_rig::basis::DEFAULT_BASIS_SIZE,
        sigma_floor=derma_rig::basis::DEFAULT_SIGMA_FLOOR, progress=None))]
    #[allow(clippy::too_many_arguments)]
    fn build(
        py: Python<'_>,
        set_dir: PathBuf,
        out: PathBuf,
        radius: f64,
        builtin: Option<Vec<String>>,
        targets: Option<std::collections::BTreeMap<String, PathBuf>>,
        mask: Option<PathBuf>,
        basis_size: usize,
        sigma_floor: f32,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Self> {
        let files = BuildFiles {
            character: CharacterFiles::of_set(
                SetFiles {
                    dir: set_dir,
                    table: None,
                },
                mask,
            ),
            targets: targets.unwrap_or_default().into_iter().collect(),
            builtin: builtin.unwrap_or_else(|| vec!["all".into()]),
            globals: Vec::new(),
            lut: None,
            on_mesh: None,
        };
        let opts = BasisOptions {
            radius,
            basis_size: (basis_size, basis_size),
            sigma_floor,
        };
        let callback = Callback::new(progress);
        let built = py.detach(|| {
            let (rig, _) =
                from_files::build(&files, &opts, &out, &callback).map_err(|e| message(&e))?;
            let lut = from_files::load_lut(None).map_err(|e| message(&e))?;
            Ok::<_, String>(Rig { rig, lut })
        });
        callback.finish()?;
        built.map_err(crate::errors::DermaError::new_err)
    }

    /// Loads the rig directory `dir` (`derma rig build`'s output, or [`Rig::build`]'s).
    #[staticmethod]
    fn load(py: Python<'_>, dir: PathBuf) -> PyResult<Self> {
        let (rig, lut, _) = py
            .detach(|| derma_rig::rig_dir::load(&dir))
            .map_err(crate::errors::error)?;
        Ok(Rig { rig, lut })
    }

    /// The targets' names, in the rig's order.
    #[getter]
    fn targets(&self) -> Vec<String> {
        self.rig.targets.iter().map(|t| t.name.clone()).collect()
    }

    /// The maps' (width, height).
    #[getter]
    fn size(&self) -> (usize, usize) {
        self.rig.size()
    }

    /// One frame on `device`: `weights` {target: weight} (the neutral takes the rest, Σ ≤ 1),
    /// the global hemoglobin scale a factor or None for each target's suggested one. Returns
    /// {"hemoglobin": (h, w) float32, "color": (h, w, 3) float32 linear sRGB, when the rig
    /// has melanin or a set's skin}.
    #[pyo3(signature = (weights, global_scale=None, device="cpu".to_string()))]
    fn evaluate<'py>(
        &self,
        py: Python<'py>,
        weights: std::collections::BTreeMap<String, f32>,
        global_scale: Option<f32>,
        device: String,
    ) -> PyResult<Bound<'py, PyDict>> {
        let device = crate::errors::device(&device)?;
        let spec = WeightSpec {
            entries: weights.into_iter().collect(),
        };
        let global = match global_scale {
            None => GlobalScale::Auto,
            Some(g) if g.is_finite() && g > 0.0 => GlobalScale::Fixed(g),
            Some(g) => {
                return Err(crate::errors::invalid(
                    "global_scale",
                    format!("{g}: expected a positive number"),
                ))
            }
        };
        let (w, g) = frame_weights(&self.rig, &spec, Normalization::default(), global)
            .map_err(crate::errors::error)?;
        let (h, rgb) = py
            .detach(|| {
                let melanin = self.rig.melanin.as_ref();
                evaluate::evaluate_frame(&self.rig, &self.lut, &w, g, melanin, device)
            })
            .map_err(crate::errors::error)?;
        let (fw, fh) = (h.width(), h.height());
        let d = PyDict::new(py);
        if let Some([r, g, b]) = rgb {
            let color = derma_core::image::Rgb::from_planes([&r, &g, &b]).data;
            d.set_item(
                "color",
                Bound::new(py, Array::new::<f32, _>(color, &[fh, fw, 3]))?,
            )?;
        }
        d.set_item(
            "hemoglobin",
            Bound::new(py, Array::new::<f32, _>(h.into_vec(), &[fh, fw]))?,
        )?;
        Ok(d)
    }
}
