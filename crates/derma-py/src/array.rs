//! Maps handed to Python without a copy: a buffer that owns the library's `Vec` and describes it
//! with numpy's array interface (shape, element type), so `numpy.asarray` wraps the memory.

use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Element types numpy knows by their array-interface type strings (little-endian).
pub(crate) trait Element: Plain {
    /// numpy's type string: `|u1`, `<u2`, `<u4`, `<f4`.
    const TYPESTR: &'static str;
}

/// Storage that is whole elements and nothing else: no padding, every bit pattern a value,
/// aligned at least as its elements. Implemented only for the types handed to numpy here.
///
/// # Safety
/// An implementor is `size_of::<Self>()` bytes of initialised scalars with no padding.
pub(crate) unsafe trait Plain: Copy + Send + Sync + 'static {}

// SAFETY: scalars and arrays of them have no padding.
unsafe impl Plain for u8 {}
unsafe impl Plain for u16 {}
unsafe impl Plain for u32 {}
unsafe impl Plain for f32 {}
unsafe impl<T: Plain, const N: usize> Plain for [T; N] {}
// SAFETY: repr(C), thirteen f32 (asserted at compile time in skin.rs).
unsafe impl Plain for derma_skin::features::BioSample {}

impl Element for u8 {
    const TYPESTR: &'static str = "|u1";
}
impl Element for u16 {
    const TYPESTR: &'static str = "<u2";
}
impl Element for u32 {
    const TYPESTR: &'static str = "<u4";
}
impl Element for f32 {
    const TYPESTR: &'static str = "<f4";
}

/// A read-only n-dimensional array owned by Rust; `numpy.asarray(a)` views it (the numpy array
/// keeps it alive).
#[pyclass(module = "derma._derma", frozen)]
pub struct Array {
    /// The storage, kept alive while Python holds this object; moving the `Vec` into the box
    /// does not move its elements, so `address` stays valid.
    _storage: Box<dyn Send + Sync>,
    address: usize,
    shape: Vec<usize>,
    typestr: &'static str,
}

impl Array {
    /// `data` (elements of `E`, or arrays of them) as an array of `shape`, row-major; the
    /// product of `shape` must be the number of scalars in `data`.
    pub(crate) fn new<E: Element, T: Plain>(data: Vec<T>, shape: &[usize]) -> Self {
        const { assert!(std::mem::align_of::<T>() >= std::mem::align_of::<E>()) };
        let scalars = data.len() * std::mem::size_of::<T>() / std::mem::size_of::<E>();
        assert_eq!(
            std::mem::size_of::<T>() % std::mem::size_of::<E>(),
            0,
            "an element of the storage is whole scalars"
        );
        assert_eq!(
            shape.iter().product::<usize>(),
            scalars,
            "shape {shape:?} for {scalars} values"
        );
        let address = data.as_ptr() as usize;
        Self {
            _storage: Box::new(data),
            address,
            shape: shape.to_vec(),
            typestr: E::TYPESTR,
        }
    }
}

#[pymethods]
impl Array {
    /// numpy's array interface (version 3): read-only data, C order.
    #[getter]
    fn __array_interface__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("version", 3)?;
        d.set_item("shape", pyo3::types::PyTuple::new(py, &self.shape)?)?;
        d.set_item("typestr", self.typestr)?;
        d.set_item("data", (self.address, true))?;
        Ok(d)
    }

    /// The shape, as numpy will see it.
    #[getter]
    fn shape(&self) -> Vec<usize> {
        self.shape.clone()
    }

    fn __repr__(&self) -> String {
        format!(
            "derma.Array(shape={:?}, typestr='{}')",
            self.shape, self.typestr
        )
    }
}

/// Little-endian f32 values from bytes the Python side packed (`numpy.ndarray.tobytes()` of a
/// float32 C-contiguous array); `what` names the argument in the error.
pub(crate) fn f32s(bytes: &[u8], count: usize, what: &str) -> PyResult<Vec<f32>> {
    if bytes.len() != count * 4 {
        return Err(crate::errors::invalid(
            what,
            format!("{} bytes for {count} float32 values", bytes.len()),
        ));
    }
    Ok(bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect())
}
