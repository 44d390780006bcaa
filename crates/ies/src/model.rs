//! Plain data types describing a photometric file's header.

use crate::IesError;

/// The file format (and LM-63 version) a [`Photometry`](crate::Photometry) was read from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[non_exhaustive]
pub enum Format {
    /// LM-63-1986: no version line, free-text label lines before `TILT=`.
    Lm63_1986,
    /// LM-63-1991 (`IESNA91`).
    Lm63_1991,
    /// LM-63-1995 (`IESNA:LM-63-1995`).
    Lm63_1995,
    /// LM-63-2002 (`IESNA:LM-63-2002`).
    Lm63_2002,
    /// LM-63-2019 (`IES:LM-63-2019`).
    Lm63_2019,
    /// EULUMDAT (`.ldt`).
    Eulumdat,
    /// Built in code ([`Photometry::isotropic`](crate::Photometry::isotropic),
    /// [`Photometry::from_grid`](crate::Photometry::from_grid)).
    Generated,
}

impl Format {
    /// Short name: `"LM-63-1986"` … `"LM-63-2019"`, `"LDT"`, `"generated"`.
    pub fn name(self) -> &'static str {
        match self {
            Format::Lm63_1986 => "LM-63-1986",
            Format::Lm63_1991 => "LM-63-1991",
            Format::Lm63_1995 => "LM-63-1995",
            Format::Lm63_2002 => "LM-63-2002",
            Format::Lm63_2019 => "LM-63-2019",
            Format::Eulumdat => "LDT",
            Format::Generated => "generated",
        }
    }
}

/// The LM-63 version the writer produces.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum IesVersion {
    /// `IESNA:LM-63-2002`.
    Lm63_2002,
    /// `IES:LM-63-2019`.
    Lm63_2019,
}

impl IesVersion {
    /// The [`Format`] a file written in this version parses as.
    pub fn format(self) -> Format {
        match self {
            IesVersion::Lm63_2002 => Format::Lm63_2002,
            IesVersion::Lm63_2019 => Format::Lm63_2019,
        }
    }
}

/// Photometric type: which angle system the file's angles are in (see the crate docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PhotometricType {
    /// Type A (automotive): polar axis vertical; horizontal angles are planes about it.
    A,
    /// Type B (floodlights): polar axis horizontal, along the luminaire's transverse axis.
    B,
    /// Type C (architectural; also every EULUMDAT file): polar axis vertical, γ from nadir.
    C,
}

impl PhotometricType {
    /// `"A"`, `"B"` or `"C"`.
    pub fn name(self) -> &'static str {
        match self {
            PhotometricType::A => "A",
            PhotometricType::B => "B",
            PhotometricType::C => "C",
        }
    }
}

/// Unit of the luminous-opening dimensions in the file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Units {
    /// Feet (LM-63 code 1).
    Feet,
    /// Metres (LM-63 code 2; EULUMDAT millimetres are converted to metres).
    Meters,
}

impl Units {
    /// Metres per unit.
    pub fn to_meters(self) -> f64 {
        match self {
            Units::Feet => 0.3048,
            Units::Meters => 1.0,
        }
    }
}

/// One keyword line of an LM-63 file, `[KEY] value`, with `[MORE]` continuation lines joined to
/// the value with `\n`. LM-63-1986 label lines (no brackets) have an empty `key`.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Keyword {
    /// Text between the brackets, e.g. `TEST`, `MANUFAC`, `_ABSOLUTELUMENS`; empty for a label.
    pub key: String,
    /// The value with surrounding whitespace trimmed.
    pub value: String,
}

/// Tilt data: how the lamp output changes with the luminaire's tilt (`TILT=INCLUDE` or a tilt
/// file).
#[derive(Clone, Debug, PartialEq)]
pub struct TiltData {
    /// Lamp-to-luminaire geometry: 1 = lamp vertical base up or down, 2 = lamp horizontal and
    /// stays horizontal when the luminaire tilts about its 0° plane, 3 = lamp horizontal and tilts
    /// with the luminaire.
    pub lamp_geometry: u8,
    /// Tilt angles in degrees, strictly increasing.
    pub angles: Vec<f64>,
    /// Multiplying factor for each angle.
    pub factors: Vec<f64>,
}

