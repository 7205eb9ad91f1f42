//! Progressive meshes: exact reproduction, prefixes, navigation, extraction equal to
//! a direct simplification, the `.pmesh` decoder on truncated and corrupt bytes.

use super::*;
use crate::cost::Placement;
use crate::mesh::{generate, Mesh, MeshStats};
use crate::simplify::{simplify, Method, SimplifyOptions};
use proptest::prelude::*;

/// A corner as comparable bits: position, every attribute, and the group.
fn corner_key(m: &Mesh, v: u32, group: u32) -> Vec<u32> {
    let v = v as usize;
    let a = &m.attributes;
    let mut k: Vec<u32> = m.positions[v].iter().map(|x| x.to_bits()).collect();
    let mut f = |s: &[f32]| k.extend(s.iter().map(|x| x.to_bits()));
    if let Some(s) = &a.normals {
        f(&s[v]);
    }
    if let Some(s) = &a.tangents {
        f(&s[v]);
    }
    if let Some(s) = &a.uv0 {
        f(&s[v]);
    }
    if let Some(s) = &a.uv1 {
        f(&s[v]);
    }
    if let Some(s) = &a.colors {
        f(&s[v]);
    }
    if let Some(s) = &a.weights {
        f(&s[v]);
    }
    if let Some(s) = &a.joints {
        k.extend(s[v].iter().map(|&j| u32::from(j)));
    }
    k.push(group);
    k
}

/// The triangles as sorted corner-key triples, each rotated to start at its
/// smallest corner: equal for meshes that differ only in vertex and triangle order
/// and triangle rotation.
pub(crate) fn canonical(m: &Mesh) -> Vec<[Vec<u32>; 3]> {
    let mut out: Vec<[Vec<u32>; 3]> = m
        .triangles
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let k = t.map(|v| corner_key(m, v, m.group(i)));
            let r = (0..3).min_by(|&a, &b| k[a].cmp(&k[b])).unwrap_or(0);
            [k[r].clone(), k[(r + 1) % 3].clone(), k[(r + 2) % 3].clone()]
        })
        .collect();
    out.sort();
    out
}

fn melax_full() -> SimplifyOptions {
    SimplifyOptions::default()
        .with_method(Method::Melax)
        .with_target_triangles(0)
        .with_facing_repair(false)
}

fn qem_full() -> SimplifyOptions {
    SimplifyOptions::default()
        .with_placement(Placement::Endpoint)
        .with_target_triangles(0)
        .with_facing_repair(false)
}

fn assert_valid(m: &Mesh) {
    m.validate().expect("valid mesh");
    let s = MeshStats::of(m);
    assert_eq!(s.topology.degenerate_triangles, 0);
}

/// The full checks on one mesh and options: exact reproduction, every level's
/// triangle count, extraction equal to direct simplification at a few targets.
fn check_pm(mesh: &Mesh, options: &SimplifyOptions) -> ProgressiveMesh {
    let (pm, report) = ProgressiveMesh::build(mesh, options).expect("build");
    let (repaired, _) = simplify(mesh, &SimplifyOptions::default().with_ratio(1.0)).unwrap();
    assert_eq!(pm.split_count(), report.collapses);
    assert_eq!(pm.base_triangle_count(), report.triangles_out);
    let mut nav = Navigator::new(&pm);
    assert_eq!(
        canonical(&nav.to_mesh()),
        canonical(&repaired),
        "finest level"
    );
    nav.set_level(0);
    assert_eq!(nav.triangle_count(), pm.base_triangle_count());
    let n0 = repaired.triangles.len();
    for target in [n0 / 2, n0 / 10, n0 / 50 + 1] {
        let (direct, _) = simplify(mesh, &options.clone().with_target_triangles(target)).unwrap();
        nav.set_triangles(target);
        let got = nav.to_mesh();
        assert_valid(&got);
        assert_eq!(
            canonical(&got),
            canonical(&direct),
            "extract {target} vs direct"
        );
    }
    pm
}

#[test]
fn icosphere_melax_and_qem_endpoint_reproduce_and_extract() {
    let m = generate::icosphere(3);
    let pm = check_pm(&m, &melax_full());
    // A closed genus-0 surface goes down to a handful of triangles.
    assert!(
        pm.base_triangle_count() <= 8,
        "{}",
        pm.base_triangle_count()
    );
    check_pm(&m, &qem_full());
}

