//! `cargo xtask` — luxbake's project commands. Each command lives in its own module; this file
//! only parses the command line and dispatches. `bake`, `measure`, `ies` and `export-scene` are
//! the `luxbake` binary's (`luxbake-cli`) own code, run with the same flags.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod bench;
#[cfg(test)]
mod import_cycles;
mod npm;
mod web;

// The commands a container runs live in the `luxbake` binary's library; `cargo xtask` runs the
// same code with the same flags.
use luxbake_cli::{bake, export, ies, measure};

/// luxbake project commands.
#[derive(Parser)]
#[command(name = "cargo xtask", about = "luxbake project commands")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Inspect a photometric file (IES LM-63 or EULUMDAT): header, symmetry, lumens, peak.
    Ies(ies::Args),
    /// Bake a scene's light maps (default: the built-in `chairs_05` into `./out`).
    Bake(bake::Args),
    /// Measured runs: the paper's Table 1 on every backend, scaling, and (`bench trade`) the
    /// speed/accuracy trade; `--quick` for CI.
    Bench(bench::Args),
    /// Write a built-in scene (or a scene file) as glTF 2.0 binary (.glb) for other tools.
    ExportScene(export::Args),
    /// Illuminance at calculation points (`x,y,z` rows) read back from a bake's light maps.
    Measure(measure::Args),
    /// Build the `luxbake` npm package into `target/npm/` and pack it (`--check`: install it
    /// with three.js in a scratch project and test it in headless Chromium).
    Npm(npm::Args),
    /// Build the browser viewer and serve it on 127.0.0.1 (`--check`: end-to-end test in
    /// headless Chromium).
    Web(web::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Ies(args) => ies::run(&args),
        Command::Bake(args) => bake::run(&args),
        Command::Bench(args) => bench::run(&args),
        Command::ExportScene(args) => export::run(&args),
        Command::Measure(args) => measure::run(&args),
        Command::Npm(args) => npm::run(&args),
        Command::Web(args) => web::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}
