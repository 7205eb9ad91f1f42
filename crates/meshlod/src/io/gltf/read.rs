//! The glTF reader: container, JSON, buffers, then meshes and the node hierarchy.

use super::accessor::{self, Component, Store};
use super::json::{
    check_ref, elem, object, opt_numbers, opt_ref, opt_str, opt_uint, req_usize, show, top_array,
    Obj,
};
use super::uri::{self, Uri};
use super::{fingerprint, glb, refs, GltfSource, MeshSource, PrimitiveSource, Streams};
use crate::io::{max_elements, FormatError, Location, Matrix4, Part, Scene};
use crate::mesh::Mesh;
use serde_json::Value;
use std::path::Path;
use std::sync::Arc;

/// Extensions that store geometry compressed; meshlod refuses them.
const COMPRESSED: [&str; 3] = [
    "KHR_draco_mesh_compression",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
];

fn compressed(name: &str, location: Location, subject: &str) -> FormatError {
    FormatError::new(
        location,
        format!(
            "{subject} uses {name} (compressed geometry), which meshlod does not decode; \
             decompress it first (e.g. gltfpack -noq or gltf-transform)"
        ),
    )
}

/// Whether meshlod can honour `name` in `extensionsRequired`: it implements it
/// (`KHR_mesh_quantization`, `EXT_mesh_gpu_instancing`), or it only concerns
/// materials, textures, lights or metadata, which are passed through untouched.
fn required_supported(name: &str) -> bool {
    matches!(
        name,
        "KHR_mesh_quantization"
            | "EXT_mesh_gpu_instancing"
            | "KHR_lights_punctual"
            | "EXT_lights_image_based"
            | "KHR_xmp_json_ld"
            | "KHR_animation_pointer"
            | "KHR_node_visibility"
            | "MSFT_texture_dds"
    ) || name.starts_with("KHR_materials_")
        || name.starts_with("KHR_texture_")
        || name.starts_with("EXT_texture_")
}

/// Reads a `.gltf` or `.glb` (see the module documentation).
pub(super) fn read(data: &[u8], base_dir: Option<&Path>) -> Result<Scene, FormatError> {
    let is_glb = data.starts_with(glb::MAGIC);
    let (json, json_offset, bin) = if is_glb {
        let g = glb::parse(data)?;
        (g.json, Some(g.json_offset), g.bin)
    } else {
        (data, None, None)
    };
    let mut doc = parse_json(json, json_offset)?;
    let Some(root) = doc.as_object_mut() else {
        return Err(FormatError::new(
            Location::File,
            "the glTF JSON is not an object",
        ));
    };
    check_asset(root)?;
    check_extensions(root)?;
    let buffers = load_buffers(root, is_glb.then_some(bin), base_dir)?;
    let views = accessor::parse_views(root, buffers.len(), |b| {
        buffers.get(b)?.as_ref().map(|d| d.len())
    })?;
    let total = buffers
        .iter()
        .flatten()
        .fold(data.len(), |t, b| t.saturating_add(b.len()));
    let max_count = usize::try_from(max_elements(total, 1)).unwrap_or(usize::MAX);
    let accessors = accessor::parse_accessors(root, &views, max_count)?;
    let (n_acc, n_views) = (accessors.len(), views.len());
    refs::accessors(root, &mut |kind, i, what, v| {
        check_ref(v, what, kind, i, n_acc, "accessors").map(|_| ())
    })?;
    refs::views(root, &mut |kind, i, what, v| {
        check_ref(v, what, kind, i, n_views, "buffer views").map(|_| ())
    })?;
    let store = Store {
        buffers: buffers
            .iter()
            .map(|b| b.as_deref().unwrap_or(&[]))
            .collect(),
        views,
        accessors,
    };
    let root: &Obj = root;
    let meshes = top_array(root, "meshes")?;
    let materials = top_array(root, "materials")?;
    let instances = scene_instances(root, &store, meshes.len())?;
    let mut parts = Vec::with_capacity(meshes.len());
    let mut sources = Vec::with_capacity(meshes.len());
    for ((m, v), instances) in meshes.iter().enumerate().zip(instances) {
        let (name, mesh, primitives) = read_mesh(&store, m, v, materials)?;
        sources.push(MeshSource {
            fingerprint: fingerprint(&mesh),
            primitives,
            rewrite: false,
            morph_from: None,
        });
        parts.push(Part {
            name,
            mesh,
            instances,
        });
    }
    drop(store);
    Ok(Scene {
        parts,
        material_libraries: Vec::new(),
        gltf: Some(Box::new(GltfSource {
            document: doc,
            buffers,
            base_dir: base_dir.map(Path::to_path_buf),
            meshes: sources,
        })),
    })
}

