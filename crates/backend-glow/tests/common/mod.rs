//! Shared support of the glow backend's integration tests: a backend or a printed skip, and the
//! image-diff helper of the cross-backend tests (written to move to the workspace's `tests/`
//! harness unchanged: it only knows `MapImage`s and tolerances).
#![allow(
    dead_code,
    reason = "each test binary uses a different part of this module"
)]

use std::path::PathBuf;

use luxbake::map::MapImage;
use luxbake::output::encode_png;
use luxbake::output::picture::{Picture, srgb_byte};
use luxbake_backend_glow::GlowBackend;

/// A glow backend on a headless context; without a driver `None` with a printed reason,
/// unless `CI` is set: then a missing driver fails (a GPU test skipped in CI is a failure).
pub fn backend_or_skip(test: &str) -> Option<GlowBackend> {
    match GlowBackend::headless() {
        Ok(b) => Some(b),
        Err(e) if std::env::var_os("CI").is_none() => {
            eprintln!("skipping {test}: no headless GL context ({e}); set CI=true to fail instead");
            None
        }
        Err(e) => panic!("{test}: no headless GL context in CI: {e}"),
    }
}

/// Explicit tolerances of one image comparison.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// Largest relative RMSE: `sqrt(Σ(a − e)²) / sqrt(Σe²)` over the RGB of valid texels.
    pub rel_rmse: f64,
    /// Largest 99th percentile of the per-texel relative error
    /// `max_c |a_c − e_c| / max(|e_c|, floor)`, `floor = FLOOR_FRACTION × mean |e|`.
    pub p99: f64,
}

/// Relative errors below this fraction of the image's mean absolute value are measured against
/// that floor, so that near-black texels do not dominate the percentile.
pub const FLOOR_FRACTION: f64 = 1e-3;

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
}

/// Compares `actual` against `expected` over the texels valid in `expected`.
pub fn diff(expected: &MapImage, actual: &MapImage) -> DiffStats {
    assert_eq!(
        (expected.width, expected.height),
        (actual.width, actual.height),
        "image sizes differ"
    );
    let mut stats = DiffStats::default();
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
                    (a - e).abs() / e.abs().max(floor)
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

/// The folder failure images go to: `$LUXBAKE_TEST_OUTPUT`, or `target/test-output` of the
/// workspace (under `$CARGO_TARGET_DIR` when set).
pub fn output_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os("LUXBAKE_TEST_OUTPUT") {
        return PathBuf::from(dir);
    }
    let target = std::env::var_os("CARGO_TARGET_DIR").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../target"),
        PathBuf::from,
    );
    target.join("test-output")
}

fn picture(map: &MapImage, value: impl Fn(&[f32]) -> [f32; 3]) -> Picture {
    let mut p = Picture::filled(map.width.max(1), map.height.max(1), [0, 0, 0]);
    for y in 0..map.height {
        for x in 0..map.width {
            let i = 4 * (y as usize * map.width as usize + x as usize);
            let v = value(&map.texels[i..i + 4]);
            p.set(x, y, v.map(srgb_byte));
        }
    }
    p
}

/// Writes `<name>_expected.png`, `<name>_actual.png` (both scaled by the expected image's
/// largest value) and `<name>_difference.png` (|a − e| scaled by its own largest value) to
/// `dir`, and returns the folder.
pub fn write_failure_images(
    dir: &std::path::Path,
    name: &str,
    expected: &MapImage,
    actual: &MapImage,
) -> PathBuf {
    std::fs::create_dir_all(dir).expect("create the test-output folder");
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
    let dmax = max(&difference);
    for (suffix, map, s) in [
        ("expected", expected, scale),
        ("actual", actual, scale),
        ("difference", &difference, dmax),
    ] {
        let p = picture(map, |t| [t[0] / s, t[1] / s, t[2] / s]);
        let path = dir.join(format!("{name}_{suffix}.png"));
        std::fs::write(&path, encode_png(&p).expect("encode png")).expect("write png");
    }
    dir.to_path_buf()
}
