//! glTF 2.0 reader and writer: `.gltf` (JSON with external or data-URI buffers) and
//! `.glb` (the binary container), following the Khronos glTF 2.0 specification
//! (<https://registry.khronos.org/glTF/specs/2.0/glTF-2.0.html>).
//!
//! # Reading
//! [`read()`] accepts JSON or GLB (detected by the `glTF` magic). Buffers come from the
//! GLB `BIN` chunk, base64 data URIs, or files relative to the glTF file (never from
//! absolute paths or URLs). Every accessor and buffer view is bounds-checked before
//! anything is decoded. All component types, the `normalized` flag, byte strides,
//! sparse accessors and `KHR_mesh_quantization` are supported. Compressed geometry
//! (`KHR_draco_mesh_compression`, `EXT_meshopt_compression`) is refused with a
//! message saying so, as is any other required extension meshlod does not know.
//!
//! Each glTF mesh becomes one [`Part`](super::Part): its triangle primitives
//! (`TRIANGLES`, `TRIANGLE_STRIP`, `TRIANGLE_FAN`, converted to triangle lists; the
//! index-degenerate stitching triangles of strips and fans are dropped) are concatenated,
//! with the primitive's position in the mesh as the triangle group and the material
//! name as the group name, so material borders become attribute seams for a
//! simplifier. Primitives sharing the same vertex accessors share vertices. Points
//! and lines are not triangles: they stay out of the [`Mesh`] and are written back
//! untouched. `POSITION`, `NORMAL`, `TANGENT`, `TEXCOORD_0`, `TEXCOORD_1`, `COLOR_0`,
//! `JOINTS_0` and `WEIGHTS_0` are read into [`Mesh::attributes`]; other attributes
//! and morph targets stay in the document. The part's instances are the world
//! matrices of the nodes of the default scene that draw the mesh (including
//! `EXT_mesh_gpu_instancing` instances).
//!
//! # Writing
//! A scene read from glTF carries its [`GltfSource`]; the writer then gives the same
//! document back (nodes, materials, textures, skins, animations, cameras, extensions,
//! extras) with each part's geometry put back into its glTF mesh. A part whose mesh
//! is unchanged since reading keeps its original primitives and accessors exactly. A
//! changed part is written as one `TRIANGLES` primitive per group that still has
//! triangles (keeping the primitive's material, extras and extensions, and the
//! attribute set it had), with new accessors; primitives whose triangles all
//! vanished are removed (a mesh left without primitives is removed and nodes drawing
//! it lose their `mesh`, `skin` and `weights`). Morph targets of a changed mesh are
//! dropped (with the mesh's and its nodes' `weights` and the animation channels
//! driving them), because the simplified vertices no longer match them; nothing else
//! about them is recorded. Attributes meshlod does not model (`TEXCOORD_2`,
//! `JOINTS_1`, custom attributes) are likewise lost on changed parts. A part's name,
//! when set, becomes its mesh's name. Part instances are not written back: the
//! original node hierarchy is kept. The scene must still have one part per glTF mesh
//! (clear [`Scene::gltf`](super::Scene::gltf) to write a restructured scene as a
//! fresh document). Extensions other than `EXT_mesh_gpu_instancing` are assumed not
//! to refer to accessors or buffer views (true of the material, texture, light and
//! metadata extensions), since those are renumbered.
//!
//! The output has a single buffer: only the accessors and buffer views still
//! referenced are kept, buffer views are trimmed to the bytes their accessors use and
//! packed at 4-byte alignment. New accessors are `FLOAT` (positions with `min`/`max`),
//! with `UNSIGNED_SHORT` indices when the primitive has at most 65 535 vertices
//! (65 535 itself is the forbidden restart value) and `UNSIGNED_INT` otherwise.
//! Normals are renormalised and tangent handedness snapped to ±1 so the output stays
//! valid. External images are copied next to a `.gltf` written elsewhere (when not
//! already there), and embedded into a `.glb` (or as data URIs by
//! [`write_embedded`]) so those are self-contained.
//!
//! A scene without a glTF document (e.g. read from OBJ) is written as a fresh
//! document (`asset.generator` "meshlod"): one mesh per part that has triangles, one
//! primitive per group with a material named after the group (groups of the same
//! name share a material), one node per instance (with its matrix unless it is the
//! identity) and one scene holding those nodes. Every attribute stream of the mesh is
//! written, including `JOINTS_0`/`WEIGHTS_0` (there is no skin to use them).

