//! Attribute-aware QEM and moving seams: a planar mesh cut into three UV charts
//! whose seams meet in junctions keeps every chart's UVs exactly linear after
//! simplifying (the merged vertices' attributes are the quadric's optimum, exact for
//! a linear field) and reaches its target (the junctions slide along their seams);
//! the glTF sample assets reach `--ratio 0.1` part by part; random height fields
//! with seams give valid indices and no triangle turned over.

mod common;

use meshlod::io::read_scene;
use meshlod::mesh::Mesh;
use meshlod::metrics::{hausdorff, SamplingOptions};
use meshlod::simplify::{simplify, AttributeWeights, SimplifyOptions, StopReason};
use proptest::prelude::*;

/// The UV map of chart `c` at `(x, y)`: three different linear maps.
fn chart_uv(c: usize, x: f64, y: f64) -> [f64; 2] {
    match c {
        0 => [x, y],
        1 => [0.5 * x + 3.0, y + 1.0],
        _ => [x - y + 6.0, 2.0 * y],
    }
}

/// Which chart a UV value belongs to (the maps' ranges do not overlap).
fn chart_of(uv: [f32; 2]) -> usize {
    if uv[0] < 2.0 {
        0
    } else if uv[0] < 4.5 {
        1
    } else {
        2
    }
}

/// An `n × n`-cell grid over the unit square at height `z(x, y)`, cut into three
/// charts by the triangle's centroid (one wedge per grid point and chart):
///
/// ```text
///  y=1 +-----------------+
///      |     chart 2     |
///  y=½ +--------+--------+   seams: y = ½ (whole width) and x = ½ (below it);
///      | chart 0| chart 1|   junctions: (½, ½) with three seam edges, and
///  y=0 +--------+--------+   (0, ½), (1, ½), (½, 0) where a seam meets the border
///     x=0      x=½      x=1
/// ```
fn charted_grid(n: usize, z: impl Fn(f64, f64) -> f64) -> Mesh {
    let idx = |i: usize, j: usize| j * (n + 1) + i;
    let mut positions = Vec::new();
    let mut uv = Vec::new();
    let mut normals = Vec::new();
    // vertex id per (grid point, chart)
    let mut id = vec![[u32::MAX; 3]; (n + 1) * (n + 1)];
    let mut vertex = |g: usize, c: usize, positions: &mut Vec<[f32; 3]>| {
        if id[g][c] == u32::MAX {
            let (i, j) = (g % (n + 1), g / (n + 1));
            let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
            id[g][c] = positions.len() as u32;
            positions.push([x as f32, y as f32, z(x, y) as f32]);
            let t = chart_uv(c, x, y);
            uv.push([t[0] as f32, t[1] as f32]);
            normals.push([0.0, 0.0, 1.0]);
        }
        id[g][c]
    };
    let mut triangles = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let (cx, cy) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
            let c = if cy >= 0.5 {
                2
            } else if cx >= 0.5 {
                1
            } else {
                0
            };
            let q = [idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)];
            let v = q.map(|g| vertex(g, c, &mut positions));
            triangles.push([v[0], v[1], v[2]]);
            triangles.push([v[0], v[2], v[3]]);
        }
    }
    let mut m = Mesh::from_triangles(positions, triangles);
    m.attributes.uv0 = Some(uv);
    m.attributes.normals = Some(normals);
    m
}

/// The largest distance of an output UV from its chart's linear map at the
/// vertex's position.
fn uv_off_linear(out: &Mesh) -> f64 {
    let uv = out.attributes.uv0.as_ref().expect("uv kept");
    let mut worst = 0.0f64;
    for (v, p) in out.positions.iter().enumerate() {
        let want = chart_uv(chart_of(uv[v]), f64::from(p[0]), f64::from(p[1]));
        for k in 0..2 {
            worst = worst.max((f64::from(uv[v][k]) - want[k]).abs());
        }
    }
    worst
}

/// Every triangle's three corners are in one chart (seams stay consistent).
fn assert_one_chart_per_triangle(out: &Mesh) {
    let uv = out.attributes.uv0.as_ref().expect("uv kept");
    for t in &out.triangles {
        let c = t.map(|v| chart_of(uv[v as usize]));
        assert!(
            c[0] == c[1] && c[1] == c[2],
            "triangle {t:?} spans charts {c:?}"
        );
    }
}

