//! The GLB container (glTF 2.0 spec, section 4.4 "Binary glTF Layout"): a 12-byte
//! header (`glTF`, version 2, total length) and chunks of (length, type, data), the
//! first being JSON and an optional second being the binary buffer, all little-endian
//! and 4-byte aligned.

use super::super::{FormatError, Location};

/// The GLB magic.
pub(super) const MAGIC: &[u8; 4] = b"glTF";
/// Chunk type of the JSON chunk (`JSON`).
const JSON_CHUNK: u32 = 0x4E4F_534A;
/// Chunk type of the binary chunk (`BIN\0`).
const BIN_CHUNK: u32 = 0x004E_4942;

/// The chunks of a GLB file.
#[derive(Debug)]
pub(super) struct Glb<'a> {
    /// The JSON chunk's data.
    pub json: &'a [u8],
    /// Byte offset of the JSON data in the file (for error locations).
    pub json_offset: usize,
    /// The BIN chunk's data, if there is one.
    pub bin: Option<&'a [u8]>,
}

fn u32_at(data: &[u8], at: usize) -> Option<u32> {
    let b = data.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

fn at(offset: usize, message: impl Into<String>) -> FormatError {
    FormatError::new(Location::Byte(offset as u64), message)
}

/// Splits a GLB file into its chunks, checking the header and every length.
///
/// # Errors
/// A [`Location::Byte`] error for a bad magic or version, a length that disagrees
/// with the data, a truncated or misaligned chunk, or a missing JSON chunk.
pub(super) fn parse(data: &[u8]) -> Result<Glb<'_>, FormatError> {
    if data.len() < 12 {
        return Err(at(
            data.len(),
            format!(
                "truncated GLB header: the file has {} bytes, the header needs 12",
                data.len()
            ),
        ));
    }
    if data.get(..4) != Some(MAGIC.as_slice()) {
        return Err(at(0, "not a GLB file (the first 4 bytes are not \"glTF\")"));
    }
    let version = u32_at(data, 4).unwrap_or(0);
    if version != 2 {
        return Err(at(
            4,
            format!("GLB container version {version}; meshlod reads version 2 (glTF 2.0)"),
        ));
    }
    let length = u32_at(data, 8).unwrap_or(0) as usize;
    if length < 12 {
        return Err(at(
            8,
            format!("GLB header gives a total length of {length} bytes, less than the header"),
        ));
    }
    if length > data.len() {
        return Err(at(
            data.len(),
            format!(
                "truncated GLB: the header says {length} bytes but the file has {}",
                data.len()
            ),
        ));
    }
    // Bytes past `length` are not part of the container and are ignored.
    let data = &data[..length];
    let mut pos = 12;
    let mut index = 0usize;
    let mut json = None;
    let mut bin = None;
    while pos < length {
        if length - pos < 8 {
            return Err(at(
                pos,
                format!(
                    "truncated GLB chunk {index} header: {} bytes left, need 8",
                    length - pos
                ),
            ));
        }
        let chunk_len = u32_at(data, pos).unwrap_or(0) as usize;
        let chunk_type = u32_at(data, pos + 4).unwrap_or(0);
        let start = pos + 8;
        let end = start
            .checked_add(chunk_len)
            .filter(|&e| e <= length)
            .ok_or_else(|| {
                at(
                    pos,
                    format!(
                        "GLB chunk {index} says it has {chunk_len} bytes but only {} are left",
                        length - start
                    ),
                )
            })?;
        let body = &data[start..end];
        match (index, chunk_type) {
            (0, JSON_CHUNK) => json = Some((body, start)),
            (0, _) => {
                return Err(at(
                    pos + 4,
                    format!(
                        "the first GLB chunk must be JSON (type 0x4E4F534A), found type 0x{chunk_type:08X}"
                    ),
                ))
            }
            (_, JSON_CHUNK) => {
                return Err(at(pos + 4, format!("GLB chunk {index} is a second JSON chunk")))
            }
            (1, BIN_CHUNK) => bin = Some(body),
            (_, BIN_CHUNK) => {
                return Err(at(
                    pos + 4,
                    format!("GLB chunk {index} is a BIN chunk; only the second chunk may be BIN"),
                ))
            }
            // Unknown chunk types are skipped, as the specification asks.
            _ => {}
        }
        pos = end;
        if pos < length && pos % 4 != 0 {
            return Err(at(
                pos,
                format!(
                    "GLB chunk {index} has length {chunk_len}, not a multiple of 4, so the next chunk is misaligned"
                ),
            ));
        }
        index += 1;
    }
    let (json, json_offset) = json.ok_or_else(|| at(12, "GLB file has no JSON chunk"))?;
    Ok(Glb {
        json,
        json_offset,
        bin,
    })
}

/// Assembles a GLB file from the JSON text and the binary buffer (either may need
/// padding; the JSON is padded with spaces, the buffer with zeros).
///
/// # Errors
/// The file would exceed the 4 GiB a GLB length field can describe.
pub(super) fn write(json: &[u8], bin: &[u8]) -> Result<Vec<u8>, FormatError> {
    let pad = |n: usize| (4 - n % 4) % 4;
    let json_len = json.len() + pad(json.len());
    let bin_len = bin.len() + pad(bin.len());
    let total = 12 + 8 + json_len + if bin.is_empty() { 0 } else { 8 + bin_len };
    let too_big = || {
        FormatError::new(
            Location::File,
            format!("the GLB would have {total} bytes; the format is limited to 4 GiB"),
        )
    };
    let total32 = u32::try_from(total).map_err(|_| too_big())?;
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&total32.to_le_bytes());
    out.extend_from_slice(
        &u32::try_from(json_len)
            .map_err(|_| too_big())?
            .to_le_bytes(),
    );
    out.extend_from_slice(&JSON_CHUNK.to_le_bytes());
    out.extend_from_slice(json);
    out.resize(out.len() + pad(json.len()), b' ');
    if !bin.is_empty() {
        out.extend_from_slice(&u32::try_from(bin_len).map_err(|_| too_big())?.to_le_bytes());
        out.extend_from_slice(&BIN_CHUNK.to_le_bytes());
        out.extend_from_slice(bin);
        out.resize(out.len() + pad(bin.len()), 0);
    }
    Ok(out)
}