/// Parses the JSON text; errors point at the line (`.gltf`) or byte (`.glb`).
fn parse_json(text: &[u8], glb_offset: Option<usize>) -> Result<Value, FormatError> {
    let (mut text, glb_offset) = match text.strip_prefix(b"\xEF\xBB\xBF") {
        Some(rest) => (rest, glb_offset.map(|o| o + 3)),
        None => (text, glb_offset),
    };
    if glb_offset.is_some() {
        // Some writers pad the JSON chunk with zeros instead of spaces.
        while let Some(rest) = text.strip_suffix(b"\0") {
            text = rest;
        }
    }
    if text.iter().all(u8::is_ascii_whitespace) {
        let location = glb_offset.map_or(Location::File, |o| Location::Byte(o as u64));
        return Err(FormatError::new(location, "empty glTF JSON"));
    }
    serde_json::from_slice(text).map_err(|e| {
        if glb_offset.is_none() && text.iter().find(|b| !b.is_ascii_whitespace()) != Some(&b'{') {
            // Neither container: say so instead of a JSON syntax error at line 1.
            let head: String = text
                .iter()
                .take(4)
                .map(|&b| if b.is_ascii_graphic() { b as char } else { '.' })
                .collect();
            return FormatError::new(
                Location::Byte(0),
                format!(
                    "neither a GLB (it starts with \"{head}\", not the \"glTF\" magic) nor glTF JSON (no '{{' first)"
                ),
            );
        }
        let full = e.to_string();
        let message = match full.rfind(" at line ") {
            Some(cut) => format!("invalid JSON: {} (column {})", &full[..cut], e.column()),
            None => format!("invalid JSON: {full}"),
        };
        let location = match glb_offset {
            None => Location::Line(e.line() as u64),
            Some(o) => {
                // Byte of (line, column) inside the chunk.
                let line_start = text
                    .split_inclusive(|&b| b == b'\n')
                    .take(e.line().saturating_sub(1))
                    .map(<[u8]>::len)
                    .sum::<usize>();
                Location::Byte((o + line_start + e.column().saturating_sub(1)) as u64)
            }
        };
        FormatError::new(location, message)
    })
}

fn check_asset(root: &Obj) -> Result<(), FormatError> {
    let file = |m: String| FormatError::new(Location::File, m);
    let asset = root
        .get("asset")
        .and_then(Value::as_object)
        .ok_or_else(|| file("no \"asset\" object: not a glTF 2.0 document".into()))?;
    let version = |key: &str| -> Result<Option<(u64, u64)>, FormatError> {
        let Some(v) = asset.get(key) else {
            return Ok(None);
        };
        let parsed = v.as_str().and_then(|s| {
            let (a, b) = s.split_once('.')?;
            Some((a.parse().ok()?, b.parse().ok()?))
        });
        parsed
            .map(Some)
            .ok_or_else(|| file(format!("asset.{key} {} is not MAJOR.MINOR", show(v))))
    };
    match version("version")? {
        None => return Err(file("asset has no \"version\"".into())),
        Some((2, _)) => {}
        Some((major, minor)) => {
            return Err(file(format!(
            "glTF version {major}.{minor}; meshlod reads glTF 2.x (convert glTF 1.0 files first)"
        )))
        }
    }
    if let Some((major, minor)) = version("minVersion")? {
        if (major, minor) > (2, 0) {
            return Err(file(format!(
                "the document needs glTF {major}.{minor}; meshlod reads glTF 2.0"
            )));
        }
    }
    Ok(())
}

