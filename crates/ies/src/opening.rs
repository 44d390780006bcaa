//! The luminous opening as an emitting solid: where a luminaire's light leaves it.
//!
//! A photometric file gives the far field, the intensity `I(ω)`. A luminaire that is large
//! next to the distances it lights is better baked as a surface of **uniform luminance per
//! direction**, `L(ω) = I(ω) / A_proj(ω)` on every emitting part, where `A_proj(ω)` is the
//! area the emitting parts show toward ω ([`Emitter::projected_area`]). Seen from afar such a
//! surface has exactly the file's intensity, and up close it spreads the light over the
//! opening instead of a point ([`Photometry::opening_luminance`]).
//!
//! [`Photometry::emitter`] turns the file's luminous opening ([`LuminousOpening`]) into one of
//! three solids ([`SolidKind`]): a box, an elliptic cylinder or an ellipsoid, axis-aligned in
//! the photometric frame and centred on the photometric centre. Flat openings are solids of
//! zero height.
//!
//! # Length, width, height
//! In every LM-63 version the **length** is the opening's extent along the 0°–180°
//! photometric plane, the **width** along the 90°–270° plane, the **height** vertical. For
//! type C that is length along **+X (C0)**, width along **+Y (C90)**, height along **Z**.
//! Radiance's `ies2rad` agrees: it puts the length along x and the 0° plane along x (its
//! `putpoint` and its manual page). Types A and B: see *Types A and B* below.
//!
//! EULUMDAT has the same reading: the luminous area's length (line 16) lies along C0–C180 and
//! its width (line 17) along C90–C270; its heights (lines 18–21) are those of the luminous
//! sides facing C0, C90, C180 and C270. The crate reads an `.ldt` file's luminous area into the
//! LM-63 signs as width = line 17, length = line 16 (width 0: a circle of diameter line 16),
//! height = the **largest** of the four heights (a box has one height; a side lower than the
//! others is drawn as high as the highest, which keeps the sides emitting and overstates the
//! area of the lower ones). The luxpy pair in the test data shows which reading is right:
//! `luxpy_test_lid_file.ldt` (length 80 mm, width 1966 mm, luminaire 110 × 2000 mm) has a
//! batwing in C0 and a narrower C90. A linear luminaire's extruded lens can only shape light
//! across its length, and EULUMDAT practice (DIALux: C0–C180 "transverse to", C90–C270 "along
//! the luminaire axis") puts that plane at C0, so the 1966 mm run lies along C90 = +Y, as this
//! reading gives. The converted `luxpy_test_lid_file.ies` (width 0.080, length 1.966) swapped
//! the two: read by the LM-63 rule it puts the run along C0, across its own batwing.
//!
//! # The mapping (LM-63-2002 and LM-63-2019, and EULUMDAT)
//! Signs of (width W, length L, height H) as in LM-63-2002's table of luminous opening shapes
//! (LM-63-2019 keeps it); `+` positive, `−` negative, `0` zero. Extents below are full sizes;
//! the emitter's `half` are half of them, in its own (u, v, w) order.
//!
//! | W, L, H | shape ([`OpeningShape`]) | emitter | extents along X, Y, Z |
//! |---|---|---|---|
//! | 0, 0, 0 | point | none | — |
//! | +, +, 0 | rectangular | box, axis Z, flat | L, W, 0 |
//! | +, +, + | rectangular with luminous sides | box, axis Z | L, W, H |
//! | −, −, 0 | circular (W = L) / ellipse | cylinder, axis Z, flat | L, W, 0 |
//! | −, −, + | vertical (elliptic) cylinder | cylinder, axis Z | L, W, H |
//! | −, −, − | sphere / ellipsoid | ellipsoid | L, W, H |
//! | −, +, − | horizontal (elliptic) cylinder along the photometric horizontal (C0) | cylinder, axis X | L, W, H |
//! | +, −, − | horizontal (elliptic) cylinder perpendicular to it (along C90) | cylinder, axis Y | L, W, H |
//! | −, 0, − | vertical circle / ellipse facing the photometric horizontal (C0) | cylinder, axis X, flat | 0, W, H |
//! | 0, −, − | vertical circle / ellipse facing C90 (not in the LM-63 table; the 2019 rule "negative = rounded in that plane" read the other way round) | cylinder, axis Y, flat | L, 0, H |
//! | anything else | other | box of the absolute sizes, axis Z (flat when H = 0) | L, W, H |
//!
//! # LM-63-1986, -1991 and -1995
//! The older versions write round shapes differently (LM-63-1995's table): a diameter is
//! written once, in the width, and a zero stands for the dimension that repeats it. We read
//! 1986 and 1991 files by the 1995 table too. Those sign patterns are read first; the others
//! (including 2002-style `−, −, ·` in an old file) fall through to the table above. Where the
//! zero stands for a diameter, [`LuminousOpening`] fills in that diameter.
//!
//! | W, L, H (1995) | shape | extents along X, Y, Z |
//! |---|---|---|
//! | −d, 0, 0 | circular | d, d, 0 |
//! | −d, 0, −h | sphere (an ellipsoid when h ≠ d) | d, d, h |
//! | −d, 0, + | vertical cylinder | d, d, H |
//! | 0, +, −d | horizontal cylinder along the length (C0) | L, d, d |
//! | +, 0, −d | horizontal cylinder along the width (C90) | d, W, d |
//! | −, +, 0 or +, −, 0 | ellipse | L, W, 0 |
//! | −, +, + or +, −, + | vertical elliptic cylinder | L, W, H |
//! | −, +, − or +, −, − | ellipsoid | L, W, H |
//!
//! So `−, +, −` is an ellipsoid in a 1995 file and a horizontal cylinder in a 2002 file, and
//! `−, 0, −` a sphere in 1995 and a vertical circle in 2002: the format decides. (`ies2rad`
//! also switches on the version; for 1986 and 1991 files it has a shorter table that agrees
//! with 1995's except that it reads `−, +, +` as an ellipsoid, and it rejects the 1995
//! sphere unless the zero length equals the height.)
//!
//! # Which parts emit
//! * **Ends** (the faces ±w of a box or cylinder, both faces of a flat opening): the end
//!   facing a direction `a` emits when the file has any intensity above zero in the open
//!   hemisphere `dir · a > 0`. For type C and an axis-Z solid: the bottom (−Z) when there is
//!   light below the horizontal (γ < 90°), the top (+Z) when there is light above it
//!   (γ > 90°). For the vertical discs, the face toward ±X (or ±Y) when there is light that
//!   way. A file with no light at all gets both ends (it emits nothing anyway; the opening
//!   keeps its shape).
//! * **Sides** (box faces ±u, ±v; the cylinder's mantle) emit whenever the solid has height.
//! * An **ellipsoid** emits over its whole surface.
//!
//! # Where we differ from `ies2rad`
//! `ies2rad` (Radiance, `src/cv/ies2rad.c`, `makeiesshape` and `putsource`) maps the shapes to
//! a box, a vertical cylinder/disk or a sphere only:
//! * ellipses, elliptic cylinders and ellipsoids become a circular disk/cylinder or a sphere
//!   when nearly round, otherwise a box; horizontal cylinders and vertical discs become boxes.
//!   We keep them as elliptic cylinders and ellipsoids (with their real axes), so the
//!   projected area, and with it the luminance, is that of the shape the file names.
//! * It emits from the bottom when the file's vertical angles start below 90°, from the top
//!   when they end above 90°, and from the sides only when it emits from both and the height
//!   exceeds 1 mm; its luminance is then I / (box or cylinder silhouette), and with one end
//!   only I / (area · |cos|). We look at where the candela are above zero (a 0–180° file that
//!   is dark above the horizontal gets no top), and a file that gives its opening a height
//!   gets luminous sides even for a downlight: the height says the sides glow, and without
//!   them a downlight's light near the horizontal would come from an end seen edge-on.
//! * For the 2002 vertical disc it tests length < 0, width = 0 (with `FEQ(w, h)` on the zero
//!   width), where the LM-63 table has width < 0, length = 0; the table's own sign pattern is
//!   then rejected ("illegal source dimensions"). We follow the table.
//! * It makes a point a 1 mm sphere and sizes below 1 mm 1 mm; we give no emitter for a
//!   point (the lamp stays a point light) and keep any size above zero (a flat opening stays
//!   flat).
//!
//! # Types A and B
//! A type A or B file's photometric axis is +X (crate docs). `ies2rad` builds the opening
//! exactly as for type C, facing its −z, and puts the type B axis on −z, so the opening faces
//! the beam. We do the same in our frame: the type C solid is turned as a downlight tilted up
//! to the horizon in its C0 plane, (X, Y, Z) → (Z, Y, −X), so its bottom faces +X, its length
//! runs along Z (vertical) and its width along Y (lateral).
//!
//! # The three solids
//! Each solid lives in its own frame (u, v, w), w its axis ([`Emitter::axis`]), centred at the
//! photometric centre. `half` are the semi-axes along u, v, w.
//! * **Box**: ends are the rectangles 2·half\[0\] × 2·half\[1\] at w = ±half\[2\], sides the four
//!   faces u = ±half\[0\], v = ±half\[1\].
//! * **Cylinder** (elliptic): ends are the ellipses of semi-axes half\[0\], half\[1\] at
//!   w = ±half\[2\]; the mantle joins them.
//! * **Ellipsoid** of semi-axes `half`.
//!
//! # Projected areas
//! `A_proj(d) = Σ over emitting parts ∫ max(0, n·d) dA`, d a unit direction with components
//! (d_u, d_v, d_w) in the solid's frame. A flat face of area A and normal n adds A·max(0, n·d):
//! * box end: 4·h0·h1·|d_w| for the end whose outward normal (±w) has n·d > 0; box sides:
//!   of each pair of opposite faces exactly one faces d, so 4·h1·h2·|d_u| + 4·h0·h2·|d_v|;
//! * cylinder end: π·h0·h1·|d_w| for the facing end;
//! * mantle: the point (h0 cos φ, h1 sin φ, w) has the outward normal ∝ (h1 cos φ, h0 sin φ, 0)
//!   and dA = sqrt(h0² sin²φ + h1² cos²φ) dφ dw, so n·d dA = (h1 d_u cos φ + h0 d_v sin φ) dφ dw.
//!   With ∫₀^2π max(0, A cos φ + B sin φ) dφ = 2·sqrt(A² + B²), the mantle shows
//!   2·(2·h2)·sqrt(h1² d_u² + h0² d_v²);
//! * ellipsoid: its silhouette toward d is an ellipse of area
//!   π·sqrt((h1h2 d_u)² + (h0h2 d_v)² + (h0h1 d_w)²) (the image of the unit sphere's
//!   silhouette π under diag(h): area scales with |det diag(h)| · |diag(h)⁻¹ d|).
//!
//! # Areas
//! Box and cylinder ends and the box sides are exact. The cylinder's mantle is 2·h2 times
//! the exact ellipse perimeter, by the arithmetic-geometric mean (Gauss–Kummer), to rounding.
//! The ellipsoid's area is 4π·R_G(h0²h1², h1²h2², h2²h0²), with Carlson's symmetric elliptic
//! integral R_G evaluated by duplication to rounding.

