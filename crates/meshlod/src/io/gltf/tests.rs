//! Tests of the glTF reader and writer on tiny documents built in code.

use super::*;
use crate::io::{Location, Matrix4, Part, IDENTITY};
use crate::mesh::VertexAttributes;
use serde_json::{json, Value};

/// Builds a tiny glTF document: a JSON tree and the bytes of buffer 0.
struct Doc {
    json: Value,
    bin: Vec<u8>,
}

const F32: u32 = 5126;
const U8: u32 = 5121;
const I8: u32 = 5120;
const U16: u32 = 5123;
const I16: u32 = 5122;
const U32: u32 = 5125;

impl Doc {
    fn new() -> Self {
        Self {
            json: json!({
                "asset": { "version": "2.0" },
                "scene": 0,
                "scenes": [{ "nodes": [] }],
            }),
            bin: Vec::new(),
        }
    }

    fn push(&mut self, key: &str, v: Value) -> usize {
        let a = self.json[key].as_array_mut().map(|a| {
            a.push(v.clone());
            a.len() - 1
        });
        a.unwrap_or_else(|| {
            self.json[key] = json!([v]);
            0
        })
    }

    /// A buffer view over `bytes` (placed at a 4-byte boundary).
    fn view(&mut self, bytes: &[u8], stride: Option<usize>) -> usize {
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        let mut v = json!({ "buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len() });
        if let Some(s) = stride {
            v["byteStride"] = json!(s);
        }
        self.bin.extend_from_slice(bytes);
        self.push("bufferViews", v)
    }

    fn accessor(&mut self, view: usize, component: u32, ty: &str, count: usize) -> usize {
        self.push(
            "accessors",
            json!({ "bufferView": view, "componentType": component, "type": ty, "count": count }),
        )
    }

    fn f32s(&mut self, data: &[f32], ty: &str, n: usize) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|x| x.to_le_bytes()).collect();
        let v = self.view(&bytes, None);
        self.accessor(v, F32, ty, data.len() / n)
    }

    fn u16s(&mut self, data: &[u16], ty: &str, n: usize) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|x| x.to_le_bytes()).collect();
        let v = self.view(&bytes, None);
        self.accessor(v, U16, ty, data.len() / n)
    }

    fn u8s(&mut self, data: &[u8], ty: &str, n: usize) -> usize {
        let v = self.view(data, None);
        self.accessor(v, U8, ty, data.len() / n)
    }

    fn u32s(&mut self, data: &[u32], ty: &str, n: usize) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|x| x.to_le_bytes()).collect();
        let v = self.view(&bytes, None);
        self.accessor(v, U32, ty, data.len() / n)
    }

    /// A node drawing `mesh`, a root of the scene.
    fn root_node(&mut self, node: Value) -> usize {
        let n = self.push("nodes", node);
        if let Some(a) = self.json["scenes"][0]["nodes"].as_array_mut() {
            a.push(json!(n));
        }
        n
    }

    fn with_buffer(&self, uri: Option<String>) -> Value {
        let mut j = self.json.clone();
        if !self.bin.is_empty() {
            let mut b = json!({ "byteLength": self.bin.len() });
            if let Some(u) = uri {
                b["uri"] = json!(u);
            }
            j["buffers"] = json!([b]);
        }
        j
    }

    /// `.gltf` bytes with the buffer as a data URI.
    fn gltf(&self) -> Vec<u8> {
        let uri = uri::data_uri("application/octet-stream", &self.bin);
        serde_json::to_vec(&self.with_buffer(Some(uri))).unwrap()
    }

    /// `.glb` bytes.
    fn glb(&self) -> Vec<u8> {
        let json = serde_json::to_vec(&self.with_buffer(None)).unwrap();
        glb::write(&json, &self.bin).unwrap()
    }
}

/// The unit square in z = 0 as positions (4 vertices).
const SQUARE: [f32; 12] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0];

/// A document with one mesh: the unit square as two triangles (u16 indices), drawn
/// by one root node.
///
/// ```text
/// 3---2
/// | / |
/// 0---1
/// ```
fn square() -> Doc {
    let mut d = Doc::new();
    let pos = d.f32s(&SQUARE, "VEC3", 3);
    let idx = d.u16s(&[0, 1, 2, 0, 2, 3], "SCALAR", 1);
    d.push(
        "meshes",
        json!({ "name": "square", "primitives": [{ "attributes": { "POSITION": pos }, "indices": idx }] }),
    );
    d.root_node(json!({ "mesh": 0 }));
    d
}

fn read_ok(bytes: &[u8]) -> Scene {
    match read(bytes, None) {
        Ok(s) => s,
        Err(e) => panic!("read failed: {e}"),
    }
}

fn read_err(bytes: &[u8]) -> FormatError {
    match read(bytes, None) {
        Ok(_) => panic!("read should fail"),
        Err(e) => e,
    }
}

fn assert_err(e: &FormatError, location: Location, words: &str) {
    assert_eq!(e.location, location, "{e}");
    assert!(
        e.message.contains(words),
        "\"{e}\" should contain \"{words}\""
    );
}

// ---------------------------------------------------------------- GLB container

