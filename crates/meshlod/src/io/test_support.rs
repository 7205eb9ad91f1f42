//! Helpers shared by the format readers' unit tests (compiled for tests only).

use super::{FormatError, Location};
use crate::mesh::Mesh;

/// The bit patterns of every position coordinate, so round trips can be checked to
/// the bit (including the sign of zero).
pub(crate) fn position_bits(m: &Mesh) -> Vec<u32> {
    m.positions.iter().flatten().map(|x| x.to_bits()).collect()
}

/// `sample` with the byte at `at` (if any) replaced by `byte`, cut to `cut` bytes
/// (at least one): a nearly valid file for the never-panic properties.
pub(crate) fn mutated(sample: &[u8], at: usize, byte: u8, cut: usize) -> Vec<u8> {
    let mut data = sample.to_vec();
    if let Some(b) = data.get_mut(at) {
        *b = byte;
    }
    data.truncate(cut.max(1));
    data
}

/// Overwrites `file` at the given (index, byte) edits, then returns it and its
/// prefix cut at `cut`: both must read without a panic, whatever the result.
pub(crate) fn corrupted(
    mut file: Vec<u8>,
    edits: &[(proptest::sample::Index, u8)],
    cut: &proptest::sample::Index,
) -> (Vec<u8>, usize) {
    for (at, byte) in edits {
        let i = at.index(file.len());
        file[i] = *byte;
    }
    let keep = cut.index(file.len());
    (file, keep)
}

/// For each `(line, message)` case, `err(base + line)` must fail at text line
/// `line_no` with an error containing `message`.
pub(crate) fn assert_line_errors(
    err: impl Fn(&str) -> FormatError,
    base: &str,
    cases: &[(&str, &str)],
    line_no: u64,
) {
    for (line, message) in cases {
        let e = err(&format!("{base}{line}"));
        assert_eq!(e.location, Location::Line(line_no), "{line}");
        assert!(e.message.contains(message), "{line}: {}", e.message);
    }
}
