//! The cluster hierarchy: monotone errors and bounds, cuts of a closed surface that
//! are closed (no cracks: every edge used as often in each direction) for every
//! camera tried, each chosen cluster
//! within the pixel budget, fewer triangles farther away and fewer than a uniform
//! cut of the same error budget, and `.mdag` files that round-trip and refuse
//! truncation and corruption.

mod common;

use meshlod::lod::dag::{build_dag, read_mdag, write_mdag, Dag, DagOptions, DagView};
use meshlod::lod::Screen;
use meshlod::mesh::{generate, Mesh, Weld};
use std::collections::{HashMap, HashSet};

fn sphere_dag() -> (Mesh, Dag) {
    let mesh = generate::icosphere(6); // 81,920 triangles, closed
    let (dag, report) = build_dag(&mesh, &DagOptions::default()).expect("dag");
    assert_eq!(report.triangles, 81_920);
    assert!(report.roots <= 8, "{report:?}");
    assert!(report.depth >= 6, "{report:?}");
    (mesh, dag)
}

/// Edges of `m` not used equally often in both directions (open: a crack), and
/// edges used by more than two triangles (pinched).
fn edge_faults(m: &Mesh) -> (usize, usize) {
    let mut edges: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
    for t in &m.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let e = edges.entry((a.min(b), a.max(b))).or_default();
            if a < b {
                e.0 += 1;
            } else {
                e.1 += 1;
            }
        }
    }
    let open = edges.values().filter(|(f, r)| f != r).count();
    let pinched = edges.values().filter(|(f, r)| f + r > 2).count();
    (open, pinched)
}

fn view(position: [f64; 3]) -> DagView {
    DagView::new(position, Screen::default())
}

#[test]
fn errors_and_bounds_grow_up_the_hierarchy() {
    let (_, dag) = sphere_dag();
    for c in &dag.clusters {
        assert!(c.triangles.len() <= 128);
        assert!(c.parent_error >= c.error);
        if c.parent_error.is_finite() {
            let d: f64 = (0..3)
                .map(|k| (c.sphere.center[k] - c.parent_sphere.center[k]).powi(2))
                .sum::<f64>()
                .sqrt();
            assert!(d + c.sphere.radius <= c.parent_sphere.radius * (1.0 + 1e-12) + 1e-12);
        }
    }
}

