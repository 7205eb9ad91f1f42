//! `meshlod lod IN -o OUT [--levels N | --ratios R,R,…] [--pixel-error P]
//! [--screen-height H] [--fov DEG] [--method M] [--geomorph] [--json]`: a level of
//! detail chain with switch distances; `meshlod lod select FILE --camera X,Y,Z`:
//! which level each object of a chain file shows from a camera.
//!
//! A glTF scene written to glTF keeps its scene: each glTF mesh gets its own chain
//! (simplified once however many nodes draw it) and the levels are written with
//! the `MSFT_lod` extension (`meshlod::io::gltf::add_lods`). Any other input is
//! flattened into one mesh; written to glTF it becomes one mesh with `MSFT_lod`
//! levels, to any other format one file per level (`OUT-lod0.ply`, `OUT-lod1.ply`,
//! …).

use anyhow::{bail, Context, Result};
use meshlod::io::gltf::{add_lods, MeshLods};
use meshlod::io::{read_scene, write_scene, Format, Scene, WriteOptions};
use meshlod::lod::{build_chain, select, Chain, ChainOptions, LevelSpec, LodObject, Screen, View};
use meshlod::metrics::SamplingOptions;
use meshlod::simplify::{Method, SimplifyOptions};
use meshlod::Mesh;
use serde::Serialize;
use serde_json::{json, Value};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `meshlod lod`.
#[derive(Debug, clap::Args)]
#[command(
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true,
    allow_negative_numbers = true
)]
pub struct LodArgs {
    /// `select`: the level each object of a chain file shows from a camera.
    #[command(subcommand)]
    pub select: Option<LodCommand>,
    /// Input mesh or scene (.obj, .ply, .stl, .off, .gltf, .glb, .m).
    #[arg(required = true)]
    pub input: Option<PathBuf>,
    /// Output: a .gltf/.glb with the `MSFT_lod` extension, or for any other format
    /// one file per level (`OUT-lod0.ply`, `OUT-lod1.ply`, …).
    #[arg(short, long, required = true)]
    pub output: Option<PathBuf>,
    /// Number of levels after LOD0 (default 4), chosen by error: each about twice the previous
    /// level's error and at most half its triangles. The chain stops early when a
    /// level cannot halve the triangle count.
    #[arg(long, value_name = "N", conflicts_with = "ratios")]
    pub levels: Option<usize>,
    /// Levels as fractions of LOD0's triangles, strictly decreasing, e.g.
    /// `0.5,0.25,0.1`.
    #[arg(long, value_name = "R,R,…", value_delimiter = ',')]
    pub ratios: Option<Vec<f64>>,
    /// Largest error a level may show on screen, in pixels (sets the switch
    /// distances).
    #[arg(long, value_name = "P", default_value_t = 1.0)]
    pub pixel_error: f64,
    /// Screen height in pixels.
    #[arg(long, value_name = "PX", default_value_t = 1080.0)]
    pub screen_height: f64,
    /// Vertical field of view in degrees.
    #[arg(long, value_name = "DEG", default_value_t = 60.0)]
    pub fov: f64,
    /// Simplification method of each step.
    #[arg(long, value_enum, default_value_t = crate::simplify::MethodArg::Qem)]
    pub method: crate::simplify::MethodArg,
    /// Store on each coarser level the positions its vertices had in the next finer
    /// level, as a glTF morph target (weight 0: finer positions, 1: its own), so a
    /// renderer can blend between levels without popping.
    #[arg(long)]
    pub geomorph: bool,
    /// Samples per direction of each level's Hausdorff measurement against LOD0
    /// (default: 10 per triangle of the sampled mesh, at least 20,000, at most
    /// 2,000,000). `meshlod measure --samples N` with the same N reports the same
    /// distances.
    #[arg(long, value_name = "N")]
    pub samples: Option<usize>,
    /// Also write a PNG picture of the levels side by side, LOD0 first (same camera,
    /// iso view), each captioned with its level, triangles, error and switch
    /// distance.
    #[arg(long, value_name = "OUT.png")]
    pub preview: Option<PathBuf>,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

/// `meshlod lod` subcommands.
#[derive(Debug, clap::Subcommand)]
pub enum LodCommand {
    /// Print the level each object of a chain file (.gltf/.glb written by `meshlod
    /// lod`) shows from a camera.
    Select(SelectArgs),
}

/// Arguments of `meshlod lod select`.
#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct SelectArgs {
    /// A .gltf or .glb written by `meshlod lod`.
    pub file: PathBuf,
    /// Camera position in world units, `x,y,z`.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point)]
    pub camera: [f64; 3],
    /// Vertical field of view in degrees.
    #[arg(long, value_name = "DEG", default_value_t = 60.0)]
    pub fov: f64,
    /// Screen height in pixels.
    #[arg(long, value_name = "PX", default_value_t = 1080.0)]
    pub height: f64,
    /// Largest error shown, in pixels (default: the one the chain was built for).
    #[arg(long, value_name = "P")]
    pub pixel_error: Option<f64>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

/// `x,y,z` as three finite numbers.
pub(crate) fn parse_point(text: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> = text
        .split(',')
        .map(|t| t.trim().parse::<f64>().map_err(|e| format!("{t:?}: {e}")))
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([x, y, z]),
        _ => Err(format!("expected three finite numbers x,y,z, got {text:?}")),
    }
}