fn check_extensions(root: &Obj) -> Result<(), FormatError> {
    let names = |key: &str| -> Result<Vec<&str>, FormatError> {
        top_array(root, key)?
            .iter()
            .map(|v| {
                v.as_str().ok_or_else(|| {
                    FormatError::new(
                        Location::File,
                        format!("\"{key}\" holds a non-string {}", show(v)),
                    )
                })
            })
            .collect()
    };
    let used = names("extensionsUsed")?;
    let required = names("extensionsRequired")?;
    for name in used.iter().chain(&required) {
        if COMPRESSED.contains(name) {
            return Err(compressed(name, Location::File, "file"));
        }
    }
    for name in &required {
        if !required_supported(name) {
            return Err(FormatError::new(
                Location::File,
                format!(
                    "file requires extension {name}, which meshlod does not support, \
                     so it cannot be read correctly"
                ),
            ));
        }
    }
    for (i, v) in top_array(root, "bufferViews")?.iter().enumerate() {
        if let Some(ext) = v.get("extensions").and_then(Value::as_object) {
            if let Some(name) = COMPRESSED.iter().find(|n| ext.contains_key(**n)) {
                return Err(compressed(
                    name,
                    Location::Element("bufferView", i as u64),
                    "its data",
                ));
            }
        }
    }
    Ok(())
}

/// Loads the data of every buffer a buffer view uses. `glb_bin` is `Some` for GLB
/// input (holding the BIN chunk, if any).
fn load_buffers(
    root: &Obj,
    glb_bin: Option<Option<&[u8]>>,
    base_dir: Option<&Path>,
) -> Result<Vec<Option<Arc<[u8]>>>, FormatError> {
    let buffers = top_array(root, "buffers")?;
    let mut needed = vec![false; buffers.len()];
    for v in top_array(root, "bufferViews")? {
        let b = v.get("buffer").and_then(Value::as_u64);
        if let Some(n) = b.and_then(|b| needed.get_mut(usize::try_from(b).ok()?)) {
            *n = true;
        }
    }
    buffers
        .iter()
        .zip(needed)
        .enumerate()
        .map(|(i, (v, needed))| {
            needed
                .then(|| load_buffer(v, i, glb_bin, base_dir))
                .transpose()
        })
        .collect()
}

fn load_buffer(
    v: &Value,
    i: usize,
    glb_bin: Option<Option<&[u8]>>,
    base_dir: Option<&Path>,
) -> Result<Arc<[u8]>, FormatError> {
    const K: &str = "buffer";
    let o = object(v, K, i)?;
    let length = req_usize(o, "byteLength", K, i)?;
    let owned;
    let data: &[u8] = match o.get("uri") {
        None => match glb_bin {
            Some(Some(bin)) if i == 0 => bin,
            Some(None) if i == 0 => {
                return Err(elem(K, i, "has no uri, and the GLB has no BIN chunk"));
            }
            _ => {
                return Err(elem(
                    K,
                    i,
                    "has no uri (only buffer 0 of a .glb may use the BIN chunk)",
                ))
            }
        },
        Some(Value::String(u)) => match uri::parse(u).map_err(|m| elem(K, i, m))? {
            Uri::Data { bytes, .. } => {
                owned = bytes;
                &owned
            }
            Uri::Relative(rel) => {
                let dir = base_dir.ok_or_else(|| {
                    elem(
                        K,
                        i,
                        format!(
                            "refers to the external file \"{u}\", but no directory was given to look for it"
                        ),
                    )
                })?;
                let path = dir.join(&rel);
                owned = std::fs::read(&path).map_err(|e| {
                    elem(
                        K,
                        i,
                        format!("cannot read its file \"{}\": {e}", path.display()),
                    )
                })?;
                &owned
            }
        },
        Some(other) => {
            return Err(elem(
                K,
                i,
                format!("\"uri\" must be a string, found {}", show(other)),
            ))
        }
    };
    let bytes = data.get(..length).ok_or_else(|| {
        elem(
            K,
            i,
            format!(
                "byteLength is {length}, but its data has only {} bytes",
                data.len()
            ),
        )
    })?;
    Ok(Arc::from(bytes))
}

/// Which accessor feeds each modelled attribute (and `POSITION` last): primitives of
/// one mesh with the same key share their vertices.
type BlockKey = [Option<usize>; 8];

const ATTRIBUTES: [(&str, u8); 7] = [
    ("NORMAL", Streams::NORMAL),
    ("TANGENT", Streams::TANGENT),
    ("TEXCOORD_0", Streams::UV0),
    ("TEXCOORD_1", Streams::UV1),
    ("COLOR_0", Streams::COLOR),
    ("JOINTS_0", Streams::JOINTS),
    ("WEIGHTS_0", Streams::WEIGHTS),
];