impl TiltData {
    /// The multiplying factor at a tilt angle in degrees: linear between the listed angles,
    /// the end value outside them.
    pub fn factor(&self, angle_deg: f64) -> f64 {
        let n = self.angles.len().min(self.factors.len());
        if n == 0 || !angle_deg.is_finite() {
            return 1.0;
        }
        let (a, f) = (&self.angles[..n], &self.factors[..n]);
        if angle_deg <= a[0] {
            return f[0];
        }
        if angle_deg >= a[n - 1] {
            return f[n - 1];
        }
        let k = a.partition_point(|&x| x <= angle_deg).clamp(1, n - 1);
        let t = (angle_deg - a[k - 1]) / (a[k] - a[k - 1]);
        f[k - 1] + (f[k] - f[k - 1]) * t
    }
}

/// The file's `TILT=` line and the data it brings.
#[derive(Clone, Debug, PartialEq)]
pub enum Tilt {
    /// `TILT=NONE`: output does not depend on tilt.
    None,
    /// `TILT=INCLUDE`: tilt data inside the file.
    Include(TiltData),
    /// `TILT=<file>`: tilt data from a separate file, found through the caller's resolver.
    File {
        /// The file name as written after `TILT=`.
        name: String,
        /// The data read from it.
        data: TiltData,
    },
}

impl Tilt {
    /// The tilt data, if any.
    pub fn data(&self) -> Option<&TiltData> {
        match self {
            Tilt::None => None,
            Tilt::Include(d) | Tilt::File { data: d, .. } => Some(d),
        }
    }

    /// The multiplying factor at a tilt angle in degrees (1 when there is no tilt data).
    pub fn factor(&self, angle_deg: f64) -> f64 {
        self.data().map_or(1.0, |d| d.factor(angle_deg))
    }
}

/// The horizontal symmetry of the file's data, from its horizontal (C-plane) angle range.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Symmetry {
    /// Type C, one horizontal angle (EULUMDAT Isym 1): the same in every plane.
    Rotational,
    /// Type C, 0–90°: symmetric about the 0–180° and the 90–270° planes (Isym 4).
    Quadrant,
    /// Type C, 0–180°: symmetric about the 0–180° plane (Isym 2).
    Bilateral0To180,
    /// Type C, 90–270° (LM-63-1995): symmetric about the 90–270° plane (Isym 3).
    Bilateral90To270,
    /// Type C, 0–360° (or 0 to less than 360° with wrap-around): no symmetry (Isym 0).
    Full,
    /// Types A and B, horizontal 0–90°: mirrored to −90…0°.
    Lateral,
    /// Types A and B, horizontal from a negative angle: no symmetry.
    NoneAB,
}

impl Symmetry {
    /// A short label, e.g. `"quadrant (0-90)"`.
    pub fn name(self) -> &'static str {
        match self {
            Symmetry::Rotational => "rotational",
            Symmetry::Quadrant => "quadrant (0-90)",
            Symmetry::Bilateral0To180 => "bilateral (0-180)",
            Symmetry::Bilateral90To270 => "bilateral (90-270)",
            Symmetry::Full => "none (0-360)",
            Symmetry::Lateral => "lateral (0-90 mirrored)",
            Symmetry::NoneAB => "none",
        }
    }
}

