//! `meshlod view IN [IN2 ...] -o page.html [--heatmap-vs REF]`: one self-contained
//! HTML page (WebGL, no network) showing the inputs as switchable levels; a glTF
//! written by `meshlod lod` (levels in `MSFT_lod`) gives one level per LOD.

use anyhow::{bail, Context, Result};
use meshlod::metrics::bvh::Bvh;
use meshlod::render::viewer::{page, payload_bytes, PageLevel, PageOptions};
use meshlod::render::{self, HeatScale};
use meshlod::{Mesh, Scene};
use serde::Serialize;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Total triangles above which `view` warns that the page will be large and slow.
const WARN_TRIANGLES: usize = 1_000_000;

/// Arguments of `meshlod view`.
#[derive(Debug, clap::Args)]
pub struct ViewArgs {
    /// Meshes to show, as levels the page switches between (LOD0 first); a glTF
    /// written by `meshlod lod` gives each of its levels.
    #[arg(required = true, num_args = 1..)]
    pub inputs: Vec<PathBuf>,
    /// The HTML file to write.
    #[arg(short, long, value_name = "PAGE.html")]
    pub output: PathBuf,
    /// Colour each level by its vertices' distance to this reference mesh (viridis,
    /// one scale for every level; toggled with H in the page).
    #[arg(long, value_name = "REF")]
    pub heatmap_vs: Option<PathBuf>,
    /// Refuse inputs with more triangles than this in all (the page embeds every
    /// level; above a million it is slow to open). Simplify first, or raise it.
    #[arg(long, value_name = "N", default_value_t = 4_000_000)]
    pub max_triangles: usize,
    /// The page's title (default: the first input's file name).
    #[arg(long)]
    pub title: Option<String>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct LevelReport {
    label: String,
    input: String,
    triangles: usize,
    vertices: usize,
}

#[derive(Serialize)]
struct Report {
    output: String,
    bytes: usize,
    levels: Vec<LevelReport>,
    #[serde(skip_serializing_if = "Option::is_none")]
    heatmap_max: Option<f64>,
}

/// A level read from the inputs: its mesh, label, source file and info line.
struct Level {
    mesh: Mesh,
    label: String,
    input: String,
    info: String,
}

/// The levels of a glTF scene whose nodes carry `MSFT_lod` (as `meshlod lod`
/// writes them): level k draws, for each node with levels, its k-th level's mesh
/// (or its coarsest), the other parts as they are. `None` without `MSFT_lod`.
fn gltf_levels(scene: &Scene) -> Option<Vec<(Mesh, Option<&Value>)>> {
    let doc = scene.gltf.as_ref()?.document();
    let nodes = doc.get("nodes")?.as_array()?;
    let mut lods: Vec<(usize, Vec<usize>)> = Vec::new();
    for node in nodes {
        let (Some(mesh), Some(ids)) = (
            node.get("mesh").and_then(Value::as_u64),
            node.pointer("/extensions/MSFT_lod/ids")
                .and_then(Value::as_array),
        ) else {
            continue;
        };
        let meshes: Option<Vec<usize>> = ids
            .iter()
            .map(|id| {
                let m = nodes.get(id.as_u64()? as usize)?.get("mesh")?.as_u64()?;
                Some(m as usize).filter(|&m| m < scene.parts.len())
            })
            .collect();
        if let Some(meshes) = meshes.filter(|m| !m.is_empty()) {
            if (mesh as usize) < scene.parts.len() && !lods.iter().any(|(p, _)| *p == mesh as usize)
            {
                lods.push((mesh as usize, meshes));
            }
        }
    }
    if lods.is_empty() {
        return None;
    }
    let n = 1 + lods.iter().map(|(_, l)| l.len()).max().unwrap_or(0);
    let extras = |part: usize| {
        doc.get("meshes")?
            .as_array()?
            .get(part)?
            .pointer("/extras/meshlod_lod")
    };
    let single = if lods.len() == 1 {
        extras(lods[0].0)
    } else {
        None
    };
    Some(
        (0..n)
            .map(|k| {
                let mut s = Scene {
                    parts: scene.parts.clone(),
                    ..Scene::default()
                };
                if k > 0 {
                    for (part, levels) in &lods {
                        let from = levels[(k - 1).min(levels.len() - 1)];
                        s.parts[*part].mesh = scene.parts[from].mesh.clone();
                    }
                }
                (s.flatten(), single)
            })
            .collect(),
    )
}

/// Reads the inputs into levels.
fn read_levels(args: &ViewArgs) -> Result<Vec<Level>> {
    let mut levels = Vec::new();
    for path in &args.inputs {
        let scene = meshlod::read_scene(path)
            .with_context(|| format!("{}: cannot read", path.display()))?;
        let name = crate::preview::file_name(path);
        if let Some(lods) = gltf_levels(&scene) {
            for (k, (mesh, extras)) in lods.into_iter().enumerate() {
                let mut info = format!(
                    "{name} LOD{k}: {} triangles",
                    crate::preview::thousands(mesh.triangle_count())
                );
                let pick = |key: &str| {
                    extras
                        .and_then(|e| e.get(key))
                        .and_then(|v| v.get(k))
                        .and_then(Value::as_f64)
                };
                if let (Some(e), Some(d)) = (pick("error_max"), pick("switch_distances")) {
                    info.push_str(&format!(
                        ", error {} units, switch distance {}",
                        render::sig3(e),
                        render::sig3(d)
                    ));
                }
                levels.push(Level {
                    mesh,
                    label: format!("LOD{k}"),
                    input: path.display().to_string(),
                    info,
                });
            }
        } else {
            let mesh = crate::textures::into_mesh(scene);
            crate::warn_precision(path, &mesh);
            let label = name.clone();
            levels.push(Level {
                info: format!(
                    "{name}: {} triangles, {} vertices",
                    crate::preview::thousands(mesh.triangle_count()),
                    crate::preview::thousands(mesh.vertex_count())
                ),
                mesh,
                label,
                input: path.display().to_string(),
            });
        }
    }
    Ok(levels)
}

/// Runs `meshlod view`.
///
/// # Errors
/// An unreadable input or reference, too many triangles, or the page cannot be
/// written.
pub fn run(args: &ViewArgs) -> Result<()> {
    let levels = read_levels(args)?;
    let total: usize = levels.iter().map(|l| l.mesh.triangle_count()).sum();
    if total > args.max_triangles {
        bail!(
            "{total} triangles in all is more than --max-triangles {}: the page would embed about {} MB. \
             Show fewer or simplified levels (e.g. `meshlod simplify IN -o small.ply --triangles 500000`), \
             or raise --max-triangles",
            args.max_triangles,
            (total * 24) >> 20
        );
    }
    if total > WARN_TRIANGLES {
        eprintln!(
            "meshlod: warning: {total} triangles in all: the page will be large and slow to open; \
             `meshlod simplify IN -o small.ply --triangles 500000` gives a lighter one"
        );
    }
    let mut heat = None;
    let mut values: Vec<Vec<f32>> = Vec::new();
    if let Some(r) = &args.heatmap_vs {
        let reference = meshlod::read_scene(r)
            .with_context(|| format!("{}: cannot read", r.display()))?
            .flatten();
        if reference.triangles.is_empty() {
            bail!("{}: the reference has no triangles", r.display());
        }
        let bvh = Bvh::build(&reference.positions, &reference.triangles);
        values = levels
            .iter()
            .map(|l| render::heat_values(&l.mesh, &bvh))
            .collect();
        let max = values
            .iter()
            .flatten()
            .filter(|v| v.is_finite())
            .fold(0.0f32, |a, &b| a.max(b));
        heat = Some((
            HeatScale {
                max: f64::from(max),
                diagonal: reference.bbox_diagonal(),
            },
            crate::preview::file_name(r),
        ));
    }
    let page_levels: Vec<PageLevel> = levels
        .iter()
        .enumerate()
        .map(|(i, l)| PageLevel {
            mesh: &l.mesh,
            label: &l.label,
            info: &l.info,
            heat: values.get(i).map(Vec::as_slice),
        })
        .collect();
    let opts = PageOptions {
        title: args
            .title
            .clone()
            .unwrap_or_else(|| crate::preview::file_name(&args.inputs[0])),
        heat: heat.clone(),
    };
    let bytes_in = payload_bytes(&page_levels);
    let html = page(&page_levels, &opts).context("cannot make the page")?;
    write(&args.output, &html)?;
    let report = Report {
        output: args.output.display().to_string(),
        bytes: html.len(),
        levels: levels
            .iter()
            .map(|l| LevelReport {
                label: l.label.clone(),
                input: l.input.clone(),
                triangles: l.mesh.triangle_count(),
                vertices: l.mesh.vertex_count(),
            })
            .collect(),
        heatmap_max: heat.map(|h| h.0.max),
    };
    if args.json {
        out!("{}", serde_json::to_string(&report)?);
    } else {
        out!(
            "wrote {} ({:.1} MB, {:.1} MB of mesh data)",
            report.output,
            report.bytes as f64 / 1e6,
            bytes_in as f64 / 1e6
        );
        for l in &report.levels {
            out!(
                "  {}: {} triangles ({})",
                l.label,
                crate::preview::thousands(l.triangles),
                l.input
            );
        }
    }
    Ok(())
}

fn write(path: &Path, html: &str) -> Result<()> {
    std::fs::write(path, html).with_context(|| format!("{}: cannot write the page", path.display()))
}
