//! Photometric files — IES LM-63 (1986, 1991, 1995, 2002, 2019) and EULUMDAT — read exactly,
//! written back, and queried in SI units.
//!
//! ```
//! use luxbake_ies::Photometry;
//! let text = "IESNA:LM-63-2002\n[TEST] demo\nTILT=NONE\n1 -1 1 3 1 1 2 0 0 0\n1 1 10\n\
//!             0 45 90\n0\n100 70.7107 0\n";
//! let lamp = Photometry::parse(text.as_bytes())?;
//! assert_eq!(lamp.intensity([0.0, 0.0, -1.0]), 100.0); // straight down
//! assert_eq!(lamp.intensity_at(45.0, 0.0), 70.7107);
//! # Ok::<(), luxbake_ies::IesError>(())
//! ```
//!
//! # Contract
//! * [`Photometry::parse`] never panics, on any bytes. Allocation is bounded by [`Limits`].
//!   Errors ([`IesError`]) carry the 1-based line and what was expected there. Oddities that do
//!   not stop reading (trailing data after the candela values, stray lines in the keyword
//!   block) become [`Warning`]s.
//! * Intensities are in **candela**, fluxes in **lumens**, angles given to and taken from the
//!   API in **degrees** (file angles) or as direction vectors.
//! * Every file is expanded once, at load, to a full-sphere grid; queries never look at the
//!   symmetry again.
//! * EULUMDAT intensities are in cd/klm of the luminaire's lamps: all of its lamp sets are
//!   fitted, so they are scaled by the sum of the sets' fluxes ([`LdtInfo::lamp_sets`] keeps
//!   each set). [`Photometry::to_ies`] writes any data as LM-63, [`Photometry::to_ldt`] writes
//!   EULUMDAT data back as EULUMDAT, losslessly.
//!
//! # The photometric frame
//! One right-handed frame serves every photometric type. Picture the luminaire hanging from the
//! ceiling, seen from above:
//!
//! ```text
//!                 +Z  zenith (γ = 180°)              seen from above:
//!                  |                                        +Y  (C 90°)
//!                  |   +Y (C 90°)                            |
//!                  |  /                           C 180° ----+---- +X (C 0°)
//!                  | /                                       |
//!                  o------ +X (C 0°)                      C 270°
//!                  |                           (C grows counter-clockwise,
//!                  |                            from +X toward +Y)
//!                 −Z  nadir (γ = 0°), where a downlight shines
//! ```
//!
//! * **Type C** (C-γ, every EULUMDAT file): polar axis vertical. γ is the angle from nadir,
//!   C the plane angle from +X toward +Y:
//!   `d(γ, C) = (sin γ cos C, sin γ sin C, −cos γ)`.
//! * **Type A** (A-α, automotive): the luminaire sits as measured on the goniometer, its
//!   photometric axis (V = 0, H = 0) horizontal along **+X**; the polar axis is the luminaire's
//!   vertical axis, **+Z**. H is the plane angle about +Z (positive toward +Y), V the elevation
//!   in that plane (positive up):
//!   `d(V, H) = (cos V cos H, cos V sin H, sin V)`.
//! * **Type B** (B-β, floodlights): photometric axis along **+X** as for type A; the polar axis
//!   is the luminaire's horizontal transverse axis, **+Y**. V is the plane angle about +Y
//!   (positive: axis tilted up, toward +Z), H the lateral angle in that plane (positive toward
//!   +Y):
//!   `d(V, H) = (cos H cos V, sin H, cos H sin V)`.
//!
//! So a type A or B floodlight points along +X, toward the C 0° direction of the same frame,
//! and the scene places and aims it like any other lamp. [`Photometry::direction_at`] gives the
//! direction of any file angle pair; the unit tests check each formula.
//!
//! # Symmetry and interpolation
//! Horizontal angles define the symmetry ([`Symmetry`]): type C one plane (rotational), 0–90°
//! (quadrant), 0–180°, 90–270°, 0–360° (or 0 to less than 360° with wrap-around); types A and B
//! 0–90° (mirrored to negative angles) or from a negative angle. EULUMDAT symmetry indicators
//! 0–4 map onto the same cases. Vertical ranges may be any increasing sub-range of 0–180° (type
//! C) or −90–90° (type A), −180–180° for type B's plane angle.
//!
//! The intensity is **bilinear** in the grid's two angles (θ from the grid's pole, φ about its
//! axis; for type C θ = γ, φ = C). It is zero outside the measured vertical range and, for type
//! A/B data that does not go all the way round, outside the measured plane range. Continuity:
//! mirrored seams coincide by construction, a 360° plane is averaged with the 0° plane, and the
//! values at a pole (γ = 0° or 180°) are replaced by their mean over the planes, so the
//! intensity is continuous at the poles even when a file's nadir values differ between planes.
//!
//! # Multipliers and tilt
//! [`Photometry::intensity`] = file value × candela multiplier × ballast factor (× the
//! ballast-lamp photometric factor for LM-63-1986/1991, where it was still a multiplier) × the
//! tilt factor at 0° (1 without tilt data; the as-measured orientation).
//!
//! `TILT=INCLUDE` and `TILT=<file>` give the lamp's output as multiplying factors against the
//! luminaire's **tilt**: the angle in degrees between the luminaire's photometric nadir
//! (γ = 0°, −Z of the photometric frame) as installed and straight down (gravity). 0° is the
//! luminaire as measured, aimed straight down; 90° aims it at the horizon, 180° straight up.
//! The factor is linear between the listed angles and the end value outside them
//! ([`TiltData::factor`]). The `_tilted` queries ([`Photometry::intensity_tilted`],
//! [`Photometry::luminous_flux_tilted`], [`Photometry::max_intensity_tilted`],
//! [`Photometry::gpu_table_tilted`]) apply the factor at a given tilt instead of at 0°.
//!
//! The tilt is one unsigned angle whatever the lamp-to-luminaire geometry
//! ([`TiltData::lamp_geometry`]) and whatever the direction the luminaire leans: LM-63 gives
//! the factors of geometries 2 and 3 for a tilt in the luminaire's 0° photometric plane, and
//! this crate applies them to a tilt in any plane. Listed angles below 0° or above 180° are
//! never reached, so they only matter through the end values.
//!
//! # Flux
//! [`Photometry::luminous_flux`] integrates the interpolated intensity over the sphere exactly:
//! per grid cell the bilinear interpolant times sin θ has a closed-form integral. For
//! `I = I₀ cos γ` sampled every 5° over the lower hemisphere this gives π·I₀ within 0.1 %; a
//! constant gives exactly 4π·I.
//!
//! # Luminous opening
//! [`Photometry::luminous_opening`] reads the file's opening (shape and size; length along
//! C0 = +X, width along C90 = +Y), and [`Photometry::emitter`] makes an emitting box, elliptic
//! cylinder or ellipsoid of it, with uniform luminance per direction
//! ([`Photometry::opening_luminance`]) so the far field is the file's intensity. See the
//! [`opening`] module for the mapping from every LM-63 and EULUMDAT shape.
//!
//! # GPU table
//! See [`GpuTable`]: rows over γ, columns over C, bilinear, wrap in C.

#![warn(missing_docs)]

mod error;
mod gpu;
mod ies;
mod ldt;
mod model;
pub mod opening;
mod photometry;
mod read;
mod sphere;
mod text;
mod write;

pub use error::IesError;
pub use gpu::{ASIN_POLY, ATAN_POLY, GpuTable, TAN_PI_8, acos_f32, atan_unit_f32, atan2_f32};
pub use model::{
    Format, IesVersion, Keyword, LampSet, LdtInfo, Limits, LuminousOpening, OpeningShape,
    ParseOptions, PhotometricType, Symmetry, Tilt, TiltData, TiltResolver, Units, Warning,
};
pub use opening::{Emitter, EmitterSample, SolidKind};
pub use photometry::Photometry;
