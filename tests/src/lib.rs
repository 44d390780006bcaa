//! # luxbake-tests: the cross-backend image-diff harness
//!
//! Every backend computes the same pass graph with the same f32 operations and the same random
//! numbers, so their light maps must agree stage by stage (the paper's Figure 5: albedo, direct,
//! blurred direct, reflected direct, indirect, combined, blurred combined, reflected combined).
//! This crate holds, in one place:
//!
//! - [`SCENES`]: the scenes compared and their **tolerances per stage** (one table of scenes ×
//!   stages × tolerances, [`Tolerance`]: relative RMSE and 99th-percentile relative error);
//! - [`KNOWN_GAPS`]: the one list of known, explained backend differences that loosen a
//!   tolerance for one backend pair (none is skipped: a gap only widens a tolerance);
//! - [`compare`]: every stage of two bakes through `luxbake_backends::image_diff`, writing the
//!   expected / actual / difference PNGs of a failure under [`output_dir`];
//! - [`Tally`]: opens a backend by [`BackendKind`] (`luxbake_backends`), skipped without a
//!   driver outside CI and failed under CI (`luxbake_testkit`): a GPU test skipped in CI is a
//!   failure; and counts what a test compared: a test that compared nothing is reported as
//!   skipped (outside CI, with the backends it skipped) or fails, and never passes.
//!
//! The comparisons run in `tests/cross_backend.rs` (cpu-vs-glow, cpu-vs-wgpu, glow-vs-wgpu on
//! `chairs_01`, `floor`, `sphere`) and the closed-form checks on every GPU backend in
//! `tests/analytic.rs`; `tests/atrous.rs` compares the à-trous denoiser's programs, which are
//! not in the bake graph yet, pass by pass on synthetic textures (cpu-vs-glow, cpu-vs-wgpu). Settings are reduced for test time on two CPU cores (the default bake
//! is 64 texels per metre, 4 rays and 3 bounces): [`settings`] uses 12 texels per metre, 16 gather rays,
//! one bounce, blur σ = 2. The comparison does not depend on them: every backend computes the
//! same texels with the same random numbers.
#![warn(missing_docs)]

use std::path::{Path, PathBuf};

use luxbake::bake::BakeOutput;
use luxbake::graph::Figure5;
use luxbake::map::MapImage;
use luxbake::scene::{Blur, BvhMode, Method, Quality, Sampler, Scene, Settings};
use luxbake_backends::image_diff::{DiffStats, Tolerance, diff, write_failure_images};
use luxbake_backends::{AnyBackend, BackendKind, OpenError};

/// Stages whose inputs are uploaded: identical on every backend.
const EXACT: Tolerance = Tolerance::new(0.0, 0.0);
/// Direct light: the same f32 operations in the same order; only the drivers' `sqrt`, division
/// and our acos/atan2 polynomials (a few ulps) differ, and a shadow ray that grazes an edge may
/// flip (rare: the percentile).
const DIRECT: Tolerance = Tolerance::new(1e-5, 1e-5);
/// Gathered light: the directions go through the drivers' `cos`/`sin` (about 1 ulp), so a ray
/// that grazes an edge can hit another surface and change a texel by one ray's share (1/16
/// here) of its value.
const GATHERED: Tolerance = Tolerance::new(1e-3, 1e-4);

/// One compared scene: its built-in name, the method baked and its tolerance per Figure 5
/// stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneCase {
    /// Built-in scene name
    /// ([`Scene::builtin_with_settings`](luxbake::scene::Scene::builtin_with_settings)).
    pub scene: &'static str,
    /// The pipeline ([`settings`]).
    pub method: Method,
    /// The gather directions' sampler ([`Settings::sampler`]).
    pub sampler: Sampler,
    /// The converged method's preset ([`settings`]; the paper's method ignores it).
    pub quality: Quality,
    /// [`Settings::refine_rays`] (0: none, as in every preset), at a target of
    /// [`REFINE_ERROR`].
    pub refine_rays: u32,
    /// [`Settings::narrow_rays`]: [`Settings::NARROW_RAYS`] in the cases with refinement (the
    /// first bounce's refinement then takes the larger of both counts where both apply, and
    /// the later bounces' reduced gathers are refined in the gaps), else 0; with it and no
    /// refinement, as at the `default` preset, every refinement works in the gaps alone.
    pub narrow_rays: u32,
    /// [`Settings::denoise_correction`] (false in every preset but `final`).
    pub denoise_correction: bool,
    /// [`Settings::direct_at_hits`].
    pub direct_at_hits: bool,
    /// Tolerance per stage, in [`Figure5::NAMES`] order.
    pub stages: [Tolerance; 8],
}

