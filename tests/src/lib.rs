//! # luxbake-tests: the cross-backend image-diff harness
//!
//! Every backend computes the same pass graph with the same f32 operations and the same random
//! numbers, so their light maps must agree stage by stage (the paper's Figure 5: albedo, direct,
//! blurred direct, reflected direct, indirect, combined, blurred combined, reflected combined).
//! This crate holds, in one place:
//!
//! - [`SCENES`]: the scenes compared, each with its gather sampler, and their **tolerances per
//!   stage** (one table of scenes × stages × tolerances, [`Tolerance`]: relative RMSE and
//!   99th-percentile relative error);
//! - [`KNOWN_GAPS`]: the one list of known, explained backend differences that loosen a
//!   tolerance for one backend pair (none is skipped: a gap only widens a tolerance);
//! - [`diff`] and [`write_failure_images`]: the comparison and, on failure, the expected /
//!   actual / difference PNGs written under [`output_dir`];
//! - [`Backend`]: the backends as an enum (the edge of the program, where an enum belongs),
//!   with [`Backend::open`] that skips a GPU backend without a driver outside CI and fails in
//!   CI (`CI` set): a GPU test skipped in CI is a failure.
//!
//! The comparisons run in `tests/cross_backend.rs` (cpu-vs-glow, cpu-vs-wgpu, glow-vs-wgpu on
//! `chairs_01`, `floor`, `sphere` with the paper's hash sampler and `chairs_01` with the Sobol
//! sampler) and the closed-form checks on every GPU backend in `tests/analytic.rs`. Settings
//! are reduced for test time on two CPU cores (the default bake is 64 texels per metre, 4 rays
//! and 3 bounces): [`settings`] uses 12 texels per metre, 16 gather rays, one bounce, blur
//! σ = 2. The comparison does not depend on them: every backend computes the same texels with
//! the same random numbers.
//!
//! The diff code started as the glow backend's `tests/common` (moved here to be shared).
#![warn(missing_docs)]

use std::path::{Path, PathBuf};

use luxbake::bake::{BakeError, BakeOutput, Progress, bake};
use luxbake::cpu::CpuBackend;
use luxbake::graph::Figure5;
use luxbake::map::MapImage;
use luxbake::output::encode_png;
use luxbake::output::picture::{Picture, srgb_byte};
use luxbake::scene::{Blur, BvhMode, Sampler, Scene, Settings};
use luxbake_backend_glow::GlowBackend;
use luxbake_backend_wgpu::WgpuBackend;

/// Explicit tolerances of one image comparison.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// Largest relative RMSE: `sqrt(Σ(a − e)²) / sqrt(Σe²)` over the RGB of valid texels.
    pub rel_rmse: f64,
    /// Largest 99th percentile of the per-texel relative error
    /// `max_c |a_c − e_c| / max(|e_c|, floor)`, `floor = FLOOR_FRACTION × mean |e|`.
    pub p99: f64,
}

const fn tol(rel_rmse: f64, p99: f64) -> Tolerance {
    Tolerance { rel_rmse, p99 }
}

/// Relative errors below this fraction of the image's mean absolute value are measured against
/// that floor, so that near-black texels do not dominate the percentile.
pub const FLOOR_FRACTION: f64 = 1e-3;

/// Stages whose inputs are uploaded: identical on every backend.
const EXACT: Tolerance = tol(0.0, 0.0);
/// Direct light: the same f32 operations in the same order; only the drivers' `sqrt`, division
/// and our acos/atan2 polynomials (a few ulps) differ, and a shadow ray that grazes an edge may
/// flip (rare: the percentile).
const DIRECT: Tolerance = tol(1e-5, 1e-5);
/// Gathered light: the directions go through the drivers' `cos`/`sin` (about 1 ulp), so a ray
/// that grazes an edge can hit another surface and change a texel by one ray's share (1/16
/// here) of its value.
const GATHERED: Tolerance = tol(1e-3, 1e-4);

