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
//!
//! With lamp paths ([`crate::lightpaths`]) the first gather's value `X₁ = G₁ + C₁` is the sum
//! of two multiple-importance parts: its `N` rays' weighted mean `G₁` and the texel's `K`
//! connections to the lamp paths `C₁`, both weighted by the balance heuristic for `N` rays
//! and `K` paths. The refinement makes a second estimate `X₂ = G₂ + C₂` of the same kind:
//! `rays` further rays and `K·rays/N` (rounded, at least 1) further connections (the connect
//! pass with [`ConnectParams::picks`](crate::passes::connect::ConnectParams::picks), slot
//! `connected`), each weighted by the same heuristic (for `N` and `K`: the weights depend on
//! the strategies' ratio, which stays), so that `G₂` and `C₂` estimate what `G₁` and `C₁` do;
//! the refined value is `(N·X₁ + rays·X₂) / (N + rays)`. Both parts get more samples: more
//! rays alone (the connections' part kept) brought `chairs_01`'s furniture from 1.23 to 1.13 %
//! only, and a plain gather averaged with the first value (unbiased too) adds its larger noise
//! where the connections carry the light (`sofa_01`'s furniture 1.65 → 2.16 %).

pub(crate) mod cpu;

/// Whether the refinement refines a texel whose variance estimate (the variance pass's
/// texel: `[variance, window mean luminance, variance without the texel, …]`) is `noise`:
/// its relative standard error over `max_error`. The refine pass and the connect pass of its
/// second connections take the same decision (`luxRefines` / `lux_refines` in the shaders).
// `!(x <= y)` on purpose: a NaN estimate refines, as in the shaders.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(crate) fn refines(noise: [f32; 4], max_error: f32) -> bool {
    !(noise[2].max(0.0).sqrt() <= max_error * noise[1])
}

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
        /// Lamp paths per texel of the first gather (`K`,
        /// [`GatherParams::lamp_paths`](crate::passes::gather::GatherParams::lamp_paths)): the
        /// further rays are weighted against them and the slot `connected` holds their part;
        /// 0: none (the slot is not read).
        lamp_paths: u32,
        /// [`crate::lightpaths::LampPaths::density_scale`].
        density_scale: f32,
        /// Uploaded lamps the lamp paths' density sums over.
        lamp_count: u32,
        /// Padding.
        pad0: u32,
        /// Padding.
        pad1: u32,
        /// Padding.
        pad2: u32,
    }
}

signature! {
    refine {
        reads: ["position", "normal", "reflected", "first", "variance", "connected"],
        // The lamps and their tables: the gather loop weights the rays against the lamp
        // paths.
        scene: [bvh, lamps, regions],
        params: RefineParams,
        libraries: [Common, Rng, Scene, Bvh, Ies, Gather],
    }
}

/// Evaluations per texel, for the tile plan ([`crate::program::TilePlan`]).
pub fn work(p: &RefineParams) -> u64 {
    u64::from(p.rays)
}