use crate::sphere::{self, Sphere};
use crate::{LuminousOpening, OpeningShape, PhotometricType, Photometry};
use std::f64::consts::{PI, TAU};

/// Kind of solid, in the emitter's own frame (u, v, w), w the solid's axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum SolidKind {
    /// A box: ends are rectangles, sides its four faces ±u, ±v.
    Box = 0,
    /// An elliptic cylinder: ends are ellipses, sides its mantle.
    Cylinder = 1,
    /// An ellipsoid: one surface.
    Ellipsoid = 2,
}

impl SolidKind {
    /// `"box"`, `"cylinder"` or `"ellipsoid"`.
    pub fn name(self) -> &'static str {
        match self {
            SolidKind::Box => "box",
            SolidKind::Cylinder => "cylinder",
            SolidKind::Ellipsoid => "ellipsoid",
        }
    }
}

/// An emitting solid (see the [module docs](self)): what [`Photometry::emitter`] makes of a
/// luminous opening.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emitter {
    /// The solid.
    pub kind: SolidKind,
    /// Photometric axis that w lies along: 0 = X, 1 = Y, 2 = Z; u and v are the next two axes
    /// cyclically (axis 2: u = X, v = Y; axis 0: u = Y, v = Z; axis 1: u = Z, v = X).
    pub axis: u8,
    /// Semi-axes (half extents) along u, v, w in metres, >= 0 (a flat opening has
    /// half\[2\] = 0).
    pub half: [f64; 3],
    /// Emitting parts: bit 0 (1) the end facing −w, bit 1 (2) the end facing +w, bit 2 (4)
    /// the sides (box: the four faces ±u, ±v; cylinder: the mantle); an ellipsoid emits with
    /// bit 2 over its whole surface.
    pub faces: u8,
}

