//! Load and save throughput of binary PLY, OBJ and GLB on a ≥1M-triangle mesh.
//!
//! The mesh is the Stanford bunny shipped in `tests/data`, subdivided twice (1→4) to
//! 1,111,216 triangles. Each format is written to a temporary file once, then read and
//! written `REPS` times in memory (no disk in the timed part); the best time is
//! reported as MB/s of file bytes. Run with:
//!
//!     cargo bench -p meshlod --bench io_throughput
//!
//! Targets (issue "Foundation"): ≥150 MB/s for binary PLY and GLB, ≥60 MB/s for OBJ.

use meshlod::io::{read_scene_from_bytes, write_scene_to_bytes, Format, Scene, WriteOptions};
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

const REPS: usize = 5;

fn best_of<T>(reps: usize, mut f: impl FnMut() -> T) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let t = Instant::now();
        black_box(f());
        best = best.min(t.elapsed().as_secs_f64());
    }
    best
}

fn main() {
    let bunny = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/stanford-bunny.obj");
    let mut mesh = meshlod::read_mesh(&bunny).expect("bunny loads");
    mesh.compact_vertices();
    let mesh = mesh.subdivide_midpoint().subdivide_midpoint();
    println!(
        "mesh: bunny subdivided twice, {} vertices, {} triangles",
        mesh.positions.len(),
        mesh.triangles.len()
    );
    let scene = Scene::from_mesh(mesh);
    println!("| format | file MB | read MB/s | write MB/s | read Mtris/s |");
    println!("|---|---:|---:|---:|---:|");
    for (name, format) in [
        ("PLY (binary LE)", Format::Ply),
        ("GLB", Format::Glb),
        ("OBJ", Format::Obj),
        ("STL (binary)", Format::Stl),
        ("OFF", Format::Off),
    ] {
        let opts = WriteOptions::default();
        let bytes = write_scene_to_bytes(&scene, format, &opts).expect("write");
        let mb = bytes.len() as f64 / 1e6;
        let read = best_of(REPS, || {
            read_scene_from_bytes(&bytes, format, None).expect("read")
        });
        let write = best_of(REPS, || {
            write_scene_to_bytes(&scene, format, &opts).expect("write")
        });
        let tris = scene.parts[0].mesh.triangles.len() as f64;
        println!(
            "| {name} | {mb:.1} | {:.0} | {:.0} | {:.2} |",
            mb / read,
            mb / write,
            tris / read / 1e6
        );
    }
}
