//! `meshlod pm build IN -o OUT.pmesh [--method melax|qem]` and
//! `meshlod pm extract IN.pmesh (--triangles N | --ratio R) -o OUT [--geomorph G]`.
//!
//! `build` simplifies the input down to the coarsest mesh the operator allows with
//! half-edge collapses (Melax, or QEM with endpoint placement) and writes the base
//! mesh and the vertex splits as `.pmesh` (format: `meshlod::lod`'s `pmesh` module
//! docs, or `docs/pmesh.md`). `extract` reads it (or any prefix cut between splits),
//! moves to the finest level with at most N triangles — the same mesh as
//! `meshlod simplify --method melax --triangles N` (or `--method qem --placement
//! endpoint`) on the same input — and writes it in any mesh format.
//!
//! `--geomorph G` also writes the geomorph start of that level: the same mesh
//! (same vertex order, same triangles) with every vertex at the position of its
//! ancestor in a coarser level (`--geomorph-ratio F`: the level with at most F × the
//! extracted triangles, default 0.5). A renderer blends `lerp(G, OUT, α)` per vertex
//! for α from 0 to 1 to morph smoothly from the coarser level into this one.

use anyhow::{bail, Context, Result};
use meshlod::cost::Placement;
use meshlod::io::WriteOptions;
use meshlod::lod::{read_pmesh, write_pmesh, Navigator, ProgressiveMesh};
use meshlod::simplify::{Method, SimplifyOptions};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// `meshlod pm` subcommands.
#[derive(Debug, clap::Subcommand)]
pub enum PmCommand {
    /// Build a progressive mesh (.pmesh) from a mesh.
    Build(BuildArgs),
    /// Extract one level of a progressive mesh as a mesh file.
    Extract(ExtractArgs),
}

/// Arguments of `meshlod pm build`.
#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct BuildArgs {
    /// Input mesh (.obj .ply .stl .off .gltf .glb .m); scenes are flattened.
    pub input: PathBuf,
    /// Output .pmesh file.
    #[arg(short = 'o', long = "output")]
    pub output: PathBuf,
    /// Cost model of the half-edge collapses.
    #[arg(long, value_enum, default_value_t = PmMethodArg::Melax)]
    pub method: PmMethodArg,
    /// Print the report as one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// `--method` values of `pm build`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PmMethodArg {
    /// Melax's edge cost (half-edge collapses).
    Melax,
    /// Quadric error metric with endpoint placement (half-edge collapses).
    Qem,
}

