//! Pass `combine`: the program's signature, its parameter block and its shaders
//! (combine.glsl, combine.wgsl) side by side, and its CPU reference (`cpu.rs`), the semantics the
//! shaders mirror.
//!
//! Weighted sum of two maps (direct + indirect), clamped at 0; or the two steps of the
//! denoiser's bias correction around its linear filter ([`crate::program::correction_steps`]):
//! the two maps' luminances side by side, and a map scaled by the ratio of two filtered
//! luminances.

pub(crate) mod cpu;

use crate::contract::{param_block, signature};

param_block! {
    /// Parameters of [`Program::Combine`](crate::program::Program::Combine): by `mode`,
    /// `dst = a_weight · a + b_weight · b` ([`CombineParams::WEIGHTED`]), or one of the bias
    /// correction's steps ([`CombineParams::LUMINANCES`], [`CombineParams::SCALED`]); every
    /// result clamped at 0 ([`crate::exact::guard`]), the alpha `a`'s.
    CombineParams as "LuxCombineParams" {
        /// Weight of the first input ([`CombineParams::WEIGHTED`] only).
        a_weight: f32,
        /// Weight of the second input ([`CombineParams::WEIGHTED`] only).
        b_weight: f32,
        /// [`CombineParams::WEIGHTED`], [`CombineParams::LUMINANCES`] or
        /// [`CombineParams::SCALED`].
        mode: u32,
        /// Padding.
        pad1: u32,
    }
}

impl CombineParams {
    /// Mode: `a_weight · a + b_weight · b`.
    pub const WEIGHTED: u32 = 0;
    /// Mode: `(L(a), L(b), 0)`, `L` the luminance ([`crate::exact::luminance`]): the unfiltered
    /// and the filtered map's luminances side by side, for the bias correction's linear filter.
    pub const LUMINANCES: u32 = 1;
    /// Mode: `a · b.r / b.g` where `b.g > 0`, else `a`: the filtered map `a` scaled by the
    /// ratio of the linearly filtered luminances that [`CombineParams::LUMINANCES`] paired.
    pub const SCALED: u32 = 2;

    /// `a + b` (the paper's combine): weights 1, bit-identical to an unweighted sum.
    pub const SUM: CombineParams = CombineParams {
        a_weight: 1.0,
        b_weight: 1.0,
        mode: CombineParams::WEIGHTED,
        pad1: 0,
    };

    /// The luminances of `a` (the unfiltered map) and `b` (the filtered one) side by side.
    pub const PAIR: CombineParams = CombineParams {
        mode: CombineParams::LUMINANCES,
        ..CombineParams::SUM
    };

    /// `a` scaled by the ratio of `b`'s first two channels.
    pub const RATIO: CombineParams = CombineParams {
        mode: CombineParams::SCALED,
        ..CombineParams::SUM
    };
}

signature! {
    combine {
        reads: ["direct", "indirect"],
        params: CombineParams,
        libraries: [Common],
    }
}

/// Evaluations per texel, for the tile plan ([`crate::program::TilePlan`]).
pub fn work(_: &CombineParams) -> u64 {
    1
}
