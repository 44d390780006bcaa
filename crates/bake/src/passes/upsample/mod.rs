//! Pass `upsample`: the program's signature, its parameter block and its shaders
//! (upsample.glsl, upsample.wgsl) side by side, and its CPU reference (`cpu.rs`), the semantics the
//! shaders mirror.
//!
//! Fills the texels a reduced-resolution gather left out
//! ([`GatherParams::stride`](crate::program::GatherParams::stride)) from
//! the grid texels around them on their surface ([`coarse`](crate::program::coarse)).

pub(crate) mod cpu;

use crate::contract::{param_block, signature};

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

signature! {
    upsample {
        reads: ["src", "position", "normal"],
        params: UpsampleParams,
        libraries: [Common, Coarse],
    }
}

/// Evaluations per texel, for the tile plan ([`crate::program::TilePlan`]).
pub fn work(_: &UpsampleParams) -> u64 {
    4
}
