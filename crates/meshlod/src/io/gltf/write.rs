//! The glTF writer: puts each part's mesh back into the source document (or builds
//! a fresh one), garbage-collects accessors and buffer views, repacks everything into
//! one buffer, and stores external images as the output kind needs.

use super::accessor::{self, View};
use super::json::{elem, num, top_array, Obj};
use super::uri::{self, Uri};
use super::{fingerprint, glb, GltfSource, MeshSource, Streams};
use crate::io::{FormatError, Location, Part, Scene, WriteError, IDENTITY};
use crate::mesh::Mesh;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// `bufferView.target` for vertex attributes.
const ARRAY_BUFFER: u32 = 34962;
/// `bufferView.target` for indices.
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

/// Where the output goes, which decides how the buffer and external images are stored.
enum Target<'a> {
    /// A `.glb`: the buffer is the BIN chunk; images are embedded in it.
    Glb,
    /// A self-contained `.gltf`: buffer and external images as data URIs.
    Embedded,
    /// A `.gltf` in `dir`, the buffer in the file `bin_name` next to it.
    Files { dir: &'a Path, bin_name: &'a str },
}

/// A finished document.
struct Built {
    doc: Value,
    bin: Vec<u8>,
    /// Image files to copy: (from, to).
    copies: Vec<(PathBuf, PathBuf)>,
}

pub(super) fn write_glb(scene: &Scene) -> Result<Vec<u8>, FormatError> {
    let built = build(scene, &Target::Glb)?;
    let json = serde_json::to_vec(&built.doc).map_err(internal)?;
    glb::write(&json, &built.bin)
}

pub(super) fn write_embedded(scene: &Scene) -> Result<Vec<u8>, FormatError> {
    let built = build(scene, &Target::Embedded)?;
    serde_json::to_vec_pretty(&built.doc).map_err(internal)
}

