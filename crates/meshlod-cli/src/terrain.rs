//! `meshlod terrain IN -o OUT [--max-error E] [--triangles N] [--z-scale S]
//! [--cell-size C] [--tile-size T] [--json]`: a height field (PNG, SRTM `.hgt`, ESRI
//! `.asc`, GeoTIFF) to a TIN within a vertical error bound, as one mesh or as tiles.

use crate::memory;
use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use meshlod::io::WriteOptions;
use meshlod::terrain::tin::{build_tin_region, Region, Seeding};
use meshlod::terrain::{
    build_tiles, build_tin_blocked, measure, read_height_field, tin_to_mesh, HeightField, Tin,
    TinOptions,
};
use meshlod::write_mesh;
use serde::Serialize;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `meshlod terrain`.
#[derive(Debug, Args)]
pub struct TerrainArgs {
    /// Height field: greyscale PNG (8/16-bit), SRTM .hgt, ESRI ASCII grid .asc, or
    /// single-band GeoTIFF .tif.
    pub input: PathBuf,
    /// Output mesh; the format follows the extension (OBJ, PLY, STL, OFF, glTF). With
    /// --tile-size, tiles are written as OUT_x_y.ext beside an index OUT_index.json.
    #[arg(short = 'o', long = "output")]
    pub output: PathBuf,
    /// Largest vertical distance between any grid sample and the TIN, in height
    /// units after --z-scale: a guarantee. Default 1 unless --triangles is given.
    #[arg(long, value_name = "E")]
    pub max_error: Option<f64>,
    /// Stop once the TIN has this many triangles (or the --max-error bound holds,
    /// whichever comes first).
    #[arg(long, value_name = "N")]
    pub triangles: Option<usize>,
    /// Multiply every height by S (e.g. grey levels to metres).
    #[arg(long, value_name = "S", default_value_t = 1.0)]
    pub z_scale: f64,
    /// Distance between neighbouring samples in the output's x and y (default: the
    /// file's cell size for .asc and GeoTIFF, else 1).
    #[arg(long, value_name = "C")]
    pub cell_size: Option<f64>,
    /// Cut into square tiles of T samples a side sharing their borders (no cracks),
    /// each within --max-error.
    #[arg(long, value_name = "T")]
    pub tile_size: Option<usize>,
    /// Build the single TIN as crack-free blocks of B samples a side, merged (faster,
    /// in parallel, about the same triangle count); 0: the whole grid at once. Not
    /// used with --triangles or --tile-size.
    #[arg(long, value_name = "B", default_value_t = 257)]
    pub block_size: usize,
    /// Skip the vertex-removal pass after the insertion: the plain Garland & Heckbert
    /// Delaunay TIN (more triangles, same bound).
    #[arg(long)]
    pub no_prune: bool,
    /// Write ASCII where the format has a choice (PLY, STL).
    #[arg(long)]
    pub ascii: bool,
    /// Print the report as one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// The report of one run.
#[derive(Debug, Serialize)]
struct Report {
    input: String,
    output: String,
    width: usize,
    height: usize,
    samples: usize,
    voids_filled: usize,
    triangles: usize,
    vertices: usize,
    /// Largest vertical distance over every grid sample, measured on the output.
    max_error: f64,
    rms_error: f64,
    /// The bound asked for (null with --triangles alone).
    max_error_bound: Option<f64>,
    tiles: Option<usize>,
    /// Block size of the single TIN (null: the whole grid at once).
    block_size: Option<usize>,
    read_seconds: f64,
    /// Triangulation time (the insertion), without reading, measuring or writing.
    seconds: f64,
    measure_seconds: f64,
    write_seconds: f64,
    peak_rss_bytes: Option<u64>,
    peak_rss_bytes_per_sample: Option<f64>,
}

/// One entry of the tile index.
#[derive(Debug, Serialize)]
struct TileEntry {
    x: usize,
    y: usize,
    file: String,
    /// Grid columns and rows covered, inclusive.
    columns: [u32; 2],
    rows: [u32; 2],
    /// Bounds in the output frame: [xmin, ymin, zmin], [xmax, ymax, zmax].
    bounds: [[f32; 3]; 2],
    triangles: usize,
    vertices: usize,
    max_error: f64,
}

fn options(args: &TerrainArgs) -> Result<TinOptions> {
    let max_error = match (args.max_error, args.triangles) {
        (Some(e), _) => e,
        (None, Some(_)) => 0.0,
        (None, None) => 1.0,
    };
    if !(max_error >= 0.0 && max_error.is_finite()) {
        bail!("--max-error {max_error}: must be a non-negative number");
    }
    if !(args.z_scale.is_finite() && args.z_scale != 0.0) {
        bail!("--z-scale {}: must be a non-zero number", args.z_scale);
    }
    if let Some(c) = args.cell_size {
        if !(c > 0.0 && c.is_finite()) {
            bail!("--cell-size {c}: must be positive");
        }
    }
    if args.block_size == 1 {
        bail!("--block-size 1: a block needs at least 2 samples a side (0: no blocks)");
    }
    if let Some(t) = args.tile_size {
        if t < 2 {
            bail!("--tile-size {t}: a tile needs at least 2 samples a side");
        }
        if args.triangles.is_some() {
            bail!("--tile-size takes --max-error, not --triangles");
        }
    }
    Ok(TinOptions {
        max_error,
        max_triangles: args.triangles,
        prune: !args.no_prune,
    })
}

/// Runs `meshlod terrain`.
pub fn run(args: &TerrainArgs) -> Result<()> {
    let opts = options(args)?;
    let t0 = Instant::now();
    let mut hf = read_height_field(&args.input)?;
    hf.scale_heights(args.z_scale);
    if let Some(c) = args.cell_size {
        hf.cell_size = c;
    }
    let read_seconds = t0.elapsed().as_secs_f64();
    if hf.voids_filled > 0 && !args.json {
        eprintln!(
            "meshlod: {}: filled {} void samples from their neighbours",
            args.input.display(),
            hf.voids_filled
        );
    }
    let mut report = Report {
        input: args.input.display().to_string(),
        output: args.output.display().to_string(),
        width: hf.width,
        height: hf.height,
        samples: hf.width * hf.height,
        voids_filled: hf.voids_filled,
        triangles: 0,
        vertices: 0,
        max_error: 0.0,
        rms_error: 0.0,
        max_error_bound: args
            .max_error
            .or((args.triangles.is_none()).then_some(opts.max_error)),
        tiles: None,
        block_size: None,
        read_seconds,
        seconds: 0.0,
        measure_seconds: 0.0,
        write_seconds: 0.0,
        peak_rss_bytes: None,
        peak_rss_bytes_per_sample: None,
    };
    match args.tile_size {
        Some(t) => run_tiles(args, &hf, &opts, t, &mut report)?,
        None => run_single(args, &hf, &opts, &mut report)?,
    }
    if let Some(rss) = memory::rss() {
        report.peak_rss_bytes = Some(rss.peak);
        report.peak_rss_bytes_per_sample = Some(rss.peak as f64 / report.samples as f64);
    }
    print_report(args, &report)
}

fn run_single(
    args: &TerrainArgs,
    hf: &HeightField,
    opts: &TinOptions,
    report: &mut Report,
) -> Result<()> {
    let bar = std::io::stderr().is_terminal().then(|| {
        let b = ProgressBar::new_spinner();
        b.set_style(
            ProgressStyle::with_template("{spinner} triangulating {msg} {elapsed}")
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
        );
        b
    });
    let mut tick = |triangles: usize, error: f64| {
        if let Some(b) = &bar {
            b.set_message(format!("{triangles} triangles, error {error:.4}"));
            b.tick();
        }
    };
    let t1 = Instant::now();
    let blocked = args.block_size >= 2 && opts.max_triangles.is_none();
    let tin = if blocked {
        report.block_size = Some(args.block_size);
        build_tin_blocked(&hf.heights, hf.width, hf.height, args.block_size, opts)
    } else {
        let seeding = Seeding {
            region: Region {
                x0: 0,
                y0: 0,
                x1: (hf.width - 1) as u32,
                y1: (hf.height - 1) as u32,
            },
            seeds: &[],
            frozen_border: false,
        };
        build_tin_region(
            &hf.heights,
            hf.width,
            hf.height,
            seeding,
            opts,
            Some(&mut tick),
        )
    }
    .with_context(|| args.input.display().to_string())?;
    report.seconds = t1.elapsed().as_secs_f64();
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let t2 = Instant::now();
    let dev = measure(&tin, &hf.heights, hf.width);
    report.measure_seconds = t2.elapsed().as_secs_f64();
    report.max_error = dev.max;
    report.rms_error = dev.rms;
    report.triangles = tin.triangles.len();
    report.vertices = tin.points.len();
    let t3 = Instant::now();
    write_tin(&args.output, &tin, hf, args.ascii)?;
    report.write_seconds = t3.elapsed().as_secs_f64();
    Ok(())
}

fn write_tin(path: &Path, tin: &Tin, hf: &HeightField, ascii: bool) -> Result<()> {
    let mesh = tin_to_mesh(tin, hf);
    write_mesh(path, &mesh, &WriteOptions::default().with_ascii(ascii))?;
    Ok(())
}

/// `OUT_x_y.ext` beside `OUT.ext`.
fn tile_path(out: &Path, x: usize, y: usize) -> PathBuf {
    let stem = out.file_stem().and_then(|s| s.to_str()).unwrap_or("tile");
    let name = match out.extension().and_then(|e| e.to_str()) {
        Some(ext) => format!("{stem}_{x}_{y}.{ext}"),
        None => format!("{stem}_{x}_{y}"),
    };
    out.with_file_name(name)
}

fn run_tiles(
    args: &TerrainArgs,
    hf: &HeightField,
    opts: &TinOptions,
    tile_size: usize,
    report: &mut Report,
) -> Result<()> {
    let t1 = Instant::now();
    let tiles = build_tiles(&hf.heights, hf.width, hf.height, tile_size, opts)
        .with_context(|| args.input.display().to_string())?;
    report.seconds = t1.elapsed().as_secs_f64();
    let t2 = Instant::now();
    let mut entries = Vec::with_capacity(tiles.len());
    let (mut sum_sq, mut covered) = (0.0f64, 0usize);
    let mut measure_seconds = 0.0;
    for tile in &tiles {
        let tm = Instant::now();
        let dev = measure(&tile.tin, &hf.heights, hf.width);
        measure_seconds += tm.elapsed().as_secs_f64();
        report.max_error = report.max_error.max(dev.max);
        sum_sq += dev.rms * dev.rms * dev.covered as f64;
        covered += dev.covered;
        report.triangles += tile.tin.triangles.len();
        report.vertices += tile.tin.points.len();
        let path = tile_path(&args.output, tile.x, tile.y);
        let mesh = tin_to_mesh(&tile.tin, hf);
        let (lo, hi) = mesh.bounding_box(false).unwrap_or_default();
        write_mesh(
            &path,
            &mesh,
            &WriteOptions::default().with_ascii(args.ascii),
        )?;
        entries.push(TileEntry {
            x: tile.x,
            y: tile.y,
            file: path
                .file_name()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_default(),
            columns: [tile.region.x0, tile.region.x1],
            rows: [tile.region.y0, tile.region.y1],
            bounds: [lo, hi],
            triangles: tile.tin.triangles.len(),
            vertices: tile.tin.points.len(),
            max_error: dev.max,
        });
    }
    report.rms_error = if covered > 0 {
        (sum_sq / covered as f64).sqrt()
    } else {
        0.0
    };
    report.tiles = Some(tiles.len());
    report.measure_seconds = measure_seconds;
    let index = serde_json::json!({
        "width": hf.width,
        "height": hf.height,
        "tile_size": tile_size,
        "cell_size": hf.cell_size,
        "origin": hf.origin,
        "max_error_bound": opts.max_error,
        "tiles": entries,
    });
    let index_path = tile_path(&args.output, 0, 0).with_file_name(format!(
        "{}_index.json",
        args.output
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("tile")
    ));
    std::fs::write(&index_path, serde_json::to_string_pretty(&index)?)
        .with_context(|| index_path.display().to_string())?;
    report.write_seconds = t2.elapsed().as_secs_f64() - measure_seconds;
    Ok(())
}

fn print_report(args: &TerrainArgs, r: &Report) -> Result<()> {
    if args.json {
        out!("{}", serde_json::to_string(r)?);
        return Ok(());
    }
    out!(
        "{}: {} x {} samples -> {} triangles, {} vertices{}",
        r.input,
        r.width,
        r.height,
        r.triangles,
        r.vertices,
        r.tiles
            .map(|t| format!(" in {t} tiles"))
            .unwrap_or_default()
    );
    out!(
        "error over every sample: max {:.6}, rms {:.6} (height units)",
        r.max_error,
        r.rms_error
    );
    out!(
        "time: read {:.3} s, triangulate {:.3} s, measure {:.3} s, write {:.3} s",
        r.read_seconds,
        r.seconds,
        r.measure_seconds,
        r.write_seconds
    );
    if let (Some(p), Some(b)) = (r.peak_rss_bytes, r.peak_rss_bytes_per_sample) {
        out!(
            "memory: peak {:.1} MB, {b:.1} bytes per sample",
            p as f64 / 1e6
        );
    }
    Ok(())
}
