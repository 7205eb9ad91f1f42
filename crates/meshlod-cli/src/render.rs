//! `meshlod render IN [IN2 ...] -o out.png`: pictures of meshes, side by side, with
//! an optional wireframe and a heat map of the distance to a reference.

use crate::memory::{MemoryReport, Phases};
use anyhow::{bail, Context, Result};
use meshlod::metrics::bvh::Bvh;
use meshlod::render::{self, Canvas, HeatScale, RenderOptions, Shading, Texture, View, MAX_SIZE};
use meshlod::Mesh;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `meshlod render`.
#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct RenderArgs {
    /// Meshes to draw, side by side in equal panels, all framed on the first one's
    /// bounding box so their sizes compare.
    #[arg(required = true, num_args = 1..)]
    pub inputs: Vec<PathBuf>,
    /// The PNG file to write.
    #[arg(short, long, value_name = "OUT.png")]
    pub output: PathBuf,
    /// Picture width in pixels (1 to 16384), shared by the panels.
    #[arg(long, default_value_t = 1024)]
    pub width: u32,
    /// Picture height in pixels (1 to 16384).
    #[arg(long, default_value_t = 768)]
    pub height: u32,
    /// Where the camera looks from: front (along −z), top (down −y), iso (from
    /// (1,1,1)), or a viewing direction x,y,z.
    #[arg(long, default_value = "front", value_name = "front|top|iso|x,y,z")]
    pub view: String,
    /// Draw the triangles' edges over the surface.
    #[arg(long)]
    pub wireframe: bool,
    /// Flat (facets show) or smooth (vertex normals) shading.
    #[arg(long, value_enum, default_value = "flat")]
    pub shading: ShadingArg,
    /// Colour each input by its vertices' distance to this reference mesh (viridis,
    /// one scale for all panels, with a legend in mesh units and % of the
    /// reference's bounding-box diagonal).
    #[arg(long, value_name = "REF")]
    pub heatmap_vs: Option<PathBuf>,
    /// Colour every input with this PNG texture (at its UVs) instead of the
    /// textures its materials name (OBJ `map_Kd`, glTF base colour).
    #[arg(long, value_name = "IMAGE.png", conflicts_with = "no_textures")]
    pub texture: Option<PathBuf>,
    /// Draw without textures even when the inputs' materials have them.
    #[arg(long)]
    pub no_textures: bool,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

/// `--shading` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ShadingArg {
    /// One normal per triangle.
    Flat,
    /// Interpolated vertex normals.
    Smooth,
}

#[derive(Serialize)]
struct PanelReport {
    input: String,
    triangles: usize,
    vertices: usize,
    covered_pixels: usize,
    /// Seconds to read the file.
    read_seconds: f64,
    /// Seconds to draw the panel (and compute its heat-map distances).
    seconds: f64,
    /// Resident memory: the peak, after reading this input, and the drawing's peak
    /// above that per triangle (Linux only).
    #[serde(skip_serializing_if = "Option::is_none")]
    memory: Option<MemoryReport>,
}

#[derive(Serialize)]
struct HeatReport {
    reference: String,
    max: f64,
    units: &'static str,
    percent_of_diagonal: f64,
    reference_diagonal: f64,
}

#[derive(Serialize)]
struct Report {
    output: String,
    width: u32,
    height: u32,
    view: String,
    shading: &'static str,
    wireframe: bool,
    panels: Vec<PanelReport>,
    #[serde(skip_serializing_if = "Option::is_none")]
    heatmap: Option<HeatReport>,
    seconds: f64,
}

