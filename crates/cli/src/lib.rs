//! # luxbake-cli: the `luxbake` command
//!
//! The commands a container (or a lighting engineer) runs, as a library that the `luxbake`
//! binary and `cargo xtask` share, so both take the same flags and write the same files:
//!
//! - [`bake`]: bake a scene's light maps into a folder (EXR in lux, PNG previews, manifest);
//! - [`measure`]: illuminance at calculation points read back from a bake's maps (CSV);
//! - [`ies`]: inspect a photometric file (IES LM-63 or EULUMDAT);
//! - [`export`]: write a scene as glTF 2.0 binary for other tools;
//! - [`catalogue`]: plan a catalogue (rooms × lamps × placements × qualities) into a manifest of
//!   content-keyed rows, bake one row per batch task (Kubernetes Indexed Job, AWS Batch array,
//!   SLURM array) with atomic publication, and report what is done, failed and missing.
//!
//! Install the binary with `cargo install --path crates/cli`; `luxbake --help` and
//! `luxbake <command> --help` describe every flag. The catalogue's file format, exit codes and
//! deployment are in `docs/catalogue.md`.
//!
//! Every command returns its error as a message for stderr (the catalogue's also carries the
//! exit code that tells a batch engine whether to retry: [`catalogue::Failure`]); no input makes
//! a command panic.
#![warn(missing_docs)]

pub mod bake;
pub mod catalogue;
pub mod export;
pub mod ies;
pub mod measure;

use std::process::ExitCode;

/// The commands of the `luxbake` binary; `cargo xtask` runs the same ones (flattened into its
/// own), so both parse the same flags and run the same code.
#[derive(clap::Subcommand)]
pub enum Command {
    /// Bake a scene's light maps (default: the built-in `chairs_05` into `./out`).
    Bake(bake::Args),
    /// Illuminance at calculation points (`x,y,z` rows) read back from a bake's light maps.
    Measure(measure::Args),
    /// Inspect a photometric file (IES LM-63 or EULUMDAT): header, symmetry, lumens, peak.
    Ies(ies::Args),
    /// Write a built-in scene (or a scene file) as glTF 2.0 binary (.glb) for other tools.
    #[command(visible_alias = "export-scene")]
    Export(export::Args),
    /// Catalogue bakes: plan rooms × lamps × placements × qualities into a manifest, bake its
    /// rows (one per batch task, or all locally), report their status.
    Catalogue(catalogue::Args),
}

impl Command {
    /// Runs the command; an error is printed to stderr as `error: …`. The exit code: 0 success,
    /// 1 a failure worth retrying, 2 a usage error, 3 (`catalogue run`) a permanent input
    /// error of the row.
    pub fn run(self) -> ExitCode {
        let result = match self {
            Command::Bake(args) => bake::run(&args),
            Command::Measure(args) => measure::run(&args),
            Command::Ies(args) => ies::run(&args),
            Command::Export(args) => export::run(&args),
            Command::Catalogue(args) => {
                return catalogue::run(&args).unwrap_or_else(|f| f.report());
            }
        };
        exit_code(result)
    }
}

/// `ExitCode::SUCCESS` for `Ok`; for `Err` the message printed to stderr as `error: …` and
/// `ExitCode::FAILURE`.
pub fn exit_code(result: Result<(), String>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}
