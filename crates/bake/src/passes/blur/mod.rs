//! Pass `blur`: the program's signature, its parameter block and its shaders
//! (blur.glsl, blur.wgsl) side by side, and its CPU reference (`cpu.rs`), the semantics the shaders
//! mirror.
//!
//! One axis of the masked separable Gaussian.

pub(crate) mod cpu;

use crate::contract::{param_block, signature};

param_block! {
    /// Parameters of [`Program::Blur`](crate::program::Program::Blur) (one axis of the masked
    /// Gaussian).
    BlurParams as "LuxBlurParams" {
        /// Texel step along the axis: (1, 0) for U.
        step_x: i32,
        /// Texel step along the axis: (0, 1) for V.
        step_y: i32,
        /// Taps on each side: [`blur_radius`](crate::program::blur_radius)`(σ)`.
        radius: i32,
        /// Exponent factor `−1 / (2σ²)`.
        inv: f32,
    }
}

signature! {
    blur {
        reads: ["src", "normal"],
        params: BlurParams,
        libraries: [Common],
    }
}

/// Evaluations per texel, for the tile plan ([`crate::program::TilePlan`]).
pub fn work(p: &BlurParams) -> u64 {
    u64::from(p.radius.unsigned_abs()) * 2 + 1
}