/// Shape of the luminous opening, from the signs of width, length and height (LM-63-2002 and
/// -2019 table of luminous opening shapes; LM-63-1995 and older files by the 1995 table, see
/// [`LuminousOpening::from_signed_lm63_1995`]). "Length" lies along the 0°–180° photometric
/// plane (+X for type C), "width" along 90°–270° (+Y). The signs listed are the 2002 ones;
/// the [`opening`](crate::opening) module docs give both tables and the emitting solid of each
/// shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum OpeningShape {
    /// 0, 0, 0.
    Point,
    /// +W, +L, 0.
    Rectangular,
    /// +W, +L, +H.
    RectangularWithLuminousSides,
    /// −D, −D, 0.
    Circular,
    /// −W, −L, 0 (W ≠ L).
    Ellipse,
    /// −D, −D, +H.
    VerticalCylinder,
    /// −W, −L, +H (W ≠ L).
    VerticalEllipticalCylinder,
    /// −D, −D, −D.
    Sphere,
    /// −W, −L, −H (not all equal).
    Ellipsoid,
    /// −D, +L, −D: cylinder lying along the 0° direction.
    HorizontalCylinderAlong0,
    /// −W, +L, −H (W ≠ H).
    HorizontalEllipticalCylinderAlong0,
    /// +W, −D, −D: cylinder lying along the 90° direction.
    HorizontalCylinderAlong90,
    /// +W, −L, −H (L ≠ H).
    HorizontalEllipticalCylinderAlong90,
    /// −D, 0, −D: vertical disc facing the 0° direction (the "photometric horizontal").
    VerticalCircleFacing0,
    /// −W, 0, −H (W ≠ H).
    VerticalEllipseFacing0,
    /// 0, −D, −D: vertical disc facing the 90° direction. Not in LM-63's table; read by the
    /// same rule (negative = rounded in that plane) as the disc facing 0°.
    VerticalCircleFacing90,
    /// 0, −L, −H (L ≠ H).
    VerticalEllipseFacing90,
    /// Any other sign combination.
    Other,
}

/// The luminous opening as given in the file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LuminousOpening {
    /// Width in metres (absolute value), the extent along the 90°–270° plane (+Y for type C).
    /// In an LM-63-1995 shape whose zero width stands for a diameter, that diameter.
    pub width: f64,
    /// Length in metres (absolute value), the extent along the 0°–180° plane (+X for type C).
    /// In an LM-63-1995 shape whose zero length stands for a diameter, that diameter.
    pub length: f64,
    /// Height in metres (absolute value), the vertical extent.
    pub height: f64,
    /// Shape from the signs.
    pub shape: OpeningShape,
}

impl LuminousOpening {
    /// Classifies signed file dimensions (in file units) by the LM-63-1995 table (used for
    /// LM-63-1986, -1991 and -1995 files) and converts them to metres. A diameter is written
    /// once, in the width, with a zero for the dimension that repeats it: −d, 0, 0 circular;
    /// −d, 0, −d sphere (an ellipsoid when the height differs); −d, 0, +h vertical cylinder;
    /// 0, +l, −d horizontal cylinder along the length (0°); +w, 0, −d horizontal cylinder
    /// along the width (90°); −w, +l or +w, −l with height 0, above 0 or below 0: ellipse,
    /// vertical elliptic cylinder, ellipsoid. Other sign patterns are read as by
    /// [`LuminousOpening::from_signed`]. The repeated diameter is filled in.
    pub fn from_signed_lm63_1995(
        width: f64,
        length: f64,
        height: f64,
        units: Units,
    ) -> LuminousOpening {
        use OpeningShape as S;
        let (w, l, h) = (width.abs(), length.abs(), height.abs());
        let eq = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.max(b);
        let found = match (sign(width), sign(length), sign(height)) {
            (-1, 0, 0) => Some((S::Circular, w, w, 0.0)),
            (-1, 0, -1) if eq(w, h) => Some((S::Sphere, w, w, h)),
            (-1, 0, -1) => Some((S::Ellipsoid, w, w, h)),
            (-1, 0, 1) => Some((S::VerticalCylinder, w, w, h)),
            (0, 1, -1) => Some((S::HorizontalCylinderAlong0, h, l, h)),
            (1, 0, -1) => Some((S::HorizontalCylinderAlong90, w, h, h)),
            (-1, 1, 0) | (1, -1, 0) => Some((S::Ellipse, w, l, 0.0)),
            (-1, 1, 1) | (1, -1, 1) => Some((S::VerticalEllipticalCylinder, w, l, h)),
            (-1, 1, -1) | (1, -1, -1) => Some((S::Ellipsoid, w, l, h)),
            _ => None,
        };
        let Some((shape, w, l, h)) = found else {
            return LuminousOpening::from_signed(width, length, height, units);
        };
        let m = units.to_meters();
        LuminousOpening {
            width: w * m,
            length: l * m,
            height: h * m,
            shape,
        }
    }

