//! `meshlod measure A B`: Metro-class distances between two meshes.

use anyhow::{bail, Result};
use meshlod::metrics::{
    self, appearance::Appearance, bvh::Bvh, Distances, OneSided, SamplingOptions,
};
use meshlod::read_mesh;
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `meshlod measure`.
#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct MeasureArgs {
    /// The reference mesh (relative errors are fractions of its bounding-box diagonal).
    pub a: PathBuf,
    /// The mesh compared with it (e.g. a simplified version).
    pub b: PathBuf,
    /// Samples on edges and as many on faces, per direction, besides every vertex
    /// (MeshLab's `samplenum`). Default: max(1,000,000, 10 × triangles).
    #[arg(long)]
    pub samples: Option<usize>,
    /// Seed for the placement of face samples.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Write B with a blue→red colour map of each vertex's distance to A (and, as
    /// .ply, the distance itself as a `quality` property); .obj, .off and .glb get
    /// the colours alone.
    #[arg(long, value_name = "OUT.ply")]
    pub heatmap: Option<PathBuf>,
    /// Screen height in pixels, for screen-space error.
    #[arg(long, value_name = "PX")]
    pub screen_height: Option<f64>,
    /// Vertical field of view in degrees, for screen-space error.
    #[arg(long, value_name = "DEG", default_value_t = 60.0)]
    pub fov: f64,
    /// Viewing distance (mesh units), for screen-space error.
    #[arg(long, value_name = "D")]
    pub distance: Option<f64>,
    /// Skip certifying the maximum: `max` is then the largest sample only (a lower
    /// bound that can be low), and `max_upper` is null. Saves the refinement's time.
    #[arg(long)]
    pub no_certify: bool,
    /// Skip the attribute deviation (UV distance, normal angle, colour difference at
    /// corresponding points), which is measured by default when both meshes carry the
    /// attribute and costs about as much as the geometric measure (0.7–3.2× its time
    /// on the glTF sample assets).
    #[arg(long)]
    pub no_appearance: bool,
}

#[derive(Serialize)]
struct Relative {
    hausdorff: f64,
    mean: f64,
    rms: f64,
}

#[derive(Serialize)]
struct Screen {
    screen_height_px: f64,
    fov_degrees: f64,
    /// Pixels covered by the Hausdorff distance at `distance`.
    #[serde(skip_serializing_if = "Option::is_none")]
    distance: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pixels: Option<f64>,
    /// Distance at which the Hausdorff distance covers one pixel.
    distance_for_one_pixel: f64,
}

#[derive(Serialize)]
struct Report {
    a: String,
    b: String,
    units: &'static str,
    hausdorff: f64,
    /// The certified interval of the symmetric maximum: `max_lower` = `hausdorff`.
    max_lower: f64,
    max_upper: Option<f64>,
    mean: f64,
    rms: f64,
    a_to_b: OneSided,
    b_to_a: OneSided,
    relative_to_bbox_diagonal: Relative,
    relative_to_max_extent: Relative,
    bbox_diagonal: f64,
    max_extent: f64,
    samples: u64,
    #[serde(skip_serializing_if = "Option::is_none")]
    screen: Option<Screen>,
    seconds: f64,
    /// Attribute deviation, when both meshes share an attribute (and not skipped).
    #[serde(skip_serializing_if = "Option::is_none")]
    appearance: Option<Appearance>,
    #[serde(skip_serializing_if = "Option::is_none")]
    appearance_seconds: Option<f64>,
}

fn relative(d: &Distances, scale: f64) -> Relative {
    let s = d.scaled(scale);
    Relative {
        hausdorff: s.hausdorff,
        mean: s.mean,
        rms: s.rms,
    }
}

