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
