//! # luxbake-js
//!
//! The wasm baker of the `luxbake` npm package: a web page hands over a glTF/GLB scene, its
//! lamps (IES LM-63 or EULUMDAT text, position, aim, rotation, multiplier) and the CLI's
//! settings (`quality` `draft`/`default`/`final`, `method` `paper`, overrides), and gets back
//! per object light maps of illuminance in lux, timings and warnings. `cargo xtask npm` builds
//! the package into `<target dir>/npm/` (ES modules, a module worker, TypeScript declarations,
//! README and a three.js example, all in `crates/js/package/`); `cargo xtask npm --check` tests
//! the packed package in headless Chromium against the native glow bake.
//!
//! ## One path, natively and in the browser
//! [`build_scene`] turns a request into a [`luxbake::scene::Scene`] with the core's checks
//! ([`luxbake::scene::Settings::validate`], [`luxbake::scene::Lamp::validate`]), the photometry
//! parser of `luxbake-ies` and the glTF reader of `luxbake-assets` (light-map UVs generated
//! when the file has none usable). The browser bakes it with `luxbake-backend-glow` on an
//! `OffscreenCanvas` in a module worker (`web::Baker`, wasm32 only); the package's test bakes
//! the same [`build_scene`] natively and compares the maps.
//!
//! ## Errors
//! Bad input is a [`JsBakeError`], never a panic; its [`JsBakeError::kind`] is the `kind` of
//! the `LuxbakeError` the JavaScript promise rejects with.
#![warn(missing_docs)]

mod error;
pub mod request;
#[cfg(target_arch = "wasm32")]
pub mod web;

pub use error::JsBakeError;
pub use request::{
    BakeOptions, Built, Imported, LampOptions, ObjectInfo, build_lamps, build_scene, import_room,
    measure,
};
