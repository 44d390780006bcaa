//! Test support: a headless context, or a printed skip outside CI.

use crate::GlContext;

/// A headless context; without a driver: `None` with a printed reason, unless `CI` is set, in
/// which case a missing driver fails the test (a GPU test skipped in CI is a failure).
pub(crate) fn context_or_skip(test: &str) -> Option<GlContext> {
    match GlContext::headless() {
        Ok(ctx) => Some(ctx),
        Err(e) if std::env::var_os("CI").is_none() => {
            eprintln!("skipping {test}: no headless GL context ({e}); set CI=true to fail instead");
            None
        }
        Err(e) => panic!("{test}: no headless GL context in CI: {e}"),
    }
}