/// Runs the measurement and prints the report.
///
/// # Errors
/// A file cannot be read, or the heat map cannot be written.
pub fn run(args: &MeasureArgs) -> Result<()> {
    // Screen-space error needs a picture to project onto.
    if !(args.fov > 0.0 && args.fov < 180.0) {
        bail!(
            "--fov {} must be an angle strictly between 0 and 180 degrees",
            args.fov
        );
    }
    if let Some(h) = args.screen_height.filter(|h| !(*h > 0.0 && h.is_finite())) {
        bail!("--screen-height {h} must be a positive number of pixels");
    }
    if let Some(d) = args.distance.filter(|d| !(*d > 0.0 && d.is_finite())) {
        bail!("--distance {d} must be a positive distance");
    }
    let a = read_mesh(&args.a)?;
    let b = read_mesh(&args.b)?;
    crate::warn_precision(&args.a, &a);
    crate::warn_precision(&args.b, &b);
    if a.triangles.is_empty() || b.triangles.is_empty() {
        bail!(
            "{}: has no triangles to measure",
            if a.triangles.is_empty() {
                args.a.display()
            } else {
                args.b.display()
            }
        );
    }
    let options = SamplingOptions {
        samples: args.samples,
        seed: args.seed,
        certify: !args.no_certify,
        ..SamplingOptions::default()
    };
    let t0 = Instant::now();
    let d = metrics::hausdorff(&a, &b, &options);
    let seconds = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let appearance = if args.no_appearance {
        None
    } else {
        metrics::appearance::appearance(&a, &b, &options)
    };
    let appearance_seconds = appearance.is_some().then(|| t1.elapsed().as_secs_f64());
    if let Some(out) = &args.heatmap {
        let bvh = Bvh::build(&a.positions, &a.triangles);
        let dist = metrics::vertex_distances(&b, &bvh);
        crate::heatmap::write(out, &b, &dist)?;
    }
    let screen = args.screen_height.map(|h| Screen {
        screen_height_px: h,
        fov_degrees: args.fov,
        distance: args.distance,
        pixels: args
            .distance
            .map(|dist| metrics::screen_space_error(d.hausdorff, h, args.fov, dist)),
        distance_for_one_pixel: metrics::distance_for_pixels(d.hausdorff, 1.0, h, args.fov),
    });
    let report = Report {
        a: args.a.display().to_string(),
        b: args.b.display().to_string(),
        units: "mesh units; relative_* are fractions of A's bounding-box diagonal / largest side",
        hausdorff: d.hausdorff,
        max_lower: d.hausdorff,
        max_upper: d.hausdorff_upper,
        mean: d.mean,
        rms: d.rms,
        a_to_b: d.a_to_b,
        b_to_a: d.b_to_a,
        relative_to_bbox_diagonal: relative(&d, d.bbox_diagonal),
        relative_to_max_extent: relative(&d, d.max_extent),
        bbox_diagonal: d.bbox_diagonal,
        max_extent: d.max_extent,
        samples: d.a_to_b.samples + d.b_to_a.samples,
        screen,
        seconds,
        appearance,
        appearance_seconds,
    };
    if args.json {
        out!("{}", serde_json::to_string(&report)?);
        return Ok(());
    }
    let pct = |x: f64| 100.0 * x / d.bbox_diagonal.max(f64::MIN_POSITIVE);
    out!("A: {}", report.a);
    out!("B: {}", report.b);
    out!(
        "bounding-box diagonal of A: {:.6} (largest side {:.6})",
        d.bbox_diagonal,
        d.max_extent
    );
    out!(
        "{:<14}{:>14}{:>14}{:>14}{:>12}",
        "",
        "max",
        "mean",
        "rms",
        "samples"
    );
    for (name, o) in [("A -> B", &d.a_to_b), ("B -> A", &d.b_to_a)] {
        out!(
            "{name:<14}{:>14.6e}{:>14.6e}{:>14.6e}{:>12}",
            o.max,
            o.mean,
            o.rms,
            o.samples
        );
    }
    out!(
        "{:<14}{:>14.6e}{:>14.6e}{:>14.6e}",
        "symmetric",
        d.hausdorff,
        d.mean,
        d.rms
    );
    out!(
        "{:<14}{:>13.4}%{:>13.5}%{:>13.5}%   of the bbox diagonal",
        "relative",
        pct(d.hausdorff),
        pct(d.mean),
        pct(d.rms)
    );
    if let Some(up) = d.hausdorff_upper {
        out!(
            "certified: the symmetric maximum lies in [{:.6e}, {:.6e}] (+{:.3}%)",
            d.hausdorff,
            up,
            100.0 * (up / d.hausdorff.max(f64::MIN_POSITIVE) - 1.0)
        );
    }
    let far = if d.a_to_b.max >= d.b_to_a.max {
        &d.a_to_b
    } else {
        &d.b_to_a
    };
    out!(
        "max at ({:.6}, {:.6}, {:.6})",
        far.max_at[0],
        far.max_at[1],
        far.max_at[2]
    );
    if let Some(s) = &report.screen {
        if let Some(px) = s.pixels {
            out!(
                "screen: {px:.3} px at distance {} ({} px high, fov {}°)",
                s.distance.unwrap_or(0.0),
                s.screen_height_px,
                s.fov_degrees
            );
        }
        out!(
            "screen: the Hausdorff error covers one pixel at distance {:.6}",
            s.distance_for_one_pixel
        );
    }
    if let Some(ap) = &report.appearance {
        print_appearance(ap);
    }
    out!("time: {seconds:.3} s");
    if let Some(t) = report.appearance_seconds {
        out!("appearance time: {t:.3} s");
    }
    Ok(())
}

/// The attribute deviation table of the text report.
fn print_appearance(ap: &Appearance) {
    out!(
        "{:<14}{:>14}{:>14}{:>14}{:>14}",
        "appearance",
        "A -> B max",
        "B -> A max",
        "max",
        "mean"
    );
    let rows = [
        ("uv", ap.uv, ap.a_to_b.uv, ap.b_to_a.uv),
        (
            "normal (deg)",
            ap.normal_deg,
            ap.a_to_b.normal_deg,
            ap.b_to_a.normal_deg,
        ),
        ("color", ap.color, ap.a_to_b.color, ap.b_to_a.color),
    ];
    for (name, sym, ab, ba) in rows {
        let Some(sym) = sym else { continue };
        let m = |d: Option<metrics::appearance::Deviation>| d.map_or(0.0, |d| d.max);
        out!(
            "{name:<14}{:>14.6e}{:>14.6e}{:>14.6e}{:>14.6e}",
            m(ab),
            m(ba),
            sym.max,
            sym.mean
        );
    }
    let unmatched = ap.a_to_b.uv_unmatched + ap.b_to_a.uv_unmatched;
    if unmatched > 0 {
        out!("uv: {unmatched} samples lie in a material the other mesh does not have");
    }
}
