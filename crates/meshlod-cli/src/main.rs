//! `meshlod`: mesh simplification and level of detail from the command line.
//!
//! Arguments are parsed by clap into [`Cli`], then each subcommand resolves them into
//! the library's options and runs. Errors carry the file name and are printed by
//! `anyhow`; the exit status is non-zero on any error.

/// `println!` that ends the process quietly when standard output is closed
/// (`meshlod info big.ply | head -3`) instead of panicking, and with an error
/// message when writing fails otherwise.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if let Err(e) = writeln!(std::io::stdout(), $($arg)*) {
            $crate::stdout_failed(&e);
        }
    }};
}

mod budget;
mod dag;
mod heatmap;
mod impostor;
mod info;
mod lod;
mod measure;
mod memory;
mod pm;
mod preview;
mod render;
mod simplify;
mod terrain;
mod textures;
mod view;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use std::process::ExitCode;

/// Mesh simplification and level of detail.
#[derive(Debug, Parser)]
#[command(name = "meshlod", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Print counts, attributes, bounding box and topology of a mesh file.
    Info(info::InfoArgs),
    /// Measure the distance between two meshes: Hausdorff, mean and RMS.
    ///
    /// One-sided and symmetric Hausdorff, mean and RMS distances by Metro-style
    /// vertex + edge + face sampling.
    Measure(measure::MeasureArgs),
    /// Simplify a mesh (edge collapse, vertex removal or clustering) and print a report.
    ///
    /// The everyday flags are listed by `--help`, grouped by method; the tuning
    /// options (thresholds and orders of each method) by `--help-tuning`.
    Simplify(Box<simplify::SimplifyArgs>),
    /// Level-of-detail chain: LOD0 … LODn with measured errors and switch distances,
    /// written to glTF with `MSFT_lod` (or one file per level); `lod select` picks
    /// levels for a camera.
    Lod(Box<lod::LodArgs>),
    /// View-dependent level of detail: build a cluster hierarchy (.mdag), cut it
    /// for a camera.
    #[command(subcommand)]
    Dag(dag::DagCommand),
    /// Progressive meshes: build a .pmesh, extract a level.
    #[command(subcommand)]
    Pm(pm::PmCommand),
    /// Height field (PNG, SRTM .hgt, ESRI .asc, GeoTIFF) to a triangulated irregular
    /// network within a vertical error bound, as one mesh or crack-free tiles.
    Terrain(Box<terrain::TerrainArgs>),
    /// Draw meshes to a PNG picture: side by side, shaded, with an optional
    /// wireframe and a heat map of the distance to a reference.
    Render(Box<render::RenderArgs>),
    /// Write a self-contained HTML page (WebGL, no network) to orbit the meshes,
    /// switch levels, toggle the wireframe and a heat map.
    View(Box<view::ViewArgs>),
    /// Impostor for the farthest level: the object drawn from N directions into an
    /// RGBA atlas (octahedral layout), written as a GLB quad textured with it.
    Impostor(Box<impostor::ImpostorArgs>),
}

/// The error and its causes on one line, `: `-separated, each once: a cause whose
/// text the message already holds (a library error that prints its own cause, such
/// as an I/O error naming its file) is not repeated.
fn one_line(e: &anyhow::Error) -> String {
    let mut msg = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if msg.contains(&text) {
            continue;
        }
        if !msg.is_empty() {
            msg.push_str(": ");
        }
        msg.push_str(&text);
    }
    msg
}

/// Largest float spacing, relative to the bounding-box diagonal, read without a
/// warning (0.001% of the diagonal: a tenth of the finest Hausdorff means we report).
const PRECISION_WARN: f64 = 1e-5;

/// Warns on stderr when `mesh`, read from `path`, lies so far from the origin that
/// its 32-bit positions are coarser than [`PRECISION_WARN`] of its size. Returns
/// whether it warned.
pub(crate) fn warn_precision(path: &std::path::Path, mesh: &meshlod::Mesh) -> bool {
    let (step, diag) = (mesh.position_step(), mesh.bbox_diagonal());
    let warn = diag > 0.0 && step > PRECISION_WARN * diag;
    if warn {
        eprintln!(
            "meshlod: warning: {}: coordinates this far from the origin are stored as 32-bit floats {step} units apart, {:.4}% of the bounding-box diagonal ({diag:.6}); no result is finer than that. Translate the mesh near the origin first (e.g. subtract a survey offset) to keep its detail.",
            path.display(),
            100.0 * step / diag
        );
    }
    warn
}

/// Ends the process after a failed write to standard output: with the status a
/// process killed by `SIGPIPE` has (141) when the reader went away, as other
/// command-line tools do, and with a message and status 1 otherwise.
pub(crate) fn stdout_failed(e: &std::io::Error) -> ! {
    if e.kind() == std::io::ErrorKind::BrokenPipe {
        std::process::exit(141);
    }
    eprintln!("meshlod: error: writing to standard output: {e}");
    std::process::exit(1);
}

/// Parses the command line as [`Cli::parse`] does, answering `meshlod simplify
/// --help-tuning` (which the required arguments would refuse) first: `None` when it
/// did.
fn parse() -> Option<Cli> {
    let mut matches = Cli::command().get_matches();
    if let Some(("simplify", sub)) = matches.subcommand() {
        if sub.get_flag("help_tuning") {
            let cli = Cli::command();
            if let Some(cmd) = cli.find_subcommand("simplify") {
                out!("{}", simplify::tuning_help(cmd));
            }
            return None;
        }
    }
    Some(
        Cli::from_arg_matches_mut(&mut matches)
            .unwrap_or_else(|e| e.format(&mut Cli::command()).exit()),
    )
}

fn main() -> ExitCode {
    let Some(cli) = parse() else {
        return ExitCode::SUCCESS;
    };
    let result = match cli.command {
        Command::Info(args) => info::run(&args),
        Command::Measure(args) => measure::run(&args),
        Command::Simplify(args) => simplify::run(&args),
        Command::Lod(args) => lod::run(&args),
        Command::Dag(cmd) => dag::run(&cmd),
        Command::Pm(cmd) => pm::run(&cmd),
        Command::Terrain(args) => terrain::run(&args),
        Command::Render(args) => render::run(&args),
        Command::View(args) => view::run(&args),
        Command::Impostor(args) => impostor::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("meshlod: error: {}", one_line(&e));
            ExitCode::FAILURE
        }
    }
}
