//! derma-py: the `derma._derma` extension module behind the `derma` Python package (docs/python.md).
//! It calls the libraries — derma-skin, derma-head, derma-synth, derma-rig, derma-photo,
//! derma-eyes, derma-export — as the CLI does, with the GIL released while they work, their
//! progress through an optional Python callback and their errors as `derma.DermaError`; maps
//! come back as buffers numpy wraps without a copy ([`array`]). The models and their sources
//! are the libraries' (docs/skin.md, docs/rig.md, docs/synth.md, docs/photo.md, docs/eyes.md).

mod array;
mod errors;
mod head;
mod jobs;
mod progress;
mod rig;
mod skin;
mod synth;

use pyo3::prelude::*;

#[pymodule]
fn _derma(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("DermaError", m.py().get_type::<errors::DermaError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<array::Array>()?;
    m.add_class::<rig::Rig>()?;
    m.add_function(wrap_pyfunction!(skin::skin, m)?)?;
    m.add_function(wrap_pyfunction!(head::head, m)?)?;
    m.add_function(wrap_pyfunction!(synth::synth, m)?)?;
    m.add_function(wrap_pyfunction!(jobs::photo_bake, m)?)?;
    m.add_function(wrap_pyfunction!(jobs::eyes_animate, m)?)?;
    Ok(())
}
