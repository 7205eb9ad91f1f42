//! Level-of-detail chains: counts fall and errors grow along the chain, each
//! level's reported error is the Hausdorff distance `metrics::hausdorff` measures,
//! the selection is monotone in distance and switches where the projected error
//! is the pixel budget, geomorph starts are positions of the finer level, and the
//! glTF output carries `MSFT_lod` with the materials kept.

mod common;

use meshlod::io::gltf::{self, add_lods, MeshLods};
use meshlod::io::{read_scene, Scene, IDENTITY};
use meshlod::lod::{
    build_chain, select, select_level, Chain, ChainOptions, LevelSpec, LodObject, Screen, View,
};
use meshlod::mesh::{generate, Mesh};
use meshlod::metrics::{self, SamplingOptions};
use meshlod::simplify::{Method, SimplifyOptions};

fn bunny() -> Mesh {
    meshlod::read_mesh(common::data_dir().join("stanford-bunny.obj")).expect("bunny reads")
}

fn options(levels: LevelSpec) -> ChainOptions {
    ChainOptions {
        levels,
        sampling: SamplingOptions::default().with_samples(30_000),
        ..ChainOptions::default()
    }
}

/// The properties every chain must have.
fn check_chain(input: &Mesh, chain: &Chain, sampling: &SamplingOptions) {
    assert_eq!(chain.levels[0].triangles, input.triangles.len());
    for pair in chain.levels.windows(2) {
        let (fine, coarse) = (&pair[0], &pair[1]);
        assert!(
            coarse.triangles < fine.triangles,
            "LOD{} has {} triangles, LOD{} {}",
            coarse.level,
            coarse.triangles,
            fine.level,
            fine.triangles
        );
        assert!(
            coarse.error_max > fine.error_max,
            "LOD{} error {} not above LOD{}'s {}",
            coarse.level,
            coarse.error_max,
            fine.level,
            fine.error_max
        );
        assert!(coarse.switch_distance > fine.switch_distance);
        assert!(coarse.screen_coverage <= fine.screen_coverage);
    }
    for l in &chain.levels[1..] {
        assert_eq!(l.triangles, l.mesh.triangles.len());
        assert_eq!(l.vertices, l.mesh.positions.len());
        l.mesh.validate().expect("valid level");
        // The reported error is what the metrics module measures, exactly.
        let d = metrics::hausdorff(input, &l.mesh, sampling);
        assert_eq!(l.error_max, d.hausdorff, "LOD{} max", l.level);
        assert_eq!(l.error_mean, d.mean, "LOD{} mean", l.level);
    }
    let cov = chain.coverages();
    assert_eq!(cov.len(), chain.levels.len());
    assert!(cov.windows(2).all(|w| w[1] <= w[0]), "{cov:?}");
}

#[test]
fn chain_by_error_halves_each_level_and_measures_it() {
    let mesh = bunny();
    let o = options(LevelSpec::ByError(4));
    let chain = build_chain(&mesh, &o).expect("chain");
    assert_eq!(chain.levels.len(), 5, "stopped: {:?}", chain.stopped_early);
    check_chain(&mesh, &chain, &o.sampling);
    for pair in chain.levels.windows(2) {
        assert!(
            pair[1].triangles <= pair[0].triangles / 2 + 1,
            "LOD{} does not halve: {} → {}",
            pair[1].level,
            pair[0].triangles,
            pair[1].triangles
        );
    }
}

#[test]
fn chain_by_ratios_reaches_each_ratio() {
    let mesh = bunny();
    let ratios = vec![0.5, 0.2, 0.05];
    let o = options(LevelSpec::Ratios(ratios.clone()));
    let chain = build_chain(&mesh, &o).expect("chain");
    assert_eq!(chain.levels.len(), 4, "stopped: {:?}", chain.stopped_early);
    check_chain(&mesh, &chain, &o.sampling);
    for (l, r) in chain.levels[1..].iter().zip(&ratios) {
        let target = (r * mesh.triangles.len() as f64).round() as usize;
        assert!(
            l.triangles <= target && l.triangles + 2 >= target,
            "LOD{}: {} triangles for target {target}",
            l.level,
            l.triangles
        );
    }
}

#[test]
fn chain_level_by_level_with_vertex_removal() {
    // Vertex removal cannot run through the levels in one pass: each level is a
    // simplification of the previous one, and the chain keeps the same properties.
    let mesh = generate::icosphere(5);
    let o = ChainOptions {
        simplify: SimplifyOptions::default().with_method(Method::VertexRemoval),
        geomorph: true,
        ..options(LevelSpec::Ratios(vec![0.4, 0.1]))
    };
    let chain = build_chain(&mesh, &o).expect("chain");
    assert_eq!(chain.levels.len(), 3, "stopped: {:?}", chain.stopped_early);
    check_chain(&mesh, &chain, &o.sampling);
    // Vertex removal moves no vertex: every start of a geomorph is where the
    // vertex already is.
    for l in &chain.levels[1..] {
        assert_eq!(l.morph_from, l.mesh.positions);
    }
}