/// One compared scene: its built-in name, the gather's sampler and its tolerance per Figure 5
/// stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneCase {
    /// Built-in scene name ([`Scene::builtin_with_settings`]).
    pub scene: &'static str,
    /// The gather directions' sampler ([`Settings::sampler`]).
    pub sampler: Sampler,
    /// Tolerance per stage, in [`Figure5::NAMES`] order.
    pub stages: [Tolerance; 8],
}

impl SceneCase {
    /// The case's name in reports, failure-image folders and [`KNOWN_GAPS`]: the scene, with
    /// `_<sampler>` appended for any sampler but the default hash (`chairs_01_sobol`).
    pub fn name(&self) -> String {
        if self.sampler == Sampler::default() {
            self.scene.to_owned()
        } else {
            format!("{}_{}", self.scene, self.sampler.name())
        }
    }

    /// The reduced settings ([`settings`]) with the case's sampler.
    pub fn settings(&self) -> Settings {
        Settings {
            sampler: self.sampler,
            ..settings()
        }
    }
}

/// The tolerances of a bake with a gather: the uploaded albedo exact, direct light, gathered
/// light.
const BAKED: [Tolerance; 8] = [
    EXACT, DIRECT, DIRECT, DIRECT, GATHERED, GATHERED, GATHERED, GATHERED,
];

/// The table of scenes × stages × tolerances (every backend pair).
pub const SCENES: [SceneCase; 4] = [
    SceneCase {
        scene: "chairs_01",
        sampler: Sampler::Hash,
        stages: BAKED,
    },
    SceneCase {
        scene: "floor",
        sampler: Sampler::Hash,
        stages: BAKED,
    },
    SceneCase {
        scene: "sphere",
        sampler: Sampler::Hash,
        stages: BAKED,
    },
    SceneCase {
        scene: "chairs_01",
        sampler: Sampler::Sobol,
        stages: BAKED,
    },
];

/// A known, explained difference between two backends: replaces the table's tolerance of one
/// stage of one case for one pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KnownGap {
    /// The pair, as `"expected-vs-actual"` ([`Pair::name`]).
    pub pair: &'static str,
    /// Case name ([`SceneCase::name`]).
    pub case: &'static str,
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

/// The tolerance of `stage` of `case` for `pair`: a known gap's, else the table's.
pub fn tolerance(pair: &str, case: &SceneCase, stage: usize) -> Tolerance {
    KNOWN_GAPS
        .iter()
        .find(|g| g.pair == pair && g.case == case.name() && g.stage == stage)
        .map_or(case.stages[stage], |g| g.tolerance)
}

/// The reduced bake settings of the comparisons (see the crate docs).
pub fn settings() -> Settings {
    Settings {
        rays: 16,
        bounces: 1,
        blur: Blur::Sigma(2.0),
        texels_per_metre: 12.0,
        bvh: BvhMode::Mtbvh,
        seed: 7,
        ..Settings::default()
    }
}

/// The result of one comparison.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DiffStats {
    /// Texels compared (valid in the expected image).
    pub texels: usize,
    /// Texels whose mask (alpha > ½) differs between the images.
    pub mask_mismatches: usize,
    /// Relative RMSE (see [`Tolerance::rel_rmse`]).
    pub rel_rmse: f64,
    /// 99th percentile relative error (see [`Tolerance::p99`]).
    pub p99: f64,
    /// Largest relative error.
    pub max: f64,
}

impl DiffStats {
    /// Whether the comparison is within `tol` (and the masks agree).
    pub fn within(&self, tol: Tolerance) -> bool {
        self.mask_mismatches == 0 && self.rel_rmse <= tol.rel_rmse && self.p99 <= tol.p99
    }

    /// Pools per-object statistics: counts add, errors take the worst.
    pub fn pool(&mut self, s: &DiffStats) {
        self.texels += s.texels;
        self.mask_mismatches += s.mask_mismatches;
        self.rel_rmse = self.rel_rmse.max(s.rel_rmse);
        self.p99 = self.p99.max(s.p99);
        self.max = self.max.max(s.max);
    }
}

