//! `meshlod impostor IN -o out.glb [--views N] [--size PX]`: the object drawn from
//! N directions into an RGBA atlas (octahedral layout, alpha = coverage), written
//! as a GLB quad textured with the atlas, the layout in the node's extras
//! (`meshlod::render::impostor`).

use anyhow::{bail, Context, Result};
use meshlod::io::Format;
use meshlod::lod::Screen;
use meshlod::render::impostor::{build_impostor, impostor_glb, ImpostorOptions};
use meshlod::render::{Shading, MAX_SIZE};
use serde::Serialize;
use serde_json::json;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `meshlod impostor`.
#[derive(Debug, clap::Args)]
pub struct ImpostorArgs {
    /// The detailed object (.obj .ply .stl .off .gltf .glb .m); a scene is flattened.
    pub input: PathBuf,
    /// The GLB file to write.
    #[arg(short, long, value_name = "OUT.glb")]
    pub output: PathBuf,
    /// Number of views, a square (1, 4, 9, 16, …): an octahedral atlas of √N × √N
    /// tiles; 1 is a single front view.
    #[arg(long, value_name = "N", default_value_t = 64)]
    pub views: u32,
    /// Side of the atlas in pixels (each tile is size / √N).
    #[arg(long, value_name = "PX", default_value_t = 1024)]
    pub size: u32,
    /// Flat or smooth shading of the pictures.
    #[arg(long, value_enum, default_value = "smooth")]
    pub shading: crate::render::ShadingArg,
    /// Also write the atlas as a PNG file.
    #[arg(long, value_name = "ATLAS.png")]
    pub atlas: Option<PathBuf>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct Report {
    input: String,
    output: String,
    triangles: usize,
    views: u32,
    grid: u32,
    tile_px: u32,
    atlas_px: u32,
    radius: f64,
    texel: f64,
    min_distance: f64,
    covered_fraction: f64,
    bytes: usize,
    seconds: f64,
}

/// Runs `meshlod impostor`.
///
/// # Errors
/// A view count that is not a square, a size out of range, an unreadable input or
/// an unwritable output.
pub fn run(args: &ImpostorArgs) -> Result<()> {
    let t0 = Instant::now();
    let grid = (f64::from(args.views).sqrt().round()) as u32;
    if args.views == 0 || grid * grid != args.views {
        bail!(
            "--views {}: give a square number of views (1, 4, 9, 16, 25, 36, 49, 64, …): the atlas is √N × √N tiles",
            args.views
        );
    }
    if !(grid..=MAX_SIZE).contains(&args.size) {
        bail!(
            "--size {}: give {grid} to {MAX_SIZE} pixels (at least one pixel per tile)",
            args.size
        );
    }
    if Format::from_path(&args.output) != Some(Format::Glb) {
        bail!("{}: the impostor is written as .glb", args.output.display());
    }
    let (mesh, textures) = crate::textures::read(&args.input, false)?;
    crate::warn_precision(&args.input, &mesh);
    if mesh.triangles.is_empty() {
        bail!("{}: no triangles to draw", args.input.display());
    }
    let tile = args.size / grid;
    let samples = (4).min(MAX_SIZE / tile).max(1);
    let opts = ImpostorOptions {
        grid,
        size: args.size,
        samples,
        shading: match args.shading {
            crate::render::ShadingArg::Flat => Shading::Flat,
            crate::render::ShadingArg::Smooth => Shading::Smooth,
        },
    };
    let imp = build_impostor(&mesh, &textures, &opts)
        .with_context(|| format!("{}: cannot draw", args.input.display()))?;
    // A texel's size, and the distance from which it covers at most one pixel of
    // a 1080-pixel-high screen with a 60° field of view.
    let texel = 2.0 * imp.radius / f64::from(imp.tile);
    let screen = Screen::default();
    let min_distance = screen.switch_distance(texel);
    let extra = json!({
        "source": crate::preview::file_name(&args.input),
        "source_triangles": mesh.triangle_count(),
        "texel": texel,
        "min_distance": min_distance,
        "min_distance_screen": { "pixel_error": screen.pixel_error,
            "screen_height_px": screen.screen_height_px, "fov_degrees": screen.fov_degrees },
    });
    let glb = impostor_glb(&imp, extra)?;
    std::fs::write(&args.output, &glb)
        .with_context(|| format!("{}: cannot write", args.output.display()))?;
    if let Some(p) = &args.atlas {
        let file =
            std::fs::File::create(p).with_context(|| format!("{}: cannot write", p.display()))?;
        imp.atlas
            .encode_png(std::io::BufWriter::new(file))
            .with_context(|| format!("{}: cannot write", p.display()))?;
    }
    let covered = imp
        .atlas
        .pixels
        .iter()
        .map(|p| f64::from(p[3]) / 255.0)
        .sum::<f64>()
        / imp.atlas.pixels.len().max(1) as f64;
    let r = Report {
        input: args.input.display().to_string(),
        output: args.output.display().to_string(),
        triangles: mesh.triangle_count(),
        views: args.views,
        grid,
        tile_px: imp.tile,
        atlas_px: imp.atlas.width,
        radius: imp.radius,
        texel,
        min_distance,
        covered_fraction: covered,
        bytes: glb.len(),
        seconds: t0.elapsed().as_secs_f64(),
    };
    if args.json {
        out!("{}", serde_json::to_string(&r)?);
    } else {
        out!(
            "wrote {} ({} views, {}×{} atlas of {} px tiles, {:.1} kB)",
            r.output,
            r.views,
            r.atlas_px,
            r.atlas_px,
            r.tile_px,
            r.bytes as f64 / 1e3
        );
        out!(
            "  quad side {} units; a texel is {} units, at most one pixel from {} on (1080 px, 60°)",
            meshlod::render::sig3(2.0 * r.radius),
            meshlod::render::sig3(texel),
            meshlod::render::sig3(min_distance)
        );
        out!("time: {:.3} s", r.seconds);
    }
    Ok(())
}
