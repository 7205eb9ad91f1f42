//! Reading and writing meshes: OBJ, PLY, STL, OFF, glTF 2.0 (`.gltf`, `.glb`) and
//! Hoppe's `.m`, chosen by file extension.
//!
//! Every reader works on the whole file in memory (`&[u8]`), validates what it reads
//! (indices in range, finite coordinates, counts the file can hold) and returns a
//! [`FormatError`] with a [`Location`] (line, byte offset or element); [`read_scene`]
//! adds the file name. No input makes a reader panic: `fuzz/` exercises every one.
//!
//! A file becomes a [`Scene`]: one or more [`Part`]s (a glTF mesh, or the whole file
//! for the other formats), each a [`Mesh`] with the world transforms of its instances.
//! [`Scene::flatten`] bakes every instance into one world-space mesh, which is what
//! `meshlod info` measures. glTF scenes keep their original document so a writer can
//! put simplified geometry back with materials, textures, nodes and skins intact.

pub mod gltf;
pub mod hoppe;
pub mod obj;
pub mod off;
pub mod ply;
pub mod stl;
pub mod stream;
mod stream_base;
#[cfg(test)]
mod test_support;
pub(crate) mod text;

use crate::mesh::{Mesh, MeshError};
use std::fmt;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// A column-major 4×4 matrix (glTF layout): `m[column][row]`.
pub type Matrix4 = [[f32; 4]; 4];

/// The identity matrix.
pub const IDENTITY: Matrix4 = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

/// The largest factor by which `m` (column-major) stretches a length: the spectral
/// norm of its linear part, by power iteration on `MᵀM` from each axis (one of
/// them is never orthogonal to the largest eigenvector); 1 for a zero or
/// non-finite matrix.
#[must_use]
pub fn stretch(m: &Matrix4) -> f64 {
    let a: [[f64; 3]; 3] = std::array::from_fn(|c| std::array::from_fn(|r| f64::from(m[c][r])));
    let g: [[f64; 3]; 3] =
        std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * a[j][k]).sum()));
    let mut largest = 0.0f64;
    for axis in 0..3 {
        let mut v: [f64; 3] = std::array::from_fn(|k| if k == axis { 1.0 } else { 0.0 });
        for _ in 0..64 {
            let w: [f64; 3] = std::array::from_fn(|i| (0..3).map(|j| g[i][j] * v[j]).sum());
            let n = w.iter().map(|x| x * x).sum::<f64>().sqrt();
            if !(n.is_finite() && n > 0.0) {
                break;
            }
            largest = largest.max(n);
            v = w.map(|x| x / n);
        }
    }
    if largest > 0.0 {
        largest.sqrt()
    } else {
        1.0
    }
}

/// File formats, chosen by extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// Wavefront OBJ (`.obj`).
    Obj,
    /// Stanford PLY (`.ply`), ASCII or binary.
    Ply,
    /// STL (`.stl`), ASCII or binary.
    Stl,
    /// Object File Format (`.off`), also COFF/NOFF/STOFF headers.
    Off,
    /// glTF 2.0 JSON (`.gltf`) with external or embedded buffers.
    Gltf,
    /// glTF 2.0 binary (`.glb`).
    Glb,
    /// Hugues Hoppe's `.m` format (Mesh-processing-library).
    HoppeM,
}

impl Format {
    /// The format for `path`'s extension (case-insensitive), if known.
    #[must_use]
    pub fn from_path(path: &Path) -> Option<Self> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Some(match ext.as_str() {
            "obj" => Self::Obj,
            "ply" => Self::Ply,
            "stl" => Self::Stl,
            "off" | "coff" | "noff" => Self::Off,
            "gltf" => Self::Gltf,
            "glb" => Self::Glb,
            "m" => Self::HoppeM,
            _ => return None,
        })
    }

    /// Short name for messages.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Obj => "OBJ",
            Self::Ply => "PLY",
            Self::Stl => "STL",
            Self::Off => "OFF",
            Self::Gltf => "glTF",
            Self::Glb => "GLB",
            Self::HoppeM => "Hoppe .m",
        }
    }
}