/// The planar three-chart grid at 10%, and down to 3 triangles: with the
/// junctions fixed the charts need at least 4 (chart 2 keeps three fixed points
/// on its lower side and one more, two triangles; charts 0 and 1 one each), so
/// reaching 3 takes a junction sliding along its seam. Every output UV is its
/// chart's linear map at the vertex's position, to f32 precision, including the
/// wedges a junction carried across to its neighbour (with the attribute terms
/// off, their interpolated values are 0.5 off).
#[test]
fn planar_charts_keep_linear_uvs_and_reach_target() {
    let m = charted_grid(16, |_, _| 0.0);
    let target = m.triangles.len() / 10;
    let (out, r) = simplify(&m, &SimplifyOptions::default().with_ratio(0.1)).expect("valid");
    assert_eq!(r.stop_reason, StopReason::TargetReached, "{r:?}");
    assert!(out.triangles.len() <= target + target / 100 + 1);
    let worst = uv_off_linear(&out);
    assert!(worst < 1e-5, "UV off its chart's linear map by {worst}");
    assert_one_chart_per_triangle(&out);

    let m = charted_grid(8, |_, _| 0.0);
    let (out, r) =
        simplify(&m, &SimplifyOptions::default().with_target_triangles(3)).expect("valid");
    assert_eq!(r.stop_reason, StopReason::TargetReached, "{r:?}");
    assert!(
        out.triangles.len() <= 3,
        "{} triangles",
        out.triangles.len()
    );
    // Endpoint placement (half-edge runs a progressive mesh records) keeps the
    // junctions fixed: it stops above 3.
    let fixed = SimplifyOptions::default()
        .with_target_triangles(3)
        .with_placement(meshlod::cost::Placement::Endpoint);
    let (stuck, _) = simplify(&m, &fixed).expect("valid");
    assert!(
        stuck.triangles.len() >= 4,
        "{} triangles",
        stuck.triangles.len()
    );
    let worst = uv_off_linear(&out);
    assert!(worst < 1e-5, "UV off its chart's linear map by {worst}");
    assert_one_chart_per_triangle(&out);
}

/// With every attribute weight 0 (UVs interpolated, not solved) on a bumpy
/// three-chart grid, the junctions still move and every triangle stays in one
/// chart.
#[test]
fn junctions_move_without_attribute_terms() {
    let m = charted_grid(16, |x, y| 0.05 * (3.0 * x).sin() * (2.0 * y).cos());
    let mut o = SimplifyOptions::default().with_ratio(0.1);
    o.attribute_weights = AttributeWeights::NONE;
    let (out, r) = simplify(&m, &o).expect("valid");
    assert_eq!(r.stop_reason, StopReason::TargetReached, "{r:?}");
    assert_one_chart_per_triangle(&out);
}

/// An attribute weight that is negative or not finite is refused.
#[test]
fn bad_attribute_weights_are_refused() {
    let m = charted_grid(4, |_, _| 0.0);
    for bad in [-1.0, f64::NAN, f64::INFINITY] {
        let mut o = SimplifyOptions::default().with_ratio(0.5);
        o.attribute_weights.uv = bad;
        assert!(simplify(&m, &o).is_err(), "uv weight {bad} accepted");
    }
}

/// Simplifies every part of the glTF at `path` to `ratio` and returns (input
/// triangles, target, output triangles, stop reasons that are not "target reached").
fn gltf_at(path: &std::path::Path, ratio: f64) -> (usize, usize, usize, Vec<String>) {
    let scene = read_scene(path).expect("reads");
    let (mut tin, mut target, mut tout) = (0, 0, 0);
    let mut stops = Vec::new();
    for (i, p) in scene.parts.iter().enumerate() {
        let o = SimplifyOptions::default().with_ratio(ratio);
        let (out, r) = simplify(&p.mesh, &o).expect("valid part");
        out.validate().expect("valid output");
        tin += p.mesh.triangles.len();
        target += ((p.mesh.triangles.len() as f64) * ratio).round() as usize;
        tout += out.triangles.len();
        if r.stop_reason != StopReason::TargetReached {
            stops.push(format!("part {i}: {:?} ({})", r.stop_reason, r.stop_detail));
        }
    }
    (tin, target, tout, stops)
}

/// The Duck shipped in `tests/data` (a UV-mapped asset with seam junctions)
/// reaches 10% within 1%.
#[test]
fn duck_reaches_ten_percent() {
    let path = common::data_dir().join("Duck/Duck.gltf");
    let (tin, target, tout, stops) = gltf_at(&path, 0.1);
    assert!(tin > 4000);
    assert!(
        tout as f64 <= target as f64 * 1.01 + 1.0,
        "{tout} of {target} triangles: {stops:?}"
    );
}