/// A block of vertices appended to the part's mesh.
struct Block {
    key: BlockKey,
    base: u32,
    count: u32,
    streams: Streams,
    color_rgb: bool,
    joints_u8: bool,
}

fn attribute(attrs: &Obj, name: &str) -> Option<usize> {
    attrs
        .get(name)
        .and_then(Value::as_u64)
        .and_then(|a| usize::try_from(a).ok())
}

/// Reads glTF mesh `m` into one mesh (see the module documentation).
fn read_mesh(
    store: &Store<'_>,
    m: usize,
    v: &Value,
    materials: &[Value],
) -> Result<(Option<String>, Mesh, Vec<PrimitiveSource>), FormatError> {
    const K: &str = "mesh";
    let o = object(v, K, m)?;
    let name = opt_str(o, "name").map(str::to_string);
    let prims = match o.get("primitives") {
        Some(Value::Array(a)) => a.as_slice(),
        _ => return Err(elem(K, m, "has no \"primitives\" array")),
    };
    let mut mesh = Mesh {
        groups: Some(Vec::new()),
        ..Mesh::default()
    };
    let mut blocks: Vec<Block> = Vec::new();
    let mut sources = Vec::with_capacity(prims.len());
    for (p, pv) in prims.iter().enumerate() {
        let err = |msg: String| elem(K, m, format!("primitive {p}: {msg}"));
        let po = pv
            .as_object()
            .ok_or_else(|| err(format!("must be an object, found {}", show(pv))))?;
        if let Some(ext) = po.get("extensions").and_then(Value::as_object) {
            if let Some(name) = COMPRESSED.iter().find(|n| ext.contains_key(**n)) {
                return Err(compressed(
                    name,
                    Location::Element(K, m as u64),
                    &format!("primitive {p}"),
                ));
            }
        }
        let mode = opt_uint(po, "mode", K, m)?.unwrap_or(4);
        if mode > 6 {
            return Err(err(format!("unknown mode {mode}")));
        }
        let attrs = po
            .get("attributes")
            .and_then(Value::as_object)
            .ok_or_else(|| err("has no \"attributes\" object".into()))?;
        let material = opt_ref(po, "material", K, m, materials.len(), "materials")?;
        let indices = opt_ref(po, "indices", K, m, store.accessors.len(), "accessors")?;
        mesh.group_names.push(
            material
                .and_then(|i| materials.get(i))
                .and_then(|mat| mat.get("name"))
                .and_then(Value::as_str)
                .map_or_else(
                    || material.map_or_else(|| "default".into(), |i| format!("material {i}")),
                    str::to_string,
                ),
        );
        let mut source = PrimitiveSource {
            mode: mode as u32,
            material,
            attribute_names: attrs.keys().cloned().collect(),
            group: None,
            streams: Streams::default(),
            color_rgb: false,
            joints_u8: false,
        };
        let position = attribute(attrs, "POSITION");
        let Some(position) = position.filter(|_| matches!(mode, 4..=6)) else {
            // Points, lines, or no positions: passed through untouched.
            sources.push(source);
            continue;
        };
        let mut key: BlockKey = [None; 8];
        for (k, (name, _)) in ATTRIBUTES.iter().enumerate() {
            key[k] = attribute(attrs, name);
        }
        key[7] = Some(position);
        let block = match blocks.iter().position(|b| b.key == key) {
            Some(b) => b,
            None => {
                let block = read_block(store, m, p, &key, mesh.positions.len())?;
                mesh.append(&block.0, 0);
                blocks.push(block.1);
                blocks.len() - 1
            }
        };
        let Some(block) = blocks.get(block) else {
            continue;
        };
        source.group = Some(p as u32);
        source.streams = block.streams;
        source.color_rgb = block.color_rgb;
        source.joints_u8 = block.joints_u8;
        sources.push(source);
        let index_data: Vec<u32> = match indices {
            Some(a) => {
                let what = format!("indices of mesh {m} primitive {p}");
                let idx = store.uints::<1>(a, &what, true)?;
                if let Some((k, [i])) = idx.iter().enumerate().find(|(_, [i])| *i >= block.count) {
                    return Err(err(format!(
                        "index {i} (element {k} of accessor {a}) is out of range for {} vertices",
                        block.count
                    )));
                }
                idx.into_iter().map(|[i]| i).collect()
            }
            None => (0..block.count).collect(),
        };
        let before = mesh.triangles.len();
        triangulate(mode, &index_data, block.base, &mut mesh.triangles);
        let added = mesh.triangles.len() - before;
        if let Some(g) = &mut mesh.groups {
            g.extend(std::iter::repeat_n(p as u32, added));
        }
    }
    Ok((name, mesh, sources))
}

