//! Pass `combine`: the program's signature, its parameter block and its shaders
//! (combine.glsl, combine.wgsl) side by side, and its CPU reference (`cpu.rs`), the semantics the
//! shaders mirror.
//!
//! Weighted sum of two maps (direct + indirect), clamped at 0 unless signed.

pub(crate) mod cpu;

use crate::contract::{param_block, signature};

param_block! {
    /// Parameters of [`Program::Combine`](crate::program::Program::Combine): `dst = a_weight · a +
    /// b_weight · b`.
    CombineParams as "LuxCombineParams" {
        /// Weight of the first input.
        a_weight: f32,
        /// Weight of the second input.
        b_weight: f32,
        /// 1: negative sums are kept ([`crate::exact::guard_signed`]; the bias correction's
        /// residual, [`crate::program::correction_steps`]); 0: clamped at 0
        /// ([`crate::exact::guard`]), as every map the bake reports.
        signed: u32,
        /// Padding.
        pad1: u32,
    }
}

impl CombineParams {
    /// `a + b` (the paper's combine): weights 1, bit-identical to an unweighted sum.
    pub const SUM: CombineParams = CombineParams {
        a_weight: 1.0,
        b_weight: 1.0,
        signed: 0,
        pad1: 0,
    };

    /// `a − b`, signed: the residual of a filter (`a` the unfiltered map, `b` the filtered).
    pub const RESIDUAL: CombineParams = CombineParams {
        a_weight: 1.0,
        b_weight: -1.0,
        signed: 1,
        pad1: 0,
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