/// Compares `actual` against `expected` over the texels valid in `expected`. Images of
/// different sizes compare as all texels mismatched.
pub fn diff(expected: &MapImage, actual: &MapImage) -> DiffStats {
    let mut stats = DiffStats::default();
    if (expected.width, expected.height) != (actual.width, actual.height) {
        stats.mask_mismatches = expected.width as usize * expected.height as usize;
        stats.rel_rmse = f64::INFINITY;
        stats.p99 = f64::INFINITY;
        stats.max = f64::INFINITY;
        return stats;
    }
    let (mut se, mut sd, mut sabs) = (0.0f64, 0.0f64, 0.0f64);
    let pairs: Vec<(&[f32], &[f32])> = expected
        .texels
        .chunks_exact(4)
        .zip(actual.texels.chunks_exact(4))
        .collect();
    for (e, a) in &pairs {
        if (e[3] > 0.5) != (a[3] > 0.5) {
            stats.mask_mismatches += 1;
        }
        if e[3] > 0.5 {
            stats.texels += 1;
            for c in 0..3 {
                let (e, a) = (f64::from(e[c]), f64::from(a[c]));
                se += e * e;
                sd += (a - e) * (a - e);
                sabs += e.abs();
            }
        }
    }
    if stats.texels == 0 {
        return stats;
    }
    stats.rel_rmse = if se > 0.0 {
        (sd / se).sqrt()
    } else {
        sd.sqrt()
    };
    let floor = (FLOOR_FRACTION * sabs / (3 * stats.texels) as f64).max(f64::MIN_POSITIVE);
    let mut rel: Vec<f64> = pairs
        .iter()
        .filter(|(e, _)| e[3] > 0.5)
        .map(|(e, a)| {
            (0..3)
                .map(|c| {
                    let (e, a) = (f64::from(e[c]), f64::from(a[c]));
                    let r = (a - e).abs() / e.abs().max(floor);
                    if r.is_nan() { f64::INFINITY } else { r }
                })
                .fold(0.0, f64::max)
        })
        .collect();
    rel.sort_by(f64::total_cmp);
    let idx = ((rel.len() as f64 * 0.99).ceil() as usize).clamp(1, rel.len()) - 1;
    stats.p99 = rel[idx];
    stats.max = rel[rel.len() - 1];
    stats
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

fn picture(map: &MapImage, scale: f32) -> Picture {
    let mut p = Picture::filled(map.width.max(1), map.height.max(1), [0, 0, 0]);
    for y in 0..map.height {
        for x in 0..map.width {
            let t = map.texel(x, y);
            p.set(x, y, [t[0], t[1], t[2]].map(|v| srgb_byte(v / scale)));
        }
    }
    p
}

/// Writes `<name>_expected.png`, `<name>_actual.png` (both scaled by the expected image's
/// largest value) and `<name>_difference.png` (|a − e| scaled by its own largest value) to
/// `dir`.
///
/// # Errors
/// The folder or a file cannot be written.
pub fn write_failure_images(
    dir: &Path,
    name: &str,
    expected: &MapImage,
    actual: &MapImage,
) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let max = |m: &MapImage| {
        m.texels
            .chunks_exact(4)
            .flat_map(|t| [t[0], t[1], t[2]])
            .fold(0.0f32, f32::max)
            .max(f32::MIN_POSITIVE)
    };
    let scale = max(expected);
    let mut difference = expected.clone();
    for (d, a) in difference.texels.iter_mut().zip(&actual.texels) {
        *d = (*d - a).abs();
    }
    for t in difference.texels.chunks_exact_mut(4) {
        t[3] = 1.0;
    }
    let dmax = max(&difference);
    for (suffix, map, s) in [
        ("expected", expected, scale),
        ("actual", actual, scale),
        ("difference", &difference, dmax),
    ] {
        let png = encode_png(&picture(map, s)).map_err(std::io::Error::other)?;
        std::fs::write(dir.join(format!("{name}_{suffix}.png")), png)?;
    }
    Ok(())
}