#[test]
fn cuts_are_closed_within_budget_and_coarser_farther() {
    let (_, dag) = sphere_dag();
    for dir in [[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [0.577, 0.577, 0.577]] {
        let mut last = usize::MAX;
        for d in [1.05, 1.3, 2.0, 4.0, 10.0, 40.0, 200.0, 2000.0, 1e6] {
            let v = view(dir.map(|x| x * d));
            let cut = dag.cut(&v);
            let mesh = dag.cut_mesh(&cut);
            let (open, pinched) = edge_faults(&mesh);
            assert_eq!(open, 0, "at {d} along {dir:?}: open edges (cracks)");
            // Known limit: two groups may each cut the corner at a locked border
            // vertex, leaving a flat two-triangle fin whose edges are used four
            // times; rare, and never a hole.
            assert!(
                pinched <= 2.max(mesh.triangles.len() / 1000),
                "at {d} along {dir:?}: {pinched} pinched edges"
            );
            for &c in &cut {
                let c = &dag.clusters[c];
                let near: f64 = (0..3)
                    .map(|k| (c.sphere.center[k] - v.position[k]).powi(2))
                    .sum::<f64>()
                    .sqrt()
                    - c.sphere.radius;
                if c.error > 0.0 {
                    assert!(near > 0.0);
                    assert!(v.screen.pixels(c.error, near) <= v.screen.pixel_error);
                }
            }
            let n = mesh.triangles.len();
            assert!(n <= last, "at {d}: {n} triangles after {last}");
            assert!(n > 0);
            last = n;
        }
        assert!(last <= 128 * 8, "far away the roots: {last}");
    }
}

#[test]
fn a_near_camera_cut_is_smaller_than_a_uniform_one() {
    let (_, dag) = sphere_dag();
    // Camera close to one side: the far side needs little detail.
    let v = view([0.0, 0.0, 1.5]);
    let cut = dag.cut(&v);
    let vd: usize = cut.iter().map(|&c| dag.clusters[c].triangles.len()).sum();
    // A uniform LOD: one error threshold for the whole object (every cluster whose
    // error is at most it and whose parent's is above), the largest whose cut keeps
    // every cluster within the same pixel budget, measured the same way (error
    // over the distance from the camera to the cluster's sphere).
    let pixels = |c: &meshlod::lod::dag::Cluster| {
        let d: f64 = (0..3)
            .map(|k| (c.sphere.center[k] - v.position[k]).powi(2))
            .sum::<f64>()
            .sqrt()
            - c.sphere.radius;
        if c.error == 0.0 {
            0.0
        } else if d <= 0.0 {
            f64::INFINITY
        } else {
            v.screen.pixels(c.error, d)
        }
    };
    let mut thresholds: Vec<f64> = dag.clusters.iter().map(|c| c.error).collect();
    thresholds.sort_by(f64::total_cmp);
    thresholds.dedup();
    let uniform = thresholds
        .iter()
        .rev()
        .map(|&e| {
            let chosen: Vec<_> = dag
                .clusters
                .iter()
                .filter(|c| c.error <= e && c.parent_error > e)
                .collect();
            (
                chosen.iter().all(|c| pixels(c) <= v.screen.pixel_error),
                chosen,
            )
        })
        .find(|(ok, _)| *ok)
        .map(|(_, chosen)| chosen.iter().map(|c| c.triangles.len()).sum::<usize>())
        .expect("the finest cut is within any budget");
    assert!(vd < uniform, "view-dependent {vd} vs uniform {uniform}");
}

#[test]
fn a_view_direction_coarsens_what_is_out_of_view_and_keeps_the_cut_closed() {
    let (_, dag) = sphere_dag();
    let roots: usize = dag
        .clusters
        .iter()
        .filter(|c| c.parent_error.is_infinite())
        .map(|c| c.triangles.len())
        .sum();
    // Looking away from the sphere: nothing is in view, the cut is the roots.
    let away = DagView {
        target: Some([0.0, 0.0, 8.0]),
        ..view([0.0, 0.0, 4.0])
    };
    let cut = dag.cut(&away);
    assert!(cut
        .iter()
        .all(|&c| dag.clusters[c].parent_error.is_infinite()));
    assert_eq!(dag.cut_mesh(&cut).triangles.len(), roots);
    // Views of points of the sphere, near and far: closed, each cluster in view
    // within the budget, and no more triangles than the same screen with every
    // direction in view. Only groups wholly out of view can be coarsened (their
    // spheres enclose their clusters'), so the narrow view from 2 radii gains,
    // the others little or nothing. Culling (`visible`) keeps exactly the clusters whose
    // own triangles' spheres reach into the view.
    let mut checked = 0;
    for (camera, target, fov, fewer) in [
        ([0.0, 0.0, 1.3], [0.3, 0.0, 0.95], 40.0, false),
        ([0.0, 0.0, 1.3], [0.0, 0.0, 1.0], 60.0, false),
        ([1.2, 0.6, 0.0], [0.8, 0.6, 0.0], 90.0, false),
        ([0.0, 0.0, 3.0], [0.6, 0.0, 0.8], 20.0, false),
        ([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], 5.0, false),
        ([0.0, 0.0, 2.0], [0.0, 0.0, 0.0], 5.0, true),
        ([0.0, 0.0, 6.0], [0.0, 0.0, 0.0], 60.0, false),
    ] {
        let everywhere = DagView::new(
            camera,
            Screen {
                fov_degrees: fov,
                ..Screen::default()
            },
        );
        let v = DagView {
            target: Some(target),
            ..everywhere
        };
        let cut = dag.cut(&v);
        let mesh = dag.cut_mesh(&cut);
        let (open, _) = edge_faults(&mesh);
        assert_eq!(open, 0, "{camera:?} to {target:?}: open edges (cracks)");
        let axis: Vec<f64> = (0..3).map(|k| target[k] - camera[k]).collect();
        let n = axis.iter().map(|x| x * x).sum::<f64>().sqrt();
        let half_diagonal =
            ((fov.to_radians() / 2.0).tan() * (1.0 + (16.0f64 / 9.0).powi(2)).sqrt()).atan();
        for &c in &cut {
            let c = &dag.clusters[c];
            let rel: Vec<f64> = (0..3).map(|k| c.sphere.center[k] - camera[k]).collect();
            let along = (0..3).map(|k| rel[k] * axis[k] / n).sum::<f64>();
            let length = rel.iter().map(|x| x * x).sum::<f64>().sqrt();
            // In view: the angle to the axis less the sphere's angular radius within
            // the half-diagonal (tested with a margin, so the check does not hang on
            // the cone test's exact edge).
            let angle = (along / length).clamp(-1.0, 1.0).acos();
            let spread = (c.sphere.radius / length).min(1.0).asin();
            if angle - spread < half_diagonal * 0.99 && c.error > 0.0 {
                checked += 1;
                let near = length - c.sphere.radius;
                assert!(near > 0.0);
                assert!(v.screen.pixels(c.error, near) <= v.screen.pixel_error);
            }
        }
        let all: usize = dag
            .cut(&everywhere)
            .iter()
            .map(|&c| dag.clusters[c].triangles.len())
            .sum();
        let k = mesh.triangles.len();
        assert!(
            k <= all,
            "{camera:?}: {k} triangles, {all} with every direction"
        );
        let seen = dag.visible(&v, &cut);
        // The narrower views (40° or less) leave part of the sphere out.
        assert!(
            seen.len() < cut.len() || fov > 40.0,
            "{camera:?}: all {} clusters kept",
            cut.len()
        );
        for &c in &cut {
            let s = &dag.clusters[c].bounds(&dag.positions);
            let rel: Vec<f64> = (0..3).map(|k| s.center[k] - camera[k]).collect();
            let along = (0..3).map(|k| rel[k] * axis[k] / n).sum::<f64>();
            let length = rel.iter().map(|x| x * x).sum::<f64>().sqrt();
            let angle = (along / length).clamp(-1.0, 1.0).acos();
            let spread = (s.radius / length).min(1.0).asin();
            if angle - spread < half_diagonal * 0.99 {
                assert!(
                    seen.contains(&c),
                    "{camera:?}: cluster {c} in view was culled"
                );
            } else if angle - spread > half_diagonal * 1.01 {
                assert!(
                    !seen.contains(&c),
                    "{camera:?}: cluster {c} out of view kept"
                );
            }
        }
        if fewer {
            assert!(
                k < all,
                "{camera:?}: {k} triangles, {all} with every direction"
            );
        }
    }
    assert!(checked > 0, "some clusters in view with an error");
}

#[test]
fn mdag_files_round_trip_and_refuse_damage() {
    let mesh = generate::icosphere(3);
    let (dag, _) = build_dag(&mesh, &DagOptions::default()).expect("dag");
    let bytes = write_mdag(&dag);
    assert_eq!(read_mdag(&bytes).expect("reads back"), dag);
    for cut in [0, 5, 12, 20, 40, bytes.len() / 2, bytes.len() - 1] {
        let e = read_mdag(&bytes[..cut]).expect_err("truncated");
        assert!(e.offset as usize <= cut, "{e}");
    }
    let mut extra = bytes.clone();
    extra.push(0);
    assert!(read_mdag(&extra).is_err());
    let mut bad = bytes.clone();
    bad[0] = b'X';
    assert!(read_mdag(&bad).is_err());
    // An absurd position count is refused before anything is allocated.
    let mut huge = bytes.clone();
    huge[16..24].copy_from_slice(&u64::MAX.to_le_bytes());
    assert!(read_mdag(&huge).is_err());
    // An index out of range (the last triangle's last index).
    let mut oob = bytes;
    let n = oob.len();
    oob[n - 4..].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(read_mdag(&oob)
        .expect_err("out of range")
        .message
        .contains("out of range"));
}

#[test]
fn bad_dag_options_and_inputs() {
    let mesh = generate::icosphere(2);
    let o = DagOptions {
        cluster_size: 0,
        ..DagOptions::default()
    };
    assert!(build_dag(&mesh, &o).is_err());
    let (dag, report) = build_dag(&Mesh::default(), &DagOptions::default()).expect("empty");
    assert_eq!(report.clusters, 0);
    assert!(dag.cut(&view([0.0, 0.0, 5.0])).is_empty());
    let mut nan = mesh;
    nan.positions[0][1] = f32::NAN;
    assert!(build_dag(&nan, &DagOptions::default()).is_err());
}

#[test]
fn the_hierarchy_is_the_same_on_any_number_of_threads() {
    let mesh = generate::icosphere(5);
    let on = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool")
            .install(|| build_dag(&mesh, &DagOptions::default()).expect("dag").0)
    };
    assert_eq!(on(1), on(3));
}

