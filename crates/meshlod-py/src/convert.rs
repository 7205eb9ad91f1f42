//! numpy arrays to the library's buffers and back.
//!
//! In: every array is checked (an `ndarray`, its dtype, its shape, every index
//! non-negative and within `u32`, every `float64` coordinate within `float32`'s
//! range) and copied once into the library's `Vec`s; a C-contiguous array is read
//! as one slice, any other layout through its strides. Out: the library's `Vec`s
//! become numpy arrays without a copy when the dtype is the library's own
//! (`float32` positions, `uint32` indices), and are converted in one pass otherwise.

use numpy::{
    dtype, Element, PyArray1, PyArray2, PyArrayDescrMethods, PyArrayMethods, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

/// The float width of an input, given back on output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FloatKind {
    /// `float32`.
    F32,
    /// `float64`.
    F64,
}

/// The integer dtype of an index input, given back on output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IndexKind {
    /// `int32`.
    I32,
    /// `int64`.
    I64,
    /// `uint32`.
    U32,
    /// `uint64`.
    U64,
}

/// The dtype of a colour input: floats in `[0, 1]` or bytes in `0..=255`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColorKind {
    /// Floats of this width.
    Float(FloatKind),
    /// `uint8`.
    U8,
}

/// `obj` as an untyped numpy array with `cols` columns (shape `(n, cols)`), or a
/// `TypeError`/`ValueError` naming `name`.
fn matrix<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
    cols: &[usize],
) -> PyResult<Bound<'py, PyUntypedArray>> {
    let array = obj.cast::<PyUntypedArray>().map_err(|_| {
        PyTypeError::new_err(format!(
            "{name} must be a numpy array, got {}",
            type_name(obj)
        ))
    })?;
    let shape = array.shape();
    if shape.len() != 2 || !cols.contains(&shape[1]) {
        let want = cols
            .iter()
            .map(|c| format!("(n, {c})"))
            .collect::<Vec<_>>()
            .join(" or ");
        return Err(PyValueError::new_err(format!(
            "{name} must have shape {want}, got {}",
            shape_text(shape)
        )));
    }
    Ok(array.clone())
}

/// The Python type name of `obj`, for messages.
fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type()
        .name()
        .map_or_else(|_| "an unknown type".to_string(), |n| n.to_string())
}

