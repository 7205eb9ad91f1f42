//! Buffer views and accessors (glTF 2.0 spec, section 3.6 "Binary Data Storage"):
//! parsing with bounds checks, and decoding into `f32` / `u32` arrays, with
//! normalisation, byte strides and sparse substitution.

use super::super::FormatError;
use super::json::{elem, object, opt_bool, opt_ref, opt_usize, req_usize, show, top_array, Obj};
use serde_json::Value;

/// An accessor component type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Component {
    /// `BYTE` (5120).
    I8,
    /// `UNSIGNED_BYTE` (5121).
    U8,
    /// `SHORT` (5122).
    I16,
    /// `UNSIGNED_SHORT` (5123).
    U16,
    /// `UNSIGNED_INT` (5125).
    U32,
    /// `FLOAT` (5126).
    F32,
}

impl Component {
    fn from_code(code: u64) -> Option<Self> {
        Some(match code {
            5120 => Self::I8,
            5121 => Self::U8,
            5122 => Self::I16,
            5123 => Self::U16,
            5125 => Self::U32,
            5126 => Self::F32,
            _ => return None,
        })
    }

    /// Bytes per component.
    pub(super) fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::U32 | Self::F32 => 4,
        }
    }

    /// The glTF name, for messages.
    pub(super) fn name(self) -> &'static str {
        match self {
            Self::I8 => "BYTE",
            Self::U8 => "UNSIGNED_BYTE",
            Self::I16 => "SHORT",
            Self::U16 => "UNSIGNED_SHORT",
            Self::U32 => "UNSIGNED_INT",
            Self::F32 => "FLOAT",
        }
    }
}

/// A parsed buffer view.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct View {
    /// The buffer it points into.
    pub buffer: usize,
    /// Start in the buffer.
    pub offset: usize,
    /// Length in bytes.
    pub length: usize,
    /// Distance between vertex attribute elements, when interleaved.
    pub stride: Option<usize>,
}

/// Sparse substitution of an accessor.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct Sparse {
    /// Number of substituted elements.
    pub count: usize,
    /// Buffer view of the element indices.
    pub indices_view: usize,
    /// Offset of the indices in their view.
    pub indices_offset: usize,
    /// Component type of the indices (`U8`, `U16` or `U32`).
    pub indices_component: Component,
    /// Buffer view of the substituted values.
    pub values_view: usize,
    /// Offset of the values in their view.
    pub values_offset: usize,
}

/// A parsed accessor.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Accessor {
    /// Component type.
    pub component: Component,
    /// Integer values map to [0, 1] or [-1, 1].
    pub normalized: bool,
    /// Number of elements.
    pub count: usize,
    /// `SCALAR`, `VEC2`, … `MAT4`.
    pub ty: &'static str,
    /// Components per element.
    pub components: usize,
    /// Bytes per element, including the column padding of small matrices.
    pub element_size: usize,
    /// Its buffer view; `None` means all zeros (before sparse substitution).
    pub view: Option<usize>,
    /// Offset in the view.
    pub offset: usize,
    /// Sparse substitution.
    pub sparse: Option<Sparse>,
}

impl Accessor {
    /// The byte range `(start, end)` the accessor reads from its view, given the
    /// view's stride.
    pub(super) fn byte_range(&self, stride: Option<usize>) -> Option<(usize, usize)> {
        let stride = stride.unwrap_or(self.element_size);
        let span = stride
            .checked_mul(self.count.checked_sub(1)?)?
            .checked_add(self.element_size)?;
        Some((self.offset, self.offset.checked_add(span)?))
    }

    /// Byte ranges `(start, end)` of the sparse indices and values in their views.
    pub(super) fn sparse_ranges(&self) -> Option<((usize, usize), (usize, usize))> {
        let s = self.sparse.as_ref()?;
        let ilen = s.count.checked_mul(s.indices_component.size())?;
        let vlen = s.count.checked_mul(self.element_size)?;
        Some((
            (s.indices_offset, s.indices_offset.checked_add(ilen)?),
            (s.values_offset, s.values_offset.checked_add(vlen)?),
        ))
    }
}

