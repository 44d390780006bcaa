//! `luxbake`: bake, measure, ies, export and catalogue (see the `luxbake_cli` docs and
//! `luxbake --help`). Exit codes: 0 success; 1 a failure worth retrying; 2 a usage error (bad
//! flags, an unreadable catalogue or manifest); 3 (`catalogue run`) a permanent input error of
//! the row, recorded in `OUT/errors/<key>.json`.

use std::process::ExitCode;

use clap::Parser;

/// luxbake: physically based light maps, in lux, for rooms lit by IES/EULUMDAT lamps.
#[derive(Parser)]
#[command(name = "luxbake", version, about)]
struct Cli {
    #[command(subcommand)]
    command: luxbake_cli::Command,
}

fn main() -> ExitCode {
    Cli::parse().command.run()
}
