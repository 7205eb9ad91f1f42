//! ply reader and writer (placeholder; being written).

use super::FormatError;
use crate::mesh::Mesh;

/// Reads a ply file from memory.
///
/// # Errors
/// [`FormatError`] naming the line, byte or element that is wrong.
pub fn read(_data: &[u8]) -> Result<Mesh, FormatError> {
    Err(FormatError::new(
        super::Location::File,
        "reader not written yet",
    ))
}

/// Writes `mesh` as PLY (binary little-endian, or ASCII).
///
/// # Errors
/// [`FormatError`] when the mesh cannot be expressed.
pub fn write(_mesh: &Mesh, _ascii: bool, _out: &mut Vec<u8>) -> Result<(), FormatError> {
    Err(FormatError::new(
        super::Location::File,
        "writer not written yet",
    ))
}