/// One point on an emitter's surface, from [`Emitter::sample`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmitterSample {
    /// Position in metres in the photometric frame, from the photometric centre (the solid's
    /// centre).
    pub point: [f64; 3],
    /// Unit outward normal in the photometric frame.
    pub normal: [f64; 3],
    /// Area element over probability density, m²: E\[g(point, normal) · weight\] is the
    /// integral of g over the emitting surface.
    pub weight: f64,
}

/// Gauss–Legendre nodes per quarter turn over the cylinder mantle (see
/// [`Emitter::mean_square_radius`]).
const MANTLE_NODES: usize = 64;
/// Gauss–Legendre nodes per half of the ellipsoid's polar angle and per quarter turn in φ.
const ELLIPSOID_THETA_NODES: usize = 96;
const ELLIPSOID_PHI_NODES: usize = 96;

impl Emitter {
    /// Bit of the end facing −w ([`Emitter::faces`]).
    pub const END_NEG: u8 = 1;
    /// Bit of the end facing +w.
    pub const END_POS: u8 = 2;
    /// Bit of the sides (box faces ±u, ±v; cylinder mantle; the ellipsoid's surface).
    pub const SIDES: u8 = 4;

    fn has(&self, bit: u8) -> bool {
        self.faces & bit != 0
    }

    /// The half extents, zero where not finite or negative.
    fn h(&self) -> [f64; 3] {
        self.half
            .map(|x| if x.is_finite() && x > 0.0 { x } else { 0.0 })
    }

    /// The three photometric axes (indices 0 = X, 1 = Y, 2 = Z) of u, v, w.
    pub fn frame(&self) -> [usize; 3] {
        let a = usize::from(self.axis.min(2));
        [(a + 1) % 3, (a + 2) % 3, a]
    }

    /// A photometric-frame vector in (u, v, w).
    fn local_of(&self, d: [f64; 3]) -> [f64; 3] {
        let [iu, iv, iw] = self.frame();
        [d[iu], d[iv], d[iw]]
    }

    /// A (u, v, w) vector in the photometric frame.
    fn global_of(&self, p: [f64; 3]) -> [f64; 3] {
        let [iu, iv, iw] = self.frame();
        let mut g = [0.0; 3];
        g[iu] = p[0];
        g[iv] = p[1];
        g[iw] = p[2];
        g
    }

