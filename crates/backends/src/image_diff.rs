//! Light maps compared texel by texel: the measure behind every cross-backend test and the
//! browser check.
//!
//! [`diff`] compares an actual map with an expected one over the texels valid in the expected
//! map (alpha > ½): the relative RMSE of their RGB, the 99th percentile and maximum of the
//! per-texel relative error (against a floor, [`FLOOR_FRACTION`], so that near-black texels do
//! not dominate), and the texels whose masks differ. [`DiffStats::within`] checks them against
//! a [`Tolerance`]; [`write_failure_images`] writes the maps and their difference as PNGs for
//! a failure.

use std::path::Path;

use luxbake::map::MapImage;
use luxbake_output::encode_png;
use luxbake_output::picture::{Picture, srgb_byte};

/// Explicit tolerances of one image comparison.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// Largest relative RMSE: `sqrt(Σ(a − e)²) / sqrt(Σe²)` over the RGB of valid texels.
    pub rel_rmse: f64,
    /// Largest 99th percentile of the per-texel relative error
    /// `max_c |a_c − e_c| / max(|e_c|, floor)`, `floor = FLOOR_FRACTION × mean |e|`.
    pub p99: f64,
}

impl Tolerance {
    /// A relative RMSE and a 99th-percentile bound.
    pub const fn new(rel_rmse: f64, p99: f64) -> Tolerance {
        Tolerance { rel_rmse, p99 }
    }
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
        assert!(s.within(Tolerance::new(0.0, 0.0)));
    }

    #[test]
    fn errors_masks_and_sizes_are_detected() {
        let e = image(&[(1.0, true), (2.0, true), (4.0, true), (0.0, false)]);
        let a = image(&[(1.0, true), (2.2, true), (4.0, true), (0.0, false)]);
        let s = diff(&e, &a);
        assert!((s.max - 0.1).abs() < 1e-6, "{s:?}");
        assert!((s.rel_rmse - (3.0 * 0.04f64 / (3.0 * 21.0)).sqrt()).abs() < 1e-6);
        assert!(!s.within(Tolerance::new(1e-3, 1.0)));
        assert!(!s.within(Tolerance::new(1.0, 1e-3)));
        assert!(s.within(Tolerance::new(0.1, 0.11)));
        let m = image(&[(1.0, true), (2.0, false), (4.0, true), (0.0, false)]);
        assert_eq!(diff(&e, &m).mask_mismatches, 1);
        assert!(!diff(&e, &m).within(Tolerance::new(f64::MAX, f64::MAX)));
        let nan = image(&[(1.0, true), (f32::NAN, true), (4.0, true), (0.0, false)]);
        assert!(!diff(&e, &nan).within(Tolerance::new(1.0, 1.0)));
        let small = image(&[(1.0, true)]);
        assert!(!diff(&e, &small).within(Tolerance::new(f64::MAX, f64::MAX)));
    }

    #[test]
    fn failure_images_are_written() {
        let dir = std::env::temp_dir().join(format!("luxbake-image-diff-{}", std::process::id()));
        let e = image(&[(1.0, true), (2.0, true)]);
        let a = image(&[(1.0, true), (3.0, true)]);
        write_failure_images(&dir, "x", &e, &a).expect("write");
        for s in ["expected", "actual", "difference"] {
            let p = dir.join(format!("x_{s}.png"));
            assert!(std::fs::metadata(&p).is_ok_and(|m| m.len() > 0), "{p:?}");
        }
        std::fs::remove_dir_all(&dir).expect("clean up");
    }
}