mod accessor;
mod glb;
mod json;
mod lod;
mod read;
mod refs;
/// Texture coordinates between glTF's convention (origin at the image's top left,
/// `v` down) and the mesh model's, which is OBJ's, PLY's and OFF's (origin at the
/// bottom left, `v` up): `v ↦ 1 − v`, its own inverse. Read and written through it,
/// a texture stays on the surface when a glTF becomes an OBJ or the reverse; a
/// glTF read and written back gets its coordinates again to within `f32` rounding
/// of `1 − v` (below 6·10⁻⁸ of the image).
pub(crate) fn flip_v(mut uv: Vec<[f32; 2]>) -> Vec<[f32; 2]> {
    for t in &mut uv {
        t[1] = 1.0 - t[1];
    }
    uv
}

#[cfg(test)]
mod tests;
mod uri;
mod write;

pub use lod::{add_lods, MeshLods};

use super::{FormatError, Scene, WriteError};
use crate::mesh::Mesh;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The original glTF document kept with a scene so a writer can give it back: the
/// JSON, the binary buffers it refers to (held whole in memory, shared between
/// clones), the directory it came from (for external images), and how each glTF mesh
/// was turned into a [`Part`](super::Part).
#[derive(Clone, PartialEq, Default)]
pub struct GltfSource {
    /// The JSON document as read.
    document: serde_json::Value,
    /// The data of each buffer (`None` for buffers no buffer view uses).
    buffers: Vec<Option<Arc<[u8]>>>,
    /// Where external files of the document live.
    base_dir: Option<PathBuf>,
    /// One entry per glTF mesh (= per part, in order).
    meshes: Vec<MeshSource>,
}

/// How one glTF mesh became a part.
#[derive(Debug, Clone, PartialEq)]
struct MeshSource {
    /// [`fingerprint`] of the part's mesh as read: equal on write means unchanged.
    fingerprint: u64,
    /// One entry per glTF primitive, in order.
    primitives: Vec<PrimitiveSource>,
    /// Write the part's geometry even when its fingerprint matches (a mesh added
    /// to the document, e.g. a coarser level of detail).
    rewrite: bool,
    /// Base positions of a geomorph, one per vertex of the part's mesh: written as
    /// `POSITION` with the mesh's own positions as the single morph target (weight 0
    /// shows these, weight 1 the part's positions).
    morph_from: Option<Vec<[f32; 3]>>,
}

/// How one glTF primitive became part of a part's mesh.
#[derive(Debug, Clone, PartialEq)]
struct PrimitiveSource {
    /// Topology mode (4 = triangles, 5 = strip, 6 = fan, 0–3 points and lines).
    mode: u32,
    /// Material index, if any.
    material: Option<usize>,
    /// Names of the primitive's attributes, sorted.
    attribute_names: Vec<String>,
    /// The group id of its triangles in the part's mesh; `None` for primitives that
    /// are passed through (points, lines, no `POSITION`).
    group: Option<u32>,
    /// Which modelled attribute streams it had (bits of [`Streams`]).
    streams: Streams,
    /// `COLOR_0` was a `VEC3` (no alpha).
    color_rgb: bool,
    /// `JOINTS_0` was `UNSIGNED_BYTE`.
    joints_u8: bool,
}

/// A set of modelled attribute streams, as bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
struct Streams(u8);

impl Streams {
    const NORMAL: u8 = 1;
    const TANGENT: u8 = 2;
    const UV0: u8 = 4;
    const UV1: u8 = 8;
    const COLOR: u8 = 16;
    const JOINTS: u8 = 32;
    const WEIGHTS: u8 = 64;
    const ALL: Self = Self(127);

    fn has(self, bit: u8) -> bool {
        self.0 & bit != 0
    }

    fn set(&mut self, bit: u8) {
        self.0 |= bit;
    }
}

impl fmt::Debug for GltfSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let count = |key: &str| {
            self.document
                .get(key)
                .and_then(serde_json::Value::as_array)
                .map_or(0, Vec::len)
        };
        f.debug_struct("GltfSource")
            .field("meshes", &count("meshes"))
            .field("nodes", &count("nodes"))
            .field("accessors", &count("accessors"))
            .field("materials", &count("materials"))
            .field("images", &count("images"))
            .field(
                "buffer_bytes",
                &self
                    .buffers
                    .iter()
                    .map(|b| b.as_ref().map_or(0, |b| b.len()))
                    .collect::<Vec<_>>(),
            )
            .field("base_dir", &self.base_dir)
            .finish()
    }
}

impl GltfSource {
    /// The glTF JSON document as read (buffers and accessors as in the file).
    #[must_use]
    pub fn document(&self) -> &serde_json::Value {
        &self.document
    }

    /// The directory external buffers and images were looked up in, if any.
    #[must_use]
    pub fn base_dir(&self) -> Option<&Path> {
        self.base_dir.as_deref()
    }
}