/// [`Settings::refine_error`] of the cases with refinement: about half the texels of
/// `chairs_01` at 16 rays and 12 texels/m are refined (the refine pass takes 0.52× the first
/// gather's time with as many rays; at 0.3 only ~0.2×), so both of its branches are compared.
pub const REFINE_ERROR: f32 = 0.15;

/// Gathered light after the converged method's denoiser: a ray that flips on one backend
/// (see [`GATHERED`]) also moves the variance estimate and the luminance weights of the
/// à-trous taps around it, and the bounce ratio of the tail, so a few texels near such a ray
/// differ by a few per cent (measured on `chairs_01`: relative RMSE ≤ 2.7e-3, p99 ≤ 1.8e-2).
const DENOISED: Tolerance = Tolerance::new(5e-3, 3e-2);

/// The stage tolerances of the paper's method: the G-buffer exact, the direct stages as the
/// direct light, the gathered stages as gathered light.
const STAGES: [Tolerance; 8] = [
    EXACT, DIRECT, DIRECT, DIRECT, GATHERED, GATHERED, GATHERED, GATHERED,
];

/// The stage tolerances of the converged method: stages (5)–(8) are the denoised indirect
/// light with its tail, the total and its exitance.
const CONVERGED_STAGES: [Tolerance; 8] = [
    EXACT, DIRECT, DIRECT, DIRECT, DENOISED, DENOISED, DENOISED, DENOISED,
];

/// Gathered light at reduced resolution ([`luxbake::program::coarse`]): whether a texel is
/// interpolated from its grid-cell corners or traced itself as an orphan hangs on tests of
/// the corners' normals and positions, and a corner at the threshold can count on one
/// backend and not on another (the drivers' `sqrt` and division, a fused multiply-add), so
/// such a texel carries the orphan's own few rays on one backend and its corners' mean on
/// the other. Measured on `chairs_01` at `draft`, 12 texels/m: a handful of texels of the chair's
/// legs (4 of 2022 with 16 rays per grid texel: relative RMSE 6.7e-3; with the preset's 8
/// rays, over all maps, 1.1e-2, p99 3.2e-6); glow and wgpu agree exactly.
const REDUCED: Tolerance = Tolerance::new(1.5e-2, 3e-2);

/// The stage tolerances of the `draft` preset: reduced-resolution gathers, no denoiser.
const DRAFT_STAGES: [Tolerance; 8] = [
    EXACT, DIRECT, DIRECT, DIRECT, REDUCED, REDUCED, REDUCED, REDUCED,
];

/// A case of the paper's method (hash or Sobol sampling; the preset is ignored).
const fn paper(scene: &'static str, sampler: Sampler) -> SceneCase {
    SceneCase {
        scene,
        method: Method::Paper,
        sampler,
        quality: Quality::Default,
        refine_rays: 0,
        narrow_rays: 0,
        denoise_correction: false,
        direct_at_hits: false,
        stages: STAGES,
    }
}

/// A case of the converged method with Sobol sampling at `quality`, with `refine_rays`.
const fn converged(
    scene: &'static str,
    quality: Quality,
    refine_rays: u32,
    stages: [Tolerance; 8],
) -> SceneCase {
    SceneCase {
        scene,
        method: Method::Converged,
        sampler: Sampler::Sobol,
        quality,
        refine_rays,
        narrow_rays: if refine_rays > 0 {
            Settings::NARROW_RAYS
        } else {
            0
        },
        denoise_correction: false,
        direct_at_hits: false,
        stages,
    }
}

