//! Tests of vertex clustering: in memory and streamed, the count search, the
//! representatives, the clean-up and the coverage repair.

use super::*;
use crate::io::{write_mesh, WriteOptions};
use crate::mesh::generate;
use crate::mesh::stats::TopologyStats;
use proptest::prelude::*;

/// The acceptance invariants: indices valid, no degenerate (repeated point or zero
/// area) and no duplicate triangles (over exactly welded positions).
fn assert_clean(m: &Mesh) {
    m.validate().expect("valid output");
    let weld = Weld::exact(&m.positions);
    let welded = weld.map_triangles(&m.triangles);
    let s = TopologyStats::of(&welded, weld.point_count(), |p| {
        m.positions[weld.representative[p as usize] as usize]
    });
    assert_eq!(s.degenerate_triangles, 0, "degenerate triangles");
    assert_eq!(s.duplicate_triangles, 0, "duplicate triangles");
    if let Some(g) = &m.groups {
        assert_eq!(g.len(), m.triangles.len());
    }
}

fn cluster(m: &Mesh, target: usize) -> Clustered {
    cluster_mesh(m, Some(target), &ClusterOptions::default()).expect("clusters")
}

#[test]
fn target_counts_within_five_percent() {
    let sphere = generate::icosphere(5); // 20480 triangles
    let torus = generate::torus(160, 64, 1.0, 0.3);
    for m in [&sphere, &torus] {
        for target in [200, 1000, 2000, 5000] {
            for how in [
                Representative::Quadric,
                Representative::Average,
                Representative::Weighted,
            ] {
                let o = ClusterOptions::default().with_representative(how);
                let c = cluster_mesh(m, Some(target), &o).unwrap();
                assert_clean(&c.mesh);
                let n = c.mesh.triangles.len() as f64;
                assert!(
                    (n - target as f64).abs() <= 0.05 * target as f64,
                    "{how:?}: {n} for target {target}"
                );
                assert!(c.stats.builds <= 3 && c.stats.search_passes > 0);
            }
        }
    }
}

/// Every representative lies in its cell, so no vertex is farther than the cell
/// diagonal from the vertices it replaces: the one-sided distance output → input is
/// below `ε√3` plus the distance of a vertex to the surface (0 here: representatives
/// are checked against the input's vertices of their cells via `vertex_source`).
#[test]
fn representatives_stay_in_their_cells() {
    let m = generate::torus(80, 40, 1.0, 0.3);
    for how in [
        Representative::Quadric,
        Representative::Average,
        Representative::Weighted,
    ] {
        let o = ClusterOptions::default()
            .with_cell_size(Distance::Relative(0.03))
            .with_representative(how)
            .with_vertex_sources(true);
        let c = cluster_mesh(&m, None, &o).unwrap();
        assert_clean(&c.mesh);
        assert_eq!(c.vertex_source.len(), c.mesh.positions.len());
        let e = c.stats.cell_size;
        let (lo, _) = m.bounding_box(false).unwrap();
        for (o, &src) in c.vertex_source.iter().enumerate() {
            let p = c.mesh.positions[o];
            let q = m.positions[src as usize];
            for k in 0..3 {
                // Same cell: the same floor((x − lo)/ε), up to f32 rounding.
                let cp = ((f64::from(p[k]) - f64::from(lo[k])) / e).floor();
                let cq = ((f64::from(q[k]) - f64::from(lo[k])) / e).floor();
                assert!((cp - cq).abs() <= 1.0, "{how:?} vertex {o}");
                assert!(
                    (f64::from(p[k]) - f64::from(q[k])).abs() <= e * (1.0 + 1e-6),
                    "{how:?} vertex {o}"
                );
            }
        }
    }
}

/// A flat 20×20 grid (800 triangles) in z = 0.25: quadric representatives stay on
/// the plane, so every output vertex has z = 0.25 exactly (to f32).
#[test]
fn flat_surfaces_stay_flat() {
    let m = generate::grid(20, 20, |_, _| 0.25);
    let c = cluster(&m, 100);
    assert_clean(&c.mesh);
    assert!(c.mesh.positions.iter().all(|p| (p[2] - 0.25).abs() < 1e-6));
    assert!(c.stats.max_error < 1e-6);
}