/// `m` with its vertices welded by position (the topology of a seamed mesh).
fn welded(m: &Mesh) -> Mesh {
    let point_of = Weld::exact(&m.positions).point_of;
    Mesh::from_triangles(
        m.positions.clone(),
        m.triangles
            .iter()
            .map(|t| t.map(|v| point_of[v as usize]))
            .collect(),
    )
}

/// The textured cow (UV seams: vertices on either side of a seam share a
/// position), in two groups by triangle index, as a glTF asset with two materials.
fn spot_with_groups() -> Mesh {
    let mut mesh = meshlod::io::read_mesh(common::data_dir().join("spot.obj")).expect("spot");
    let n = mesh.triangles.len();
    mesh.groups = Some((0..n).map(|i| u32::from(i >= n / 2)).collect());
    mesh.group_names = vec!["hide".into(), "horns".into()];
    mesh
}

#[test]
fn attributes_and_groups_are_carried_and_seams_do_not_crack() {
    let mesh = spot_with_groups();
    assert!(mesh.attributes.uv0.is_some());
    let (open_in, _) = edge_faults(&welded(&mesh));
    assert_eq!(open_in, 0, "the cow is closed by positions");
    let (dag, report) = build_dag(&mesh, &DagOptions::default()).expect("dag");
    assert!(report.roots <= 2, "{report:?}");
    assert_eq!(
        dag.attributes.uv0.as_ref().map(Vec::len),
        Some(dag.positions.len())
    );
    assert_eq!(dag.group_names.as_deref().map(<[String]>::len), Some(2));
    let mut coarser = usize::MAX;
    for d in [0.5, 2.0, 8.0, 30.0, 1e4] {
        let cut = dag.cut(&view([0.0, 0.3, d]));
        let m = dag.cut_mesh(&cut);
        m.validate().expect("a valid mesh");
        let uv = m.attributes.uv0.as_ref().expect("UVs carried");
        assert_eq!(uv.len(), m.positions.len());
        assert!(uv.iter().flatten().all(|x| x.is_finite()));
        let groups = m.groups.as_ref().expect("groups carried");
        assert_eq!(groups.len(), m.triangles.len());
        assert!(groups.iter().all(|&g| g < 2));
        assert_eq!(m.group_names, ["hide", "horns"]);
        // Borders between groups of the hierarchy are locked by position, so the
        // vertices on either side of a UV seam stay together: no cracks.
        let (open, _) = edge_faults(&welded(&m));
        assert_eq!(open, 0, "at {d}: open edges (cracks)");
        assert!(m.triangles.len() <= coarser);
        coarser = m.triangles.len();
    }
    assert!(coarser < mesh.triangles.len() / 10, "far away: {coarser}");
}