/// Where in a file an error was found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Location {
    /// Nowhere in particular (the whole file).
    File,
    /// A 1-based line of a text file.
    Line(u64),
    /// A byte offset in a binary file.
    Byte(u64),
    /// An element of the file's model, e.g. `("accessor", 3)` or `("face", 17)`.
    Element(&'static str, u64),
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::File => Ok(()),
            Self::Line(l) => write!(f, "line {l}: "),
            Self::Byte(b) => write!(f, "byte {b}: "),
            Self::Element(kind, i) => write!(f, "{kind} {i}: "),
        }
    }
}

/// An error from a format reader or writer, before the file name is attached.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("{location}{message}")]
pub struct FormatError {
    /// Where.
    pub location: Location,
    /// What, in words.
    pub message: String,
}

impl FormatError {
    /// An error at `location`.
    #[must_use]
    pub fn new(location: Location, message: impl Into<String>) -> Self {
        Self {
            location,
            message: message.into(),
        }
    }
}

/// An error reading or writing a mesh file; always names the file.
#[derive(Debug, Error)]
pub enum IoError {
    /// The operating system refused (missing file, permissions, disk full).
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The extension names no format meshlod knows.
    #[error("{}: unknown mesh format (expected .obj, .ply, .stl, .off, .gltf, .glb or .m)", path.display())]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
    /// The file is malformed, or uses a feature meshlod refuses (e.g. compressed glTF).
    #[error("{}: {format} {error}", path.display(), format = format.name())]
    Format {
        /// The file.
        path: PathBuf,
        /// Its format.
        format: Format,
        /// Where and what.
        error: FormatError,
    },
    /// The file parsed but the mesh breaks an invariant (bad index, NaN coordinate).
    #[error("{}: invalid mesh: {source}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// The broken invariant.
        source: MeshError,
    },
}

/// One mesh of a scene with the places it is drawn.
#[derive(Debug, Clone, PartialEq)]
pub struct Part {
    /// Name from the file (glTF mesh name, OBJ `o`), if any.
    pub name: Option<String>,
    /// The geometry, in the part's local space.
    pub mesh: Mesh,
    /// World transforms of its instances (column-major); `[IDENTITY]` outside glTF.
    /// Empty when the part is not drawn by the default scene.
    pub instances: Vec<Matrix4>,
}

/// What a file holds: parts with instances, plus what a writer needs to give the file
/// back as it was (OBJ material libraries, the glTF document).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Scene {
    /// The meshes.
    pub parts: Vec<Part>,
    /// OBJ `mtllib` file names, written back to OBJ output.
    pub material_libraries: Vec<String>,
    /// The original glTF document, when read from glTF.
    pub gltf: Option<Box<gltf::GltfSource>>,
}

impl Scene {
    /// A scene holding one mesh drawn once at the origin.
    #[must_use]
    pub fn from_mesh(mesh: Mesh) -> Self {
        Self {
            parts: vec![Part {
                name: None,
                mesh,
                instances: vec![IDENTITY],
            }],
            material_libraries: Vec::new(),
            gltf: None,
        }
    }

    /// Every instance of every part in world space, concatenated into one mesh. Group
    /// ids are kept when the scene has a single part; otherwise each part's groups are
    /// offset so groups of different parts stay distinct, and names are merged.
    #[must_use]
    pub fn flatten(&self) -> Mesh {
        self.flattened().into_owned()
    }

    /// As [`Self::flatten`], without a copy when the scene is one part drawn once at
    /// the origin (the usual single-mesh file): then the part's mesh is borrowed.
    #[must_use]
    pub fn flattened(&self) -> std::borrow::Cow<'_, Mesh> {
        if let [part] = self.parts.as_slice() {
            if part.instances == [IDENTITY] {
                return std::borrow::Cow::Borrowed(&part.mesh);
            }
        }
        std::borrow::Cow::Owned(self.flatten_parts())
    }

    fn flatten_parts(&self) -> Mesh {
        let mut out = Mesh::default();
        let mut group_offset = 0u32;
        for part in &self.parts {
            let groups_here = part
                .mesh
                .groups
                .as_ref()
                .and_then(|g| g.iter().max().map(|m| m + 1))
                .unwrap_or(1)
                .max(part.mesh.group_names.len() as u32);
            for m in &part.instances {
                let mut placed = part.mesh.clone();
                if *m != IDENTITY {
                    placed.transform(m);
                }
                out.append(&placed, group_offset);
            }
            out.group_names.resize(group_offset as usize, String::new());
            out.group_names
                .extend(part.mesh.group_names.iter().cloned());
            group_offset += groups_here;
        }
        if self.parts.len() == 1 {
            out.group_names = self.parts[0].mesh.group_names.clone();
        }
        out
    }

    /// World positions of every instance of every part, in the vertex order of
    /// [`Self::flatten`], transformed in f64 (not rounded to f32).
    #[must_use]
    pub fn world_positions_f64(&self) -> Vec<[f64; 3]> {
        let mut out = Vec::new();
        for part in &self.parts {
            for m in &part.instances {
                let a = |r: usize, c: usize| f64::from(m[c][r]);
                out.extend(part.mesh.positions.iter().map(|p| {
                    let v = [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])];
                    std::array::from_fn(|r| {
                        a(r, 0) * v[0] + a(r, 1) * v[1] + a(r, 2) * v[2] + a(r, 3)
                    })
                }));
            }
        }
        out
    }

    /// Total triangles over all instances.
    #[must_use]
    pub fn instanced_triangle_count(&self) -> usize {
        self.parts
            .iter()
            .map(|p| p.mesh.triangles.len() * p.instances.len())
            .sum()
    }
}

