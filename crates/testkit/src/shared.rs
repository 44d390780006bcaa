//! The shared test data beside the repository (`../shared`).

use std::path::PathBuf;

use crate::skip_or_fail;

/// `relative` inside the shared test data (`../shared` from the repository root), or `None`
/// after [`skip_or_fail`] for `test` when it is missing (which fails `test` under CI).
#[track_caller]
pub fn shared_data(test: &str, relative: &str) -> Option<PathBuf> {
    // This crate is `crates/testkit`: the repository root is two folders up.
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared")
        .join(relative);
    if path.exists() {
        return Some(path);
    }
    skip_or_fail(test, &format!("{} not found", path.display()));
    None
}

/// An empty path in the temporary folder for this process, `luxbake-<prefix>-<pid>-<tag>`
/// (anything an earlier run left there removed): where a test writes files.
pub fn temp_dir(prefix: &str, tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("luxbake-{prefix}-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}
