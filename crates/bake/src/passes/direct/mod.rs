//! Pass `direct`: the program's signature, its parameter block and its shaders
//! (direct.glsl, direct.wgsl) side by side, and its CPU reference (`cpu.rs`), the semantics the
//! shaders mirror.
//!
//! Direct illuminance with shadow rays: from each lamp's photometric centre, or, for texels
//! near a lamp with a luminous opening, from [`DirectParams::samples`] points of the opening
//! ([`crate::opening`]).

pub(crate) mod cpu;

use crate::contract::{param_block, signature};

param_block! {
    /// Parameters of [`Program::Direct`](crate::program::Program::Direct): the lamps are the
    /// scene's uploaded lamps.
    DirectParams as "LuxDirectParams" {
        /// Lamps to evaluate (the first `lamp_count` of the uploaded lamps).
        lamp_count: u32,
        /// Seed of the RNG hash (the openings' lattice shift).
        seed: u32,
        /// Points of a lamp's opening per texel near it, from twice the opening's size on (up
        /// to twice as many nearer, [`crate::opening::texel_samples`]).
        samples: u32,
        /// Lamps with an opening among the first `lamp_count` (for the tile plan).
        openings: u32,
    }
}

signature! {
    direct {
        reads: ["position", "normal"],
        scene: [bvh, lamps],
        params: DirectParams,
        libraries: [Common, Rng, Scene, Bvh, Ies, Lamp, Opening],
    }
}

/// Evaluations per texel, for the tile plan ([`crate::program::TilePlan`]): one shadow ray
/// per lamp, and at most twice `samples` per lamp with an opening
/// ([`crate::opening::texel_samples`]).
pub fn work(p: &DirectParams) -> u64 {
    u64::from(p.lamp_count) + 2 * u64::from(p.openings) * u64::from(p.samples)
}