/// The backends, at the edge of the program.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Backend {
    /// The CPU reference (always available).
    Cpu,
    /// OpenGL ES 3.0 through EGL (llvmpipe in CI).
    Glow,
    /// wgpu on Vulkan (lavapipe in CI).
    Wgpu,
}

/// An opened backend.
#[derive(Debug)]
pub enum Opened {
    /// The CPU reference.
    Cpu(CpuBackend),
    /// The glow backend.
    Glow(Box<GlowBackend>),
    /// The wgpu backend.
    Wgpu(Box<WgpuBackend>),
}

/// Whether a missing GPU driver must fail the test run: the `CI` environment variable is set
/// (to anything but `false` or `0`).
pub fn in_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false" && v != "0")
}

impl Backend {
    /// Every backend.
    pub const ALL: [Backend; 3] = [Backend::Cpu, Backend::Glow, Backend::Wgpu];

    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Backend::Cpu => "cpu",
            Backend::Glow => "glow",
            Backend::Wgpu => "wgpu",
        }
    }

    /// Opens the backend. Without a driver: `None` with a printed reason outside CI; in CI a
    /// panic (the test fails: a GPU test skipped in CI is a failure).
    pub fn open(self, test: &str) -> Option<Opened> {
        let result = match self {
            Backend::Cpu => return Some(Opened::Cpu(CpuBackend::new())),
            Backend::Glow => GlowBackend::headless()
                .map(|b| Opened::Glow(Box::new(b)))
                .map_err(|e| e.to_string()),
            Backend::Wgpu => WgpuBackend::new()
                .map(|b| Opened::Wgpu(Box::new(b)))
                .map_err(|e| e.to_string()),
        };
        match result {
            Ok(b) => Some(b),
            Err(e) if !in_ci() => {
                eprintln!(
                    "skipping {} in {test}: no driver ({e}); set CI=true to fail instead",
                    self.name()
                );
                None
            }
            Err(e) => panic!(
                "{test}: the {} backend has no driver in CI: {e}",
                self.name()
            ),
        }
    }
}

impl Opened {
    /// Bakes `scene` with `settings`.
    ///
    /// # Errors
    /// The bake's error, as text (backend error types differ).
    pub fn bake(
        &mut self,
        scene: &Scene,
        settings: &Settings,
        progress: &mut dyn FnMut(&Progress<'_>),
    ) -> Result<BakeOutput, String> {
        fn text<E: std::error::Error>(e: BakeError<E>) -> String {
            e.to_string()
        }
        match self {
            Opened::Cpu(b) => bake(b, scene, settings, progress).map_err(text),
            Opened::Glow(b) => bake(b.as_mut(), scene, settings, progress).map_err(text),
            Opened::Wgpu(b) => bake(b.as_mut(), scene, settings, progress).map_err(text),
        }
    }
}

/// Two backends compared: `expected` is the reference of the pair.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pair {
    /// The reference.
    pub expected: Backend,
    /// The backend under test.
    pub actual: Backend,
}

