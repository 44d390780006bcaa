//! [`Photometry`]: the parsed file and its full-sphere model, and the photometric queries.

use crate::IesError;
use crate::model::{
    Format, Keyword, LdtInfo, LuminousOpening, PhotometricType, Symmetry, Tilt, Units, Warning,
};
use crate::sphere::{self, Axis, Sphere};
use std::f64::consts::PI;

/// Largest accepted intensity after multipliers, in candela (the brightest searchlights reach
/// about 1e9 cd); keeps every sum over the sphere finite.
const MAX_CANDELA: f64 = 1e15;

/// A luminaire's photometry: the header data of its file and the luminous intensity
/// distribution expanded to the full sphere.
///
/// Equality (`PartialEq`) compares the file data (header, keywords, tilt, angles, candela
/// values, EULUMDAT fields) and ignores the [warnings](Photometry::warnings).
#[derive(Clone, Debug)]
pub struct Photometry {
    pub(crate) format: Format,
    pub(crate) keywords: Vec<Keyword>,
    pub(crate) tilt: Tilt,
    pub(crate) lamp_count: u32,
    pub(crate) lumens_per_lamp: Option<f64>,
    pub(crate) candela_multiplier: f64,
    pub(crate) photometric_type: PhotometricType,
    pub(crate) units: Units,
    pub(crate) dimensions: [f64; 3],
    pub(crate) ballast_factor: f64,
    pub(crate) ballast_lamp_factor: f64,
    pub(crate) input_watts: f64,
    pub(crate) vertical_angles: Vec<f64>,
    pub(crate) horizontal_angles: Vec<f64>,
    /// One row of `vertical_angles.len()` values per horizontal angle, as in the file.
    pub(crate) candela: Vec<f64>,
    pub(crate) ldt: Option<Box<LdtInfo>>,
    pub(crate) warnings: Vec<Warning>,
    pub(crate) symmetry: Symmetry,
    pub(crate) sphere: Sphere,
}

impl PartialEq for Photometry {
    fn eq(&self, o: &Self) -> bool {
        self.format == o.format
            && self.keywords == o.keywords
            && self.tilt == o.tilt
            && self.lamp_count == o.lamp_count
            && self.lumens_per_lamp == o.lumens_per_lamp
            && self.candela_multiplier == o.candela_multiplier
            && self.photometric_type == o.photometric_type
            && self.units == o.units
            && self.dimensions == o.dimensions
            && self.ballast_factor == o.ballast_factor
            && self.ballast_lamp_factor == o.ballast_lamp_factor
            && self.input_watts == o.input_watts
            && self.vertical_angles == o.vertical_angles
            && self.horizontal_angles == o.horizontal_angles
            && self.candela == o.candela
            && self.ldt == o.ldt
    }
}

/// The header fields a [`Photometry`] is assembled from (shared by the parsers).
pub(crate) struct Parts {
    pub format: Format,
    pub keywords: Vec<Keyword>,
    pub tilt: Tilt,
    pub lamp_count: u32,
    pub lumens_per_lamp: Option<f64>,
    pub candela_multiplier: f64,
    pub photometric_type: PhotometricType,
    pub units: Units,
    pub dimensions: [f64; 3],
    pub ballast_factor: f64,
    pub ballast_lamp_factor: f64,
    pub input_watts: f64,
    pub vertical_angles: Vec<f64>,
    pub horizontal_angles: Vec<f64>,
    pub candela: Vec<f64>,
    pub ldt: Option<Box<LdtInfo>>,
    pub warnings: Vec<Warning>,
    /// Line numbers of the vertical angles, horizontal angles and first candela value, for errors.
    pub lines: [usize; 3],
}

impl Photometry {
    /// A lamp that shines `candela` in every direction (4π·`candela` lumens). Negative or
    /// non-finite values give a dark lamp.
    pub fn isotropic(candela: f64) -> Photometry {
        let cd = if candela.is_finite() && candela > 0.0 {
            candela
        } else {
            0.0
        };
        let mut p = Photometry::from_grid(
            PhotometricType::C,
            vec![0.0, 180.0],
            vec![0.0],
            vec![cd, cd],
        )
        .unwrap_or_else(|_| unreachable!("a two-angle constant grid is valid"));
        p.lumens_per_lamp = Some(4.0 * PI * cd);
        p.lamp_count = 1;
        p
    }

