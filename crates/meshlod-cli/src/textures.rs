//! Reading an input for `meshlod render`: the mesh (moved out of its scene without a
//! copy when it is one part drawn once) and the base-colour texture of each of its
//! material groups: OBJ `map_Kd` from the `mtllib` files, glTF
//! `pbrMetallicRoughness.baseColorTexture` images given by a file or a `data:` URI.
//! Only PNG images are decoded; others are skipped with a warning.

use anyhow::{Context, Result};
use base64::Engine as _;
use meshlod::io::Format;
use meshlod::render::Texture;
use meshlod::{Mesh, Scene};
use std::collections::HashMap;
use std::path::Path;

/// The scene's mesh, moved out when the scene is a single part drawn once.
pub fn into_mesh(mut scene: Scene) -> Mesh {
    if matches!(scene.flattened(), std::borrow::Cow::Borrowed(_)) {
        if let Some(part) = scene.parts.pop() {
            return part.mesh;
        }
    }
    scene.flatten()
}

/// Decodes the PNG file `path`, or warns and gives `None`.
fn load(path: &Path) -> Option<Texture> {
    let bytes = std::fs::read(path)
        .map_err(|e| {
            eprintln!(
                "meshlod: warning: {}: {e}; drawn untextured",
                path.display()
            )
        })
        .ok()?;
    decode(&bytes, &path.display().to_string())
}

fn decode(bytes: &[u8], what: &str) -> Option<Texture> {
    Texture::from_png(bytes)
        .map_err(|e| {
            eprintln!(
                "meshlod: warning: {what}: {e} (only PNG textures are read); drawn untextured"
            )
        })
        .ok()
}

/// The texture of each group of `mesh` read from `path` (its scene `scene`), by
/// group id; empty when the mesh has no UVs or the format has no materials.
pub fn for_groups(path: &Path, scene: &Scene, mesh: &Mesh) -> Vec<Option<Texture>> {
    if mesh.attributes.uv0.is_none() {
        return Vec::new();
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    let files: HashMap<String, String> = match Format::from_path(path) {
        Some(Format::Obj) => obj_maps(dir, &scene.material_libraries),
        Some(Format::Gltf | Format::Glb) => {
            return gltf_textures(scene, mesh, dir);
        }
        _ => return Vec::new(),
    };
    let mut cache: HashMap<String, Option<Texture>> = HashMap::new();
    let names: Vec<String> = if mesh.group_names.is_empty() {
        vec![String::new()]
    } else {
        mesh.group_names.clone()
    };
    names
        .iter()
        .map(|name| {
            let file = files.get(name)?;
            cache
                .entry(file.clone())
                .or_insert_with(|| load(&dir.join(file)))
                .clone()
        })
        .collect()
}

/// `newmtl` name → `map_Kd` file of each material library in `dir`.
fn obj_maps(dir: &Path, libraries: &[String]) -> HashMap<String, String> {
    let mut maps = HashMap::new();
    for lib in libraries {
        let Ok(text) = std::fs::read_to_string(dir.join(lib)) else {
            eprintln!(
                "meshlod: warning: {}: cannot read the material library",
                dir.join(lib).display()
            );
            continue;
        };
        let mut current = String::new();
        for line in text.lines() {
            let line = line.trim();
            if let Some(name) = line.strip_prefix("newmtl ") {
                current = name.trim().to_string();
            } else if let Some(rest) = line.strip_prefix("map_Kd ") {
                // Options (`-s 1 1 1`, …) come first; the file name is last.
                if let Some(file) = rest.split_whitespace().last() {
                    maps.insert(current.clone(), file.to_string());
                }
            }
        }
    }
    maps
}

/// The base-colour texture of each group of a glTF scene's flattened mesh: groups
/// are named after their material (or `material N` when it has no name).
fn gltf_textures(scene: &Scene, mesh: &Mesh, dir: &Path) -> Vec<Option<Texture>> {
    let Some(src) = scene.gltf.as_ref() else {
        return Vec::new();
    };
    let doc = src.document();
    let base = src.base_dir().unwrap_or(dir);
    let list = |k: &str| {
        doc.get(k)
            .and_then(|v| v.as_array())
            .cloned()
            .unwrap_or_default()
    };
    let (materials, textures, images) = (list("materials"), list("textures"), list("images"));
    let image_of = |m: usize| -> Option<Texture> {
        let t = materials.get(m)?["pbrMetallicRoughness"]["baseColorTexture"]["index"].as_u64()?;
        let img = textures.get(t as usize)?["source"].as_u64()?;
        let uri = images.get(img as usize)?["uri"].as_str()?;
        if let Some(data) = uri.strip_prefix("data:") {
            let b64 = data.split_once(";base64,")?.1;
            let bytes = base64::engine::general_purpose::STANDARD.decode(b64).ok()?;
            return decode(&bytes, "embedded image");
        }
        load(&base.join(uri))
    };
    mesh.group_names
        .iter()
        .map(|name| {
            let m = materials
                .iter()
                .position(|mat| mat["name"].as_str() == Some(name.as_str()));
            let m = m.or_else(|| name.strip_prefix("material ")?.parse().ok())?;
            image_of(m)
        })
        .collect()
}

/// Reads `path`: the mesh and, unless `plain`, its textures.
///
/// # Errors
/// The file cannot be read.
pub fn read(path: &Path, plain: bool) -> Result<(Mesh, Vec<Option<Texture>>)> {
    let scene =
        meshlod::read_scene(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let textures = if plain || scene.material_libraries.is_empty() && scene.gltf.is_none() {
        Vec::new()
    } else {
        let flat = scene.flattened();
        for_groups(path, &scene, &flat)
    };
    Ok((into_mesh(scene), textures))
}
