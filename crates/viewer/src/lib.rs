//! # luxbake-viewer
//!
//! luxbake in a browser: a page bakes a furnished room's light maps on the visitor's GPU
//! (WebGL2, through `luxbake-backend-glow`) and renders the lit room for an orbit or walk
//! through it. Compiled to `wasm32-unknown-unknown` with wasm-bindgen; the static page is in
//! `crates/viewer/web/`; `cargo xtask web` builds and serves it, `cargo xtask web --check`
//! runs the end-to-end test in headless Chromium.
//!
//! ## Threads
//! The bake runs in a module Web Worker (`web::Baker`, wasm32 only, on an `OffscreenCanvas`
//! WebGL2 context) so that the page stays interactive during a bake; the worker reports every pass
//! start, tile and pass time, and sends the final maps back. The page's thread owns the
//! display context (`web::Viewer`). Both build the same [`luxbake::scene::Scene`] from the
//! same [`BakeRequest`] ([`build_scene`]).
//!
//! ## What is displayed
//! Per fragment: illuminance `E` (lux) from the object's light map (blurred combined, Figure 5
//! stage 7; masked bilinear, as the gather pass reads maps), times the albedo ρ of the
//! surface ([`mesh`]) gives exitance `M = ρE`; luminance `L = M/π` (cd/m²) times the exposure
//! `2^EV` is tone-mapped (`1 − e^{−x}`) and sRGB-encoded. The false-colour view maps
//! `log10 E` from 1 to 10⁴ lux onto a colour ramp.
//!
//! ## Native build
//! Only the page-independent parts ([`request`], [`camera`], [`mesh`]) compile natively (and
//! are unit-tested there); the wasm-bindgen glue and the WebGL renderer are `wasm32` only.
#![warn(missing_docs)]

pub mod camera;
mod error;
pub mod mesh;
pub mod request;
#[cfg(target_arch = "wasm32")]
pub mod web;

pub use error::ViewerError;
pub use request::{BakeRequest, LampSpec, build_scene};
