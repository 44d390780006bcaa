//! # luxbake-testkit: test support for the whole workspace
//!
//! Two things every crate's tests need, in one place, with no dependency:
//!
//! - **The one rule for tests that cannot run on this machine** (no GPU driver, no browser,
//!   no shared test data, a CPU without a feature): [`ci_requires_everything`],
//!   [`skip_or_fail`], [`or_skip`] (and [`skip_decision`], the rule as a pure function);
//! - **The one seeded generator of test data**: [`SplitMix64`], whose streams are fixed (test
//!   scenes, rays and expected values are drawn from them);
//! - small shared helpers: [`shared_data`] (the shared test data), [`temp_dir`] (where a test
//!   writes files), [`RelativeError`] (the largest and mean relative error of compared
//!   values), [`fibonacci_sphere`] (evenly spread test directions) and
//!   [`photometric_test_directions`] (the edge cases of a table look-up, then random ones).
//!
//! ## The skip rule
//!
//! When the `CI` environment variable is set to a true value — anything non-empty other
//! than `false` or `0` — everything must run, so a test that cannot run **fails** with the
//! reason (`<test>: <reason>; CI is set, so this test may not be skipped`); otherwise the
//! test prints `skipping <test>: <reason>; set CI=true to fail instead` and skips. A GPU
//! test skipped in CI would be a test that never runs, and a test that skips in silence
//! would be a pass that compared nothing.
//!
//! Every test that needs a driver goes through [`skip_or_fail`] (directly or through
//! [`or_skip`]): the backends' own tests, the cross-backend harness (`luxbake-tests`, whose
//! `Tally` also reports a test that compared nothing as skipped, never as passed) and the
//! browser and npm checks (`cargo xtask web --check`, `cargo xtask npm --check`). This crate
//! names no backend; each backend's error type says which of its errors mean "no driver"
//! (`GlowError::is_driver_missing`, `WgpuError::is_driver_missing`,
//! `OpenError::is_driver_missing`): any other error of a driver that is there fails the
//! test. Tests that read the shared test data (`../shared`, beside the repository) find it
//! with [`shared_data`], which goes through it when the data is missing.
//!
//! ## Who depends on it
//!
//! Every library crate takes it as a **dev-dependency** only, so none of them ships test
//! policy and `luxbake-ies` and `luxbake-bvh` stay standalone for their users. The tools
//! (`xtask`, `luxbake-bench-embree`) and the cross-backend test crate (`luxbake-tests`, whose
//! library is the harness) depend on it normally. It is never published.
#![warn(missing_docs)]

mod ci;
mod shared;
mod sphere;
mod splitmix;
mod stats;

pub use ci::{ci_requires_everything, or_skip, skip_decision, skip_or_fail};
pub use shared::{shared_data, temp_dir};
pub use sphere::{fibonacci_sphere, photometric_test_directions};
pub use splitmix::SplitMix64;
pub use stats::RelativeError;