/// A level in the report.
#[derive(Debug, Serialize)]
struct LevelRow {
    level: usize,
    triangles: usize,
    vertices: usize,
    error_max: f64,
    error_mean: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    switch_distance: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    screen_coverage: Option<f64>,
}

/// One mesh's chain in the report.
#[derive(Debug, Serialize)]
struct MeshRow {
    name: String,
    instances: usize,
    levels: Vec<LevelRow>,
    #[serde(skip_serializing_if = "Option::is_none")]
    stopped_early: Option<String>,
    simplify_seconds: f64,
    measure_seconds: f64,
}

/// The JSON report of `meshlod lod`.
#[derive(Debug, Serialize)]
struct Report {
    input: String,
    outputs: Vec<String>,
    method: &'static str,
    pixel_error: f64,
    screen_height_px: f64,
    fov_degrees: f64,
    units: &'static str,
    /// The chain of a single mesh; for a scene, per level the totals over its
    /// meshes (a mesh with fewer levels counts its coarsest).
    levels: Vec<LevelRow>,
    meshes: Vec<MeshRow>,
    simplify_seconds: f64,
    measure_seconds: f64,
    seconds: f64,
    /// The LOD strip written (with --preview).
    #[serde(skip_serializing_if = "Option::is_none")]
    preview: Option<String>,
}

fn rows(chain: &Chain) -> Vec<LevelRow> {
    chain
        .levels
        .iter()
        .map(|l| LevelRow {
            level: l.level,
            triangles: l.triangles,
            vertices: l.vertices,
            error_max: l.error_max,
            error_mean: l.error_mean,
            switch_distance: Some(l.switch_distance),
            screen_coverage: Some(l.screen_coverage),
        })
        .collect()
}

fn options(args: &LodArgs) -> Result<ChainOptions> {
    let levels = match (&args.ratios, args.levels) {
        (Some(r), _) => LevelSpec::Ratios(r.clone()),
        (None, Some(n)) => LevelSpec::ByError(n),
        (None, None) => LevelSpec::ByError(4),
    };
    let method = match args.method {
        crate::simplify::MethodArg::Qem => Method::Qem,
        crate::simplify::MethodArg::Melax => Method::Melax,
        crate::simplify::MethodArg::VertexRemoval => Method::VertexRemoval,
        crate::simplify::MethodArg::Cluster => Method::Cluster,
    };
    if args.geomorph && method == Method::Cluster {
        bail!("--geomorph needs an edge-collapse or vertex-removal method, not cluster");
    }
    let screen = Screen {
        pixel_error: args.pixel_error,
        screen_height_px: args.screen_height,
        fov_degrees: args.fov,
        ..Screen::default()
    };
    screen.check()?;
    if args.samples == Some(0) {
        bail!("--samples must be at least 1");
    }
    Ok(ChainOptions {
        levels,
        simplify: SimplifyOptions::default().with_method(method),
        sampling: SamplingOptions {
            samples: args.samples,
            ..SamplingOptions::default()
        },
        screen,
        geomorph: args.geomorph,
    })
}

/// What `meshlod lod` stores in a mesh's `extras.meshlod_lod`.
fn chain_extras(chain: &Chain, screen: &Screen) -> Value {
    json!({
        "center": chain.center,
        "radius": chain.radius,
        "errors": chain.errors(),
        "error_max": chain.levels.iter().map(|l| l.error_max).collect::<Vec<_>>(),
        "error_mean": chain.levels.iter().map(|l| l.error_mean).collect::<Vec<_>>(),
        "triangles": chain.levels.iter().map(|l| l.triangles).collect::<Vec<_>>(),
        "switch_distances": chain.levels.iter().map(|l| l.switch_distance).collect::<Vec<_>>(),
        "pixel_error": screen.pixel_error,
        "screen_height_px": screen.screen_height_px,
        "fov_degrees": screen.fov_degrees,
    })
}