/// The table of scenes × methods × stages × tolerances (every backend pair).
pub const SCENES: [SceneCase; 8] = [
    paper("chairs_01", Sampler::Hash),
    paper("floor", Sampler::Hash),
    paper("sphere", Sampler::Hash),
    paper("chairs_01", Sampler::Sobol),
    converged("chairs_01", Quality::Default, 0, CONVERGED_STAGES),
    converged("sphere", Quality::Default, 0, CONVERGED_STAGES),
    // Reduced-resolution gathers at every bounce, no denoiser.
    converged("chairs_01", Quality::Draft, 0, DRAFT_STAGES),
    // Progressive refinement of the first bounce (its rays and, with the preset's lamp paths,
    // its connections: the refine_connect pass), with the denoiser's bias correction (its
    // pair of luminances and linear filter), the first bounce's gather and refinement reading
    // the direct light at their hits (the downlight a point beyond its opening's 0.75 m).
    SceneCase {
        denoise_correction: true,
        direct_at_hits: true,
        ..converged("chairs_01", Quality::Default, 16, CONVERGED_STAGES)
    },
];

/// A known, explained difference between two backends: replaces the table's tolerance of one
/// stage of one scene for one pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KnownGap {
    /// The pair, as `"expected-vs-actual"` ([`Pair::name`]).
    pub pair: &'static str,
    /// Case name ([`SceneCase::name`]).
    pub scene: &'static str,
    /// Stage index (0-based, [`Figure5::NAMES`] order).
    pub stage: usize,
    /// The tolerance that applies instead.
    pub tolerance: Tolerance,
    /// Why.
    pub reason: &'static str,
}

/// The one list of known backend gaps. Empty: every backend pair meets [`SCENES`]' tolerances
/// on lavapipe/llvmpipe. Add an entry here (with its reason) rather than skipping a test.
pub const KNOWN_GAPS: &[KnownGap] = &[];

/// The tolerance of `stage` of `scene` for `pair`: a known gap's, else the table's.
pub fn tolerance(pair: &str, case: &SceneCase, stage: usize) -> Tolerance {
    KNOWN_GAPS
        .iter()
        .find(|g| g.pair == pair && g.scene == case.name() && g.stage == stage)
        .map_or(case.stages[stage], |g| g.tolerance)
}

impl SceneCase {
    /// The case's name in reports, failure-image folders and [`KNOWN_GAPS`]: the scene and the
    /// method, then the sampler when it is not the method's default
    /// (`chairs_01_paper_sobol`), the converged preset when it is not `default`
    /// (`chairs_01_converged_draft`), `refine` with refinement and `corrected` with the
    /// denoiser's bias correction.
    pub fn name(&self) -> String {
        let mut name = format!("{}_{}", self.scene, self.method.name());
        if self.sampler != settings(self.method, Quality::Default).sampler {
            name = format!("{name}_{}", self.sampler.name());
        }
        if self.method == Method::Converged && self.quality != Quality::Default {
            name = format!("{name}_{}", self.quality.name());
        }
        if self.refine_rays > 0 {
            name.push_str("_refine");
        } else if self.narrow_rays > 0 {
            name.push_str("_gaps");
        }
        if self.denoise_correction {
            name.push_str("_corrected");
        }
        if self.direct_at_hits {
            name.push_str("_direct_at_hits");
        }
        name
    }

    /// The reduced settings ([`settings`]) of the case's method and preset with its sampler,
    /// refinement and rays in narrow gaps.
    pub fn settings(&self) -> Settings {
        Settings {
            sampler: self.sampler,
            refine_rays: self.refine_rays,
            refine_error: REFINE_ERROR,
            narrow_rays: self.narrow_rays,
            denoise_correction: self.denoise_correction,
            direct_at_hits: self.direct_at_hits,
            ..settings(self.method, self.quality)
        }
    }
}