    /// Builds a photometry from angles (degrees) and candela values, as an LM-63 file would
    /// give them: `candela` holds one row of `vertical.len()` values per horizontal angle.
    /// The result is absolute photometry (no header lumens), multipliers 1, no tilt,
    /// [`Format::Generated`]. The same validation as for files applies (errors report line 0).
    pub fn from_grid(
        photometric_type: PhotometricType,
        vertical: Vec<f64>,
        horizontal: Vec<f64>,
        candela: Vec<f64>,
    ) -> Result<Photometry, IesError> {
        let expected = vertical.len().saturating_mul(horizontal.len());
        if candela.len() != expected {
            return Err(IesError::OutOfRange {
                line: 0,
                what: "number of candela values".into(),
                value: candela.len() as f64,
                expected: format!("{expected} (vertical × horizontal angles)"),
            });
        }
        Photometry::assemble(Parts {
            format: Format::Generated,
            keywords: Vec::new(),
            tilt: Tilt::None,
            lamp_count: 1,
            lumens_per_lamp: None,
            candela_multiplier: 1.0,
            photometric_type,
            units: Units::Meters,
            dimensions: [0.0; 3],
            ballast_factor: 1.0,
            ballast_lamp_factor: 1.0,
            input_watts: 0.0,
            vertical_angles: vertical,
            horizontal_angles: horizontal,
            candela,
            ldt: None,
            warnings: Vec::new(),
            lines: [0; 3],
        })
    }

    /// Validates the angles and values and builds the full-sphere model.
    pub(crate) fn assemble(p: Parts) -> Result<Photometry, IesError> {
        validate(&p)?;
        let scale = p.candela_multiplier
            * p.ballast_factor
            * if p.format <= Format::Lm63_1991 {
                p.ballast_lamp_factor
            } else {
                1.0
            };
        let peak = p.candela.iter().fold(0.0f64, |m, &c| m.max(c)) * scale;
        if !(scale >= 0.0 && peak <= MAX_CANDELA) {
            return Err(IesError::OutOfRange {
                line: p.lines[2],
                what: "peak intensity with all multipliers applied (cd)".into(),
                value: peak,
                expected: format!("a value from 0 to {MAX_CANDELA:e} cd"),
            });
        }
        let (symmetry, sphere) = expand(&p, scale)?;
        Ok(Photometry {
            format: p.format,
            keywords: p.keywords,
            tilt: p.tilt,
            lamp_count: p.lamp_count,
            lumens_per_lamp: p.lumens_per_lamp,
            candela_multiplier: p.candela_multiplier,
            photometric_type: p.photometric_type,
            units: p.units,
            dimensions: p.dimensions,
            ballast_factor: p.ballast_factor,
            ballast_lamp_factor: p.ballast_lamp_factor,
            input_watts: p.input_watts,
            vertical_angles: p.vertical_angles,
            horizontal_angles: p.horizontal_angles,
            candela: p.candela,
            ldt: p.ldt,
            warnings: p.warnings,
            symmetry,
            sphere,
        })
    }

    // ----- header -----