/// `(3,)`, `(4, 2)`: a shape as numpy prints it.
fn shape_text(shape: &[usize]) -> String {
    match shape {
        [one] => format!("({one},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// The dtype's name (`float32`, `int64`, …), for messages.
fn dtype_name(array: &Bound<'_, PyUntypedArray>) -> String {
    array
        .dtype()
        .str()
        .map_or_else(|_| "an unknown dtype".to_string(), |s| s.to_string())
}

/// Whether `array`'s dtype is `T`.
fn is<T: Element>(array: &Bound<'_, PyUntypedArray>) -> bool {
    array.dtype().is_equiv_to(&dtype::<T>(array.py()))
}

/// The rows of a 2-D array of `T` with `C` columns, each converted by `f`: one pass
/// over a C-contiguous array's slice, or through the strides otherwise.
fn rows<T: Element + Copy, U, const C: usize>(
    array: &Bound<'_, PyUntypedArray>,
    mut f: impl FnMut(T) -> U,
) -> PyResult<Vec<[U; C]>> {
    let typed = array.cast::<PyArray2<T>>()?;
    let readonly = typed.readonly();
    let view = readonly.as_array();
    Ok(match view.as_slice() {
        Some(flat) => flat
            .chunks_exact(C)
            .map(|r| std::array::from_fn(|k| f(r[k])))
            .collect(),
        None => view
            .rows()
            .into_iter()
            .map(|r| std::array::from_fn(|k| f(r[k])))
            .collect(),
    })
}

/// A `float32`/`float64` array of shape `(n, C)` as `f32` rows, with its width.
/// `float64` values beyond `float32`'s range are refused (they would become
/// infinite); NaN and infinity are left to the library's validation.
pub fn float_rows<const C: usize>(
    obj: &Bound<'_, PyAny>,
    name: &str,
) -> PyResult<(Vec<[f32; C]>, FloatKind)> {
    let array = matrix(obj, name, &[C])?;
    if is::<f32>(&array) {
        return Ok((rows::<f32, f32, C>(&array, |x| x)?, FloatKind::F32));
    }
    if is::<f64>(&array) {
        let mut overflow: Option<f64> = None;
        let out = rows::<f64, f32, C>(&array, |x| {
            let y = x as f32;
            if y.is_infinite() && x.is_finite() && overflow.is_none() {
                overflow = Some(x);
            }
            y
        })?;
        if let Some(x) = overflow {
            return Err(PyValueError::new_err(format!(
                "{name} holds {x}, beyond float32's range (meshlod stores positions and \
                 attributes as float32)"
            )));
        }
        return Ok((out, FloatKind::F64));
    }
    Err(PyTypeError::new_err(format!(
        "{name} must be float32 or float64, got {}",
        dtype_name(&array)
    )))
}

/// Colours of shape `(n, 3)` or `(n, 4)`: floats in `[0, 1]` or `uint8`; RGB gets
/// alpha 1. Returns RGBA rows, the dtype and the column count.
pub fn colors(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<(Vec<[f32; 4]>, ColorKind, usize)> {
    let array = matrix(obj, name, &[3, 4])?;
    let cols = array.shape()[1];
    let rgba = |rgb: Vec<[f32; 3]>| -> Vec<[f32; 4]> {
        rgb.into_iter().map(|[r, g, b]| [r, g, b, 1.0]).collect()
    };
    if is::<u8>(&array) {
        let to = |x: u8| f32::from(x) / 255.0;
        let out = if cols == 3 {
            rgba(rows::<u8, f32, 3>(&array, to)?)
        } else {
            rows::<u8, f32, 4>(&array, to)?
        };
        return Ok((out, ColorKind::U8, cols));
    }
    let (out, kind) = if cols == 3 {
        let (rgb, kind) = float_rows::<3>(obj, name)?;
        (rgba(rgb), kind)
    } else {
        float_rows::<4>(obj, name)?
    };
    if let Some(bad) = out.as_flattened().iter().find(|x| !x.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "{name} holds {bad}: colours must be finite"
        )));
    }
    Ok((out, ColorKind::Float(kind), cols))
}

/// An index array of shape `(m, 3)` (any integer dtype) as `u32` triangles. A
/// negative index, or one above `u32`'s range, is refused here naming its row and
/// column; indices at or past the vertex count are left to the library's
/// validation (which names the triangle).
pub fn faces(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<(Vec<[u32; 3]>, IndexKind)> {
    let array = matrix(obj, name, &[3])?;
    macro_rules! try_dtype {
        ($t:ty, $kind:expr) => {
            if is::<$t>(&array) {
                let mut bad: Option<(usize, i128)> = None;
                let mut i = 0usize;
                let out = rows::<$t, u32, 3>(&array, |x| {
                    let v = i128::from(x);
                    if (v < 0 || v > i128::from(u32::MAX)) && bad.is_none() {
                        bad = Some((i, v));
                    }
                    i += 1;
                    v as u32
                })?;
                if let Some((at, v)) = bad {
                    let (row, col) = (at / 3, at % 3);
                    return Err(PyValueError::new_err(if v < 0 {
                        format!("{name}[{row}, {col}] is {v}: vertex indices must be non-negative")
                    } else {
                        format!(
                            "{name}[{row}, {col}] is {v}: beyond 32-bit indices (meshlod's limit)"
                        )
                    }));
                }
                return Ok((out, $kind));
            }
        };
    }
    try_dtype!(i32, IndexKind::I32);
    try_dtype!(i64, IndexKind::I64);
    try_dtype!(u32, IndexKind::U32);
    try_dtype!(u64, IndexKind::U64);
    try_dtype!(i16, IndexKind::I64);
    try_dtype!(u16, IndexKind::I64);
    try_dtype!(i8, IndexKind::I64);
    try_dtype!(u8, IndexKind::I64);
    Err(PyTypeError::new_err(format!(
        "{name} must be an integer array (int32, int64, uint32, …), got {}",
        dtype_name(&array)
    )))
}

/// A boolean array of shape `(n,)`.
pub fn mask(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<bool>> {
    let array = obj.cast::<PyArray1<bool>>().map_err(|_| {
        PyTypeError::new_err(format!(
            "{name} must be a one-dimensional numpy array of bool"
        ))
    })?;
    Ok(array.readonly().as_array().iter().copied().collect())
}

/// `rows` as a numpy array of shape `(n, C)` in `kind`: the buffer handed over as
/// it is for `float32`, converted for `float64`.
pub fn float_array<'py, const C: usize>(
    py: Python<'py>,
    rows: Vec<[f32; C]>,
    kind: FloatKind,
) -> PyResult<Bound<'py, PyAny>> {
    let n = rows.len();
    let flat = rows.into_flattened();
    Ok(match kind {
        FloatKind::F32 => PyArray1::from_vec(py, flat).reshape([n, C])?.into_any(),
        FloatKind::F64 => {
            let wide: Vec<f64> = flat.into_iter().map(f64::from).collect();
            PyArray1::from_vec(py, wide).reshape([n, C])?.into_any()
        }
    })
}

/// Triangles as a numpy array of shape `(m, 3)` in `kind` (`int32` when it holds
/// every index, else `int64`).
pub fn index_array<'py>(
    py: Python<'py>,
    triangles: Vec<[u32; 3]>,
    vertices: usize,
    kind: IndexKind,
) -> PyResult<Bound<'py, PyAny>> {
    let m = triangles.len();
    let flat = triangles.into_flattened();
    let kind = if kind == IndexKind::I32 && i32::try_from(vertices).is_err() {
        IndexKind::I64
    } else {
        kind
    };
    Ok(match kind {
        IndexKind::U32 => PyArray1::from_vec(py, flat).reshape([m, 3])?.into_any(),
        IndexKind::I32 => {
            let v: Vec<i32> = flat.into_iter().map(|i| i as i32).collect();
            PyArray1::from_vec(py, v).reshape([m, 3])?.into_any()
        }
        IndexKind::I64 => {
            let v: Vec<i64> = flat.into_iter().map(i64::from).collect();
            PyArray1::from_vec(py, v).reshape([m, 3])?.into_any()
        }
        IndexKind::U64 => {
            let v: Vec<u64> = flat.into_iter().map(u64::from).collect();
            PyArray1::from_vec(py, v).reshape([m, 3])?.into_any()
        }
    })
}

