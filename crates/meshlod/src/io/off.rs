//! off reader and writer (placeholder; being written).

use super::FormatError;
use crate::mesh::Mesh;

/// Reads a off file from memory.
///
/// # Errors
/// [`FormatError`] naming the line, byte or element that is wrong.
pub fn read(_data: &[u8]) -> Result<Mesh, FormatError> {
    Err(FormatError::new(
        super::Location::File,
        "reader not written yet",
    ))
}

/// Writes `mesh`.
///
/// # Errors
/// [`FormatError`] when the mesh cannot be expressed.
pub fn write(_mesh: &Mesh, _out: &mut Vec<u8>) -> Result<(), FormatError> {
    Err(FormatError::new(
        super::Location::File,
        "writer not written yet",
    ))
}