    /// Names of the emitting parts: `"bottom"`/`"top"` for the ends of an axis-Z solid,
    /// `"-x"`/`"+x"` or `"-y"`/`"+y"` for the ends of an axis-X or axis-Y one, `"sides"`, and
    /// `"surface"` for an ellipsoid.
    pub fn part_names(&self) -> Vec<&'static str> {
        if self.kind == SolidKind::Ellipsoid {
            return if self.has(Self::SIDES) {
                vec!["surface"]
            } else {
                vec![]
            };
        }
        let (neg, pos) = match self.axis {
            0 => ("-x", "+x"),
            1 => ("-y", "+y"),
            _ => ("bottom", "top"),
        };
        let mut out = Vec::new();
        for (bit, name) in [
            (Self::END_NEG, neg),
            (Self::END_POS, pos),
            (Self::SIDES, "sides"),
        ] {
            if self.has(bit) {
                out.push(name);
            }
        }
        out
    }

    /// The parts in sampling order with their exact areas and the fixed areas
    /// [`Emitter::sample`] picks them by: (part, exact area, sampling area). Parts that do not
    /// emit have both areas zero.
    fn parts(&self) -> [(Part, f64, f64); 6] {
        const NONE: (Part, f64, f64) = (Part::None, 0.0, 0.0);
        let [h0, h1, h2] = self.h();
        let s = self.has(Self::SIDES);
        let on = |b: bool, a: f64| if b { a } else { 0.0 };
        // A part sampled by its exact area.
        let exact = |part: Part, b: bool, a: f64| (part, on(b, a), on(b, a));
        let ends = |e: f64| {
            [
                exact(Part::EndNeg, self.has(Self::END_NEG), e),
                exact(Part::EndPos, self.has(Self::END_POS), e),
            ]
        };
        match self.kind {
            SolidKind::Box => {
                let [neg, pos] = ends(4.0 * h0 * h1);
                let (fu, fv) = (4.0 * h1 * h2, 4.0 * h0 * h2);
                [
                    neg,
                    pos,
                    exact(Part::FacePosU, s, fu),
                    exact(Part::FaceNegU, s, fu),
                    exact(Part::FacePosV, s, fv),
                    exact(Part::FaceNegV, s, fv),
                ]
            }
            SolidKind::Cylinder => {
                let [neg, pos] = ends(PI * h0 * h1);
                let mantle = 2.0 * h2 * ellipse_perimeter(h0, h1);
                let approx = TAU * 2.0 * h2 * ((h0 * h0 + h1 * h1) / 2.0).sqrt();
                [
                    neg,
                    pos,
                    (Part::Mantle, on(s, mantle), on(s, approx)),
                    NONE,
                    NONE,
                    NONE,
                ]
            }
            SolidKind::Ellipsoid => {
                let sides = exact(Part::Ellipsoid, s, ellipsoid_area(h0, h1, h2));
                [sides, NONE, NONE, NONE, NONE, NONE]
            }
        }
    }

    /// Total emitting area in m² (see the module docs, *Areas*: exact to rounding).
    pub fn area(&self) -> f64 {
        self.parts().iter().map(|p| p.1).sum()
    }

    /// Σ over the emitting parts of ∫ max(0, n·dir) dA, in m²: the area the emitting surface
    /// shows toward `dir`, a unit direction of emission in the photometric frame (the result
    /// scales with |dir| otherwise). Closed forms, derived in the module docs.
    pub fn projected_area(&self, dir: [f64; 3]) -> f64 {
        if !dir.iter().all(|x| x.is_finite()) {
            return 0.0;
        }
        let [h0, h1, h2] = self.h();
        let [du, dv, dw] = self.local_of(dir);
        let facing_end = if dw < 0.0 {
            self.has(Self::END_NEG)
        } else {
            dw > 0.0 && self.has(Self::END_POS)
        };
        let sides = self.has(Self::SIDES);
        match self.kind {
            SolidKind::Box => {
                let ends = if facing_end {
                    4.0 * h0 * h1 * dw.abs()
                } else {
                    0.0
                };
                let s = if sides {
                    4.0 * h1 * h2 * du.abs() + 4.0 * h0 * h2 * dv.abs()
                } else {
                    0.0
                };
                ends + s
            }
            SolidKind::Cylinder => {
                let ends = if facing_end {
                    PI * h0 * h1 * dw.abs()
                } else {
                    0.0
                };
                let m = if sides {
                    4.0 * h2 * (h1 * h1 * du * du + h0 * h0 * dv * dv).sqrt()
                } else {
                    0.0
                };
                ends + m
            }
            SolidKind::Ellipsoid => {
                if !sides {
                    return 0.0;
                }
                let (a, b, c) = (h1 * h2 * du, h0 * h2 * dv, h0 * h1 * dw);
                PI * (a * a + b * b + c * c).sqrt()
            }
        }
    }

    /// A point on the emitting surface for three uniform numbers in \[0, 1), such that
    /// E\[g(point, normal) · weight\] = ∫ g dA over the emitting surface for any g. `None` only
    /// when nothing emits (total area zero).
    ///
    /// The scheme, which the GPU shaders mirror: `u[2]` picks a part with probability
    /// proportional to a fixed area per part, in the order −w end, +w end, then the sides
    /// (box: faces +u, −u, +v, −v of areas 4·h1·h2, 4·h1·h2, 4·h0·h2, 4·h0·h2; cylinder: the
    /// mantle, counted as 2π·2h2·sqrt((h0² + h1²)/2); an ellipsoid is one part); parts that
    /// do not emit or have zero area are never picked. Then `(u[0], u[1])` map into the part:
    /// * box end: (h0·(2u0 − 1), h1·(2u1 − 1), ±h2); face ±u: (±h0, h1·(2u0 − 1),
    ///   h2·(2u1 − 1)); face ±v: (h0·(2u0 − 1), ±h1, h2·(2u1 − 1)); area element = the face's
    ///   area;
    /// * cylinder end: r = sqrt(u0), φ = 2π·u1, (h0·r·cos φ, h1·r·sin φ, ±h2), area element
    ///   π·h0·h1;
    /// * mantle: φ = 2π·u1, w = (2u0 − 1)·h2, (h0 cos φ, h1 sin φ, w), normal
    ///   ∝ (h1 cos φ, h0 sin φ, 0), area element 2π·2h2·sqrt(h0² sin²φ + h1² cos²φ);
    /// * ellipsoid: z = 1 − 2u0, φ = 2π·u1, s = (sqrt(1 − z²) cos φ, sqrt(1 − z²) sin φ, z),
    ///   point (h0 s0, h1 s1, h2 s2), normal ∝ (s0/h0, s1/h1, s2/h2) (computed as
    ///   (h1h2 s0, h0h2 s1, h0h1 s2), which needs no division), area element
    ///   4π·sqrt((h1h2 s0)² + (h0h2 s1)² + (h0h1 s2)²) = 4π·h0h1h2·|(s0/h0, s1/h1, s2/h2)|;
    ///
    /// and weight = area element / probability of the part. Coordinates are in (u, v, w) and
    /// then placed in the photometric frame by [`Emitter::axis`]. Where a degenerate solid
    /// leaves the normal undefined (a mantle or ellipsoid collapsed to a line) the area
    /// element there is zero, and the normal is the radial direction.
    pub fn sample(&self, u: [f64; 3]) -> Option<EmitterSample> {
        let parts = self.parts();
        let total: f64 = parts.iter().map(|p| p.2).sum();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let target = u[2] * total;
        let mut acc = 0.0;
        let mut chosen = None;
        for &(part, _, a) in &parts {
            if a > 0.0 {
                chosen = Some((part, a));
                acc += a;
                if target < acc {
                    break;
                }
            }
        }
        let (part, a) = chosen?;
        let prob = a / total;
        let [h0, h1, h2] = self.h();
        let (u0, u1) = (u[0], u[1]);
        let (p, n, element) = match part {
            Part::EndNeg | Part::EndPos => {
                let s = if part == Part::EndPos { 1.0 } else { -1.0 };
                if self.kind == SolidKind::Box {
                    let p = [h0 * (2.0 * u0 - 1.0), h1 * (2.0 * u1 - 1.0), s * h2];
                    (p, [0.0, 0.0, s], 4.0 * h0 * h1)
                } else {
                    let r = u0.max(0.0).sqrt();
                    let (sp, cp) = (TAU * u1).sin_cos();
                    let p = [h0 * r * cp, h1 * r * sp, s * h2];
                    (p, [0.0, 0.0, s], PI * h0 * h1)
                }
            }
            Part::FacePosU | Part::FaceNegU => {
                let s = if part == Part::FacePosU { 1.0 } else { -1.0 };
                let p = [s * h0, h1 * (2.0 * u0 - 1.0), h2 * (2.0 * u1 - 1.0)];
                (p, [s, 0.0, 0.0], 4.0 * h1 * h2)
            }
            Part::FacePosV | Part::FaceNegV => {
                let s = if part == Part::FacePosV { 1.0 } else { -1.0 };
                let p = [h0 * (2.0 * u0 - 1.0), s * h1, h2 * (2.0 * u1 - 1.0)];
                (p, [0.0, s, 0.0], 4.0 * h0 * h2)
            }
            Part::Mantle => {
                let (sp, cp) = (TAU * u1).sin_cos();
                let p = [h0 * cp, h1 * sp, (2.0 * u0 - 1.0) * h2];
                let n = unit_or([h1 * cp, h0 * sp, 0.0], [cp, sp, 0.0]);
                let element = TAU * 2.0 * h2 * (h0 * h0 * sp * sp + h1 * h1 * cp * cp).sqrt();
                (p, n, element)
            }
            Part::Ellipsoid => {
                let z = (1.0 - 2.0 * u0).clamp(-1.0, 1.0);
                let r = (1.0 - z * z).max(0.0).sqrt();
                let (sp, cp) = (TAU * u1).sin_cos();
                let s = [r * cp, r * sp, z];
                let m = [h1 * h2 * s[0], h0 * h2 * s[1], h0 * h1 * s[2]];
                let p = [h0 * s[0], h1 * s[1], h2 * s[2]];
                (p, unit_or(m, s), 2.0 * TAU * norm(m))
            }
            Part::None => return None,
        };
        Some(EmitterSample {
            point: self.global_of(p),
            normal: self.global_of(n),
            weight: element / prob,
        })
    }

    /// Area-weighted mean of |x|² over the emitting surface, m², x from the photometric
    /// centre (0 when nothing emits). Closed forms for the box and the cylinder ends
    /// (a rectangle's mean x² is h²/3, an ellipse's h²/4); the mantle's φ integral by
    /// Gauss–Legendre, 64 nodes per quarter turn; the ellipsoid's by Gauss–Legendre over the
    /// sphere it is the image of, 96 nodes per half of the polar angle and 96 per quarter turn
    /// of φ. The quarters and halves end where a
    /// collapsed semi-axis puts a kink in the integrand, so flat and collapsed solids are as
    /// accurate as round ones: relative error below 1e-9 for semi-axis ratios up to 1 : 100
    /// (tested).
    pub fn mean_square_radius(&self) -> f64 {
        let [h0, h1, h2] = self.h();
        let (q0, q1, q2) = (h0 * h0, h1 * h1, h2 * h2);
        let mut sum = 0.0;
        let mut area = 0.0;
        for (part, a, _) in self.parts() {
            if a <= 0.0 {
                continue;
            }
            area += a;
            sum += match (self.kind, part) {
                (SolidKind::Box, Part::EndNeg | Part::EndPos) => a * (q0 / 3.0 + q1 / 3.0 + q2),
                (SolidKind::Box, Part::FacePosU | Part::FaceNegU) => a * (q0 + q1 / 3.0 + q2 / 3.0),
                (SolidKind::Box, Part::FacePosV | Part::FaceNegV) => a * (q1 + q0 / 3.0 + q2 / 3.0),
                (_, Part::EndNeg | Part::EndPos) => a * (q0 / 4.0 + q1 / 4.0 + q2),
                (_, Part::Mantle) => {
                    // 2·h2 ∫ (h0² cos²φ + h1² sin²φ) ds(φ) + (h2²/3) · mantle area.
                    let ring: f64 = quarters(MANTLE_NODES)
                        .iter()
                        .map(|&(phi, wt)| {
                            let (sp, cp) = phi.sin_cos();
                            let r2 = q0 * cp * cp + q1 * sp * sp;
                            wt * r2 * (q0 * sp * sp + q1 * cp * cp).sqrt()
                        })
                        .sum();
                    2.0 * h2 * ring + a * q2 / 3.0
                }
                (_, Part::Ellipsoid) => ellipsoid_moment(h0, h1, h2),
                _ => 0.0,
            };
        }
        if area > 0.0 { sum / area } else { 0.0 }
    }

    /// The distance in metres beyond which treating the emitter as a point at its centre
    /// errs by less than `tolerance` (relative, e.g. 0.01), on the axis of a face:
    /// sqrt(2 · [`mean_square_radius`](Emitter::mean_square_radius) / tolerance).
    ///
    /// A patch of uniform luminance at offset ρ from the axis of a receiver at distance h,
    /// facing it, gives an illuminance ∝ cos θ · cos θ' / r² = h² / (h² + ρ²)², which is
    /// (1 − 2ρ²/h² + …) / h²; the point model gives 1 / h². So the point model overstates
    /// the illuminance by about 2⟨ρ²⟩ / h², below `tolerance` beyond
    /// h = sqrt(2⟨ρ²⟩ / tolerance). For a disk of diameter D, ⟨ρ²⟩ = D²/8, which gives
    /// h = 5·D at 1 %: the IES five-times rule. (Exactly, on a disk's axis, E_area / E_point
    /// = h² / (a² + h²) for radius a: −0.99 % at h = 5·D.)
    pub fn point_model_distance(&self, tolerance: f64) -> f64 {
        (2.0 * self.mean_square_radius() / tolerance).sqrt()
    }
}