    /// The format and LM-63 version the data was read from.
    pub fn format(&self) -> Format {
        self.format
    }
    /// Keyword lines in file order (`[MORE]` joined). For EULUMDAT files, the header's text
    /// fields under the LM-63 keywords `TEST`, `MANUFAC`, `LUMCAT`, `LUMINAIRE`, `LAMP` (the
    /// lamp type of each set, one line each), `ISSUEDATE`.
    pub fn keywords(&self) -> &[Keyword] {
        &self.keywords
    }
    /// The value of the first keyword `key` (case-insensitive).
    pub fn keyword(&self, key: &str) -> Option<&str> {
        self.keywords
            .iter()
            .find(|k| k.key.eq_ignore_ascii_case(key))
            .map(|k| k.value.as_str())
    }
    /// The `TILT=` data.
    pub fn tilt(&self) -> &Tilt {
        &self.tilt
    }
    /// Number of lamps (EULUMDAT: of every lamp set).
    pub fn lamp_count(&self) -> u32 {
        self.lamp_count
    }
    /// Rated lumens per lamp; `None` for absolute photometry (`-1` in the file; EULUMDAT: a
    /// negative number of lamps). EULUMDAT: the total flux of every lamp set over the number
    /// of lamps.
    pub fn lumens_per_lamp(&self) -> Option<f64> {
        self.lumens_per_lamp
    }
    /// Total rated lamp lumens from the header (lamps × lumens per lamp); `None` for absolute
    /// photometry.
    pub fn lumens_header(&self) -> Option<f64> {
        self.lumens_per_lamp.map(|l| l * f64::from(self.lamp_count))
    }
    /// Candela multiplier (EULUMDAT: conversion factor × the total flux of every lamp set
    /// / 1000, since its values are in cd/klm).
    pub fn candela_multiplier(&self) -> f64 {
        self.candela_multiplier
    }
    /// Ballast factor.
    pub fn ballast_factor(&self) -> f64 {
        self.ballast_factor
    }
    /// The second field of the ballast line: the ballast-lamp photometric factor (LM-63-1986
    /// and -1991, where it multiplies the candela values), "future use" (1995, 2002), or the
    /// file-generation type (2019, see [`Photometry::file_generation_type`]).
    pub fn ballast_lamp_factor(&self) -> f64 {
        self.ballast_lamp_factor
    }
    /// The LM-63-2019 file-generation type (e.g. 1.00001 = undefined); `None` for other formats.
    pub fn file_generation_type(&self) -> Option<f64> {
        (self.format == Format::Lm63_2019).then_some(self.ballast_lamp_factor)
    }
    /// Input watts (EULUMDAT: the sum over the lamp sets).
    pub fn input_watts(&self) -> f64 {
        self.input_watts
    }
    /// Units of the opening dimensions in the file.
    pub fn units(&self) -> Units {
        self.units
    }
    /// Signed width, length, height as written in the file (file units).
    pub fn dimensions(&self) -> [f64; 3] {
        self.dimensions
    }
    /// Luminous opening size in metres and its shape: by the LM-63-1995 table for LM-63-1986,
    /// -1991 and -1995 files, by the LM-63-2002 table otherwise (see the
    /// [`opening`](crate::opening) module docs; [`Photometry::emitter`] makes a solid of it).
    pub fn luminous_opening(&self) -> LuminousOpening {
        let [w, l, h] = self.dimensions;
        match self.format {
            Format::Lm63_1986 | Format::Lm63_1991 | Format::Lm63_1995 => {
                LuminousOpening::from_signed_lm63_1995(w, l, h, self.units)
            }
            _ => LuminousOpening::from_signed(w, l, h, self.units),
        }
    }
    /// Photometric type (angle system).
    pub fn photometric_type(&self) -> PhotometricType {
        self.photometric_type
    }
    /// Horizontal symmetry of the data.
    pub fn symmetry(&self) -> Symmetry {
        self.symmetry
    }
    /// Vertical angles in degrees, as in the file.
    pub fn vertical_angles(&self) -> &[f64] {
        &self.vertical_angles
    }
    /// Horizontal angles (EULUMDAT: the stored C planes) in degrees, as in the file.
    pub fn horizontal_angles(&self) -> &[f64] {
        &self.horizontal_angles
    }
    /// The file's candela values for horizontal angle index `h`, one per vertical angle,
    /// before any multiplier (EULUMDAT: cd/klm).
    pub fn candela_row(&self, h: usize) -> Option<&[f64]> {
        let n = self.vertical_angles.len();
        self.candela.get(h * n..(h + 1) * n)
    }
    /// EULUMDAT header fields, for files read from EULUMDAT.
    pub fn ldt(&self) -> Option<&LdtInfo> {
        self.ldt.as_deref()
    }
    /// Oddities noticed while reading (e.g. trailing data after the candela values).
    pub fn warnings(&self) -> &[Warning] {
        &self.warnings
    }

    // ----- queries -----

    /// Luminous intensity in candela toward `dir`, a direction in the photometric frame (see
    /// the crate docs); it need not be unit length. Candela multiplier, ballast factor (and for
    /// LM-63-1986/1991 the ballast-lamp factor) and the tilt factor at 0° are applied. The zero
    /// vector and non-finite input give 0.
    pub fn intensity(&self, dir: [f64; 3]) -> f64 {
        self.intensity_tilted(dir, 0.0)
    }