/// Two triangles of a unit square split by its diagonal:
/// ```text
///  3 ─── 2
///  │   ╱ │     cell side 2: one cell, both triangles collapse to a point;
///  │ ╱   │     cell side 0.6: corners in four cells, nothing merges.
///  0 ─── 1
/// ```
#[test]
fn unit_square_collapses_or_survives() {
    let m = Mesh::from_triangles(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    );
    let o = ClusterOptions::default().with_cell_size(Distance::Absolute(2.0));
    let c = cluster_mesh(&m, None, &o).unwrap();
    assert!(c.mesh.triangles.is_empty());
    assert_eq!(c.stats.collapsed_triangles, 2);
    let o = ClusterOptions::default().with_cell_size(Distance::Absolute(0.6));
    let c = cluster_mesh(&m, None, &o).unwrap();
    assert_eq!(c.mesh.triangles.len(), 2);
    assert_eq!(
        c.mesh.positions,
        vec![
            m.positions[0],
            m.positions[1],
            m.positions[2],
            m.positions[3]
        ]
    );
}

/// A fin: two triangles over the same three cells (one of each winding) keep one.
#[test]
fn duplicate_cell_triples_are_removed() {
    let m = Mesh::from_triangles(
        vec![
            [0.0, 0.0, 0.0],
            [4.0, 0.0, 0.0],
            [0.0, 4.0, 0.0],
            [0.1, 0.1, 0.0],
            [4.1, 0.1, 0.0],
            [0.1, 4.1, 0.0],
        ],
        vec![[0, 1, 2], [3, 5, 4]],
    );
    let o = ClusterOptions::default().with_cell_size(Distance::Absolute(1.0));
    let c = cluster_mesh(&m, None, &o).unwrap();
    assert_eq!(c.mesh.triangles.len(), 1);
    assert_eq!(c.stats.duplicate_triangles, 1);
    assert_clean(&c.mesh);
}

#[test]
fn groups_and_attributes_are_carried() {
    let mut m = generate::icosphere(4);
    let n = m.triangles.len() as u32;
    m.groups = Some((0..n).map(|t| u32::from(t >= n / 2)).collect());
    m.group_names = vec!["red".into(), "blue".into()];
    m.attributes.uv0 = Some(m.positions.iter().map(|p| [p[0], p[1]]).collect());
    let c = cluster(&m, 500);
    assert_clean(&c.mesh);
    assert_eq!(c.mesh.group_names, m.group_names);
    let g = c.mesh.groups.as_ref().unwrap();
    assert!(g.contains(&0) && g.contains(&1));
    let uv = c.mesh.attributes.uv0.as_ref().unwrap();
    // An input with attributes always gets its sources.
    assert_eq!(c.vertex_source.len(), c.mesh.positions.len());
    for (o, &src) in c.vertex_source.iter().enumerate() {
        assert_eq!(uv[o], m.attributes.uv0.as_ref().unwrap()[src as usize]);
    }
}

#[test]
fn weights_options_are_checked() {
    let m = generate::icosphere(2);
    let bad = ClusterOptions::default()
        .with_representative(Representative::Weighted)
        .with_weights(ClusterWeights::PerVertex(vec![1.0; 3]));
    assert!(matches!(
        cluster_mesh(&m, Some(10), &bad),
        Err(ClusterError::Option(_))
    ));
    let nan = ClusterOptions::default()
        .with_representative(Representative::Weighted)
        .with_weights(ClusterWeights::PerVertex(vec![f32::NAN; m.positions.len()]));
    assert!(cluster_mesh(&m, Some(10), &nan).is_err());
    let zero = ClusterOptions::default().with_cell_size(Distance::Relative(0.0));
    assert!(cluster_mesh(&m, Some(10), &zero).is_err());
    // Feature and per-vertex weights both work in memory and move representatives.
    let feature = ClusterOptions::default()
        .with_representative(Representative::Weighted)
        .with_weights(ClusterWeights::Feature);
    let cube_like = generate::cylinder(32, 8, 1.0, true);
    let c = cluster_mesh(&cube_like, Some(100), &feature).unwrap();
    assert_clean(&c.mesh);
    let heavy: Vec<f32> = (0..m.positions.len()).map(|i| (i % 7) as f32).collect();
    let o = ClusterOptions::default()
        .with_representative(Representative::Weighted)
        .with_weights(ClusterWeights::PerVertex(heavy));
    let a = cluster_mesh(&m, Some(80), &o).unwrap();
    let b = cluster_mesh(
        &m,
        Some(80),
        &ClusterOptions::default().with_representative(Representative::Weighted),
    )
    .unwrap();
    assert_ne!(a.mesh.positions, b.mesh.positions);
}