    /// Classifies signed file dimensions (in file units) by the LM-63-2002/2019 table (also
    /// used for EULUMDAT) and converts them to metres.
    pub fn from_signed(width: f64, length: f64, height: f64, units: Units) -> LuminousOpening {
        use OpeningShape as S;
        let s = sign;
        let eq = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs());
        let shape = match (s(width), s(length), s(height)) {
            (0, 0, 0) => S::Point,
            (1, 1, 0) => S::Rectangular,
            (1, 1, 1) => S::RectangularWithLuminousSides,
            (-1, -1, 0) if eq(width, length) => S::Circular,
            (-1, -1, 0) => S::Ellipse,
            (-1, -1, 1) if eq(width, length) => S::VerticalCylinder,
            (-1, -1, 1) => S::VerticalEllipticalCylinder,
            (-1, -1, -1) if eq(width, length) && eq(length, height) => S::Sphere,
            (-1, -1, -1) => S::Ellipsoid,
            (-1, 1, -1) if eq(width, height) => S::HorizontalCylinderAlong0,
            (-1, 1, -1) => S::HorizontalEllipticalCylinderAlong0,
            (1, -1, -1) if eq(length, height) => S::HorizontalCylinderAlong90,
            (1, -1, -1) => S::HorizontalEllipticalCylinderAlong90,
            (-1, 0, -1) if eq(width, height) => S::VerticalCircleFacing0,
            (-1, 0, -1) => S::VerticalEllipseFacing0,
            (0, -1, -1) if eq(length, height) => S::VerticalCircleFacing90,
            (0, -1, -1) => S::VerticalEllipseFacing90,
            _ => S::Other,
        };
        let m = units.to_meters();
        LuminousOpening {
            width: width.abs() * m,
            length: length.abs() * m,
            height: height.abs() * m,
            shape,
        }
    }
}

/// −1, 0 or 1 (0 for NaN).
fn sign(v: f64) -> i8 {
    if v > 0.0 {
        1
    } else if v < 0.0 {
        -1
    } else {
        0
    }
}

/// Something odd in a file that did not stop it from being read.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Warning {
    /// 1-based line number.
    pub line: usize,
    /// What was noticed.
    pub message: String,
}

/// Bounds on what a file may make the parser allocate. The defaults are generous for any real
/// photometric file and keep a hostile file from asking for gigabytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Limits {
    /// Largest accepted input, in bytes. Default 16 MiB.
    pub max_bytes: usize,
    /// Most vertical, horizontal or C-plane angles in one list. Default 4096.
    pub max_angles: usize,
    /// Most candela values (vertical × horizontal). Default 1 048 576.
    pub max_values: usize,
    /// Most tilt angle/factor pairs. Default 4096.
    pub max_tilt_pairs: usize,
    /// Most header (keyword) lines before `TILT=`. Default 10 000.
    pub max_header_lines: usize,
    /// Most EULUMDAT lamp sets. Default 64.
    pub max_lamp_sets: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_bytes: 16 << 20,
            max_angles: 4096,
            max_values: 1 << 20,
            max_tilt_pairs: 4096,
            max_header_lines: 10_000,
            max_lamp_sets: 64,
        }
    }
}

