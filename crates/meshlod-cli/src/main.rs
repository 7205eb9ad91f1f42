//! `meshlod`: mesh simplification and level of detail from the command line.
//!
//! Arguments are parsed by clap into [`Cli`], then each subcommand resolves them into
//! the library's options and runs. Errors carry the file name and are printed by
//! `anyhow`; the exit status is non-zero on any error.

mod heatmap;
mod info;
mod measure;
mod memory;
mod pm;
mod simplify;

use clap::{Parser, Subcommand};
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
    /// Measure the distance between two meshes: one-sided and symmetric Hausdorff,
    /// mean and RMS (Metro-style vertex + edge + face sampling).
    Measure(measure::MeasureArgs),
    /// Simplify a mesh (quadric error metric edge collapse) and print a report.
    Simplify(Box<simplify::SimplifyArgs>),
    /// Progressive meshes: build a .pmesh, extract a level.
    #[command(subcommand)]
    Pm(pm::PmCommand),
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

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Info(args) => info::run(&args),
        Command::Measure(args) => measure::run(&args),
        Command::Simplify(args) => simplify::run(&args),
        Command::Pm(cmd) => pm::run(&cmd),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("meshlod: error: {}", one_line(&e));
            ExitCode::FAILURE
        }
    }
}