/// Reads the vertices of a primitive whose accessors are given by `key`; `base` is
/// the number of vertices already in the part.
fn read_block(
    store: &Store<'_>,
    m: usize,
    p: usize,
    key: &BlockKey,
    base: usize,
) -> Result<(Mesh, Block), FormatError> {
    let what = |name: &str| format!("{name} of mesh {m} primitive {p}");
    let pos = key[7].unwrap_or(0);
    let positions = store.floats::<3>(pos, &what("POSITION"))?;
    if let Some((k, bad)) = positions
        .iter()
        .enumerate()
        .find(|(_, q)| !q.iter().all(|c| c.is_finite()))
    {
        return Err(elem(
            "accessor",
            pos,
            format!("POSITION element {k} is not finite: {bad:?}"),
        ));
    }
    let n = positions.len();
    let count = |name: &str, len: usize| -> Result<(), FormatError> {
        if len == n {
            Ok(())
        } else {
            Err(elem(
                "mesh",
                m,
                format!("primitive {p}: {name} has {len} elements but POSITION has {n}"),
            ))
        }
    };
    let mut mesh = Mesh::from_triangles(positions, Vec::new());
    let mut streams = Streams::default();
    let mut color_rgb = false;
    let mut joints_u8 = false;
    for (k, (name, bit)) in ATTRIBUTES.iter().enumerate() {
        let Some(a) = key[k] else { continue };
        streams.set(*bit);
        let w = what(name);
        let at = &mut mesh.attributes;
        let len = match *bit {
            Streams::NORMAL => at.normals.insert(store.floats::<3>(a, &w)?).len(),
            Streams::TANGENT => at.tangents.insert(store.floats::<4>(a, &w)?).len(),
            Streams::UV0 => at
                .uv0
                .insert(super::flip_v(store.floats::<2>(a, &w)?))
                .len(),
            Streams::UV1 => at
                .uv1
                .insert(super::flip_v(store.floats::<2>(a, &w)?))
                .len(),
            Streams::COLOR => {
                let rgb = store.accessors.get(a).is_some_and(|acc| acc.ty == "VEC3");
                let c = if rgb {
                    color_rgb = true;
                    store
                        .floats::<3>(a, &w)?
                        .into_iter()
                        .map(|[r, g, b]| [r, g, b, 1.0])
                        .collect()
                } else {
                    store.floats::<4>(a, &w)?
                };
                at.colors.insert(c).len()
            }
            Streams::JOINTS => {
                joints_u8 = store
                    .accessors
                    .get(a)
                    .is_some_and(|acc| acc.component == Component::U8);
                let j = store.uints::<4>(a, &w, false)?;
                let j = j
                    .into_iter()
                    .map(|j| j.map(|x| u16::try_from(x).unwrap_or(u16::MAX)))
                    .collect();
                at.joints.insert(j).len()
            }
            _ => at.weights.insert(store.floats::<4>(a, &w)?).len(),
        };
        count(name, len)?;
    }
    let too_many = || {
        elem(
            "mesh",
            m,
            "has more than 2^32 vertices, which meshlod cannot index",
        )
    };
    let block = Block {
        key: *key,
        base: u32::try_from(base).map_err(|_| too_many())?,
        count: u32::try_from(n).map_err(|_| too_many())?,
        streams,
        color_rgb,
        joints_u8,
    };
    if base
        .checked_add(n)
        .and_then(|t| u32::try_from(t).ok())
        .is_none()
    {
        return Err(too_many());
    }
    Ok((mesh, block))
}

/// Appends the triangles of an index list in `mode` (4 list, 5 strip, 6 fan), offset
/// by `base`. Strips and fans drop the index-degenerate triangles used to stitch them.
/// A list's trailing incomplete triangle is ignored.
pub(super) fn triangulate(mode: u64, idx: &[u32], base: u32, out: &mut Vec<[u32; 3]>) {
    let degenerate = |t: &[u32; 3]| t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
    match mode {
        4 => out.extend(
            idx.chunks_exact(3)
                .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
        ),
        5 => out.extend(idx.windows(3).enumerate().filter_map(|(i, w)| {
            // Every other triangle of a strip is reversed to keep the winding.
            let t = if i % 2 == 0 {
                [w[0], w[1], w[2]]
            } else {
                [w[1], w[0], w[2]]
            };
            (!degenerate(&t)).then(|| t.map(|v| v + base))
        })),
        6 => {
            if let Some((&first, rest)) = idx.split_first() {
                out.extend(rest.windows(2).filter_map(|w| {
                    let t = [w[0], w[1], first];
                    (!degenerate(&t)).then(|| t.map(|v| v + base))
                }));
            }
        }
        _ => {}
    }
}

