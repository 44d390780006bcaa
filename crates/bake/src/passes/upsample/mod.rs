//! Pass `upsample`: the program's signature, its parameter block and its shaders
//! (upsample.glsl, upsample.wgsl) side by side, and its CPU reference (`cpu.rs`), the semantics the
//! shaders mirror.
//!
//! Fills the texels a reduced-resolution gather left out
//! ([`GatherParams::stride`](crate::program::GatherParams::stride)) from
//! the grid texels around them on their surface ([`coarse`](crate::program::coarse)).

pub(crate) mod cpu;

use crate::contract::{Field, Library, ParamBlock, ParamScalar, SceneNeeds, Signature, param_block};

param_block! {
    /// Parameters of [`Program::Upsample`](crate::program::Program::Upsample): the
    /// reduced-resolution gather's grid.
    UpsampleParams as "LuxUpsampleParams" {
        /// The gather's [`GatherParams::stride`](crate::program::GatherParams::stride).
        stride: u32,
        /// The gather's [`GatherParams::reach`](crate::program::GatherParams::reach).
        reach: f32,
        /// Padding.
        pad0: u32,
        /// Padding.
        pad1: u32,
    }
}

/// What the pass reads and which parameters it takes.
pub const SIGNATURE: Signature = Signature {
    reads: &["src", "position", "normal"],
    scene: SceneNeeds::NONE,
    params: UpsampleParams::FIELDS,
    params_wgsl: UpsampleParams::WGSL_NAME,
    libraries: &[Library::Common, Library::Coarse],
    glsl: include_str!("upsample.glsl"),
    wgsl: include_str!("upsample.wgsl"),
};

/// Evaluations per texel, for the tile plan ([`crate::program::TilePlan`]).
pub fn work(_: &UpsampleParams) -> u64 {
    4
}
