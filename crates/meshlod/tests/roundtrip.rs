//! Property tests: random meshes survive write → read in every format, with every
//! attribute the format can carry. Meshes are compared corner by corner (each
//! triangle's three corners with their position and attributes, in order; the list of
//! triangles sorted), so a reader may renumber vertices (OBJ wedges, STL welding) and a
//! writer may group triangles by material, but neither may change the surface.
//! Also round-trips the real meshes shipped in `tests/data`.

mod common;

use meshlod::io::{read_scene_from_bytes, write_scene_to_bytes, Format, Scene, WriteOptions};
use meshlod::mesh::{Mesh, VertexAttributes};
use proptest::prelude::*;

/// Which attributes a format carries.
#[derive(Clone, Copy)]
struct Caps {
    normals: bool,
    uv0: bool,
    colors: bool,
    groups: bool,
    /// The format stores `v` top-down (glTF): the reader and writer map `v ↦ 1 − v`,
    /// so a coordinate comes back as `1 − (1 − v)` in `f32` (the same for the value
    /// that comes back: that rounding is idempotent). Compared through it.
    uv_flipped: bool,
}

fn caps(format: Format) -> Caps {
    let all = Caps {
        normals: true,
        uv0: true,
        colors: true,
        groups: true,
        uv_flipped: false,
    };
    match format {
        Format::Obj => all,
        Format::Gltf | Format::Glb => Caps {
            uv_flipped: true,
            ..all
        },
        Format::Ply => Caps {
            groups: false,
            ..all
        },
        Format::Off => Caps {
            normals: false,
            uv0: false,
            groups: false,
            ..all
        },
        Format::HoppeM => Caps {
            normals: true,
            uv0: false,
            colors: false,
            groups: false,
            uv_flipped: false,
        },
        Format::Stl => Caps {
            normals: false,
            uv0: false,
            colors: false,
            groups: false,
            uv_flipped: false,
        },
    }
}

/// A corner: position, then optional normal, uv, colour (as bit patterns for exact
/// comparison), then the triangle's group by name (formats renumber group ids in order
/// of appearance; names are what they keep).
type Corner = (
    [u32; 3],
    Option<[u32; 3]>,
    Option<[u32; 2]>,
    Option<[u32; 4]>,
    String,
);

/// The mesh's triangles as corner triples, sorted: writers may reorder triangles
/// (grouping them by material) but not change them.
fn corners(m: &Mesh, c: Caps, by_name: bool) -> Vec<[Corner; 3]> {
    let flat = corner_list(m, c, by_name);
    let mut tris: Vec<[Corner; 3]> = flat
        .chunks_exact(3)
        .map(|k| [k[0].clone(), k[1].clone(), k[2].clone()])
        .collect();
    tris.sort_unstable();
    tris
}

fn corner_list(m: &Mesh, c: Caps, by_name: bool) -> Vec<Corner> {
    let bits3 = |v: [f32; 3]| v.map(f32::to_bits);
    let mut out = Vec::with_capacity(m.triangles.len() * 3);
    for (t, tri) in m.triangles.iter().enumerate() {
        for &i in tri {
            let i = i as usize;
            out.push((
                bits3(m.positions[i]),
                c.normals
                    .then(|| m.attributes.normals.as_ref().map(|n| bits3(n[i])))
                    .flatten(),
                c.uv0
                    .then(|| {
                        m.attributes.uv0.as_ref().map(|u| {
                            let [s, t] = u[i];
                            let t = if c.uv_flipped { 1.0 - (1.0 - t) } else { t };
                            [s.to_bits(), t.to_bits()]
                        })
                    })
                    .flatten(),
                c.colors
                    .then(|| m.attributes.colors.as_ref().map(|u| u[i].map(f32::to_bits)))
                    .flatten(),
                if c.groups && by_name {
                    let g = m.group(t) as usize;
                    m.group_names
                        .get(g)
                        .cloned()
                        .unwrap_or_else(|| format!("#{g}"))
                } else if c.groups {
                    // Unnamed groups: writers invent names, ids must survive.
                    format!("#{}", m.group(t))
                } else {
                    String::new()
                },
            ));
        }
    }
    out
}