/// RGBA colours as a numpy array with `cols` columns in `kind` (bytes rounded from
/// `[0, 1]`).
pub fn color_array<'py>(
    py: Python<'py>,
    rgba: Vec<[f32; 4]>,
    kind: ColorKind,
    cols: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let n = rgba.len();
    let flat: Vec<f32> = if cols == 3 {
        rgba.into_iter()
            .flat_map(|[r, g, b, _]| [r, g, b])
            .collect()
    } else {
        rgba.into_flattened()
    };
    Ok(match kind {
        ColorKind::Float(FloatKind::F32) => {
            PyArray1::from_vec(py, flat).reshape([n, cols])?.into_any()
        }
        ColorKind::Float(FloatKind::F64) => {
            let v: Vec<f64> = flat.into_iter().map(f64::from).collect();
            PyArray1::from_vec(py, v).reshape([n, cols])?.into_any()
        }
        ColorKind::U8 => {
            let v: Vec<u8> = flat
                .into_iter()
                .map(|x| (x.clamp(0.0, 1.0) * 255.0).round() as u8)
                .collect();
            PyArray1::from_vec(py, v).reshape([n, cols])?.into_any()
        }
    })
}

/// A `serde_json` value as Python objects (`dict`, `list`, `float`, `int`, `str`,
/// `bool`, `None`), so reports carry the CLI's `--json` field names.
pub fn json_to_py<'py>(py: Python<'py>, value: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    use pyo3::types::{PyDict, PyList};
    use serde_json::Value;
    Ok(match value {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => b.into_pyobject(py)?.to_owned().into_any(),
        Value::Number(n) => {
            if let Some(u) = n.as_u64() {
                u.into_pyobject(py)?.into_any()
            } else if let Some(i) = n.as_i64() {
                i.into_pyobject(py)?.into_any()
            } else {
                n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any()
            }
        }
        Value::String(s) => s.into_pyobject(py)?.into_any(),
        Value::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(json_to_py(py, item)?)?;
            }
            list.into_any()
        }
        Value::Object(map) => {
            let dict = PyDict::new(py);
            for (k, v) in map {
                dict.set_item(k, json_to_py(py, v)?)?;
            }
            dict.into_any()
        }
    })
}

