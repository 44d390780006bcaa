//! `luxbake`: bake, measure, ies, export and catalogue (see the `luxbake_cli` docs and
//! `luxbake --help`). Exit codes: 0 success; 1 a failure worth retrying; 2 a usage error (bad
//! flags, an unreadable catalogue or manifest); 3 (`catalogue run`) a permanent input error of
//! the row, recorded in `OUT/errors/<key>.json`.

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use luxbake_cli::{bake, catalogue, export, ies, measure};

/// luxbake: physically based light maps, in lux, for rooms lit by IES/EULUMDAT lamps.
#[derive(Parser)]
#[command(name = "luxbake", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Bake a scene's light maps (default: the built-in `chairs_05` into `./out`).
    Bake(bake::Args),
    /// Illuminance at calculation points (`x,y,z` rows) read back from a bake's light maps.
    Measure(measure::Args),
    /// Inspect a photometric file (IES LM-63 or EULUMDAT): header, symmetry, lumens, peak.
    Ies(ies::Args),
    /// Write a built-in scene (or a scene file) as glTF 2.0 binary (.glb) for other tools.
    Export(export::Args),
    /// Catalogue bakes: plan rooms × lamps × placements × qualities into a manifest, bake its
    /// rows (one per batch task, or all locally), report their status.
    Catalogue(catalogue::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Bake(args) => bake::run(&args),
        Command::Measure(args) => measure::run(&args),
        Command::Ies(args) => ies::run(&args),
        Command::Export(args) => export::run(&args),
        Command::Catalogue(args) => return catalogue::run(&args).unwrap_or_else(|f| f.report()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}