impl Limits {
    pub(crate) fn check(
        &self,
        line: usize,
        what: &str,
        count: usize,
        limit: usize,
    ) -> Result<(), IesError> {
        if count > limit {
            return Err(IesError::LimitExceeded {
                line,
                what: what.to_owned(),
                count: count as u64,
                limit: limit as u64,
            });
        }
        Ok(())
    }
}

/// Finds the bytes of a separate tilt file from the name written after `TILT=`; `None` when it
/// cannot be found.
pub type TiltResolver<'a> = &'a dyn Fn(&str) -> Option<Vec<u8>>;

/// Options for [`Photometry::parse_with`](crate::Photometry::parse_with).
#[derive(Clone, Copy, Default)]
pub struct ParseOptions<'a> {
    /// Allocation limits.
    pub limits: Limits,
    /// Resolver for `TILT=<file>`; without one such files are an error
    /// ([`IesError::TiltFileUnresolved`]).
    pub tilt_resolver: Option<TiltResolver<'a>>,
}

impl std::fmt::Debug for ParseOptions<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ParseOptions")
            .field("limits", &self.limits)
            .field("tilt_resolver", &self.tilt_resolver.map(|_| "<fn>"))
            .finish()
    }
}

/// A lamp set of an EULUMDAT file (fields 26a–26f).
#[derive(Clone, Debug, PartialEq)]
pub struct LampSet {
    /// Number of lamps; negative means absolute photometry (the flux is the luminaire's), and
    /// then it is negative in every set.
    pub count: i64,
    /// Lamp type.
    pub lamp_type: String,
    /// Total luminous flux of the lamps in lumens.
    pub flux: f64,
    /// Colour appearance / colour temperature, as written.
    pub color: String,
    /// Colour rendering group / index, as written.
    pub cri: String,
    /// Wattage including ballast, in watts.
    pub watts: f64,
}

/// Header fields of an EULUMDAT file that have no LM-63 counterpart.
#[derive(Clone, Debug, PartialEq)]
pub struct LdtInfo {
    /// Company identification (line 1).
    pub company: String,
    /// Type indicator Ityp (0–3).
    pub type_indicator: u8,
    /// Symmetry indicator Isym (0–4).
    pub symmetry_indicator: u8,
    /// Number of C planes Mc.
    pub c_planes: usize,
    /// Distance between C planes Dc, degrees.
    pub c_step: f64,
    /// All Mc C-plane angles as in the file, degrees; the planes stored for the symmetry are
    /// [`Photometry::horizontal_angles`](crate::Photometry::horizontal_angles).
    pub c_angles: Vec<f64>,
    /// Intensities per C plane Ng.
    pub gamma_count: usize,
    /// Distance between γ angles Dg, degrees.
    pub gamma_step: f64,
    /// Measurement report number.
    pub report_number: String,
    /// Luminaire name.
    pub luminaire_name: String,
    /// Luminaire number.
    pub luminaire_number: String,
    /// File name.
    pub file_name: String,
    /// Date / user.
    pub date_user: String,
    /// Length or diameter, width (0 for round) and height of the luminaire, millimetres.
    pub luminaire_size_mm: [f64; 3],
    /// Length or diameter and width (0 for round) of the luminous area, millimetres.
    pub luminous_area_mm: [f64; 2],
    /// Height of the luminous area in the C0, C90, C180, C270 planes, millimetres.
    pub luminous_height_mm: [f64; 4],
    /// Downward flux fraction, percent.
    pub downward_flux_fraction: f64,
    /// Light output ratio of the luminaire, percent.
    pub light_output_ratio: f64,
    /// Conversion factor for luminous intensities.
    pub conversion_factor: f64,
    /// Tilt of the luminaire during measurement, degrees.
    pub measurement_tilt: f64,
    /// Lamp sets (at least one), in file order. All are fitted: the photometry uses the sum
    /// of their lamps, fluxes and wattages.
    pub lamp_sets: Vec<LampSet>,
    /// Direct ratios for room indices k = 0.60 … 5.00.
    pub direct_ratios: [f64; 10],
}
