//! `luxbake catalogue plan|run|status|index`: catalogue bakes on a batch engine.
//!
//! A catalogue (`catalogue.toml`, format in `docs/catalogue.md`) names rooms, lamp files,
//! placements and qualities. [`plan()`] expands it into a **manifest**: JSON lines, one [`Row`]
//! per room × lamp × placement × quality, each with a **content key**, the SHA-256 of
//! luxbake's version, every input file's bytes (the scene file, the meshes and photometric
//! files it references, the row's lamp file) and the row's settings. [`run_row`] bakes one row
//! ([`run_all`]: every row) into `OUT/<key>/`; [`status()`] reports which rows are done, failed
//! and missing; [`write_index`] lists the published rows in `OUT/index.json` for a front end.
//!
//! A published row holds the bake's files (`luxbake_output::write_bake`: EXR light maps in lux,
//! PNG previews, `manifest.json`), the web GLB `web.glb`
//! (`luxbake_assets::export::export_web`: light maps as LogLuv PNGs under `MOZ_lightmap`,
//! lamps as `EXT_lights_ies`) and `row.json`.
//!
//! # Publication
//!
//! A row is baked into `OUT/.tmp-<key>-<pid>-<nanos>/` (a name starting with `.`, which
//! `status` and a front end ignore), its files' sizes and hashes are written last into
//! `row.json`, every file is synced, and the folder is published by one atomic rename to
//! `OUT/<key>/`. A row whose key folder exists and verifies (every file of its `row.json` there
//! with its hash) is skipped; a run of a row first removes the temporary folders earlier runs of
//! that row left (killed processes). The bake's timings, the one thing that differs between
//! runs, are moved from `manifest.json` into `timings.json`, which `row.json` does not list:
//! every listed file is byte-identical whoever bakes the row.
//!
//! # Exit codes
//!
//! | code | meaning | a batch engine should |
//! |---|---|---|
//! | 0 | the row is baked, or was already | count it done |
//! | 1 | a failure worth retrying (I/O, the backend) | retry the row |
//! | 2 | a usage error: bad flags, an unreadable catalogue or manifest, an index out of range | stop: fix the job |
//! | 3 | a permanent input error of the row (a malformed lamp file, a broken mesh, a missing or changed input), recorded in `OUT/errors/<key>.json` | fail the row without retrying ([`PERMANENT`]) |
//!
//! With `--all`, the worst outcome decides: 1 if any row failed for a retryable reason, else 3
//! if any row failed permanently, else 0.

mod failure;
mod index;
mod plan;
mod run;
mod status;

use std::path::PathBuf;
use std::process::ExitCode;

pub use failure::{Failure, PERMANENT, RETRYABLE, USAGE};
pub use index::{INDEX_FILE, write_index};
pub use plan::{Input, Row, plan, read_manifest};
pub use run::{RowOutcome, run_all, run_row};
pub use status::{Status, status};

/// The environment variables a batch engine gives an array task's index in, in the order they
/// are read: Kubernetes Indexed Job, AWS Batch array job, SLURM job array.
pub const INDEX_VARIABLES: [&str; 3] = [
    "JOB_COMPLETION_INDEX",
    "AWS_BATCH_JOB_ARRAY_INDEX",
    "SLURM_ARRAY_TASK_ID",
];