/// Reads a `.gltf` or `.glb` from memory (GLB is recognised by its `glTF` magic);
/// external buffers are looked up in `base_dir`.
///
/// # Errors
/// [`FormatError`] naming the element that is wrong: malformed GLB container
/// ([`Location::Byte`](super::Location::Byte)), invalid JSON (line), a buffer that
/// cannot be loaded, an accessor or buffer view out of bounds, an index out of range
/// ([`Location::Element`](super::Location::Element)), compressed geometry or an
/// unsupported required extension.
pub fn read(data: &[u8], base_dir: Option<&Path>) -> Result<Scene, FormatError> {
    read::read(data, base_dir)
}

/// Writes `scene` to `path` as `.glb` (`glb`), or as `.gltf` JSON with the binary
/// data in `<stem>.bin` next to it; external images of the source document are
/// copied next to a `.gltf` written to another directory (when not already there) and
/// embedded into a `.glb`.
///
/// # Errors
/// [`WriteError::Io`] when a file cannot be written, [`WriteError::Format`] when the
/// scene cannot be expressed (e.g. more than 4 GiB of binary data in a GLB, or a
/// scene whose part count no longer matches its glTF document).
pub fn write_file(path: &Path, scene: &Scene, glb: bool) -> Result<(), WriteError> {
    write::write_file(path, scene, glb)
}

/// Serialises `scene` as a self-contained `.gltf`: the buffer, and external images of
/// the source document when they can be read, as base64 data URIs.
///
/// # Errors
/// [`FormatError`] when the scene cannot be expressed.
pub fn write_embedded(scene: &Scene) -> Result<Vec<u8>, FormatError> {
    write::write_embedded(scene)
}

/// Serialises `scene` as a `.glb`, with external images of the source document
/// embedded when they can be read.
///
/// # Errors
/// [`FormatError`] when the scene cannot be expressed (e.g. more than 4 GiB).
pub fn write_glb(scene: &Scene) -> Result<Vec<u8>, FormatError> {
    write::write_glb(scene)
}

/// A 64-bit digest of everything in `mesh` the writer puts into a glTF mesh
/// (positions, triangles, attribute streams, groups), to tell whether a part changed
/// since it was read. Not cryptographic; deterministic.
fn fingerprint(mesh: &Mesh) -> u64 {
    /// A multiply–rotate mix (in the style of FxHash) of one 64-bit word.
    fn mix(h: u64, w: u64) -> u64 {
        (h.rotate_left(5) ^ w).wrapping_mul(0x517c_c1b7_2722_0a95)
    }
    struct H(u64);
    impl H {
        fn word(&mut self, w: u64) {
            self.0 = mix(self.0, w);
        }
        /// Mixes a tagged stream of 32-bit values in four independent lanes (so the
        /// multiplications overlap), then folds the lanes in.
        fn stream<T: Copy>(&mut self, tag: u64, v: Option<&[T]>, bits: impl Fn(T) -> u32) {
            self.word(tag);
            let Some(v) = v else {
                return;
            };
            self.word(v.len() as u64);
            let mut lanes = [self.0, self.0 ^ 1, self.0 ^ 2, self.0 ^ 3];
            let mut it = v.chunks_exact(8);
            for c in &mut it {
                for (k, lane) in lanes.iter_mut().enumerate() {
                    let w = u64::from(bits(c[2 * k])) | u64::from(bits(c[2 * k + 1])) << 32;
                    *lane = mix(*lane, w);
                }
            }
            for &r in it.remainder() {
                lanes[0] = mix(lanes[0], u64::from(bits(r)));
            }
            for l in lanes {
                self.word(l);
            }
        }
    }
    let a = &mesh.attributes;
    let f = f32::to_bits;
    let mut h = H(0x6d65_7368_6c6f_6421);
    h.stream(1, Some(mesh.positions.as_flattened()), f);
    h.stream(2, Some(mesh.triangles.as_flattened()), |x| x);
    h.stream(3, a.normals.as_deref().map(<[[f32; 3]]>::as_flattened), f);
    h.stream(4, a.tangents.as_deref().map(<[[f32; 4]]>::as_flattened), f);
    h.stream(5, a.uv0.as_deref().map(<[[f32; 2]]>::as_flattened), f);
    h.stream(6, a.uv1.as_deref().map(<[[f32; 2]]>::as_flattened), f);
    h.stream(7, a.colors.as_deref().map(<[[f32; 4]]>::as_flattened), f);
    h.stream(8, a.weights.as_deref().map(<[[f32; 4]]>::as_flattened), f);
    h.stream(
        9,
        a.joints.as_deref().map(<[[u16; 4]]>::as_flattened),
        u32::from,
    );
    h.stream(10, mesh.groups.as_deref(), |x| x);
    h.0
}
