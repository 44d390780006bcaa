//! luxbake's OpenGL ES 3.0 / WebGL2 backend: the paper's bake as fragment-shader passes.
//!
//! (Crate documentation is completed with the backend; see the module docs.)
#![warn(missing_docs)]

mod backend;
mod context;
mod error;
mod gl;
mod scene;
mod shaders;

pub use backend::{DEFAULT_TILE_WORK, GlowBackend, GlowScene, GlowTexture};
pub use context::{Capabilities, GlContext, webgl2};
pub use error::{GlowError, Result};

#[cfg(test)]
mod testutil;
