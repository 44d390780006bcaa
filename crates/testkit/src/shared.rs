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
