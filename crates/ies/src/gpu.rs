//! [`GpuTable`]: the distribution resampled on a regular (γ, C) grid for shaders.

use crate::Photometry;
use crate::sphere::Axis;
use std::f64::consts::{PI, TAU};

/// The intensity distribution resampled on a regular grid over (γ, C) of the photometric frame,
/// for upload as a one-channel float texture.
///
/// # Parametrisation (fixed; shaders rely on it)
/// * `height` rows over γ, the angle from nadir (−Z): row `j` ↔ γ = π·j/(height−1). Row 0 is
///   nadir, the last row zenith.
/// * `width` columns over C (from +X toward +Y): column `i` ↔ C = 2π·i/width; C wraps at 2π.
/// * `values[j * width + i]`, row-major, row 0 first; candela with every multiplier applied
///   (as [`Photometry::intensity`], or [`Photometry::intensity_tilted`] for
///   [`Photometry::gpu_table_tilted`]).
///
/// # Sampling ([`GpuTable::sample`], mirror it line for line in GLSL/WGSL)
/// ```text
/// len = length(d);               if !(len > 0) return 0
/// γ  = acos(clamp(-d.z / len, -1, 1))
/// C  = atan2(d.y, d.x);          if C < 0 { C += 2π }
/// ```
/// (`acos` and `atan2` are [`acos_f32`] and [`atan2_f32`], in the shaders `luxAcos` /
/// `luxAtan2` and `lux_acos` / `lux_atan2`: the same polynomials in the same order, a few ulp
/// from the exact angles; drivers' built-ins are off by up to thousands of ulp.)
/// ```text
/// fy = γ / π · (height − 1);     fx = C / (2π) · width
/// x0 = floor(fx), tx = fx − x0;  i0 = x0 mod width, i1 = (i0 + 1) mod width     (wrap in x)
/// y0 = clamp(floor(fy), 0, height − 1), ty = clamp(fy − y0, 0, 1), y1 = min(y0 + 1, height − 1)
/// value = mix(mix(v[y0][i0], v[y0][i1], tx), mix(v[y1][i0], v[y1][i1], tx), ty)
/// ```
///
/// # Resolution
/// For types C and A (whose grids are already γ/C grids) the table step is the largest angle
/// that divides every file angle (and 180° resp. 360°), split further to at most 0.5° in γ and
/// 1° in C, so every file node is a table node and bilinear sampling of the table reproduces
/// [`Photometry::intensity`] up to f32 rounding — except within one table cell of an edge
/// where the data stops (e.g. just above 90° for a 0–90° file whose 90° value is not 0), where
/// the table ramps to zero over that thin cell. A rotationally symmetric file gets one column.
/// When no such step fits in 1025 rows or 2048 columns, the table falls back to 0.25°
/// (721 × 1440).
/// Type B data lives on a grid about another axis and is resampled at 0.5° (361 × 720).
/// The tests check `sample` against `intensity` over many directions for every sample file.
#[derive(Clone, Debug, PartialEq)]
pub struct GpuTable {
    /// Number of columns (C samples).
    pub width: u32,
    /// Number of rows (γ samples), at least 2.
    pub height: u32,
    /// `width × height` values in candela, row-major, row 0 (nadir) first.
    pub values: Vec<f32>,
}

/// `tan(π/8)`: where [`atan_unit_f32`] reduces its argument.
pub const TAN_PI_8: f32 = 0.414_213_57;

/// [`atan_unit_f32`]'s odd polynomial on `[−tan(π/8), tan(π/8)]` (Cephes' `atanf`), highest
/// degree first: `atan z ≈ z + z·w·(((c₀w + c₁)w + c₂)w + c₃)`, `w = z²`.
pub const ATAN_POLY: [f32; 4] = [0.080_537_446, -0.138_776_85, 0.199_777_11, -0.333_329_5];

/// The odd polynomial of `asin x` for `|x| ≤ ½` (Cephes' `asinf`), highest degree first:
/// `asin x ≈ x + x·w·((((c₀w + c₁)w + c₂)w + c₃)w + c₄)`, `w = x²`.
pub const ASIN_POLY: [f32; 5] = [
    0.042_163_2,
    0.024_181_312,
    0.045_470_025,
    0.074_953_005,
    0.166_667_52,
];

/// `atan x` for `x` in `[0, 1]` (Cephes' `atanf`: above `tan(π/8)` as
/// `π/4 + atan((x − 1)/(x + 1))`, then [`ATAN_POLY`]); the shaders' `luxAtanUnit` /
/// `lux_atan_unit` operation for operation.
#[inline]
pub fn atan_unit_f32(x: f32) -> f32 {
    let (base, z) = if x > TAN_PI_8 {
        (std::f32::consts::FRAC_PI_4, (x - 1.0) / (x + 1.0))
    } else {
        (0.0, x)
    };
    let w = z * z;
    let [c0, c1, c2, c3] = ATAN_POLY;
    base + ((((c0 * w + c1) * w + c2) * w + c3) * w * z + z)
}