/// Random mesh: `n` vertices on a jittered grid, triangles over random distinct
/// vertices, optional attributes with values every format stores exactly (colours
/// are multiples of 1/255, as 8-bit formats store them).
fn arb_mesh() -> impl Strategy<Value = Mesh> {
    (3usize..40, any::<u64>(), any::<[bool; 4]>()).prop_flat_map(|(n, seed, flags)| {
        let tris = prop::collection::vec((0..n as u32, 0..n as u32, 0..n as u32), 1..60);
        tris.prop_map(move |tris| {
            let mut rng = seed;
            let mut next = move || {
                rng = rng
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((rng >> 40) as f32) / (1u64 << 24) as f32
            };
            let positions: Vec<[f32; 3]> = (0..n)
                .map(|i| [i as f32 * 0.5 + next(), next() * 10.0 - 5.0, next() * 1e-3])
                .collect();
            let triangles: Vec<[u32; 3]> = tris
                .into_iter()
                .filter(|&(a, b, c)| a != b && b != c && a != c)
                .map(|(a, b, c)| [a, b, c])
                .collect();
            let mut attributes = VertexAttributes::default();
            if flags[0] {
                attributes.normals = Some(
                    (0..n)
                        .map(|_| {
                            let v = [next() - 0.5, next() - 0.5, next() + 0.1];
                            let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                            [v[0] / l, v[1] / l, v[2] / l]
                        })
                        .collect(),
                );
            }
            if flags[1] {
                attributes.uv0 = Some((0..n).map(|_| [next(), next()]).collect());
            }
            if flags[2] {
                attributes.colors = Some(
                    (0..n)
                        .map(|_| {
                            let k = |x: f32| (x * 255.0).floor() / 255.0;
                            [k(next()), k(next()), k(next()), 1.0]
                        })
                        .collect(),
                );
            }
            let groups = flags[3].then(|| {
                (0..triangles.len())
                    .map(|t| u32::from(t % 3 == 0))
                    .collect()
            });
            Mesh {
                positions,
                triangles,
                attributes,
                group_names: if groups.is_some() {
                    vec!["red".into(), "blue".into()]
                } else {
                    Vec::new()
                },
                groups,
            }
        })
    })
}

fn roundtrip(mesh: &Mesh, format: Format, ascii: bool) -> Result<Mesh, String> {
    let scene = Scene::from_mesh(mesh.clone());
    let opts = WriteOptions::default().with_ascii(ascii);
    let bytes = write_scene_to_bytes(&scene, format, &opts).map_err(|e| e.to_string())?;
    let back = read_scene_from_bytes(&bytes, format, None).map_err(|e| e.to_string())?;
    Ok(back.flatten())
}

fn check(mesh: &Mesh, format: Format, ascii: bool) -> Result<(), TestCaseError> {
    let back = roundtrip(mesh, format, ascii).map_err(TestCaseError::fail)?;
    let c = caps(format);
    prop_assert_eq!(back.triangles.len(), mesh.triangles.len());
    let named = !mesh.group_names.is_empty();
    prop_assert_eq!(
        corners(&back, c, named),
        corners(mesh, c, named),
        "{:?}",
        format
    );
    Ok(())
}

const ALL: [(Format, bool); 9] = [
    (Format::Obj, false),
    (Format::Ply, false),
    (Format::Ply, true),
    (Format::Stl, false),
    (Format::Stl, true),
    (Format::Off, false),
    (Format::Gltf, false),
    (Format::Glb, false),
    (Format::HoppeM, false),
];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn random_meshes_survive_every_format(mesh in arb_mesh()) {
        for (format, ascii) in ALL {
            check(&mesh, format, ascii)?;
        }
    }
}

#[test]
fn shipped_meshes_survive_every_format() {
    let dir = common::data_dir();
    for name in [
        "cow.obj",
        "spot.obj",
        "fandisk.obj",
        "stratocaster.ply",
        "camelhead.off",
        "Duck/Duck.gltf",
    ] {
        let mut mesh = meshlod::read_mesh(dir.join(name)).unwrap_or_else(|e| panic!("{e}"));
        mesh.compact_vertices();
        for (format, ascii) in ALL {
            let back = roundtrip(&mesh, format, ascii)
                .unwrap_or_else(|e| panic!("{name} as {format:?}: {e}"));
            let c = caps(format);
            assert!(
                corners(&back, c, !mesh.group_names.is_empty())
                    == corners(&mesh, c, !mesh.group_names.is_empty()),
                "{name} changed in a round trip through {format:?} (ascii {ascii})"
            );
        }
    }
}

/// A UTF-8 byte-order mark before a text file (as some Windows editors save it) is
/// skipped by every text format's reader: the same mesh comes back.
#[test]
fn a_byte_order_mark_is_skipped() {
    let mesh = meshlod::mesh::generate::icosphere(1);
    for format in [
        Format::Obj,
        Format::Ply,
        Format::Stl,
        Format::Off,
        Format::HoppeM,
    ] {
        let opts = WriteOptions::default().with_ascii(true);
        let text =
            write_scene_to_bytes(&Scene::from_mesh(mesh.clone()), format, &opts).expect("writes");
        let mut with_bom = b"\xEF\xBB\xBF".to_vec();
        with_bom.extend_from_slice(&text);
        let plain = read_scene_from_bytes(&text, format, None).expect("reads");
        let bom = read_scene_from_bytes(&with_bom, format, None)
            .unwrap_or_else(|e| panic!("{format:?} with a BOM: {e}"));
        assert_eq!(bom.flatten(), plain.flatten(), "{format:?}");
    }
}