#[test]
fn empty_and_degenerate_inputs() {
    let empty = Mesh::default();
    let c = cluster(&empty, 10);
    assert!(c.mesh.triangles.is_empty());
    // All vertices at one point: one cell, every triangle collapses.
    let point = Mesh::from_triangles(vec![[1.0; 3]; 3], vec![[0, 1, 2], [0, 1, 2]]);
    let c = cluster(&point, 1);
    assert!(c.mesh.triangles.is_empty());
    // Unreferenced vertices only.
    let loose = Mesh::from_triangles(vec![[0.0; 3], [1.0; 3]], vec![]);
    assert!(cluster(&loose, 5).mesh.triangles.is_empty());
}

/// The same result with 1 and 3 worker threads (accumulation order is per cell).
#[test]
fn thread_count_does_not_change_the_result() {
    let m = generate::torus(120, 50, 1.0, 0.35);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| cluster(&m, 1500))
    };
    let a = run(1);
    let b = run(3);
    assert_eq!(a.mesh, b.mesh);
    assert_eq!(a.stats.max_error.to_bits(), b.stats.max_error.to_bits());
}

/// Above the parallel threshold (2¹⁸ triangles) the workers that visit only the
/// blocks touching their cells give the sequential result, vertex sources included
/// (with unreferenced vertices, which must not become sources).
#[test]
fn parallel_accumulation_matches_sequential_on_large_input() {
    let mut m = generate::torus(600, 230, 1.0, 0.35);
    assert!(m.triangles.len() >= super::PAR_ACCUMULATE);
    let referenced = m.positions.len();
    // Unreferenced vertices at the positions of used ones: never a source.
    let extra: Vec<[f32; 3]> = m.positions.iter().step_by(997).copied().collect();
    m.positions.extend(extra);
    let o = ClusterOptions::default().with_vertex_sources(true);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| cluster_mesh(&m, Some(20_000), &o).unwrap())
    };
    let a = run(1);
    let b = run(2);
    let c = run(3);
    assert!(!a.mesh.triangles.is_empty());
    for other in [&b, &c] {
        assert_eq!(a.mesh, other.mesh);
        assert_eq!(a.vertex_source, other.vertex_source);
        assert_eq!(a.stats, other.stats);
    }
    assert_eq!(a.vertex_source.len(), a.mesh.positions.len());
    assert!(a.vertex_source.iter().all(|&v| (v as usize) < referenced));
}

/// Without attributes the sources are only found on request, and asking changes
/// nothing else: the same mesh and statistics, one in-cell source per vertex.
#[test]
fn vertex_sources_only_on_request_without_attributes() {
    let m = generate::torus(120, 48, 1.0, 0.3);
    assert!(m.attributes.is_empty());
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let run = |o: ClusterOptions| pool.install(|| cluster_mesh(&m, Some(1000), &o).unwrap());
        let plain = run(ClusterOptions::default());
        let asked = run(ClusterOptions::default().with_vertex_sources(true));
        assert!(plain.vertex_source.is_empty());
        assert_eq!(asked.vertex_source.len(), asked.mesh.positions.len());
        assert!(asked
            .vertex_source
            .iter()
            .all(|&v| (v as usize) < m.positions.len()));
        assert_eq!(plain.mesh, asked.mesh);
        assert_eq!(plain.stats, asked.stats);
    }
}

