//! Writes a mesh subdivided `N` times (each triangle into four, midpoint rule): large
//! inputs for benchmarks and memory measurements from the shared meshes.
//!
//! Run: `cargo run --release -p meshlod --example subdivide -- IN OUT N`
//! (e.g. the turbine blade twice: 3.2 M triangles).

use std::process::ExitCode;

fn main() -> ExitCode {
    let a: Vec<String> = std::env::args().collect();
    let (Some(input), Some(output), Some(n)) = (a.get(1), a.get(2), a.get(3)) else {
        eprintln!("usage: subdivide IN OUT N");
        return ExitCode::FAILURE;
    };
    let Ok(n) = n.parse::<usize>() else {
        eprintln!("N must be a whole number, got {n:?}");
        return ExitCode::FAILURE;
    };
    let mut mesh = match meshlod::read_mesh(input) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::FAILURE;
        }
    };
    for _ in 0..n {
        mesh = mesh.subdivide_midpoint();
    }
    if let Err(e) = meshlod::write_mesh(output, &mesh, &Default::default()) {
        eprintln!("{e}");
        return ExitCode::FAILURE;
    }
    println!("{output}: {} triangles", mesh.triangles.len());
    ExitCode::SUCCESS
}
