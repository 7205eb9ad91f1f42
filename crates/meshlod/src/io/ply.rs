//! Stanford PLY ("Polygon File Format", Greg Turk 1994) reader and writer.
//!
//! The format follows Turk's description that ships with the original `ply.h` /
//! `plyfile.c` library, as summarised in Paul Bourke's "PLY - Polygon File Format":
//!
//! ```text
//! ply
//! format ascii 1.0 | binary_little_endian 1.0 | binary_big_endian 1.0
//! comment ...                  (anywhere in the header; also obj_info)
//! element NAME COUNT
//! property TYPE NAME
//! property list COUNT_TYPE ITEM_TYPE NAME
//! ...
//! end_header
//! <COUNT records of each element, in header order>
//! ```
//!
//! Types are `char uchar short ushort int uint float double` and their sized aliases
//! `int8 uint8 int16 uint16 int32 uint32 float32 float64`. Header lines may end in
//! CRLF. An ASCII body has one record per line; a binary body packs records without
//! padding in the declared byte order.
//!
//! What is read:
//! - element `vertex`: `x y z` (required), normals `nx ny nz` (or `normal_x ...`),
//!   colours `red green blue [alpha]` (or `diffuse_red ...`; integer types are scaled
//!   by the type's maximum, e.g. `uchar` by 255, float types are taken as they are),
//!   texture coordinates `u v`, `s t`, `texture_u texture_v` or `texture_s texture_t`
//!   (into `uv0`). Other vertex properties are skipped.
//! - element `face`: the list `vertex_indices` (or `vertex_index`) of any integer
//!   types; polygons are fan-triangulated. An integer `material_index` (or
//!   `material_id`, `material`) becomes the triangle groups.
//! - element `tristrips`: the list `vertex_indices`, where `-1` restarts a strip;
//!   strips become triangles with alternating winding, and the degenerate triangles
//!   strips use for stitching are dropped.
//! - Elements may come in any order; other elements are skipped (in binary files,
//!   list properties are walked so the records after them are found).
//!
//! Coordinates stored as `double` are rounded to `f32`. Bytes after the last record
//! of a binary file are ignored; non-blank lines after the last record of an ASCII
//! file are an error (they mean the header counts are wrong).
//!
//! The writer produces binary little-endian (or ASCII) files with `x y z` as `float`,
//! `nx ny nz` when the mesh has normals, `red green blue alpha` as `uchar`, `u v` for
//! `uv0`, faces as `list uchar int vertex_indices` (`uint` above 2³¹ vertices) and a
//! `uint material_index` when the mesh has groups. Tangents, `uv1`, skinning and group
//! names have no PLY property and are not written. ASCII numbers use the shortest
//! decimal that reads back to the same `f32`, so both encodings round-trip exactly
//! (colours exactly when they are multiples of 1/255).

use super::stream_base::{Sink, Source, StreamError};
use super::text::{self, Lines};
use super::{max_elements, FormatError, Location};
use crate::mesh::{Mesh, VertexAttributes};
use std::io::Write as _;

/// Reads a PLY file (ASCII, binary little-endian or binary big-endian) from memory.
///
/// # Errors
/// [`FormatError`] with the header line (`Location::Line`) for a malformed header, the
/// byte offset (`Location::Byte`) of the record for binary data that is truncated,
/// has a list longer than the file, a face with fewer than 3 vertices, an index out
/// of range or a non-finite number, and the line for the same problems in an ASCII
/// body. Element counts larger than the data after the header can hold are refused
/// before anything is allocated.
pub fn read(data: &[u8]) -> Result<Mesh, FormatError> {
    let (header, mut lines) = parse_header(data)?;
    let plan = Plan::new(&header)?;
    let mut out = Output::new(&plan);
    match header.encoding {
        Encoding::Ascii => read_ascii(&mut lines, &header, &plan, &mut out)?,
        Encoding::LittleEndian => read_binary::<false>(data, &header, &plan, &mut out)?,
        Encoding::BigEndian => read_binary::<true>(data, &header, &plan, &mut out)?,
    }
    Ok(out.finish())
}

/// Writes `mesh` as PLY: binary little-endian, or ASCII when `ascii` is true. See the
/// module documentation for the properties written.
///
/// # Errors
/// [`FormatError`] (at `Location::File`) when the mesh is invalid (an index out of
/// range, a non-finite coordinate, an attribute stream of the wrong length): such a
/// mesh would give a file no reader accepts.
pub fn write(mesh: &Mesh, ascii: bool, out: &mut Vec<u8>) -> Result<(), FormatError> {
    write_impl(mesh, None, ascii, out)
}

/// Writes `mesh` as PLY like [`write()`], with one more vertex property, `float quality`
/// (MeshLab's per-vertex scalar), holding `quality[i]` for vertex `i`. Used for error
/// heat maps.
///
/// # Errors
/// As [`write()`]; also when `quality` does not have one value per vertex.
pub fn write_with_quality(
    mesh: &Mesh,
    quality: &[f32],
    ascii: bool,
    out: &mut Vec<u8>,
) -> Result<(), FormatError> {
    if quality.len() != mesh.positions.len() {
        return Err(FormatError::new(
            Location::File,
            format!(
                "{} quality values for {} vertices",
                quality.len(),
                mesh.positions.len()
            ),
        ));
    }
    write_impl(mesh, Some(quality), ascii, out)
}

fn write_impl(
    mesh: &Mesh,
    quality: Option<&[f32]>,
    ascii: bool,
    out: &mut Vec<u8>,
) -> Result<(), FormatError> {
    mesh.validate().map_err(|e| {
        FormatError::new(Location::File, format!("cannot write an invalid mesh: {e}"))
    })?;
    let attrs = &mesh.attributes;
    let normals = attrs.normals.as_deref();
    let colors = attrs.colors.as_deref();
    let uv = attrs.uv0.as_deref();
    let groups = mesh.groups.as_deref();
    let n = mesh.positions.len();
    let wide = n > (i32::MAX as usize) + 1;

    let mut h = String::with_capacity(512);
    h.push_str("ply\n");
    h.push_str(if ascii {
        "format ascii 1.0\n"
    } else {
        "format binary_little_endian 1.0\n"
    });
    h.push_str("comment written by meshlod\n");
    h.push_str(&format!("element vertex {n}\n"));
    h.push_str("property float x\nproperty float y\nproperty float z\n");
    if normals.is_some() {
        h.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    if colors.is_some() {
        h.push_str(
            "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n",
        );
    }
    if uv.is_some() {
        h.push_str("property float u\nproperty float v\n");
    }
    if quality.is_some() {
        h.push_str("property float quality\n");
    }
    h.push_str(&format!("element face {}\n", mesh.triangles.len()));
    h.push_str(if wide {
        "property list uchar uint vertex_indices\n"
    } else {
        "property list uchar int vertex_indices\n"
    });
    if groups.is_some() {
        h.push_str("property uint material_index\n");
    }
    h.push_str("end_header\n");

    let vertex_bytes = 12
        + if normals.is_some() { 12 } else { 0 }
        + if colors.is_some() { 4 } else { 0 }
        + if uv.is_some() { 8 } else { 0 }
        + if quality.is_some() { 4 } else { 0 };
    let face_bytes = 13 + if groups.is_some() { 4 } else { 0 };
    let estimate = if ascii {
        n * vertex_bytes * 3 + mesh.triangles.len() * 30
    } else {
        n * vertex_bytes + mesh.triangles.len() * face_bytes
    };
    out.reserve(h.len() + estimate);
    out.extend_from_slice(h.as_bytes());

    let color_byte = |c: f32| (c.clamp(0.0, 1.0) * 255.0).round() as u8;
    for (i, p) in mesh.positions.iter().enumerate() {
        let nrm = normals.and_then(|s| s.get(i));
        let col = colors.and_then(|s| s.get(i));
        let tex = uv.and_then(|s| s.get(i));
        let q = quality.and_then(|s| s.get(i));
        if ascii {
            let mut first = true;
            let mut num = |out: &mut Vec<u8>, v: f32| {
                if !first {
                    out.push(b' ');
                }
                first = false;
                push_f32(out, v);
            };
            p.iter().for_each(|&v| num(out, v));
            if let Some(nrm) = nrm {
                nrm.iter().for_each(|&v| num(out, v));
            }
            if let Some(col) = col {
                for &c in col {
                    // Infallible: writing to a Vec cannot fail.
                    let _ = write!(out, " {}", color_byte(c));
                }
            }
            if let Some(tex) = tex {
                tex.iter().for_each(|&v| num(out, v));
            }
            if let Some(&q) = q {
                num(out, q);
            }
            out.push(b'\n');
        } else {
            p.iter()
                .for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
            if let Some(nrm) = nrm {
                nrm.iter()
                    .for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
            }
            if let Some(col) = col {
                col.iter().for_each(|&c| out.push(color_byte(c)));
            }
            if let Some(tex) = tex {
                tex.iter()
                    .for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
            }
            if let Some(q) = q {
                out.extend_from_slice(&q.to_le_bytes());
            }
        }
    }
    for (i, t) in mesh.triangles.iter().enumerate() {
        let group = groups.and_then(|g| g.get(i)).copied();
        if ascii {
            // Infallible: writing to a Vec cannot fail.
            let _ = write!(out, "3 {} {} {}", t[0], t[1], t[2]);
            if let Some(g) = group {
                let _ = write!(out, " {g}");
            }
            out.push(b'\n');
        } else {
            out.push(3);
            t.iter()
                .for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
            if let Some(g) = group {
                out.extend_from_slice(&g.to_le_bytes());
            }
        }
    }
    Ok(())
}

/// Appends `v` as the shortest decimal that parses back to the same `f32` (plain
/// notation for moderate magnitudes, exponent notation otherwise). Shared with the
/// STL writer.
pub(crate) fn push_f32(out: &mut Vec<u8>, v: f32) {
    let a = v.abs();
    // Infallible: writing to a Vec cannot fail. Both `{}` and `{:e}` print the
    // shortest digits that round-trip.
    let _ = if a == 0.0 || (1e-5..1e16).contains(&a) {
        write!(out, "{v}")
    } else {
        write!(out, "{v:e}")
    };
}

// ---------------------------------------------------------------------------------
// Header
// ---------------------------------------------------------------------------------

/// How the body is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Encoding {
    Ascii,
    LittleEndian,
    BigEndian,
}

/// A PLY scalar type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &[u8]) -> Option<Self> {
        Some(match name {
            b"char" | b"int8" => Self::I8,
            b"uchar" | b"uint8" => Self::U8,
            b"short" | b"int16" => Self::I16,
            b"ushort" | b"uint16" => Self::U16,
            b"int" | b"int32" => Self::I32,
            b"uint" | b"uint32" => Self::U32,
            b"float" | b"float32" => Self::F32,
            b"double" | b"float64" => Self::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }

    fn is_float(self) -> bool {
        matches!(self, Self::F32 | Self::F64)
    }

    /// Largest value of an integer type (what a full-intensity colour is stored as).
    fn max(self) -> f64 {
        match self {
            Self::I8 => 127.0,
            Self::U8 => 255.0,
            Self::I16 => 32767.0,
            Self::U16 => 65535.0,
            Self::I32 => 2_147_483_647.0,
            Self::U32 => 4_294_967_295.0,
            Self::F32 | Self::F64 => 1.0,
        }
    }
}

/// A property's shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Debug, Clone)]
struct Property {
    name: Vec<u8>,
    kind: Kind,
    line: u64,
}

#[derive(Debug, Clone)]
struct Element {
    name: Vec<u8>,
    count: usize,
    props: Vec<Property>,
    line: u64,
}

impl Element {
    /// Bytes per record when no property is a list.
    fn fixed_size(&self) -> Option<usize> {
        self.props.iter().try_fold(0, |acc, p| match p.kind {
            Kind::Scalar(s) => Some(acc + s.size()),
            Kind::List { .. } => None,
        })
    }

