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

/// luxbake project commands.
#[derive(Parser)]
#[command(name = "cargo xtask", about = "luxbake project commands")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// The `luxbake` binary's commands (bake, measure, ies, export alias export-scene,
    /// catalogue): the same code with the same flags.
    #[command(flatten)]
    Luxbake(luxbake_cli::Command),
    /// Measured runs: the paper's Table 1 on every backend, scaling, and (`bench trade`) the
    /// speed/accuracy trade; `--quick` for CI.
    Bench(bench::Args),
    /// Build the `luxbake` npm package into `target/npm/` and pack it (`--check`: install it
    /// with three.js in a scratch project and test it in headless Chromium).
    Npm(npm::Args),
    /// Build the browser viewer and serve it on 127.0.0.1 (`--check`: end-to-end test in
    /// headless Chromium).
    Web(web::Args),
}

fn main() -> ExitCode {
    luxbake_cli::exit_code(match Cli::parse().command {
        Command::Luxbake(command) => return command.run(),
        Command::Bench(args) => bench::run(&args),
        Command::Npm(args) => npm::run(&args),
        Command::Web(args) => web::run(&args),
    })
}