#[test]
fn open_and_seamed_and_grouped_meshes_reproduce() {
    check_pm(&generate::cylinder(24, 8, 2.0, false), &melax_full());
    check_pm(&generate::torus(24, 12, 2.0, 0.6), &qem_full());
    // UV seam down the middle and two groups.
    let mut m = generate::grid(10, 10, |x, y| 0.05 * (5.0 * x).sin() * (3.0 * y).cos());
    let mut uv: Vec<[f32; 2]> = m.positions.iter().map(|p| [p[0], p[1]]).collect();
    let mut twin = vec![u32::MAX; m.positions.len()];
    for (i, p) in m.positions.clone().iter().enumerate() {
        if p[0] == 0.5 {
            twin[i] = m.positions.len() as u32;
            m.positions.push(*p);
            uv.push([p[0] + 10.0, p[1]]);
        }
    }
    let positions = m.positions.clone();
    let mut groups = Vec::new();
    for t in &mut m.triangles {
        let right = t.iter().any(|&v| positions[v as usize][0] > 0.5);
        if right {
            for v in t.iter_mut() {
                if twin[*v as usize] != u32::MAX {
                    *v = twin[*v as usize];
                }
            }
        }
        groups.push(u32::from(t.iter().any(|&v| positions[v as usize][1] > 0.5)));
    }
    m.attributes.uv0 = Some(uv);
    m.groups = Some(groups);
    m.group_names = vec!["low".into(), "high".into()];
    let pm = check_pm(&m, &melax_full());
    let back = ProgressiveMesh::from_bytes(&pm.to_bytes()).expect("decode");
    assert!(back.complete);
    assert_eq!(back.pm, pm);
}

#[test]
fn other_placements_are_refused() {
    let m = generate::icosphere(1);
    for o in [
        SimplifyOptions::default(),
        SimplifyOptions::default().with_placement(Placement::Midpoint),
    ] {
        assert!(matches!(
            ProgressiveMesh::build(&m, &o),
            Err(PmError::NotHalfEdge(_))
        ));
    }
}

#[test]
fn navigation_both_ways_matches_fresh_extraction() {
    let m = generate::torus(30, 14, 2.0, 0.7);
    let (pm, _) = ProgressiveMesh::build(&m, &melax_full()).unwrap();
    let mut nav = Navigator::new(&pm);
    let s = pm.split_count();
    let mut x: u64 = 12345;
    for _ in 0..40 {
        x = x
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let level = (x >> 33) as usize % (s + 1);
        nav.set_level(level);
        assert_eq!(nav.level(), level);
        let mut fresh = Navigator::new(&pm);
        fresh.set_level(level);
        assert_eq!(nav.indices(), fresh.indices());
        assert_eq!(nav.triangle_count(), pm.triangles_at(level));
        // Every index refers into the vertex-buffer prefix.
        let nv = nav.vertex_count() as u32;
        assert!(nav.indices().iter().flatten().all(|&w| w < nv));
    }
    // Refine and coarsen by counts.
    nav.set_level(0);
    assert_eq!(nav.refine(s + 10), s);
    assert_eq!(nav.coarsen(3), 3);
    assert_eq!(nav.level(), s - 3);
}

#[test]
fn geomorph_starts_at_the_coarse_ancestors() {
    let m = generate::icosphere(3);
    let (pm, _) = ProgressiveMesh::build(&m, &melax_full()).unwrap();
    let mut nav = Navigator::new(&pm);
    let fine = pm.level_for_triangles(600);
    let coarse = pm.level_for_triangles(300);
    nav.set_level(fine);
    let (mesh, morph) = nav.to_mesh_with_geomorph(coarse);
    assert_eq!(morph.len(), mesh.positions.len());
    // Same level: nothing moves.
    let (_, same) = nav.to_mesh_with_geomorph(fine);
    assert_eq!(same, mesh.positions);
    // Every start position is a point of the coarse level, and the coarse level's
    // own points do not move.
    let coarse_mesh = pm.mesh_at(coarse);
    let coarse_points: std::collections::HashSet<[u32; 3]> = coarse_mesh
        .positions
        .iter()
        .map(|p| p.map(f32::to_bits))
        .collect();
    let mut moved = 0;
    for (p, q) in mesh.positions.iter().zip(&morph) {
        assert!(coarse_points.contains(&q.map(f32::to_bits)));
        if coarse_points.contains(&p.map(f32::to_bits)) {
            assert_eq!(p, q);
        } else {
            moved += 1;
        }
    }
    assert_eq!(moved, mesh.positions.len() - coarse_mesh.positions.len());
}