fn label(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// Reads `path` with its textures (none when `plain`), timed.
fn read(path: &Path, plain: bool) -> Result<(Mesh, Vec<Option<Texture>>, f64)> {
    let t = Instant::now();
    let (m, tex) = crate::textures::read(path, plain)?;
    crate::warn_precision(path, &m);
    Ok((m, tex, t.elapsed().as_secs_f64()))
}

/// The textures to draw `mesh` with: `forced` on every group, or its own.
fn pick(forced: Option<&Texture>, mesh: &Mesh, own: Vec<Option<Texture>>) -> Vec<Option<Texture>> {
    match forced {
        None => own,
        Some(t) => {
            let groups = mesh
                .groups
                .as_ref()
                .and_then(|g| g.iter().max())
                .map_or(1, |&g| g as usize + 1);
            vec![Some(t.clone()); groups]
        }
    }
}

fn panel_report(
    path: &Path,
    m: &Mesh,
    s: render::PanelStats,
    read: f64,
    t: Instant,
    phases: Option<Phases>,
) -> PanelReport {
    PanelReport {
        memory: phases.and_then(|p| p.report(s.triangles)),
        input: path.display().to_string(),
        triangles: s.triangles,
        vertices: m.vertex_count(),
        covered_pixels: s.covered_pixels,
        read_seconds: read,
        seconds: t.elapsed().as_secs_f64(),
    }
}

/// Reads the inputs, draws them and writes the picture.
///
/// # Errors
/// A size out of range, an unknown view, an unreadable input or reference, or the
/// PNG cannot be written.
pub fn run(args: &RenderArgs) -> Result<()> {
    let t0 = Instant::now();
    if !(1..=MAX_SIZE).contains(&args.width) || !(1..=MAX_SIZE).contains(&args.height) {
        bail!(
            "--width {} --height {}: each must be 1 to {MAX_SIZE} pixels",
            args.width,
            args.height
        );
    }
    if args.inputs.len() > args.width as usize {
        bail!(
            "{} inputs do not fit side by side in {} pixels; raise --width",
            args.inputs.len(),
            args.width
        );
    }
    let view: View = args.view.parse()?;
    let opts = RenderOptions {
        width: args.width,
        height: args.height,
        view,
        shading: match args.shading {
            ShadingArg::Flat => Shading::Flat,
            ShadingArg::Smooth => Shading::Smooth,
        },
        wireframe: args.wireframe,
        caption_lines: 1,
    };
    let (panels, heatmap) = match &args.heatmap_vs {
        None => (draw_streaming(args, &opts)?, None),
        Some(r) => draw_heatmap(args, &opts, r)?,
    };
    let report = Report {
        output: args.output.display().to_string(),
        width: args.width,
        height: args.height,
        view: view.to_string(),
        shading: match opts.shading {
            Shading::Flat => "flat",
            Shading::Smooth => "smooth",
        },
        wireframe: args.wireframe,
        panels,
        heatmap,
        seconds: t0.elapsed().as_secs_f64(),
    };
    print_report(&report, args.json)
}

/// Without a heat map: each input is read, drawn and dropped in turn, so one mesh
/// is in memory at a time.
fn draw_streaming(args: &RenderArgs, opts: &RenderOptions) -> Result<Vec<PanelReport>> {
    let forced = forced_texture(args)?;
    let mut canvas: Option<Canvas> = None;
    let mut panels = Vec::new();
    for (i, path) in args.inputs.iter().enumerate() {
        let (mesh, own, read_s) = read(path, args.no_textures || forced.is_some())?;
        let tex = pick(forced.as_ref(), &mesh, own);
        let phases = Phases::after_read();
        let c = match canvas.as_mut() {
            Some(c) => c,
            None => canvas.insert(Canvas::new(
                opts,
                args.inputs.len(),
                render::frame_of(Some(&mesh)),
                None,
            )?),
        };
        let t = Instant::now();
        let s = c
            .draw_with(i, &mesh, None, &tex, &label(path))
            .with_context(|| format!("{}: cannot draw", path.display()))?;
        panels.push(panel_report(path, &mesh, s, read_s, t, Some(phases)));
    }
    let image = canvas.context("no input")?.finish();
    image
        .write_png(&args.output)
        .with_context(|| format!("{}: cannot write the picture", args.output.display()))?;
    Ok(panels)
}

/// The `--texture` image, decoded.
fn forced_texture(args: &RenderArgs) -> Result<Option<Texture>> {
    let Some(p) = &args.texture else {
        return Ok(None);
    };
    let bytes = std::fs::read(p).with_context(|| format!("{}: cannot read", p.display()))?;
    Ok(Some(Texture::from_png(&bytes).with_context(|| {
        format!("{}: not a usable PNG", p.display())
    })?))
}

/// With a heat map: every input's distances are measured first (the scale is
/// their largest), then the panels drawn.
fn draw_heatmap(
    args: &RenderArgs,
    opts: &RenderOptions,
    reference: &Path,
) -> Result<(Vec<PanelReport>, Option<HeatReport>)> {
    let (r, _, _) = read(reference, true)?;
    if r.triangles.is_empty() {
        bail!("{}: the reference has no triangles", reference.display());
    }
    let bvh = Bvh::build(&r.positions, &r.triangles);
    let diagonal = r.bbox_diagonal();
    drop(r);
    let mut meshes = Vec::new();
    for path in &args.inputs {
        let (m, _, read_s) = read(path, true)?;
        let t = Instant::now();
        let v = render::heat_values(&m, &bvh);
        meshes.push((m, v, read_s, t.elapsed().as_secs_f64()));
    }
    drop(bvh);
    let max = meshes
        .iter()
        .flat_map(|(_, v, _, _)| v.iter())
        .filter(|d| d.is_finite())
        .fold(0.0f32, |a, &b| a.max(b));
    let scale = HeatScale {
        max: f64::from(max),
        diagonal,
    };
    let frame = render::frame_of(meshes.first().map(|m| &m.0));
    let mut canvas = Canvas::new(opts, meshes.len(), frame, Some(scale))?;
    let mut panels = Vec::new();
    for (i, (path, (m, v, read_s, dist_s))) in args.inputs.iter().zip(&meshes).enumerate() {
        let t = Instant::now();
        let s = canvas
            .draw(i, m, Some(v), &label(path))
            .with_context(|| format!("{}: cannot draw", path.display()))?;
        let mut p = panel_report(path, m, s, *read_s, t, None);
        p.seconds += dist_s;
        panels.push(p);
    }
    canvas
        .finish()
        .write_png(&args.output)
        .with_context(|| format!("{}: cannot write the picture", args.output.display()))?;
    let heat = HeatReport {
        reference: reference.display().to_string(),
        max: scale.max,
        units: "mesh units",
        percent_of_diagonal: if diagonal > 0.0 {
            100.0 * scale.max / diagonal
        } else {
            0.0
        },
        reference_diagonal: diagonal,
    };
    Ok((panels, Some(heat)))
}

fn print_report(r: &Report, json: bool) -> Result<()> {
    if json {
        out!("{}", serde_json::to_string(r)?);
        return Ok(());
    }
    out!(
        "wrote {} ({}x{}, view {})",
        r.output,
        r.width,
        r.height,
        r.view
    );
    for p in &r.panels {
        out!(
            "  {}: {} triangles, drawn in {:.3} s (read in {:.3} s)",
            p.input,
            p.triangles,
            p.seconds,
            p.read_seconds
        );
    }
    if let Some(h) = &r.heatmap {
        out!(
            "  heat map vs {}: 0 to {} mesh units ({}% of its bounding-box diagonal)",
            h.reference,
            render::sig3(h.max),
            render::sig3(h.percent_of_diagonal)
        );
    }
    out!("time: {:.3} s", r.seconds);
    Ok(())
}