#[test]
fn mdag_files_with_attributes_round_trip_and_refuse_damage() {
    let (dag, _) = build_dag(&spot_with_groups(), &DagOptions::default()).expect("dag");
    let bytes = write_mdag(&dag);
    assert_eq!(u32::from_le_bytes(bytes[12..16].try_into().expect("4")), 2);
    assert_eq!(read_mdag(&bytes).expect("reads back"), dag);
    for cut in [
        20,
        40,
        12 * dag.positions.len() + 40,
        bytes.len() / 2,
        bytes.len() - 1,
    ] {
        let e = read_mdag(&bytes[..cut]).expect_err("truncated");
        assert!(e.offset as usize <= cut, "{e}");
    }
    // The attribute mask right after the positions: an unknown bit.
    let mask_at = 32 + 12 * dag.positions.len();
    let mut bad = bytes.clone();
    bad[mask_at + 3] = 0x80;
    assert!(read_mdag(&bad)
        .expect_err("mask")
        .message
        .contains("unknown bits"));
    // The last triangle's group id out of range.
    let mut oob = bytes;
    let n = oob.len();
    oob[n - 4..].copy_from_slice(&7u32.to_le_bytes());
    assert!(read_mdag(&oob)
        .expect_err("group out of range")
        .message
        .contains("group id 7"));
    // A hierarchy without attributes or groups is still written as version 1.
    let (plain, _) = build_dag(&generate::icosphere(2), &DagOptions::default()).expect("dag");
    let b = write_mdag(&plain);
    assert_eq!(u32::from_le_bytes(b[12..16].try_into().expect("4")), 1);
}

#[test]
fn a_hierarchy_of_any_attribute_values_reads_back() {
    // A NaN texture coordinate is the input's own value: the file written from it
    // must read back (positions, not attributes, are what a cut relies on).
    let mut mesh = spot_with_groups();
    if let Some(uv) = mesh.attributes.uv0.as_mut() {
        uv[0] = [f32::NAN, 0.5];
    }
    let (dag, _) = build_dag(&mesh, &DagOptions::default()).expect("dag");
    let back = read_mdag(&write_mdag(&dag)).expect("reads back");
    assert_eq!(back.clusters, dag.clusters);
    assert_eq!(back.positions, dag.positions);
    let bits = |d: &Dag| -> Vec<[u32; 2]> {
        d.attributes
            .uv0
            .as_ref()
            .expect("UVs")
            .iter()
            .map(|t| t.map(f32::to_bits))
            .collect()
    };
    assert_eq!(bits(&back), bits(&dag));
    assert!(bits(&dag).contains(&[f32::NAN.to_bits(), 0.5f32.to_bits()]));
}