fn mesh_lods(part: usize, chain: &Chain, screen: &Screen) -> MeshLods {
    MeshLods {
        part,
        levels: chain.levels[1..].iter().map(|l| l.mesh.clone()).collect(),
        morph_from: chain.levels[1..]
            .iter()
            .map(|l| l.morph_from.clone())
            .collect(),
        coverage: chain.coverages(),
        extras: chain_extras(chain, screen),
    }
}

/// `OUT-lodK.ext` beside `OUT`.
fn level_path(out: &Path, k: usize) -> PathBuf {
    let stem = out
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    let ext = out
        .extension()
        .map_or_else(String::new, |e| e.to_string_lossy().into_owned());
    out.with_file_name(format!("{stem}-lod{k}.{ext}"))
}

/// Prints a level as it is made, when a person watches stderr.
fn progress(name: &str, chain: &Chain) {
    if !std::io::stderr().is_terminal() {
        return;
    }
    for l in &chain.levels[1..] {
        eprintln!(
            "{name}: LOD{} {} triangles, error {:.4e} ({:.2} s)",
            l.level, l.triangles, l.error_max, l.seconds
        );
    }
}

/// Runs `meshlod lod`.
pub fn run(args: &LodArgs) -> Result<()> {
    if let Some(LodCommand::Select(s)) = &args.select {
        return run_select(s);
    }
    let (Some(input), Some(output)) = (&args.input, &args.output) else {
        bail!("meshlod lod needs an input and -o OUTPUT");
    };
    let start = Instant::now();
    let opts = options(args)?;
    let out_format = Format::from_path(output)
        .with_context(|| format!("{}: unknown output format", output.display()))?;
    let is_gltf = |f: Option<Format>| matches!(f, Some(Format::Gltf | Format::Glb));
    let scene = read_scene(input)?;
    for part in &scene.parts {
        if crate::warn_precision(input, &part.mesh) {
            break;
        }
    }
    let per_part =
        is_gltf(Format::from_path(input)) && is_gltf(Some(out_format)) && scene.gltf.is_some();
    let mut meshes = Vec::new();
    let mut outputs = Vec::new();
    // With --preview: the levels to draw, LOD0 first.
    let mut strip: Vec<Mesh> = Vec::new();
    if per_part {
        let mut chains = Vec::new();
        let mut out = scene.clone();
        let mut lods = Vec::new();
        for (i, part) in scene.parts.iter().enumerate() {
            let name = part.name.clone().unwrap_or_else(|| format!("mesh {i}"));
            if part.mesh.triangles.is_empty() {
                continue;
            }
            let chain = build_chain(&part.mesh, &opts).with_context(|| name.clone())?;
            progress(&name, &chain);
            if chain.levels.len() > 1 {
                lods.push(mesh_lods(i, &chain, &opts.screen));
            }
            meshes.push(mesh_row(name, part.instances.len(), &chain));
            if args.preview.is_some() {
                chains.push((i, chain));
            }
        }
        if args.preview.is_some() {
            strip = scene_levels(&scene, &chains);
        }
        add_lods(&mut out, lods).with_context(|| format!("{}", output.display()))?;
        write_scene(output, &out, &WriteOptions::default())?;
        outputs.push(output.display().to_string());
    } else {
        let mesh = scene.flattened().into_owned();
        let name = input.display().to_string();
        let chain = build_chain(&mesh, &opts).with_context(|| name.clone())?;
        progress(&name, &chain);
        if args.preview.is_some() {
            strip = chain.levels.iter().map(|l| l.mesh.clone()).collect();
        }
        if is_gltf(Some(out_format)) {
            let mut out = Scene::from_mesh(mesh);
            out.material_libraries = scene.material_libraries.clone();
            if chain.levels.len() > 1 {
                add_lods(&mut out, vec![mesh_lods(0, &chain, &opts.screen)])
                    .with_context(|| format!("{}", output.display()))?;
            }
            write_scene(output, &out, &WriteOptions::default())?;
            outputs.push(output.display().to_string());
        } else {
            for l in &chain.levels {
                let path = level_path(output, l.level);
                let mut s = Scene::from_mesh(l.mesh.clone());
                s.material_libraries = scene.material_libraries.clone();
                write_scene(&path, &s, &WriteOptions::default())?;
                outputs.push(path.display().to_string());
            }
        }
        meshes.push(mesh_row(name, 1, &chain));
    }
    let levels = totals(&meshes);
    if let Some(p) = &args.preview {
        write_strip(p, &strip, &levels)?;
    }
    let report = Report {
        input: input.display().to_string(),
        outputs,
        method: opts.simplify.method.name(),
        pixel_error: opts.screen.pixel_error,
        screen_height_px: opts.screen.screen_height_px,
        fov_degrees: opts.screen.fov_degrees,
        units: "errors and distances in mesh units (each mesh's own, before its node transforms)",
        levels,
        simplify_seconds: meshes.iter().map(|m| m.simplify_seconds).sum(),
        measure_seconds: meshes.iter().map(|m| m.measure_seconds).sum(),
        meshes,
        seconds: start.elapsed().as_secs_f64(),
        preview: args.preview.as_ref().map(|p| p.display().to_string()),
    };
    if args.json {
        out!("{}", serde_json::to_string(&report)?);
    } else {
        print_text(&report);
    }
    Ok(())
}