    /// Fewest bytes a binary record can take (lists empty).
    fn min_binary_size(&self) -> usize {
        self.props
            .iter()
            .map(|p| match p.kind {
                Kind::Scalar(s) | Kind::List { count: s, .. } => s.size(),
            })
            .sum()
    }

    /// Index of the first property named `name`.
    fn find(&self, name: &str) -> Option<usize> {
        self.props.iter().position(|p| p.name == name.as_bytes())
    }

    /// Index of the scalar property named `name`.
    fn find_scalar(&self, name: &str) -> Option<usize> {
        self.find(name)
            .filter(|&i| matches!(self.props.get(i).map(|p| p.kind), Some(Kind::Scalar(_))))
    }

    fn display_name(&self) -> String {
        text::show(&self.name)
    }
}

#[derive(Debug)]
struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    body_start: usize,
}

fn header_error(line: u64, message: impl Into<String>) -> FormatError {
    FormatError::new(Location::Line(line), message)
}

/// Parses the header; returns it and the line iterator positioned at the body.
fn parse_header(data: &[u8]) -> Result<(Header, Lines<'_>), FormatError> {
    parse_header_sized(data, data.len())
}

/// [`parse_header`] where `data` may hold only the start of a file of `file_len`
/// bytes (element counts are checked against the file's length).
fn parse_header_sized(data: &[u8], file_len: usize) -> Result<(Header, Lines<'_>), FormatError> {
    if data.is_empty() {
        return Err(FormatError::new(Location::File, "empty file"));
    }
    let mut lines = Lines::new(data);
    let first = lines.next().unwrap_or_default();
    if !text::tokens(first).eq([&b"ply"[..]]) {
        return Err(header_error(
            1,
            "not a PLY file: the first line must be 'ply'",
        ));
    }
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some(line) = lines.next() else {
            return Err(header_error(
                lines.line_number(),
                "the header has no 'end_header' line",
            ));
        };
        let n = lines.line_number();
        let mut t = text::tokens(line);
        let Some(keyword) = t.next() else { continue };
        match keyword {
            b"comment" | b"obj_info" => {}
            b"format" => {
                if encoding.is_some() {
                    return Err(header_error(n, "a second 'format' line"));
                }
                encoding = Some(parse_format(t, n)?);
            }
            b"element" => {
                let element = parse_element(t, n, &elements)?;
                elements.push(element);
            }
            b"property" => {
                let Some(element) = elements.last_mut() else {
                    return Err(header_error(n, "'property' before any 'element'"));
                };
                parse_property(t, n, element)?;
            }
            b"end_header" => break,
            other => {
                return Err(header_error(
                    n,
                    format!(
                        "unknown header keyword '{}' (expected comment, obj_info, format, element, property or end_header)",
                        text::show(other)
                    ),
                ))
            }
        }
    }
    let end_line = lines.line_number();
    let encoding =
        encoding.ok_or_else(|| header_error(end_line, "the header has no 'format' line"))?;
    let body_start = lines.offset();
    check_counts(&elements, encoding, file_len.saturating_sub(body_start))?;
    Ok((
        Header {
            encoding,
            elements,
            body_start,
        },
        lines,
    ))
}

/// The rest of a `format` line (line `n`): the encoding, with version 1.0.
fn parse_format<'a>(
    mut t: impl Iterator<Item = &'a [u8]>,
    n: u64,
) -> Result<Encoding, FormatError> {
    let (Some(f), Some(version), None) = (t.next(), t.next(), t.next()) else {
        return Err(header_error(
            n,
            "expected 'format ascii|binary_little_endian|binary_big_endian 1.0'",
        ));
    };
    let encoding = match f {
        b"ascii" => Encoding::Ascii,
        b"binary_little_endian" => Encoding::LittleEndian,
        b"binary_big_endian" => Encoding::BigEndian,
        _ => {
            return Err(header_error(
                n,
                format!(
                    "unknown PLY format '{}' (expected ascii, binary_little_endian or binary_big_endian)",
                    text::show(f)
                ),
            ))
        }
    };
    if version != b"1.0" && version != b"1" {
        return Err(header_error(
            n,
            format!(
                "unsupported PLY version '{}' (only 1.0 exists)",
                text::show(version)
            ),
        ));
    }
    Ok(encoding)
}

/// The rest of an `element` line (line `n`): a new element, named unlike the
/// `elements` before it.
fn parse_element<'a>(
    mut t: impl Iterator<Item = &'a [u8]>,
    n: u64,
    elements: &[Element],
) -> Result<Element, FormatError> {
    let (Some(name), Some(count), None) = (t.next(), t.next(), t.next()) else {
        return Err(header_error(n, "expected 'element NAME COUNT'"));
    };
    // Capped after the header, when the size of a record is known.
    let count = text::parse_count(count, n, "the element count", usize::MAX as u64)?;
    if elements.iter().any(|e| e.name == name) {
        return Err(header_error(
            n,
            format!("a second element named '{}'", text::show(name)),
        ));
    }
    Ok(Element {
        name: name.to_vec(),
        count,
        props: Vec::new(),
        line: n,
    })
}

/// The rest of a `property` line (line `n`), added to `element`: a scalar or a
/// list (with an integer length type), named unlike the element's others.
fn parse_property<'a>(
    mut t: impl Iterator<Item = &'a [u8]>,
    n: u64,
    element: &mut Element,
) -> Result<(), FormatError> {
    let ty = |name: &[u8]| {
        Scalar::parse(name).ok_or_else(|| {
            header_error(
                n,
                format!(
                    "unknown property type '{}' (expected char, uchar, short, ushort, int, uint, float, double or int8 ... float64)",
                    text::show(name)
                ),
            )
        })
    };
    let (kind, name) = match (t.next(), t.next(), t.next(), t.next(), t.next()) {
        (Some(b"list"), Some(count), Some(item), Some(name), None) => {
            let count = ty(count)?;
            if count.is_float() {
                return Err(header_error(
                    n,
                    "the length type of a list property must be an integer type",
                ));
            }
            (
                Kind::List {
                    count,
                    item: ty(item)?,
                },
                name,
            )
        }
        (Some(b"list"), ..) => {
            return Err(header_error(
                n,
                "expected 'property list LENGTH_TYPE ITEM_TYPE NAME'",
            ))
        }
        (Some(scalar), Some(name), None, None, None) => (Kind::Scalar(ty(scalar)?), name),
        _ => {
            return Err(header_error(
                n,
                "expected 'property TYPE NAME' or 'property list LENGTH_TYPE ITEM_TYPE NAME'",
            ))
        }
    };
    if element.props.iter().any(|p| p.name == name) {
        return Err(header_error(
            n,
            format!(
                "element '{}' has a second property named '{}'",
                element.display_name(),
                text::show(name)
            ),
        ));
    }
    element.props.push(Property {
        name: name.to_vec(),
        kind,
        line: n,
    });
    Ok(())
}

