//! Streaming triangle readers: a mesh file read triangle by triangle, without
//! building a [`crate::Mesh`], for meshes larger than memory (vertex clustering's
//! out-of-core mode, after Lindstrom 2000).
//!
//! [`for_each_triangle`] calls a closure with each triangle's three corner positions
//! and its group id, in file order, exactly as [`crate::io::read_mesh`] would
//! produce them (same fan triangulation, same `f64 → f32` rounding, same group ids),
//! and returns a [`StreamSummary`] (counts, bounding box of all vertices, group
//! names). Formats:
//! - **STL**, binary and ASCII: a true triangle soup; memory is a fixed buffer;
//! - **binary PLY** (either byte order): vertices are read first and their positions
//!   kept (12 bytes per vertex), then faces (and `tristrips`) are streamed;
//! - **OBJ**: `v` positions are kept (12 bytes per vertex), faces are streamed;
//!   `vt`/`vn` indices are not checked, `usemtl` gives the group ids.
//!
//! ASCII PLY, OFF, glTF and Hoppe `.m` are refused with a message saying so. Errors
//! name the file and the line or byte offset, as the in-memory readers do; a NaN or
//! infinite coordinate is an error.
//!
//! This module owns the public entry point and the choice of reader by format; each
//! format module owns its streaming reader (`stl::stream`, `ply::stream`,
//! `obj::stream`), built on the byte source and triangle sink of the private
//! `io::stream_base` module, which depends on no format (so the formats and this
//! module do not import each other).

pub use super::stream_base::StreamSummary;
use super::stream_base::{Sink, Source, StreamError};
use super::{Format, FormatError, IoError, Location};
use std::path::Path;

/// Calls `f(corners, group)` for every triangle of the mesh file at `path`, in file
/// order, reading it in a stream (see the module documentation for the formats).
///
/// # Errors
/// [`IoError`] naming the file: it cannot be read, its format cannot be streamed, or
/// it is malformed (with the line or byte offset).
pub fn for_each_triangle(
    path: impl AsRef<Path>,
    mut f: impl FnMut(&[[f32; 3]; 3], u32),
) -> Result<StreamSummary, IoError> {
    let path = path.as_ref();
    let format = Format::from_path(path).ok_or_else(|| IoError::UnknownFormat {
        path: path.to_path_buf(),
    })?;
    let io_err = |source| IoError::Io {
        path: path.to_path_buf(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io_err)?;
    let len = file.metadata().map_err(io_err)?.len();
    let mut src = Source::new(file);
    let mut sink = Sink::new(&mut f);
    let result = match format {
        Format::Stl => super::stl::stream(&mut src, len, &mut sink),
        Format::Ply => super::ply::stream(&mut src, len, &mut sink),
        Format::Obj => super::obj::stream(&mut src, &mut sink),
        other => Err(StreamError::Format(FormatError::new(
            Location::File,
            format!(
                "{} files cannot be streamed (use STL, binary PLY or OBJ, or read the mesh into memory)",
                other.name()
            ),
        ))),
    };
    match result {
        Ok(()) => Ok(sink.summary),
        Err(StreamError::Io(source)) => Err(io_err(source)),
        Err(StreamError::Format(error)) => Err(IoError::Format {
            path: path.to_path_buf(),
            format,
            error,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;
    use crate::{read_mesh, write_mesh};

    /// The triangles a streaming read gives, as corner positions and groups.
    fn streamed(path: &Path) -> (Vec<[[f32; 3]; 3]>, Vec<u32>, StreamSummary) {
        let mut tris = Vec::new();
        let mut groups = Vec::new();
        let s = for_each_triangle(path, |t, g| {
            tris.push(*t);
            groups.push(g);
        })
        .expect("streams");
        (tris, groups, s)
    }

    fn in_memory(path: &Path) -> (Vec<[[f32; 3]; 3]>, Vec<u32>, crate::Mesh) {
        let m = read_mesh(path).expect("reads");
        let tris = m
            .triangles
            .iter()
            .map(|t| t.map(|i| m.positions[i as usize]))
            .collect();
        let groups = (0..m.triangles.len()).map(|t| m.group(t)).collect();
        (tris, groups, m)
    }

    #[test]
    fn every_format_streams_what_the_reader_reads() {
        let dir = tempfile::tempdir().unwrap();
        let mut mesh = generate::torus(12, 8, 1.0, 0.25);
        let n = mesh.triangles.len();
        mesh.groups = Some((0..n as u32).map(|t| t % 3).collect());
        mesh.group_names = vec!["a".into(), "b".into(), "c".into()];
        for (name, ascii) in [
            ("t.stl", false),
            ("t.stl", true),
            ("t.ply", false),
            ("t.obj", false),
        ] {
            let path = dir.path().join(name);
            write_mesh(
                &path,
                &mesh,
                &crate::io::WriteOptions::default().with_ascii(ascii),
            )
            .unwrap();
            let (a, ga, s) = streamed(&path);
            let (b, gb, m) = in_memory(&path);
            assert_eq!(a, b, "{name} ascii={ascii}");
            assert_eq!(ga, gb, "{name} ascii={ascii}");
            assert_eq!(s.triangles as usize, n);
            assert_eq!(s.bbox, m.bounding_box(false));
        }
    }

    #[test]
    fn errors_name_file_and_place() {
        let dir = tempfile::tempdir().unwrap();
        let obj = dir.path().join("bad.obj");
        std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n").unwrap();
        let e = for_each_triangle(&obj, |_, _| {}).unwrap_err().to_string();
        assert!(e.contains("bad.obj") && e.contains("line 5"), "{e}");
        let obj_nan = dir.path().join("nan.obj");
        std::fs::write(&obj_nan, "v 0 0 0\nv nan 0 0\n").unwrap();
        let e = for_each_triangle(&obj_nan, |_, _| {})
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2"), "{e}");
        // A binary STL that claims more triangles than it holds.
        let stl = dir.path().join("short.stl");
        let mut b = vec![0u8; 80];
        b.extend_from_slice(&5u32.to_le_bytes());
        b.extend_from_slice(&[0u8; 60]);
        std::fs::write(&stl, &b).unwrap();
        let e = for_each_triangle(&stl, |_, _| {}).unwrap_err().to_string();
        assert!(e.contains("short.stl") && e.contains("byte"), "{e}");
        let ply = dir.path().join("a.ply");
        std::fs::write(
            &ply,
            "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
        )
        .unwrap();
        let e = for_each_triangle(&ply, |_, _| {}).unwrap_err().to_string();
        assert!(e.contains("ASCII"), "{e}");
        let off = dir.path().join("a.off");
        std::fs::write(&off, "OFF\n0 0 0\n").unwrap();
        let e = for_each_triangle(&off, |_, _| {}).unwrap_err().to_string();
        assert!(e.contains("cannot be streamed"), "{e}");
        let missing = dir.path().join("missing.stl");
        assert!(for_each_triangle(&missing, |_, _| {}).is_err());
    }

    #[test]
    fn truncated_binary_ply_names_the_byte() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.ply");
        write_mesh(
            &path,
            &generate::tetrahedron(),
            &crate::io::WriteOptions::default(),
        )
        .unwrap();
        let mut bytes = std::fs::read(&path).unwrap();
        bytes.truncate(bytes.len() - 5);
        std::fs::write(&path, &bytes).unwrap();
        let e = for_each_triangle(&path, |_, _| {}).unwrap_err().to_string();
        assert!(e.contains("t.ply") && e.contains("byte"), "{e}");
    }
}
