//! glTF 2.0 reader and writer (placeholder; being written).

use super::{FormatError, Scene, WriteError};
use std::path::Path;

/// The original glTF document kept with a scene so a writer can give it back.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct GltfSource {}

/// Reads a `.gltf` or `.glb` from memory; external buffers are looked up in `base_dir`.
///
/// # Errors
/// [`FormatError`] naming the element that is wrong.
pub fn read(_data: &[u8], _base_dir: Option<&Path>) -> Result<Scene, FormatError> {
    Err(FormatError::new(
        super::Location::File,
        "reader not written yet",
    ))
}

/// Writes `scene` to `path` as `.glb` (`glb`) or `.gltf` with a side `.bin`.
///
/// # Errors
/// [`WriteError`] when writing fails or the scene cannot be expressed.
pub fn write_file(_path: &Path, _scene: &Scene, _glb: bool) -> Result<(), WriteError> {
    Err(FormatError::new(super::Location::File, "writer not written yet").into())
}

/// Serialises `scene` as a `.gltf` with buffers embedded as data URIs.
///
/// # Errors
/// [`FormatError`] when the scene cannot be expressed.
pub fn write_embedded(_scene: &Scene) -> Result<Vec<u8>, FormatError> {
    Err(FormatError::new(
        super::Location::File,
        "writer not written yet",
    ))
}

/// Serialises `scene` as a `.glb`.
///
/// # Errors
/// [`FormatError`] when the scene cannot be expressed.
pub fn write_glb(_scene: &Scene) -> Result<Vec<u8>, FormatError> {
    Err(FormatError::new(
        super::Location::File,
        "writer not written yet",
    ))
}