/// Options for writers.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct WriteOptions {
    /// Write PLY and STL as text instead of binary. Default: false (binary).
    pub ascii: bool,
}

impl WriteOptions {
    /// Sets [`Self::ascii`].
    #[must_use]
    pub fn with_ascii(mut self, ascii: bool) -> Self {
        self.ascii = ascii;
        self
    }
}

/// Reads the file at `path` as a scene, choosing the format by extension.
///
/// # Errors
/// [`IoError`] naming the file: it cannot be read, has an unknown extension, is
/// malformed (with the line, byte or element), or breaks a mesh invariant.
pub fn read_scene(path: impl AsRef<Path>) -> Result<Scene, IoError> {
    let path = path.as_ref();
    let format = Format::from_path(path).ok_or_else(|| IoError::UnknownFormat {
        path: path.to_path_buf(),
    })?;
    let data = std::fs::read(path).map_err(|source| IoError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    read_scene_from_bytes(&data, format, path.parent()).map_err(|e| attach_path(e, path, format))
}

/// Reads a scene from bytes in memory. `base_dir` is where a `.gltf` looks for its
/// external buffers (none are loaded when it is `None`).
///
/// # Errors
/// [`ReadError`]: the data is malformed, or the mesh breaks an invariant.
pub fn read_scene_from_bytes(
    data: &[u8],
    format: Format,
    base_dir: Option<&Path>,
) -> Result<Scene, ReadError> {
    if data.is_empty() {
        return Err(FormatError::new(Location::File, "file is empty (0 bytes)").into());
    }
    // A UTF-8 byte-order mark before a text header (some Windows editors write one;
    // glTF skips it itself; an OBJ took it for part of its first keyword and dropped
    // that line). An STL only when text ("solid") follows, so
    // a binary header that happens to start with those bytes stays whole. Byte
    // offsets in errors then count from after it.
    const BOM: &[u8] = b"\xEF\xBB\xBF";
    let data = match (format, data.strip_prefix(BOM)) {
        (Format::Obj | Format::Off | Format::HoppeM | Format::Ply, Some(rest)) => rest,
        (Format::Stl, Some(rest)) if rest.starts_with(b"solid") => rest,
        _ => data,
    };
    let scene = match format {
        Format::Obj => obj::read(data)?,
        Format::Ply => Scene::from_mesh(ply::read(data)?),
        Format::Stl => Scene::from_mesh(stl::read(data)?),
        Format::Off => Scene::from_mesh(off::read(data)?),
        Format::HoppeM => Scene::from_mesh(hoppe::read(data)?),
        Format::Gltf | Format::Glb => gltf::read(data, base_dir)?,
    };
    for part in &scene.parts {
        part.mesh.validate()?;
    }
    Ok(scene)
}

/// Reads the file at `path` and flattens it into one world-space mesh.
///
/// # Errors
/// As [`read_scene`].
pub fn read_mesh(path: impl AsRef<Path>) -> Result<Mesh, IoError> {
    read_scene(path).map(|s| s.flatten())
}

/// An error from [`read_scene_from_bytes`]: a format error or an invalid mesh.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ReadError {
    /// Malformed data.
    #[error(transparent)]
    Format(#[from] FormatError),
    /// A broken mesh invariant.
    #[error(transparent)]
    Invalid(#[from] MeshError),
}

fn attach_path(e: ReadError, path: &Path, format: Format) -> IoError {
    match e {
        ReadError::Format(error) => IoError::Format {
            path: path.to_path_buf(),
            format,
            error,
        },
        ReadError::Invalid(source) => IoError::Invalid {
            path: path.to_path_buf(),
            source,
        },
    }
}

/// Writes `scene` to `path` in the format of its extension. glTF output from a glTF
/// scene keeps the original document (materials, textures, nodes, skins); other
/// formats receive [`Scene::flatten`].
///
/// # Errors
/// [`IoError`] naming the file: unknown extension, the write failed, or the scene
/// cannot be expressed in the format (e.g. more than 2³² vertices).
pub fn write_scene(
    path: impl AsRef<Path>,
    scene: &Scene,
    options: &WriteOptions,
) -> Result<(), IoError> {
    let path = path.as_ref();
    let format = Format::from_path(path).ok_or_else(|| IoError::UnknownFormat {
        path: path.to_path_buf(),
    })?;
    let io_err = |source| IoError::Io {
        path: path.to_path_buf(),
        source,
    };
    if matches!(format, Format::Gltf | Format::Glb) {
        return gltf::write_file(path, scene, format == Format::Glb).map_err(|e| match e {
            WriteError::Io(source) => io_err(source),
            WriteError::Format(error) => IoError::Format {
                path: path.to_path_buf(),
                format,
                error,
            },
        });
    }
    let bytes = write_scene_to_bytes(scene, format, options).map_err(|error| IoError::Format {
        path: path.to_path_buf(),
        format,
        error,
    })?;
    std::fs::write(path, bytes).map_err(io_err)
}

/// Serialises `scene` in a format that is a single file (everything but `.gltf`,
/// whose buffers may be separate; `.gltf` here embeds buffers as data URIs).
///
/// # Errors
/// [`FormatError`] when the scene cannot be expressed in the format.
pub fn write_scene_to_bytes(
    scene: &Scene,
    format: Format,
    options: &WriteOptions,
) -> Result<Vec<u8>, FormatError> {
    let mut out = Vec::new();
    match format {
        Format::Obj => obj::write(scene, &mut out)?,
        Format::Ply => ply::write(&scene.flatten(), options.ascii, &mut out)?,
        Format::Stl => stl::write(&scene.flatten(), options.ascii, &mut out)?,
        Format::Off => off::write(&scene.flatten(), &mut out)?,
        Format::HoppeM => hoppe::write(&scene.flatten(), &mut out)?,
        Format::Gltf => out = gltf::write_embedded(scene)?,
        Format::Glb => out = gltf::write_glb(scene)?,
    }
    Ok(out)
}

/// Writes `mesh` to `path` (a one-part scene).
///
/// # Errors
/// As [`write_scene`].
pub fn write_mesh(
    path: impl AsRef<Path>,
    mesh: &Mesh,
    options: &WriteOptions,
) -> Result<(), IoError> {
    write_scene(path, &Scene::from_mesh(mesh.clone()), options)
}

/// An error from a writer that writes files itself (glTF with side files).
#[derive(Debug, Error)]
pub enum WriteError {
    /// The operating system refused.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// The scene cannot be expressed.
    #[error(transparent)]
    Format(#[from] FormatError),
}

/// The largest count of elements of at least `min_bytes` bytes each that `data` can
/// hold: the cap readers put on header counts before allocating.
#[must_use]
pub(crate) fn max_elements(data_len: usize, min_bytes: usize) -> u64 {
    (data_len / min_bytes.max(1)) as u64
}

#[cfg(test)]
mod stretch_tests {
    use super::{stretch, IDENTITY};

    #[test]
    fn stretch_is_the_largest_scale_of_a_transform() {
        assert!((stretch(&IDENTITY) - 1.0).abs() < 1e-12);
        // Scale (2, 5, 3), then a quarter turn about z, then a translation.
        let mut m = IDENTITY;
        m[0] = [0.0, 2.0, 0.0, 0.0];
        m[1] = [-5.0, 0.0, 0.0, 0.0];
        m[2] = [0.0, 0.0, 3.0, 0.0];
        m[3] = [7.0, 8.0, 9.0, 1.0];
        assert!((stretch(&m) - 5.0).abs() < 1e-9, "{}", stretch(&m));
        assert!((stretch(&[[0.0; 4]; 4]) - 1.0).abs() < 1e-12);
    }
}