/// Parses buffer view `i`, checking that it lies inside its buffer, whose length is
/// `buffer_len(b)` (`None` when the buffer is not loaded).
pub(super) fn parse_view(
    v: &Value,
    i: usize,
    buffer_count: usize,
    buffer_len: impl Fn(usize) -> Option<usize>,
) -> Result<View, FormatError> {
    const K: &str = "bufferView";
    let o = object(v, K, i)?;
    let buffer = opt_ref(o, "buffer", K, i, buffer_count, "buffers")?
        .ok_or_else(|| elem(K, i, "missing \"buffer\""))?;
    let offset = opt_usize(o, "byteOffset", K, i)?.unwrap_or(0);
    let length = req_usize(o, "byteLength", K, i)?;
    if length == 0 {
        return Err(elem(K, i, "byteLength must be at least 1"));
    }
    let stride = opt_usize(o, "byteStride", K, i)?;
    if let Some(s) = stride {
        if !(4..=252).contains(&s) {
            return Err(elem(K, i, format!("byteStride {s} is outside 4..252")));
        }
    }
    let buf_len =
        buffer_len(buffer).ok_or_else(|| elem(K, i, format!("buffer {buffer} is not loaded")))?;
    match offset.checked_add(length) {
        Some(end) if end <= buf_len => {}
        _ => {
            return Err(elem(
                K,
                i,
                format!(
                    "bytes {offset}..{} run past the end of buffer {buffer} ({buf_len} bytes)",
                    offset as u128 + length as u128
                ),
            ))
        }
    }
    Ok(View {
        buffer,
        offset,
        length,
        stride,
    })
}

fn type_components(ty: &str) -> Option<(&'static str, usize)> {
    Some(match ty {
        "SCALAR" => ("SCALAR", 1),
        "VEC2" => ("VEC2", 2),
        "VEC3" => ("VEC3", 3),
        "VEC4" => ("VEC4", 4),
        "MAT2" => ("MAT2", 4),
        "MAT3" => ("MAT3", 9),
        "MAT4" => ("MAT4", 16),
        _ => return None,
    })
}

/// Bytes per element: matrix columns start on 4-byte boundaries.
fn element_size(ty: &str, c: Component) -> usize {
    let s = c.size();
    match (ty, s) {
        ("MAT2", 1) => 8,
        ("MAT3", 1) => 12,
        ("MAT3", 2) => 24,
        (_, s) => type_components(ty).map_or(0, |(_, n)| n * s),
    }
}

/// Parses accessor `i` and checks that everything it reads lies inside its buffer
/// views. Accessors without a buffer view may have at most `max_count` elements.
pub(super) fn parse_accessor(
    v: &Value,
    i: usize,
    views: &[View],
    max_count: usize,
) -> Result<Accessor, FormatError> {
    const K: &str = "accessor";
    let o = object(v, K, i)?;
    let code = req_usize(o, "componentType", K, i)?;
    let component = Component::from_code(code as u64)
        .ok_or_else(|| elem(K, i, format!("unknown componentType {code}")))?;
    let ty_value = o
        .get("type")
        .ok_or_else(|| elem(K, i, "missing \"type\""))?;
    let (ty, components) = ty_value
        .as_str()
        .and_then(type_components)
        .ok_or_else(|| elem(K, i, format!("unknown type {}", show(ty_value))))?;
    let normalized = opt_bool(o, "normalized", K, i)?;
    if normalized && matches!(component, Component::U32) {
        return Err(elem(K, i, "UNSIGNED_INT accessors cannot be normalized"));
    }
    let count = req_usize(o, "count", K, i)?;
    if count == 0 {
        return Err(elem(K, i, "count must be at least 1"));
    }
    let view = opt_ref(o, "bufferView", K, i, views.len(), "buffer views")?;
    let offset = opt_usize(o, "byteOffset", K, i)?.unwrap_or(0);
    let esize = element_size(ty, component);
    let mut acc = Accessor {
        component,
        normalized,
        count,
        ty,
        components,
        element_size: esize,
        view,
        offset: if view.is_some() { offset } else { 0 },
        sparse: None,
    };
    match view.and_then(|v| views.get(v).map(|w| (v, w))) {
        Some((vi, w)) => {
            if let Some(s) = w.stride {
                if s < esize {
                    return Err(elem(
                        K,
                        i,
                        format!(
                            "bufferView {vi} has byteStride {s}, less than the {esize}-byte {ty} {} element",
                            component.name()
                        ),
                    ));
                }
            }
            match acc.byte_range(w.stride) {
                Some((_, end)) if end <= w.length => {}
                _ => {
                    return Err(elem(
                        K,
                        i,
                        format!(
                            "{count} elements of {esize} bytes from byteOffset {offset} do not fit in bufferView {vi} ({} bytes)",
                            w.length
                        ),
                    ))
                }
            }
        }
        None => {
            if count > max_count {
                return Err(elem(
                    K,
                    i,
                    format!("count {count} is more than the file can describe ({max_count})"),
                ));
            }
        }
    }
    if let Some(s) = o.get("sparse") {
        acc.sparse = Some(parse_sparse(s, i, &acc, views)?);
    }
    Ok(acc)
}

