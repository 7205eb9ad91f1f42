#!/usr/bin/env python3
"""Regenerates the malformed-input corpus in this folder.

Every file here must make `meshlod info FILE` exit non-zero with a message that names
the file, and must never make a reader panic. Names say what is wrong. Run this script
from this folder after adding a case; the files are committed so tests need no Python.
"""
import base64, json, struct

def w(name, data):
    if isinstance(data, str):
        data = data.encode()
    with open(name, "wb") as f:
        f.write(data)

TRI = "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
# --- OBJ ---
w("obj_bad_number.obj", "v 0 0 0\nv 1 abc 0\nv 0 1 0\nf 1 2 3\n")
w("obj_index_zero.obj", TRI + "f 0 1 2\n")
w("obj_index_out_of_range.obj", TRI + "f 1 2 99\n")
w("obj_negative_index_out_of_range.obj", TRI + "f -1 -2 -10\n")
w("obj_nan_coordinate.obj", "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
w("obj_inf_coordinate.obj", "v 0 0 0\nv 1 0 inf\nv 0 1 0\nf 1 2 3\n")
w("obj_face_two_vertices.obj", TRI + "f 1 2\n")
w("obj_non_utf8_number.obj", b"v 0 0 0\nv 1 \xff\xfe 0\nv 0 1 0\nf 1 2 3\n")
w("obj_uv_index_out_of_range.obj", TRI + "vt 0 0\nf 1/1 2/5 3/1\n")
w("obj_empty.obj", "")
w("obj_index_overflow.obj", TRI + "f 1 2 99999999999999999999999\n")
# --- PLY ---
HDR = "ply\nformat {fmt} 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\nproperty float z\nelement face {nf}\nproperty list uchar int vertex_indices\nend_header\n"
w("ply_no_magic.ply", "plx\nformat ascii 1.0\nend_header\n")
w("ply_bad_format.ply", HDR.format(fmt="binary_middle_endian", nv=3, nf=1))
w("ply_missing_end_header.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n")
w("ply_unknown_property_type.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n1\n")
body = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0) + struct.pack("<B3i", 3, 0, 1, 2)
w("ply_truncated_binary.ply", HDR.format(fmt="binary_little_endian", nv=3, nf=1).encode() + body[:-5])
w("ply_huge_vertex_count.ply", HDR.format(fmt="binary_little_endian", nv=4000000000, nf=1).encode() + body)
w("ply_face_index_out_of_range.ply", HDR.format(fmt="ascii", nv=3, nf=1) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n")
w("ply_negative_index.ply", HDR.format(fmt="ascii", nv=3, nf=1) + "0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n")
w("ply_bad_ascii_number.ply", HDR.format(fmt="ascii", nv=3, nf=1) + "0 0 0\n1 0x 0\n0 1 0\n3 0 1 2\n")
w("ply_list_count_past_end.ply", HDR.format(fmt="binary_little_endian", nv=3, nf=1).encode()
  + struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0) + struct.pack("<B3i", 200, 0, 1, 2))
w("ply_no_x_property.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0\n0 0\n1 0\n3 0 1 2\n")
w("ply_nan_binary.ply", HDR.format(fmt="binary_little_endian", nv=3, nf=1).encode()
  + struct.pack("<9f", 0, 0, 0, float("nan"), 0, 0, 0, 1, 0) + struct.pack("<B3i", 3, 0, 1, 2))
w("ply_empty.ply", "")
# --- STL ---
rec = struct.pack("<12fH", 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0)
w("stl_truncated_binary.stl", b"\0" * 80 + struct.pack("<I", 100) + rec)
w("stl_ascii_bad_vertex.stl", "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n")
w("stl_ascii_bad_number.stl", "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 q\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n")
w("stl_nan_binary.stl", b"\0" * 80 + struct.pack("<I", 1) + struct.pack("<12fH", 0, 0, 1, float("nan"), 0, 0, 1, 0, 0, 0, 1, 0, 0))
w("stl_short_garbage.stl", b"\x07" * 50)
w("stl_huge_count.stl", b"\0" * 80 + struct.pack("<I", 0xFFFFFFFF) + rec)
# --- OFF ---
w("off_bad_header.off", "OFX\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
w("off_count_too_large.off", "OFF\n1000000000 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
w("off_index_out_of_range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n")
w("off_truncated.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n")
w("off_negative_count.off", "OFF\n-3 1 0\n0 0 0\n")
# --- glTF / GLB ---
def gltf_doc(buf, count=3, idx_count=3, extra=None):
    d = {
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": len(buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": count, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5123, "count": idx_count, "type": "SCALAR"},
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0,
    }
    if extra:
        d.update(extra)
    return json.dumps(d)
good_buf = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0) + struct.pack("<3H", 0, 1, 2)
w("gltf_bad_json.gltf", '{"asset": {"version": "2.0"}, "meshes": [')
w("gltf_accessor_out_of_bounds.gltf", gltf_doc(good_buf, count=1000))
w("gltf_index_out_of_range.gltf", gltf_doc(struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0) + struct.pack("<3H", 0, 1, 9)))
w("gltf_draco_required.gltf", gltf_doc(good_buf, extra={"extensionsUsed": ["KHR_draco_mesh_compression"], "extensionsRequired": ["KHR_draco_mesh_compression"]}))
d = json.loads(gltf_doc(good_buf)); d["buffers"][0] = {"byteLength": 42, "uri": "does_not_exist.bin"}
w("gltf_missing_buffer_file.gltf", json.dumps(d))
w("gltf_not_json.gltf", b"\x00\x01binary garbage\xff")
w("glb_bad_magic.glb", b"glTX" + struct.pack("<II", 2, 20) + b"\0" * 8)
w("glb_truncated.glb", b"glTF" + struct.pack("<II", 2, 5000) + struct.pack("<I", 4000) + b"JSON" + b"{}")
w("glb_chunk_past_end.glb", b"glTF" + struct.pack("<II", 2, 28) + struct.pack("<I", 1000) + b"JSON" + b"{}  ")
# --- Hoppe .m ---
w("m_unknown_vertex.m", "Vertex 1 0 0 0\nVertex 2 1 0 0\nVertex 3 0 1 0\nFace 1 1 2 4\n")
w("m_bad_number.m", "Vertex 1 0 0 0\nVertex 2 1 zero 0\nVertex 3 0 1 0\nFace 1 1 2 3\n")