#[test]
fn glb_round_trip_of_the_container() {
    let s = read_ok(&square().glb());
    assert_eq!(s.parts.len(), 1);
    assert_eq!(s.parts[0].name.as_deref(), Some("square"));
    assert_eq!(s.parts[0].mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(s.parts[0].mesh.positions[2], [1.0, 1.0, 0.0]);
    assert_eq!(s.parts[0].instances, vec![IDENTITY]);
}

#[test]
fn glb_truncated_and_bad_headers() {
    let good = square().glb();
    // Fewer than 12 bytes.
    assert_err(
        &read_err(&good[..10]),
        Location::Byte(10),
        "truncated GLB header",
    );
    // Wrong magic is not GLB, nor JSON: the error says both.
    let mut bad = good.clone();
    bad[0] = b'x';
    assert_err(&read_err(&bad), Location::Byte(0), "neither a GLB");
    assert_err(
        &glb::parse(&bad).unwrap_err(),
        Location::Byte(0),
        "not a GLB",
    );
    // Version 1.
    let mut v1 = good.clone();
    v1[4] = 1;
    assert_err(&read_err(&v1), Location::Byte(4), "version 1");
    // Length field larger than the file.
    let cut = &good[..good.len() - 4];
    assert_err(
        &read_err(cut),
        Location::Byte(cut.len() as u64),
        "truncated GLB",
    );
    // Length field smaller than the header.
    let mut small = good.clone();
    small[8..12].copy_from_slice(&4u32.to_le_bytes());
    assert_err(&read_err(&small), Location::Byte(8), "less than the header");
    // JSON chunk length past the end.
    let mut long = good.clone();
    long[12..16].copy_from_slice(&100_000u32.to_le_bytes());
    assert_err(&read_err(&long), Location::Byte(12), "only");
    // Header only: no chunks.
    let mut empty = good[..12].to_vec();
    empty[8..12].copy_from_slice(&12u32.to_le_bytes());
    assert_err(&read_err(&empty), Location::Byte(12), "no JSON chunk");
    // A chunk header cut short.
    let mut short = good[..16].to_vec();
    short[8..12].copy_from_slice(&16u32.to_le_bytes());
    assert_err(&read_err(&short), Location::Byte(12), "chunk 0 header");
}

#[test]
fn glb_chunk_order_types_and_alignment() {
    // First chunk BIN instead of JSON.
    let good = square().glb();
    let mut bin_first = good.clone();
    bin_first[16..20].copy_from_slice(&0x004E_4942u32.to_le_bytes());
    assert_err(&read_err(&bin_first), Location::Byte(16), "must be JSON");
    // A JSON chunk of 3 bytes followed by another chunk is misaligned.
    let mut mis = Vec::new();
    mis.extend_from_slice(b"glTF");
    mis.extend_from_slice(&2u32.to_le_bytes());
    mis.extend_from_slice(&0u32.to_le_bytes());
    mis.extend_from_slice(&3u32.to_le_bytes());
    mis.extend_from_slice(&0x4E4F_534Au32.to_le_bytes());
    mis.extend_from_slice(b"{}}");
    mis.extend_from_slice(&[0; 9]);
    let n = mis.len() as u32;
    mis[8..12].copy_from_slice(&n.to_le_bytes());
    assert_err(&read_err(&mis), Location::Byte(23), "misaligned");
    // Invalid JSON inside the chunk is reported at its byte.
    let bad_json = glb::write(b"{\n \"asset\": ]", &[]).unwrap();
    let e = read_err(&bad_json);
    assert_err(&e, Location::Byte(20 + 12), "invalid JSON");
    // JSON padded with zeros instead of spaces is accepted.
    let d = square();
    let mut json = serde_json::to_vec(&d.with_buffer(None)).unwrap();
    json.resize(json.len().next_multiple_of(4) + 4, 0);
    let zero_padded = glb::write(&json, &d.bin).unwrap();
    assert_eq!(read_ok(&zero_padded).parts[0].mesh.triangles.len(), 2);
    // Buffer 0 without uri in a GLB without BIN chunk.
    let mut d = square();
    d.json["buffers"] = json!([{ "byteLength": 4 }]);
    let json = serde_json::to_vec(&d.json).unwrap();
    let no_bin = glb::write(&json, &[]).unwrap();
    assert_err(
        &read_err(&no_bin),
        Location::Element("buffer", 0),
        "no BIN chunk",
    );
}

// ---------------------------------------------------------------- JSON and asset

#[test]
fn json_errors_name_the_line() {
    assert_err(&read_err(b""), Location::File, "empty");
    assert_err(&read_err(b"  \n "), Location::File, "empty");
    assert_err(
        &read_err(b"{\n\"asset\": {\n,}"),
        Location::Line(3),
        "invalid JSON",
    );
    assert_err(&read_err(b"[1, 2]"), Location::File, "not an object");
    assert_err(
        &read_err(b"{\"asset\": {\"version\": \"1.0\"}}"),
        Location::File,
        "glTF 2.x",
    );
    assert_err(&read_err(b"{\"meshes\": []}"), Location::File, "asset");
    assert_err(
        &read_err(b"{\"asset\": {\"version\": \"2.0\", \"minVersion\": \"2.1\"}}"),
        Location::File,
        "2.1",
    );
    assert_err(
        &read_err(b"{\"asset\": {\"version\": \"2.0\"}, \"meshes\": 3}"),
        Location::File,
        "array",
    );
    // Non-UTF-8 bytes in a string.
    let e = read_err(b"{\"asset\": {\"version\": \"2.0\", \"generator\": \"\xff\"}}");
    assert!(matches!(e.location, Location::Line(1)), "{e}");
    // A document with nothing in it is an empty scene.
    let s = read_ok(b"{\"asset\": {\"version\": \"2.0\"}}");
    assert!(s.parts.is_empty());
}

// ---------------------------------------------------------------- buffers

#[test]
fn buffer_errors_name_the_buffer() {
    let mut d = square();
    let mut j = d.with_buffer(Some("data:application/octet-stream;base64,@@@".into()));
    assert_err(
        &read_err(&serde_json::to_vec(&j).unwrap()),
        Location::Element("buffer", 0),
        "invalid base64",
    );
    j["buffers"][0]["uri"] = json!(uri::data_uri("application/gltf-buffer", &d.bin[..8]));
    assert_err(
        &read_err(&serde_json::to_vec(&j).unwrap()),
        Location::Element("buffer", 0),
        "byteLength",
    );
    j["buffers"][0]["uri"] = json!("/abs/path.bin");
    assert_err(
        &read_err(&serde_json::to_vec(&j).unwrap()),
        Location::Element("buffer", 0),
        "absolute path or URL",
    );
    j["buffers"][0]["uri"] = json!("https://example.com/a.bin");
    assert_err(
        &read_err(&serde_json::to_vec(&j).unwrap()),
        Location::Element("buffer", 0),
        "absolute path or URL",
    );
    j["buffers"][0]["uri"] = json!("side.bin");
    assert_err(
        &read_err(&serde_json::to_vec(&j).unwrap()),
        Location::Element("buffer", 0),
        "no directory",
    );
    // External files are found relative to base_dir, percent-decoded.
    let dir = tempfile::tempdir().unwrap();
    j["buffers"][0]["uri"] = json!("my%20side.bin");
    let bytes = serde_json::to_vec(&j).unwrap();
    let e = read(&bytes, Some(dir.path())).unwrap_err();
    assert_err(&e, Location::Element("buffer", 0), "my side.bin");
    std::fs::write(dir.path().join("my side.bin"), &d.bin).unwrap();
    let s = read(&bytes, Some(dir.path())).unwrap();
    assert_eq!(s.parts[0].mesh.triangles.len(), 2);
    // A buffer nothing uses is not loaded at all.
    d.json["buffers"] = json!([{ "byteLength": 1, "uri": "missing.bin" }]);
    d.json["bufferViews"] = json!([]);
    d.json["accessors"] = json!([]);
    d.json["meshes"] = json!([]);
    d.json["nodes"] = json!([]);
    d.json["scenes"] = json!([{ "nodes": [] }]);
    assert!(read(&serde_json::to_vec(&d.json).unwrap(), None).is_ok());
}

// ---------------------------------------------------------------- compression and extensions

#[test]
fn compressed_geometry_is_refused_clearly() {
    let mut d = square();
    d.json["extensionsUsed"] = json!(["EXT_meshopt_compression"]);
    let e = read_err(&d.glb());
    assert_err(
        &e,
        Location::File,
        "uses EXT_meshopt_compression (compressed geometry)",
    );
    assert!(e.message.contains("gltfpack -noq"));

    let mut d = square();
    d.json["meshes"][0]["primitives"][0]["extensions"] =
        json!({ "KHR_draco_mesh_compression": { "bufferView": 0, "attributes": {} } });
    assert_err(
        &read_err(&d.glb()),
        Location::Element("mesh", 0),
        "KHR_draco_mesh_compression (compressed geometry)",
    );

    let mut d = square();
    d.json["bufferViews"][0]["extensions"] = json!({ "EXT_meshopt_compression": {} });
    assert_err(
        &read_err(&d.glb()),
        Location::Element("bufferView", 0),
        "EXT_meshopt_compression",
    );

    let mut d = square();
    d.json["extensionsRequired"] = json!(["EXT_unknown_geometry"]);
    assert_err(
        &read_err(&d.glb()),
        Location::File,
        "requires extension EXT_unknown_geometry",
    );

    let mut d = square();
    d.json["extensionsUsed"] = json!(["KHR_mesh_quantization", "KHR_materials_unlit"]);
    d.json["extensionsRequired"] = json!(["KHR_mesh_quantization", "KHR_texture_transform"]);
    assert_eq!(read_ok(&d.glb()).parts[0].mesh.triangles.len(), 2);
}

// ---------------------------------------------------------------- accessors

#[test]
fn accessor_and_view_bounds_are_checked() {
    // Accessor past the end of its view.
    let mut d = square();
    d.json["accessors"][0]["count"] = json!(5);
    assert_err(
        &read_err(&d.glb()),
        Location::Element("accessor", 0),
        "do not fit in bufferView 0",
    );
    let mut d = square();
    d.json["accessors"][1]["byteOffset"] = json!(4);
    assert_err(
        &read_err(&d.glb()),
        Location::Element("accessor", 1),
        "byteOffset 4",
    );
    // View past the end of its buffer.
    let mut d = square();
    d.json["bufferViews"][1]["byteLength"] = json!(1000);
    assert_err(
        &read_err(&d.glb()),
        Location::Element("bufferView", 1),
        "past the end of buffer 0",
    );
    // View naming a missing buffer.
    let mut d = square();
    d.json["bufferViews"][0]["buffer"] = json!(3);
    assert_err(
        &read_err(&d.glb()),
        Location::Element("bufferView", 0),
        "only 1 buffers",
    );
    // Stride smaller than the element.
    let mut d = square();
    d.json["bufferViews"][0]["byteStride"] = json!(8);
    assert_err(
        &read_err(&d.glb()),
        Location::Element("accessor", 0),
        "byteStride 8",
    );
    // Bad component type, type, count.
    let mut d = square();
    d.json["accessors"][0]["componentType"] = json!(5124);
    assert_err(
        &read_err(&d.glb()),
        Location::Element("accessor", 0),
        "componentType 5124",
    );
    let mut d = square();
    d.json["accessors"][0]["type"] = json!("VEC5");
    assert_err(
        &read_err(&d.glb()),
        Location::Element("accessor", 0),
        "unknown type",
    );
    let mut d = square();
    d.json["accessors"][0]["count"] = json!(0);
    assert_err(
        &read_err(&d.glb()),
        Location::Element("accessor", 0),
        "at least 1",
    );
    let mut d = square();
    d.json["accessors"][0]["count"] = json!(-3);
    assert_err(
        &read_err(&d.glb()),
        Location::Element("accessor", 0),
        "non-negative integer",
    );
    // An accessor without a view cannot claim more elements than the file could hold.
    let mut d = square();
    d.json["accessors"][0] = json!({ "componentType": F32, "type": "VEC3", "count": 1u64 << 40 });
    assert_err(
        &read_err(&d.glb()),
        Location::Element("accessor", 0),
        "more than the file",
    );
    // Reference to a missing accessor.
    let mut d = square();
    d.json["meshes"][0]["primitives"][0]["indices"] = json!(9);
    assert_err(
        &read_err(&d.glb()),
        Location::Element("mesh", 0),
        "only 2 accessors",
    );
    // Wrong type for the attribute.
    let mut d = square();
    d.json["accessors"][0]["type"] = json!("VEC2");
    d.json["accessors"][0]["count"] = json!(4);
    assert_err(
        &read_err(&d.glb()),
        Location::Element("accessor", 0),
        "must be VEC3",
    );
    // Index out of range.
    let mut d = square();
    let idx = d.u16s(&[0, 1, 7], "SCALAR", 1);
    d.json["meshes"][0]["primitives"][0]["indices"] = json!(idx);
    assert_err(
        &read_err(&d.glb()),
        Location::Element("mesh", 0),
        "index 7 (element 2",
    );
    // Float indices.
    let mut d = square();
    d.json["meshes"][0]["primitives"][0]["indices"] = json!(0);
    assert_err(
        &read_err(&d.glb()),
        Location::Element("accessor", 0),
        "must be SCALAR",
    );
    // Attribute count differs from POSITION.
    let mut d = square();
    let n = d.f32s(&[0.0; 9], "VEC3", 3);
    d.json["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(n);
    assert_err(
        &read_err(&d.glb()),
        Location::Element("mesh", 0),
        "NORMAL has 3 elements but POSITION has 4",
    );
    // Non-finite position.
    let mut d = square();
    let p = d.f32s(
        &[0.0, f32::NAN, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        "VEC3",
        3,
    );
    d.json["meshes"][0]["primitives"][0] = json!({ "attributes": { "POSITION": p } });
    assert_err(
        &read_err(&d.glb()),
        Location::Element("accessor", 2),
        "not finite",
    );
}

#[test]
fn strided_and_offset_accessors() {
    // Interleaved position + uv (20-byte stride), read through byteOffset.
    let mut d = Doc::new();
    let mut bytes = Vec::new();
    for v in 0..3 {
        for x in [v as f32, 2.0 * v as f32, 3.0, 0.5 * v as f32, 0.25] {
            bytes.extend_from_slice(&x.to_le_bytes());
        }
    }
    let view = d.view(&bytes, Some(20));
    let pos = d.accessor(view, F32, "VEC3", 3);
    let uv = d.accessor(view, F32, "VEC2", 3);
    d.json["accessors"][uv]["byteOffset"] = json!(12);
    d.push(
        "meshes",
        json!({ "primitives": [{ "attributes": { "POSITION": pos, "TEXCOORD_0": uv } }] }),
    );
    d.root_node(json!({ "mesh": 0 }));
    let s = read_ok(&d.gltf());
    let m = &s.parts[0].mesh;
    assert_eq!(
        m.positions,
        vec![[0.0, 0.0, 3.0], [1.0, 2.0, 3.0], [2.0, 4.0, 3.0]]
    );
    // The file's v = 0.25 (glTF: from the top) is 0.75 from the bottom.
    assert_eq!(
        m.attributes.uv0,
        Some(vec![[0.0, 0.75], [0.5, 0.75], [1.0, 0.75]])
    );
    // Non-indexed: implicit 0..n.
    assert_eq!(m.triangles, vec![[0, 1, 2]]);
}

#[test]
fn sparse_accessors_substitute_elements() {
    // Base: the square; sparse replaces vertex 1 and 3 (u8 indices).
    let mut d = square();
    let idx = d.view(&[1, 3], None);
    let vals: Vec<u8> = [5.0f32, 0.0, 0.0, 0.0, 5.0, 0.0]
        .iter()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    let val = d.view(&vals, None);
    d.json["accessors"][0]["sparse"] = json!({
        "count": 2,
        "indices": { "bufferView": idx, "componentType": U8 },
        "values": { "bufferView": val }
    });
    let s = read_ok(&d.glb());
    assert_eq!(
        s.parts[0].mesh.positions,
        vec![
            [0.0, 0.0, 0.0],
            [5.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 5.0, 0.0]
        ]
    );
    // Without a buffer view the base is all zeros.
    let mut z = d.json.clone();
    z["accessors"][0]
        .as_object_mut()
        .unwrap()
        .remove("bufferView");
    let doc = Doc {
        json: z,
        bin: d.bin.clone(),
    };
    let s = read_ok(&doc.glb());
    assert_eq!(s.parts[0].mesh.positions[0], [0.0; 3]);
    assert_eq!(s.parts[0].mesh.positions[2], [0.0; 3]);
    assert_eq!(s.parts[0].mesh.positions[3], [0.0, 5.0, 0.0]);
    // Indices must increase.
    let mut bad = Doc {
        json: d.json.clone(),
        bin: d.bin.clone(),
    };
    let dec = bad.view(&[3, 1], None);
    bad.json["accessors"][0]["sparse"]["indices"]["bufferView"] = json!(dec);
    assert_err(
        &read_err(&bad.glb()),
        Location::Element("accessor", 0),
        "must increase",
    );
    // Sparse data must fit in its view.
    let mut bad = Doc {
        json: d.json.clone(),
        bin: d.bin.clone(),
    };
    bad.json["accessors"][0]["sparse"]["count"] = json!(3);
    assert_err(
        &read_err(&bad.glb()),
        Location::Element("accessor", 0),
        "sparse indices (3)",
    );
    // And round-trip through the writer (unchanged part keeps the sparse accessor).
    let s = read_ok(&d.glb());
    let back = read_ok(&write_glb(&s).unwrap());
    assert_eq!(back.parts[0].mesh, s.parts[0].mesh);
}

#[test]
fn index_component_types_and_modes() {
    // The same strip 0 1 2 3 4 as u8, u16 and u32 indices.
    //
    // 1---3
    // |\  |\
    // | \ | \
    // 0---2---4
    for component in [U8, U16, U32] {
        let mut d = Doc::new();
        let pos = d.f32s(
            &[
                0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 2.0, 0.0, 0.0,
            ],
            "VEC3",
            3,
        );
        let idx = match component {
            U8 => d.u8s(&[0, 1, 2, 3, 4], "SCALAR", 1),
            U16 => d.u16s(&[0, 1, 2, 3, 4], "SCALAR", 1),
            _ => d.u32s(&[0, 1, 2, 3, 4], "SCALAR", 1),
        };
        d.push(
            "meshes",
            json!({ "primitives": [{ "attributes": { "POSITION": pos }, "indices": idx, "mode": 5 }] }),
        );
        d.root_node(json!({ "mesh": 0 }));
        let s = read_ok(&d.glb());
        // Strip triangles alternate winding: (0 1 2), (2 1 3), (2 3 4).
        assert_eq!(
            s.parts[0].mesh.triangles,
            vec![[0, 1, 2], [2, 1, 3], [2, 3, 4]]
        );
    }
}

#[test]
fn strips_and_fans_drop_stitching_triangles() {
    let mut tris = Vec::new();
    // Strip with a repeated index (degenerate joins): 0 1 2 2 3 4 → (0,1,2) only
    // non-degenerate, then (2,3,4) at even position 3? (index 3: 2 3 4 reversed).
    read::triangulate(5, &[0, 1, 2, 2, 3, 4], 10, &mut tris);
    assert_eq!(tris, vec![[10, 11, 12], [13, 12, 14]]);
    tris.clear();
    // Fan around vertex 0: (1 2 0), (2 3 0), (3 4 0).
    read::triangulate(6, &[0, 1, 2, 3, 4], 0, &mut tris);
    assert_eq!(tris, vec![[1, 2, 0], [2, 3, 0], [3, 4, 0]]);
    tris.clear();
    // Lists ignore a trailing incomplete triangle; points make no triangles.
    read::triangulate(4, &[0, 1, 2, 3], 0, &mut tris);
    assert_eq!(tris, vec![[0, 1, 2]]);
    read::triangulate(0, &[0, 1, 2], 0, &mut tris);
    assert_eq!(tris.len(), 1);
    read::triangulate(6, &[], 0, &mut tris);
    assert_eq!(tris.len(), 1);
}

#[test]
fn normalized_and_quantized_attributes() {
    // KHR_mesh_quantization: i16 positions (not normalized), i8 normalized normals,
    // u16 normalized UVs, u8 normalized RGB colours, u8 joints, u8 normalized weights.
    let mut d = Doc::new();
    let pbytes: Vec<u8> = [0i16, 0, 0, 0, 0, 100, 0, 0, 0, 0, -200, 0]
        .iter()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    let pv = d.view(&pbytes, Some(8));
    let pos = d.accessor(pv, I16, "VEC3", 3);
    let nv = d.view(&[0, 127, 0, 0, 0, 0x81, 0, 0, 0x80, 0, 0, 0], Some(4));
    let nrm = d.accessor(nv, I8, "VEC3", 3);
    d.json["accessors"][nrm]["normalized"] = json!(true);
    let uv = d.u16s(&[0, 65535, 32768, 0, 65535, 65535], "VEC2", 2);
    d.json["accessors"][uv]["normalized"] = json!(true);
    let cv = d.view(&[255, 0, 51, 0, 0, 255, 0, 0, 0, 0, 255, 0], Some(4));
    let col = d.accessor(cv, U8, "VEC3", 3);
    d.json["accessors"][col]["normalized"] = json!(true);
    let joints = d.u8s(&[1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12], "VEC4", 4);
    let weights = d.u8s(&[255, 0, 0, 0, 128, 127, 0, 0, 0, 0, 0, 255], "VEC4", 4);
    d.json["accessors"][weights]["normalized"] = json!(true);
    d.push(
        "meshes",
        json!({ "primitives": [{ "attributes": {
            "POSITION": pos, "NORMAL": nrm, "TEXCOORD_0": uv, "COLOR_0": col,
            "JOINTS_0": joints, "WEIGHTS_0": weights } }] }),
    );
    d.root_node(json!({ "mesh": 0 }));
    d.json["extensionsUsed"] = json!(["KHR_mesh_quantization"]);
    d.json["extensionsRequired"] = json!(["KHR_mesh_quantization"]);
    let s = read_ok(&d.glb());
    let m = &s.parts[0].mesh;
    assert_eq!(
        m.positions,
        vec![[0.0; 3], [0.0, 100.0, 0.0], [0.0, 0.0, -200.0]]
    );
    let n = m.attributes.normals.as_ref().unwrap();
    assert_eq!(n[0], [0.0, 1.0, 0.0]);
    assert_eq!(n[1], [0.0, -1.0, 0.0]); // -127 / 127
    assert_eq!(n[2], [-1.0, 0.0, 0.0]); // -128 clamps to -1
    let uvs = m.attributes.uv0.as_ref().unwrap();
    // Normalised u16 (0, 65535) and (32768, 0), v turned to bottom-up.
    assert_eq!(uvs[0], [0.0, 0.0]);
    assert_eq!(uvs[1], [32768.0 / 65535.0, 1.0]);
    let c = m.attributes.colors.as_ref().unwrap();
    assert_eq!(c[0], [1.0, 0.0, 0.2, 1.0]);
    assert_eq!(m.attributes.joints.as_ref().unwrap()[2], [9, 10, 11, 12]);
    let w = m.attributes.weights.as_ref().unwrap();
    assert_eq!(w[0], [1.0, 0.0, 0.0, 0.0]);
    assert_eq!(w[1], [128.0 / 255.0, 127.0 / 255.0, 0.0, 0.0]);
    // JOINTS_0 must be integers, not normalized or float.
    let mut bad = Doc {
        json: d.json.clone(),
        bin: d.bin.clone(),
    };
    bad.json["accessors"][joints]["normalized"] = json!(true);
    assert_err(
        &read_err(&bad.glb()),
        Location::Element("accessor", joints as u64),
        "normalized UNSIGNED_BYTE",
    );
    let mut bad = Doc {
        json: d.json.clone(),
        bin: d.bin.clone(),
    };
    bad.json["accessors"][uv]["componentType"] = json!(U32);
    assert_err(
        &read_err(&bad.glb()),
        Location::Element("accessor", uv as u64),
        "cannot be normalized",
    );

    // Written back after a change: float streams, RGB colour kept as VEC3, u8 joints.
    let mut s = s;
    s.parts[0].mesh.attributes.uv0.as_mut().unwrap()[0] = [0.5, 0.5];
    let out = write_glb(&s).unwrap();
    let back = read_ok(&out);
    assert_eq!(back.parts[0].mesh.positions, s.parts[0].mesh.positions);
    assert_eq!(back.parts[0].mesh.attributes, s.parts[0].mesh.attributes);
    let doc = back.gltf.as_ref().unwrap().document();
    let attrs = &doc["meshes"][0]["primitives"][0]["attributes"];
    let acc = |name: &str| &doc["accessors"][attrs[name].as_u64().unwrap() as usize];
    assert_eq!(acc("COLOR_0")["type"], "VEC3");
    assert_eq!(acc("JOINTS_0")["componentType"], U8);
    assert_eq!(acc("POSITION")["componentType"], F32);
    assert_eq!(acc("POSITION")["min"], json!([0.0, 0.0, -200.0]));
    assert_eq!(acc("POSITION")["max"], json!([0.0, 100.0, 0.0]));
}

// ---------------------------------------------------------------- nodes and scenes

fn close(a: &Matrix4, b: &Matrix4) -> bool {
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .all(|(x, y)| (x - y).abs() < 1e-6)
}

#[test]
fn node_hierarchy_composes_transforms() {
    // root (translate x+10) → child (rotate 90° about z, scale 2) → draws mesh 0;
    // a second root with a matrix (translate y+5) draws mesh 0 too; mesh 1 is drawn
    // by no node.
    let mut d = square();
    d.json["nodes"] = json!([]);
    d.json["scenes"][0]["nodes"] = json!([]);
    let s = std::f64::consts::FRAC_1_SQRT_2;
    d.push("meshes", d.json["meshes"][0].clone());
    d.root_node(json!({ "translation": [10.0, 0.0, 0.0], "children": [1] }));
    d.push(
        "nodes",
        json!({ "rotation": [0.0, 0.0, s, s], "scale": [2.0, 2.0, 2.0], "mesh": 0 }),
    );
    d.root_node(json!({ "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,5,0,1], "mesh": 0 }));
    let scene = read_ok(&d.glb());
    let inst = &scene.parts[0].instances;
    assert_eq!(inst.len(), 2);
    let rotated: Matrix4 = [
        [0.0, 2.0, 0.0, 0.0],
        [-2.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 2.0, 0.0],
        [10.0, 0.0, 0.0, 1.0],
    ];
    assert!(close(&inst[0], &rotated), "{:?}", inst[0]);
    let mut moved = IDENTITY;
    moved[3][1] = 5.0;
    assert!(close(&inst[1], &moved));
    assert!(scene.parts[1].instances.is_empty());
    // 2 instances × 2 triangles (mesh 1 is not drawn).
    assert_eq!(scene.instanced_triangle_count(), 4);
    // The flattened mesh has the rotated square: (1,0,0) → (10, 2, 0).
    let flat = scene.flatten();
    assert!(flat
        .positions
        .iter()
        .any(|p| (p[0] - 10.0).abs() < 1e-5 && (p[1] - 2.0).abs() < 1e-5));

    // Without scenes, every root node is drawn.
    let mut noscene = Doc {
        json: d.json.clone(),
        bin: d.bin.clone(),
    };
    noscene.json.as_object_mut().unwrap().remove("scenes");
    noscene.json.as_object_mut().unwrap().remove("scene");
    assert_eq!(read_ok(&noscene.glb()).parts[0].instances.len(), 2);
    // `scene` selects the scene.
    let mut second = Doc {
        json: d.json.clone(),
        bin: d.bin.clone(),
    };
    second.json["scenes"] = json!([{ "nodes": [0, 2] }, { "nodes": [2] }]);
    second.json["scene"] = json!(1);
    assert_eq!(read_ok(&second.glb()).parts[0].instances, vec![moved]);
}

#[test]
fn node_errors_cycles_and_ranges() {
    let mut d = square();
    d.json["nodes"] = json!([{ "children": [1] }, { "children": [0], "mesh": 0 }]);
    d.json["scenes"][0]["nodes"] = json!([0]);
    assert_err(&read_err(&d.glb()), Location::Element("node", 0), "cycle");
    d.json["nodes"] = json!([{ "children": [4] }]);
    assert_err(
        &read_err(&d.glb()),
        Location::Element("node", 0),
        "only 1 nodes",
    );
    d.json["nodes"] = json!([{ "mesh": 3 }]);
    assert_err(
        &read_err(&d.glb()),
        Location::Element("node", 0),
        "only 1 meshes",
    );
    d.json["nodes"] = json!([{ "mesh": 0, "matrix": [1, 0] }]);
    assert_err(
        &read_err(&d.glb()),
        Location::Element("node", 0),
        "16 finite numbers",
    );
    d.json["nodes"] = json!([{ "mesh": 0, "scale": [1e300, 1e300, 1e300] }]);
    assert_err(
        &read_err(&d.glb()),
        Location::Element("node", 0),
        "not finite",
    );
    d.json["nodes"] = json!([{ "mesh": 0 }]);
    d.json["scenes"][0]["nodes"] = json!([0, 0]);
    assert_err(
        &read_err(&d.glb()),
        Location::Element("node", 0),
        "reached twice",
    );
    d.json["scenes"][0]["nodes"] = json!([2]);
    assert_err(
        &read_err(&d.glb()),
        Location::Element("scene", 0),
        "only 1 nodes",
    );
    d.json["scene"] = json!(5);
    assert_err(&read_err(&d.glb()), Location::File, "only 1 scenes");
}

#[test]
fn gpu_instancing_adds_instances() {
    let mut d = square();
    let t = d.f32s(&[0.0, 0.0, 0.0, 3.0, 0.0, 0.0], "VEC3", 3);
    d.json["nodes"][0]["extensions"] =
        json!({ "EXT_mesh_gpu_instancing": { "attributes": { "TRANSLATION": t } } });
    d.json["extensionsUsed"] = json!(["EXT_mesh_gpu_instancing"]);
    d.json["extensionsRequired"] = json!(["EXT_mesh_gpu_instancing"]);
    let s = read_ok(&d.glb());
    assert_eq!(s.parts[0].instances.len(), 2);
    assert_eq!(s.parts[0].instances[1][3], [3.0, 0.0, 0.0, 1.0]);
    // The instancing accessor survives a rewrite (renumbered).
    let mut changed = s.clone();
    changed.parts[0].mesh.triangles.pop();
    changed.parts[0].mesh.groups.as_mut().unwrap().pop();
    let back = read_ok(&write_glb(&changed).unwrap());
    assert_eq!(back.parts[0].instances, s.parts[0].instances);
    assert_eq!(back.parts[0].mesh.triangles.len(), 1);
}

// ---------------------------------------------------------------- primitives and groups

/// A mesh with three primitives: a triangle list with material 0 ("red"), a point
/// primitive, and a fan sharing the first primitive's vertex accessors with
/// material 1 (unnamed), plus a second part with a line primitive only.
fn multi() -> Doc {
    let mut d = Doc::new();
    let pos = d.f32s(&SQUARE, "VEC3", 3);
    let nrm = d.f32s(&[0.0, 0.0, 1.0].repeat(4), "VEC3", 3);
    let list = d.u16s(&[0, 1, 2], "SCALAR", 1);
    let fan = d.u8s(&[0, 2, 3], "SCALAR", 1);
    d.json["materials"] = json!([{ "name": "red" }, {}]);
    d.push(
        "meshes",
        json!({ "name": "multi", "primitives": [
            { "attributes": { "POSITION": pos, "NORMAL": nrm }, "indices": list, "material": 0 },
            { "attributes": { "POSITION": pos }, "mode": 0 },
            { "attributes": { "POSITION": pos, "NORMAL": nrm }, "indices": fan, "mode": 6, "material": 1,
              "extras": { "keep": true } },
        ] }),
    );
    d.push(
        "meshes",
        json!({ "name": "lines", "primitives": [{ "attributes": { "POSITION": pos }, "mode": 1 }] }),
    );
    d.root_node(json!({ "mesh": 0 }));
    d.root_node(json!({ "mesh": 1 }));
    d
}

#[test]
fn primitives_become_groups_sharing_vertices() {
    let s = read_ok(&multi().glb());
    let m = &s.parts[0].mesh;
    // Both triangle primitives use the same accessors: one block of 4 vertices.
    assert_eq!(m.positions.len(), 4);
    assert_eq!(m.triangles, vec![[0, 1, 2], [2, 3, 0]]);
    assert_eq!(m.groups, Some(vec![0, 2]));
    assert_eq!(m.group_names, vec!["red", "default", "material 1"]);
    // The lines-only mesh is a part with no triangles.
    assert!(s.parts[1].mesh.triangles.is_empty());
    assert_eq!(s.parts[1].instances.len(), 1);
    let src = s.gltf.as_ref().unwrap();
    let prims = &src.meshes[0].primitives;
    assert_eq!(prims[1].group, None);
    assert_eq!(prims[1].mode, 0);
    assert_eq!(prims[2].group, Some(2));
    assert_eq!(prims[2].material, Some(1));
    assert_eq!(prims[0].attribute_names, vec!["NORMAL", "POSITION"]);
}

#[test]
fn changed_parts_keep_pass_through_primitives_and_materials() {
    let s = read_ok(&multi().glb());
    // Remove the fan's triangle: group 2 vanishes, its primitive goes.
    let mut changed = s.clone();
    changed.parts[0].mesh.triangles.pop();
    changed.parts[0].mesh.groups.as_mut().unwrap().pop();
    let out = write_glb(&changed).unwrap();
    let back = read_ok(&out);
    let doc = back.gltf.as_ref().unwrap().document();
    let prims = doc["meshes"][0]["primitives"].as_array().unwrap();
    assert_eq!(prims.len(), 2);
    assert_eq!(prims[0]["material"], 0);
    assert_eq!(prims[1]["mode"], 0); // the points, untouched
    assert_eq!(back.parts[0].mesh.triangles, vec![[0, 1, 2]]);
    assert_eq!(
        back.parts[0].mesh.positions,
        SQUARE
            .chunks(3)
            .take(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect::<Vec<_>>()
    );
    // The lines mesh is unchanged.
    assert_eq!(doc["meshes"][1]["primitives"][0]["mode"], 1);

    // Change only the fan: it is written as a TRIANGLES primitive with material 1
    // and its extras, and only NORMAL and POSITION.
    let mut changed = s.clone();
    changed.parts[0].mesh.positions[3][2] = 0.5;
    let back = read_ok(&write_glb(&changed).unwrap());
    let doc = back.gltf.as_ref().unwrap().document();
    let prims = doc["meshes"][0]["primitives"].as_array().unwrap();
    assert_eq!(prims.len(), 3);
    assert_eq!(prims[2]["material"], 1);
    assert_eq!(prims[2]["extras"], json!({ "keep": true }));
    assert!(prims[2].get("mode").is_none());
    let keys: Vec<&String> = prims[2]["attributes"].as_object().unwrap().keys().collect();
    assert_eq!(keys, ["NORMAL", "POSITION"]);
    // Same triangles, now in separate vertex blocks per primitive.
    let m = &back.parts[0].mesh;
    assert_eq!(m.triangles.len(), 2);
    assert_eq!(m.groups, Some(vec![0, 2]));
    let corner = |t: usize, k: usize| m.positions[m.triangles[t][k] as usize];
    assert_eq!(corner(1, 1), [0.0, 1.0, 0.5]);
    assert_eq!(corner(1, 2), [0.0, 0.0, 0.0]);
    // New group ids without a source primitive get a primitive of their own.
    let mut extra = s.clone();
    extra.parts[0].mesh.groups = Some(vec![0, 7]);
    let back = read_ok(&write_glb(&extra).unwrap());
    let doc = back.gltf.as_ref().unwrap().document();
    let prims = doc["meshes"][0]["primitives"].as_array().unwrap();
    assert_eq!(prims.len(), 3); // red, points, new (fan's group 2 has vanished)
    assert!(prims[2].get("material").is_none());
}

#[test]
fn differing_attribute_sets_are_written_back_per_primitive() {
    // Primitive 0 has UVs, primitive 1 does not; the mesh fills primitive 1's UVs
    // with zeros, but writing gives it no TEXCOORD_0.
    let mut d = Doc::new();
    let p0 = d.f32s(&SQUARE[..9], "VEC3", 3);
    let uv = d.f32s(&[0.0, 0.0, 1.0, 0.0, 1.0, 1.0], "VEC2", 2);
    let p1 = d.f32s(&SQUARE[3..], "VEC3", 3);
    d.push(
        "meshes",
        json!({ "primitives": [
            { "attributes": { "POSITION": p0, "TEXCOORD_0": uv } },
            { "attributes": { "POSITION": p1 } },
        ] }),
    );
    d.root_node(json!({ "mesh": 0 }));
    let s = read_ok(&d.glb());
    let m = &s.parts[0].mesh;
    assert_eq!(m.positions.len(), 6);
    assert_eq!(m.attributes.uv0.as_ref().unwrap()[4], [0.0, 0.0]);
    let mut changed = s.clone();
    changed.parts[0].mesh.triangles.swap(0, 1);
    changed.parts[0].mesh.groups.as_mut().unwrap().swap(0, 1);
    let back = read_ok(&write_glb(&changed).unwrap());
    let doc = back.gltf.as_ref().unwrap().document();
    assert!(doc["meshes"][0]["primitives"][0]["attributes"]
        .get("TEXCOORD_0")
        .is_some());
    assert!(doc["meshes"][0]["primitives"][1]["attributes"]
        .get("TEXCOORD_0")
        .is_none());
    // The file's (1, 0), v turned to bottom-up.
    assert_eq!(
        back.parts[0].mesh.attributes.uv0.as_ref().unwrap()[1],
        [1.0, 1.0]
    );
}

#[test]
fn vanished_meshes_are_removed_and_nodes_fixed() {
    let mut d = square();
    d.push("meshes", d.json["meshes"][0].clone());
    d.root_node(json!({ "mesh": 1, "name": "second" }));
    d.json["skins"] = json!([{ "joints": [0] }]);
    d.json["nodes"][0]["skin"] = json!(0);
    let s = read_ok(&d.glb());
    let mut empty = s.clone();
    empty.parts[0].mesh = Mesh::default();
    let back = read_ok(&write_glb(&empty).unwrap());
    let doc = back.gltf.as_ref().unwrap().document();
    assert_eq!(doc["meshes"].as_array().unwrap().len(), 1);
    assert!(doc["nodes"][0].get("mesh").is_none());
    assert!(doc["nodes"][0].get("skin").is_none());
    assert_eq!(doc["nodes"][1]["mesh"], 0);
    assert_eq!(back.parts.len(), 1);
    assert_eq!(back.parts[0].instances.len(), 1);
    // A part count that no longer matches the document is refused.
    let mut fewer = s.clone();
    fewer.parts.pop();
    assert_err(
        &write_glb(&fewer).unwrap_err(),
        Location::File,
        "clear Scene::gltf",
    );
}

// ---------------------------------------------------------------- writer details

#[test]
fn unchanged_scene_round_trips_exactly_and_keeps_strips() {
    let mut d = Doc::new();
    let pos = d.f32s(&SQUARE, "VEC3", 3);
    let idx = d.u8s(&[0, 1, 3, 2], "SCALAR", 1);
    let _unused = d.f32s(&[1.0, 2.0], "SCALAR", 1);
    d.push(
        "meshes",
        json!({ "primitives": [{ "attributes": { "POSITION": pos }, "indices": idx, "mode": 5 }] }),
    );
    d.root_node(json!({ "mesh": 0, "name": "n", "extras": { "x": [1, 2] } }));
    d.json["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    d.json["extensions"] = json!({ "KHR_lights_punctual": { "lights": [{ "type": "point" }] } });
    d.json["cameras"] =
        json!([{ "type": "perspective", "perspective": { "yfov": 1.0, "znear": 0.1 } }]);
    let s = read_ok(&d.gltf());
    for out in [write_glb(&s).unwrap(), write_embedded(&s).unwrap()] {
        let back = read_ok(&out);
        assert_eq!(back.parts, s.parts);
        let doc = back.gltf.as_ref().unwrap().document();
        assert_eq!(doc["meshes"][0]["primitives"][0]["mode"], 5);
        // The unused accessor (and its view) are gone; indices keep their u8 type.
        assert_eq!(doc["accessors"].as_array().unwrap().len(), 2);
        assert_eq!(doc["bufferViews"].as_array().unwrap().len(), 2);
        assert_eq!(doc["accessors"][1]["componentType"], U8);
        assert_eq!(doc["nodes"][0]["extras"], json!({ "x": [1, 2] }));
        assert_eq!(doc["extensions"], d.json["extensions"]);
        assert_eq!(doc["cameras"], d.json["cameras"]);
        assert_eq!(doc["buffers"].as_array().unwrap().len(), 1);
        for v in doc["bufferViews"].as_array().unwrap() {
            assert_eq!(v["byteOffset"].as_u64().unwrap_or(0) % 4, 0);
        }
        // Deterministic.
        assert_eq!(
            write_glb(&back).unwrap(),
            write_glb(&read_ok(&write_glb(&back).unwrap())).unwrap()
        );
    }
}

#[test]
fn shared_buffer_views_are_trimmed_to_what_is_used() {
    // Two meshes whose positions live in one view; changing mesh 0 drops its
    // accessors, and the view keeps only mesh 1's bytes.
    let mut d = Doc::new();
    let mut all = SQUARE.to_vec();
    all.extend(SQUARE.iter().map(|x| x + 10.0));
    let bytes: Vec<u8> = all.iter().flat_map(|x| x.to_le_bytes()).collect();
    let view = d.view(&bytes, None);
    let a = d.accessor(view, F32, "VEC3", 4);
    let b = d.accessor(view, F32, "VEC3", 4);
    d.json["accessors"][b]["byteOffset"] = json!(48);
    let idx = d.u16s(&[0, 1, 2, 0, 2, 3], "SCALAR", 1);
    d.push(
        "meshes",
        json!({ "primitives": [{ "attributes": { "POSITION": a }, "indices": idx }] }),
    );
    d.push(
        "meshes",
        json!({ "primitives": [{ "attributes": { "POSITION": b }, "indices": idx }] }),
    );
    d.root_node(json!({ "mesh": 0 }));
    d.root_node(json!({ "mesh": 1 }));
    let mut s = read_ok(&d.glb());
    s.parts[0].mesh.triangles.truncate(1);
    s.parts[0].mesh.groups.as_mut().unwrap().truncate(1);
    let back = read_ok(&write_glb(&s).unwrap());
    let doc = back.gltf.as_ref().unwrap().document();
    let acc1 = doc["meshes"][1]["primitives"][0]["attributes"]["POSITION"]
        .as_u64()
        .unwrap() as usize;
    let view1 = doc["accessors"][acc1]["bufferView"].as_u64().unwrap() as usize;
    assert_eq!(doc["bufferViews"][view1]["byteLength"], 48);
    assert!(doc["accessors"][acc1].get("byteOffset").is_none());
    assert_eq!(back.parts[1].mesh, s.parts[1].mesh);
    assert_eq!(back.parts[0].mesh.triangles, vec![[0, 1, 2]]);
}

#[test]
fn index_width_follows_vertex_count() {
    // 65 535 vertices: the largest index is 65 534, below the u16 restart value.
    let tris = [[0u32, 1, 65_534]];
    assert_eq!(write::index_layout(&tris, 65_535), (U16, 6));
    assert_eq!(write::index_layout(&tris, 65_536), (U32, 12));
}

#[test]
fn morph_targets_are_dropped_only_when_geometry_changes() {
    let mut d = square();
    let dp = d.f32s(&[0.0, 0.0, 1.0].repeat(4), "VEC3", 3);
    d.json["meshes"][0]["primitives"][0]["targets"] = json!([{ "POSITION": dp }]);
    d.json["meshes"][0]["weights"] = json!([0.5]);
    d.json["meshes"][0]["extras"] = json!({ "targetNames": ["up"], "other": 1 });
    d.json["nodes"][0]["weights"] = json!([0.25]);
    let times = d.f32s(&[0.0, 1.0], "SCALAR", 1);
    let values = d.f32s(&[0.0, 1.0], "SCALAR", 1);
    let tr = d.f32s(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0], "VEC3", 3);
    d.json["animations"] = json!([{
        "channels": [
            { "sampler": 0, "target": { "node": 0, "path": "weights" } },
            { "sampler": 1, "target": { "node": 0, "path": "translation" } },
        ],
        "samplers": [{ "input": times, "output": values }, { "input": times, "output": tr }],
    }]);
    let s = read_ok(&d.glb());
    // Unchanged: targets survive.
    let same = read_ok(&write_glb(&s).unwrap());
    let doc = same.gltf.as_ref().unwrap().document();
    assert!(doc["meshes"][0]["primitives"][0].get("targets").is_some());
    assert_eq!(
        doc["animations"][0]["channels"].as_array().unwrap().len(),
        2
    );
    // Changed: targets, weights and the weights channel go; the other channel stays
    // and points at its renumbered sampler.
    let mut changed = s.clone();
    changed.parts[0].mesh.positions[0][2] = -1.0;
    let back = read_ok(&write_glb(&changed).unwrap());
    let doc = back.gltf.as_ref().unwrap().document();
    assert!(doc["meshes"][0]["primitives"][0].get("targets").is_none());
    assert!(doc["meshes"][0].get("weights").is_none());
    assert_eq!(doc["meshes"][0]["extras"], json!({ "other": 1 }));
    assert!(doc["nodes"][0].get("weights").is_none());
    let anim = &doc["animations"][0];
    assert_eq!(anim["channels"].as_array().unwrap().len(), 1);
    assert_eq!(anim["channels"][0]["sampler"], 0);
    assert_eq!(anim["channels"][0]["target"]["path"], "translation");
    assert_eq!(anim["samplers"].as_array().unwrap().len(), 1);
    assert_eq!(back.parts[0].mesh.positions[0], [0.0, 0.0, -1.0]);
}

/// The smallest file with a PNG signature: enough for the writer, which never
/// decodes images.
const PNG: &[u8] = b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR";

fn textured() -> Doc {
    let mut d = square();
    let uv = d.f32s(&[0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0], "VEC2", 2);
    d.json["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(uv);
    d.json["meshes"][0]["primitives"][0]["material"] = json!(0);
    d.json["materials"] = json!([{ "name": "wood",
        "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }]);
    d.json["textures"] = json!([{ "source": 0, "sampler": 0 }]);
    d.json["samplers"] = json!([{ "magFilter": 9729 }]);
    d.json["images"] = json!([{ "uri": uri::data_uri("image/png", PNG) }]);
    d
}

#[test]
fn textured_round_trip_embeds_the_image_in_glb() {
    let s = read_ok(&textured().gltf());
    assert_eq!(s.parts[0].mesh.group_names, vec!["wood"]);
    let mut changed = s.clone();
    changed.parts[0].mesh.triangles.truncate(1);
    changed.parts[0].mesh.groups.as_mut().unwrap().truncate(1);
    for scene in [&s, &changed] {
        let glb_bytes = write_glb(scene).unwrap();
        let back = read_ok(&glb_bytes);
        let doc = back.gltf.as_ref().unwrap().document();
        let img = &doc["images"][0];
        assert!(img.get("uri").is_none());
        assert_eq!(img["mimeType"], "image/png");
        let v = img["bufferView"].as_u64().unwrap() as usize;
        let view = &doc["bufferViews"][v];
        let src = back.gltf.as_ref().unwrap();
        let start = view["byteOffset"].as_u64().unwrap_or(0) as usize;
        let bytes = &src.buffers[0].as_ref().unwrap()[start..start + PNG.len()];
        assert_eq!(bytes, PNG);
        assert_eq!(doc["materials"][0]["name"], "wood");
        assert_eq!(doc["textures"], json!([{ "source": 0, "sampler": 0 }]));
        assert_eq!(
            back.parts[0].mesh.positions.len(),
            scene.parts[0].mesh.compact_clone().positions.len()
        );
        // The file's (1, 1), v turned to bottom-up.
        assert_eq!(
            back.parts[0].mesh.attributes.uv0.as_ref().unwrap()[2],
            [1.0, 0.0]
        );
        // The embedded .gltf keeps the data-URI image.
        let emb = read_ok(&write_embedded(&back).unwrap());
        let doc = emb.gltf.as_ref().unwrap().document();
        assert_eq!(doc["images"][0]["mimeType"], "image/png");
        assert_eq!(emb.parts[0].mesh, back.parts[0].mesh);
    }
}

trait CompactClone {
    fn compact_clone(&self) -> Mesh;
}

impl CompactClone for Mesh {
    fn compact_clone(&self) -> Mesh {
        let mut m = self.clone();
        m.compact_vertices();
        m
    }
}

#[test]
fn external_images_are_copied_or_embedded() {
    let src = tempfile::tempdir().unwrap();
    let dst = tempfile::tempdir().unwrap();
    let mut d = textured();
    d.json["images"] = json!([{ "uri": "tex%201.png" }, { "uri": "../up.png" }]);
    d.json["textures"] = json!([{ "source": 0 }, { "source": 1 }]);
    std::fs::write(src.path().join("tex 1.png"), PNG).unwrap();
    std::fs::create_dir(src.path().join("sub")).unwrap();
    std::fs::write(src.path().join("up.png"), b"\xFF\xD8\xFFjpeg").unwrap();
    let base = src.path().join("sub");
    std::fs::write(base.join("../tex 1.png"), PNG).unwrap();
    // The model lives in src/sub, so "../up.png" is src/up.png; "tex 1.png" must be
    // in src/sub too.
    std::fs::write(base.join("tex 1.png"), PNG).unwrap();
    let path = base.join("model.gltf");
    let uri_bin = "model.bin";
    std::fs::write(base.join(uri_bin), &d.bin).unwrap();
    std::fs::write(
        &path,
        serde_json::to_vec(&d.with_buffer(Some(uri_bin.into()))).unwrap(),
    )
    .unwrap();
    let scene = crate::io::read_scene(&path).unwrap();
    // .gltf elsewhere: images copied, the outside one renamed into the folder.
    let out = dst.path().join("out.gltf");
    write_file(&out, &scene, false).unwrap();
    assert_eq!(std::fs::read(dst.path().join("tex 1.png")).unwrap(), PNG);
    assert!(dst.path().join("up.png").exists());
    assert!(dst.path().join("out.bin").exists());
    let back = crate::io::read_scene(&out).unwrap();
    let doc = back.gltf.as_ref().unwrap().document();
    assert_eq!(doc["images"][0]["uri"], "tex%201.png");
    assert_eq!(doc["images"][1]["uri"], "up.png");
    assert_eq!(doc["buffers"][0]["uri"], "out.bin");
    assert_eq!(back.parts[0].mesh, scene.parts[0].mesh);
    // Existing files are not overwritten.
    std::fs::write(dst.path().join("tex 1.png"), b"mine").unwrap();
    write_file(&out, &scene, false).unwrap();
    assert_eq!(
        std::fs::read(dst.path().join("tex 1.png")).unwrap(),
        b"mine"
    );
    // .glb: both images embedded with their media types.
    let glb_path = dst.path().join("out.glb");
    write_file(&glb_path, &scene, true).unwrap();
    let back = crate::io::read_scene(&glb_path).unwrap();
    let doc = back.gltf.as_ref().unwrap().document();
    assert_eq!(doc["images"][0]["mimeType"], "image/png");
    assert_eq!(doc["images"][1]["mimeType"], "image/jpeg");
    assert!(doc["images"][1].get("uri").is_none());
    // Embedded .gltf: data URIs.
    let emb = write_embedded(&scene).unwrap();
    let v: Value = serde_json::from_slice(&emb).unwrap();
    assert!(v["images"][0]["uri"]
        .as_str()
        .unwrap()
        .starts_with("data:image/png;base64,"));
    // Written into the source folder: nothing to copy, URIs unchanged.
    let same = base.join("again.gltf");
    write_file(&same, &scene, false).unwrap();
    let v: Value = serde_json::from_slice(&std::fs::read(&same).unwrap()).unwrap();
    assert_eq!(v["images"][1]["uri"], "../up.png");
}

/// The square skinned to two joints, with inverse bind matrices and an animation.
fn skinned() -> Doc {
    let mut d = square();
    let joints = d.u16s(&[0, 1, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0], "VEC4", 4);
    let weights = d.f32s(
        &[
            0.5, 0.5, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0,
        ],
        "VEC4",
        4,
    );
    let ibm: Vec<f32> = IDENTITY
        .as_flattened()
        .iter()
        .chain(IDENTITY.as_flattened())
        .copied()
        .collect();
    let ibm = d.f32s(&ibm, "MAT4", 16);
    let times = d.f32s(&[0.0, 1.0], "SCALAR", 1);
    let rot = d.f32s(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0], "VEC4", 4);
    let prim = &mut d.json["meshes"][0]["primitives"][0]["attributes"];
    prim["JOINTS_0"] = json!(joints);
    prim["WEIGHTS_0"] = json!(weights);
    d.json["nodes"] = json!([
        { "mesh": 0, "skin": 0 },
        { "name": "hip", "children": [2] },
        { "name": "knee", "translation": [0.0, 1.0, 0.0] },
    ]);
    d.json["scenes"][0]["nodes"] = json!([0, 1]);
    d.json["skins"] = json!([{ "joints": [1, 2], "inverseBindMatrices": ibm, "skeleton": 1 }]);
    d.json["animations"] = json!([{
        "channels": [{ "sampler": 0, "target": { "node": 2, "path": "rotation" } }],
        "samplers": [{ "input": times, "output": rot, "interpolation": "LINEAR" }],
    }]);
    d
}

#[test]
fn skinned_round_trip_keeps_skin_and_animation() {
    let d = skinned();
    let s = read_ok(&d.glb());
    let m = &s.parts[0].mesh;
    assert_eq!(m.attributes.joints.as_ref().unwrap()[0], [0, 1, 0, 0]);
    let mut changed = s.clone();
    changed.parts[0].mesh.triangles.truncate(1);
    changed.parts[0].mesh.groups.as_mut().unwrap().truncate(1);
    let back = read_ok(&write_glb(&changed).unwrap());
    let doc = back.gltf.as_ref().unwrap().document();
    assert_eq!(doc["skins"][0]["joints"], json!([1, 2]));
    assert_eq!(doc["nodes"][0]["skin"], 0);
    assert_eq!(
        doc["animations"][0]["samplers"][0]["interpolation"],
        "LINEAR"
    );
    // The inverse bind matrices and animation data are carried over intact.
    let src = back.gltf.as_ref().unwrap();
    let root = src.document.as_object().unwrap();
    let views =
        accessor::parse_views(root, 1, |_| src.buffers[0].as_ref().map(|b| b.len())).unwrap();
    let accs = accessor::parse_accessors(root, &views, usize::MAX).unwrap();
    let store = accessor::Store {
        buffers: vec![src.buffers[0].as_deref().unwrap()],
        views,
        accessors: accs,
    };
    let ibm_acc = doc["skins"][0]["inverseBindMatrices"].as_u64().unwrap() as usize;
    assert_eq!(doc["accessors"][ibm_acc]["type"], "MAT4");
    assert_eq!(doc["accessors"][ibm_acc]["count"], 2);
    let out_acc = doc["animations"][0]["samplers"][0]["output"]
        .as_u64()
        .unwrap() as usize;
    assert_eq!(
        store.floats::<4>(out_acc, "rotation").unwrap()[1],
        [0.0, 0.0, 1.0, 0.0]
    );
    // Skinning streams of the kept triangle's vertices are unchanged.
    let bm = &back.parts[0].mesh;
    assert_eq!(bm.triangles, vec![[0, 1, 2]]);
    assert_eq!(
        bm.attributes.joints.as_ref().unwrap()[..3],
        m.attributes.joints.as_ref().unwrap()[..3]
    );
    assert_eq!(
        bm.attributes.weights.as_ref().unwrap()[..3],
        m.attributes.weights.as_ref().unwrap()[..3]
    );
    let jacc = doc["meshes"][0]["primitives"][0]["attributes"]["JOINTS_0"]
        .as_u64()
        .unwrap() as usize;
    assert_eq!(doc["accessors"][jacc]["componentType"], U16);
}

#[test]
fn fresh_documents_for_scenes_without_gltf() {
    // Two groups with names, a second part drawn twice (one moved), an empty part.
    let mut mesh = Mesh::from_triangles(
        SQUARE.chunks(3).map(|c| [c[0], c[1], c[2]]).collect(),
        vec![[0, 1, 2], [0, 2, 3]],
    );
    mesh.groups = Some(vec![3, 1]);
    mesh.group_names = vec![String::new(), "metal".into(), String::new(), "glass".into()];
    mesh.attributes.colors = Some(vec![[1.0, 0.5, 0.0, 1.0]; 4]);
    let mut moved = IDENTITY;
    moved[3] = [1.0, 2.0, 3.0, 1.0];
    let scene = Scene {
        parts: vec![
            Part {
                name: Some("a".into()),
                mesh: mesh.clone(),
                instances: vec![IDENTITY],
            },
            Part {
                name: None,
                mesh: Mesh::default(),
                instances: vec![IDENTITY],
            },
            Part {
                name: Some("b".into()),
                mesh: mesh.clone(),
                instances: vec![IDENTITY, moved],
            },
        ],
        ..Scene::default()
    };
    let bytes = write_glb(&scene).unwrap();
    let back = read_ok(&bytes);
    let doc = back.gltf.as_ref().unwrap().document();
    assert_eq!(
        doc["asset"],
        json!({ "version": "2.0", "generator": "meshlod" })
    );
    assert_eq!(doc["materials"].as_array().unwrap().len(), 2);
    assert_eq!(doc["materials"][0]["name"], "metal");
    assert_eq!(doc["materials"][1]["name"], "glass");
    assert_eq!(back.parts.len(), 2);
    assert_eq!(back.parts[0].mesh.group_names, vec!["metal", "glass"]);
    assert_eq!(back.parts[0].mesh.groups, Some(vec![0, 1]));
    assert_eq!(back.parts[1].instances, vec![IDENTITY, moved]);
    assert!(doc["nodes"][0].get("matrix").is_none());
    assert_eq!(doc["nodes"][2]["matrix"][12], 1.0);
    assert_eq!(
        back.parts[0].mesh.attributes.colors.as_ref().unwrap()[0],
        [1.0, 0.5, 0.0, 1.0]
    );
    assert_eq!(back.instanced_triangle_count(), 6);
    // Scene::from_mesh without groups: one "default" material.
    let plain = Scene::from_mesh(Mesh::from_triangles(
        vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    ));
    let back = read_ok(&write_embedded(&plain).unwrap());
    assert_eq!(back.parts[0].mesh.group_names, vec!["default"]);
    assert_eq!(back.parts[0].mesh.positions, plain.parts[0].mesh.positions);
    // An empty scene is a valid, empty document.
    let empty = read_ok(&write_glb(&Scene::default()).unwrap());
    assert!(empty.parts.is_empty());
}

#[test]
fn write_file_puts_the_buffer_next_to_the_gltf() {
    let dir = tempfile::tempdir().unwrap();
    let scene = read_ok(&square().glb());
    let path = dir.path().join("my model.gltf");
    write_file(&path, &scene, false).unwrap();
    let v: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    assert_eq!(v["buffers"][0]["uri"], "my%20model.bin");
    assert!(dir.path().join("my model.bin").exists());
    let back = crate::io::read_scene(&path).unwrap();
    assert_eq!(back.parts, scene.parts);
    let glb_path = dir.path().join("m.glb");
    write_file(&glb_path, &scene, true).unwrap();
    assert_eq!(&std::fs::read(&glb_path).unwrap()[..4], b"glTF");
}

#[test]
fn invalid_meshes_are_not_written() {
    let mut scene = read_ok(&square().glb());
    scene.parts[0].mesh.triangles.push([0, 1, 9]);
    scene.parts[0].mesh.groups.as_mut().unwrap().push(0);
    assert_err(
        &write_glb(&scene).unwrap_err(),
        Location::Element("mesh", 0),
        "cannot be written",
    );
}

#[test]
fn debug_output_is_short() {
    let scene = read_ok(&square().glb());
    let s = format!("{:?}", scene.gltf.as_ref().unwrap());
    assert!(s.contains("meshes: 1") && s.len() < 300, "{s}");
}

// ---------------------------------------------------------------- property test

mod props {
    use super::*;
    use proptest::prelude::*;

    /// Every corner of every triangle as the bits of all its vertex data, grouped by
    /// the rank of the triangle's group.
    fn soup(m: &Mesh) -> Vec<Vec<Vec<u32>>> {
        let mut groups: Vec<u32> = (0..m.triangles.len()).map(|t| m.group(t)).collect();
        groups.sort_unstable();
        groups.dedup();
        let a = &m.attributes;
        let mut out = vec![Vec::new(); groups.len()];
        for (t, tri) in m.triangles.iter().enumerate() {
            let rank = groups.binary_search(&m.group(t)).unwrap_or(0);
            for &v in tri {
                let v = v as usize;
                let mut c: Vec<u32> = m.positions[v].iter().map(|x| x.to_bits()).collect();
                let f = |s: Option<&[f32]>| {
                    s.map(|s| s.iter().map(|x| x.to_bits()).collect::<Vec<_>>())
                        .unwrap_or_default()
                };
                c.extend(f(a.normals.as_ref().map(|s| &s[v][..])));
                c.extend(f(a.tangents.as_ref().map(|s| &s[v][..])));
                c.extend(f(a.uv0.as_ref().map(|s| &s[v][..])));
                c.extend(f(a.uv1.as_ref().map(|s| &s[v][..])));
                c.extend(f(a.colors.as_ref().map(|s| &s[v][..])));
                c.extend(f(a.weights.as_ref().map(|s| &s[v][..])));
                if let Some(j) = &a.joints {
                    c.extend(j[v].iter().map(|&x| u32::from(x)));
                }
                out[rank].push(c);
            }
        }
        out
    }

    fn unit3() -> impl Strategy<Value = [f32; 3]> {
        (-1.0f32..1.0, -1.0f32..1.0, 0.1f32..1.0).prop_map(|(x, y, z)| {
            let l = (x * x + y * y + z * z).sqrt();
            [x / l, y / l, z / l]
        })
    }

    /// A texture coordinate pair on a 2⁻¹² grid in `[-2, 2]`: `1 − v` is exact
    /// there, so the reader's and writer's `v ↦ 1 − v` (see `flip_v`) gives the
    /// same bits back.
    fn uv() -> impl Strategy<Value = [f32; 2]> {
        prop::array::uniform2(-8192i32..=8192).prop_map(|c| c.map(|k| k as f32 / 4096.0))
    }

    fn mesh() -> impl Strategy<Value = Mesh> {
        (3usize..30).prop_flat_map(|n| {
            (
                prop::collection::vec(prop::array::uniform3(-100.0f32..100.0), n),
                prop::collection::vec(prop::array::uniform3(0..n as u32), 1..40),
                prop::option::of(prop::collection::vec(unit3(), n)),
                prop::option::of(prop::collection::vec((unit3(), prop::bool::ANY), n)),
                prop::option::of(prop::collection::vec(uv(), n)),
                prop::option::of(prop::collection::vec(prop::array::uniform4(0.0f32..1.0), n)),
                prop::option::of(prop::collection::vec(
                    (
                        prop::array::uniform4(0u16..300),
                        prop::array::uniform4(0.0f32..1.0),
                    ),
                    n,
                )),
                prop::option::of(prop::collection::vec(0u32..4, 40)),
                prop::option::of(prop::collection::vec(uv(), n)),
            )
                .prop_map(|(p, t, nrm, tan, uv0, col, skin, groups, uv1)| {
                    let mut m = Mesh::from_triangles(p, t);
                    m.attributes = VertexAttributes {
                        normals: nrm,
                        tangents: tan.map(|v| {
                            v.into_iter()
                                .map(|(d, s)| [d[0], d[1], d[2], if s { 1.0 } else { -1.0 }])
                                .collect()
                        }),
                        uv0,
                        uv1,
                        colors: col,
                        joints: skin.as_ref().map(|s| s.iter().map(|x| x.0).collect()),
                        weights: skin.map(|s| s.into_iter().map(|x| x.1).collect()),
                    };
                    if let Some(mut g) = groups {
                        g.truncate(m.triangles.len());
                        m.groups = Some(g);
                        m.group_names = vec!["a".into(), "b".into(), String::new(), "d".into()];
                    }
                    m
                })
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn random_meshes_round_trip(mesh in mesh(), second in mesh()) {
            let scene = Scene {
                parts: vec![
                    Part { name: Some("one".into()), mesh: mesh.clone(), instances: vec![IDENTITY] },
                    Part { name: None, mesh: second.clone(), instances: vec![IDENTITY] },
                ],
                ..Scene::default()
            };
            let back = read(&write_glb(&scene).unwrap(), None).unwrap();
            prop_assert_eq!(back.parts.len(), 2);
            for (a, b) in scene.parts.iter().zip(&back.parts) {
                prop_assert_eq!(soup(&a.mesh), soup(&b.mesh));
                prop_assert_eq!(a.mesh.attributes.kinds(), b.mesh.attributes.kinds());
            }
            // Through the source document: change part 0, write, read again.
            let mut changed = back.clone();
            let m = &mut changed.parts[0].mesh;
            m.triangles.pop();
            if let Some(g) = &mut m.groups { g.pop(); }
            let again = read(&write_glb(&changed).unwrap(), None).unwrap();
            prop_assert_eq!(again.parts.len(), changed.parts.len() - usize::from(changed.parts[0].mesh.triangles.is_empty()));
            if !changed.parts[0].mesh.triangles.is_empty() {
                prop_assert_eq!(soup(&changed.parts[0].mesh), soup(&again.parts[0].mesh));
            }
            let last = again.parts.last().unwrap();
            prop_assert_eq!(&back.parts[1].mesh, &last.mesh);
        }
    }
}

// ---------------------------------------------------------------- robustness

/// A xorshift generator for the mutation tests (fixed seed: deterministic).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Reads `bytes`; when that works, writes the scene unchanged and changed. Nothing
/// may panic.
fn exercise(bytes: &[u8]) {
    if let Ok(scene) = read(bytes, None) {
        let _ = write_glb(&scene);
        let mut changed = scene;
        for part in &mut changed.parts {
            part.mesh.triangles.pop();
            if let Some(g) = &mut part.mesh.groups {
                g.truncate(part.mesh.triangles.len());
            }
        }
        let _ = write_embedded(&changed);
    }
}

#[test]
fn mutated_bytes_never_panic() {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    for seed in [
        textured().glb(),
        skinned().glb(),
        multi().glb(),
        multi().gltf(),
    ] {
        for _ in 0..400 {
            let mut b = seed.clone();
            for _ in 0..1 + rng.below(4) {
                let i = rng.below(b.len());
                b[i] = rng.next() as u8;
            }
            if rng.below(8) == 0 {
                b.truncate(rng.below(b.len()));
            }
            exercise(&b);
        }
    }
}

#[test]
fn mutated_json_values_never_panic() {
    fn leaves(v: &Value) -> usize {
        match v {
            Value::Array(a) => a.iter().map(leaves).sum(),
            Value::Object(o) => o.values().map(leaves).sum(),
            _ => 1,
        }
    }
    let weird = [
        json!(-1),
        json!(0),
        json!(1),
        json!(3),
        json!(255),
        json!(65535),
        json!(4_294_967_295u64),
        json!(1e20),
        json!(2.5),
        json!("x"),
        json!(null),
        json!([]),
        json!({}),
    ];
    let mut rng = Rng(0xD1B5_4A32_D192_ED03);
    for seed in [textured(), skinned(), multi()] {
        let leaves = leaves(&seed.json);
        for _ in 0..400 {
            let mut j = seed.json.clone();
            // Replace the k-th leaf value.
            let k = rng.below(leaves);
            let w = weird[rng.below(weird.len())].clone();
            replace_leaf(&mut j, k, w);
            let d = Doc {
                json: j,
                bin: seed.bin.clone(),
            };
            exercise(&d.glb());
        }
    }
}

/// Replaces the `k`-th leaf (non-container value) of `v`, in depth-first order.
fn replace_leaf(v: &mut Value, k: usize, with: Value) {
    fn walk(v: &mut Value, k: &mut usize, with: &mut Option<Value>) {
        match v {
            Value::Array(a) => a.iter_mut().for_each(|x| walk(x, k, with)),
            Value::Object(o) => o.values_mut().for_each(|x| walk(x, k, with)),
            leaf => {
                if *k == 0 {
                    if let Some(w) = with.take() {
                        *leaf = w;
                    }
                }
                *k = k.wrapping_sub(1);
            }
        }
    }
    let mut k = k;
    walk(v, &mut k, &mut Some(with));
}

// ---------------------------------------------------------------- real files

/// The shared test meshes (`shared/meshes` beside the repository or one of its
/// parents), when present.
fn shared_meshes() -> Option<std::path::PathBuf> {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .ancestors()
        .map(|a| a.join("shared/meshes"))
        .find(|d| d.join("MANIFEST.md").is_file())
}

#[test]
fn sample_models_match_the_manifest_and_round_trip() {
    let Some(dir) = shared_meshes() else {
        eprintln!("shared/meshes not found: skipping the sample-model check");
        return;
    };
    // (model, instanced vertices, instanced triangles) from shared/meshes/MANIFEST.md.
    let expected = [
        ("2CylinderEngine", 84_657, 121_496),
        ("Avocado", 406, 682),
        ("BrainStem", 34_159, 61_666),
        ("DamagedHelmet", 14_556, 15_452),
        ("Duck", 2_399, 4_212),
        ("ReciprocatingSaw", 156_254, 198_470),
        ("VC", 19_483, 8_383),
        ("WaterBottle", 2_549, 4_510),
    ];
    for (name, vertices, triangles) in expected {
        let path = dir.join(format!("gltf-sample-models/{name}/{name}.gltf"));
        let scene = crate::io::read_scene(&path).unwrap();
        let v: usize = scene
            .parts
            .iter()
            .map(|p| p.mesh.positions.len() * p.instances.len())
            .sum();
        assert_eq!(
            (v, scene.instanced_triangle_count()),
            (vertices, triangles),
            "{name}"
        );
        // Unchanged: identical parts after a GLB round trip.
        let back = read_ok(&write_glb(&scene).unwrap());
        assert_eq!(back.parts, scene.parts, "{name}");
        // Changed: every fifth triangle removed, still readable with the same count.
        let mut changed = scene.clone();
        for part in &mut changed.parts {
            let m = &mut part.mesh;
            let keep: Vec<bool> = (0..m.triangles.len()).map(|t| t % 5 != 4).collect();
            let mut k = keep.iter();
            m.triangles.retain(|_| *k.next().unwrap_or(&true));
            if let Some(g) = &mut m.groups {
                let mut k = keep.iter();
                g.retain(|_| *k.next().unwrap_or(&true));
            }
        }
        let back = read_ok(&write_glb(&changed).unwrap());
        assert_eq!(
            back.instanced_triangle_count(),
            changed.instanced_triangle_count(),
            "{name}"
        );
    }
    let pirate = crate::io::read_scene(dir.join("meshoptimizer/pirate.glb")).unwrap_err();
    let text = pirate.to_string();
    assert!(
        text.contains("EXT_meshopt_compression (compressed geometry)"),
        "{text}"
    );
}