/// Every cut of the byte stream: never a panic; a cut between records decodes to
/// exactly that prefix, a cut inside a record is an error naming an offset within
/// the buffer, and the partial decoder returns the last complete prefix.
#[test]
fn every_prefix_decodes_or_errors_cleanly() {
    let m = generate::icosphere(2);
    let (pm, _) = ProgressiveMesh::build(&m, &melax_full()).unwrap();
    let bytes = pm.to_bytes();
    let mut boundaries = 0;
    let mut last_level = 0;
    for n in 0..=bytes.len() {
        match ProgressiveMesh::from_bytes(&bytes[..n]) {
            Ok(d) => {
                boundaries += 1;
                assert_eq!(d.bytes_used, n);
                assert_eq!(d.splits_in_header, pm.split_count());
                assert_eq!(d.complete, n == bytes.len());
                let k = d.pm.split_count();
                let mut want = pm.clone();
                want.truncate(k);
                assert_eq!(d.pm, want);
                let mesh = d.pm.mesh_at(k);
                assert_valid(&mesh);
                assert_eq!(canonical(&mesh), canonical(&pm.mesh_at(k)));
            }
            Err(PmError::Format {
                offset, message, ..
            }) => {
                assert!(offset <= n, "offset {offset} past the cut {n}: {message}");
                assert!(!message.is_empty());
            }
            Err(e) => panic!("unexpected error {e}"),
        }
        if let Ok(d) = ProgressiveMesh::from_bytes_partial(&bytes[..n]) {
            assert!(d.pm.split_count() >= last_level);
            last_level = d.pm.split_count();
            assert_valid(&d.pm.mesh_at(last_level));
        }
    }
    // The header+base, then one boundary per split.
    assert_eq!(boundaries, pm.split_count() + 1);
    assert_eq!(last_level, pm.split_count());
}

/// Every byte flipped: never a panic; what decodes is a valid mesh at every level.
#[test]
fn corrupt_bytes_never_panic() {
    let m = generate::cylinder(8, 3, 1.0, true);
    let (pm, _) = ProgressiveMesh::build(&m, &melax_full()).unwrap();
    let bytes = pm.to_bytes();
    for i in 0..bytes.len() {
        for x in [0xff_u8, 0x01, 0x80] {
            let mut b = bytes.clone();
            b[i] ^= x;
            if let Ok(d) = ProgressiveMesh::from_bytes(&b) {
                let mut nav = Navigator::new(&d.pm);
                for l in [0, d.pm.split_count() / 2, d.pm.split_count()] {
                    nav.set_level(l);
                    nav.to_mesh().validate().expect("valid");
                }
            }
        }
    }
}

#[test]
fn bad_headers_are_named() {
    let m = generate::icosphere(1);
    let (pm, _) = ProgressiveMesh::build(&m, &melax_full()).unwrap();
    let good = pm.to_bytes();
    let msg = |b: &[u8]| match ProgressiveMesh::from_bytes(b) {
        Err(e) => e.to_string(),
        Ok(_) => String::from("ok"),
    };
    assert!(msg(b"").contains("byte 0"));
    let mut b = good.clone();
    b[0] = b'X';
    assert!(msg(&b).contains("not a .pmesh"), "{}", msg(&b));
    let mut b = good.clone();
    b[4] = 9;
    assert!(msg(&b).contains("unsupported version 9"));
    // A huge base point count must not allocate: it is checked against the bytes.
    let mut b = good.clone();
    b[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(msg(&b).contains("needs at least"), "{}", msg(&b));
    let mut b = good.clone();
    b.push(0);
    assert!(msg(&b).contains("trailing"));
}

#[test]
fn empty_mesh_gives_an_empty_progressive_mesh() {
    let (pm, _) = ProgressiveMesh::build(&Mesh::default(), &melax_full()).unwrap();
    assert_eq!(pm.split_count(), 0);
    let d = ProgressiveMesh::from_bytes(&pm.to_bytes()).unwrap();
    assert!(d.pm.mesh_at(0).is_empty());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]
    /// Random height fields with holes and junk triangles: the finest level is the
    /// repaired input, and the bytes round-trip.
    #[test]
    fn random_meshes_reproduce(n in 3u32..12, m in 3u32..12,
        heights in prop::collection::vec(-1.0f32..1.0, 144),
        keep in prop::collection::vec(any::<bool>(), 200),
        junk in prop::collection::vec((0u32..200, 0u32..200, 0u32..200), 0..5),
        melax in any::<bool>())
    {
        let mut g = generate::grid(n, m, |_, _| 0.0);
        for (i, p) in g.positions.iter_mut().enumerate() {
            p[2] = 0.3 * heights[i % heights.len()];
        }
        g.triangles = g.triangles.iter().enumerate()
            .filter(|(i, _)| keep[i % keep.len()] || i % 3 != 0)
            .map(|(_, t)| *t).collect();
        let nv = g.positions.len() as u32;
        for (a, b, c) in junk {
            g.triangles.push([a % nv, b % nv, c % nv]);
        }
        let o = if melax { melax_full() } else { qem_full() };
        let (pm, _) = ProgressiveMesh::build(&g, &o).unwrap();
        let (repaired, _) = simplify(&g, &SimplifyOptions::default().with_ratio(1.0)).unwrap();
        prop_assert_eq!(canonical(&pm.mesh_at(pm.split_count())), canonical(&repaired));
        let d = ProgressiveMesh::from_bytes(&pm.to_bytes()).unwrap();
        prop_assert_eq!(d.pm, pm);
    }
}
