//! The failures of the catalogue commands and their exit codes (the table in the
//! [`catalogue`](super) docs).

use std::process::ExitCode;

/// The exit code of a permanent input error (a Kubernetes `podFailurePolicy` maps it to
/// `FailIndex`).
pub const PERMANENT: u8 = 3;
/// The exit code of a usage error (clap's own code for bad flags).
pub const USAGE: u8 = 2;
/// The exit code of a failure worth retrying.
pub const RETRYABLE: u8 = 1;

/// Why a catalogue command failed, and so its exit code.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Failure {
    /// Bad flags, an unreadable catalogue or manifest, an index out of range (exit 2).
    Usage(String),
    /// A permanent input error of a row (exit 3); its record is in `OUT/errors/<key>.json`.
    Permanent(String),
    /// A failure that may pass on a retry (exit 1).
    Retryable(String),
}

impl Failure {
    /// The process exit code ([`USAGE`], [`PERMANENT`] or [`RETRYABLE`]).
    pub fn code(&self) -> u8 {
        match self {
            Failure::Usage(_) => USAGE,
            Failure::Permanent(_) => PERMANENT,
            Failure::Retryable(_) => RETRYABLE,
        }
    }

    /// The message, for stderr.
    pub fn message(&self) -> &str {
        match self {
            Failure::Usage(m) | Failure::Permanent(m) | Failure::Retryable(m) => m,
        }
    }

    /// Prints the message on stderr and gives the exit code.
    pub fn report(self) -> ExitCode {
        eprintln!("error: {}", self.message());
        ExitCode::from(self.code())
    }
}