/// The reduced bake settings of the comparisons (see the crate docs): the paper's method with
/// one bounce (hash sampling), or a converged preset (Sobol sampling) with at most four explicit
/// bounces; 12 texels per metre. The paper's method and the `default` preset gather 16 rays
/// and filter at σ 2; `draft` keeps its own rays, strides and (no) filter.
pub fn settings(method: Method, quality: Quality) -> Settings {
    let base = match method {
        Method::Paper => Settings {
            bounces: 1,
            ..Settings::paper()
        },
        Method::Converged => Settings {
            bounces: 4,
            ..Settings::preset(quality)
        },
    };
    let reduced = Settings {
        texels_per_metre: 12.0,
        bvh: BvhMode::Mtbvh,
        seed: 7,
        ..base
    };
    if method == Method::Converged && quality == Quality::Draft {
        reduced
    } else {
        Settings {
            rays: 16,
            blur: Blur::Sigma(2.0),
            ..reduced
        }
    }
}

/// The folder failure images go to: `$LUXBAKE_TEST_OUTPUT`, or `test-output` under
/// `$CARGO_TARGET_DIR` when set, else under the workspace's `target/`.
pub fn output_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os("LUXBAKE_TEST_OUTPUT") {
        return PathBuf::from(dir);
    }
    let target = std::env::var_os("CARGO_TARGET_DIR").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target"),
        PathBuf::from,
    );
    target.join("test-output")
}

/// Opens `kind` for `test`; without its driver `None` after [`luxbake_testkit::skip_or_fail`]
/// (which fails the test under CI). A driver that fails to open fails the test.
fn open(kind: BackendKind, test: &str) -> Option<AnyBackend> {
    luxbake_testkit::or_skip(
        test,
        luxbake_backends::open(kind),
        OpenError::is_driver_missing,
    )
}

/// Writes the expected, actual and difference PNGs of a failed comparison as `file` in
/// `folder` under [`output_dir`]; says where they are, or why they are not there.
pub fn failure_images(
    folder: impl AsRef<Path>,
    file: &str,
    expected: &MapImage,
    actual: &MapImage,
) -> String {
    let dir = output_dir().join(folder);
    match write_failure_images(&dir, file, expected, actual) {
        Ok(()) => format!("images in {}", dir.display()),
        Err(err) => format!("images not written: {err}"),
    }
}

/// What one test compared, and which backends it skipped through [`Tally::open`].
/// [`Tally::finish`] reports it ([`Tally::verdict`]): a test that compared nothing is never a
/// pass — outside CI it is skipped by the workspace's rule
/// (`skipping <test>: compared nothing (skipped without a driver: …); set CI=true to fail
/// instead`), under CI it fails, and with no backend skipped either it fails everywhere. So a
/// machine without drivers cannot pass a test that compared nothing.
#[derive(Debug)]
pub struct Tally {
    test: String,
    compared: usize,
    skipped: Vec<BackendKind>,
}

impl Tally {
    /// An empty tally for `test`.
    pub fn new(test: impl Into<String>) -> Tally {
        Tally {
            test: test.into(),
            compared: 0,
            skipped: Vec::new(),
        }
    }

    /// Opens `kind` for this test; without its driver `None` after
    /// [`luxbake_testkit::skip_or_fail`] (which fails the test under CI), recording the skip. A
    /// driver that fails to open fails the test.
    pub fn open(&mut self, kind: BackendKind) -> Option<AnyBackend> {
        let opened = open(kind, &self.test);
        if opened.is_none() && !self.skipped.contains(&kind) {
            self.skipped.push(kind);
        }
        opened
    }

    /// Bakes `scene` at its own settings on `kind` ([`Tally::open`]: `None` when skipped); a
    /// failed bake, or a texel of any stage that is not finite and non-negative, fails the test.
    pub fn bake(&mut self, kind: BackendKind, scene: &Scene) -> Option<BakeOutput> {
        let mut backend = self.open(kind)?;
        let out = luxbake::bake::bake(&mut backend, scene, &scene.settings, &mut |_| {})
            .unwrap_or_else(|e| panic!("{kind} bake: {e}"));
        for m in &out.maps {
            for stage in m.stages.iter().flatten() {
                assert!(
                    stage.texels.iter().all(|v| v.is_finite() && *v >= 0.0),
                    "{kind} {}",
                    m.name
                );
            }
        }
        Some(out)
    }

    /// Counts `cases` compared cases (backend pairs, passes, closed forms: the test's unit).
    pub fn compared(&mut self, cases: usize) {
        self.compared += cases;
    }