/// Refuses an element count larger than the `body_len` bytes after the header can
/// hold in `encoding`.
fn check_counts(
    elements: &[Element],
    encoding: Encoding,
    body_len: usize,
) -> Result<(), FormatError> {
    for e in elements {
        if e.props.is_empty() {
            // Records without properties take no room and are never stored.
            continue;
        }
        // ASCII: every value is at least one character plus a separator (the last
        // line may lack its newline, hence the extra byte).
        let cap = match encoding {
            Encoding::Ascii => max_elements(body_len + 1, 2 * e.props.len()),
            _ => max_elements(body_len, e.min_binary_size()),
        };
        if e.count as u64 > cap {
            return Err(header_error(
                e.line,
                format!(
                    "element '{}' has count {}, more than the {body_len} bytes after the header can hold (at most {cap})",
                    e.display_name(),
                    e.count
                ),
            ));
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------------
// What each property means
// ---------------------------------------------------------------------------------

/// What a property is read into.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    Skip,
    Pos(usize),
    Normal(usize),
    Color(usize),
    Uv(usize),
    Indices,
    Group,
}

/// Which element is which.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ElementKind {
    Vertex,
    Face,
    Strips,
    Other,
}

/// Per element its kind and per property its role, decided once from the header.
#[derive(Debug)]
struct Plan {
    kinds: Vec<ElementKind>,
    roles: Vec<Vec<Role>>,
    vertex_count: usize,
    normals: bool,
    colors: bool,
    uv: bool,
    groups: bool,
}

const NORMAL_NAMES: [[&str; 3]; 2] = [["nx", "ny", "nz"], ["normal_x", "normal_y", "normal_z"]];
const COLOR_NAMES: [[&str; 4]; 2] = [
    ["red", "green", "blue", "alpha"],
    [
        "diffuse_red",
        "diffuse_green",
        "diffuse_blue",
        "diffuse_alpha",
    ],
];
const UV_NAMES: [[&str; 2]; 4] = [
    ["u", "v"],
    ["s", "t"],
    ["texture_u", "texture_v"],
    ["texture_s", "texture_t"],
];
const INDEX_NAMES: [&str; 2] = ["vertex_indices", "vertex_index"];
const GROUP_NAMES: [&str; 3] = ["material_index", "material_id", "material"];

impl Plan {
    fn new(h: &Header) -> Result<Self, FormatError> {
        let mut plan = Self {
            kinds: Vec::with_capacity(h.elements.len()),
            roles: Vec::with_capacity(h.elements.len()),
            vertex_count: 0,
            normals: false,
            colors: false,
            uv: false,
            groups: false,
        };
        for e in &h.elements {
            let mut roles = vec![Role::Skip; e.props.len()];
            let mut set = |i: usize, r: Role| {
                if let Some(slot) = roles.get_mut(i) {
                    *slot = r;
                }
            };
            let kind = match e.name.as_slice() {
                b"vertex" => {
                    plan.vertex_count = e.count;
                    for (k, name) in ["x", "y", "z"].into_iter().enumerate() {
                        let i = e.find(name).ok_or_else(|| {
                            header_error(
                                e.line,
                                format!("the vertex element has no '{name}' property"),
                            )
                        })?;
                        if let Some(p) = e
                            .props
                            .get(i)
                            .filter(|p| matches!(p.kind, Kind::List { .. }))
                        {
                            return Err(header_error(
                                p.line,
                                format!("vertex property '{name}' is a list; it must be a number"),
                            ));
                        }
                        set(i, Role::Pos(k));
                    }
                    if let Some(ids) = first_complete(e, &NORMAL_NAMES) {
                        plan.normals = true;
                        ids.iter()
                            .enumerate()
                            .for_each(|(k, &i)| set(i, Role::Normal(k)));
                    }
                    let rgb = COLOR_NAMES.map(|s| [s[0], s[1], s[2]]);
                    if let Some((which, ids)) = first_complete_with_set(e, &rgb) {
                        plan.colors = true;
                        ids.iter()
                            .enumerate()
                            .for_each(|(k, &i)| set(i, Role::Color(k)));
                        if let Some(a) = COLOR_NAMES.get(which).and_then(|s| e.find_scalar(s[3])) {
                            set(a, Role::Color(3));
                        }
                    }
                    if let Some(ids) = first_complete(e, &UV_NAMES) {
                        plan.uv = true;
                        ids.iter()
                            .enumerate()
                            .for_each(|(k, &i)| set(i, Role::Uv(k)));
                    }
                    ElementKind::Vertex
                }
                b"face" | b"tristrips" => {
                    let strips = e.name == b"tristrips";
                    let i = INDEX_NAMES.iter().find_map(|n| e.find(n)).ok_or_else(|| {
                        header_error(
                            e.line,
                            format!(
                                "the {} element has no 'vertex_indices' list",
                                e.display_name()
                            ),
                        )
                    })?;
                    if let Some(p) = e.props.get(i) {
                        match p.kind {
                            Kind::List { item, .. } if !item.is_float() => {}
                            Kind::List { .. } => {
                                return Err(header_error(
                                    p.line,
                                    format!(
                                        "'{}' must hold an integer type, not a float type",
                                        text::show(&p.name)
                                    ),
                                ))
                            }
                            Kind::Scalar(_) => {
                                return Err(header_error(
                                    p.line,
                                    format!("'{}' must be a list property", text::show(&p.name)),
                                ))
                            }
                        }
                    }
                    set(i, Role::Indices);
                    if !strips {
                        let group = GROUP_NAMES.iter().find_map(|n| {
                            e.find_scalar(n).filter(|&g| {
                                matches!(
                                    e.props.get(g).map(|p| p.kind),
                                    Some(Kind::Scalar(s)) if !s.is_float()
                                )
                            })
                        });
                        if let Some(g) = group {
                            plan.groups = true;
                            set(g, Role::Group);
                        }
                    }
                    if strips {
                        ElementKind::Strips
                    } else {
                        ElementKind::Face
                    }
                }
                _ => ElementKind::Other,
            };
            plan.kinds.push(kind);
            plan.roles.push(roles);
        }
        let has_faces = plan
            .kinds
            .iter()
            .zip(&h.elements)
            .any(|(k, e)| matches!(k, ElementKind::Face | ElementKind::Strips) && e.count > 0);
        if has_faces && !plan.kinds.contains(&ElementKind::Vertex) {
            return Err(header_error(
                h.elements.first().map_or(1, |e| e.line),
                "the file has faces but no vertex element",
            ));
        }
        Ok(plan)
    }
}

/// The property indices of the first name set whose members are all scalars.
fn first_complete<const N: usize>(e: &Element, sets: &[[&str; N]]) -> Option<[usize; N]> {
    first_complete_with_set(e, sets).map(|(_, ids)| ids)
}

fn first_complete_with_set<const N: usize>(
    e: &Element,
    sets: &[[&str; N]],
) -> Option<(usize, [usize; N])> {
    sets.iter().enumerate().find_map(|(which, names)| {
        let mut ids = [0; N];
        for (slot, name) in ids.iter_mut().zip(names) {
            *slot = e.find_scalar(name)?;
        }
        Some((which, ids))
    })
}

// ---------------------------------------------------------------------------------
// Output
// ---------------------------------------------------------------------------------

struct Output {
    positions: Vec<[f32; 3]>,
    normals: Option<Vec<[f32; 3]>>,
    colors: Option<Vec<[f32; 4]>>,
    uv: Option<Vec<[f32; 2]>>,
    triangles: Vec<[u32; 3]>,
    groups: Option<Vec<u32>>,
}

impl Output {
    fn new(plan: &Plan) -> Self {
        let n = plan.vertex_count;
        Self {
            positions: vec![[0.0; 3]; n],
            normals: plan.normals.then(|| vec![[0.0; 3]; n]),
            colors: plan.colors.then(|| vec![[0.0, 0.0, 0.0, 1.0]; n]),
            uv: plan.uv.then(|| vec![[0.0; 2]; n]),
            triangles: Vec::new(),
            groups: plan.groups.then(Vec::new),
        }
    }

    /// Stores value `v` (read as type `ty`) of vertex `i` into the stream `role`
    /// names. False when the value is not finite.
    #[inline]
    fn store(&mut self, i: usize, role: Role, ty: Scalar, v: f64) -> bool {
        let f = v as f32;
        match role {
            Role::Pos(k) => put(&mut self.positions, i, k, f),
            Role::Normal(k) => opt_put(&mut self.normals, i, k, f),
            Role::Uv(k) => opt_put(&mut self.uv, i, k, f),
            Role::Color(k) => {
                let c = if ty.is_float() {
                    f
                } else if ty == Scalar::U8 {
                    // In f32, so k/255 is the same number a writer computes.
                    f / 255.0
                } else {
                    (v / ty.max()).clamp(0.0, 1.0) as f32
                };
                opt_put(&mut self.colors, i, k, c.clamp(0.0, 1.0));
            }
            Role::Skip | Role::Indices | Role::Group => {}
        }
        f.is_finite()
    }

    /// Makes the group stream (if any) as long as the triangles, group 0 for
    /// triangles of elements without groups.
    fn pad_groups(&mut self) {
        if let Some(g) = &mut self.groups {
            g.resize(self.triangles.len(), 0);
        }
    }

    fn finish(mut self) -> Mesh {
        self.pad_groups();
        Mesh {
            positions: self.positions,
            triangles: self.triangles,
            attributes: VertexAttributes {
                normals: self.normals,
                uv0: self.uv,
                colors: self.colors,
                ..VertexAttributes::default()
            },
            groups: self.groups,
            group_names: Vec::new(),
        }
    }
}

#[inline]
fn put<const N: usize>(v: &mut [[f32; N]], i: usize, k: usize, f: f32) {
    if let Some(slot) = v.get_mut(i).and_then(|a| a.get_mut(k)) {
        *slot = f;
    }
}

#[inline]
fn opt_put<const N: usize>(v: &mut Option<Vec<[f32; N]>>, i: usize, k: usize, f: f32) {
    if let Some(v) = v {
        put(v, i, k, f);
    }
}

/// Turns triangle strips into triangles: the k-th triangle of a strip is
/// `(s[k], s[k+1], s[k+2])` for even k and `(s[k+1], s[k], s[k+2])` for odd k, so
/// all face the same way. Degenerate (stitching) triangles are dropped.
#[derive(Default)]
struct Strip {
    a: Option<u32>,
    b: Option<u32>,
    odd: bool,
}

impl Strip {
    fn restart(&mut self) {
        *self = Self::default();
    }

    fn push(&mut self, v: u32, out: &mut Vec<[u32; 3]>) {
        match (self.a, self.b) {
            (Some(a), Some(b)) => {
                if a != b && b != v && a != v {
                    out.push(if self.odd { [b, a, v] } else { [a, b, v] });
                }
                self.odd = !self.odd;
                self.a = Some(b);
                self.b = Some(v);
            }
            (Some(_), None) => self.b = Some(v),
            (None, _) => self.a = Some(v),
        }
    }
}

/// Fan-triangulates a polygon one index at a time: `(v0, v[k-1], v[k])`.
#[derive(Default)]
struct Fan {
    first: u32,
    prev: u32,
    seen: usize,
}

impl Fan {
    #[inline]
    fn push(&mut self, v: u32, out: &mut Vec<[u32; 3]>) {
        match self.seen {
            0 => self.first = v,
            1 => {}
            _ => out.push([self.first, self.prev, v]),
        }
        self.prev = v;
        self.seen += 1;
    }
}

fn bad_index(face: usize, value: i64, vertices: usize, location: Location) -> FormatError {
    FormatError::new(
        location,
        format!("face {face} refers to vertex {value}, but the file has {vertices} vertices"),
    )
}

fn too_few(face: usize, n: usize, location: Location) -> FormatError {
    FormatError::new(
        location,
        format!("face {face} has {n} vertices; a face needs at least 3"),
    )
}

fn non_finite(e: &Element, i: usize, prop: usize, v: f64, location: Location) -> FormatError {
    let name = e
        .props
        .get(prop)
        .map_or(String::new(), |p| text::show(&p.name));
    FormatError::new(
        location,
        format!("{} {i} has a non-finite {name} ({v})", e.display_name()),
    )
}

/// Checks a vertex index read as `v`; `None` when out of range.
#[inline]
fn check_index(v: f64, vertices: usize) -> Option<u32> {
    (v >= 0.0 && v < vertices as f64 && v <= f64::from(u32::MAX)).then_some(v as u32)
}

// ---------------------------------------------------------------------------------
// Streaming (binary only)
// ---------------------------------------------------------------------------------

/// Streams a binary PLY file (see [`super::stream`]): vertex positions are kept,
/// faces and triangle strips are passed on one triangle at a time, with the same
/// triangulation, group ids and errors as [`read`]. The vertex element must come
/// before the faces.
pub(crate) fn stream<R: std::io::Read>(
    src: &mut Source<R>,
    file_len: u64,
    sink: &mut Sink<'_>,
) -> Result<(), StreamError> {
    // The header: lines up to `end_header`, at most 1 MiB.
    let mut head = Vec::new();
    let mut line = Vec::new();
    loop {
        if !src.line(&mut line)? {
            break;
        }
        head.extend_from_slice(&line);
        head.push(b'\n');
        if text::tokens(&line).next() == Some(&b"end_header"[..]) {
            break;
        }
        if head.len() > 1 << 20 {
            return Err(FormatError::new(
                Location::File,
                "the header is longer than 1 MiB without 'end_header'",
            )
            .into());
        }
    }
    if head.is_empty() {
        return Err(FormatError::new(Location::File, "empty file").into());
    }
    let len = usize::try_from(file_len).unwrap_or(usize::MAX);
    let (header, _) = parse_header_sized(&head, len)?;
    let plan = Plan::new(&header)?;
    match header.encoding {
        Encoding::Ascii => Err(FormatError::new(
            Location::File,
            "ASCII PLY cannot be streamed (convert it to binary, or read it into memory)",
        )
        .into()),
        Encoding::LittleEndian => stream_body::<false, R>(src, &header, &plan, sink),
        Encoding::BigEndian => stream_body::<true, R>(src, &header, &plan, sink),
    }
}

/// Reads `n` bytes at the source's cursor (without consuming them).
fn need<R: std::io::Read>(
    src: &mut Source<R>,
    n: usize,
    e: &Element,
    i: usize,
) -> Result<(), StreamError> {
    if src.ensure(n)? {
        Ok(())
    } else {
        Err(FormatError::new(
            Location::Byte(src.offset()),
            format!(
                "the file ends inside {} {i} of {}",
                e.display_name(),
                e.count
            ),
        )
        .into())
    }
}

fn stream_body<const BE: bool, R: std::io::Read>(
    src: &mut Source<R>,
    h: &Header,
    plan: &Plan,
    sink: &mut Sink<'_>,
) -> Result<(), StreamError> {
    let mut positions: Vec<[f32; 3]> = Vec::new();
    let mut have_vertices = false;
    let mut tris: Vec<[u32; 3]> = Vec::new();
    for ((e, kind), roles) in h.elements.iter().zip(&plan.kinds).zip(&plan.roles) {
        if e.props.is_empty() || e.count == 0 {
            continue;
        }
        let is_face = matches!(kind, ElementKind::Face | ElementKind::Strips);
        if is_face && !have_vertices && plan.vertex_count > 0 {
            return Err(FormatError::new(
                Location::Byte(src.offset()),
                format!(
                    "element '{}' comes before the vertices: such a file cannot be streamed",
                    e.display_name()
                ),
            )
            .into());
        }
        let strips = *kind == ElementKind::Strips;
        if *kind == ElementKind::Vertex {
            positions.reserve(e.count.min(1 << 24));
        }
        let mut strip = Strip::default();
        for i in 0..e.count {
            let record = src.offset();
            let mut p = [0f32; 3];
            let mut group = 0u32;
            tris.clear();
            for (pi, (prop, &role)) in e.props.iter().zip(roles).enumerate() {
                match prop.kind {
                    Kind::Scalar(ty) => {
                        need(src, ty.size(), e, i)?;
                        let v = scalar::<BE>(src.bytes(), 0, ty).unwrap_or(f64::NAN);
                        match role {
                            Role::Pos(k) => {
                                let f = v as f32;
                                if !f.is_finite() {
                                    return Err(
                                        non_finite(e, i, pi, v, Location::Byte(record)).into()
                                    );
                                }
                                if let Some(slot) = p.get_mut(k) {
                                    *slot = f;
                                }
                            }
                            Role::Group => {
                                group = group_id(v, i, Location::Byte(src.offset()))?;
                            }
                            _ => {}
                        }
                        src.consume(ty.size());
                    }
                    Kind::List { count, item } => {
                        need(src, count.size(), e, i)?;
                        let c = scalar::<BE>(src.bytes(), 0, count).unwrap_or(-1.0);
                        if c < 0.0 {
                            return Err(FormatError::new(
                                Location::Byte(src.offset()),
                                format!(
                                    "{} {i} has a list of negative length {c}",
                                    e.display_name()
                                ),
                            )
                            .into());
                        }
                        src.consume(count.size());
                        let n = c as usize;
                        let indices = role == Role::Indices && is_face;
                        if indices && !strips && n < 3 {
                            return Err(too_few(i, n, Location::Byte(record)).into());
                        }
                        need(src, n * item.size(), e, i)?;
                        if indices {
                            strip.restart();
                            let mut fan = Fan::default();
                            let vertices = positions.len();
                            for k in 0..n {
                                let v = scalar::<BE>(src.bytes(), k * item.size(), item)
                                    .unwrap_or(f64::NAN);
                                if strips && v == -1.0 {
                                    strip.restart();
                                    continue;
                                }
                                let Some(v) = check_index(v, vertices) else {
                                    let what = if strips { "tristrip" } else { "face" };
                                    return Err(FormatError::new(
                                        Location::Byte(record),
                                        format!(
                                            "{what} {i} refers to vertex {v}, but the file has {vertices} vertices"
                                        ),
                                    )
                                    .into());
                                };
                                if strips {
                                    strip.push(v, &mut tris);
                                } else {
                                    fan.push(v, &mut tris);
                                }
                            }
                        }
                        src.consume(n * item.size());
                    }
                }
            }
            match kind {
                ElementKind::Vertex => {
                    sink.vertex(p);
                    positions.push(p);
                }
                ElementKind::Face | ElementKind::Strips => {
                    for t in &tris {
                        let c = t.map(|v| positions[v as usize]);
                        sink.triangle(&c, group);
                    }
                }
                ElementKind::Other => {}
            }
        }
        if *kind == ElementKind::Vertex {
            have_vertices = true;
        }
    }
    sink.summary.vertices_held = positions.len() as u64;
    Ok(())
}

// ---------------------------------------------------------------------------------
// Binary body
// ---------------------------------------------------------------------------------

/// Reads a fixed-size array at `pos`.
#[inline(always)]
fn array<const N: usize>(data: &[u8], pos: usize) -> Option<[u8; N]> {
    data.get(pos..pos.checked_add(N)?)?.try_into().ok()
}

/// Reads one scalar of type `ty` at `pos` as f64 (exact for every PLY type).
#[inline(always)]
fn scalar<const BE: bool>(data: &[u8], pos: usize, ty: Scalar) -> Option<f64> {
    macro_rules! rd {
        ($t:ty) => {{
            let b = array::<{ std::mem::size_of::<$t>() }>(data, pos)?;
            if BE {
                <$t>::from_be_bytes(b)
            } else {
                <$t>::from_le_bytes(b)
            }
        }};
    }
    Some(match ty {
        Scalar::I8 => f64::from(rd!(i8)),
        Scalar::U8 => f64::from(rd!(u8)),
        Scalar::I16 => f64::from(rd!(i16)),
        Scalar::U16 => f64::from(rd!(u16)),
        Scalar::I32 => f64::from(rd!(i32)),
        Scalar::U32 => f64::from(rd!(u32)),
        Scalar::F32 => f64::from(rd!(f32)),
        Scalar::F64 => rd!(f64),
    })
}

#[inline(always)]
fn f32_at<const BE: bool>(rec: &[u8], off: usize) -> f32 {
    match array::<4>(rec, off) {
        Some(b) if BE => f32::from_be_bytes(b),
        Some(b) => f32::from_le_bytes(b),
        None => f32::NAN,
    }
}

#[inline(always)]
fn u32_of<const BE: bool>(b: [u8; 4]) -> u32 {
    if BE {
        u32::from_be_bytes(b)
    } else {
        u32::from_le_bytes(b)
    }
}

fn truncated(e: &Element, i: usize, at: usize, len: usize) -> FormatError {
    FormatError::new(
        Location::Byte(at as u64),
        format!(
            "the file ends inside {} {i} of {} (it has {len} bytes)",
            e.display_name(),
            e.count
        ),
    )
}

/// Reads a list length at `pos`; returns the length and where the items start.
fn list_header<const BE: bool>(
    data: &[u8],
    pos: usize,
    (count, item): (Scalar, Scalar),
    e: &Element,
    i: usize,
    record: usize,
) -> Result<(usize, usize), FormatError> {
    let c = scalar::<BE>(data, pos, count).ok_or_else(|| truncated(e, i, record, data.len()))?;
    if c < 0.0 {
        return Err(FormatError::new(
            Location::Byte(pos as u64),
            format!("{} {i} has a list of negative length {c}", e.display_name()),
        ));
    }
    let items = pos + count.size();
    let left = data.len().saturating_sub(items);
    // c is an integer of at most 32 bits, so this is exact.
    let n = c as u64;
    if n > (left / item.size()) as u64 {
        return Err(FormatError::new(
            Location::Byte(pos as u64),
            format!(
                "{} {i} has a list of {n} items ({} bytes), but only {left} bytes remain",
                e.display_name(),
                n * item.size() as u64
            ),
        ));
    }
    Ok((n as usize, items))
}

fn read_binary<const BE: bool>(
    data: &[u8],
    h: &Header,
    plan: &Plan,
    out: &mut Output,
) -> Result<(), FormatError> {
    let mut pos = h.body_start;
    for ((e, kind), roles) in h.elements.iter().zip(&plan.kinds).zip(&plan.roles) {
        if e.props.is_empty() || e.count == 0 {
            continue;
        }
        pos = match kind {
            ElementKind::Vertex => vertices_binary::<BE>(data, pos, e, roles, out)?,
            ElementKind::Face | ElementKind::Strips => {
                faces_binary::<BE>(data, pos, e, roles, *kind, plan.vertex_count, out)?
            }
            ElementKind::Other => skip_binary::<BE>(data, pos, e)?,
        };
        out.pad_groups();
    }
    Ok(())
}

fn skip_binary<const BE: bool>(
    data: &[u8],
    start: usize,
    e: &Element,
) -> Result<usize, FormatError> {
    if let Some(stride) = e.fixed_size() {
        let end = e
            .count
            .checked_mul(stride)
            .and_then(|b| b.checked_add(start))
            .filter(|&end| end <= data.len());
        return end.ok_or_else(|| {
            let k = data.len().saturating_sub(start) / stride.max(1);
            truncated(e, k, start + k * stride, data.len())
        });
    }
    let mut pos = start;
    for i in 0..e.count {
        pos = skip_record::<BE>(data, pos, e, i)?;
    }
    Ok(pos)
}

/// Skips one record with lists; returns where the next starts.
fn skip_record<const BE: bool>(
    data: &[u8],
    start: usize,
    e: &Element,
    i: usize,
) -> Result<usize, FormatError> {
    let mut pos = start;
    for p in &e.props {
        pos = match p.kind {
            Kind::Scalar(s) => pos + s.size(),
            Kind::List { count, item } => {
                if pos > data.len() {
                    break;
                }
                let (n, items) = list_header::<BE>(data, pos, (count, item), e, i, start)?;
                items + n * item.size()
            }
        };
    }
    if pos > data.len() {
        return Err(truncated(e, i, start, data.len()));
    }
    Ok(pos)
}

fn vertices_binary<const BE: bool>(
    data: &[u8],
    start: usize,
    e: &Element,
    roles: &[Role],
    out: &mut Output,
) -> Result<usize, FormatError> {
    let Some(stride) = e.fixed_size() else {
        return vertices_binary_general::<BE>(data, start, e, roles, out);
    };
    // Fixed layout: every field at a known offset of every record.
    let mut fields = Vec::new();
    let mut offset = 0;
    for (pi, (p, &role)) in e.props.iter().zip(roles).enumerate() {
        if let Kind::Scalar(ty) = p.kind {
            if role != Role::Skip {
                fields.push((offset, ty, role, pi));
            }
            offset += ty.size();
        }
    }
    let mut xyz = [0usize; 3];
    let mut xyz_prop = [0usize; 3];
    let mut fast = true;
    for &(off, ty, role, pi) in &fields {
        if let Role::Pos(k) = role {
            fast &= ty == Scalar::F32;
            if let (Some(o), Some(p)) = (xyz.get_mut(k), xyz_prop.get_mut(k)) {
                *o = off;
                *p = pi;
            }
        }
    }
    if fast {
        fields.retain(|f| !matches!(f.2, Role::Pos(_)));
    }
    let block = start
        .checked_add(e.count.saturating_mul(stride))
        .and_then(|end| data.get(start..end));
    let Some(block) = block else {
        let k = data.len().saturating_sub(start) / stride;
        return Err(truncated(e, k, start + k * stride, data.len()));
    };
    let [ox, oy, oz] = xyz;
    for (i, rec) in block.chunks_exact(stride).enumerate() {
        if fast {
            let p = [
                f32_at::<BE>(rec, ox),
                f32_at::<BE>(rec, oy),
                f32_at::<BE>(rec, oz),
            ];
            if !(p[0].is_finite() && p[1].is_finite() && p[2].is_finite()) {
                let (pi, v) = p
                    .iter()
                    .zip(xyz_prop)
                    .find(|(v, _)| !v.is_finite())
                    .map_or((0, f32::NAN), |(&v, pi)| (pi, v));
                return Err(non_finite(
                    e,
                    i,
                    pi,
                    f64::from(v),
                    Location::Byte((start + i * stride) as u64),
                ));
            }
            if let Some(slot) = out.positions.get_mut(i) {
                *slot = p;
            }
        }
        for &(off, ty, role, pi) in &fields {
            let v = scalar::<BE>(rec, off, ty).unwrap_or(f64::NAN);
            if !out.store(i, role, ty, v) {
                return Err(non_finite(
                    e,
                    i,
                    pi,
                    v,
                    Location::Byte((start + i * stride) as u64),
                ));
            }
        }
    }
    Ok(start + block.len())
}

/// Vertex records that contain lists: walk property by property.
fn vertices_binary_general<const BE: bool>(
    data: &[u8],
    start: usize,
    e: &Element,
    roles: &[Role],
    out: &mut Output,
) -> Result<usize, FormatError> {
    let mut pos = start;
    for i in 0..e.count {
        let record = pos;
        for (pi, (p, &role)) in e.props.iter().zip(roles).enumerate() {
            match p.kind {
                Kind::Scalar(ty) => {
                    let v = scalar::<BE>(data, pos, ty)
                        .ok_or_else(|| truncated(e, i, record, data.len()))?;
                    // Skipped properties may hold anything, NaN included.
                    if role != Role::Skip && !out.store(i, role, ty, v) {
                        return Err(non_finite(e, i, pi, v, Location::Byte(record as u64)));
                    }
                    pos += ty.size();
                }
                Kind::List { count, item } => {
                    let (n, items) = list_header::<BE>(data, pos, (count, item), e, i, record)?;
                    pos = items + n * item.size();
                }
            }
        }
    }
    Ok(pos)
}

fn faces_binary<const BE: bool>(
    data: &[u8],
    start: usize,
    e: &Element,
    roles: &[Role],
    kind: ElementKind,
    vertices: usize,
    out: &mut Output,
) -> Result<usize, FormatError> {
    let strips = kind == ElementKind::Strips;
    if let ([p], [Role::Indices], false) = (e.props.as_slice(), roles, strips) {
        if let Kind::List {
            count: Scalar::U8,
            item: item @ (Scalar::I32 | Scalar::U32),
        } = p.kind
        {
            return faces_binary_fast::<BE>(data, start, e, item == Scalar::I32, vertices, out);
        }
    }
    let has_group = roles.contains(&Role::Group);
    // A hint only: a face takes at least 4 bytes (a list of three 1-byte indices).
    out.triangles
        .reserve(e.count.min(data.len().saturating_sub(start) / 4));
    let mut pos = start;
    let mut strip = Strip::default();
    for i in 0..e.count {
        let record = pos;
        let mut group = 0u32;
        for (p, &role) in e.props.iter().zip(roles) {
            match (p.kind, role) {
                (Kind::List { count, item }, Role::Indices) => {
                    let (n, items) = list_header::<BE>(data, pos, (count, item), e, i, record)?;
                    if !strips && n < 3 {
                        return Err(too_few(i, n, Location::Byte(record as u64)));
                    }
                    strip.restart();
                    let mut fan = Fan::default();
                    for k in 0..n {
                        let v = scalar::<BE>(data, items + k * item.size(), item)
                            .ok_or_else(|| truncated(e, i, record, data.len()))?;
                        if strips && v == -1.0 {
                            strip.restart();
                            continue;
                        }
                        let Some(v) = check_index(v, vertices) else {
                            let what = if strips { "tristrip" } else { "face" };
                            return Err(FormatError::new(
                                Location::Byte(record as u64),
                                format!(
                                    "{what} {i} refers to vertex {v}, but the file has {vertices} vertices"
                                ),
                            ));
                        };
                        if strips {
                            strip.push(v, &mut out.triangles);
                        } else {
                            fan.push(v, &mut out.triangles);
                        }
                    }
                    pos = items + n * item.size();
                }
                (Kind::List { count, item }, _) => {
                    let (n, items) = list_header::<BE>(data, pos, (count, item), e, i, record)?;
                    pos = items + n * item.size();
                }
                (Kind::Scalar(ty), role) => {
                    let v = scalar::<BE>(data, pos, ty)
                        .ok_or_else(|| truncated(e, i, record, data.len()))?;
                    if role == Role::Group {
                        group = group_id(v, i, Location::Byte(pos as u64))?;
                    }
                    pos += ty.size();
                }
            }
        }
        if has_group {
            if let Some(g) = &mut out.groups {
                g.resize(out.triangles.len(), group);
            }
        }
    }
    Ok(pos)
}

fn group_id(v: f64, face: usize, location: Location) -> Result<u32, FormatError> {
    if v >= 0.0 && v <= f64::from(u32::MAX) {
        Ok(v as u32)
    } else {
        Err(FormatError::new(
            location,
            format!("face {face} has material index {v}, outside 0..=4294967295"),
        ))
    }
}

/// The common layout `property list uchar int|uint vertex_indices` and nothing else.
fn faces_binary_fast<const BE: bool>(
    data: &[u8],
    start: usize,
    e: &Element,
    signed: bool,
    vertices: usize,
    out: &mut Output,
) -> Result<usize, FormatError> {
    // Indices are compared as u32 bit patterns; negative i32 values are >= 2^31.
    let limit = if signed {
        vertices.min(1 << 31) as u64
    } else {
        vertices as u64
    };
    let value = |bits: u32| {
        if signed {
            i64::from(bits as i32)
        } else {
            i64::from(bits)
        }
    };
    // A hint only: each face record here takes at least 13 bytes.
    out.triangles
        .reserve(e.count.min(data.len().saturating_sub(start) / 13));
    let mut pos = start;
    for i in 0..e.count {
        let Some(&n) = data.get(pos) else {
            return Err(truncated(e, i, pos, data.len()));
        };
        if n == 3 {
            let Some(b) = array::<12>(data, pos + 1) else {
                return Err(
                    list_header::<BE>(data, pos, (Scalar::U8, Scalar::U32), e, i, pos)
                        .err()
                        .unwrap_or_else(|| truncated(e, i, pos, data.len())),
                );
            };
            let t = [
                u32_of::<BE>([b[0], b[1], b[2], b[3]]),
                u32_of::<BE>([b[4], b[5], b[6], b[7]]),
                u32_of::<BE>([b[8], b[9], b[10], b[11]]),
            ];
            if t.iter().any(|&v| u64::from(v) >= limit) {
                let bad = t
                    .iter()
                    .find(|&&v| u64::from(v) >= limit)
                    .copied()
                    .unwrap_or(0);
                return Err(bad_index(
                    i,
                    value(bad),
                    vertices,
                    Location::Byte(pos as u64),
                ));
            }
            out.triangles.push(t);
            pos += 13;
        } else {
            let n = usize::from(n);
            if n < 3 {
                return Err(too_few(i, n, Location::Byte(pos as u64)));
            }
            let (n, items) = list_header::<BE>(data, pos, (Scalar::U8, Scalar::U32), e, i, pos)?;
            let mut fan = Fan::default();
            for k in 0..n {
                let bits = array::<4>(data, items + 4 * k).map_or(u32::MAX, u32_of::<BE>);
                if u64::from(bits) >= limit {
                    return Err(bad_index(
                        i,
                        value(bits),
                        vertices,
                        Location::Byte(pos as u64),
                    ));
                }
                fan.push(bits, &mut out.triangles);
            }
            pos = items + 4 * n;
        }
    }
    Ok(pos)
}

// ---------------------------------------------------------------------------------
// ASCII body
// ---------------------------------------------------------------------------------

/// The next line that is not blank.
fn next_data_line<'a>(lines: &mut Lines<'a>) -> Option<&'a [u8]> {
    lines.find(|l| l.iter().any(|b| !b.is_ascii_whitespace()))
}

