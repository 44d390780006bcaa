//! Pass `combine`: the program's signature, its parameter block and its shaders
//! (combine.glsl, combine.wgsl) side by side, and its CPU reference (`cpu.rs`), the semantics the
//! shaders mirror.
//!
//! Weighted sum of two maps (direct + indirect).

pub(crate) mod cpu;

use crate::contract::{Field, Library, ParamBlock, ParamScalar, SceneNeeds, Signature, param_block};

param_block! {
    /// Parameters of [`Program::Combine`](crate::program::Program::Combine): `dst = a_weight · a +
    /// b_weight · b`.
    CombineParams as "LuxCombineParams" {
        /// Weight of the first input.
        a_weight: f32,
        /// Weight of the second input.
        b_weight: f32,
        /// Padding.
        pad0: u32,
        /// Padding.
        pad1: u32,
    }
}

impl CombineParams {
    /// `a + b` (the paper's combine): weights 1, bit-identical to an unweighted sum.
    pub const SUM: CombineParams = CombineParams {
        a_weight: 1.0,
        b_weight: 1.0,
        pad0: 0,
        pad1: 0,
    };
}

/// What the pass reads and which parameters it takes.
pub const SIGNATURE: Signature = Signature {
    reads: &["direct", "indirect"],
    scene: SceneNeeds::NONE,
    params: CombineParams::FIELDS,
    params_wgsl: CombineParams::WGSL_NAME,
    libraries: &[Library::Common],
    glsl: include_str!("combine.glsl"),
    wgsl: include_str!("combine.wgsl"),
};

/// Evaluations per texel, for the tile plan ([`crate::program::TilePlan`]).
pub fn work(_: &CombineParams) -> u64 {
    1
}
