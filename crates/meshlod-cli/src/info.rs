//! `meshlod info FILE [--json]`.

use anyhow::Result;
use meshlod::io::{read_scene, Format};
use meshlod::mesh::{MeshStats, Weld};
use serde::Serialize;
use std::path::PathBuf;

/// Arguments of `meshlod info`.
#[derive(Debug, clap::Args)]
pub struct InfoArgs {
    /// Mesh file (.obj .ply .stl .off .gltf .glb .m).
    pub file: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct InfoReport<'a> {
    file: String,
    format: &'static str,
    parts: usize,
    instances: usize,
    #[serde(flatten)]
    stats: &'a MeshStats,
}

/// Reads the file, measures it, prints the report.
///
/// # Errors
/// The file cannot be read or parsed.
pub fn run(args: &InfoArgs) -> Result<()> {
    let scene = read_scene(&args.file)?;
    let mesh = scene.flattened();
    crate::warn_precision(&args.file, &mesh);
    // Topology on world positions welded in f64, so that instances placed by node
    // transforms weld where they truly touch and nowhere else.
    let weld = Weld::exact_f64(&scene.world_positions_f64());
    let stats = MeshStats::with_weld(&mesh, &weld);
    let format = Format::from_path(&args.file).map_or("?", Format::name);
    let report = InfoReport {
        file: args.file.display().to_string(),
        format,
        parts: scene.parts.len(),
        instances: scene.parts.iter().map(|p| p.instances.len()).sum(),
        stats: &stats,
    };
    if args.json {
        out!("{}", serde_json::to_string(&report)?);
        return Ok(());
    }
    let t = &stats.topology;
    out!("{}  ({format})", report.file);
    if report.parts > 1 || report.instances != report.parts {
        out!(
            "  scene           {} meshes, {} instances (counts below are per instance)",
            report.parts,
            report.instances
        );
    }
    out!("  vertices        {}", stats.vertices);
    out!("  triangles       {}", stats.triangles);
    let attrs: Vec<String> = stats
        .attributes
        .iter()
        .map(|a| {
            serde_json::to_value(a)
                .map_or_else(|_| "?".into(), |v| v.as_str().unwrap_or("?").to_string())
        })
        .collect();
    out!(
        "  attributes      {}",
        if attrs.is_empty() {
            "none".to_string()
        } else {
            attrs.join(", ")
        }
    );
    out!("  groups          {}", stats.groups);
    match (stats.bbox_min, stats.bbox_max) {
        (Some(lo), Some(hi)) => out!(
            "  bounding box    ({}, {}, {}) .. ({}, {}, {}), diagonal {:.6}",
            lo[0],
            lo[1],
            lo[2],
            hi[0],
            hi[1],
            hi[2],
            stats.bbox_diagonal
        ),
        _ => out!("  bounding box    empty"),
    }
    out!(
        "  welded vertices {} ({} duplicate positions)",
        t.welded_vertices,
        stats.duplicate_positions
    );
    out!("  edges           {}", t.edges);
    out!(
        "  boundary        {} edges in {} loops",
        t.boundary_edges,
        t.boundary_loops
    );
    out!(
        "  non-manifold    {} edges, {} vertices",
        t.non_manifold_edges,
        t.non_manifold_vertices
    );
    out!("  components      {}", t.components);
    match t.genus {
        Some(g) => out!(
            "  euler / genus   {} / {g} (closed manifold)",
            t.euler_characteristic
        ),
        None => out!(
            "  euler / genus   {} / - (not a closed manifold)",
            t.euler_characteristic
        ),
    }
    out!(
        "  degenerate      {} triangles; duplicate {} triangles",
        t.degenerate_triangles,
        t.duplicate_triangles
    );
    out!("  unreferenced    {} vertices", stats.unreferenced_vertices);
    Ok(())
}