/// A sampling part (see [`Emitter::sample`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Part {
    EndNeg,
    EndPos,
    FacePosU,
    FaceNegU,
    FacePosV,
    FaceNegV,
    Mantle,
    Ellipsoid,
    None,
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// `v` normalized, or `fallback` normalized when `v` is zero (or +Z when both are).
fn unit_or(v: [f64; 3], fallback: [f64; 3]) -> [f64; 3] {
    for w in [v, fallback] {
        let n = norm(w);
        if n > 0.0 && n.is_finite() {
            return [w[0] / n, w[1] / n, w[2] / n];
        }
    }
    [0.0, 0.0, 1.0]
}

/// Perimeter of the ellipse with semi-axes `a`, `b`, by the arithmetic-geometric mean:
/// P = 2π / M · (a² − Σₙ 2ⁿ⁻¹ cₙ²), M the AGM of a and b, c₀² = a² − b²,
/// cₙ₊₁ = (aₙ − bₙ) / 2. Exact to rounding; 4a for a segment.
pub(crate) fn ellipse_perimeter(a: f64, b: f64) -> f64 {
    let (a, b) = (a.max(b), a.min(b));
    if a <= 0.0 {
        return 0.0;
    }
    if b <= 0.0 {
        return 4.0 * a;
    }
    let (mut x, mut y) = (a, b);
    let mut sum = 0.5 * (a * a - b * b);
    let mut pow = 0.5;
    for _ in 0..64 {
        let c = 0.5 * (x - y);
        if c <= 1e-17 * x {
            break;
        }
        pow *= 2.0;
        sum += pow * c * c;
        (x, y) = (0.5 * (x + y), (x * y).sqrt());
    }
    TAU / x * (a * a - sum)
}