/// Parses an ASCII value of type `ty` (integers must be written as integers).
fn parse_value(tok: &[u8], ty: Scalar, line: u64, what: &str) -> Result<f64, FormatError> {
    match ty {
        // Straight to f32, so the shortest round-trip decimal gives the same bits.
        Scalar::F32 => text::parse_f32(tok, line, what).map(f64::from),
        Scalar::F64 => text::parse_f64(tok, line, what),
        _ => text::parse_i64(tok, line, what).map(|v| v as f64),
    }
}

fn read_ascii(
    lines: &mut Lines<'_>,
    h: &Header,
    plan: &Plan,
    out: &mut Output,
) -> Result<(), FormatError> {
    let vertices = plan.vertex_count;
    for ((e, &kind), roles) in h.elements.iter().zip(&plan.kinds).zip(&plan.roles) {
        if e.props.is_empty() {
            continue;
        }
        let strips = kind == ElementKind::Strips;
        let has_group = roles.contains(&Role::Group);
        let name = e.display_name();
        let mut strip = Strip::default();
        for i in 0..e.count {
            let Some(line) = next_data_line(lines) else {
                return Err(FormatError::new(
                    Location::Line(lines.line_number()),
                    format!("the file ends before {name} {i} of {}", e.count),
                ));
            };
            let ln = lines.line_number();
            let mut toks = text::tokens(line);
            let mut group = 0u32;
            for (pi, (p, &role)) in e.props.iter().zip(roles).enumerate() {
                let pname = std::str::from_utf8(&p.name).unwrap_or("a property");
                let mut next = || {
                    toks.next().ok_or_else(|| {
                        FormatError::new(
                            Location::Line(ln),
                            format!(
                                "{name} {i} has too few values (the line ends in property '{}')",
                                text::show(&p.name)
                            ),
                        )
                    })
                };
                match (p.kind, role) {
                    (Kind::Scalar(_), Role::Skip) => {
                        next()?;
                    }
                    (Kind::Scalar(_), Role::Group) => {
                        let v = text::parse_i64(next()?, ln, "a material index")?;
                        group = group_id(v as f64, i, Location::Line(ln))?;
                    }
                    (Kind::Scalar(ty), role) => {
                        let v = parse_value(next()?, ty, ln, pname)?;
                        if !out.store(i, role, ty, v) {
                            return Err(non_finite(e, i, pi, v, Location::Line(ln)));
                        }
                    }
                    (Kind::List { .. }, role) => {
                        let n = text::parse_count(next()?, ln, "a list length", u64::MAX)?;
                        // Each item takes at least two characters of the line.
                        if n > line.len() / 2 {
                            return Err(FormatError::new(
                                Location::Line(ln),
                                format!(
                                    "{name} {i} has a list of {n} items, more than its line holds"
                                ),
                            ));
                        }
                        if role != Role::Indices {
                            for _ in 0..n {
                                next()?;
                            }
                            continue;
                        }
                        if !strips && n < 3 {
                            return Err(too_few(i, n, Location::Line(ln)));
                        }
                        strip.restart();
                        let mut fan = Fan::default();
                        for _ in 0..n {
                            let v = text::parse_i64(next()?, ln, "a vertex index")?;
                            if strips && v == -1 {
                                strip.restart();
                                continue;
                            }
                            let Some(idx) = check_index(v as f64, vertices) else {
                                let what = if strips { "tristrip" } else { "face" };
                                return Err(FormatError::new(
                                    Location::Line(ln),
                                    format!(
                                        "{what} {i} refers to vertex {v}, but the file has {vertices} vertices"
                                    ),
                                ));
                            };
                            if strips {
                                strip.push(idx, &mut out.triangles);
                            } else {
                                fan.push(idx, &mut out.triangles);
                            }
                        }
                    }
                }
            }
            if let Some(extra) = toks.next() {
                return Err(FormatError::new(
                    Location::Line(ln),
                    format!(
                        "unexpected value '{}' after the last property of {name} {i}",
                        text::show(extra)
                    ),
                ));
            }
            if has_group {
                if let Some(g) = &mut out.groups {
                    g.resize(out.triangles.len(), group);
                }
            }
        }
        out.pad_groups();
    }
    if next_data_line(lines).is_some() {
        return Err(FormatError::new(
            Location::Line(lines.line_number()),
            "data after the last element the header declares",
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::test_support::{corrupted, position_bits};
    use proptest::prelude::*;

    fn err(data: &[u8]) -> FormatError {
        match read(data) {
            Ok(m) => panic!("expected an error, read {m:?}"),
            Err(e) => e,
        }
    }

    /// A header followed by binary values in the chosen byte order.
    struct Bin {
        out: Vec<u8>,
        be: bool,
    }

    impl Bin {
        fn new(header: &str, be: bool) -> Self {
            Self {
                out: header.as_bytes().to_vec(),
                be,
            }
        }
        fn header_len(header: &str) -> u64 {
            header.len() as u64
        }
        /// Appends numbers of one type in the chosen byte order.
        fn put<const N: usize, T: Copy>(
            &mut self,
            v: &[T],
            le: fn(T) -> [u8; N],
            be: fn(T) -> [u8; N],
        ) -> &mut Self {
            for &x in v {
                let b = if self.be { be(x) } else { le(x) };
                self.out.extend_from_slice(&b);
            }
            self
        }
        fn f32(&mut self, v: &[f32]) -> &mut Self {
            self.put(v, f32::to_le_bytes, f32::to_be_bytes)
        }
        fn f64(&mut self, v: &[f64]) -> &mut Self {
            self.put(v, f64::to_le_bytes, f64::to_be_bytes)
        }
        fn i32(&mut self, v: &[i32]) -> &mut Self {
            self.put(v, i32::to_le_bytes, i32::to_be_bytes)
        }
        fn u16(&mut self, v: &[u16]) -> &mut Self {
            self.put(v, u16::to_le_bytes, u16::to_be_bytes)
        }
        fn u8(&mut self, v: &[u8]) -> &mut Self {
            self.out.extend_from_slice(v);
            self
        }
        fn bytes(&self) -> &[u8] {
            &self.out
        }
    }

    const XYZ_TRI: &str = "property float x\nproperty float y\nproperty float z\n";

    // A unit square (quad) and a triangle over a fifth vertex, ASCII.
    #[test]
    fn ascii_polygons_are_fan_triangulated() {
        let data = b"ply\nformat ascii 1.0\ncomment square and apex\nobj_info test\n\
element vertex 5\nproperty float x\nproperty float y\nproperty float z\n\
element face 2\nproperty list uchar int vertex_indices\nend_header\n\
0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 0.5 1\n4 0 1 2 3\n3 0 1 4\n";
        let m = read(data).unwrap();
        assert_eq!(m.positions.len(), 5);
        assert_eq!(m.positions[4], [0.5, 0.5, 1.0]);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 1, 4]]);
        assert!(m.attributes.is_empty());
        assert_eq!(m.groups, None);
    }

    // Vertex with unknown properties mixed in, normals, rgb without alpha, s/t UVs.
    #[test]
    fn ascii_attributes() {
        let data = b"ply\nformat ascii 1.0\nelement vertex 3\n\
property float x\nproperty float confidence\nproperty float y\nproperty float z\n\
property float nx\nproperty float ny\nproperty float nz\n\
property uchar red\nproperty uchar green\nproperty uchar blue\n\
property float s\nproperty float t\nproperty list uchar int extra\n\
element face 1\nproperty list uchar uint vertex_index\nend_header\n\
1 0.9 2 3 0 0 1 255 0 51 0.25 0.75 2 7 8\n\
4 0.1 5 6 0 1 0 0 255 0 0.5 0.5 0\n\
7 0.5 8 9 1 0 0 0 0 255 1 0 1 9\n\
3 0 1 2\n";
        let m = read(data).unwrap();
        assert_eq!(
            m.positions,
            vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]]
        );
        let a = &m.attributes;
        assert_eq!(a.normals.as_ref().unwrap()[1], [0.0, 1.0, 0.0]);
        assert_eq!(a.colors.as_ref().unwrap()[0], [1.0, 0.0, 51.0 / 255.0, 1.0]);
        assert_eq!(a.uv0.as_ref().unwrap()[0], [0.25, 0.75]);
        assert_eq!(m.triangles, vec![[0, 1, 2]]);
    }

    // texture_u/texture_v, float colours with alpha, ushort colours scaled by 65535.
    #[test]
    fn uv_and_colour_variants() {
        let data = b"ply\nformat ascii 1.0\nelement vertex 1\n\
property float x\nproperty float y\nproperty float z\n\
property float texture_u\nproperty float texture_v\n\
property float red\nproperty float green\nproperty float blue\nproperty float alpha\n\
end_header\n0 0 0 0.5 0.125 0.25 0.5 0.75 0.5\n";
        let m = read(data).unwrap();
        assert_eq!(m.attributes.uv0, Some(vec![[0.5, 0.125]]));
        assert_eq!(m.attributes.colors, Some(vec![[0.25, 0.5, 0.75, 0.5]]));
        assert!(m.triangles.is_empty());

        let data = b"ply\nformat ascii 1.0\nelement vertex 1\n\
property float x\nproperty float y\nproperty float z\n\
property ushort diffuse_red\nproperty ushort diffuse_green\nproperty ushort diffuse_blue\n\
end_header\n0 0 0 65535 0 13107\n";
        let m = read(data).unwrap();
        assert_eq!(m.attributes.colors, Some(vec![[1.0, 0.0, 0.2, 1.0]]));
    }

    // CRLF everywhere, blank lines in the header and body, trailing spaces.
    #[test]
    fn ascii_crlf() {
        let data = b"ply\r\nformat ascii 1.0\r\n\r\nelement vertex 3\r\nproperty float32 x\r\n\
property float32 y\r\nproperty float32 z\r\nelement face 1\r\n\
property list uint8 int32 vertex_indices\r\nend_header\r\n\
0 0 0 \r\n1 0 0\r\n\r\n0 1 0\r\n3 0 1 2 \r\n\r\n";
        let m = read(data).unwrap();
        assert_eq!(m.positions[2], [0.0, 1.0, 0.0]);
        assert_eq!(m.triangles, vec![[0, 1, 2]]);
    }

    // Faces before vertices, unknown elements with lists before and after, double
    // coordinates, ushort list length with short indices (general paths), LE.
    #[test]
    fn binary_any_order_and_unknown_elements() {
        let header = "ply\nformat binary_little_endian 1.0\n\
element material 2\nproperty list uchar float params\nproperty int id\n\
element face 2\nproperty list ushort ushort vertex_indices\nproperty float quality\n\
element vertex 4\nproperty double x\nproperty double y\nproperty double z\nproperty int flags\n\
element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n";
        let mut b = Bin::new(header, false);
        // material 0: 2 params, id; material 1: 0 params, id
        b.u8(&[2]).f32(&[1.0, 2.0]).i32(&[7]).u8(&[0]).i32(&[8]);
        // face 0: quad; face 1: triangle
        b.u16(&[4, 0, 1, 2, 3])
            .f32(&[0.5])
            .u16(&[3, 3, 2, 1])
            .f32(&[1.0]);
        for (i, p) in [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.1, 1.0, 0.0],
        ]
        .iter()
        .enumerate()
        {
            b.f64(p).i32(&[i as i32]);
        }
        b.i32(&[0, 1]);
        let m = read(b.bytes()).unwrap();
        assert_eq!(m.positions[3], [0.1, 1.0, 0.0]);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3], [3, 2, 1]]);
    }

    // horse.ply's layout in big-endian: float xyz, float confidence, uchar rgb; faces
    // `list uchar int` (the fast paths), with one quad among the triangles.
    #[test]
    fn binary_big_endian_colours_fast_paths() {
        let header = "ply\nformat binary_big_endian 1.0\nelement vertex 4\n\
property float x\nproperty float y\nproperty float z\nproperty float confidence\n\
property uchar red\nproperty uchar green\nproperty uchar blue\n\
element face 2\nproperty list uchar int vertex_indices\nend_header\n";
        let mut b = Bin::new(header, true);
        b.f32(&[1.5, -2.0, 3.25, 0.5]).u8(&[255, 0, 128]);
        b.f32(&[4.0, 5.0, 6.0, 0.5]).u8(&[1, 2, 3]);
        b.f32(&[7.0, 8.0, 9.0, 0.5]).u8(&[0, 0, 0]);
        b.f32(&[1.0, 1.0, 1.0, 0.5]).u8(&[9, 9, 9]);
        b.u8(&[3]).i32(&[0, 1, 2]).u8(&[4]).i32(&[0, 1, 2, 3]);
        let m = read(b.bytes()).unwrap();
        assert_eq!(m.positions[0], [1.5, -2.0, 3.25]);
        assert_eq!(m.positions[2], [7.0, 8.0, 9.0]);
        let c = m.attributes.colors.as_ref().unwrap();
        assert_eq!(c[0], [1.0, 0.0, 128.0 / 255.0, 1.0]);
        assert_eq!(c[1], [1.0 / 255.0, 2.0 / 255.0, 3.0 / 255.0, 1.0]);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 1, 2], [0, 2, 3]]);
    }

    // The same vertices decoded by the fixed-size fast path and by the general path
    // (a list property in the vertex element forces it) give the same mesh.
    #[test]
    fn vertex_fast_and_general_paths_agree() {
        let fixed = "ply\nformat binary_little_endian 1.0\nelement vertex 2\n\
property float x\nproperty float y\nproperty float z\nproperty float nx\n\
property float ny\nproperty float nz\nend_header\n";
        let listed = "ply\nformat binary_little_endian 1.0\nelement vertex 2\n\
property float x\nproperty list uchar short junk\nproperty float y\nproperty float z\n\
property float nx\nproperty float ny\nproperty float nz\nend_header\n";
        let mut a = Bin::new(fixed, false);
        let mut b = Bin::new(listed, false);
        for (k, p) in [[1.0f32, 2.0, 3.0], [-4.0, 5.5, 1e-3]].iter().enumerate() {
            a.f32(p).f32(&[0.0, 0.0, 1.0]);
            b.f32(&p[..1]).u8(&[k as u8]);
            for _ in 0..k {
                b.u16(&[0xffff]);
            }
            b.f32(&p[1..]).f32(&[0.0, 0.0, 1.0]);
        }
        let ma = read(a.bytes()).unwrap();
        let mb = read(b.bytes()).unwrap();
        assert_eq!(ma, mb);
        assert_eq!(ma.positions[1], [-4.0, 5.5, 1e-3]);
        assert_eq!(ma.attributes.normals, Some(vec![[0.0, 0.0, 1.0]; 2]));
    }

    // Strips 0 1 2 3 | 4 5 6 and 0 1 2 2 3 4 (with stitching degenerates).
    #[test]
    fn tristrips_ascii_and_binary() {
        let data = b"ply\nformat ascii 1.0\nelement vertex 7\nproperty float x\n\
property float y\nproperty float z\nelement tristrips 2\nproperty list int int vertex_indices\n\
end_header\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n2 0 0\n3 0 0\n2 1 0\n\
8 0 1 2 3 -1 4 5 6\n6 0 1 2 2 3 4\n";
        let m = read(data).unwrap();
        assert_eq!(
            m.triangles,
            vec![[0, 1, 2], [2, 1, 3], [4, 5, 6], [0, 1, 2], [3, 2, 4]]
        );

        let header = "ply\nformat binary_little_endian 1.0\nelement vertex 4\n\
property float x\nproperty float y\nproperty float z\nelement tristrips 1\n\
property list int int vertex_indices\nend_header\n";
        let mut b = Bin::new(header, false);
        for p in [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
        ] {
            b.f32(&p);
        }
        b.i32(&[4, 0, 1, 2, 3]);
        assert_eq!(
            read(b.bytes()).unwrap().triangles,
            vec![[0, 1, 2], [2, 1, 3]]
        );
    }

    // material_index becomes groups: a quad of group 2 gives two triangles of group 2;
    // tristrips (no groups) after the faces get group 0.
    #[test]
    fn material_index_groups() {
        let data = b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n\
property float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\n\
property uchar material_index\nelement tristrips 1\nproperty list int int vertex_indices\n\
end_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3 2\n3 0 1 3 1\n3 1 2 3\n";
        let m = read(data).unwrap();
        assert_eq!(m.triangles.len(), 4);
        assert_eq!(m.groups, Some(vec![2, 2, 1, 0]));

        let header = "ply\nformat binary_big_endian 1.0\nelement vertex 3\n\
property float x\nproperty float y\nproperty float z\nelement face 2\n\
property int material_id\nproperty list uchar int vertex_indices\nend_header\n";
        let mut b = Bin::new(header, true);
        b.f32(&[0.0; 9]);
        b.i32(&[5])
            .u8(&[3])
            .i32(&[0, 1, 2])
            .i32(&[0])
            .u8(&[3])
            .i32(&[2, 1, 0]);
        let m = read(b.bytes()).unwrap();
        assert_eq!(m.groups, Some(vec![5, 0]));
    }

    // A file with an empty vertex element and no faces is an empty mesh.
    #[test]
    fn empty_mesh() {
        let m = read(b"ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n").unwrap();
        assert_eq!(m, Mesh::default());
    }

    // An unknown float property may hold NaN: it is skipped, not checked. Fixed-size
    // binary, binary with a list in the vertex (general path), and ASCII.
    #[test]
    fn nan_in_skipped_property_is_fine() {
        let fixed = "ply\nformat binary_little_endian 1.0\nelement vertex 1\n\
property float x\nproperty float y\nproperty float z\nproperty float quality\nend_header\n";
        let mut b = Bin::new(fixed, false);
        b.f32(&[1.0, 2.0, 3.0, f32::NAN]);
        assert_eq!(read(b.bytes()).unwrap().positions, vec![[1.0, 2.0, 3.0]]);
        let general = fixed
            .replace("end_header", "property list uchar int junk\nend_header")
            .replace("little", "big");
        let mut b = Bin::new(&general, true);
        b.f32(&[1.0, 2.0, 3.0, f32::INFINITY]).u8(&[1]).i32(&[4]);
        assert_eq!(read(b.bytes()).unwrap().positions, vec![[1.0, 2.0, 3.0]]);
        let text = fixed.replace("binary_little_endian", "ascii") + "1 2 3 nan\n";
        assert_eq!(
            read(text.as_bytes()).unwrap().positions,
            vec![[1.0, 2.0, 3.0]]
        );
    }

    // ---- header errors -------------------------------------------------------------

    #[test]
    fn header_errors() {
        let cases: &[(&[u8], Location, &str)] = &[
            (b"", Location::File, "empty"),
            (b"plx\nformat ascii 1.0\n", Location::Line(1), "not a PLY"),
            (b"ply\nend_header\n", Location::Line(2), "no 'format'"),
            (
                b"ply\nformat text 1.0\nend_header\n",
                Location::Line(2),
                "unknown PLY format",
            ),
            (
                b"ply\nformat ascii 2.0\nend_header\n",
                Location::Line(2),
                "version",
            ),
            (
                b"ply\nformat ascii\nend_header\n",
                Location::Line(2),
                "expected 'format",
            ),
            (
                b"ply\nformat ascii 1.0\nformat ascii 1.0\n",
                Location::Line(3),
                "second 'format'",
            ),
            (
                b"ply\nformat ascii 1.0\nproperty float x\n",
                Location::Line(3),
                "before any 'element'",
            ),
            (
                b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float16 x\n",
                Location::Line(4),
                "unknown property type",
            ),
            (
                b"ply\nformat ascii 1.0\nelement vertex 1\nproperty list float int x\n",
                Location::Line(4),
                "length type",
            ),
            (
                b"ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar x\n",
                Location::Line(4),
                "property list",
            ),
            (
                b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x y\n",
                Location::Line(4),
                "expected 'property",
            ),
            (
                b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty int x\n",
                Location::Line(5),
                "second property",
            ),
            (
                b"ply\nformat ascii 1.0\nelement vertex 0\nelement vertex 0\n",
                Location::Line(4),
                "second element",
            ),
            (
                b"ply\nformat ascii 1.0\nelement vertex\n",
                Location::Line(3),
                "element NAME COUNT",
            ),
            (
                b"ply\nformat ascii 1.0\nelement vertex -1\n",
                Location::Line(3),
                "negative",
            ),
            (
                b"ply\nformat ascii 1.0\nelement vertex x\n",
                Location::Line(3),
                "integer",
            ),
            (
                b"ply\nformat ascii 1.0\nelemnt vertex 0\n",
                Location::Line(3),
                "unknown header keyword",
            ),
            (
                b"ply\nformat ascii 1.0\ncomment no end\n",
                Location::Line(3),
                "no 'end_header'",
            ),
        ];
        for (data, loc, msg) in cases {
            let e = err(data);
            assert_eq!(&e.location, loc, "{e}");
            assert!(e.message.contains(msg), "{e} (wanted '{msg}')");
        }
    }

    // Element counts larger than the body can hold are refused at the element line.
    #[test]
    fn counts_capped_by_file_size() {
        // Binary: 1000 vertices of 12 bytes in a 24-byte body.
        let header = format!(
            "ply\nformat binary_little_endian 1.0\nelement vertex 1000\n{XYZ_TRI}end_header\n"
        );
        let mut b = Bin::new(&header, false);
        b.f32(&[0.0; 6]);
        let e = err(b.bytes());
        assert_eq!(e.location, Location::Line(3));
        assert!(e.message.contains("at most 2"), "{e}");
        // ASCII: 4 billion faces in a few bytes.
        let e = err(b"ply\nformat ascii 1.0\nelement face 4000000000\nproperty list uchar int vertex_indices\nend_header\n3 0 1 2\n");
        assert_eq!(e.location, Location::Line(3));
    }

    #[test]
    fn element_layout_errors() {
        let cases: &[(&[u8], Location, &str)] = &[
            (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n", Location::Line(3), "no 'z'"),
            (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar float x\nproperty float y\nproperty float z\nend_header\n1 0 0 0 0\n", Location::Line(4), "is a list"),
            (b"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int verts\nend_header\n3 0 0 0\n", Location::Line(7), "no 'vertex_indices'"),
            (b"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar float vertex_indices\nend_header\n3 0 0 0\n", Location::Line(8), "integer type"),
            (b"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty int vertex_indices\nend_header\n3\n", Location::Line(8), "must be a list"),
            (b"ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n3 0 0 0\n", Location::Line(3), "no vertex element"),
        ];
        for (data, loc, msg) in cases {
            let e = err(data);
            assert_eq!(&e.location, loc, "{e}");
            assert!(e.message.contains(msg), "{e} (wanted '{msg}')");
        }
    }

    // ---- binary body errors --------------------------------------------------------

    const TRI_HEADER: &str = "ply\nformat binary_little_endian 1.0\nelement vertex 3\n\
property float x\nproperty float y\nproperty float z\nelement face 1\n\
property list uchar int vertex_indices\nend_header\n";

    fn tri_vertices(b: &mut Bin) {
        b.f32(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    }

    #[test]
    fn binary_truncated_vertex() {
        // An unknown element with a list (its minimum size is 1 byte, it takes 11)
        // lets the vertex count pass the header cap; the vertices then run out.
        let header = "ply\nformat binary_little_endian 1.0\nelement junk 1\n\
property list uchar uchar data\nelement vertex 2\nproperty float x\nproperty float y\n\
property float z\nend_header\n";
        let mut b = Bin::new(header, false);
        b.u8(&[10]).u8(&[0; 10]).f32(&[0.0; 5]);
        let e = err(b.bytes());
        assert_eq!(
            e.location,
            Location::Byte(Bin::header_len(header) + 11 + 12)
        );
        assert!(e.message.contains("vertex 1 of 2"), "{e}");
    }

    #[test]
    fn binary_truncated_face() {
        let mut b = Bin::new(TRI_HEADER, false);
        tri_vertices(&mut b);
        b.u8(&[3]).i32(&[0, 1]);
        let e = err(b.bytes());
        let face_at = Bin::header_len(TRI_HEADER) + 36;
        assert_eq!(e.location, Location::Byte(face_at));
        assert!(e.message.contains("12 bytes"), "{e}");
        // No face record at all.
        let mut b = Bin::new(TRI_HEADER, false);
        tri_vertices(&mut b);
        let e = err(b.bytes());
        assert_eq!(e.location, Location::Byte(face_at), "{e}");
    }

    #[test]
    fn binary_list_too_long() {
        let mut b = Bin::new(TRI_HEADER, false);
        tri_vertices(&mut b);
        b.u8(&[200]).i32(&[0, 1, 2]);
        let e = err(b.bytes());
        assert_eq!(e.location, Location::Byte(Bin::header_len(TRI_HEADER) + 36));
        assert!(e.message.contains("list of 200 items"), "{e}");
        // The same in a general-path element (ushort length).
        let header = TRI_HEADER.replace("list uchar int", "list ushort int");
        let mut b = Bin::new(&header, false);
        tri_vertices(&mut b);
        b.u16(&[60000]).i32(&[0, 1, 2]);
        let e = err(b.bytes());
        assert!(e.message.contains("list of 60000 items"), "{e}");
        // And in an unknown element that is skipped.
        let header = TRI_HEADER.replace(
            "end_header",
            "element junk 1\nproperty list int int x\nend_header",
        );
        let mut b = Bin::new(&header, false);
        tri_vertices(&mut b);
        b.u8(&[3]).i32(&[0, 1, 2]).i32(&[-5]);
        let e = err(b.bytes());
        assert!(e.message.contains("negative length"), "{e}");
    }

    #[test]
    fn binary_face_errors() {
        let face_at = Bin::header_len(TRI_HEADER) + 36;
        // Two vertices (fast path).
        let mut b = Bin::new(TRI_HEADER, false);
        tri_vertices(&mut b);
        b.u8(&[2]).i32(&[0, 1]);
        let e = err(b.bytes());
        assert_eq!(e.location, Location::Byte(face_at));
        assert!(e.message.contains("face 0 has 2 vertices"), "{e}");
        // Index 3 of 3 vertices; -1 (signed).
        for (bad, shown) in [(3, "vertex 3,"), (-1, "vertex -1,")] {
            let mut b = Bin::new(TRI_HEADER, false);
            tri_vertices(&mut b);
            b.u8(&[3]).i32(&[0, bad, 1]);
            let e = err(b.bytes());
            assert_eq!(e.location, Location::Byte(face_at));
            assert!(e.message.contains(shown), "{e}");
            assert!(e.message.contains("face 0"), "{e}");
        }
        // Out of range in a quad (fast path, polygon branch).
        let mut b = Bin::new(TRI_HEADER, false);
        tri_vertices(&mut b);
        b.u8(&[4]).i32(&[0, 1, 2, 9]);
        assert!(err(b.bytes()).message.contains("vertex 9,"));
        // General path: short indices with an extra property.
        let header = TRI_HEADER.replace(
            "property list uchar int vertex_indices",
            "property list uchar short vertex_indices\nproperty uchar flag",
        );
        let mut b = Bin::new(&header, false);
        tri_vertices(&mut b);
        b.u8(&[3]).u16(&[0, 1, 7]).u8(&[0]);
        let e = err(b.bytes());
        assert_eq!(e.location, Location::Byte(Bin::header_len(&header) + 36));
        assert!(e.message.contains("vertex 7,"), "{e}");
        let mut b = Bin::new(&header, false);
        tri_vertices(&mut b);
        b.u8(&[1]).u16(&[0]).u8(&[0]);
        assert!(err(b.bytes()).message.contains("has 1 vertices"));
    }

    #[test]
    fn binary_non_finite() {
        let mut b = Bin::new(TRI_HEADER, false);
        b.f32(&[0.0, 0.0, 0.0, 1.0, f32::NAN, 0.0, 0.0, 1.0, 0.0]);
        b.u8(&[3]).i32(&[0, 1, 2]);
        let e = err(b.bytes());
        assert_eq!(e.location, Location::Byte(Bin::header_len(TRI_HEADER) + 12));
        assert!(e.message.contains("vertex 1 has a non-finite y"), "{e}");
        // A double too large for f32.
        let header = TRI_HEADER.replace("float", "double");
        let mut b = Bin::new(&header, false);
        b.f64(&[0.0, 0.0, 1e300, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        b.u8(&[3]).i32(&[0, 1, 2]);
        let e = err(b.bytes());
        assert_eq!(e.location, Location::Byte(Bin::header_len(&header)));
        assert!(e.message.contains("non-finite z"), "{e}");
    }

    #[test]
    fn binary_negative_material_index() {
        let header = TRI_HEADER.replace("end_header", "property int material_index\nend_header");
        let mut b = Bin::new(&header, false);
        tri_vertices(&mut b);
        b.u8(&[3]).i32(&[0, 1, 2]).i32(&[-3]);
        assert!(err(b.bytes()).message.contains("material index -3"));
    }

    #[test]
    fn binary_bad_tristrip_index() {
        let header = "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n\
property float y\nproperty float z\nelement tristrips 1\nproperty list int int vertex_indices\nend_header\n";
        let mut b = Bin::new(header, false);
        b.f32(&[0.0; 3]).i32(&[3, 0, -2, 0]);
        let e = err(b.bytes());
        assert!(e.message.contains("tristrip 0 refers to vertex -2"), "{e}");
    }

    // Bytes after the last record of a binary file are ignored.
    #[test]
    fn binary_trailing_bytes_ignored() {
        let mut b = Bin::new(TRI_HEADER, false);
        tri_vertices(&mut b);
        b.u8(&[3]).i32(&[0, 1, 2]).u8(b"\n\n");
        assert_eq!(read(b.bytes()).unwrap().triangles, vec![[0, 1, 2]]);
    }

    // ---- ASCII body errors ---------------------------------------------------------

    const ASCII_HEADER: &str = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n\
property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n\
end_header\n";

    fn ascii(body: &str) -> Vec<u8> {
        format!("{ASCII_HEADER}{body}").into_bytes()
    }

    #[test]
    fn ascii_body_errors() {
        // The body starts on line 10.
        let cases: &[(&str, u64, &str)] = &[
            (
                "0 0 0\n1 0 x\n0 1 0\n3 0 1 2\n",
                11,
                "expected a number for z",
            ),
            ("0 0 0\n1 0\n0 1 0\n3 0 1 2\n", 11, "too few values"),
            (
                "0 0 0\n1 0 0 5\n0 1 0\n3 0 1 2\n",
                11,
                "unexpected value '5'",
            ),
            (
                "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n",
                11,
                "vertex 1 has a non-finite y",
            ),
            (
                "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
                13,
                "face 0 refers to vertex 3,",
            ),
            ("0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", 13, "vertex -1,"),
            ("0 0 0\n1 0 0\n0 1 0\n2 0 1\n", 13, "face 0 has 2 vertices"),
            ("0 0 0\n1 0 0\n0 1 0\n4 0 1 2  \n", 13, "too few values"),
            (
                "0 0 0\n1 0 0\n0 1 0\n9 0 1 2\n",
                13,
                "list of 9 items, more than its line holds",
            ),
            (
                "0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n",
                13,
                "expected an integer",
            ),
            (
                "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n0 0 0\n",
                14,
                "data after the last element",
            ),
            (
                "0.000 0.000 0.000\n1 0 0\n",
                11,
                "ends before vertex 2 of 3",
            ),
        ];
        for (body, line, msg) in cases {
            let e = err(&ascii(body));
            assert_eq!(e.location, Location::Line(*line), "{e} for {body:?}");
            assert!(e.message.contains(msg), "{e} (wanted '{msg}')");
        }
    }

    // Non-UTF-8 bytes in a comment are fine; in a number they are an error.
    #[test]
    fn non_utf8() {
        let mut data = b"ply\nformat ascii 1.0\ncomment caf\xe9\n".to_vec();
        data.extend_from_slice(b"element vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n");
        assert_eq!(read(&data).unwrap().positions, vec![[1.0, 2.0, 3.0]]);
        let mut data = ascii("0 0 0\n1 0 0\n0 1 ");
        data.extend_from_slice(b"\xff\n3 0 1 2\n");
        let e = err(&data);
        assert_eq!(e.location, Location::Line(12));
    }

    // ---- writer --------------------------------------------------------------------

    fn sample_mesh() -> Mesh {
        Mesh {
            positions: vec![[0.1, 0.2, 0.3], [-1.0, 1e-30, 3.5e20], [0.0, -0.0, 1.0]],
            triangles: vec![[0, 1, 2], [2, 1, 0]],
            attributes: VertexAttributes {
                normals: Some(vec![[0.0, 0.0, 1.0], [0.6, 0.8, 0.0], [1.0, 0.0, 0.0]]),
                colors: Some(vec![
                    [1.0, 0.0, 0.5019608, 1.0],
                    [0.2, 0.4, 0.6, 0.8],
                    [0.0, 0.0, 0.0, 0.0],
                ]),
                uv0: Some(vec![[0.0, 1.0], [0.5, 0.25], [1.0, 0.0]]),
                ..VertexAttributes::default()
            },
            groups: Some(vec![0, 3]),
            group_names: Vec::new(),
        }
    }

    #[test]
    fn writer_header() {
        let mut out = Vec::new();
        write(&sample_mesh(), false, &mut out).unwrap();
        let text = String::from_utf8_lossy(&out);
        let header = text.split("end_header\n").next().unwrap();
        assert_eq!(
            header,
            "ply\nformat binary_little_endian 1.0\ncomment written by meshlod\n\
element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
property float nx\nproperty float ny\nproperty float nz\n\
property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n\
property float u\nproperty float v\nelement face 2\n\
property list uchar int vertex_indices\nproperty uint material_index\n"
        );
        // 3 vertices of 36 bytes, 2 faces of 17 bytes.
        assert_eq!(
            out.len(),
            header.len() + "end_header\n".len() + 3 * 36 + 2 * 17
        );
        let mut ascii = Vec::new();
        write(
            &Mesh::from_triangles(vec![[0.5, 1.0, -2.0]; 3], vec![[0, 1, 2]]),
            true,
            &mut ascii,
        )
        .unwrap();
        assert!(String::from_utf8(ascii)
            .unwrap()
            .ends_with("end_header\n0.5 1 -2\n0.5 1 -2\n0.5 1 -2\n3 0 1 2\n"));
    }

    #[test]
    fn writer_round_trip_both_encodings() {
        let mut m = sample_mesh();
        // Colours round-trip through uchar when they are multiples of 1/255.
        for c in m.attributes.colors.as_mut().unwrap() {
            *c = c.map(|x| (x * 255.0).round() / 255.0);
        }
        for ascii in [false, true] {
            let mut out = Vec::new();
            write(&m, ascii, &mut out).unwrap();
            let back = read(&out).unwrap();
            assert_eq!(back, m, "ascii = {ascii}");
            // Bitwise, including -0.0.
            assert_eq!(back.positions[2][1].to_bits(), (-0.0f32).to_bits());
        }
    }

    #[test]
    fn writer_refuses_invalid_mesh() {
        let m = Mesh::from_triangles(vec![[0.0; 3]], vec![[0, 0, 1]]);
        let e = write(&m, false, &mut Vec::new()).unwrap_err();
        assert!(e.message.contains("invalid mesh"), "{e}");
    }

    #[test]
    fn shortest_float_text() {
        let show = |v: f32| {
            let mut s = Vec::new();
            push_f32(&mut s, v);
            String::from_utf8(s).unwrap()
        };
        assert_eq!(show(0.1), "0.1");
        assert_eq!(show(-0.0), "-0");
        assert_eq!(show(1.0), "1");
        assert_eq!(show(1e-30), "1e-30");
        assert_eq!(show(3.5e20), "3.5e20");
        assert_eq!(show(f32::MAX), "3.4028235e38");
        assert_eq!(show(f32::from_bits(1)), "1e-45");
    }

    fn finite_f32() -> prop::num::f32::Any {
        prop::num::f32::POSITIVE
            | prop::num::f32::NEGATIVE
            | prop::num::f32::NORMAL
            | prop::num::f32::SUBNORMAL
            | prop::num::f32::ZERO
    }

    fn arb_mesh() -> impl Strategy<Value = Mesh> {
        (1usize..16, 0usize..24).prop_flat_map(|(n, t)| {
            let i = 0..n as u32;
            let v3 = prop::array::uniform3(finite_f32());
            (
                prop::collection::vec(v3, n),
                prop::collection::vec(prop::array::uniform3(i), t),
                prop::option::of(prop::collection::vec(v3, n)),
                prop::option::of(prop::collection::vec(
                    prop::array::uniform4(any::<u8>())
                        .prop_map(|c| c.map(|k| f32::from(k) / 255.0)),
                    n,
                )),
                prop::option::of(prop::collection::vec(
                    prop::array::uniform2(finite_f32()),
                    n,
                )),
                prop::option::of(prop::collection::vec(0u32..1000, t)),
            )
                .prop_map(|(positions, triangles, normals, colors, uv0, groups)| {
                    Mesh {
                        positions,
                        triangles,
                        attributes: VertexAttributes {
                            normals,
                            colors,
                            uv0,
                            ..VertexAttributes::default()
                        },
                        groups,
                        group_names: Vec::new(),
                    }
                })
        })
    }

    proptest! {
        #[test]
        fn round_trip(m in arb_mesh()) {
            for ascii in [false, true] {
                let mut out = Vec::new();
                write(&m, ascii, &mut out).unwrap();
                let back = read(&out).unwrap();
                prop_assert_eq!(&back, &m);
                prop_assert_eq!(position_bits(&back), position_bits(&m));
            }
        }

        // Valid files with a few bytes overwritten, or cut short, never panic the
        // reader (whatever the result).
        #[test]
        fn no_panic_on_corrupted_files(
            m in arb_mesh(),
            ascii in any::<bool>(),
            edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
            cut in any::<prop::sample::Index>(),
        ) {
            let mut out = Vec::new();
            write(&m, ascii, &mut out).unwrap();
            let (out, keep) = corrupted(out, &edits, &cut);
            let _ = read(&out);
            let _ = read(&out[..keep]);
        }

        // Arbitrary bytes after a valid header never panic the reader.
        #[test]
        fn no_panic_on_garbage(body in prop::collection::vec(any::<u8>(), 0..200), be in any::<bool>(), ascii in any::<bool>()) {
            let format = if ascii { "ascii" } else if be { "binary_big_endian" } else { "binary_little_endian" };
            let mut data = format!("ply\nformat {format} 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty list uchar short l\nelement face 3\nproperty list uchar int vertex_indices\nproperty uchar material_index\nelement tristrips 1\nproperty list int int vertex_indices\nend_header\n").into_bytes();
            data.extend_from_slice(&body);
            let _ = read(&data);
        }
    }

    // The PLY files of the shared test set: vertex and triangle counts from its
    // MANIFEST.md (skipped where the directory is not present).
    #[test]
    fn shared_test_files() {
        let dir = std::path::Path::new("/work/shared/meshes/vtk-data");
        let cases = [
            ("bunny.ply", 35947, 69451, false),
            ("horse.ply", 48485, 96966, true),
            ("lucy.ply", 49987, 99970, false),
            ("turbineblade.ply", 99519, 199_034, false),
            ("stratocaster.ply", 4500, 8660, false),
        ];
        for (name, v, t, colors) in cases {
            let Ok(data) = std::fs::read(dir.join(name)) else {
                eprintln!("skipping {name}: not found");
                continue;
            };
            let m = read(&data).unwrap();
            assert_eq!((m.positions.len(), m.triangles.len()), (v, t), "{name}");
            assert_eq!(m.attributes.colors.is_some(), colors, "{name}");
            m.validate().unwrap();
        }
    }

    /// A flat grid of `side × side` vertices, `2 (side-1)²` triangles.
    fn grid(side: u32) -> Mesh {
        let mut positions = Vec::new();
        for y in 0..side {
            for x in 0..side {
                positions.push([
                    x as f32 * 0.01,
                    y as f32 * 0.01,
                    ((x ^ y) % 7) as f32 * 0.001,
                ]);
            }
        }
        let mut triangles = Vec::new();
        for y in 0..side - 1 {
            for x in 0..side - 1 {
                let v = y * side + x;
                triangles.push([v, v + 1, v + side]);
                triangles.push([v + 1, v + side + 1, v + side]);
            }
        }
        Mesh::from_triangles(positions, triangles)
    }

    // Throughput on a ≥1M-triangle file; run with
    // `cargo test --release -p meshlod --lib io::ply::tests::throughput -- --ignored --nocapture`.
    // Prints MB/s; asserts only correctness.
    #[test]
    #[ignore = "measurement, run by hand in release"]
    fn throughput() {
        let m = grid(710);
        assert!(m.triangles.len() >= 1_000_000);
        for ascii in [false, true] {
            let mut out = Vec::new();
            write(&m, ascii, &mut out).unwrap();
            let mut best = f64::INFINITY;
            for _ in 0..5 {
                let t = std::time::Instant::now();
                let back = read(&out).unwrap();
                best = best.min(t.elapsed().as_secs_f64());
                assert_eq!(back.triangles.len(), m.triangles.len());
            }
            eprintln!(
                "PLY {} read: {:.1} MB in {:.1} ms = {:.0} MB/s ({} triangles)",
                if ascii { "ASCII" } else { "binary" },
                out.len() as f64 / 1e6,
                best * 1e3,
                out.len() as f64 / 1e6 / best,
                m.triangles.len()
            );
        }
    }
}
