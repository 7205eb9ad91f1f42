//! The orientation repair after QEM (`SimplifyOptions::facing_repair`, diagonal swaps
//! that turn triangles facing away from the input back toward it) on the repository's
//! test meshes at 10% and 1%: it moves no vertex, keeps the triangle count and the
//! topology, never raises the facing-away count, does swap on the meshes that have
//! triangles facing away (the cow, the bunny and the stratocaster do at these
//! ratios), and does not raise the symmetric Hausdorff distance beyond sampling noise
//! (1%; the sampler's face samples move when two triangles change) nor the mean by
//! more than 1% (2% on the stratocaster at 10%, see below).

mod common;

use meshlod::io::read_scene;
use meshlod::mesh::MeshStats;
use meshlod::metrics::bvh::Bvh;
use meshlod::simplify::{simplify, SimplifyOptions};

#[test]
fn repair_turns_triangles_back_without_leaving_the_input() {
    let mut flips = 0;
    for file in [
        "cow.obj",
        "stanford-bunny.obj",
        "camelhead.off",
        "stratocaster.ply",
    ] {
        let mesh = read_scene(common::data_dir().join(file))
            .expect("test mesh reads")
            .flatten();
        let bvh = Bvh::build(&mesh.positions, &mesh.triangles);
        for ratio in [0.1, 0.01] {
            let name = format!("{file} @ {ratio}");
            let base = SimplifyOptions::default().with_ratio(ratio);
            let (off, r_off) = simplify(&mesh, &base.clone().with_facing_repair(false)).unwrap();
            let (on, r_on) = simplify(&mesh, &base).unwrap();
            assert_eq!(r_off.facing_away, None, "{name}");
            assert_eq!(r_off.facing_flips, 0, "{name}");
            let [before, after] = r_on.facing_away.expect("the repair ran");
            assert!(after <= before, "{name}: {before} -> {after}");
            // The tests' own count (no area floor, so it also counts slivers).
            let (f_off, f_on) = (
                common::flipped(&mesh, &bvh, &off),
                common::flipped(&mesh, &bvh, &on),
            );
            assert!(f_on <= f_off, "{name}: {f_off} -> {f_on}");
            assert_eq!(on.positions, off.positions, "{name}: a vertex moved");
            assert_eq!(on.triangles.len(), off.triangles.len(), "{name}");
            flips += r_on.facing_flips;
            let (so, sn) = (MeshStats::of(&off).topology, MeshStats::of(&on).topology);
            assert_eq!(sn.duplicate_triangles, 0, "{name}");
            assert_eq!(sn.degenerate_triangles, 0, "{name}");
            assert!(sn.boundary_edges <= so.boundary_edges, "{name}");
            assert!(sn.non_manifold_edges <= so.non_manifold_edges, "{name}");
            let (d_off, d_on, line) = common::distances_before_after(&mesh, &off, &on);
            eprintln!(
                "{name}: facing away {before} -> {after} ({} swaps); {line}",
                r_on.facing_flips
            );
            assert!(
                d_on.hausdorff <= 1.01 * d_off.hausdorff,
                "{name}: H max rose"
            );
            // The swaps' distance rule bounds the maximum, not the mean: on the
            // stratocaster at 10% (interpenetrating parts, where "facing away" is
            // partly an artefact of the nearest-triangle test) 10 swaps of 866
            // triangles raise the mean by 1.4% since the retries of rejected
            // pairs (2452d18, 2026-12-02) changed that output; 2% still catches a
            // swap rule that stops checking distances. The other cases keep 1%.
            let tol = if file == "stratocaster.ply" && ratio == 0.1 {
                1.02
            } else {
                1.01
            };
            assert!(d_on.mean <= tol * d_off.mean, "{name}: H mean rose");
        }
    }
    assert!(
        flips > 0,
        "no swap on meshes known to have triangles facing away"
    );
}