/// Surface area of the ellipsoid with semi-axes `a`, `b`, `c`: 4π·R_G(a²b², b²c², c²a²)
/// (2πab for a flat one, counting both sides; zero for a segment).
pub(crate) fn ellipsoid_area(a: f64, b: f64, c: f64) -> f64 {
    let mut q = [a * a * b * b, b * b * c * c, c * c * a * a];
    q.sort_by(f64::total_cmp);
    4.0 * PI * carlson_rg(q[0], q[1], q[2])
}

/// Carlson's R_G(x, y, z) for 0 <= x <= y <= z:
/// 2·R_G = z·R_F − (x − z)(y − z)·R_D / 3 + sqrt(x·y / z).
fn carlson_rg(x: f64, y: f64, z: f64) -> f64 {
    if z <= 0.0 {
        return 0.0;
    }
    if y <= 0.0 {
        return 0.5 * z.sqrt();
    }
    0.5 * (z * carlson_rf(x, y, z) - (x - z) * (y - z) * carlson_rd(x, y, z) / 3.0
        + (x * y / z).sqrt())
}

/// Carlson's R_F by duplication (at most one argument zero).
fn carlson_rf(mut x: f64, mut y: f64, mut z: f64) -> f64 {
    let mut mu = (x + y + z) / 3.0;
    for _ in 0..100 {
        let (sx, sy, sz) = (x.sqrt(), y.sqrt(), z.sqrt());
        let lam = sx * sy + sy * sz + sz * sx;
        x = 0.25 * (x + lam);
        y = 0.25 * (y + lam);
        z = 0.25 * (z + lam);
        mu = (x + y + z) / 3.0;
        let d = (1.0 - x / mu)
            .abs()
            .max((1.0 - y / mu).abs())
            .max((1.0 - z / mu).abs());
        if d < 1e-4 {
            break;
        }
    }
    let (dx, dy, dz) = (1.0 - x / mu, 1.0 - y / mu, 1.0 - z / mu);
    let e2 = dx * dy - dz * dz;
    let e3 = dx * dy * dz;
    (1.0 - e2 / 10.0 + e3 / 14.0 + e2 * e2 / 24.0 - 3.0 * e2 * e3 / 44.0) / mu.sqrt()
}

/// Carlson's R_D(x, y, z) by duplication (x + y > 0, z > 0).
fn carlson_rd(mut x: f64, mut y: f64, mut z: f64) -> f64 {
    let mut sum = 0.0;
    let mut fac = 1.0;
    let mut mu = (x + y + 3.0 * z) / 5.0;
    for _ in 0..100 {
        let (sx, sy, sz) = (x.sqrt(), y.sqrt(), z.sqrt());
        let lam = sx * (sy + sz) + sy * sz;
        sum += fac / (sz * (z + lam));
        fac *= 0.25;
        x = 0.25 * (x + lam);
        y = 0.25 * (y + lam);
        z = 0.25 * (z + lam);
        mu = (x + y + 3.0 * z) / 5.0;
        let d = ((mu - x) / mu)
            .abs()
            .max(((mu - y) / mu).abs())
            .max(((mu - z) / mu).abs());
        if d < 1e-4 {
            break;
        }
    }
    let (dx, dy, dz) = ((mu - x) / mu, (mu - y) / mu, (mu - z) / mu);
    let ea = dx * dy;
    let eb = dz * dz;
    let ec = ea - eb;
    let ed = ea - 6.0 * eb;
    let ee = ed + ec + ec;
    let (c1, c2, c3, c4) = (3.0 / 14.0, 1.0 / 6.0, 9.0 / 22.0, 3.0 / 26.0);
    let (c5, c6) = (0.25 * c1, 1.5 * c4);
    let series =
        1.0 + ed * (-c1 + c5 * ed - c6 * dz * ee) + dz * (c2 * ee + dz * (-c3 * ec + dz * c4 * ea));
    3.0 * sum + fac * series / (mu * mu.sqrt())
}

/// Nodes and weights over φ ∈ \[0, 2π): n-point Gauss–Legendre on each quarter turn, so
/// kinks at multiples of π/2 (where a collapsed semi-axis puts them) fall on panel ends.
fn quarters(n: usize) -> Vec<(f64, f64)> {
    let gl = gauss_legendre(n);
    let q = 0.25 * PI;
    (0..4)
        .flat_map(|k| {
            let mid = (2 * k + 1) as f64 * q;
            gl.iter().map(move |&(x, w)| (mid + q * x, q * w))
        })
        .collect()
}

/// ∫ f over the unit sphere, with the sphere's point s = (sin θ cos φ, sin θ sin φ, cos θ) and
/// dΩ = sin θ dθ dφ: n-point Gauss–Legendre on each half of θ (split at the equator, where
/// a flat ellipsoid's area element has a kink) times [`quarters`]`(m)` in φ. In θ and φ the
/// integrands here are smooth apart from those kinks.
fn sphere_quadrature(n: usize, m: usize, f: impl Fn([f64; 3]) -> f64) -> f64 {
    let gl = gauss_legendre(n);
    let phis = quarters(m);
    let q = 0.25 * PI;
    let mut total = 0.0;
    for mid in [q, 3.0 * q] {
        for &(x, w) in &gl {
            let (st, ct) = (mid + q * x).sin_cos();
            let ring: f64 = phis
                .iter()
                .map(|&(phi, wp)| {
                    let (sp, cp) = phi.sin_cos();
                    wp * f([st * cp, st * sp, ct])
                })
                .sum();
            total += w * q * st * ring;
        }
    }
    total
}