    /// [`Photometry::intensity`] for the luminaire installed at a tilt of `tilt_deg` (see the
    /// crate docs, *Multipliers and tilt*): the tilt factor at that angle replaces the factor
    /// at 0°.
    pub fn intensity_tilted(&self, dir: [f64; 3], tilt_deg: f64) -> f64 {
        self.sphere.eval_dir(dir) * self.tilt.factor(tilt_deg)
    }

    /// Intensity in candela at the file's own angles in degrees: type C (γ from nadir, C
    /// plane), type A (V elevation, H plane about the vertical axis), type B (V plane about the
    /// transverse axis, H lateral angle). Angles outside the usual ranges wrap around.
    pub fn intensity_at(&self, vertical_deg: f64, horizontal_deg: f64) -> f64 {
        self.intensity(self.direction_at(vertical_deg, horizontal_deg))
    }

    /// The unit direction in the photometric frame of the file's angles in degrees.
    pub fn direction_at(&self, vertical_deg: f64, horizontal_deg: f64) -> [f64; 3] {
        direction_at(self.photometric_type, vertical_deg, horizontal_deg)
    }

    /// Total luminous flux in lumens: the exact integral over the sphere of the interpolated
    /// intensity (as [`Photometry::intensity`] returns it). Per grid cell, the bilinear
    /// interpolant times sin θ is integrated in closed form.
    pub fn luminous_flux(&self) -> f64 {
        self.luminous_flux_tilted(0.0)
    }

    /// [`Photometry::luminous_flux`] for the luminaire installed at a tilt of `tilt_deg`.
    pub fn luminous_flux_tilted(&self, tilt_deg: f64) -> f64 {
        self.sphere.integral() * self.tilt.factor(tilt_deg)
    }

    /// [`Photometry::luminous_flux`] over the header lumens (`None` for absolute photometry or
    /// zero header lumens). For relative photometry this is the light output ratio.
    pub fn flux_ratio(&self) -> Option<f64> {
        self.lumens_header()
            .filter(|&l| l > 0.0)
            .map(|l| self.luminous_flux() / l)
    }

    /// The largest intensity in candela and its unit direction in the photometric frame.
    /// (Bilinear interpolation peaks at grid nodes, so this is the maximum over all
    /// directions.) An all-dark lamp gives 0 toward nadir.
    pub fn max_intensity(&self) -> (f64, [f64; 3]) {
        self.max_intensity_tilted(0.0)
    }

    /// [`Photometry::max_intensity`] for the luminaire installed at a tilt of `tilt_deg`.
    pub fn max_intensity_tilted(&self, tilt_deg: f64) -> (f64, [f64; 3]) {
        let (v, t, p) = self.sphere.max();
        let v = v * self.tilt.factor(tilt_deg);
        if v <= 0.0 {
            return (0.0, [0.0, 0.0, -1.0]);
        }
        (v, sphere::direction(self.sphere.axis, t, p))
    }

    pub(crate) fn sphere(&self) -> &Sphere {
        &self.sphere
    }
}

/// Unit direction for file angles in degrees (see [`Photometry::intensity_at`]).
pub(crate) fn direction_at(t: PhotometricType, v: f64, h: f64) -> [f64; 3] {
    let (v, h) = (v.to_radians(), h.to_radians());
    match t {
        PhotometricType::C => sphere::direction(Axis::Z, v, h),
        PhotometricType::A => sphere::direction(Axis::Z, v + PI / 2.0, h),
        PhotometricType::B => sphere::direction(Axis::Y, h + PI / 2.0, v),
    }
}

/// Smallest accepted step between consecutive angles, in degrees. Keeps mirrored and shifted
/// angle lists strictly increasing after rounding, and every interpolation weight finite.
const MIN_STEP_DEG: f64 = 1e-6;

fn increasing(list: &[f64], line: usize, what: &str) -> Result<(), IesError> {
    for w in list.windows(2) {
        if w[1] - w[0] < MIN_STEP_DEG {
            return Err(IesError::NotIncreasing {
                line,
                what: format!("{what} (by at least {MIN_STEP_DEG}°)"),
                previous: w[0],
                next: w[1],
            });
        }
    }
    Ok(())
}