/// Arguments of `meshlod pm extract`.
#[derive(Debug, clap::Args)]
pub struct ExtractArgs {
    /// Input .pmesh file (or a prefix of one).
    pub input: PathBuf,
    /// Output mesh; the format follows the extension.
    #[arg(short = 'o', long = "output")]
    pub output: PathBuf,
    /// Finest level with at most N triangles.
    #[arg(long, conflicts_with = "ratio", required_unless_present = "ratio")]
    pub triangles: Option<usize>,
    /// At most this fraction (0..=1) of the full mesh's triangles.
    #[arg(long)]
    pub ratio: Option<f64>,
    /// Also write the geomorph start (the same mesh at the coarser level's
    /// positions) to this file.
    #[arg(long, value_name = "G")]
    pub geomorph: Option<PathBuf>,
    /// The geomorph's coarser level: at most this fraction of the extracted
    /// triangles (default 0.5).
    #[arg(long, value_name = "F", default_value_t = 0.5)]
    pub geomorph_ratio: f64,
    /// Write ASCII where the format has a choice (PLY, STL).
    #[arg(long)]
    pub ascii: bool,
    /// Print the report as one JSON object.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Serialize)]
struct BuildReport {
    input: String,
    output: String,
    method: &'static str,
    triangles_in: usize,
    triangles_full: usize,
    base_triangles: usize,
    vertex_splits: usize,
    bytes: usize,
    seconds: f64,
    stop_reason: String,
}

#[derive(Debug, Serialize)]
struct ExtractReport {
    input: String,
    output: String,
    splits_in_file: usize,
    splits_in_header: usize,
    complete: bool,
    level: usize,
    triangles: usize,
    vertices: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    geomorph: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    geomorph_level: Option<usize>,
    seconds: f64,
}

/// Runs `meshlod pm …`.
///
/// # Errors
/// Reading, building, decoding or writing errors, naming the file.
pub fn run(cmd: &PmCommand) -> Result<()> {
    match cmd {
        PmCommand::Build(a) => build(a),
        PmCommand::Extract(a) => extract(a),
    }
}

fn build(a: &BuildArgs) -> Result<()> {
    let t0 = Instant::now();
    let mesh = meshlod::read_scene(&a.input)?.flatten();
    crate::warn_precision(&a.input, &mesh);
    let o = match a.method {
        PmMethodArg::Melax => SimplifyOptions::default().with_method(Method::Melax),
        PmMethodArg::Qem => SimplifyOptions::default().with_placement(Placement::Endpoint),
    }
    .with_target_triangles(0);
    let (pm, report) =
        ProgressiveMesh::build(&mesh, &o).with_context(|| format!("{}", a.input.display()))?;
    write_pmesh(&a.output, &pm)?;
    let bytes = std::fs::metadata(&a.output).map_or(0, |m| m.len() as usize);
    let r = BuildReport {
        input: a.input.display().to_string(),
        output: a.output.display().to_string(),
        method: report.method,
        triangles_in: mesh.triangles.len(),
        triangles_full: pm.triangles_at(pm.split_count()),
        base_triangles: pm.base_triangle_count(),
        vertex_splits: pm.split_count(),
        bytes,
        seconds: t0.elapsed().as_secs_f64(),
        stop_reason: report.stop_detail,
    };
    if a.json {
        out!("{}", serde_json::to_string(&r)?);
    } else {
        out!("{} -> {}  ({})", r.input, r.output, r.method);
        out!(
            "  triangles    {} in, {} after repair; base mesh {}",
            r.triangles_in,
            r.triangles_full,
            r.base_triangles
        );
        out!(
            "  splits       {} ({} bytes, {:.1} bytes per split)",
            r.vertex_splits,
            r.bytes,
            r.bytes as f64 / r.vertex_splits.max(1) as f64
        );
        out!("  base         {}", r.stop_reason);
        out!("  time         {:.3} s", r.seconds);
    }
    Ok(())
}

fn extract(a: &ExtractArgs) -> Result<()> {
    let t0 = Instant::now();
    let d = read_pmesh(&a.input)?;
    let pm = &d.pm;
    let full = pm.triangles_at(pm.split_count());
    let target = match (a.triangles, a.ratio) {
        (Some(n), _) => n,
        (None, Some(r)) => {
            if !(0.0..=1.0).contains(&r) {
                bail!("--ratio {r} is not in [0, 1]");
            }
            (full as f64 * r).round() as usize
        }
        (None, None) => bail!("give --triangles or --ratio"),
    };
    if !(0.0..=1.0).contains(&a.geomorph_ratio) {
        bail!("--geomorph-ratio {} is not in [0, 1]", a.geomorph_ratio);
    }
    let mut nav = Navigator::new(pm);
    let level = nav.set_triangles(target);
    let wo = WriteOptions::default().with_ascii(a.ascii);
    let (mesh, geomorph_level) = if let Some(g) = &a.geomorph {
        let coarse = pm
            .level_for_triangles((nav.triangle_count() as f64 * a.geomorph_ratio).round() as usize);
        let (mesh, morph) = nav.to_mesh_with_geomorph(coarse);
        let mut start = mesh.clone();
        start.positions = morph;
        meshlod::write_mesh(g, &start, &wo)?;
        (mesh, Some(coarse))
    } else {
        (nav.to_mesh(), None)
    };
    meshlod::write_mesh(&a.output, &mesh, &wo)?;
    let r = ExtractReport {
        input: a.input.display().to_string(),
        output: a.output.display().to_string(),
        splits_in_file: pm.split_count(),
        splits_in_header: d.splits_in_header,
        complete: d.complete,
        level,
        triangles: mesh.triangles.len(),
        vertices: mesh.positions.len(),
        geomorph: a.geomorph.as_ref().map(|g| g.display().to_string()),
        geomorph_level,
        seconds: t0.elapsed().as_secs_f64(),
    };
    if a.json {
        out!("{}", serde_json::to_string(&r)?);
    } else {
        out!("{} -> {}", r.input, r.output);
        if !r.complete {
            out!(
                "  note         the file holds {} of the {} splits its header announces (a prefix)",
                r.splits_in_file,
                r.splits_in_header
            );
        }
        out!(
            "  level        {} of {} splits: {} triangles, {} vertices",
            r.level,
            r.splits_in_file,
            r.triangles,
            r.vertices
        );
        if let (Some(g), Some(l)) = (&r.geomorph, r.geomorph_level) {
            out!("  geomorph     {g} (positions at level {l})");
        }
        out!("  time         {:.3} s", r.seconds);
    }
    Ok(())
}