/// The streaming path on a file gives the mesh the in-memory path gives on the same
/// file read into memory: binary and ASCII STL, binary PLY, OBJ; with a cell size
/// and with a target count (the file is small, so the search sample is every
/// triangle and the searches agree too).
#[test]
fn streaming_equals_in_memory() {
    let dir = tempfile::tempdir().unwrap();
    let mut m = generate::torus(90, 40, 1.0, 0.3);
    let n = m.triangles.len() as u32;
    m.groups = Some((0..n).map(|t| (t / 500) % 3).collect());
    m.group_names = vec!["a".into(), "b".into(), "c".into()];
    for (name, ascii) in [
        ("m.ply", false),
        ("m.stl", false),
        ("m.stl", true),
        ("m.obj", false),
    ] {
        let path = dir.path().join(name);
        write_mesh(&path, &m, &WriteOptions::default().with_ascii(ascii)).unwrap();
        let read = crate::read_mesh(&path).unwrap();
        for how in [Representative::Quadric, Representative::Average] {
            for cell in [Some(Distance::Relative(0.02)), None] {
                let mut o = ClusterOptions::default().with_representative(how);
                o.cell_size = cell;
                let mem = cluster_mesh(&read, Some(700), &o).unwrap();
                let st = cluster_file(&path, |_| Some(700), &o).unwrap();
                let ctx = format!("{name} ascii={ascii} {how:?} {cell:?}");
                assert_eq!(mem.mesh.positions, st.mesh.positions, "{ctx}");
                assert_eq!(mem.mesh.triangles, st.mesh.triangles, "{ctx}");
                assert_eq!(mem.mesh.groups, st.mesh.groups, "{ctx}");
                assert_eq!(mem.stats.cell_size, st.stats.cell_size, "{ctx}");
                assert!(st.stats.streamed);
                assert_clean(&st.mesh);
            }
        }
    }
}

#[test]
fn streaming_refuses_in_memory_weights() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.stl");
    write_mesh(&path, &generate::icosphere(2), &WriteOptions::default()).unwrap();
    let o = ClusterOptions::default()
        .with_representative(Representative::Weighted)
        .with_weights(ClusterWeights::Feature);
    assert!(matches!(
        cluster_file(&path, |_| Some(10), &o),
        Err(ClusterError::Option(_))
    ));
    let missing = dir.path().join("none.stl");
    let e = cluster_file(&missing, |_| Some(10), &ClusterOptions::default()).unwrap_err();
    assert!(e.to_string().contains("none.stl"));
}

/// The manifold counts `ClusterStats` reports.
fn counts_of(c: &Clustered) -> (usize, usize, usize) {
    let s = &c.stats;
    (
        s.non_manifold_edges,
        s.non_manifold_vertices,
        s.boundary_edges,
    )
}

/// The same counts by `TopologyStats` (output vertices are distinct positions).
fn topology_counts(m: &Mesh) -> (usize, usize, usize) {
    let s = TopologyStats::of(&m.triangles, m.positions.len(), |v| m.positions[v as usize]);
    (
        s.non_manifold_edges,
        s.non_manifold_vertices,
        s.boundary_edges,
    )
}

/// The sort-based manifold counts of the output agree with `TopologyStats`, on
/// hand-made cases and on clustered meshes that do collapse to non-manifold sheets.
#[test]
fn manifold_counts_agree_with_topology_stats() {
    // A bow-tie (two fans at 0), a fin (three triangles on 0–1) and a closed
    // tetrahedron.
    let cases: [(&[[u32; 3]], usize, EdgeCounts); 5] = [
        (
            &[[0, 1, 2], [0, 3, 4]],
            5,
            EdgeCounts {
                non_manifold_edges: 0,
                non_manifold_vertices: 1,
                boundary_edges: 6,
            },
        ),
        (
            &[[0, 1, 2], [1, 0, 3], [0, 1, 4]],
            5,
            EdgeCounts {
                non_manifold_edges: 1,
                non_manifold_vertices: 2,
                boundary_edges: 6,
            },
        ),
        (
            &[[0, 1, 2], [0, 3, 1], [1, 3, 2], [0, 2, 3]],
            4,
            EdgeCounts {
                non_manifold_edges: 0,
                non_manifold_vertices: 0,
                boundary_edges: 0,
            },
        ),
        // Two closed tetrahedra sharing vertex 0 (two closed fans there, found only
        // by walking them), the second one wound the other way round.
        (
            &[
                [0, 1, 2],
                [0, 3, 1],
                [1, 3, 2],
                [0, 2, 3],
                [0, 5, 4],
                [0, 4, 6],
                [4, 5, 6],
                [0, 6, 5],
            ],
            7,
            EdgeCounts {
                non_manifold_edges: 0,
                non_manifold_vertices: 1,
                boundary_edges: 0,
            },
        ),
        // A closed fan and an open one at vertex 0 (a tetrahedron and a triangle on
        // it), and a strip whose middle triangle is wound against its neighbours.
        (
            &[
                [0, 1, 2],
                [0, 3, 1],
                [1, 3, 2],
                [0, 2, 3],
                [0, 4, 5],
                [6, 7, 8],
                [7, 8, 9],
                [9, 8, 10],
            ],
            11,
            EdgeCounts {
                non_manifold_edges: 0,
                non_manifold_vertices: 1,
                boundary_edges: 8,
            },
        ),
    ];
    for (tris, n, want) in cases {
        assert_eq!(edge_counts(tris, n), want, "{tris:?}");
    }
    let thin = generate::torus(120, 24, 1.0, 0.04);
    let mut non_manifold_seen = 0;
    for m in [
        generate::torus(60, 24, 1.0, 0.3),
        generate::icosphere(4),
        thin,
    ] {
        for cell in [0.01, 0.03, 0.06, 0.12, 0.25] {
            let o = ClusterOptions::default().with_cell_size(Distance::Relative(cell));
            let c = cluster_mesh(&m, None, &o).unwrap();
            assert_eq!(counts_of(&c), topology_counts(&c.mesh), "cell {cell}");
            non_manifold_seen += c.stats.non_manifold_vertices;
        }
    }
    assert!(
        non_manifold_seen > 0,
        "no case exercised the non-manifold counts"
    );
}