/// ∫ |x|² dA over the ellipsoid with semi-axes a, b, c (numerically; see
/// [`Emitter::mean_square_radius`]).
fn ellipsoid_moment(a: f64, b: f64, c: f64) -> f64 {
    sphere_quadrature(ELLIPSOID_THETA_NODES, ELLIPSOID_PHI_NODES, |s| {
        let p = [a * s[0], b * s[1], c * s[2]];
        let j = norm([b * c * s[0], a * c * s[1], a * b * s[2]]);
        (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) * j
    })
}

/// Nodes and weights of the n-point Gauss–Legendre rule on \[−1, 1\] (Newton on Pₙ).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let k = k as f64;
                (p0, p1) = (p1, ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k);
            }
            dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        out.push((x, 2.0 / ((1.0 - x * x) * dp * dp)));
    }
    out
}

/// The type C solid of an opening: kind, axis, full extents along X, Y, Z (see the mapping
/// table in the module docs); `None` for a point.
fn solid_of(o: &LuminousOpening) -> Option<(SolidKind, u8, [f64; 3])> {
    use OpeningShape as S;
    let (l, w, h) = (o.length, o.width, o.height);
    let e = [l, w, h];
    Some(match o.shape {
        S::Point => return None,
        S::Rectangular => (SolidKind::Box, 2, [l, w, 0.0]),
        S::RectangularWithLuminousSides => (SolidKind::Box, 2, e),
        S::Circular | S::Ellipse => (SolidKind::Cylinder, 2, [l, w, 0.0]),
        S::VerticalCylinder | S::VerticalEllipticalCylinder => (SolidKind::Cylinder, 2, e),
        S::Sphere | S::Ellipsoid => (SolidKind::Ellipsoid, 2, e),
        S::HorizontalCylinderAlong0 | S::HorizontalEllipticalCylinderAlong0 => {
            (SolidKind::Cylinder, 0, e)
        }
        S::HorizontalCylinderAlong90 | S::HorizontalEllipticalCylinderAlong90 => {
            (SolidKind::Cylinder, 1, e)
        }
        S::VerticalCircleFacing0 | S::VerticalEllipseFacing0 => {
            (SolidKind::Cylinder, 0, [0.0, w, h])
        }
        S::VerticalCircleFacing90 | S::VerticalEllipseFacing90 => {
            (SolidKind::Cylinder, 1, [l, 0.0, h])
        }
        _ => (SolidKind::Box, 2, e),
    })
}

impl Photometry {
    /// The luminous opening as an emitting solid (see the [`opening`](crate::opening) module
    /// docs for the mapping and which parts emit); `None` for a point opening or one of zero
    /// area.
    pub fn emitter(&self) -> Option<Emitter> {
        let (kind, mut axis, mut ext) = solid_of(&self.luminous_opening())?;
        if matches!(
            self.photometric_type,
            PhotometricType::A | PhotometricType::B
        ) {
            // A downlight tilted up to the horizon in its C0 plane: (X, Y, Z) → (Z, Y, −X).
            ext = [ext[2], ext[1], ext[0]];
            axis = 2 - axis;
        }
        let ext = ext.map(|x| if x.is_finite() && x > 0.0 { x } else { 0.0 });
        let mut e = Emitter {
            kind,
            axis,
            half: [0.0; 3],
            faces: 0,
        };
        let [iu, iv, iw] = e.frame();
        e.half = [0.5 * ext[iu], 0.5 * ext[iv], 0.5 * ext[iw]];
        if kind == SolidKind::Ellipsoid {
            e.faces = Emitter::SIDES;
        } else {
            let mut a = [0.0; 3];
            a[iw] = 1.0;
            let s = self.sphere();
            let neg = lit_toward(s, a.map(|x| -x));
            let pos = lit_toward(s, a);
            if neg || !pos {
                e.faces |= Emitter::END_NEG;
            }
            if pos || !neg {
                e.faces |= Emitter::END_POS;
            }
            if e.half[2] > 0.0 {
                e.faces |= Emitter::SIDES;
            }
        }
        let area = e.area();
        (area > 0.0 && area.is_finite()).then_some(e)
    }

    /// Luminance in cd/m² of the [emitter](Photometry::emitter) toward `dir` (any length):
    /// [`intensity`](Photometry::intensity) / [`projected_area`](Emitter::projected_area),
    /// 0 where the projected area is zero or there is no emitter. Uniform over the emitting
    /// parts, this reproduces the file's intensity in the far field. It derives the emitter on
    /// every call (a pass over the candela grid): for many directions take
    /// [`Photometry::emitter`] once and divide by its `projected_area`.
    pub fn opening_luminance(&self, dir: [f64; 3]) -> f64 {
        let n = norm(dir);
        if !(n > 0.0 && n.is_finite()) {
            return 0.0;
        }
        let d = dir.map(|x| x / n);
        let Some(e) = self.emitter() else {
            return 0.0;
        };
        let a = e.projected_area(d);
        if a > 0.0 { self.intensity(d) / a } else { 0.0 }
    }
}