/// Points of a cut where clusters of different levels meet and a coarser
/// level's vertex carries a UV that no vertex of the finest level there has
/// anywhere in the hierarchy: a texture tear along a border between levels. (At
/// a UV seam the finer and the coarser side may each use one of its vertices.)
fn torn_level_borders(dag: &Dag, cut: &[usize]) -> usize {
    let uv = dag.attributes.uv0.as_ref().expect("UVs");
    let key = |v: u32| dag.positions[v as usize].map(f32::to_bits);
    // Per (position, level): the UVs of that level's vertices there, in all
    // clusters (the input's for level 0).
    let mut known: HashMap<([u32; 3], u32), HashSet<[u32; 2]>> = HashMap::new();
    for c in &dag.clusters {
        for &v in c.triangles.iter().flatten() {
            known
                .entry((key(v), c.level))
                .or_default()
                .insert(uv[v as usize].map(f32::to_bits));
        }
    }
    // Per position in the cut: per level, its vertices' UVs.
    let mut at: HashMap<[u32; 3], HashMap<u32, HashSet<[u32; 2]>>> = HashMap::new();
    for &c in cut {
        let level = dag.clusters[c].level;
        for &v in dag.clusters[c].triangles.iter().flatten() {
            at.entry(key(v))
                .or_default()
                .entry(level)
                .or_default()
                .insert(uv[v as usize].map(f32::to_bits));
        }
    }
    at.iter()
        .filter(|(p, levels)| {
            let finest = *levels.keys().min().expect("a level");
            let there = &known[&(**p, finest)];
            levels.len() > 1
                && levels
                    .iter()
                    .any(|(&l, set)| l != finest && !set.is_subset(there))
        })
        .count()
}

#[test]
fn cuts_across_levels_keep_the_texture_continuous() {
    // Where a finer cluster meets a coarser one, their shared border points were
    // locked when the coarser was made: they kept their positions and their UVs,
    // so the texture does not tear along the border. Known limit: a few points
    // (at most 5 in a cut here, where UV seams cross group borders) still get a
    // new UV; before locked points kept their attributes it was 22–27.
    let mesh = spot_with_groups();
    let (dag, _) = build_dag(&mesh, &DagOptions::default()).expect("dag");
    let mut mixed = 0;
    for (d, dir) in [1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 20.0]
        .into_iter()
        .flat_map(|d| [[0.0, 0.3, 1.0], [1.0, 0.2, 0.0], [0.0, -0.5, -1.0]].map(|x| (d, x)))
    {
        for pixels in [1.0, 4.0, 16.0] {
            let mut v = view(dir.map(|x| x * d));
            v.screen.pixel_error = pixels;
            let cut = dag.cut(&v);
            let levels: HashSet<u32> = cut.iter().map(|&c| dag.clusters[c].level).collect();
            let torn = torn_level_borders(&dag, &cut);
            assert!(
                torn <= 8,
                "at {d} along {dir:?}, {pixels} px: levels {levels:?}: {torn} torn points"
            );
            if levels.len() > 1 {
                mixed += 1;
            }
        }
    }
    assert!(mixed >= 3, "cuts mixing levels: {mixed}");
}

#[test]
fn a_version_1_file_still_reads() {
    // `tests/data/icosphere3.mdag`: the geometry-only format (version 1), the
    // hierarchy of the 1,280-triangle icosphere. It reads, writes back byte for
    // byte, and its cuts are closed.
    let path = common::data_dir().join("icosphere3.mdag");
    let bytes = std::fs::read(&path).expect("the version-1 fixture");
    assert_eq!(u32::from_le_bytes(bytes[12..16].try_into().expect("4")), 1);
    let dag = read_mdag(&bytes).expect("reads");
    assert!(dag.clusters.len() > 10 && dag.attributes.is_empty());
    assert_eq!(write_mdag(&dag), bytes);
    for d in [1.2, 3.0, 100.0] {
        let (open, _) = edge_faults(&dag.cut_mesh(&dag.cut(&view([0.0, 0.0, d]))));
        assert_eq!(open, 0);
    }
}