fn parse_sparse(
    s: &Value,
    i: usize,
    acc: &Accessor,
    views: &[View],
) -> Result<Sparse, FormatError> {
    const K: &str = "accessor";
    let s = s
        .as_object()
        .ok_or_else(|| elem(K, i, "\"sparse\" must be an object"))?;
    let count = req_usize(s, "count", K, i)?;
    if count == 0 || count > acc.count {
        return Err(elem(
            K,
            i,
            format!("sparse count {count} must be in 1..={}", acc.count),
        ));
    }
    let part = |key: &str| -> Result<&Obj, FormatError> {
        s.get(key)
            .and_then(Value::as_object)
            .ok_or_else(|| elem(K, i, format!("sparse \"{key}\" must be an object")))
    };
    let idx = part("indices")?;
    let val = part("values")?;
    let indices_view = opt_ref(idx, "bufferView", K, i, views.len(), "buffer views")?
        .ok_or_else(|| elem(K, i, "sparse indices have no bufferView"))?;
    let values_view = opt_ref(val, "bufferView", K, i, views.len(), "buffer views")?
        .ok_or_else(|| elem(K, i, "sparse values have no bufferView"))?;
    let code = req_usize(idx, "componentType", K, i)?;
    let indices_component = Component::from_code(code as u64)
        .filter(|c| matches!(c, Component::U8 | Component::U16 | Component::U32))
        .ok_or_else(|| {
            elem(
                K,
                i,
                format!("sparse indices componentType {code} is not an unsigned integer type"),
            )
        })?;
    let sparse = Sparse {
        count,
        indices_view,
        indices_offset: opt_usize(idx, "byteOffset", K, i)?.unwrap_or(0),
        indices_component,
        values_view,
        values_offset: opt_usize(val, "byteOffset", K, i)?.unwrap_or(0),
    };
    let mut checked = acc.clone();
    checked.sparse = Some(sparse.clone());
    let ranges = checked.sparse_ranges();
    let fits = |view: usize, end: Option<usize>| matches!((views.get(view), end), (Some(w), Some(e)) if e <= w.length);
    if !fits(indices_view, ranges.map(|r| r.0 .1)) {
        return Err(elem(
            K,
            i,
            format!("sparse indices ({count}) do not fit in bufferView {indices_view}"),
        ));
    }
    if !fits(values_view, ranges.map(|r| r.1 .1)) {
        return Err(elem(
            K,
            i,
            format!("sparse values ({count}) do not fit in bufferView {values_view}"),
        ));
    }
    Ok(sparse)
}

/// Parses every buffer view of the document.
pub(super) fn parse_views(
    root: &Obj,
    buffer_count: usize,
    buffer_len: impl Fn(usize) -> Option<usize>,
) -> Result<Vec<View>, FormatError> {
    top_array(root, "bufferViews")?
        .iter()
        .enumerate()
        .map(|(i, v)| parse_view(v, i, buffer_count, &buffer_len))
        .collect()
}