#[test]
fn chain_by_error_with_clustering_halves_the_count() {
    // Clustering has no error stop: by error, each level halves the count.
    let mesh = generate::icosphere(6);
    let o = ChainOptions {
        simplify: SimplifyOptions::default().with_method(Method::Cluster),
        ..options(LevelSpec::ByError(3))
    };
    let chain = build_chain(&mesh, &o).expect("chain");
    assert_eq!(chain.levels.len(), 4, "stopped: {:?}", chain.stopped_early);
    check_chain(&mesh, &chain, &o.sampling);
}

#[test]
fn bad_chain_options_are_refused() {
    let mesh = generate::icosphere(2);
    for levels in [
        LevelSpec::ByError(0),
        LevelSpec::Ratios(vec![]),
        LevelSpec::Ratios(vec![0.5, 0.6]),
        LevelSpec::Ratios(vec![1.0]),
        LevelSpec::Ratios(vec![0.5, f64::NAN]),
    ] {
        let o = options(levels.clone());
        assert!(build_chain(&mesh, &o).is_err(), "{levels:?} accepted");
    }
    let o = ChainOptions {
        screen: Screen {
            fov_degrees: 180.0,
            ..Screen::default()
        },
        ..ChainOptions::default()
    };
    assert!(build_chain(&mesh, &o).is_err());
    // An empty mesh is a chain of LOD0 alone, with the reason.
    let chain = build_chain(&Mesh::default(), &ChainOptions::default()).expect("empty is fine");
    assert_eq!(chain.levels.len(), 1);
    assert!(chain.stopped_early.is_some());
}

#[test]
fn geomorph_starts_are_positions_of_the_finer_level() {
    let mesh = bunny();
    let o = ChainOptions {
        geomorph: true,
        ..options(LevelSpec::Ratios(vec![0.3, 0.05]))
    };
    let chain = build_chain(&mesh, &o).expect("chain");
    for pair in chain.levels.windows(2) {
        let (fine, coarse) = (&pair[0], &pair[1]);
        assert_eq!(coarse.morph_from.len(), coarse.mesh.positions.len());
        let mut fine_points: Vec<[u32; 3]> = fine
            .mesh
            .positions
            .iter()
            .map(|p| p.map(f32::to_bits))
            .collect();
        fine_points.sort_unstable();
        let mut moved = 0;
        for (from, to) in coarse.morph_from.iter().zip(&coarse.mesh.positions) {
            assert!(
                fine_points.binary_search(&from.map(f32::to_bits)).is_ok(),
                "LOD{}: geomorph start {from:?} is no vertex of LOD{}",
                coarse.level,
                fine.level
            );
            moved += usize::from(from != to);
        }
        // QEM moves the vertices it keeps: the morph has something to do.
        assert!(moved > 0, "LOD{}: no vertex moved", coarse.level);
    }
}

/// An object of three levels with errors 0, 0.01 and 0.05 at the origin.
fn object() -> LodObject {
    LodObject::new([0.0; 3], 1.0, vec![0.0, 0.01, 0.05])
}

#[test]
fn selection_never_refines_when_the_camera_moves_away() {
    let view = |x: f64| View {
        position: [x, 0.0, 0.0],
        screen: Screen::default(),
    };
    let mut last = 0;
    for i in 0..2000 {
        let x = 0.01 * 1.01f64.powi(i);
        let level = select(&[object()], &view(x))[0];
        assert!(level >= last, "at {x} level {level} after {last}");
        last = level;
    }
    assert_eq!(last, 2, "far away the coarsest level is used");
}

#[test]
fn at_each_switch_distance_the_projected_error_is_the_budget() {
    for screen in [
        Screen::default(),
        Screen {
            pixel_error: 2.5,
            screen_height_px: 2160.0,
            fov_degrees: 35.0,
            ..Screen::default()
        },
    ] {
        let o = object();
        for (k, &e) in o.errors.iter().enumerate().skip(1) {
            let d = screen.switch_distance(e);
            let p = screen.pixels(e, d);
            assert!(
                (p - screen.pixel_error).abs() <= 0.01 * screen.pixel_error,
                "LOD{k}: {p} px at its switch distance {d}"
            );
            assert_eq!(select_level(&o.errors, d * (1.0 + 1e-9), &screen), k);
            assert_eq!(select_level(&o.errors, d * (1.0 - 1e-6), &screen), k - 1);
        }
    }
}

