//! The one rule for tests that cannot run on this machine (see the [crate docs](crate)).

use std::fmt::Display;

/// Whether everything must run: `CI` is set to anything non-empty other than `false` or `0`.
pub fn ci_requires_everything() -> bool {
    std::env::var("CI").is_ok_and(|v| is_true(&v))
}

fn is_true(value: &str) -> bool {
    !value.is_empty() && value != "false" && value != "0"
}

/// The [rule](crate) as a pure function of `ci` (whether [everything must
/// run](ci_requires_everything)) for `test`, which cannot run for `reason`: `Ok` with the line
/// printed when it skips (`skipping <test>: <reason>; set CI=true to fail instead`), or `Err`
/// with the message it fails with (`<test>: <reason>; CI is set, so this test may not be
/// skipped`). For callers that decide more than a skip and test that decision without the
/// environment; [`skip_or_fail`] is this with the environment's `CI`.
pub fn skip_decision(ci: bool, test: &str, reason: &dyn Display) -> Result<String, String> {
    if ci {
        Err(format!(
            "{test}: {reason}; CI is set, so this test may not be skipped"
        ))
    } else {
        Ok(format!(
            "skipping {test}: {reason}; set CI=true to fail instead"
        ))
    }
}

/// Applies the [rule](crate) to `test`, which cannot run for `reason`: panics under CI, else
/// prints `skipping <test>: <reason>; set CI=true to fail instead` and returns (the caller
/// then skips).
///
/// # Panics
/// When [`ci_requires_everything`] (at the caller's location).
#[track_caller]
pub fn skip_or_fail(test: &str, reason: &dyn Display) {
    match skip_decision(ci_requires_everything(), test, reason) {
        Ok(line) => eprintln!("{line}"),
        Err(message) => panic!("{message}"),
    }
}

/// The value of an opened driver, or `None` after [`skip_or_fail`] when `driver_missing` says
/// the error means that the machine has no driver.
///
/// # Panics
/// On any other error (a driver that is there but fails is a test failure), and on a missing
/// driver under CI (at the caller's location).
#[track_caller]
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
    fn the_rule_skips_outside_ci_and_fails_under_it() {
        assert_eq!(
            skip_decision(false, "t", &"no driver"),
            Ok("skipping t: no driver; set CI=true to fail instead".to_owned())
        );
        assert_eq!(
            skip_decision(true, "t", &"no driver"),
            Err("t: no driver; CI is set, so this test may not be skipped".to_owned())
        );
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