/// Arguments of `luxbake catalogue`.
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Subcommand)]
enum Command {
    /// Expand a catalogue.toml into a manifest: one JSON line per room × lamp × placement ×
    /// quality, each with its content key. Prints the number of rows.
    Plan {
        /// The catalogue file (docs/catalogue.md).
        catalogue: PathBuf,
        /// The manifest to write.
        #[arg(long, short, default_value = "manifest.jsonl")]
        output: PathBuf,
    },
    /// Bake row I of a manifest into OUT/<key>/ (skipped when it is there and verifies), or
    /// every row with --all. Exit codes: 0 done, 1 retry, 2 usage error, 3 permanent input
    /// error (recorded in OUT/errors/<key>.json).
    Run {
        /// The manifest written by `catalogue plan`.
        manifest: PathBuf,
        /// The row (from 0). Without it: JOB_COMPLETION_INDEX (Kubernetes Indexed Job),
        /// AWS_BATCH_JOB_ARRAY_INDEX or SLURM_ARRAY_TASK_ID, the first that is set.
        #[arg(long, conflicts_with = "all")]
        index: Option<usize>,
        /// Bake every row on this machine.
        #[arg(long)]
        all: bool,
        /// With --all: rows baked at once (threads).
        #[arg(long, default_value_t = 1, requires = "all")]
        jobs: usize,
        /// The output folder (a volume, or a folder synced to an object store afterwards).
        #[arg(long)]
        out: PathBuf,
    },
    /// Write OUT/index.json, what a shop's front end reads: every published and verified row
    /// (room, lamp, placement, quality, key, web GLB, files with sizes, lux range), atomically.
    /// `run --all` writes it when it ends; after an array job, run this once.
    Index {
        /// The manifest written by `catalogue plan`.
        manifest: PathBuf,
        /// The output folder.
        #[arg(long)]
        out: PathBuf,
    },
    /// Which rows of a manifest are done (published and verified), failed (an error record)
    /// and missing in OUT.
    Status {
        /// The manifest written by `catalogue plan`.
        manifest: PathBuf,
        /// The output folder.
        #[arg(long)]
        out: PathBuf,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
}

/// Runs a catalogue command; the error carries its exit code.
pub fn run(args: &Args) -> Result<ExitCode, Failure> {
    match &args.command {
        Command::Plan { catalogue, output } => {
            let rows = plan(catalogue)?;
            plan::write_manifest(output, &rows)?;
            println!("planned {} rows into {}", rows.len(), output.display());
            Ok(ExitCode::SUCCESS)
        }
        Command::Run {
            manifest,
            index,
            all,
            jobs,
            out,
        } => {
            let rows = read_manifest(manifest)?;
            if *all {
                let code = run_all(&rows, out, *jobs)?;
                print_index(&rows, out)?;
                return Ok(ExitCode::from(code));
            }
            let index = match index {
                Some(i) => *i,
                None => index_from_env(|name| std::env::var(name).ok())?,
            };
            let row = rows.get(index).ok_or_else(|| {
                Failure::Usage(format!(
                    "index {index} is out of range: the manifest has {} rows",
                    rows.len()
                ))
            })?;
            let outcome = run_row(row, out)?;
            println!("{}", outcome.line(row));
            Ok(ExitCode::SUCCESS)
        }
        Command::Index { manifest, out } => {
            let rows = read_manifest(manifest)?;
            print_index(&rows, out)?;
            Ok(ExitCode::SUCCESS)
        }
        Command::Status {
            manifest,
            out,
            json,
        } => {
            let rows = read_manifest(manifest)?;
            let s = status(&rows, out)?;
            if *json {
                println!("{}", s.json(&rows));
            } else {
                print!("{}", s.text(&rows));
            }
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// Writes the index of `rows` in `out` and says how many it lists.
fn print_index(rows: &[Row], out: &std::path::Path) -> Result<(), Failure> {
    let listed = write_index(rows, out)?;
    println!(
        "index: {listed} of {} rows in {}",
        rows.len(),
        out.join(INDEX_FILE).display()
    );
    Ok(())
}

/// The row index a batch engine gives (the first of [`INDEX_VARIABLES`] that `var` finds).
pub fn index_from_env(var: impl Fn(&str) -> Option<String>) -> Result<usize, Failure> {
    for name in INDEX_VARIABLES {
        if let Some(value) = var(name) {
            return value.trim().parse().map_err(|_| {
                Failure::Usage(format!("{name}={value:?} is not a row index (0, 1, ...)"))
            });
        }
    }
    Err(Failure::Usage(format!(
        "no row: give --index I or --all, or run as an array task ({} set)",
        INDEX_VARIABLES.join(", ")
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_index_comes_from_the_first_variable_set() {
        let env = |pairs: &'static [(&'static str, &'static str)]| {
            move |name: &str| {
                pairs
                    .iter()
                    .find(|(k, _)| *k == name)
                    .map(|(_, v)| v.to_string())
            }
        };
        assert_eq!(index_from_env(env(&[("SLURM_ARRAY_TASK_ID", "7")])), Ok(7));
        assert_eq!(
            index_from_env(env(&[
                ("SLURM_ARRAY_TASK_ID", "7"),
                ("JOB_COMPLETION_INDEX", " 2 ")
            ])),
            Ok(2)
        );
        assert_eq!(
            index_from_env(env(&[("AWS_BATCH_JOB_ARRAY_INDEX", "0")])),
            Ok(0)
        );
        let e = index_from_env(env(&[("JOB_COMPLETION_INDEX", "x")])).expect_err("bad");
        assert!(e.message().contains("JOB_COMPLETION_INDEX") && e.code() == USAGE);
        assert_eq!(index_from_env(env(&[])).map_err(|e| e.code()), Err(USAGE));
    }
}
