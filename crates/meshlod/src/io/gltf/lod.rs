//! Levels of detail in a glTF document, with the `MSFT_lod` vendor extension
//! (<https://github.com/KhronosGroup/glTF/tree/main/extensions/2.0/Vendor/MSFT_lod>).
//!
//! Each coarser level of a glTF mesh becomes a new mesh (a copy of the original's
//! triangle primitives, same materials, new geometry) drawn by a new node per node
//! that draws the original. Those nodes copy the original node's transform, skin
//! and GPU instancing and belong to no scene; the original node lists them, finest
//! first, in `extensions.MSFT_lod.ids` and gets `extras.MSFT_screencoverage`
//! (one value per coarser level, where it takes over, then the coverage under
//! which nothing is drawn). A mesh drawn by several nodes is simplified once: every
//! node's levels share the coarser meshes.

use super::json::elem;
use super::{MeshSource, Scene};
use crate::io::{FormatError, Location, Part};
use crate::mesh::Mesh;
use serde_json::{json, Map, Value};

fn internal_error(what: &str) -> FormatError {
    FormatError::new(Location::File, format!("internal error: {what}"))
}

/// The coarser levels of one glTF mesh, for [`add_lods`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MeshLods {
    /// The part of the scene (= the glTF mesh) they belong to.
    pub part: usize,
    /// The coarser meshes, finest first (LOD1, LOD2, …).
    pub levels: Vec<Mesh>,
    /// Per level, the geomorph base positions (one per vertex of that level, the
    /// positions in the next finer level its vertices descend from); an empty list
    /// writes no morph target for that level. Shorter than `levels` means the rest
    /// have none.
    pub morph_from: Vec<Vec<[f32; 3]>>,
    /// `MSFT_screencoverage`: one value per level, then the cull coverage.
    pub coverage: Vec<f64>,
    /// Put into the original mesh's `extras.meshlod_lod` (e.g. the levels' errors).
    pub extras: Value,
}

/// Adds each [`MeshLods`] to `scene` as `MSFT_lod` levels of its mesh: new parts
/// (one per level, after the existing ones, drawn by no scene node) and, in the
/// kept glTF document, new meshes and nodes, `MSFT_lod` on every node drawing the
/// original mesh, and `MSFT_lod` in `extensionsUsed`. A scene not read from glTF
/// first gets the document a fresh write would give it.
///
/// With a level's `morph_from` the level's mesh gets one morph target and default
/// weight 1: its `POSITION` holds the finer positions and the target the
/// displacement to its own, so weight 0 shows the finer shape and 1 the coarse one.
///
/// # Errors
/// [`FormatError`] when a part index is out of range, a coverage list does not have
/// one value more than its levels, a geomorph list does not match its level's
/// vertices, a node drawing the mesh already has `MSFT_lod`, or the document cannot
/// be made.
pub fn add_lods(scene: &mut Scene, lods: Vec<MeshLods>) -> Result<(), FormatError> {
    if scene.gltf.is_none() {
        let bytes = super::write_glb(scene)?;
        let parts = scene.parts.len();
        *scene = super::read(&bytes, None)?;
        if scene.parts.len() != parts {
            return Err(FormatError::new(
                Location::File,
                "a part without triangles cannot be given levels of detail",
            ));
        }
    }
    for l in &lods {
        check(scene, l)?;
    }
    let src = scene
        .gltf
        .as_deref_mut()
        .ok_or_else(|| internal_error("no glTF document"))?;
    let root = src
        .document
        .as_object_mut()
        .ok_or_else(|| internal_error("the document is not an object"))?;
    let original_nodes = root
        .get("nodes")
        .and_then(Value::as_array)
        .map_or(0, Vec::len);
    for l in lods {
        let part = l.part;
        let ids = add_meshes(root, &mut src.meshes, &mut scene.parts, &l)?;
        if let Some(m) = root
            .get_mut("meshes")
            .and_then(|m| m.get_mut(part))
            .and_then(Value::as_object_mut)
        {
            extras_of(m).insert("meshlod_lod".into(), l.extras);
        }
        add_nodes(root, original_nodes, part, &ids, &l.coverage)?;
    }
    let used = root
        .entry("extensionsUsed")
        .or_insert_with(|| Value::Array(Vec::new()));
    if let Some(list) = used.as_array_mut() {
        if !list.iter().any(|v| v == "MSFT_lod") {
            list.push(Value::from("MSFT_lod"));
        }
    }
    Ok(())
}

fn check(scene: &Scene, l: &MeshLods) -> Result<(), FormatError> {
    if l.part >= scene.parts.len() {
        return Err(FormatError::new(
            Location::File,
            format!(
                "part {} does not exist (the scene has {})",
                l.part,
                scene.parts.len()
            ),
        ));
    }
    if l.coverage.len() != l.levels.len() + 1 {
        return Err(FormatError::new(
            Location::File,
            format!(
                "part {}: {} screen coverages for {} levels (one more is needed)",
                l.part,
                l.coverage.len(),
                l.levels.len()
            ),
        ));
    }
    for (k, (m, f)) in l.levels.iter().zip(&l.morph_from).enumerate() {
        if !f.is_empty() && f.len() != m.positions.len() {
            return Err(FormatError::new(
                Location::File,
                format!(
                    "part {} LOD{}: {} geomorph positions for {} vertices",
                    l.part,
                    k + 1,
                    f.len(),
                    m.positions.len()
                ),
            ));
        }
    }
    Ok(())
}