/// Each level of a scene whose parts have chains (`(part, chain)`), flattened: a
/// part shows its own level, or its coarsest when it has fewer; parts without a
/// chain show themselves.
fn scene_levels(scene: &Scene, chains: &[(usize, Chain)]) -> Vec<Mesh> {
    let n = chains
        .iter()
        .map(|(_, c)| c.levels.len())
        .max()
        .unwrap_or(1);
    (0..n)
        .map(|k| {
            let mut s = Scene {
                parts: scene.parts.clone(),
                ..Scene::default()
            };
            for (i, c) in chains {
                if let (Some(part), Some(level)) =
                    (s.parts.get_mut(*i), c.levels.get(k).or(c.levels.last()))
                {
                    part.mesh = level.mesh.clone();
                }
            }
            s.flatten()
        })
        .collect()
}

/// `--preview`: the levels side by side, captioned with the report's rows.
fn write_strip(path: &Path, levels: &[Mesh], rows: &[LevelRow]) -> Result<()> {
    use crate::preview::{percent, thousands};
    let diagonal = levels.first().map_or(0.0, Mesh::bbox_diagonal);
    let panels: Vec<(&Mesh, Vec<String>)> = levels
        .iter()
        .zip(rows)
        .map(|(m, r)| {
            let mut second = format!("error {}", percent(r.error_max, diagonal));
            match r.switch_distance {
                _ if r.level == 0 => second = "the input".to_string(),
                Some(d) => second.push_str(&format!(", switch {}", meshlod::render::sig3(d))),
                None => {}
            }
            (
                m,
                vec![
                    format!(
                        "LOD{}  {} triangles",
                        r.level,
                        thousands(m.triangle_count())
                    ),
                    second,
                ],
            )
        })
        .collect();
    crate::preview::write(path, &panels)
}

fn mesh_row(name: String, instances: usize, chain: &Chain) -> MeshRow {
    MeshRow {
        name,
        instances,
        levels: rows(chain),
        stopped_early: chain.stopped_early.clone(),
        simplify_seconds: chain.simplify_seconds,
        measure_seconds: chain.measure_seconds,
    }
}

/// The levels of a one-mesh report, or per level the totals over a scene's meshes.
fn totals(meshes: &[MeshRow]) -> Vec<LevelRow> {
    if let [one] = meshes {
        return one
            .levels
            .iter()
            .map(|l| LevelRow {
                switch_distance: l.switch_distance,
                screen_coverage: l.screen_coverage,
                ..*l
            })
            .collect();
    }
    let n = meshes.iter().map(|m| m.levels.len()).max().unwrap_or(0);
    (0..n)
        .map(|k| {
            let mut row = LevelRow {
                level: k,
                triangles: 0,
                vertices: 0,
                error_max: 0.0,
                error_mean: 0.0,
                switch_distance: None,
                screen_coverage: None,
            };
            for m in meshes {
                if let Some(l) = m.levels.get(k).or(m.levels.last()) {
                    row.triangles += l.triangles * m.instances.max(1);
                    row.vertices += l.vertices * m.instances.max(1);
                    row.error_max = row.error_max.max(l.error_max);
                    row.error_mean = row.error_mean.max(l.error_mean);
                }
            }
            row
        })
        .collect()
}