/// A column-major 4×4 matrix in `f64`: element (row r, column c) at `c * 4 + r`.
type M64 = [f64; 16];

const I64: M64 = [
    1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
];

fn mul(a: &M64, b: &M64) -> M64 {
    let mut out = [0.0; 16];
    for c in 0..4 {
        for r in 0..4 {
            out[c * 4 + r] = (0..4).map(|k| a[k * 4 + r] * b[c * 4 + k]).sum();
        }
    }
    out
}

/// The matrix translate(t) · rotate(q) · scale(s); `q` is (x, y, z, w), normalised
/// here (a zero quaternion means no rotation).
pub(super) fn trs(t: [f64; 3], q: [f64; 4], s: [f64; 3]) -> M64 {
    let len = q.iter().map(|x| x * x).sum::<f64>().sqrt();
    let [x, y, z, w] = if len > 0.0 {
        q.map(|c| c / len)
    } else {
        [0.0, 0.0, 0.0, 1.0]
    };
    let r = [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - z * w),
            2.0 * (x * z + y * w),
        ],
        [
            2.0 * (x * y + z * w),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - x * w),
        ],
        [
            2.0 * (x * z - y * w),
            2.0 * (y * z + x * w),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ];
    let mut out = I64;
    for c in 0..3 {
        for (row, rr) in r.iter().enumerate() {
            out[c * 4 + row] = rr[c] * s[c];
        }
    }
    out[12..15].copy_from_slice(&t);
    out
}

fn to_f32(m: &M64) -> Option<Matrix4> {
    let mut out = [[0.0f32; 4]; 4];
    for (c, col) in out.iter_mut().enumerate() {
        for (r, x) in col.iter_mut().enumerate() {
            *x = m[c * 4 + r] as f32;
            if !x.is_finite() {
                return None;
            }
        }
    }
    Some(out)
}

/// A parsed node.
struct Node {
    local: M64,
    mesh: Option<usize>,
    children: Vec<usize>,
    /// `EXT_mesh_gpu_instancing` transforms, applied after the node's world matrix.
    gpu_instances: Option<Vec<M64>>,
}

fn parse_node(
    store: &Store<'_>,
    n: usize,
    v: &Value,
    node_count: usize,
    mesh_count: usize,
) -> Result<Node, FormatError> {
    const K: &str = "node";
    let o = object(v, K, n)?;
    let mesh = opt_ref(o, "mesh", K, n, mesh_count, "meshes")?;
    let children = match o.get("children") {
        None => Vec::new(),
        Some(Value::Array(a)) => a
            .iter()
            .map(|c| check_ref(c, "a child", K, n, node_count, "nodes"))
            .collect::<Result<_, _>>()?,
        Some(other) => {
            return Err(elem(
                K,
                n,
                format!("\"children\" must be an array, found {}", show(other)),
            ))
        }
    };
    let local = match opt_numbers::<16>(o, "matrix", K, n)? {
        Some(m) => m,
        None => trs(
            opt_numbers(o, "translation", K, n)?.unwrap_or([0.0; 3]),
            opt_numbers(o, "rotation", K, n)?.unwrap_or([0.0, 0.0, 0.0, 1.0]),
            opt_numbers(o, "scale", K, n)?.unwrap_or([1.0; 3]),
        ),
    };
    let inst = o
        .get("extensions")
        .and_then(|e| e.get("EXT_mesh_gpu_instancing"))
        .and_then(|e| e.get("attributes"))
        .and_then(Value::as_object);
    let gpu_instances = match inst {
        Some(attrs) if mesh.is_some() && !attrs.is_empty() => {
            let what = |name: &str| format!("EXT_mesh_gpu_instancing {name} of node {n}");
            let get = |name| attribute(attrs, name);
            let t = get("TRANSLATION")
                .map(|a| store.floats::<3>(a, &what("TRANSLATION")))
                .transpose()?;
            let r = get("ROTATION")
                .map(|a| store.floats::<4>(a, &what("ROTATION")))
                .transpose()?;
            let s = get("SCALE")
                .map(|a| store.floats::<3>(a, &what("SCALE")))
                .transpose()?;
            let lens = [
                t.as_ref().map(Vec::len),
                r.as_ref().map(Vec::len),
                s.as_ref().map(Vec::len),
            ];
            let count = lens.iter().flatten().copied().max().unwrap_or(0);
            if lens.iter().flatten().any(|&l| l != count) {
                return Err(elem(
                    K,
                    n,
                    "EXT_mesh_gpu_instancing attributes have different counts",
                ));
            }
            let mut out = Vec::with_capacity(count);
            for i in 0..count {
                let at = |v: &Option<Vec<[f32; 3]>>, default| {
                    v.as_ref()
                        .and_then(|v| v.get(i))
                        .map_or(default, |e| e.map(f64::from))
                };
                let rot = r
                    .as_ref()
                    .and_then(|r| r.get(i))
                    .map_or([0.0, 0.0, 0.0, 1.0], |e| e.map(f64::from));
                out.push(trs(at(&t, [0.0; 3]), rot, at(&s, [1.0; 3])));
            }
            Some(out)
        }
        _ => None,
    };
    Ok(Node {
        local,
        mesh,
        children,
        gpu_instances,
    })
}

