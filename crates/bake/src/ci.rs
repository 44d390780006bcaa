//! The one rule for tests that cannot run on this machine (no GPU driver, no browser).
//!
//! **Policy**: when the `CI` environment variable is set to a true value — anything non-empty
//! other than `false` or `0` — everything must run, so a missing driver **fails** the test
//! with the reason; otherwise the test prints `skipping <test>: <reason>; set CI=true to fail
//! instead` and skips. A GPU test skipped in CI would be a test that never runs.
//!
//! Every test that needs a driver goes through [`skip_or_fail`] (directly or through
//! [`or_skip`]): the backends' own tests, the cross-backend harness and the browser check.
//! This module names no backend; each backend's error type says which of its errors mean
//! "no driver". Tests that read the shared test data (`../shared`, beside the repository) go
//! through it too when `../shared` is missing; `luxbake-ies` and `luxbake-bvh`, which do not
//! depend on this crate, apply the same rule in their own test code.

use std::fmt::Display;

/// Whether everything must run: `CI` is set to anything non-empty other than `false` or `0`.
pub fn ci_requires_everything() -> bool {
    std::env::var("CI").is_ok_and(|v| is_true(&v))
}

fn is_true(value: &str) -> bool {
    !value.is_empty() && value != "false" && value != "0"
}

/// Applies the [policy](self) to `test`, which cannot run for `reason`: panics under CI,
/// else prints `skipping <test>: <reason>; set CI=true to fail instead` and returns (the
/// caller then skips).
///
/// # Panics
/// When [`ci_requires_everything`].
pub fn skip_or_fail(test: &str, reason: &dyn Display) {
    if ci_requires_everything() {
        panic!("{test}: {reason}; CI is set, so this test may not be skipped");
    }
    eprintln!("skipping {test}: {reason}; set CI=true to fail instead");
}

/// The value of an opened driver, or `None` after [`skip_or_fail`] when `driver_missing` says
/// the error means that the machine has no driver.
///
/// # Panics
/// On any other error (a driver that is there but fails is a test failure), and on a missing
/// driver under CI.
pub fn or_skip<T, E: Display>(
    test: &str,
    opened: Result<T, E>,
    driver_missing: impl FnOnce(&E) -> bool,
) -> Option<T> {
    match opened {
        Ok(v) => Some(v),
        Err(e) if driver_missing(&e) => {
            skip_or_fail(test, &e);
            None
        }
        Err(e) => panic!("{test}: {e}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ci_values() {
        for v in ["true", "1", "yes", "TRUE"] {
            assert!(is_true(v), "{v}");
        }
        for v in ["", "false", "0"] {
            assert!(!is_true(v), "{v}");
        }
    }

    #[test]
    fn an_opened_driver_is_returned_and_a_missing_one_skipped_outside_ci() {
        assert_eq!(or_skip("t", Ok::<_, String>(3), |_| true), Some(3));
        if !ci_requires_everything() {
            assert_eq!(or_skip("t", Err::<(), _>("no driver"), |_| true), None);
        }
    }

    #[test]
    #[should_panic(expected = "t: broken")]
    fn a_failing_driver_fails_the_test() {
        or_skip("t", Err::<(), _>("broken"), |_| false);
    }
}
