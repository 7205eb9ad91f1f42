//! Checked access to the glTF JSON tree: every getter names the element it reads in
//! its error.

use super::super::{FormatError, Location};
use serde_json::{Map, Value};

/// A JSON object.
pub(super) type Obj = Map<String, Value>;

/// An error at element `i` of kind `kind` (e.g. `("accessor", 3)`).
pub(super) fn elem(kind: &'static str, i: usize, message: impl Into<String>) -> FormatError {
    FormatError::new(Location::Element(kind, i as u64), message)
}

/// A short rendering of a JSON value for messages (containers are summarised, not
/// printed).
pub(super) fn show(v: &Value) -> String {
    match v {
        Value::Array(a) => format!("an array of {} items", a.len()),
        Value::Object(o) => format!("an object of {} members", o.len()),
        Value::String(s) if s.len() > 40 => {
            let cut = (0..=40).rev().find(|&i| s.is_char_boundary(i)).unwrap_or(0);
            format!("\"{}…\"", s.get(..cut).unwrap_or(""))
        }
        other => other.to_string(),
    }
}

/// The top-level array `key` (empty when absent).
///
/// # Errors
/// The member exists but is not an array.
pub(super) fn top_array<'a>(root: &'a Obj, key: &str) -> Result<&'a [Value], FormatError> {
    match root.get(key) {
        None => Ok(&[]),
        Some(Value::Array(a)) => Ok(a),
        Some(v) => Err(FormatError::new(
            Location::File,
            format!("\"{key}\" must be an array, found {}", show(v)),
        )),
    }
}

/// `v` as an object, or an error naming element `kind` `i`.
pub(super) fn object<'a>(
    v: &'a Value,
    kind: &'static str,
    i: usize,
) -> Result<&'a Obj, FormatError> {
    v.as_object()
        .ok_or_else(|| elem(kind, i, format!("must be a JSON object, found {}", show(v))))
}

/// Member `key` of `o` as a non-negative integer, `None` when absent.
pub(super) fn opt_uint(
    o: &Obj,
    key: &str,
    kind: &'static str,
    i: usize,
) -> Result<Option<u64>, FormatError> {
    match o.get(key) {
        None => Ok(None),
        Some(v) => v.as_u64().map(Some).ok_or_else(|| {
            elem(
                kind,
                i,
                format!(
                    "\"{key}\" must be a non-negative integer, found {}",
                    show(v)
                ),
            )
        }),
    }
}

/// Member `key` of `o` as a non-negative integer that fits `usize`.
pub(super) fn opt_usize(
    o: &Obj,
    key: &str,
    kind: &'static str,
    i: usize,
) -> Result<Option<usize>, FormatError> {
    match opt_uint(o, key, kind, i)? {
        None => Ok(None),
        Some(n) => usize::try_from(n)
            .map(Some)
            .map_err(|_| elem(kind, i, format!("\"{key}\" {n} is too large"))),
    }
}

/// Member `key` of `o` as a required non-negative integer.
pub(super) fn req_usize(
    o: &Obj,
    key: &str,
    kind: &'static str,
    i: usize,
) -> Result<usize, FormatError> {
    opt_usize(o, key, kind, i)?.ok_or_else(|| elem(kind, i, format!("missing \"{key}\"")))
}

/// Member `key` of `o` as an index into an array of `len` `target`s (plural noun).
pub(super) fn opt_ref(
    o: &Obj,
    key: &str,
    kind: &'static str,
    i: usize,
    len: usize,
    target: &str,
) -> Result<Option<usize>, FormatError> {
    match opt_usize(o, key, kind, i)? {
        Some(r) if r >= len => Err(elem(
            kind,
            i,
            format!("\"{key}\" is {r}, but there are only {len} {target}"),
        )),
        r => Ok(r),
    }
}

/// Checks that `value` is an index into an array of `len` `target`s.
pub(super) fn check_ref(
    value: &Value,
    what: &str,
    kind: &'static str,
    i: usize,
    len: usize,
    target: &str,
) -> Result<usize, FormatError> {
    let r = value
        .as_u64()
        .and_then(|r| usize::try_from(r).ok())
        .ok_or_else(|| {
            elem(
                kind,
                i,
                format!(
                    "{what} must be a non-negative integer, found {}",
                    show(value)
                ),
            )
        })?;
    if r >= len {
        return Err(elem(
            kind,
            i,
            format!("{what} is {r}, but there are only {len} {target}"),
        ));
    }
    Ok(r)
}

/// Member `key` of `o` as exactly `N` finite numbers, `None` when absent.
pub(super) fn opt_numbers<const N: usize>(
    o: &Obj,
    key: &str,
    kind: &'static str,
    i: usize,
) -> Result<Option<[f64; N]>, FormatError> {
    let Some(v) = o.get(key) else {
        return Ok(None);
    };
    let bad = || {
        elem(
            kind,
            i,
            format!(
                "\"{key}\" must be an array of {N} finite numbers, found {}",
                show(v)
            ),
        )
    };
    let a = v.as_array().ok_or_else(bad)?;
    if a.len() != N {
        return Err(bad());
    }
    let mut out = [0.0; N];
    for (o, x) in out.iter_mut().zip(a) {
        *o = x.as_f64().filter(|x| x.is_finite()).ok_or_else(bad)?;
    }
    Ok(Some(out))
}

/// Member `key` of `o` as a string, `None` when absent or not a string.
pub(super) fn opt_str<'a>(o: &'a Obj, key: &str) -> Option<&'a str> {
    o.get(key).and_then(Value::as_str)
}

/// Member `key` of `o` as a boolean (`false` when absent).
pub(super) fn opt_bool(
    o: &Obj,
    key: &str,
    kind: &'static str,
    i: usize,
) -> Result<bool, FormatError> {
    match o.get(key) {
        None => Ok(false),
        Some(Value::Bool(b)) => Ok(*b),
        Some(v) => Err(elem(
            kind,
            i,
            format!("\"{key}\" must be true or false, found {}", show(v)),
        )),
    }
}

/// An unsigned integer as a JSON number.
pub(super) fn num(n: usize) -> Value {
    Value::from(n as u64)
}