/// World matrices of every node of the default scene that draws each mesh: the
/// scene `scene` (or scene 0); when the document has no scenes, every root node.
fn scene_instances(
    root: &Obj,
    store: &Store<'_>,
    mesh_count: usize,
) -> Result<Vec<Vec<Matrix4>>, FormatError> {
    let node_values = top_array(root, "nodes")?;
    let nodes = node_values
        .iter()
        .enumerate()
        .map(|(n, v)| parse_node(store, n, v, node_values.len(), mesh_count))
        .collect::<Result<Vec<_>, _>>()?;
    let scenes = top_array(root, "scenes")?;
    let roots: Vec<usize> = if scenes.is_empty() {
        let mut has_parent = vec![false; nodes.len()];
        for c in nodes.iter().flat_map(|n| &n.children) {
            if let Some(h) = has_parent.get_mut(*c) {
                *h = true;
            }
        }
        (0..nodes.len()).filter(|&n| !has_parent[n]).collect()
    } else {
        let s = match root.get("scene") {
            None => 0,
            Some(v) => check_ref(v, "\"scene\"", "scene", 0, scenes.len(), "scenes")
                .map_err(|e| FormatError::new(Location::File, e.message))?,
        };
        let so = object(scenes.get(s).unwrap_or(&Value::Null), "scene", s)?;
        match so.get("nodes") {
            None => Vec::new(),
            Some(Value::Array(a)) => a
                .iter()
                .map(|v| check_ref(v, "a root node", "scene", s, nodes.len(), "nodes"))
                .collect::<Result<_, _>>()?,
            Some(other) => {
                return Err(elem(
                    "scene",
                    s,
                    format!("\"nodes\" must be an array, found {}", show(other)),
                ))
            }
        }
    };
    let mut instances = vec![Vec::new(); mesh_count];
    let mut visited = vec![false; nodes.len()];
    let mut stack: Vec<(usize, M64)> = roots.iter().rev().map(|&r| (r, I64)).collect();
    while let Some((n, parent)) = stack.pop() {
        let (Some(node), Some(seen)) = (nodes.get(n), visited.get_mut(n)) else {
            continue;
        };
        if *seen {
            return Err(elem(
                "node",
                n,
                "is reached twice from the scene: the node hierarchy has a cycle or a node with two parents",
            ));
        }
        *seen = true;
        let world = mul(&parent, &node.local);
        if let Some(out) = node.mesh.and_then(|m| instances.get_mut(m)) {
            let not_finite = || elem("node", n, "its world transform is not finite");
            match &node.gpu_instances {
                None => out.push(to_f32(&world).ok_or_else(not_finite)?),
                Some(list) => {
                    for inst in list {
                        out.push(to_f32(&mul(&world, inst)).ok_or_else(not_finite)?);
                    }
                }
            }
        }
        stack.extend(node.children.iter().rev().map(|&c| (c, world)));
    }
    Ok(instances)
}
