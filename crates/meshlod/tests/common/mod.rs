//! Helpers shared by the integration tests: where the repo's test data and the shared
//! mesh set live, and a parser for the shared set's `MANIFEST.md`.
#![allow(dead_code)]

use meshlod::mesh::Mesh;
use meshlod::metrics::bvh::Bvh;
use std::path::{Path, PathBuf};

/// `tests/data` at the repository root.
pub fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data")
}

/// `../shared/meshes` beside the checkout, if present. Prints a notice when absent so a
/// user's clone shows why the shared-set tests did nothing.
pub fn shared_meshes(test: &str) -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/meshes");
    if p.join("MANIFEST.md").is_file() {
        Some(p)
    } else {
        eprintln!(
            "notice: {test}: ../shared/meshes is absent (a user's clone); skipping the shared-set checks"
        );
        None
    }
}

/// One row of the manifest's mesh table.
#[derive(Debug, Clone)]
pub struct ManifestRow {
    /// Path relative to `shared/meshes`.
    pub file: String,
    /// `V` column (position vertices stored), if a number.
    pub vertices: Option<usize>,
    /// `T` column (triangles after fan triangulation), if a number.
    pub triangles: Option<usize>,
    /// Welded boundary edges.
    pub boundary_welded: Option<usize>,
    /// Welded non-manifold edges.
    pub non_manifold_welded: Option<usize>,
    /// Welded connected components.
    pub components_welded: Option<usize>,
    /// Attributes column (`-` for none).
    pub attrs: String,
    /// Notes column.
    pub notes: String,
}

fn first_number(s: &str) -> Option<usize> {
    let digits: String = s
        .trim()
        .chars()
        .take_while(|c| c.is_ascii_digit())
        .collect();
    digits.parse().ok()
}

fn welded(s: &str) -> Option<usize> {
    s.split('/').nth(1).and_then(first_number)
}

/// Parses the "Meshes" table of `MANIFEST.md`.
pub fn manifest_rows(shared: &Path) -> Vec<ManifestRow> {
    let text = std::fs::read_to_string(shared.join("MANIFEST.md")).expect("MANIFEST.md readable");
    let mut rows = Vec::new();
    let mut in_meshes = false;
    for line in text.lines() {
        if line.starts_with("## ") {
            in_meshes = line.trim() == "## Meshes";
            continue;
        }
        if !in_meshes || !line.starts_with("| `") {
            continue;
        }
        let cols: Vec<&str> = line.split('|').map(str::trim).collect();
        // cols[0] is empty (leading '|').
        if cols.len() < 13 {
            continue;
        }
        rows.push(ManifestRow {
            file: cols[1].trim_matches('`').to_string(),
            vertices: first_number(cols[4]),
            triangles: first_number(cols[5]),
            boundary_welded: welded(cols[7]),
            non_manifold_welded: welded(cols[8]),
            components_welded: welded(cols[9]),
            attrs: cols[6].to_string(),
            notes: cols[12].to_string(),
        });
    }
    rows
}

// ----- fold-over measure (the peers benchmark's "flipped" column) ----------------

pub fn f64x3(p: [f32; 3]) -> [f64; 3] {
    p.map(f64::from)
}

pub fn normal(m: &Mesh, t: [u32; 3]) -> [f64; 3] {
    let [a, b, c] = t.map(|i| f64x3(m.positions[i as usize]));
    let (u, v) = (
        [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
        [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
    );
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

/// Output triangles whose normal points away from the normal of the closest
/// original triangle to their centroid.
pub fn flipped(original: &Mesh, bvh: &Bvh, out: &Mesh) -> usize {
    let mut n = 0;
    for t in &out.triangles {
        let [a, b, c] = t.map(|i| f64x3(out.positions[i as usize]));
        let centroid = [
            (a[0] + b[0] + c[0]) / 3.0,
            (a[1] + b[1] + c[1]) / 3.0,
            (a[2] + b[2] + c[2]) / 3.0,
        ];
        if let Some(cl) = bvh.closest(centroid, None) {
            let no = normal(original, original.triangles[cl.triangle as usize]);
            let ns = normal(out, *t);
            if no[0] * ns[0] + no[1] * ns[1] + no[2] * ns[2] < 0.0 {
                n += 1;
            }
        }
    }
    n
}

/// The symmetric distances of `before` and `after` from `input` (300,000 samples a
/// direction: enough for 1% comparisons of the maximum on the repository's meshes)
/// and a log line "H max … -> …, mean … -> … (diag)".
pub fn distances_before_after(
    input: &Mesh,
    before: &Mesh,
    after: &Mesh,
) -> (
    meshlod::metrics::Distances,
    meshlod::metrics::Distances,
    String,
) {
    let s = meshlod::metrics::SamplingOptions {
        samples: Some(300_000),
        ..meshlod::metrics::SamplingOptions::default()
    };
    let (b, a) = (
        meshlod::metrics::hausdorff(input, before, &s),
        meshlod::metrics::hausdorff(input, after, &s),
    );
    let line = format!(
        "H max {:.5} -> {:.5}, mean {:.6} -> {:.6} (diag)",
        b.hausdorff / b.bbox_diagonal,
        a.hausdorff / a.bbox_diagonal,
        b.mean / b.bbox_diagonal,
        a.mean / a.bbox_diagonal
    );
    (b, a, line)
}
