//! Pass `variance`: the program's signature, its parameter block and its shaders
//! (variance.glsl, variance.wgsl) side by side, and its CPU reference (`cpu.rs`), the semantics the
//! shaders mirror.
//!
//! Noise variance of the luminance in a 5×5 window (red, for the à-trous filter's
//! edge-stopping), and with the centre left out its mean luminance (green, for refinement and
//! the à-trous filter's wide term) and variance (blue, for refinement); alpha is the luminance
//! of the texel's direct light (slot `direct`), which refinement weighs the noise against
//! ([`crate::passes::refine`], "Against the light the maps report"; the denoiser does not
//! read it).

pub(crate) mod cpu;

use crate::contract::{param_block, signature};

param_block! {
    /// Parameters of [`Program::Variance`](crate::program::Program::Variance): the noise variance
    /// of the luminance at a texel,
    /// estimated from neighbouring texels of its surface (the derivation is in
    /// [`atrous_steps`](crate::program::atrous_steps)' docs and [`crate::cpu`]).
    VarianceParams as "LuxVarianceParams" {
        /// Farthest a tap on the centre's chart lies per texel of offset, metres
        /// ([`AtrousConfig::reach`](crate::program::AtrousConfig::reach)).
        reach: f32,
        /// Fewest texel pairs a direction needs to give an estimate
        /// ([`ATROUS_MIN_PAIRS`](crate::program::ATROUS_MIN_PAIRS)).
        min_pairs: u32,
        /// A power of two the luminances are multiplied by before their differences are
        /// squared ([`AtrousConfig::luminance_scale`](crate::program::AtrousConfig::luminance_scale)):
        /// the variance and the mean come out in those units.
        luminance_scale: f32,
        /// Padding.
        pad1: u32,
    }
}

signature! {
    variance {
        reads: ["src", "position", "normal", "direct"],
        params: VarianceParams,
        libraries: [Common, Guide],
    }
}

/// Evaluations per texel, for the tile plan ([`crate::program::TilePlan`]).
pub fn work(_: &VarianceParams) -> u64 {
    // 25 taps, then 4 directions × 20 pairs.
    105
}