/// `atan2(y, x)` in single precision, within 4 ulp, with C's quadrants and signed zeros
/// (`(±0, +0)` → ±0, `(±0, −0)` → ±π): [`atan_unit_f32`] of the smaller over the larger of `|y|`,
/// `|x|`, turned into the quadrant. Only `+`, `−`, `×`, `÷` in a fixed order: the same bits on
/// every platform and in wasm32, and the shaders' `luxAtan2` / `lux_atan2` compute it
/// operation for operation.
#[inline]
pub fn atan2_f32(y: f32, x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, PI};
    let (ax, ay) = (x.abs(), y.abs());
    let mut a = if ax == 0.0 && ay == 0.0 {
        0.0
    } else if ax >= ay {
        atan_unit_f32(ay / ax)
    } else {
        FRAC_PI_2 - atan_unit_f32(ax / ay)
    };
    if x.is_sign_negative() {
        a = PI - a;
    }
    if y.is_sign_negative() { -a } else { a }
}

/// `asin x` for `|x| ≤ ½` ([`ASIN_POLY`]).
#[inline]
fn asin_small(x: f32) -> f32 {
    let w = x * x;
    let [c0, c1, c2, c3, c4] = ASIN_POLY;
    ((((c0 * w + c1) * w + c2) * w + c3) * w + c4) * w * x + x
}

/// `acos x` for `x` in `[−1, 1]` in single precision, within 4 ulp (Cephes' `asinf`: beyond
/// ±½ by `acos x = 2·asin √((1 − x)/2)`); exactly 0, π/2 and π at 1, 0 and −1. The shaders'
/// `luxAcos` / `lux_acos` operation for operation.
#[inline]
pub fn acos_f32(x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, PI};
    if x > 0.5 {
        2.0 * asin_small((0.5 * (1.0 - x)).sqrt())
    } else if x < -0.5 {
        PI - 2.0 * asin_small((0.5 * (1.0 + x)).sqrt())
    } else {
        FRAC_PI_2 - asin_small(x)
    }
}

const MAX_ROWS: u32 = 1025;
const MAX_COLS: u32 = 2048;

/// Angle in millidegrees, when it is a whole number of them.
fn millideg(a: f64) -> Option<u64> {
    let m = (a * 1000.0).rem_euclid(360_000.0);
    let r = m.round();
    ((m - r).abs() < 1e-3).then_some(r as u64)
}

fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// `cells` cells of `step` millidegrees, each split in the fewest equal parts that makes them
/// at most `target` millidegrees, as a cell count no larger than `max`.
fn refine(cells: u64, target: u64, step: u64, max: u32) -> Option<u32> {
    let split = step.div_ceil(target).max(1);
    let n = cells.checked_mul(split)?;
    if n <= u64::from(max) {
        return u32::try_from(n).ok();
    }
    (cells <= u64::from(max)).then_some(cells as u32)
}

/// The largest step in millidegrees dividing `span` and every angle, if all are whole
/// millidegrees.
fn common_step(angles: &[f64], span: u64) -> Option<u64> {
    angles
        .iter()
        .try_fold(span, |g, &a| millideg(a).map(|m| gcd(g, m)))
        .filter(|&g| g > 0)
}

impl Photometry {
    /// A resampled table for shaders; see [`GpuTable`].
    pub fn gpu_table(&self) -> GpuTable {
        self.gpu_table_tilted(0.0)
    }

    /// [`Photometry::gpu_table`] for the luminaire installed at a tilt of `tilt_deg`: every
    /// value carries the tilt factor at that angle (see the crate docs, *Multipliers and
    /// tilt*).
    pub fn gpu_table_tilted(&self, tilt_deg: f64) -> GpuTable {
        GpuTable::from_photometry(self, tilt_deg)
    }
}

impl GpuTable {
    fn from_photometry(p: &Photometry, tilt_deg: f64) -> GpuTable {
        let s = p.sphere();
        let (height, width) = match s.axis {
            Axis::Z => {
                let rows = common_step(&s.theta_deg, 180_000)
                    .and_then(|g| refine(180_000 / g, 500, g, MAX_ROWS - 1))
                    .map_or(721, |r| r + 1);
                let cols = if s.phi_deg.len() < 2 {
                    1
                } else {
                    common_step(&s.phi_deg, 360_000)
                        .and_then(|g| refine(360_000 / g, 1000, g, MAX_COLS))
                        .unwrap_or(1440)
                };
                (rows, cols)
            }
            Axis::Y => (361, 720),
        };
        let factor = p.tilt().factor(tilt_deg);
        let mut values = Vec::with_capacity(height as usize * width as usize);
        for j in 0..height {
            let gamma = PI * f64::from(j) / f64::from(height - 1);
            for i in 0..width {
                let c = TAU * f64::from(i) / f64::from(width);
                let v = match s.axis {
                    Axis::Z => s.eval(gamma, c) * factor,
                    Axis::Y => {
                        p.intensity_tilted(crate::sphere::direction(Axis::Z, gamma, c), tilt_deg)
                    }
                };
                values.push(v as f32);
            }
        }
        GpuTable {
            width,
            height,
            values,
        }
    }