/// The Duck at 3% (126 of 4,212 triangles): its UV charts leave no collapse that
/// keeps every seam long before that. With seams never crossed the run tears the
/// shape apart on its way down (every remaining collapse moves a seam far) and
/// still stops near 284 triangles, with a Hausdorff distance of about half the
/// bounding-box diagonal; by default a seam is crossed where keeping it costs ten
/// times more, and the Duck reaches its target within a few percent of the
/// diagonal (3.9% when this was written).
#[test]
fn duck_at_three_percent_crosses_seams_rather_than_tearing() {
    let scene = read_scene(common::data_dir().join("Duck/Duck.gltf")).expect("reads");
    let duck = &scene.parts[0].mesh;
    let target = (duck.triangles.len() as f64 * 0.03).round() as usize;
    let s = SamplingOptions::default();

    let (out, r) = simplify(duck, &SimplifyOptions::default().with_ratio(0.03)).expect("valid");
    out.validate().expect("valid output");
    assert_eq!(r.stop_reason, StopReason::TargetReached, "{r:?}");
    assert!(out.triangles.len() <= target + target / 100 + 1);
    let rel = |m: &Mesh| {
        let h = hausdorff(duck, m, &s);
        h.hausdorff / h.bbox_diagonal
    };
    let d = rel(&out);
    assert!(d < 0.08, "Hausdorff {:.2}% of the diagonal", 100.0 * d);

    let strict = SimplifyOptions {
        strict_seams: true,
        ..SimplifyOptions::default().with_ratio(0.03)
    };
    let (torn, r) = simplify(duck, &strict).expect("valid");
    assert_ne!(r.stop_reason, StopReason::TargetReached, "{r:?}");
    let dt = rel(&torn);
    assert!(
        dt > 4.0 * d,
        "strict seams: {:.2}% against {:.2}%",
        100.0 * dt,
        100.0 * d
    );

    let both = SimplifyOptions {
        permissive: true,
        ..strict
    };
    assert!(
        simplify(duck, &both).is_err(),
        "strict and permissive accepted"
    );
}