fn print_text(r: &Report) {
    out!("{} -> {}", r.input, r.outputs.join(", "));
    out!(
        "switch distances for {} px of error on a {} px high screen, {}° field of view",
        r.pixel_error,
        r.screen_height_px,
        r.fov_degrees
    );
    for m in &r.meshes {
        if r.meshes.len() > 1 {
            out!("{} ({} instances)", m.name, m.instances);
        }
        out!(
            "{:>5}{:>12}{:>11}{:>14}{:>14}{:>16}{:>12}",
            "level",
            "triangles",
            "vertices",
            "error max",
            "error mean",
            "switch dist",
            "coverage"
        );
        for l in &m.levels {
            out!(
                "{:>5}{:>12}{:>11}{:>14.4e}{:>14.4e}{:>16.4e}{:>12.4e}",
                l.level,
                l.triangles,
                l.vertices,
                l.error_max,
                l.error_mean,
                l.switch_distance.unwrap_or(0.0),
                l.screen_coverage.unwrap_or(1.0)
            );
        }
        if let Some(why) = &m.stopped_early {
            out!("  stopped early: {why}");
        }
    }
    if let Some(p) = &r.preview {
        out!("preview: {p} (the levels side by side)");
    }
    out!(
        "simplify {:.2} s, measure {:.2} s, total {:.2} s",
        r.simplify_seconds,
        r.measure_seconds,
        r.seconds
    );
}

/// One object's selection in `meshlod lod select`.
#[derive(Debug, Serialize)]
struct Selected {
    mesh: String,
    instance: usize,
    distance: f64,
    level: usize,
    levels: usize,
    pixels: f64,
}

fn number_list(v: &Value, key: &str) -> Option<Vec<f64>> {
    v.get(key)?.as_array()?.iter().map(Value::as_f64).collect()
}

fn run_select(args: &SelectArgs) -> Result<()> {
    let scene = read_scene(&args.file)?;
    let Some(doc) = scene.gltf.as_ref().map(|g| g.document()) else {
        bail!(
            "{}: not a glTF chain file (write one with `meshlod lod IN -o OUT.glb`)",
            args.file.display()
        );
    };
    let camera = args.camera;
    let mut out = Vec::new();
    for (i, part) in scene.parts.iter().enumerate() {
        let Some(info) = doc
            .get("meshes")
            .and_then(|m| m.get(i))
            .and_then(|m| m.get("extras"))
            .and_then(|e| e.get("meshlod_lod"))
        else {
            continue;
        };
        let (Some(center), Some(errors), Some(radius)) = (
            number_list(info, "center"),
            number_list(info, "errors"),
            info.get("radius").and_then(Value::as_f64),
        ) else {
            bail!(
                "{}: mesh {i}: malformed extras.meshlod_lod",
                args.file.display()
            );
        };
        let [cx, cy, cz] = center[..] else {
            bail!(
                "{}: mesh {i}: extras.meshlod_lod.center is not 3 numbers",
                args.file.display()
            );
        };
        let pixel_error = args
            .pixel_error
            .or_else(|| info.get("pixel_error").and_then(Value::as_f64))
            .unwrap_or(1.0);
        let view = View {
            position: camera,
            screen: Screen {
                pixel_error,
                screen_height_px: args.height,
                fov_degrees: args.fov,
                ..Screen::default()
            },
        };
        view.screen.check()?;
        let object = LodObject::new([cx, cy, cz], radius, errors);
        let name = part.name.clone().unwrap_or_else(|| format!("mesh {i}"));
        for (j, m) in part.instances.iter().enumerate() {
            let placed = object.placed(m);
            let level = select(std::slice::from_ref(&placed), &view)[0];
            let d = (0..3)
                .map(|k| (placed.center[k] - camera[k]).powi(2))
                .sum::<f64>()
                .sqrt();
            out.push(Selected {
                mesh: name.clone(),
                instance: j,
                distance: d,
                level,
                levels: placed.errors.len(),
                pixels: view.screen.pixels(placed.errors[level], d),
            });
        }
    }
    if out.is_empty() {
        bail!(
            "{}: no mesh has levels of detail written by `meshlod lod`",
            args.file.display()
        );
    }
    if args.json {
        out!(
            "{}",
            serde_json::to_string(
                &json!({ "file": args.file.display().to_string(), "objects": out })
            )?
        );
    } else {
        out!(
            "{:<24}{:>9}{:>14}{:>7}{:>12}",
            "mesh",
            "instance",
            "distance",
            "level",
            "error px"
        );
        for s in &out {
            out!(
                "{:<24}{:>9}{:>14.4}{:>7}{:>12.3}",
                s.mesh,
                s.instance,
                s.distance,
                format!("{}/{}", s.level, s.levels - 1),
                s.pixels
            );
        }
    }
    Ok(())
}