fn within(list: &[f64], line: usize, what: &str, lo: f64, hi: f64) -> Result<(), IesError> {
    for &a in list {
        if !(lo..=hi).contains(&a) {
            return Err(IesError::OutOfRange {
                line,
                what: what.into(),
                value: a,
                expected: format!("from {lo} to {hi} degrees"),
            });
        }
    }
    Ok(())
}

fn validate(p: &Parts) -> Result<(), IesError> {
    let [lv, lh, lc] = p.lines;
    let (v, h) = (&p.vertical_angles, &p.horizontal_angles);
    if v.is_empty() || h.is_empty() {
        return Err(IesError::OutOfRange {
            line: lv,
            what: "number of angles".into(),
            value: 0.0,
            expected: "at least one vertical and one horizontal angle".into(),
        });
    }
    increasing(v, lv, "vertical angles")?;
    increasing(h, lh, "horizontal angles")?;
    match p.photometric_type {
        PhotometricType::C => {
            within(v, lv, "type C vertical angle", 0.0, 180.0)?;
            within(h, lh, "type C horizontal angle", 0.0, 360.0)?;
        }
        PhotometricType::A => {
            within(v, lv, "type A vertical angle", -90.0, 90.0)?;
            within(h, lh, "type A horizontal angle", -180.0, 180.0)?;
        }
        PhotometricType::B => {
            within(v, lv, "type B vertical angle", -180.0, 180.0)?;
            within(h, lh, "type B horizontal angle", -90.0, 90.0)?;
        }
    }
    if let Some(&bad) = p.candela.iter().find(|c| !(c.is_finite() && **c >= 0.0)) {
        return Err(IesError::OutOfRange {
            line: lc,
            what: "candela value".into(),
            value: bad,
            expected: "a finite value ≥ 0".into(),
        });
    }
    for (what, value) in [
        ("candela multiplier", p.candela_multiplier),
        ("ballast factor", p.ballast_factor),
    ] {
        if !(value.is_finite() && value >= 0.0) {
            return Err(IesError::OutOfRange {
                line: lv,
                what: what.into(),
                value,
                expected: "a finite value ≥ 0".into(),
            });
        }
    }
    Ok(())
}