/// Parses every accessor of the document.
pub(super) fn parse_accessors(
    root: &Obj,
    views: &[View],
    max_count: usize,
) -> Result<Vec<Accessor>, FormatError> {
    top_array(root, "accessors")?
        .iter()
        .enumerate()
        .map(|(i, v)| parse_accessor(v, i, views, max_count))
        .collect()
}

#[inline]
fn bytes<const S: usize>(b: &[u8], at: usize) -> [u8; S] {
    // Never out of range after the bounds checks in `parse_accessor`; zeros otherwise.
    b.get(at..at.saturating_add(S))
        .and_then(|s| <[u8; S]>::try_from(s).ok())
        .unwrap_or([0; S])
}

/// Decoded accessors over loaded buffers.
pub(super) struct Store<'a> {
    /// Buffer data by index (empty for buffers that are not loaded).
    pub buffers: Vec<&'a [u8]>,
    /// Every buffer view.
    pub views: Vec<View>,
    /// Every accessor.
    pub accessors: Vec<Accessor>,
}

/// Reads one component at byte `at` of `b` as a value of the output type.
trait Read<T>: Copy {
    fn read(self, b: &[u8], at: usize) -> T;
}

impl<T, F: Fn(&[u8], usize) -> T + Copy> Read<T> for F {
    #[inline]
    fn read(self, b: &[u8], at: usize) -> T {
        self(b, at)
    }
}