/// `o.extras` as an object (made one if absent or not an object).
fn extras_of(o: &mut Map<String, Value>) -> &mut Map<String, Value> {
    let e = o
        .entry("extras")
        .or_insert_with(|| Value::Object(Map::new()));
    if !e.is_object() {
        *e = Value::Object(Map::new());
    }
    e.as_object_mut().expect("made an object above")
}

/// Appends one glTF mesh, mesh source and part per level of `l`; returns the new
/// mesh indices.
fn add_meshes(
    root: &mut Map<String, Value>,
    sources: &mut Vec<MeshSource>,
    parts: &mut Vec<Part>,
    l: &MeshLods,
) -> Result<Vec<usize>, FormatError> {
    let meshes = root
        .get_mut("meshes")
        .and_then(Value::as_array_mut)
        .ok_or_else(|| internal_error("the document has no meshes"))?;
    let original = meshes
        .get(l.part)
        .and_then(Value::as_object)
        .ok_or_else(|| elem("mesh", l.part, "is not an object"))?
        .clone();
    let source = sources
        .get(l.part)
        .ok_or_else(|| internal_error("no source for the mesh"))?
        .clone();
    // Only the triangle primitives are levels of detail.
    let prims: Vec<Value> = original
        .get("primitives")
        .and_then(Value::as_array)
        .map(|p| p.to_vec())
        .unwrap_or_default();
    let (prims, prim_sources): (Vec<Value>, Vec<_>) = prims
        .into_iter()
        .zip(source.primitives)
        .filter(|(_, s)| s.group.is_some())
        .map(|(mut p, s)| {
            if let Some(o) = p.as_object_mut() {
                o.remove("targets");
            }
            (p, s)
        })
        .unzip();
    let base_name = original
        .get("name")
        .and_then(Value::as_str)
        .map_or_else(|| format!("mesh{}", l.part), str::to_owned);
    let mut ids = Vec::with_capacity(l.levels.len());
    for (k, level) in l.levels.iter().enumerate() {
        let name = format!("{base_name}_LOD{}", k + 1);
        let morph = l.morph_from.get(k).filter(|f| !f.is_empty()).cloned();
        let mut m = original.clone();
        m.insert("name".into(), Value::from(name.as_str()));
        m.insert("primitives".into(), Value::Array(prims.clone()));
        m.remove("weights");
        let extras = extras_of(&mut m);
        extras.remove("targetNames");
        extras.remove("meshlod_lod");
        if morph.is_some() {
            extras.insert("targetNames".into(), json!(["geomorph"]));
            m.insert("weights".into(), json!([1.0]));
        }
        if m.get("extras")
            .and_then(Value::as_object)
            .is_some_and(Map::is_empty)
        {
            m.remove("extras");
        }
        ids.push(meshes.len());
        meshes.push(Value::Object(m));
        sources.push(MeshSource {
            fingerprint: 0,
            primitives: prim_sources.clone(),
            rewrite: true,
            morph_from: morph,
        });
        parts.push(Part {
            name: Some(name),
            mesh: level.clone(),
            instances: Vec::new(),
        });
    }
    Ok(ids)
}

/// For every node among the first `original_nodes` that draws mesh `part`, one new
/// node per level in `meshes`, listed in the node's `MSFT_lod`.
fn add_nodes(
    root: &mut Map<String, Value>,
    original_nodes: usize,
    part: usize,
    meshes: &[usize],
    coverage: &[f64],
) -> Result<(), FormatError> {
    let Some(nodes) = root.get_mut("nodes").and_then(Value::as_array_mut) else {
        return Ok(());
    };
    for n in 0..original_nodes {
        let node = nodes[n]
            .as_object()
            .ok_or_else(|| elem("node", n, "is not an object"))?;
        if node.get("mesh").and_then(Value::as_u64) != Some(part as u64) {
            continue;
        }
        if node
            .get("extensions")
            .and_then(|e| e.get("MSFT_lod"))
            .is_some()
        {
            return Err(elem(
                "node",
                n,
                "already has MSFT_lod levels of detail; simplify its finest mesh instead",
            ));
        }
        let name = node
            .get("name")
            .and_then(Value::as_str)
            .map_or_else(|| format!("node{n}"), str::to_owned);
        let mut copy = Map::new();
        for key in ["translation", "rotation", "scale", "matrix", "skin"] {
            if let Some(v) = node.get(key) {
                copy.insert(key.into(), v.clone());
            }
        }
        if let Some(inst) = node
            .get("extensions")
            .and_then(|e| e.get("EXT_mesh_gpu_instancing"))
        {
            copy.insert(
                "extensions".into(),
                json!({ "EXT_mesh_gpu_instancing": inst.clone() }),
            );
        }
        let mut ids = Vec::with_capacity(meshes.len());
        for (k, &m) in meshes.iter().enumerate() {
            let mut lod = copy.clone();
            lod.insert("name".into(), Value::from(format!("{name}_LOD{}", k + 1)));
            lod.insert("mesh".into(), Value::from(m));
            ids.push(nodes.len());
            nodes.push(Value::Object(lod));
        }
        let node = nodes[n]
            .as_object_mut()
            .ok_or_else(|| elem("node", n, "is not an object"))?;
        let ext = node
            .entry("extensions")
            .or_insert_with(|| Value::Object(Map::new()));
        if !ext.is_object() {
            *ext = Value::Object(Map::new());
        }
        ext.as_object_mut()
            .expect("made an object above")
            .insert("MSFT_lod".into(), json!({ "ids": ids }));
        extras_of(node).insert("MSFT_screencoverage".into(), json!(coverage));
    }
    Ok(())
}