/// Whether the interpolated intensity is above zero somewhere in the open hemisphere
/// `dir · a > 0`: some grid cell with a corner value above zero (so positive inside) reaches
/// into it, tested at points spread over the cell.
fn lit_toward(s: &Sphere, a: [f64; 3]) -> bool {
    let nt = s.theta_deg.len();
    let np = s.phi_deg.len();
    if nt == 0 || np == 0 {
        return false;
    }
    let theta: Vec<(usize, usize)> = if nt == 1 {
        vec![(0, 0)]
    } else {
        (0..nt - 1).map(|j| (j, j + 1)).collect()
    };
    // φ cells: (node, node, start, end) in degrees.
    let mut phi: Vec<(usize, usize, f64, f64)> = (0..np.saturating_sub(1))
        .map(|i| (i, i + 1, s.phi_deg[i], s.phi_deg[i + 1]))
        .collect();
    if s.periodic {
        phi.push((np - 1, 0, s.phi_deg[np - 1], s.phi_deg[0] + 360.0));
    } else if np == 1 {
        phi.push((0, 0, s.phi_deg[0], s.phi_deg[0]));
    }
    const T: [f64; 3] = [0.02, 0.5, 0.98];
    const P: [f64; 9] = [0.0, 0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875, 1.0];
    for &(j0, j1) in &theta {
        let (t0, t1) = (s.theta_deg[j0], s.theta_deg[j1]);
        for &(i0, i1, p0, p1) in &phi {
            let lit = [(i0, j0), (i0, j1), (i1, j0), (i1, j1)]
                .iter()
                .any(|&(i, j)| s.value(i, j) > 0.0);
            if !lit {
                continue;
            }
            for ft in T {
                let t = (t0 + (t1 - t0) * ft).to_radians();
                for fp in P {
                    let p = (p0 + (p1 - p0) * fp).to_radians();
                    let d = sphere::direction(s.axis, t, p);
                    if d[0] * a[0] + d[1] * a[1] + d[2] * a[2] > 1e-9 {
                        return true;
                    }
                }
            }
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ellipse_perimeter_limits() {
        assert!((ellipse_perimeter(1.0, 1.0) - TAU).abs() < 1e-14);
        assert_eq!(ellipse_perimeter(2.0, 0.0), 8.0);
        assert_eq!(ellipse_perimeter(0.0, 0.0), 0.0);
        // Against a fine trapezoid rule (spectrally accurate for a smooth periodic integrand).
        for (a, b) in [(3.0, 1.0), (1.0, 0.1), (5.0, 4.9)] {
            let n = 20000;
            let step = TAU / n as f64;
            let p: f64 = (0..n)
                .map(|k| {
                    let (s, c) = (k as f64 * step).sin_cos();
                    (a * a * s * s + b * b * c * c).sqrt()
                })
                .sum::<f64>()
                * step;
            assert!((ellipse_perimeter(a, b) / p - 1.0).abs() < 1e-12, "{a} {b}");
        }
    }

    #[test]
    fn mean_square_radius_quadratures_are_exact_for_collapsed_and_flat_solids() {
        let e = |kind, half| Emitter {
            kind,
            axis: 2,
            half,
            faces: Emitter::SIDES,
        };
        // A flat ellipsoid (a two-sided ellipse) and one collapsed into the u-w plane.
        let msr = e(SolidKind::Ellipsoid, [0.3, 0.2, 0.0]).mean_square_radius();
        assert!((msr / ((0.09 + 0.04) / 4.0) - 1.0).abs() < 1e-12);
        let msr = e(SolidKind::Ellipsoid, [0.1, 0.0, 0.4]).mean_square_radius();
        assert!((msr / ((0.01 + 0.16) / 4.0) - 1.0).abs() < 1e-12);
        // A mantle collapsed to a two-sided strip 2h0 × 2h2: h0²/3 + h2²/3.
        let strip = e(SolidKind::Cylinder, [0.1, 0.0, 0.4]);
        assert!((strip.area() - 8.0 * 0.1 * 0.4).abs() < 1e-15);
        assert!((strip.mean_square_radius() / ((0.01 + 0.16) / 3.0) - 1.0).abs() < 1e-12);
        // A circular mantle: r² + h²/3.
        let tube = e(SolidKind::Cylinder, [0.2, 0.2, 0.3]);
        assert!((tube.mean_square_radius() / (0.04 + 0.03) - 1.0).abs() < 1e-12);
        // Semi-axis ratios 1 : 100: against a much finer rule.
        for half in [[0.01, 1.0, 0.5], [1.0, 0.01, 0.01]] {
            let (a, b, c) = (half[0], half[1], half[2]);
            let fine = sphere_quadrature(400, 400, |s| {
                let p = [a * s[0], b * s[1], c * s[2]];
                (p[0] * p[0] + p[1] * p[1] + p[2] * p[2])
                    * norm([b * c * s[0], a * c * s[1], a * b * s[2]])
            });
            let coarse = ellipsoid_moment(a, b, c);
            assert!(
                (coarse / fine - 1.0).abs() < 1e-9,
                "{half:?}: {coarse} {fine}"
            );
            // The mantle of an elliptic cylinder with the first two semi-axes.
            let m = e(SolidKind::Cylinder, [a, b, 1.0]);
            let ring: f64 = quarters(4000)
                .iter()
                .map(|&(phi, wt)| {
                    let (sp, cp) = phi.sin_cos();
                    let r2 = a * a * cp * cp + b * b * sp * sp;
                    wt * r2 * (a * a * sp * sp + b * b * cp * cp).sqrt()
                })
                .sum();
            let fine = (2.0 * ring + m.area() / 3.0) / m.area();
            let coarse = m.mean_square_radius();
            assert!(
                (coarse / fine - 1.0).abs() < 1e-9,
                "{half:?}: {coarse} {fine}"
            );
        }
    }

    #[test]
    fn ellipsoid_area_closed_forms() {
        let r = 0.7;
        assert!((ellipsoid_area(r, r, r) / (4.0 * PI * r * r) - 1.0).abs() < 1e-13);
        assert!((ellipsoid_area(2.0, 3.0, 0.0) / (2.0 * PI * 6.0) - 1.0).abs() < 1e-13);
        assert_eq!(ellipsoid_area(2.0, 0.0, 0.0), 0.0);
        // Prolate spheroid a = b = 1, c = 2: 2πa² (1 + c/(a e) asin e), e² = 1 − a²/c².
        let e = (1.0f64 - 0.25).sqrt();
        let prolate = TAU * (1.0 + 2.0 / e * e.asin());
        assert!((ellipsoid_area(1.0, 1.0, 2.0) / prolate - 1.0).abs() < 1e-13);
        // Oblate a = b = 2, c = 1: 2πa² + π c²/e · ln((1 + e)/(1 − e)), e² = 1 − c²/a².
        let e = (1.0f64 - 0.25).sqrt();
        let oblate = TAU * 4.0 + PI / e * ((1.0 + e) / (1.0 - e)).ln();
        assert!((ellipsoid_area(2.0, 2.0, 1.0) / oblate - 1.0).abs() < 1e-13);
        // The numerical surface rule agrees with R_G on a triaxial one.
        let (a, b, c) = (0.3, 1.1, 2.5);
        let num = sphere_quadrature(48, 32, |s| norm([b * c * s[0], a * c * s[1], a * b * s[2]]));
        assert!((num / ellipsoid_area(a, b, c) - 1.0).abs() < 1e-9);
    }
}