/// A serialisable report as a Python `dict` (through [`json_to_py`]).
pub fn report<'py>(py: Python<'py>, report: &impl serde::Serialize) -> PyResult<Bound<'py, PyAny>> {
    let value =
        serde_json::to_value(report).map_err(|e| PyValueError::new_err(format!("report: {e}")))?;
    json_to_py(py, &value)
}

/// A list of vertex ids as a 1-D numpy array in `kind` (`int32` when every id below
/// `bound` fits, else `int64`).
pub fn index_array_1d<'py>(
    py: Python<'py>,
    ids: Vec<u32>,
    bound: usize,
    kind: IndexKind,
) -> PyResult<Bound<'py, PyAny>> {
    Ok(match kind {
        IndexKind::U32 => PyArray1::from_vec(py, ids).into_any(),
        IndexKind::I32 if i32::try_from(bound).is_ok() => {
            let v: Vec<i32> = ids.into_iter().map(|i| i as i32).collect();
            PyArray1::from_vec(py, v).into_any()
        }
        IndexKind::I32 | IndexKind::I64 => {
            let v: Vec<i64> = ids.into_iter().map(i64::from).collect();
            PyArray1::from_vec(py, v).into_any()
        }
        IndexKind::U64 => {
            let v: Vec<u64> = ids.into_iter().map(u64::from).collect();
            PyArray1::from_vec(py, v).into_any()
        }
    })
}

/// A 2-D `float32`/`float64` grid (rows first) as row-major `f32` values, with its
/// width. NaN and infinity are voids (filled by the height field); `float64`
/// heights beyond `float32`'s range are refused.
pub fn float_grid(
    array: &Bound<'_, PyUntypedArray>,
    name: &str,
) -> PyResult<(Vec<f32>, FloatKind)> {
    fn flat<T: Element + Copy>(
        array: &Bound<'_, PyUntypedArray>,
        f: impl FnMut(T) -> f32,
    ) -> PyResult<Vec<f32>> {
        let typed = array.cast::<PyArray2<T>>()?;
        let readonly = typed.readonly();
        Ok(readonly.as_array().iter().copied().map(f).collect())
    }
    if is::<f32>(array) {
        return Ok((flat::<f32>(array, |x| x)?, FloatKind::F32));
    }
    if is::<f64>(array) {
        let mut overflow = None;
        let v = flat::<f64>(array, |x| {
            let y = x as f32;
            if y.is_infinite() && x.is_finite() && overflow.is_none() {
                overflow = Some(x);
            }
            y
        })?;
        if let Some(x) = overflow {
            return Err(PyValueError::new_err(format!(
                "{name} holds {x}, beyond float32's range"
            )));
        }
        return Ok((v, FloatKind::F64));
    }
    Err(PyTypeError::new_err(format!(
        "{name} must be float32 or float64, got {}",
        dtype_name(array)
    )))
}
