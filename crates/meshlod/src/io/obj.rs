//! OBJ reader and writer (placeholder; being written).

use super::{FormatError, Scene};

/// Reads an OBJ file from memory.
///
/// # Errors
/// [`FormatError`] naming the line that is wrong.
pub fn read(_data: &[u8]) -> Result<Scene, FormatError> {
    Err(FormatError::new(
        super::Location::File,
        "reader not written yet",
    ))
}

/// Writes `scene` (flattened) as OBJ.
///
/// # Errors
/// [`FormatError`] when the scene cannot be expressed.
pub fn write(_scene: &Scene, _out: &mut Vec<u8>) -> Result<(), FormatError> {
    Err(FormatError::new(
        super::Location::File,
        "writer not written yet",
    ))
}
