//! # luxbake-scene
//!
//! The scene model of [luxbake](https://example.invalid/luxbake): objects, lamps and bake
//! settings, as plain data ([`Scene`], [`Object`], [`Mesh`], [`Lamp`], [`Transform`],
//! [`Albedo`], [`Settings`] and the one overlay of them, [`SettingsPatch`], checked by one
//! [`Settings::validate`]), and where scenes come from ([`sources`]: the built-in rooms, TOML
//! scene files, procedural meshes, closed-form test scenes). The model imports no source.
//!
//! The bake (crate `luxbake`) depends on this crate and re-exports it unchanged as
//! `luxbake::scene` and `luxbake::sources`: code written against those paths keeps working.
//! An engine that only builds or reads scenes (an editor, a converter, a catalogue planner)
//! can depend on this crate alone; it needs no pass, shader or backend.
//!
//! # Conventions
//! - Units: metres for lengths, candela for intensities (from the IES file), lux (lm/m²) for
//!   illuminance, lm/m² for exitance.
//! - World frame: right-handed, **+Y up**, as glTF.
//! - A lamp's photometric frame (see [`Lamp`]) maps to world with nadir along −Y, the C0 plane
//!   toward +X and the C90 plane toward −Z (horizontal angles run counter-clockwise seen from
//!   above, as LM-63 defines them); `aim` and `rotation_deg` rotate that frame.
//! - Light-map UVs: origin (0, 0) at the **top-left texel corner** of the object's light-map
//!   rectangle, u to the right (+x texel), v downward (+y texel, row index), both in [0, 1]
//!   over the rectangle. Row 0 of every texture is the first row in memory. A point at light-map
//!   UV `(u, v)` of an object lies in texel `region.offset + floor((u, v) * region.size)` of its
//!   `luxbake::layout::Region`.
//! - Object transforms: `world = T · Rz · Ry · Rx · S · p` ([`Transform::from_trs`]): scale
//!   first, then rotations about the fixed world X, Y and Z axes in that order, then translation.
//!
//! # The lamp frame, precisely
//! `luxbake-ies` answers intensities in its photometric frame: nadir (γ = 0°) along −Z, the
//! C0 half-plane toward +X, C90 toward +Y. [`Lamp::world_to_photometric_matrix`] maps a world
//! direction into that frame. It is built in three steps:
//! 1. **Default frame** (`aim = [0, -1, 0]`, `rotation_deg = 0`): photometric +X (C0) is world
//!    +X, photometric +Y (C90) is world −Z, photometric +Z (zenith) is world +Y. So world −Y is
//!    the nadir and, seen from above, C angles grow counter-clockwise from +X toward −Z.
//! 2. **Aim**: the default frame is turned by the *smallest* rotation that takes world −Y onto
//!    the normalised `aim` (rotation axis `(−Y) × aim`). When `aim` points straight up (+Y) that
//!    axis is undefined and the turn is 180° about world +X (C0 stays +X, C90 becomes +Z). An
//!    `aim` of zero length or with non-finite components counts as the default `[0, -1, 0]`.
//! 3. **Rotation**: the aimed frame is then turned by `rotation_deg` about the photometric
//!    zenith axis (−aim), right-handed. Positive angles move the C0 plane toward where C90 was:
//!    with the default aim, `rotation_deg = 90` puts C0 at world −Z and C90 at world −X, i.e.
//!    counter-clockwise seen from above (from behind the lamp, looking along `aim`).

#![warn(missing_docs)]

mod model;
mod names;
pub mod sources;

pub use model::*;