#[test]
fn a_placed_object_scales_its_errors() {
    let mut m = IDENTITY;
    m[0][0] = 3.0;
    m[1][1] = 3.0;
    m[2][2] = 3.0;
    m[3] = [10.0, 0.0, 0.0, 1.0];
    let placed = object().placed(&m);
    assert_eq!(placed.center, [10.0, 0.0, 0.0]);
    assert!((placed.errors[2] - 0.15).abs() < 1e-12);
    assert!((placed.radius - 3.0).abs() < 1e-12);
}

/// The Duck (one mesh, one textured material) with a chain written as `MSFT_lod`.
fn duck_with_lods(geomorph: bool) -> (Scene, Chain) {
    let scene = read_scene(common::data_dir().join("Duck/Duck.gltf")).expect("duck");
    let o = ChainOptions {
        geomorph,
        ..options(LevelSpec::Ratios(vec![0.5, 0.2]))
    };
    let chain = build_chain(&scene.parts[0].mesh, &o).expect("chain");
    let mut out = scene.clone();
    add_lods(
        &mut out,
        vec![MeshLods {
            part: 0,
            levels: chain.levels[1..].iter().map(|l| l.mesh.clone()).collect(),
            morph_from: chain.levels[1..]
                .iter()
                .map(|l| l.morph_from.clone())
                .collect(),
            coverage: chain.coverages(),
            extras: serde_json::json!({ "errors": chain.errors() }),
        }],
    )
    .expect("add lods");
    let bytes = gltf::write_glb(&out).expect("write");
    (gltf::read(&bytes, None).expect("read back"), chain)
}

#[test]
fn gltf_msft_lod_levels_keep_the_material() {
    let (back, chain) = duck_with_lods(false);
    let doc = back.gltf.as_ref().expect("a glTF document").document();
    assert!(doc["extensionsUsed"]
        .as_array()
        .expect("extensionsUsed")
        .iter()
        .any(|e| e == "MSFT_lod"));
    let nodes = doc["nodes"].as_array().expect("nodes");
    let lod_node = nodes
        .iter()
        .find(|n| n["extensions"]["MSFT_lod"].is_object())
        .expect("a node with MSFT_lod");
    let ids: Vec<usize> = lod_node["extensions"]["MSFT_lod"]["ids"]
        .as_array()
        .expect("ids")
        .iter()
        .map(|v| v.as_u64().expect("index") as usize)
        .collect();
    assert_eq!(ids.len(), 2);
    let coverage = lod_node["extras"]["MSFT_screencoverage"]
        .as_array()
        .expect("coverage");
    assert_eq!(coverage.len(), 3);
    let material = &doc["meshes"][0]["primitives"][0]["material"];
    for (k, &id) in ids.iter().enumerate() {
        let mesh = nodes[id]["mesh"].as_u64().expect("LOD node draws a mesh") as usize;
        assert_eq!(&doc["meshes"][mesh]["primitives"][0]["material"], material);
        // Read back, the level is a part with the chain's triangles and its UVs.
        let part = &back.parts[mesh];
        assert_eq!(part.mesh.triangles.len(), chain.levels[k + 1].triangles);
        assert!(part.mesh.attributes.uv0.is_some());
        assert!(part.instances.is_empty(), "LOD nodes are in no scene");
    }
    assert_eq!(
        back.parts[0].mesh.triangles.len(),
        chain.levels[0].triangles
    );
}

#[test]
fn gltf_geomorph_is_a_morph_target_to_the_coarse_positions() {
    let (back, chain) = duck_with_lods(true);
    let doc = back.gltf.as_ref().expect("a glTF document").document();
    for k in 1..chain.levels.len() {
        let m = &doc["meshes"][k];
        assert_eq!(m["weights"], serde_json::json!([1.0]));
        let prims = m["primitives"].as_array().expect("primitives");
        assert!(prims
            .iter()
            .all(|p| p["targets"].as_array().map(Vec::len) == Some(1)));
        // The base positions read back are the geomorph starts (the finer shape),
        // as a set: the writer may reorder vertices.
        let mut got: Vec<[u32; 3]> = back.parts[k]
            .mesh
            .positions
            .iter()
            .map(|p| p.map(f32::to_bits))
            .collect();
        let mut want: Vec<[u32; 3]> = chain.levels[k]
            .morph_from
            .iter()
            .map(|p| p.map(f32::to_bits))
            .collect();
        got.sort_unstable();
        got.dedup();
        want.sort_unstable();
        want.dedup();
        assert_eq!(got, want, "LOD{k}");
    }
}