fn arb_mesh() -> impl Strategy<Value = Mesh> {
    (4usize..40).prop_flat_map(|nv| {
        (
            prop::collection::vec(prop::array::uniform3(-10.0f32..10.0), nv),
            prop::collection::vec(prop::array::uniform3(0..nv as u32), 1..120),
        )
            .prop_map(|(p, t)| Mesh::from_triangles(p, t))
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// The manifold counts of random triangle sets over few points (pinched fans,
    /// fins, mixed windings; three distinct points each, no two over the same
    /// points, as in an output) agree with `TopologyStats`.
    #[test]
    fn edge_counts_agree_on_random_sets(
        raw in proptest::collection::vec((0u32..9, 0u32..9, 0u32..9), 0..40),
    ) {
        let mut tris: Vec<[u32; 3]> = Vec::new();
        let mut sets = std::collections::HashSet::new();
        for (a, b, c) in raw {
            let mut s = [a, b, c];
            s.sort_unstable();
            if a != b && b != c && a != c && sets.insert(s) {
                tris.push([a, b, c]);
            }
        }
        let s = TopologyStats::of(&tris, 9, |v| [v as f32, 0.0, 0.0]);
        let want = EdgeCounts {
            non_manifold_edges: s.non_manifold_edges,
            non_manifold_vertices: s.non_manifold_vertices,
            boundary_edges: s.boundary_edges,
        };
        prop_assert_eq!(edge_counts(&tris, 9), want);
    }

    /// Random soups (repeated indices, duplicates, non-manifold): the output is
    /// always clean, and the search never needs more than three builds.
    #[test]
    fn random_meshes_give_clean_output(m in arb_mesh(), cell in 0.05f64..2.0, target in 0usize..100) {
        let o = ClusterOptions::default().with_cell_size(Distance::Absolute(cell));
        let c = cluster_mesh(&m, None, &o).unwrap();
        assert_clean(&c.mesh);
        prop_assert!(c.mesh.triangles.len() <= m.triangles.len());
        prop_assert_eq!(counts_of(&c), topology_counts(&c.mesh));
        for how in [Representative::Quadric, Representative::Average] {
            let o = ClusterOptions::default().with_representative(how);
            let c = cluster_mesh(&m, Some(target), &o).unwrap();
            assert_clean(&c.mesh);
            prop_assert!(c.stats.builds <= 3);
        }
    }
}

/// Merging the stats of two parts sums their counts, keeps the larger error and the
/// first part's settings.
#[test]
fn stats_merge_sums_counts() {
    let a = cluster(&generate::torus(64, 32, 1.0, 0.3), 200).stats;
    let b = cluster(&generate::icosphere(3), 100).stats;
    let mut m = a.clone();
    m.merge(&b);
    assert_eq!(m.occupied_cells, a.occupied_cells + b.occupied_cells);
    assert_eq!(
        m.collapsed_triangles,
        a.collapsed_triangles + b.collapsed_triangles
    );
    assert_eq!(m.boundary_edges, a.boundary_edges + b.boundary_edges);
    assert_eq!(m.working_bytes, a.working_bytes + b.working_bytes);
    assert_eq!(m.max_error, a.max_error.max(b.max_error));
    assert_eq!((m.grid, m.cell_size), (a.grid, a.cell_size));
}

/// The count model follows the grid's cells: an axis of `t` cells has `t + ½` on
/// average where the grid starts at the box (below 8 cells), and jumps by a whole
/// cell where a centred axis passes from `n + 1` to `n + 2` cells.
#[test]
fn cover_factor_follows_the_cells_per_axis() {
    let (lo, hi) = ([0.0; 3], [10.0, 0.0, 0.0]);
    let at = |t: f64| Grid::cover_factor(lo, hi, 10.0 / t);
    // Uncentred (t < 8): ⌈t⌉ / (t + ½) averages about 1 over a cell.
    let mean = (0..100)
        .map(|i| at(3.0 + (i as f64 + 0.5) / 100.0))
        .sum::<f64>()
        / 100.0;
    assert!((mean - 1.0).abs() < 0.01, "{mean}");
    // Centred: 11 cells at t = 10.4, 12 at t = 10.6.
    assert_eq!(Grid::new(lo, hi, 10.0 / 10.4).dims[0], 11);
    assert_eq!(Grid::new(lo, hi, 10.0 / 10.6).dims[0], 12);
    assert!(at(10.6) > 1.04 * at(10.4), "{} {}", at(10.4), at(10.6));
    // Axes under one cell do not count.
    assert_eq!(Grid::cover_factor(lo, [0.5, 0.0, 0.0], 1.0), 1.0);
}

/// A flat plate `[0, 1]²` with a needle (an open tube of radius 0.004 and height 1)
/// standing at its centre, and, with `piece`, a separate thin rod lying beside it;
/// on cells of side 0.05 (centred: cell centres near the needle's axis and on its rings)
/// every needle and rod triangle falls on one or two cells and collapses.
fn plate_with_needle(piece: bool) -> Mesh {
    let plate = generate::grid(20, 20, |_, _| 0.0);
    let mut positions = plate.positions.clone();
    let mut triangles = plate.triangles.clone();
    let tube = generate::cylinder(6, 20, 1.0, false);
    let mut add = |m: &Mesh, place: &dyn Fn([f32; 3]) -> [f32; 3]| {
        let base = positions.len() as u32;
        positions.extend(m.positions.iter().map(|&p| place(p)));
        triangles.extend(m.triangles.iter().map(|t| t.map(|v| v + base)));
    };
    // Slightly bent (a straight needle's representatives would be exactly
    // collinear, and a triangle over them flat), within its column of cells.
    add(&tube, &|p| {
        [
            0.5 + 0.004 * p[0] + 0.01 * p[2] * p[2],
            0.5 + 0.004 * p[1],
            p[2],
        ]
    });
    if piece {
        // A rod along x at height 0.6, half a unit long, away from the needle.
        let rod = generate::cylinder(6, 10, 0.5, false);
        add(&rod, &|p| {
            [
                0.1 + p[2],
                0.2 + 0.004 * p[0] + 0.02 * p[2] * p[2],
                0.6 + 0.004 * p[1],
            ]
        });
    }
    Mesh::from_triangles(positions, triangles)
}

/// The coverage repair keeps something of a thin part whose triangles all
/// collapsed: the needle's tip and the separate rod are within two cells of the
/// output, and a mesh without thin parts gets no repair triangles.
#[test]
fn coverage_repair_keeps_thin_parts() {
    let e = 0.05;
    let o = ClusterOptions::default().with_cell_size(Distance::Absolute(e));
    let plain = cluster_mesh(&generate::grid(20, 20, |_, _| 0.0), None, &o).unwrap();
    assert_eq!(plain.stats.coverage_triangles, 0);
    let torus = cluster_mesh(
        &generate::torus(90, 40, 1.0, 0.3),
        Some(700),
        &ClusterOptions::default(),
    )
    .unwrap();
    assert_eq!(torus.stats.coverage_triangles, 0);
    for piece in [false, true] {
        let m = plate_with_needle(piece);
        let c = cluster_mesh(&m, None, &o).unwrap();
        assert_clean(&c.mesh);
        assert!(c.stats.coverage_triangles > 0, "piece={piece}");
        // Every input vertex is within two cells of some output vertex.
        let near = |p: [f32; 3]| {
            c.mesh.positions.iter().any(|q| {
                let d2: f64 = (0..3)
                    .map(|k| (f64::from(p[k]) - f64::from(q[k])).powi(2))
                    .sum();
                d2.sqrt() <= 2.0 * e
            })
        };
        for (v, &p) in m.positions.iter().enumerate() {
            assert!(
                near(p),
                "piece={piece}: vertex {v} at {p:?} is far from the output"
            );
        }
        // Without the repair (the triangles over the plate's cells only) the
        // needle's tip would be a whole unit away: the repair's triangles reach it.
        let top = c
            .mesh
            .positions
            .iter()
            .map(|p| p[2])
            .fold(f32::MIN, f32::max);
        assert!(
            top > 0.9,
            "piece={piece}: highest output vertex at z = {top}"
        );
    }
}

/// The streaming path adds the same repair triangles (cells are numbered differently
/// there, the repair orders by cell key).
#[test]
fn coverage_repair_streams_alike() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("needle.stl");
    let m = plate_with_needle(true);
    write_mesh(&path, &m, &WriteOptions::default()).unwrap();
    let read = crate::read_mesh(&path).unwrap();
    let o = ClusterOptions::default().with_cell_size(Distance::Absolute(0.05));
    let mem = cluster_mesh(&read, None, &o).unwrap();
    let st = cluster_file(&path, |_| None, &o).unwrap();
    assert!(mem.stats.coverage_triangles > 0);
    assert_eq!(mem.stats.coverage_triangles, st.stats.coverage_triangles);
    assert_eq!(mem.mesh.positions, st.mesh.positions);
    assert_eq!(mem.mesh.triangles, st.mesh.triangles);
}

/// A random soup (13 triangles with repeated corners over 18 points, found by
/// `random_meshes_give_clean_output`): at 29 triangles with quadric
/// representatives, the coverage repair once wrote the same three cells twice,
/// in opposite orders. Every run on it is clean.
#[test]
fn coverage_repair_never_repeats_a_triangle() {
    let positions: Vec<[f32; 3]> = vec![
        [1.933_300_6, 4.489_176_8, 0.0],
        [0.0, 0.0, 9.790_009_5],
        [0.0, 4.497_631, -3.431_458_7],
        [1.033_026_8, 2.671_430_6, -4.778_195_4],
        [-2.030_208, -4.102_251, 0.0],
        [2.043_367_9, -8.195_693, 0.0],
        [9.869_063, 0.0, 0.0],
        [4.733_597, 0.0, -9.295_336],
        [0.0, -4.086_556, -6.830_721],
        [0.0, -7.165_023_3, -5.517_174_7],
        [0.0, 0.0, 6.903_789],
        [0.0, 0.0, 6.994_321],
        [3.799_055, 0.0, 0.0],
        [-8.012_332, 1.447_200_9, -2.094_660_5],
        [-5.467_685, 0.0, -2.518_782_4],
        [4.962_386, 0.0, 0.0],
        [-6.344_104_3, -0.487_978_67, -2.984_471_8],
        [5.705_677_5, 1.405_409_9, -8.636_794],
    ];
    let triangles = vec![
        [17, 1, 13],
        [8, 8, 0],
        [15, 9, 12],
        [6, 5, 7],
        [5, 7, 8],
        [10, 9, 13],
        [0, 3, 3],
        [5, 14, 13],
        [10, 5, 6],
        [2, 0, 2],
        [10, 4, 6],
        [13, 4, 6],
        [6, 4, 9],
    ];
    let m = Mesh {
        positions,
        triangles,
        ..Mesh::default()
    };
    let o = ClusterOptions::default().with_cell_size(Distance::Absolute(0.357_604_084_808_375_74));
    assert_clean(&cluster_mesh(&m, None, &o).unwrap().mesh);
    for how in [Representative::Quadric, Representative::Average] {
        let o = ClusterOptions::default().with_representative(how);
        let c = cluster_mesh(&m, Some(29), &o).unwrap();
        assert_clean(&c.mesh);
    }
}
