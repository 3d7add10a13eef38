//! Errors across the boundary: a library's error (with its chain of causes) or a bad argument
//! becomes `derma.DermaError`, whose message names the file, key or value and what was expected.

use pyo3::prelude::*;

pyo3::create_exception!(
    derma,
    DermaError,
    pyo3::exceptions::PyException,
    "An error of derma's libraries: its message names the file, key or value and what was expected."
);

/// A library error's text with its causes not already in it (built without the GIL, raised
/// with it).
pub(crate) fn message(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        let t = s.to_string();
        if !text.contains(&t) {
            text.push_str(": ");
            text.push_str(&t);
        }
        source = s.source();
    }
    text
}

/// A library error as a `DermaError` carrying its whole chain of causes.
pub(crate) fn error(e: impl std::error::Error) -> PyErr {
    DermaError::new_err(message(&e))
}

/// A value the caller gave that derma cannot use, as a `DermaError` naming it.
pub(crate) fn invalid(what: &str, detail: impl std::fmt::Display) -> PyErr {
    DermaError::new_err(format!("{what}: {detail}"))
}

/// The value of argument `key` in `d` (None when absent or None); a value of the wrong type is
/// a `DermaError` naming the argument, what was `expected` and what was given.
pub(crate) fn item<'py, T>(
    d: &Bound<'py, pyo3::types::PyDict>,
    key: &str,
    expected: &str,
) -> PyResult<Option<T>>
where
    T: for<'a> FromPyObject<'a, 'py>,
{
    use pyo3::types::PyDictMethods;
    let Some(v) = d.get_item(key)? else {
        return Ok(None);
    };
    if v.is_none() {
        return Ok(None);
    }
    v.extract::<T>().map(Some).map_err(|_| {
        let got = v.repr().map_or_else(|_| "?".into(), |r| r.to_string());
        invalid(key, format!("expected {expected}, got {got}"))
    })
}

/// A device name ("auto", "cpu", "gpu") as derma-core reads it.
pub(crate) fn device(name: &str) -> PyResult<derma_core::gpu::Device> {
    name.parse().map_err(|e: String| invalid("device", e))
}
