//! `derma.head`: the built-in head (or a fitted one) as arrays — the skin's vertices, normals,
//! UVs and triangles in mm, and the 52 face units as sparse vertex offsets (docs/head.md).

use crate::array::Array;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

fn vec3s(v: &[glam::Vec3]) -> Vec<[f32; 3]> {
    v.iter().map(|p| p.to_array()).collect()
}

/// The head's skin mesh and face units: `vertices` (n, 3) float32 mm, `normals` (n, 3),
/// `uvs` (n, 2) (OpenGL: v up), `faces` (m, 3) uint32, `face_units` {name: {"indices": (k,)
/// uint32, "offsets": (k, 3) float32 mm}}, `landmarks` {name: (x, y, z)}.
#[pyfunction]
#[pyo3(signature = (fitted=None))]
pub fn head(py: Python<'_>, fitted: Option<PathBuf>) -> PyResult<Bound<'_, PyDict>> {
    let h = py
        .detach(|| {
            let h = derma_head::fitted::or_builtin(fitted.as_deref())?;
            // The face units are built on first use (about a second): here, off the GIL.
            h.face_units();
            Ok::<_, derma_head::fit::store::StoreError>(h)
        })
        .map_err(crate::errors::error)?;
    let skin = &h.skin;
    let n = skin.positions.len();
    let d = PyDict::new(py);
    d.set_item(
        "vertices",
        Bound::new(py, Array::new::<f32, _>(vec3s(&skin.positions), &[n, 3]))?,
    )?;
    d.set_item(
        "normals",
        Bound::new(py, Array::new::<f32, _>(vec3s(&skin.normals), &[n, 3]))?,
    )?;
    let uvs: Vec<[f32; 2]> = skin.uvs.iter().map(|t| t.to_array()).collect();
    d.set_item("uvs", Bound::new(py, Array::new::<f32, _>(uvs, &[n, 2]))?)?;
    let m = skin.triangles.len();
    d.set_item(
        "faces",
        Bound::new(py, Array::new::<u32, _>(skin.triangles.clone(), &[m, 3]))?,
    )?;
    let units = PyDict::new(py);
    for u in h.face_units() {
        let k = u.skin.len();
        let e = PyDict::new(py);
        let idx: Vec<u32> = u.skin.iter().map(|(i, _)| *i).collect();
        let off: Vec<[f32; 3]> = u.skin.iter().map(|(_, o)| o.to_array()).collect();
        e.set_item("indices", Bound::new(py, Array::new::<u32, _>(idx, &[k]))?)?;
        e.set_item(
            "offsets",
            Bound::new(py, Array::new::<f32, _>(off, &[k, 3]))?,
        )?;
        units.set_item(&u.name, e)?;
    }
    d.set_item("face_units", units)?;
    let marks = PyDict::new(py);
    for (name, p) in &h.landmarks.points {
        marks.set_item(name, p.to_array())?;
    }
    d.set_item("landmarks", marks)?;
    Ok(d)
}
