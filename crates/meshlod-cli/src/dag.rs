//! `meshlod dag build IN -o X.mdag [--cluster-size 128] [--json]` and `meshlod dag
//! cut X.mdag --camera X,Y,Z [--target X,Y,Z] [--fov DEG] [--height PX] [--width PX]
//! [--pixel-error P] [--cull] -o OUT [--json]`: the cluster hierarchy of view-dependent level of detail
//! (`meshlod::lod::dag`) and its crack-free cut for a camera.

use anyhow::{bail, Context, Result};
use meshlod::io::{read_scene, write_mesh, WriteOptions};
use meshlod::lod::dag::{build_dag, read_mdag, write_mdag, DagOptions, DagView};
use meshlod::lod::Screen;
use serde_json::json;
use std::path::PathBuf;
use std::time::Instant;

/// `meshlod dag` subcommands.
#[derive(Debug, clap::Subcommand)]
pub enum DagCommand {
    /// Build the cluster hierarchy of a mesh and write it as a .mdag file.
    Build(BuildArgs),
    /// Write the crack-free cut of a .mdag hierarchy for a camera as a mesh.
    Cut(CutArgs),
}

/// Arguments of `meshlod dag build`.
#[derive(Debug, clap::Args)]
pub struct BuildArgs {
    /// Input mesh (any format meshlod reads; a scene is flattened; normals, UVs,
    /// colours and materials are carried into every cut).
    pub input: PathBuf,
    /// Output `.mdag` file.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Triangles per cluster (at most).
    #[arg(long, value_name = "N", default_value_t = 128)]
    pub cluster_size: usize,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `meshlod dag cut`.
#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct CutArgs {
    /// A `.mdag` file written by `meshlod dag build`.
    pub file: PathBuf,
    /// Camera position in the mesh's units, `x,y,z`.
    #[arg(long, value_name = "X,Y,Z", value_parser = crate::lod::parse_point)]
    pub camera: [f64; 3],
    /// The point the camera looks at, `x,y,z`. With it, groups of clusters wholly
    /// outside the view (behind the camera or beyond the screen's corners) are taken
    /// as coarse as the hierarchy allows; the cut stays closed. Without it, every
    /// direction counts as in view.
    #[arg(long, value_name = "X,Y,Z", value_parser = crate::lod::parse_point)]
    pub target: Option<[f64; 3]>,
    /// Vertical field of view in degrees.
    #[arg(long, value_name = "DEG", default_value_t = 60.0)]
    pub fov: f64,
    /// Screen height in pixels.
    #[arg(long, value_name = "PX", default_value_t = 1080.0)]
    pub height: f64,
    /// Screen width in pixels, for the screen's corners with `--target` [default:
    /// height × 16/9].
    #[arg(long, value_name = "PX")]
    pub width: Option<f64>,
    /// With `--target`: drop the clusters of the cut that are out of view, as a
    /// renderer's frustum culling does (the output then has holes where nothing is
    /// seen).
    #[arg(long, requires = "target")]
    pub cull: bool,
    /// Largest error a cluster may show, in pixels.
    #[arg(long, value_name = "P", default_value_t = 1.0)]
    pub pixel_error: f64,
    /// Output mesh (any format meshlod writes).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Runs `meshlod dag`.
pub fn run(cmd: &DagCommand) -> Result<()> {
    match cmd {
        DagCommand::Build(a) => build(a),
        DagCommand::Cut(a) => cut(a),
    }
}

fn build(a: &BuildArgs) -> Result<()> {
    if a.cluster_size == 0 {
        bail!("--cluster-size must be at least 1");
    }
    let scene = read_scene(&a.input)?;
    let mesh = scene.flattened();
    crate::warn_precision(&a.input, &mesh);
    let options = DagOptions {
        cluster_size: a.cluster_size,
        ..DagOptions::default()
    };
    let (dag, report) =
        build_dag(&mesh, &options).with_context(|| a.input.display().to_string())?;
    let bytes = write_mdag(&dag);
    std::fs::write(&a.output, &bytes).with_context(|| a.output.display().to_string())?;
    if a.json {
        let mut v = serde_json::to_value(&report)?;
        v["input"] = json!(a.input.display().to_string());
        v["output"] = json!(a.output.display().to_string());
        v["bytes"] = json!(bytes.len());
        out!("{}", serde_json::to_string(&v)?);
    } else {
        out!("{} -> {}", a.input.display(), a.output.display());
        out!(
            "  {} triangles in {} clusters ({} leaves), depth {}, {} roots of {} triangles",
            report.triangles,
            report.clusters,
            report.leaf_clusters,
            report.depth,
            report.roots,
            report.root_triangles
        );
        if report.stuck_groups > 0 {
            out!(
                "  {} groups could not be halved and were regrouped",
                report.stuck_groups
            );
        }
        out!("  {:.2} s, {} bytes", report.seconds, bytes.len());
    }
    Ok(())
}

fn cut(a: &CutArgs) -> Result<()> {
    let screen = Screen {
        pixel_error: a.pixel_error,
        screen_height_px: a.height,
        fov_degrees: a.fov,
        aspect: a.width.map_or(16.0 / 9.0, |w| w / a.height),
    };
    if a.width.is_some_and(|w| !(w > 0.0 && w.is_finite())) {
        bail!("--width must be a positive number of pixels");
    }
    screen.check()?;
    if a.target == Some(a.camera) {
        bail!("--target is the camera position: it gives no view direction");
    }
    let data = std::fs::read(&a.file).with_context(|| a.file.display().to_string())?;
    let dag = read_mdag(&data).with_context(|| a.file.display().to_string())?;
    let view = DagView {
        position: a.camera,
        target: a.target,
        screen,
    };
    let t = Instant::now();
    let mut clusters = dag.cut(&view);
    let in_cut = clusters.len();
    if a.cull {
        clusters = dag.visible(&view, &clusters);
    }
    let cut_seconds = t.elapsed().as_secs_f64();
    let mesh = dag.cut_mesh(&clusters);
    write_mesh(&a.output, &mesh, &WriteOptions::default())?;
    let max_level = clusters
        .iter()
        .map(|&c| dag.clusters[c].level)
        .max()
        .unwrap_or(0);
    if a.json {
        out!(
            "{}",
            serde_json::to_string(&json!({
                "file": a.file.display().to_string(),
                "output": a.output.display().to_string(),
                "clusters": clusters.len(),
                "triangles": mesh.triangles.len(),
                "vertices": mesh.positions.len(),
                "coarsest_level": max_level,
                "target": a.target,
                "culled_clusters": in_cut - clusters.len(),
                "cut_seconds": cut_seconds,
                "attributes": mesh.attributes.kinds(),
                "groups": dag.group_names.as_ref().map_or(0, Vec::len),
            }))?
        );
    } else {
        out!(
            "{} clusters, {} triangles (levels up to {max_level}) -> {} ({:.3} ms)",
            clusters.len(),
            mesh.triangles.len(),
            a.output.display(),
            1e3 * cut_seconds
        );
    }
    Ok(())
}