pub(super) fn write_file(path: &Path, scene: &Scene, glb: bool) -> Result<(), WriteError> {
    if glb {
        std::fs::write(path, write_glb(scene)?)?;
        return Ok(());
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let stem = path
        .file_stem()
        .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    let bin_name = format!("{stem}.bin");
    refuse_overwriting_source(scene, &dir.join(&bin_name))?;
    let built = build(
        scene,
        &Target::Files {
            dir,
            bin_name: &bin_name,
        },
    )?;
    std::fs::write(
        path,
        serde_json::to_vec_pretty(&built.doc).map_err(internal)?,
    )?;
    if !built.bin.is_empty() {
        std::fs::write(dir.join(&bin_name), &built.bin)?;
    }
    for (from, to) in &built.copies {
        if to.exists() || !from.is_file() {
            continue;
        }
        if let Some(parent) = to.parent() {
            std::fs::create_dir_all(parent)?;
        }
        std::fs::copy(from, to)?;
    }
    Ok(())
}

/// An error when `bin` is an external file (buffer or image) of the glTF the scene
/// was read from: writing `x.gltf` beside an input whose buffer is `x.bin` would
/// destroy the input (its buffer replaced by the output's).
fn refuse_overwriting_source(scene: &Scene, bin: &Path) -> Result<(), FormatError> {
    let Some(src) = &scene.gltf else {
        return Ok(());
    };
    let (Some(base), Ok(target)) = (&src.base_dir, bin.canonicalize()) else {
        return Ok(()); // nothing on disk there yet, or no files to clash with
    };
    for kind in ["buffers", "images"] {
        let Some(list) = src.document[kind].as_array() else {
            continue;
        };
        for (i, item) in list.iter().enumerate() {
            let Some(u) = item["uri"].as_str() else {
                continue;
            };
            if let Ok(uri::Uri::Relative(rel)) = uri::parse(u) {
                if base.join(&rel).canonicalize().is_ok_and(|p| p == target) {
                    return Err(FormatError::new(
                        Location::File,
                        format!(
                            "writing the binary data to {} would overwrite {} {i} of the glTF \
                             this scene was read from; choose another output name",
                            bin.display(),
                            &kind[..kind.len() - 1]
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}

fn internal(e: impl std::fmt::Display) -> FormatError {
    FormatError::new(
        Location::File,
        format!("internal error while writing glTF: {e}"),
    )
}

fn build(scene: &Scene, target: &Target<'_>) -> Result<Built, FormatError> {
    for (m, part) in scene.parts.iter().enumerate() {
        part.mesh
            .validate()
            .map_err(|e| elem("mesh", m, format!("cannot be written: {e}")))?;
    }
    let ((mut doc, pool), buffers, base_dir) = match &scene.gltf {
        Some(src) => (
            rebuild(scene, src)?,
            src.buffers.as_slice(),
            src.base_dir.as_deref(),
        ),
        None => (fresh(scene)?, &[][..], None),
    };
    let root = doc
        .as_object_mut()
        .ok_or_else(|| internal("document is not an object"))?;
    let (mut bin, mut views) = pack(root, pool, buffers)?;
    let copies = images(root, &mut bin, &mut views, target, base_dir)?;
    if views.is_empty() {
        root.remove("bufferViews");
    } else {
        root.insert("bufferViews".into(), Value::Array(views));
    }
    if bin.is_empty() {
        root.remove("buffers");
    } else {
        let mut buffer = Obj::new();
        buffer.insert("byteLength".into(), num(bin.len()));
        match target {
            Target::Glb => {}
            Target::Embedded => {
                buffer.insert(
                    "uri".into(),
                    Value::from(uri::data_uri("application/octet-stream", &bin)),
                );
                bin.clear();
            }
            Target::Files { bin_name, .. } => {
                buffer.insert("uri".into(), Value::from(uri::percent_encode(bin_name)));
            }
        }
        root.insert("buffers".into(), Value::Array(vec![Value::Object(buffer)]));
    }
    Ok(Built { doc, bin, copies })
}

/// New accessors and buffer views, numbered after the source document's.
#[derive(Default)]
struct Pool {
    /// Accessor objects: the source's (by original index), then new ones.
    accessors: Vec<Value>,
    /// Buffer views: the source's, then new ones.
    views: Vec<PoolView>,
}

enum PoolView {
    /// A view of the source document (its JSON).
    Source(Value),
    /// A new view and its bytes.
    New { data: Vec<u8>, target: u32 },
}

impl Pool {
    fn add(&mut self, data: Vec<u8>, target: u32, mut acc: Obj) -> usize {
        acc.insert("bufferView".into(), num(self.views.len()));
        self.views.push(PoolView::New { data, target });
        self.accessors.push(Value::Object(acc));
        self.accessors.len() - 1
    }

    fn floats<const N: usize>(&mut self, v: &[[f32; N]], bounds: bool) -> usize {
        let mut data = Vec::with_capacity(v.len() * N * 4);
        for x in v.iter().flatten() {
            data.extend_from_slice(&x.to_le_bytes());
        }
        let mut acc = accessor_json(5126, v.len(), N);
        if bounds {
            let mut lo = [f32::INFINITY; N];
            let mut hi = [f32::NEG_INFINITY; N];
            for e in v {
                for k in 0..N {
                    lo[k] = lo[k].min(e[k]);
                    hi[k] = hi[k].max(e[k]);
                }
            }
            let list =
                |a: [f32; N]| Value::Array(a.iter().map(|&x| Value::from(f64::from(x))).collect());
            if !v.is_empty() {
                acc.insert("min".into(), list(lo));
                acc.insert("max".into(), list(hi));
            }
        }
        self.add(data, ARRAY_BUFFER, acc)
    }

    /// Indices as `UNSIGNED_SHORT` when every vertex index fits below the restart
    /// value 65 535, else `UNSIGNED_INT`.
    fn indices(&mut self, tris: &[[u32; 3]], vertices: usize) -> usize {
        let flat = tris.as_flattened();
        let (code, data) = if vertices <= usize::from(u16::MAX) {
            let mut d = Vec::with_capacity(flat.len() * 2);
            for &i in flat {
                d.extend_from_slice(&(i as u16).to_le_bytes());
            }
            (5123, d)
        } else {
            let mut d = Vec::with_capacity(flat.len() * 4);
            for &i in flat {
                d.extend_from_slice(&i.to_le_bytes());
            }
            (5125, d)
        };
        self.add(
            data,
            ELEMENT_ARRAY_BUFFER,
            accessor_json(code, flat.len(), 1),
        )
    }

    fn joints(&mut self, j: &[[u16; 4]], as_u8: bool) -> usize {
        let as_u8 = as_u8 && j.iter().flatten().all(|&x| x <= 255);
        let mut data = Vec::with_capacity(j.len() * if as_u8 { 4 } else { 8 });
        for &x in j.iter().flatten() {
            if as_u8 {
                data.push(x as u8);
            } else {
                data.extend_from_slice(&x.to_le_bytes());
            }
        }
        let code = if as_u8 { 5121 } else { 5123 };
        self.add(data, ARRAY_BUFFER, accessor_json(code, j.len(), 4))
    }
}

fn accessor_json(component: u32, count: usize, n: usize) -> Obj {
    let ty = match n {
        1 => "SCALAR",
        2 => "VEC2",
        3 => "VEC3",
        _ => "VEC4",
    };
    let mut o = Obj::new();
    o.insert("componentType".into(), Value::from(component));
    o.insert("count".into(), num(count));
    o.insert("type".into(), Value::from(ty));
    o
}

/// Groups the triangles of `mesh` by group id (ascending).
fn by_group(mesh: &Mesh) -> BTreeMap<u32, Vec<u32>> {
    let mut out: BTreeMap<u32, Vec<u32>> = BTreeMap::new();
    for t in 0..mesh.triangles.len() {
        out.entry(mesh.group(t)).or_default().push(t as u32);
    }
    out
}

/// The triangles `tris` of `mesh` as a compact mesh of their vertices (in first-use
/// order) with the attribute streams in `streams`. `remap` is scratch space, one
/// `u32::MAX` per vertex of `mesh`, and is left that way.
fn extract(mesh: &Mesh, tris: &[u32], streams: Streams, remap: &mut [u32]) -> Mesh {
    let mut order: Vec<u32> = Vec::new();
    let mut triangles = Vec::with_capacity(tris.len());
    for &t in tris {
        let Some(tri) = mesh.triangles.get(t as usize) else {
            continue;
        };
        let mut out = [0u32; 3];
        for (o, &i) in out.iter_mut().zip(tri) {
            if let Some(r) = remap.get_mut(i as usize) {
                if *r == u32::MAX {
                    *r = order.len() as u32;
                    order.push(i);
                }
                *o = *r;
            }
        }
        triangles.push(out);
    }
    for &i in &order {
        if let Some(r) = remap.get_mut(i as usize) {
            *r = u32::MAX;
        }
    }
    fn g<T: Copy>(s: &Option<Vec<T>>, on: bool, order: &[u32]) -> Option<Vec<T>> {
        let s = s.as_ref().filter(|_| on)?;
        order.iter().map(|&i| s.get(i as usize).copied()).collect()
    }
    let a = &mesh.attributes;
    let mut sub = Mesh::from_triangles(
        order
            .iter()
            .filter_map(|&i| mesh.positions.get(i as usize).copied())
            .collect(),
        triangles,
    );
    let at = &mut sub.attributes;
    at.normals = g(&a.normals, streams.has(Streams::NORMAL), &order);
    at.tangents = g(&a.tangents, streams.has(Streams::TANGENT), &order);
    at.uv0 = g(&a.uv0, streams.has(Streams::UV0), &order);
    at.uv1 = g(&a.uv1, streams.has(Streams::UV1), &order);
    at.colors = g(&a.colors, streams.has(Streams::COLOR), &order);
    at.joints = g(&a.joints, streams.has(Streams::JOINTS), &order);
    at.weights = g(&a.weights, streams.has(Streams::WEIGHTS), &order);
    sub
}

/// `v` scaled to unit length (kept bit-exact when it is unit within 1e-5), or
/// `fallback` when it has no direction.
fn unit(v: [f32; 3], fallback: [f32; 3]) -> [f32; 3] {
    let len = v
        .iter()
        .map(|&x| f64::from(x) * f64::from(x))
        .sum::<f64>()
        .sqrt();
    if (len - 1.0).abs() <= 1e-5 {
        v
    } else if len > 0.0 && len.is_finite() {
        v.map(|x| (f64::from(x) / len) as f32)
    } else {
        fallback
    }
}

/// Writes the vertex streams and indices of `sub` as new accessors; returns the
/// primitive's `attributes` object and its `indices` accessor.
fn geometry(pool: &mut Pool, sub: &Mesh, color_rgb: bool, joints_u8: bool) -> (Obj, usize) {
    let mut attrs = Obj::new();
    let a = &sub.attributes;
    attrs.insert("POSITION".into(), num(pool.floats(&sub.positions, true)));
    if let Some(n) = &a.normals {
        let n: Vec<[f32; 3]> = n.iter().map(|&v| unit(v, [0.0, 0.0, 1.0])).collect();
        attrs.insert("NORMAL".into(), num(pool.floats(&n, false)));
    }
    if let Some(t) = &a.tangents {
        let t: Vec<[f32; 4]> = t
            .iter()
            .map(|&[x, y, z, w]| {
                let [x, y, z] = unit([x, y, z], [1.0, 0.0, 0.0]);
                [x, y, z, if w < 0.0 { -1.0 } else { 1.0 }]
            })
            .collect();
        attrs.insert("TANGENT".into(), num(pool.floats(&t, false)));
    }
    if let Some(uv) = &a.uv0 {
        let uv = super::flip_v(uv.clone());
        attrs.insert("TEXCOORD_0".into(), num(pool.floats(&uv, false)));
    }
    if let Some(uv) = &a.uv1 {
        let uv = super::flip_v(uv.clone());
        attrs.insert("TEXCOORD_1".into(), num(pool.floats(&uv, false)));
    }
    if let Some(c) = &a.colors {
        let acc = if color_rgb {
            let rgb: Vec<[f32; 3]> = c.iter().map(|&[r, g, b, _]| [r, g, b]).collect();
            pool.floats(&rgb, false)
        } else {
            pool.floats(c, false)
        };
        attrs.insert("COLOR_0".into(), num(acc));
    }
    if let Some(j) = &a.joints {
        attrs.insert("JOINTS_0".into(), num(pool.joints(j, joints_u8)));
    }
    if let Some(w) = &a.weights {
        attrs.insert("WEIGHTS_0".into(), num(pool.floats(w, false)));
    }
    let indices = pool.indices(&sub.triangles, sub.positions.len());
    (attrs, indices)
}

/// The source document with every changed part's geometry put back.
fn rebuild(scene: &Scene, src: &GltfSource) -> Result<(Value, Pool), FormatError> {
    let mut doc = src.document.clone();
    let root = doc
        .as_object_mut()
        .ok_or_else(|| internal("source document is not an object"))?;
    let mesh_count = top_array(root, "meshes")?.len();
    if scene.parts.len() != mesh_count || src.meshes.len() != mesh_count {
        return Err(FormatError::new(
            Location::File,
            format!(
                "the scene has {} parts but its glTF document has {mesh_count} meshes; \
                 clear Scene::gltf to write a fresh document",
                scene.parts.len()
            ),
        ));
    }
    let mut pool = Pool {
        accessors: take_array(root, "accessors"),
        views: take_array(root, "bufferViews")
            .into_iter()
            .map(PoolView::Source)
            .collect(),
    };
    let mut dropped_morphs = vec![false; mesh_count];
    let mut removed = vec![false; mesh_count];
    let meshes = root
        .get_mut("meshes")
        .and_then(Value::as_array_mut)
        .ok_or_else(|| internal("no meshes"))?;
    for (m, ((part, source), mesh)) in scene
        .parts
        .iter()
        .zip(&src.meshes)
        .zip(meshes.iter_mut())
        .enumerate()
    {
        let mesh = mesh
            .as_object_mut()
            .ok_or_else(|| elem("mesh", m, "is not an object"))?;
        if let Some(name) = &part.name {
            mesh.insert("name".into(), Value::from(name.as_str()));
        }
        if !source.rewrite && fingerprint(&part.mesh) == source.fingerprint {
            continue;
        }
        let old = take_array(mesh, "primitives");
        let had_targets = old.iter().any(|p| p.get("targets").is_some());
        let mut prims = rewrite_primitives(&mut pool, part, source, old);
        if had_targets {
            for p in &mut prims {
                if let Some(p) = p.as_object_mut() {
                    p.remove("targets");
                }
            }
            mesh.remove("weights");
            if let Some(extras) = mesh.get_mut("extras").and_then(Value::as_object_mut) {
                extras.remove("targetNames");
            }
            dropped_morphs[m] = true;
        }
        removed[m] = prims.is_empty();
        mesh.insert("primitives".into(), Value::Array(prims));
    }
    if dropped_morphs.contains(&true) {
        drop_morph_weights(root, &dropped_morphs);
    }
    if removed.contains(&true) {
        remove_meshes(root, &removed);
    }
    Ok((doc, pool))
}

fn take_array(o: &mut Obj, key: &str) -> Vec<Value> {
    match o.remove(key) {
        Some(Value::Array(a)) => a,
        _ => Vec::new(),
    }
}

/// The primitives of a changed part: pass-through primitives as they were, one
/// triangle primitive per source primitive whose group still has triangles, then one
/// per group no source primitive had.
fn rewrite_primitives(
    pool: &mut Pool,
    part: &Part,
    source: &MeshSource,
    old: Vec<Value>,
) -> Vec<Value> {
    let mesh = &part.mesh;
    let groups = by_group(mesh);
    let mut remap = vec![u32::MAX; mesh.positions.len()];
    let mut prims = Vec::new();
    let mut claimed = Vec::new();
    let morph_base = source
        .morph_from
        .as_ref()
        .filter(|f| f.len() == mesh.positions.len())
        .map(|f| Mesh::from_triangles(f.clone(), mesh.triangles.clone()));
    for (ps, prim) in source.primitives.iter().zip(old) {
        let Some(g) = ps.group else {
            prims.push(prim);
            continue;
        };
        claimed.push(g);
        let Some(tris) = groups.get(&g) else {
            continue;
        };
        let mut sub = extract(mesh, tris, ps.streams, &mut remap);
        let target = morph_base
            .as_ref()
            .map(|base| morph_target(pool, &mut sub, base, tris, &mut remap));
        let (attrs, indices) = geometry(pool, &sub, ps.color_rgb, ps.joints_u8);
        let mut prim = match prim {
            Value::Object(o) => o,
            _ => Obj::new(),
        };
        prim.remove("mode");
        prim.insert("attributes".into(), Value::Object(attrs));
        prim.insert("indices".into(), num(indices));
        if let Some(t) = target {
            prim.insert("targets".into(), json!([{ "POSITION": t }]));
        }
        prims.push(Value::Object(prim));
    }
    for (g, tris) in &groups {
        if claimed.contains(g) {
            continue;
        }
        let mut sub = extract(mesh, tris, Streams::ALL, &mut remap);
        let target = morph_base
            .as_ref()
            .map(|base| morph_target(pool, &mut sub, base, tris, &mut remap));
        let (attrs, indices) = geometry(pool, &sub, false, false);
        let mut prim = json!({ "attributes": attrs, "indices": indices });
        if let Some(t) = target {
            prim["targets"] = json!([{ "POSITION": t }]);
        }
        prims.push(prim);
    }
    prims
}

/// The geomorph of a primitive: `sub`'s positions become those of `base` (the
/// part's mesh with the geomorph's base positions, extracted in the same vertex
/// order), and its own positions are written as the morph target's displacements;
/// returns that accessor.
fn morph_target(
    pool: &mut Pool,
    sub: &mut Mesh,
    base: &Mesh,
    tris: &[u32],
    remap: &mut [u32],
) -> usize {
    let base = extract(base, tris, Streams(0), remap).positions;
    let delta: Vec<[f32; 3]> = sub
        .positions
        .iter()
        .zip(&base)
        .map(|(p, b)| std::array::from_fn(|k| p[k] - b[k]))
        .collect();
    sub.positions = base;
    pool.floats(&delta, true)
}

/// Removes the morph weights of meshes in `dropped`: node `weights`, and animation
/// channels driving them (then unused samplers, then empty animations).
fn drop_morph_weights(root: &mut Obj, dropped: &[bool]) {
    let is_dropped = |m: Option<u64>| {
        m.and_then(|m| dropped.get(usize::try_from(m).ok()?).copied())
            .unwrap_or(false)
    };
    let mut nodes_hit = Vec::new();
    if let Some(nodes) = root.get_mut("nodes").and_then(Value::as_array_mut) {
        for (n, node) in nodes.iter_mut().enumerate() {
            let Some(node) = node.as_object_mut() else {
                continue;
            };
            if is_dropped(node.get("mesh").and_then(Value::as_u64)) {
                node.remove("weights");
                nodes_hit.push(n as u64);
            }
        }
    }
    let drives_weights = |channel: &Value| -> bool {
        let Some(target) = channel.get("target") else {
            return false;
        };
        if target.get("path").and_then(Value::as_str) == Some("weights") {
            return target
                .get("node")
                .and_then(Value::as_u64)
                .is_some_and(|n| nodes_hit.contains(&n));
        }
        // KHR_animation_pointer: "/nodes/N/weights" or "/meshes/M/weights".
        let pointer = target
            .get("extensions")
            .and_then(|e| e.get("KHR_animation_pointer"))
            .and_then(|e| e.get("pointer"))
            .and_then(Value::as_str)
            .unwrap_or("");
        let mut it = pointer.split('/').skip(1);
        match (
            it.next(),
            it.next().and_then(|i| i.parse::<u64>().ok()),
            it.next(),
        ) {
            (Some("nodes"), Some(n), Some("weights")) => nodes_hit.contains(&n),
            (Some("meshes"), Some(m), Some("weights")) => is_dropped(Some(m)),
            _ => false,
        }
    };
    let Some(anims) = root.get_mut("animations").and_then(Value::as_array_mut) else {
        return;
    };
    for anim in anims.iter_mut() {
        let Some(anim) = anim.as_object_mut() else {
            continue;
        };
        let mut channels = take_array(anim, "channels");
        channels.retain(|c| !drives_weights(c));
        let samplers = take_array(anim, "samplers");
        let mut used = vec![false; samplers.len()];
        for c in &channels {
            if let Some(u) = c
                .get("sampler")
                .and_then(Value::as_u64)
                .and_then(|s| used.get_mut(usize::try_from(s).ok()?))
            {
                *u = true;
            }
        }
        let mut map = vec![None; samplers.len()];
        let mut kept = Vec::new();
        for (i, s) in samplers.into_iter().enumerate() {
            if used[i] {
                map[i] = Some(kept.len());
                kept.push(s);
            }
        }
        for c in &mut channels {
            let new = c
                .get("sampler")
                .and_then(Value::as_u64)
                .and_then(|s| map.get(usize::try_from(s).ok()?).copied().flatten());
            if let (Some(new), Some(c)) = (new, c.as_object_mut()) {
                c.insert("sampler".into(), num(new));
            }
        }
        anim.insert("channels".into(), Value::Array(channels));
        anim.insert("samplers".into(), Value::Array(kept));
    }
    anims.retain(|a| {
        a.get("channels")
            .and_then(Value::as_array)
            .is_some_and(|c| !c.is_empty())
    });
    if anims.is_empty() {
        root.remove("animations");
    }
}

/// Removes the meshes in `removed` (left without primitives), renumbers node
/// references, and takes `mesh`, `skin` and `weights` off nodes that drew them.
fn remove_meshes(root: &mut Obj, removed: &[bool]) {
    let mut map = Vec::with_capacity(removed.len());
    let mut next = 0usize;
    for &r in removed {
        map.push((!r).then(|| {
            next += 1;
            next - 1
        }));
    }
    if let Some(meshes) = root.get_mut("meshes").and_then(Value::as_array_mut) {
        let mut i = 0;
        meshes.retain(|_| {
            i += 1;
            !removed.get(i - 1).copied().unwrap_or(false)
        });
        if meshes.is_empty() {
            root.remove("meshes");
        }
    }
    if let Some(nodes) = root.get_mut("nodes").and_then(Value::as_array_mut) {
        for node in nodes.iter_mut().filter_map(Value::as_object_mut) {
            let Some(m) = node.get("mesh").and_then(Value::as_u64) else {
                continue;
            };
            match usize::try_from(m)
                .ok()
                .and_then(|m| map.get(m).copied().flatten())
            {
                Some(new) => {
                    node.insert("mesh".into(), num(new));
                }
                None => {
                    node.remove("mesh");
                    node.remove("skin");
                    node.remove("weights");
                }
            }
        }
    }
}

/// Keeps only the accessors and buffer views still referenced by `root`, trims each
/// source buffer view to the bytes its accessors use, and packs every view into one
/// buffer at 4-byte alignment. Returns the buffer and the final view objects (the
/// accessors are put into `root`).
fn pack(
    root: &mut Obj,
    pool: Pool,
    buffers: &[Option<Arc<[u8]>>],
) -> Result<(Vec<u8>, Vec<Value>), FormatError> {
    let Pool { accessors, views } = pool;
    let mut kept = keep_used_accessors(root, accessors)?;
    let (plain, bytes) = view_bytes(&views, buffers)?;
    let (used, infos) = used_ranges(root, &views, &plain, &kept)?;
    let packed = lay_out(&views, bytes, &used)?;
    relocate_all(root, &mut kept, &infos, &packed);
    if kept.is_empty() {
        root.remove("accessors");
    } else {
        root.insert("accessors".into(), Value::Array(kept));
    }
    Ok((packed.bin, packed.views))
}

/// The accessors `root` reaches, renumbered in order (the references in `root`
/// follow).
fn keep_used_accessors(root: &mut Obj, accessors: Vec<Value>) -> Result<Vec<Value>, FormatError> {
    let mut used = vec![false; accessors.len()];
    super::refs::accessors(root, &mut |kind, i, what, v| match v
        .as_u64()
        .and_then(|a| used.get_mut(usize::try_from(a).ok()?))
    {
        Some(u) => {
            *u = true;
            Ok(())
        }
        None => Err(elem(
            kind,
            i,
            format!("{what} refers to a missing accessor"),
        )),
    })?;
    let mut map = vec![None; accessors.len()];
    let mut kept = Vec::new();
    for (i, a) in accessors.into_iter().enumerate() {
        if used[i] {
            map[i] = Some(kept.len());
            kept.push(a);
        }
    }
    super::refs::accessors(root, &mut |_, _, _, v| {
        if let Some(new) = v
            .as_u64()
            .and_then(|a| map.get(usize::try_from(a).ok()?).copied().flatten())
        {
            *v = num(new);
        }
        Ok(())
    })?;
    Ok(kept)
}

/// Each view parsed, with its bytes (new views are views of their own bytes).
fn view_bytes<'a>(
    views: &'a [PoolView],
    buffers: &'a [Option<Arc<[u8]>>],
) -> Result<(Vec<View>, Vec<&'a [u8]>), FormatError> {
    let mut plain = Vec::with_capacity(views.len());
    let mut bytes = Vec::with_capacity(views.len());
    for (i, v) in views.iter().enumerate() {
        match v {
            PoolView::New { data, .. } => {
                plain.push(View {
                    buffer: usize::MAX,
                    offset: 0,
                    length: data.len(),
                    stride: None,
                });
                bytes.push(data.as_slice());
            }
            PoolView::Source(json) => {
                let view = accessor::parse_view(json, i, buffers.len(), |b| {
                    buffers.get(b)?.as_ref().map(|d| d.len())
                })?;
                let data = buffers
                    .get(view.buffer)
                    .and_then(Option::as_ref)
                    .and_then(|b| b.get(view.offset..view.offset.checked_add(view.length)?))
                    .ok_or_else(|| internal(format!("buffer view {i} has no data")))?;
                plain.push(view);
                bytes.push(data);
            }
        }
    }
    Ok((plain, bytes))
}

/// The byte range used in each view (`lo` = `usize::MAX` for an unused one).
struct UsedRanges {
    lo: Vec<usize>,
    hi: Vec<usize>,
}

/// The byte ranges the kept accessors (parsed, returned), the images and the new
/// views use in each view; images and new views are used whole.
fn used_ranges(
    root: &Obj,
    views: &[PoolView],
    plain: &[View],
    kept: &[Value],
) -> Result<(UsedRanges, Vec<accessor::Accessor>), FormatError> {
    let n = views.len();
    let mut lo = vec![usize::MAX; n];
    let mut hi = vec![0usize; n];
    let mut use_range = |v: usize, (s, e): (usize, usize)| {
        if let (Some(l), Some(h)) = (lo.get_mut(v), hi.get_mut(v)) {
            *l = (*l).min(s);
            *h = (*h).max(e);
        }
    };
    for (i, v) in views.iter().enumerate() {
        if let PoolView::New { data, .. } = v {
            use_range(i, (0, data.len()));
        }
    }
    for img in top_array(root, "images")? {
        if let Some(v) = img.get("bufferView").and_then(Value::as_u64) {
            let v = usize::try_from(v).unwrap_or(usize::MAX);
            if let Some(view) = plain.get(v) {
                use_range(v, (0, view.length));
            }
        }
    }
    let mut infos = Vec::with_capacity(kept.len());
    for (i, a) in kept.iter().enumerate() {
        let acc = accessor::parse_accessor(a, i, plain, usize::MAX)?;
        if let Some(v) = acc.view {
            let range = acc
                .byte_range(plain.get(v).and_then(|w| w.stride))
                .ok_or_else(|| internal("accessor range overflows"))?;
            use_range(v, range);
        }
        if let (Some(s), Some((ri, rv))) = (&acc.sparse, acc.sparse_ranges()) {
            use_range(s.indices_view, ri);
            use_range(s.values_view, rv);
        }
        infos.push(acc);
    }
    Ok((UsedRanges { lo, hi }, infos))
}

/// The used views laid out in one buffer.
struct Packed {
    /// The buffer.
    bin: Vec<u8>,
    /// The final view objects.
    views: Vec<Value>,
    /// Per pool view, its final index (`None` when unused).
    view_map: Vec<Option<usize>>,
    /// Per pool view, the bytes trimmed from its start.
    trim: Vec<usize>,
}

/// Lays out the used part of each view (its `bytes`, the range in `used`, its start
/// trimmed to a multiple of 4) in one buffer at 4-byte alignment.
fn lay_out(
    views: &[PoolView],
    bytes: Vec<&[u8]>,
    used: &UsedRanges,
) -> Result<Packed, FormatError> {
    let n = views.len();
    let (lo, hi) = (&used.lo, &used.hi);
    let mut bin = Vec::new();
    let mut out_views = Vec::new();
    let mut view_map = vec![None; n];
    let mut trim = vec![0usize; n];
    for (i, (pv, data)) in views.iter().zip(bytes).enumerate() {
        if lo[i] == usize::MAX {
            continue;
        }
        // Trim to a multiple of 4 so accessor offsets keep their alignment.
        let start = lo[i] - lo[i] % 4;
        let used = data
            .get(start..hi[i])
            .ok_or_else(|| internal(format!("buffer view {i} range")))?;
        bin.resize(bin.len().next_multiple_of(4), 0);
        let mut out = match pv {
            PoolView::Source(Value::Object(o)) => o.clone(),
            PoolView::Source(_) => Obj::new(),
            PoolView::New { target, .. } => {
                let mut o = Obj::new();
                o.insert("target".into(), Value::from(*target));
                o
            }
        };
        out.insert("buffer".into(), num(0));
        out.insert("byteOffset".into(), num(bin.len()));
        out.insert("byteLength".into(), num(used.len()));
        bin.extend_from_slice(used);
        view_map[i] = Some(out_views.len());
        trim[i] = start;
        out_views.push(Value::Object(out));
    }
    Ok(Packed {
        bin,
        views: out_views,
        view_map,
        trim,
    })
}

/// Points the kept accessors (`infos`: parsed) and the images of `root` at the
/// packed views.
fn relocate_all(root: &mut Obj, kept: &mut [Value], infos: &[accessor::Accessor], packed: &Packed) {
    let Packed { view_map, trim, .. } = packed;
    let relocate = |o: &mut Obj, view: usize| {
        let old = o.get("byteOffset").and_then(Value::as_u64).unwrap_or(0) as usize;
        let new = old - trim.get(view).copied().unwrap_or(0).min(old);
        if new == 0 {
            o.remove("byteOffset");
        } else {
            o.insert("byteOffset".into(), num(new));
        }
        if let Some(v) = view_map.get(view).copied().flatten() {
            o.insert("bufferView".into(), num(v));
        }
    };
    for (a, acc) in kept.iter_mut().zip(infos) {
        let Some(a) = a.as_object_mut() else { continue };
        if let Some(v) = acc.view {
            relocate(a, v);
        }
        let sparse = a.get_mut("sparse").and_then(Value::as_object_mut);
        if let (Some(s), Some(sp)) = (&acc.sparse, sparse) {
            if let Some(o) = sp.get_mut("indices").and_then(Value::as_object_mut) {
                relocate(o, s.indices_view);
            }
            if let Some(o) = sp.get_mut("values").and_then(Value::as_object_mut) {
                relocate(o, s.values_view);
            }
        }
    }
    if let Some(images) = root.get_mut("images").and_then(Value::as_array_mut) {
        for img in images.iter_mut().filter_map(Value::as_object_mut) {
            let v = img.get("bufferView").and_then(Value::as_u64);
            if let Some(new) =
                v.and_then(|v| view_map.get(usize::try_from(v).ok()?).copied().flatten())
            {
                img.insert("bufferView".into(), num(new));
            }
        }
    }
}

/// Stores external images as `target` needs: copied next to a `.gltf` in another
/// directory, embedded in the buffer of a `.glb`, or as data URIs. Returns the files
/// to copy.
fn images(
    root: &mut Obj,
    bin: &mut Vec<u8>,
    views: &mut Vec<Value>,
    target: &Target<'_>,
    base_dir: Option<&Path>,
) -> Result<Vec<(PathBuf, PathBuf)>, FormatError> {
    let mut copies = Vec::new();
    let Some(images) = root.get_mut("images").and_then(Value::as_array_mut) else {
        return Ok(copies);
    };
    for img in images.iter_mut().filter_map(Value::as_object_mut) {
        let Some(u) = img.get("uri").and_then(Value::as_str).map(str::to_string) else {
            continue;
        };
        let Ok(parsed) = uri::parse(&u) else {
            continue;
        };
        match (target, parsed) {
            (Target::Glb, Uri::Data { media_type, bytes }) => {
                let mime = img
                    .get("mimeType")
                    .and_then(Value::as_str)
                    .map(str::to_string)
                    .or_else(|| uri::image_media_type(&bytes, None).map(str::to_string))
                    .or_else(|| (!media_type.is_empty()).then_some(media_type));
                if let Some(mime) = mime {
                    embed(img, bin, views, &bytes, &mime);
                }
            }
            (_, Uri::Data { .. }) => {}
            (Target::Files { dir, .. }, Uri::Relative(rel)) => {
                let Some(base) = base_dir else { continue };
                if same_dir(base, dir) {
                    continue;
                }
                if uri::is_contained(&rel) {
                    copies.push((base.join(&rel), dir.join(&rel)));
                } else if let Some(name) = rel.file_name() {
                    copies.push((base.join(&rel), dir.join(name)));
                    img.insert(
                        "uri".into(),
                        Value::from(uri::percent_encode(&name.to_string_lossy())),
                    );
                }
            }
            (Target::Glb | Target::Embedded, Uri::Relative(rel)) => {
                let Some(base) = base_dir else { continue };
                let path = base.join(&rel);
                let Ok(bytes) = std::fs::read(&path) else {
                    continue;
                };
                let mime = img
                    .get("mimeType")
                    .and_then(Value::as_str)
                    .or_else(|| uri::image_media_type(&bytes, Some(&path)));
                let Some(mime) = mime.map(str::to_string) else {
                    continue;
                };
                if matches!(target, Target::Glb) {
                    embed(img, bin, views, &bytes, &mime);
                } else {
                    img.insert("uri".into(), Value::from(uri::data_uri(&mime, &bytes)));
                }
            }
        }
    }
    Ok(copies)
}

/// Moves an image's bytes into the buffer as a new buffer view.
fn embed(img: &mut Obj, bin: &mut Vec<u8>, views: &mut Vec<Value>, bytes: &[u8], mime: &str) {
    bin.resize(bin.len().next_multiple_of(4), 0);
    views.push(json!({ "buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len() }));
    bin.extend_from_slice(bytes);
    img.remove("uri");
    img.insert("bufferView".into(), num(views.len() - 1));
    img.insert("mimeType".into(), Value::from(mime));
}

fn same_dir(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    }
}

/// A fresh document for a scene without a glTF source.
fn fresh(scene: &Scene) -> Result<(Value, Pool), FormatError> {
    let mut pool = Pool::default();
    let mut meshes = Vec::new();
    let mut nodes = Vec::new();
    let mut materials: Vec<Value> = Vec::new();
    let mut material_ids: BTreeMap<String, usize> = BTreeMap::new();
    let mut remap = Vec::new();
    for (k, part) in scene.parts.iter().enumerate() {
        let mesh = &part.mesh;
        if mesh.triangles.is_empty() {
            continue;
        }
        remap.clear();
        remap.resize(mesh.positions.len(), u32::MAX);
        let groups = by_group(mesh);
        let mut prims = Vec::new();
        for (&g, tris) in &groups {
            let sub = extract(mesh, tris, Streams::ALL, &mut remap);
            let (attrs, indices) = geometry(&mut pool, &sub, false, false);
            let name = mesh
                .group_names
                .get(g as usize)
                .filter(|n| !n.is_empty())
                .cloned()
                .unwrap_or_else(|| {
                    if groups.len() == 1 {
                        "default".into()
                    } else {
                        format!("group {g}")
                    }
                });
            let material = *material_ids.entry(name.clone()).or_insert_with(|| {
                materials.push(json!({
                    "name": name,
                    "pbrMetallicRoughness": { "metallicFactor": 0.0 }
                }));
                materials.len() - 1
            });
            prims.push(json!({ "attributes": attrs, "indices": indices, "material": material }));
        }
        let mut mesh_json = Obj::new();
        if let Some(name) = &part.name {
            mesh_json.insert("name".into(), Value::from(name.as_str()));
        }
        mesh_json.insert("primitives".into(), Value::Array(prims));
        let mi = meshes.len();
        meshes.push(Value::Object(mesh_json));
        for m in &part.instances {
            let mut node = Obj::new();
            if let Some(name) = &part.name {
                node.insert("name".into(), Value::from(name.as_str()));
            }
            node.insert("mesh".into(), num(mi));
            if *m != IDENTITY {
                if !m.as_flattened().iter().all(|x| x.is_finite()) {
                    return Err(elem("mesh", k, "has an instance matrix that is not finite"));
                }
                let flat: Vec<Value> = m
                    .as_flattened()
                    .iter()
                    .map(|&x| Value::from(f64::from(x)))
                    .collect();
                node.insert("matrix".into(), Value::Array(flat));
            }
            nodes.push(Value::Object(node));
        }
    }
    let mut root = Obj::new();
    root.insert(
        "asset".into(),
        json!({ "version": "2.0", "generator": "meshlod" }),
    );
    if !nodes.is_empty() {
        root.insert("scene".into(), num(0));
        root.insert(
            "scenes".into(),
            json!([{ "nodes": (0..nodes.len()).collect::<Vec<_>>() }]),
        );
        root.insert("nodes".into(), Value::Array(nodes));
    }
    if !meshes.is_empty() {
        root.insert("meshes".into(), Value::Array(meshes));
    }
    if !materials.is_empty() {
        root.insert("materials".into(), Value::Array(materials));
    }
    Ok((Value::Object(root), pool))
}

/// The component type and byte length of the index accessor written for `tris` of a
/// primitive with `vertices` vertices.
#[cfg(test)]
pub(super) fn index_layout(tris: &[[u32; 3]], vertices: usize) -> (u32, usize) {
    let mut pool = Pool::default();
    let a = pool.indices(tris, vertices);
    let code = pool
        .accessors
        .get(a)
        .and_then(|a| a["componentType"].as_u64())
        .unwrap_or(0) as u32;
    let len = match pool.views.last() {
        Some(PoolView::New { data, .. }) => data.len(),
        _ => 0,
    };
    (code, len)
}