    /// What the test comes to when [everything must run](luxbake_testkit::ci_requires_everything)
    /// (`ci`) or not: a pure function of the tally and `ci` ([`Tally::finish`] passes the
    /// environment's).
    pub fn verdict(&self, ci: bool) -> Verdict {
        let skipped: Vec<&str> = self.skipped.iter().map(|b| b.name()).collect();
        let skipped = skipped.join(", ");
        if self.compared > 0 {
            return Verdict::Compared(if skipped.is_empty() {
                format!("{}: {} cases compared", self.test, self.compared)
            } else {
                format!(
                    "{}: {} cases compared; skipped without a driver: {skipped} (see above)",
                    self.test, self.compared
                )
            });
        }
        if skipped.is_empty() {
            return Verdict::Failed(format!(
                "{}: compared nothing, and skipped no backend",
                self.test
            ));
        }
        let reason = format!("compared nothing (skipped without a driver: {skipped})");
        match luxbake_testkit::skip_decision(ci, &self.test, &reason) {
            Ok(line) => Verdict::Skipped(line),
            Err(message) => Verdict::Failed(message),
        }
    }

    /// Reports the test ([`Tally::verdict`] under the environment's `CI`): prints what was
    /// compared and skipped, or the skip line of a test that compared nothing.
    ///
    /// # Panics
    /// When nothing was compared: under CI, or when no backend was skipped either.
    pub fn finish(self) {
        match self.verdict(luxbake_testkit::ci_requires_everything()) {
            Verdict::Compared(line) => println!("{line}"),
            Verdict::Skipped(line) => eprintln!("{line}"),
            Verdict::Failed(message) => panic!("{message}"),
        }
    }
}

/// What a finished [`Tally`] comes to ([`Tally::verdict`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Verdict {
    /// Something was compared (a pass): the summary line, naming the backends skipped if any.
    Compared(String),
    /// Nothing was compared and backends were skipped, outside CI: the skip line of the
    /// workspace's rule (`skipping <test>: compared nothing (skipped without a driver: …); set
    /// CI=true to fail instead`).
    Skipped(String),
    /// The test fails with this message: nothing compared under CI, or nothing compared and
    /// nothing skipped.
    Failed(String),
}

/// Two backends compared: `expected` is the reference of the pair.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pair {
    /// The reference.
    pub expected: BackendKind,
    /// The backend under test.
    pub actual: BackendKind,
}

impl Pair {
    /// The three comparisons: cpu-vs-glow, cpu-vs-wgpu, glow-vs-wgpu.
    pub const ALL: [Pair; 3] = [
        Pair {
            expected: BackendKind::Cpu,
            actual: BackendKind::Glow,
        },
        Pair {
            expected: BackendKind::Cpu,
            actual: BackendKind::Wgpu,
        },
        Pair {
            expected: BackendKind::Glow,
            actual: BackendKind::Wgpu,
        },
    ];

    /// `"<expected>-vs-<actual>"`.
    pub fn name(self) -> String {
        format!("{}-vs-{}", self.expected.name(), self.actual.name())
    }
}

/// Pooled statistics of one stage of one comparison.
#[derive(Debug, Clone, PartialEq)]
pub struct StageReport {
    /// Stage index ([`Figure5::NAMES`] order).
    pub stage: usize,
    /// Statistics pooled over objects.
    pub stats: DiffStats,
    /// The tolerance applied.
    pub tolerance: Tolerance,
}

