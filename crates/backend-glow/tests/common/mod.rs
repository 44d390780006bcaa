//! Shared support of the glow backend's integration tests. The cross-backend image diffs,
//! the analytic checks on every GPU backend and the traversal comparison live in the
//! workspace's `tests/` harness (`luxbake-tests`).

use luxbake_backend_glow::{GlowBackend, GlowError};

/// A glow backend on a headless context; without a driver `None` after
/// [`luxbake_testkit::skip_or_fail`] (which fails the test under CI).
pub fn backend_or_skip(test: &str) -> Option<GlowBackend> {
    luxbake_testkit::or_skip(test, GlowBackend::headless(), GlowError::is_driver_missing)
}