/// Close enough to count as the same angle in degrees.
fn near(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

/// The expanded grid, after checking that rounding in the symmetry expansion left every
/// angle list strictly increasing (and a periodic list shorter than a full turn).
fn grid(
    p: &Parts,
    axis: Axis,
    theta: Vec<f64>,
    phi: Vec<f64>,
    values: Vec<f64>,
    periodic: bool,
) -> Result<Sphere, IesError> {
    let ok = |l: &[f64]| l.windows(2).all(|w| w[1] > w[0]);
    let wraps = !periodic || phi.len() < 2 || phi[phi.len() - 1] < phi[0] + 360.0;
    if !(ok(&theta) && ok(&phi) && wraps) {
        return Err(IesError::UnsupportedAngles {
            line: p.lines[1],
            detail: "angles too close together to expand the symmetry".into(),
        });
    }
    Ok(Sphere::new(axis, theta, phi, values, periodic))
}

/// Expands the file's angles to the full sphere according to type and symmetry.
fn expand(p: &Parts, scale: f64) -> Result<(Symmetry, Sphere), IesError> {
    let (v, h) = (&p.vertical_angles, &p.horizontal_angles);
    let nv = v.len();
    let lh = p.lines[1];
    let row = |i: usize| -> Vec<f64> {
        p.candela
            .get(i * nv..(i + 1) * nv)
            .unwrap_or(&[])
            .iter()
            .map(|c| c * scale)
            .collect()
    };
    let unsupported = |detail: String| IesError::UnsupportedAngles { line: lh, detail };
    let (first, last) = (h[0], h[h.len() - 1]);
    let n = h.len();
    // (angle, source row) lists.
    let mut cols: Vec<(f64, usize)> = h.iter().copied().zip(0..).collect();
    match p.photometric_type {
        PhotometricType::C => {
            let symmetry = if n == 1 {
                Symmetry::Rotational
            } else if near(first, 0.0) && near(last, 90.0) {
                // 0..90 → 0..180 by C ↦ 180 − C, then → 0..360 by C ↦ 360 − C.
                cols.extend((0..n - 1).rev().map(|i| (180.0 - h[i], i)));
                let half = cols.clone();
                let m = half.len();
                cols.extend(half[1..m - 1].iter().rev().map(|&(a, i)| (360.0 - a, i)));
                Symmetry::Quadrant
            } else if near(first, 0.0) && near(last, 180.0) {
                cols.extend((1..n - 1).rev().map(|i| (360.0 - h[i], i)));
                Symmetry::Bilateral0To180
            } else if near(first, 90.0) && near(last, 270.0) {
                // Mirror about the 90–270 plane: C ↦ 180 − C (≡ 540 − C above 270).
                cols.extend((1..n - 1).rev().map(|i| (540.0 - h[i], i)));
                Symmetry::Bilateral90To270
            } else if near(first, 0.0) && last > 180.0 {
                Symmetry::Full
            } else {
                return Err(unsupported(format!(
                    "type C horizontal angles {first}..{last}: expected one angle, 0-90, 0-180, \
                     90-270 or 0-360"
                )));
            };
            let (phi, values) = periodic_columns(cols, &row);
            let theta = v.clone();
            let values = flatten(&values);
            Ok((symmetry, grid(p, Axis::Z, theta, phi, values, true)?))
        }
        PhotometricType::A | PhotometricType::B => {
            if n == 1 {
                return Err(unsupported(format!(
                    "type {} needs at least two horizontal angles",
                    p.photometric_type.name()
                )));
            }
            let symmetry = if near(first, 0.0) {
                let mirrored: Vec<(f64, usize)> = (1..n).rev().map(|i| (-h[i], i)).collect();
                cols = mirrored.into_iter().chain(cols).collect();
                Symmetry::Lateral
            } else {
                Symmetry::NoneAB
            };
            if p.photometric_type == PhotometricType::A {
                // φ = H (planes about the vertical axis), θ = V + 90.
                let theta: Vec<f64> = v.iter().map(|a| a + 90.0).collect();
                let span = cols[cols.len() - 1].0 - cols[0].0;
                let periodic = near(span, 360.0);
                let (phi, values) = if periodic {
                    periodic_columns(cols, &row)
                } else {
                    cols.iter().map(|&(a, i)| (a, row(i))).unzip()
                };
                let values = flatten(&values);
                Ok((symmetry, grid(p, Axis::Z, theta, phi, values, periodic)?))
            } else {
                // Type B: θ = H + 90 (latitude about the transverse axis), φ = V (planes about
                // it). The file's rows (per H) become the θ direction: transpose.
                let theta: Vec<f64> = cols.iter().map(|&(a, _)| a + 90.0).collect();
                let rows: Vec<Vec<f64>> = cols.iter().map(|&(_, i)| row(i)).collect();
                let mut phi: Vec<f64> = v.clone();
                let mut per_phi: Vec<Vec<f64>> = (0..nv)
                    .map(|k| {
                        rows.iter()
                            .map(|r| r.get(k).copied().unwrap_or(0.0))
                            .collect()
                    })
                    .collect();
                let periodic = near(v[nv - 1] - v[0], 360.0);
                if periodic {
                    merge_seam(&mut phi, &mut per_phi);
                }
                let values = flatten(&per_phi);
                Ok((symmetry, grid(p, Axis::Y, theta, phi, values, periodic)?))
            }
        }
    }
}

/// Columns for a φ range that goes all the way round: when the last angle is the first + 360°,
/// the two columns are the same plane and are averaged into the first.
fn periodic_columns(
    cols: Vec<(f64, usize)>,
    row: &dyn Fn(usize) -> Vec<f64>,
) -> (Vec<f64>, Vec<Vec<f64>>) {
    let (mut phi, mut values): (Vec<f64>, Vec<Vec<f64>>) =
        cols.into_iter().map(|(a, i)| (a, row(i))).unzip();
    merge_seam(&mut phi, &mut values);
    (phi, values)
}

fn merge_seam(phi: &mut Vec<f64>, values: &mut Vec<Vec<f64>>) {
    if phi.len() >= 2 && near(phi[phi.len() - 1] - phi[0], 360.0) {
        phi.pop();
        if let Some(last) = values.pop()
            && let Some(first) = values.first_mut()
        {
            for (a, b) in first.iter_mut().zip(last) {
                *a = 0.5 * (*a + b);
            }
        }
    }
}

fn flatten(rows: &[Vec<f64>]) -> Vec<f64> {
    rows.iter().flatten().copied().collect()
}
