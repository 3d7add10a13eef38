//! `derma.synth`: exemplar synthesis (Shen et al.; docs/synth.md) from Python — an exemplar
//! array in, a texture of any size out, the same bits on CPU and GPU for a seed.

use crate::array::{f32s, Array};
use crate::errors::message;
use crate::progress::Callback;
use derma_synth::synthesizer::Synthesizer;
use derma_synth::texture::Texture;
use pyo3::prelude::*;

/// Grows a `width` × `height` texture from an exemplar given as float32 bytes of shape
/// (`ex_height`, `ex_width`, `channels`), C order; returns (height, width, channels) float32.
#[pyfunction]
#[pyo3(signature = (exemplar, ex_width, ex_height, channels, width, height, *, seed=1, tile=false,
    patch=None, passes=None, settle=None, search="coherent".to_string(), device="auto".to_string(),
    progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn synth(
    py: Python<'_>,
    exemplar: &[u8],
    ex_width: usize,
    ex_height: usize,
    channels: usize,
    width: usize,
    height: usize,
    seed: u64,
    tile: bool,
    patch: Option<usize>,
    passes: Option<usize>,
    settle: Option<f32>,
    search: String,
    device: String,
    progress: Option<Py<PyAny>>,
) -> PyResult<Py<PyAny>> {
    let data = f32s(exemplar, ex_width * ex_height * channels, "exemplar")?;
    let texture =
        Texture::new(ex_width, ex_height, channels, data).map_err(crate::errors::error)?;
    let device = crate::errors::device(&device)?;
    let scope = derma_synth::coherence::Scope::parse(&search).ok_or_else(|| {
        crate::errors::invalid(
            "search",
            format!("'{search}': expected 'coherent' or 'exhaustive'"),
        )
    })?;
    if width == 0 || height == 0 {
        return Err(crate::errors::invalid(
            "size",
            format!("{width}×{height}: expected at least 1×1"),
        ));
    }
    let callback = Callback::new(progress);
    let result = py.detach(|| {
        let mut s = Synthesizer::new(texture)
            .size(width, height)
            .seed(seed)
            .tile(tile)
            .device(device)
            .search(scope)
            .progress(&callback);
        if let Some(f) = settle {
            s = s.settle(f);
        }
        if let Some(p) = patch {
            s = s.patch(p);
        }
        if let Some(p) = passes {
            s = s.passes(p);
        }
        s.run().map_err(|e| message(&e))
    });
    callback.finish()?;
    let t = result.map_err(crate::errors::DermaError::new_err)?.texture;
    let shape = [t.height, t.width, t.channels];
    Ok(Bound::new(py, Array::new::<f32, _>(t.data, &shape))?
        .into_any()
        .unbind())
}