    fn at(&self, row: u32, col: u32) -> f32 {
        self.values
            .get(row as usize * self.width as usize + col as usize)
            .copied()
            .unwrap_or(0.0)
    }

    /// Bilinear sample in candela toward `dir` (photometric frame, any length), in f32 exactly
    /// as documented on [`GpuTable`]. The zero vector, non-finite input or an empty table give 0.
    pub fn sample(&self, dir: [f32; 3]) -> f32 {
        use std::f32::consts::{PI, TAU};
        let [x, y, z] = dir;
        let len = (x * x + y * y + z * z).sqrt();
        if !(len > 0.0 && len.is_finite()) || self.width == 0 || self.height < 2 {
            return 0.0;
        }
        let gamma = acos_f32((-z / len).clamp(-1.0, 1.0));
        let mut c = atan2_f32(y, x);
        if c < 0.0 {
            c += TAU;
        }
        let fy = gamma / PI * (self.height - 1) as f32;
        let fx = c / TAU * self.width as f32;
        let x0 = fx.floor();
        let tx = fx - x0;
        let i0 = (x0 as i64).rem_euclid(i64::from(self.width)) as u32;
        let i1 = (i0 + 1) % self.width;
        let y0f = fy.floor().clamp(0.0, (self.height - 1) as f32);
        let ty = (fy - y0f).clamp(0.0, 1.0);
        let y0 = y0f as u32;
        let y1 = (y0 + 1).min(self.height - 1);
        let a = self.at(y0, i0) + (self.at(y0, i1) - self.at(y0, i0)) * tx;
        let b = self.at(y1, i0) + (self.at(y1, i1) - self.at(y1, i0)) * tx;
        a + (b - a) * ty
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Units in the last place of `exact` (as an f32) that `got` is off by.
    fn ulps(got: f32, exact: f64) -> f64 {
        let e = exact as f32;
        let ulp = f64::from(f32::from_bits(e.abs().to_bits() + 1) - e.abs());
        (f64::from(got) - exact).abs() / ulp
    }

    #[test]
    fn the_angles_are_within_a_few_ulp_and_exact_where_the_table_needs_them() {
        // atan over [0, 1], both sides of its split.
        let mut worst = [0.0f64; 3];
        for i in 1..=200_000 {
            let x = i as f32 / 200_000.0;
            worst[0] = worst[0].max(ulps(atan_unit_f32(x), f64::from(x).atan()));
        }
        // atan2 around the circle, and acos over [−1, 1], off zero by at least an ulp of π.
        for i in 0..100_000 {
            let t = -3.1 + 6.2 * i as f32 / 100_000.0;
            let (y, x) = (t.sin() * 2.5, t.cos() * 2.5);
            let exact = f64::from(y).atan2(f64::from(x));
            if exact.abs() > 1e-6 {
                worst[1] = worst[1].max(ulps(atan2_f32(y, x), exact));
            }
            let c = -1.0 + 2.0 * i as f32 / 100_000.0;
            worst[2] = worst[2].max(ulps(acos_f32(c), f64::from(c).acos()));
        }
        assert!(
            worst[0] <= 3.0 && worst[1] <= 4.0 && worst[2] <= 4.0,
            "{worst:?}"
        );
        use std::f32::consts::{FRAC_PI_2, PI};
        assert_eq!(
            [acos_f32(1.0), acos_f32(0.0), acos_f32(-1.0)],
            [0.0, FRAC_PI_2, PI]
        );
        let signs = [
            (0.0, 0.0),
            (-0.0, 0.0),
            (0.0, -0.0),
            (-0.0, -0.0),
            (0.0, -1.0),
            (-0.0, -1.0),
        ];
        for (y, x) in signs {
            let (a, b) = (atan2_f32(y, x), y.atan2(x));
            assert_eq!(a.to_bits(), b.to_bits(), "atan2({y}, {x})");
        }
        assert_eq!(
            [
                atan2_f32(1.0, 0.0),
                atan2_f32(-1.0, 0.0),
                atan2_f32(3.0, 3.0)
            ],
            [FRAC_PI_2, -FRAC_PI_2, std::f32::consts::FRAC_PI_4]
        );
        assert_eq!(
            [atan_unit_f32(0.0), atan_unit_f32(1.0)],
            [0.0, std::f32::consts::FRAC_PI_4]
        );
    }
}
