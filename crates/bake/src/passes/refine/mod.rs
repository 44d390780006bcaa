//! Pass `refine`: the program's signature, its parameter block and its shaders
//! (refine.glsl, refine.wgsl) side by side, and its CPU reference (`cpu.rs`), the semantics the
//! shaders mirror.
//!
//! Progressive refinement of a gather: a texel whose variance estimate
//! ([`Program::Variance`](crate::program::Program::Variance) of the first gather: `√variance / mean
//! luminance` of its 5×5
//! window without the texel itself) shows a relative standard error over
//! [`RefineParams::max_error`] gets `rays`
//! more rays, continuing its sequence, averaged with the first gather's by ray count; every
//! other texel keeps the first gather's value. The decision leaves the texel's own value
//! out: deciding on its own noisy estimate keeps the texels that came out high and refines
//! those that came out low (measured: +5.5 % on `chairs_05` at a target of 0.3 when
//! divided by the texel's own luminance; −2 % on the box room while its own value was in
//! the variance). Then kept and refined texels are both unbiased.

pub(crate) mod cpu;

use crate::contract::{param_block, signature};

param_block! {
    /// Parameters of [`Program::Refine`](crate::program::Program::Refine): progressive refinement
    /// of a gather of `first_rays`
    /// rays per texel (see [`Program::Refine`](crate::program::Program::Refine)).
    RefineParams as "LuxRefineParams" {
        /// Further rays per texel that misses the target: the draws of
        /// [`Stream::refine`](crate::rng::Stream::refine) (with the hash sampler samples
        /// `first_rays .. first_rays + rays` of the texel's sequence).
        rays: u32,
        /// Bounce number, 1-based (the `pass` input of the RNG hash).
        bounce: u32,
        /// Seed of the RNG hash.
        seed: u32,
        /// The direction sampler's id ([`Sampler::id`](crate::rng::Sampler::id)).
        sampler: u32,
        /// Rays of the first gather.
        first_rays: u32,
        /// The target: a texel whose estimated relative standard error (√variance / the
        /// window's mean luminance, [`Program::Variance`](crate::program::Program::Variance)) is at
        /// most this is kept as it is.
        max_error: f32,
        /// Padding.
        pad0: u32,
        /// Padding.
        pad1: u32,
    }
}

signature! {
    refine {
        reads: ["position", "normal", "reflected", "first", "variance"],
        // The lamps and their tables: the shared gather loop can weight against lamp paths
        // (the refine pass never does: lamp paths require no refinement).
        scene: [bvh, lamps, regions],
        params: RefineParams,
        libraries: [Common, Rng, Scene, Bvh, Ies, Gather],
    }
}

/// Evaluations per texel, for the tile plan ([`crate::program::TilePlan`]).
pub fn work(p: &RefineParams) -> u64 {
    u64::from(p.rays)
}
