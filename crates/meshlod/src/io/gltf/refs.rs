//! Every place of a glTF document that holds an accessor or buffer-view index, so the
//! reader can check them and the writer can renumber them after garbage collection.
//!
//! Core glTF plus `EXT_mesh_gpu_instancing`; other extensions are assumed not to
//! refer to accessors or buffer views (the compressed-geometry extensions, which do,
//! are refused when reading).

use super::super::FormatError;
use super::json::Obj;
use serde_json::Value;

/// A visitor of index-holding JSON values: `(element kind, element index, what, value)`.
pub(super) type Visit<'a> =
    dyn FnMut(&'static str, usize, &str, &mut Value) -> Result<(), FormatError> + 'a;

fn array_mut<'a>(root: &'a mut Obj, key: &str) -> impl Iterator<Item = (usize, &'a mut Obj)> {
    root.get_mut(key)
        .and_then(Value::as_array_mut)
        .into_iter()
        .flat_map(|a| a.iter_mut().enumerate())
        .filter_map(|(i, v)| v.as_object_mut().map(|o| (i, o)))
}

fn object_values(o: Option<&mut Value>) -> impl Iterator<Item = (&String, &mut Value)> {
    o.and_then(Value::as_object_mut)
        .into_iter()
        .flat_map(|m| m.iter_mut())
}

/// Calls `f` on every accessor index in the document: primitive attributes, indices
/// and morph targets, skin inverse bind matrices, animation sampler inputs and
/// outputs, and `EXT_mesh_gpu_instancing` attributes.
pub(super) fn accessors(root: &mut Obj, f: &mut Visit<'_>) -> Result<(), FormatError> {
    for (m, mesh) in array_mut(root, "meshes") {
        let prims = mesh.get_mut("primitives").and_then(Value::as_array_mut);
        for (p, prim) in prims.into_iter().flat_map(|a| a.iter_mut().enumerate()) {
            let Some(prim) = prim.as_object_mut() else {
                continue;
            };
            for (name, v) in object_values(prim.get_mut("attributes")) {
                f("mesh", m, &format!("primitive {p} attribute {name}"), v)?;
            }
            if let Some(v) = prim.get_mut("indices") {
                f("mesh", m, &format!("primitive {p} indices"), v)?;
            }
            let targets = prim.get_mut("targets").and_then(Value::as_array_mut);
            for (t, target) in targets.into_iter().flat_map(|a| a.iter_mut().enumerate()) {
                for (name, v) in object_values(Some(target)) {
                    f(
                        "mesh",
                        m,
                        &format!("primitive {p} morph target {t} {name}"),
                        v,
                    )?;
                }
            }
        }
    }
    for (s, skin) in array_mut(root, "skins") {
        if let Some(v) = skin.get_mut("inverseBindMatrices") {
            f("skin", s, "inverseBindMatrices", v)?;
        }
    }
    for (a, anim) in array_mut(root, "animations") {
        let samplers = anim.get_mut("samplers").and_then(Value::as_array_mut);
        for (k, sampler) in samplers.into_iter().flat_map(|s| s.iter_mut().enumerate()) {
            let Some(sampler) = sampler.as_object_mut() else {
                continue;
            };
            for key in ["input", "output"] {
                if let Some(v) = sampler.get_mut(key) {
                    f("animation", a, &format!("sampler {k} {key}"), v)?;
                }
            }
        }
    }
    for (n, node) in array_mut(root, "nodes") {
        let inst = node
            .get_mut("extensions")
            .and_then(|e| e.get_mut("EXT_mesh_gpu_instancing"))
            .and_then(|e| e.get_mut("attributes"));
        for (name, v) in object_values(inst) {
            f(
                "node",
                n,
                &format!("EXT_mesh_gpu_instancing attribute {name}"),
                v,
            )?;
        }
    }
    Ok(())
}

/// Calls `f` on every buffer-view index in the document: accessors (and their sparse
/// indices and values) and images.
pub(super) fn views(root: &mut Obj, f: &mut Visit<'_>) -> Result<(), FormatError> {
    for (a, acc) in array_mut(root, "accessors") {
        if let Some(v) = acc.get_mut("bufferView") {
            f("accessor", a, "bufferView", v)?;
        }
        if let Some(sparse) = acc.get_mut("sparse").and_then(Value::as_object_mut) {
            for key in ["indices", "values"] {
                if let Some(v) = sparse.get_mut(key).and_then(|s| s.get_mut("bufferView")) {
                    f("accessor", a, &format!("sparse {key} bufferView"), v)?;
                }
            }
        }
    }
    for (i, image) in array_mut(root, "images") {
        if let Some(v) = image.get_mut("bufferView") {
            f("image", i, "bufferView", v)?;
        }
    }
    Ok(())
}
