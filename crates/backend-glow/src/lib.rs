//! luxbake's OpenGL ES 3.0 / WebGL2 backend: the paper's bake as fragment-shader passes.
//!
//! (Crate documentation is completed with the backend; see the module docs.)
#![warn(missing_docs)]

mod backend;
mod context;
mod error;
#[cfg_attr(
    not(test),
    expect(dead_code, reason = "programs are used by the passes (next commits)")
)]
mod gl;
#[cfg_attr(
    not(test),
    expect(dead_code, reason = "used by the passes (next commits)")
)]
mod scene;
#[expect(dead_code, reason = "used by the passes (next commits)")]
mod shaders;

pub use backend::{GlowBackend, GlowTexture};
pub use context::{Capabilities, GlContext, webgl2};
pub use error::{GlowError, Result};

#[cfg(test)]
mod testutil;