/// The manifold glTF sample assets of the shared set reach 10% within 1%; the
/// CAD assemblies and the many-part scene (non-manifold edges stay frozen, and
/// parts of a few triangles cannot lose any) are reported, not asserted.
#[test]
fn gltf_samples_reach_ten_percent() {
    let Some(shared) = common::shared_meshes("gltf_samples_reach_ten_percent") else {
        return;
    };
    let dir = shared.join("gltf-sample-models");
    for (name, must) in [
        ("DamagedHelmet", true),
        ("Duck", true),
        ("WaterBottle", true),
        ("Avocado", true),
        ("BrainStem", true),
        ("VC", false),
        ("2CylinderEngine", false),
        ("ReciprocatingSaw", false),
    ] {
        let path = dir.join(name).join(format!("{name}.gltf"));
        if !path.is_file() {
            eprintln!("notice: {} is absent; skipped", path.display());
            continue;
        }
        let (tin, target, tout, stops) = gltf_at(&path, 0.1);
        eprintln!(
            "{name}: {tin} → {tout} triangles (target {target}); early stops: {}",
            stops.len()
        );
        if must {
            assert!(
                tout as f64 <= target as f64 * 1.01 + 1.0,
                "{name}: {tout} of {target} triangles: {stops:?}"
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Random bumpy height fields cut into three UV charts, simplified with
    /// attribute terms (and permissively): indices valid, and no triangle turned
    /// to face down (every input triangle faces up).
    #[test]
    fn charted_height_fields_stay_valid_and_unflipped(
        n in 6usize..14,
        a in 0.0f64..0.08,
        fx in 1.0f64..6.0,
        ratio in 0.02f64..0.6,
        permissive in any::<bool>(),
    ) {
        let m = charted_grid(n, |x, y| a * (fx * x).sin() * (fx * 0.7 * y).cos());
        let mut o = SimplifyOptions::default().with_ratio(ratio);
        o.permissive = permissive;
        let (out, _) = simplify(&m, &o).expect("valid");
        prop_assert!(out.validate().is_ok());
        let nv = out.positions.len() as u32;
        for t in &out.triangles {
            prop_assert!(t.iter().all(|&v| v < nv));
            let n = common::normal(&out, *t);
            prop_assert!(n[2] > 0.0, "triangle {:?} faces down: {:?}", t, n);
        }
    }
}

/// Each triangle's corners by position.
fn corners(m: &Mesh) -> Vec<[[f32; 3]; 3]> {
    m.triangles
        .iter()
        .map(|t| t.map(|v| m.positions[v as usize]))
        .collect()
}

/// The attribute refit (on by default) brings the Duck's output normals and UVs
/// closer to the input's at corresponding points than the collapses' values, at the
/// same geometry: at 10%, the mean normal angle fell from 6.32° to 5.61° when this
/// was written, the mean UV distance from 0.0057 to 0.0055.
#[test]
fn refit_lowers_the_ducks_attribute_deviation() {
    let scene = read_scene(common::data_dir().join("Duck/Duck.gltf")).expect("reads");
    let duck = &scene.parts[0].mesh;
    let on = SimplifyOptions::default().with_ratio(0.1);
    let off = on.clone().with_refit_attributes(false);
    let (a, ra) = simplify(duck, &on).expect("valid");
    let (b, rb) = simplify(duck, &off).expect("valid");
    // The refit moves no point and changes no triangle (it may copy a vertex to
    // split a crossed crease: the same corners by position).
    assert_eq!(corners(&a), corners(&b), "the same geometry");
    assert!(a.positions.len() >= b.positions.len());
    assert!(
        ra.attributes_refit > a.positions.len() / 2,
        "{}",
        ra.attributes_refit
    );
    assert_eq!(rb.attributes_refit, 0);
    let s = SamplingOptions::default();
    let dev_a = meshlod::metrics::appearance::appearance(duck, &a, &s).expect("attributes");
    let dev_b = meshlod::metrics::appearance::appearance(duck, &b, &s).expect("attributes");
    let (na, nb) = (
        dev_a.normal_deg.unwrap().mean,
        dev_b.normal_deg.unwrap().mean,
    );
    let (ua, ub) = (dev_a.uv.unwrap().mean, dev_b.uv.unwrap().mean);
    assert!(
        na < 0.95 * nb,
        "normal mean {na}° with the refit, {nb}° without"
    );
    assert!(ua <= ub, "UV mean {ua} with the refit, {ub} without");
}

/// Levels decimated in one run (`simplify_levels`, what `meshlod lod` uses) are
/// refitted as a single run is, against the input: each level's normals and UVs
/// come closer to the input's than the collapses' values, at the same geometry.
#[test]
fn levels_in_one_run_are_refitted() {
    use meshlod::simplify::{simplify_levels, LevelOutput, LevelStop};
    let scene = read_scene(common::data_dir().join("Duck/Duck.gltf")).expect("reads");
    let duck = &scene.parts[0].mesh;
    let counts = [1000usize, 300];
    let run = |o: &SimplifyOptions| -> Vec<LevelOutput> {
        let mut asked = 0;
        simplify_levels(duck, o, &mut |_| {
            let stop = counts.get(asked).map(|&n| LevelStop {
                max_error: None,
                at_most: n,
            });
            asked += 1;
            stop
        })
        .expect("levels")
    };
    let on = run(&SimplifyOptions::default());
    let off = run(&SimplifyOptions::default().with_refit_attributes(false));
    assert_eq!(on.len(), 2);
    let s = SamplingOptions::default();
    for (a, b) in on.iter().zip(&off) {
        if !a.morph_from.is_empty() {
            assert_eq!(a.morph_from.len(), a.simplified.mesh.positions.len());
        }
        let (a, b) = (&a.simplified, &b.simplified);
        let n = a.mesh.triangles.len();
        assert!(
            a.report.attributes_refit > 0,
            "level of {n}: nothing refitted"
        );
        assert_eq!(b.report.attributes_refit, 0);
        assert_eq!(corners(&a.mesh), corners(&b.mesh), "level of {n}");
        assert_eq!(
            a.vertex_source.len(),
            a.mesh.positions.len(),
            "level of {n}"
        );
        let da = meshlod::metrics::appearance::appearance(duck, &a.mesh, &s).expect("attributes");
        let db = meshlod::metrics::appearance::appearance(duck, &b.mesh, &s).expect("attributes");
        let (na, nb) = (da.normal_deg.unwrap().mean, db.normal_deg.unwrap().mean);
        assert!(
            na < nb,
            "level of {n}: normal mean {na}° refitted, {nb}° not"
        );
    }
}