impl Store<'_> {
    /// The bytes of buffer view `v`.
    fn view_bytes(&self, v: usize) -> &[u8] {
        self.views
            .get(v)
            .and_then(|w| {
                self.buffers
                    .get(w.buffer)?
                    .get(w.offset..w.offset.checked_add(w.length)?)
            })
            .unwrap_or(&[])
    }

    /// The accessor `a`, checked to have `N` components.
    fn accessor<const N: usize>(&self, a: usize, what: &str) -> Result<&Accessor, FormatError> {
        let acc = self.accessors.get(a).ok_or_else(|| {
            elem(
                "accessor",
                a,
                format!("{what} refers to a missing accessor"),
            )
        })?;
        let expected = match N {
            1 => "SCALAR",
            2 => "VEC2",
            3 => "VEC3",
            _ => "VEC4",
        };
        if acc.ty != expected {
            return Err(elem(
                "accessor",
                a,
                format!("{what} must be {expected}, found {}", acc.ty),
            ));
        }
        Ok(acc)
    }

    /// Decodes accessor `a` (`N` components per element, each read by `read` from a
    /// `size`-byte component), with sparse substitution.
    fn gather<T: Copy + Default, const N: usize>(
        &self,
        a: usize,
        acc: &Accessor,
        read: impl Read<T>,
    ) -> Result<Vec<[T; N]>, FormatError> {
        let cs = acc.component.size();
        let mut out = match acc.view {
            Some(v) => {
                let data = self.view_bytes(v);
                let stride = self
                    .views
                    .get(v)
                    .and_then(|w| w.stride)
                    .unwrap_or(acc.element_size);
                let mut out = Vec::with_capacity(acc.count);
                let mut at = acc.offset;
                for _ in 0..acc.count {
                    let mut e = [T::default(); N];
                    for (k, x) in e.iter_mut().enumerate() {
                        *x = read.read(data, at + k * cs);
                    }
                    out.push(e);
                    at += stride;
                }
                out
            }
            None => vec![[T::default(); N]; acc.count],
        };
        if let Some(s) = &acc.sparse {
            let idx = self.view_bytes(s.indices_view);
            let val = self.view_bytes(s.values_view);
            let mut prev: Option<usize> = None;
            for j in 0..s.count {
                let at = s.indices_offset + j * s.indices_component.size();
                let target = match s.indices_component {
                    Component::U8 => usize::from(bytes::<1>(idx, at)[0]),
                    Component::U16 => usize::from(u16::from_le_bytes(bytes(idx, at))),
                    _ => u32::from_le_bytes(bytes(idx, at)) as usize,
                };
                if prev.is_some_and(|p| target <= p) || target >= acc.count {
                    return Err(elem(
                        "accessor",
                        a,
                        format!(
                            "sparse index {j} is {target}: indices must increase and be below count {}",
                            acc.count
                        ),
                    ));
                }
                prev = Some(target);
                let base = s.values_offset + j * acc.element_size;
                if let Some(slot) = out.get_mut(target) {
                    for (k, x) in slot.iter_mut().enumerate() {
                        *x = read.read(val, base + k * cs);
                    }
                }
            }
        }
        Ok(out)
    }

    /// Decodes accessor `a` as floats: `FLOAT` as is, integer types normalised when the
    /// accessor says so and converted by value otherwise. `what` names the use
    /// (e.g. "POSITION of mesh 0 primitive 1") in errors.
    pub(super) fn floats<const N: usize>(
        &self,
        a: usize,
        what: &str,
    ) -> Result<Vec<[f32; N]>, FormatError> {
        let acc = self.accessor::<N>(a, what)?;
        match (acc.component, acc.normalized) {
            (Component::F32, _) => {
                self.gather(a, acc, |b: &[u8], at| f32::from_le_bytes(bytes(b, at)))
            }
            (Component::I8, true) => self.gather(a, acc, |b: &[u8], at| {
                (f32::from(i8::from_le_bytes(bytes(b, at))) / 127.0).max(-1.0)
            }),
            (Component::U8, true) => self.gather(a, acc, |b: &[u8], at| {
                f32::from(bytes::<1>(b, at)[0]) / 255.0
            }),
            (Component::I16, true) => self.gather(a, acc, |b: &[u8], at| {
                (f32::from(i16::from_le_bytes(bytes(b, at))) / 32767.0).max(-1.0)
            }),
            (Component::U16, true) => self.gather(a, acc, |b: &[u8], at| {
                f32::from(u16::from_le_bytes(bytes(b, at))) / 65535.0
            }),
            (Component::I8, false) => self.gather(a, acc, |b: &[u8], at| {
                f32::from(i8::from_le_bytes(bytes(b, at)))
            }),
            (Component::U8, false) => {
                self.gather(a, acc, |b: &[u8], at| f32::from(bytes::<1>(b, at)[0]))
            }
            (Component::I16, false) => self.gather(a, acc, |b: &[u8], at| {
                f32::from(i16::from_le_bytes(bytes(b, at)))
            }),
            (Component::U16, false) => self.gather(a, acc, |b: &[u8], at| {
                f32::from(u16::from_le_bytes(bytes(b, at)))
            }),
            (Component::U32, _) => self.gather(a, acc, |b: &[u8], at| {
                u32::from_le_bytes(bytes(b, at)) as f32
            }),
        }
    }

    /// Decodes accessor `a` as unsigned integers; it must be `UNSIGNED_BYTE`,
    /// `UNSIGNED_SHORT` or (when `allow_u32`) `UNSIGNED_INT`, and not normalized.
    pub(super) fn uints<const N: usize>(
        &self,
        a: usize,
        what: &str,
        allow_u32: bool,
    ) -> Result<Vec<[u32; N]>, FormatError> {
        let acc = self.accessor::<N>(a, what)?;
        match (acc.component, acc.normalized) {
            (Component::U8, false) => {
                self.gather(a, acc, |b: &[u8], at| u32::from(bytes::<1>(b, at)[0]))
            }
            (Component::U16, false) => self.gather(a, acc, |b: &[u8], at| {
                u32::from(u16::from_le_bytes(bytes(b, at)))
            }),
            (Component::U32, false) if allow_u32 => {
                self.gather(a, acc, |b: &[u8], at| u32::from_le_bytes(bytes(b, at)))
            }
            (c, n) => Err(elem(
                "accessor",
                a,
                format!(
                    "{what} must be {} integers, found {}{}",
                    if allow_u32 {
                        "UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT"
                    } else {
                        "UNSIGNED_BYTE or UNSIGNED_SHORT"
                    },
                    if n { "normalized " } else { "" },
                    c.name()
                ),
            )),
        }
    }
}