impl Pair {
    /// The three comparisons: cpu-vs-glow, cpu-vs-wgpu, glow-vs-wgpu.
    pub const ALL: [Pair; 3] = [
        Pair {
            expected: Backend::Cpu,
            actual: Backend::Glow,
        },
        Pair {
            expected: Backend::Cpu,
            actual: Backend::Wgpu,
        },
        Pair {
            expected: Backend::Glow,
            actual: Backend::Wgpu,
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
/// images are written under `output_dir()/<pair>/<case name>/`).
pub fn compare(
    pair: Pair,
    case: &SceneCase,
    expected: &BakeOutput,
    actual: &BakeOutput,
) -> (Vec<StageReport>, Vec<String>) {
    let name = pair.name();
    let case_name = case.name();
    let mut reports = Vec::new();
    let mut failures = Vec::new();
    if expected.maps.len() != actual.maps.len() {
        failures.push(format!(
            "{name} {}: {} objects vs {}",
            case_name,
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
                        case_name,
                        e.name,
                        stage + 1
                    ));
                    continue;
                }
            };
            let s = diff(ei, ai);
            pooled.pool(&s);
            if !s.within(tolerance) {
                let dir = output_dir().join(&name).join(&case_name);
                let file = format!("{}_{}", e.name, Figure5::NAMES[stage].replace(' ', "_"));
                let written = match write_failure_images(&dir, &file, ei, ai) {
                    Ok(()) => format!("images in {}", dir.display()),
                    Err(err) => format!("images not written: {err}"),
                };
                failures.push(format!(
                    "{name} {} `{}` stage ({}) {}: {s:?} exceeds {tolerance:?}; {written}",
                    case_name,
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

    fn image(values: &[(f32, bool)]) -> MapImage {
        MapImage {
            width: values.len() as u32,
            height: 1,
            texels: values
                .iter()
                .flat_map(|&(v, m)| [v, v, v, if m { 1.0 } else { 0.0 }])
                .collect(),
        }
    }

    #[test]
    fn identical_images_have_zero_error() {
        let a = image(&[(1.0, true), (2.0, true), (0.0, false)]);
        let s = diff(&a, &a);
        assert_eq!(s.texels, 2);
        assert_eq!(
            (s.rel_rmse, s.p99, s.max, s.mask_mismatches),
            (0.0, 0.0, 0.0, 0)
        );
        assert!(s.within(EXACT));
    }

    #[test]
    fn errors_masks_and_sizes_are_detected() {
        let e = image(&[(1.0, true), (2.0, true), (4.0, true), (0.0, false)]);
        let a = image(&[(1.0, true), (2.2, true), (4.0, true), (0.0, false)]);
        let s = diff(&e, &a);
        assert!((s.max - 0.1).abs() < 1e-6, "{s:?}");
        assert!((s.rel_rmse - (3.0 * 0.04f64 / (3.0 * 21.0)).sqrt()).abs() < 1e-6);
        assert!(!s.within(tol(1e-3, 1.0)));
        assert!(!s.within(tol(1.0, 1e-3)));
        assert!(s.within(tol(0.1, 0.11)));
        let m = image(&[(1.0, true), (2.0, false), (4.0, true), (0.0, false)]);
        assert_eq!(diff(&e, &m).mask_mismatches, 1);
        assert!(!diff(&e, &m).within(tol(f64::MAX, f64::MAX)));
        let nan = image(&[(1.0, true), (f32::NAN, true), (4.0, true), (0.0, false)]);
        assert!(!diff(&e, &nan).within(tol(1.0, 1.0)));
        let small = image(&[(1.0, true)]);
        assert!(!diff(&e, &small).within(tol(f64::MAX, f64::MAX)));
    }

    #[test]
    fn failure_images_are_written() {
        let dir = output_dir().join("harness-self-test");
        let e = image(&[(1.0, true), (2.0, true)]);
        let a = image(&[(1.0, true), (3.0, true)]);
        write_failure_images(&dir, "x", &e, &a).expect("write");
        for s in ["expected", "actual", "difference"] {
            let p = dir.join(format!("x_{s}.png"));
            assert!(std::fs::metadata(&p).is_ok_and(|m| m.len() > 0), "{p:?}");
        }
    }

    #[test]
    fn known_gaps_name_real_pairs_scenes_and_stages() {
        let pairs: Vec<String> = Pair::ALL.iter().map(|p| p.name()).collect();
        for g in KNOWN_GAPS {
            assert!(pairs.contains(&g.pair.to_owned()), "{g:?}");
            assert!(SCENES.iter().any(|c| c.name() == g.case), "{g:?}");
            assert!(g.stage < 8 && !g.reason.is_empty(), "{g:?}");
        }
        // Every table scene exists, and case names are unique.
        for c in SCENES {
            assert!(Scene::builtin_names().contains(&c.scene), "{}", c.scene);
        }
        let names: std::collections::HashSet<String> = SCENES.iter().map(|c| c.name()).collect();
        assert_eq!(names.len(), SCENES.len());
        assert_eq!(SCENES[3].name(), "chairs_01_sobol");
        assert_eq!(SCENES[3].settings().sampler, Sampler::Sobol);
        assert_eq!(SCENES[0].settings(), settings());
    }
}