/// Compares every stage of every object of two bakes of `case` under `pair`'s tolerances;
/// returns the pooled statistics per stage and a message per failing object and stage (its
/// images are written under `output_dir()/<pair>/<scene>/`).
pub fn compare(
    pair: Pair,
    case: &SceneCase,
    expected: &BakeOutput,
    actual: &BakeOutput,
) -> (Vec<StageReport>, Vec<String>) {
    let name = pair.name();
    let mut reports = Vec::new();
    let mut failures = Vec::new();
    if expected.maps.len() != actual.maps.len() {
        failures.push(format!(
            "{name} {}: {} objects vs {}",
            case.name(),
            expected.maps.len(),
            actual.maps.len()
        ));
        return (reports, failures);
    }
    for stage in 0..8 {
        let tolerance = tolerance(&name, case, stage);
        let mut pooled = DiffStats::default();
        for (e, a) in expected.maps.iter().zip(&actual.maps) {
            let (ei, ai) = match (&e.stages[stage], &a.stages[stage]) {
                (Some(ei), Some(ai)) => (ei, ai),
                (None, None) => continue,
                _ => {
                    failures.push(format!(
                        "{name} {} `{}` stage ({}): present in one bake only",
                        case.name(),
                        e.name,
                        stage + 1
                    ));
                    continue;
                }
            };
            let s = diff(ei, ai);
            pooled.pool(&s);
            if !s.within(tolerance) {
                let file = format!("{}_{}", e.name, Figure5::NAMES[stage].replace(' ', "_"));
                let written = failure_images(Path::new(&name).join(case.name()), &file, ei, ai);
                failures.push(format!(
                    "{name} {} `{}` stage ({}) {}: {s:?} exceeds {tolerance:?}; {written}",
                    case.name(),
                    e.name,
                    stage + 1,
                    Figure5::NAMES[stage],
                ));
            }
        }
        reports.push(StageReport {
            stage,
            stats: pooled,
            tolerance,
        });
    }
    (reports, failures)
}

#[cfg(test)]
mod tests {
    use super::*;
    use luxbake::scene::Scene;

    #[test]
    fn known_gaps_name_real_pairs_scenes_and_stages() {
        let pairs: Vec<String> = Pair::ALL.iter().map(|p| p.name()).collect();
        for g in KNOWN_GAPS {
            assert!(pairs.contains(&g.pair.to_owned()), "{g:?}");
            assert!(SCENES.iter().any(|c| c.scene == g.scene), "{g:?}");
            assert!(g.stage < 8 && !g.reason.is_empty(), "{g:?}");
        }
        // Every table scene exists.
        for c in SCENES {
            assert!(Scene::builtin_names().contains(&c.scene), "{}", c.scene);
        }
    }

    #[test]
    fn a_tally_that_compared_something_passes() {
        let mut tally = Tally::new("t");
        tally.compared(2);
        tally.finish();
    }

    #[test]
    #[should_panic(expected = "t: compared nothing, and skipped no backend")]
    fn a_tally_that_compared_nothing_and_skipped_nothing_fails() {
        Tally::new("t").finish();
    }

    fn tally(compared: usize, skipped: &[BackendKind]) -> Tally {
        Tally {
            test: "t".to_owned(),
            compared,
            skipped: skipped.to_vec(),
        }
    }

    #[test]
    fn a_tally_that_compared_nothing_is_skipped_outside_ci_never_passed() {
        assert_eq!(
            tally(0, &[BackendKind::Glow, BackendKind::Wgpu]).verdict(false),
            Verdict::Skipped(
                "skipping t: compared nothing (skipped without a driver: glow, wgpu); \
                 set CI=true to fail instead"
                    .to_owned()
            )
        );
    }

    #[test]
    fn a_tally_that_compared_nothing_fails_under_ci() {
        assert_eq!(
            tally(0, &[BackendKind::Wgpu]).verdict(true),
            Verdict::Failed(
                "t: compared nothing (skipped without a driver: wgpu); \
                 CI is set, so this test may not be skipped"
                    .to_owned()
            )
        );
    }

    #[test]
    fn a_tally_that_compared_nothing_and_skipped_nothing_fails_in_and_out_of_ci() {
        for ci in [false, true] {
            assert_eq!(
                tally(0, &[]).verdict(ci),
                Verdict::Failed("t: compared nothing, and skipped no backend".to_owned()),
                "ci {ci}"
            );
        }
    }

    #[test]
    fn a_tally_that_compared_something_passes_and_says_what_it_skipped() {
        for ci in [false, true] {
            assert_eq!(
                tally(2, &[]).verdict(ci),
                Verdict::Compared("t: 2 cases compared".to_owned())
            );
            assert_eq!(
                tally(3, &[BackendKind::Wgpu]).verdict(ci),
                Verdict::Compared(
                    "t: 3 cases compared; skipped without a driver: wgpu (see above)".to_owned()
                )
            );
        }
    }
}
