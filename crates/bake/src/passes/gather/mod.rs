//! Pass `gather`: the program's signature, its parameter block and its shaders
//! (gather.glsl, gather.wgsl) side by side, and its CPU reference (`cpu.rs`), the semantics the
//! shaders mirror.
//!
//! One bounce of indirect illuminance.

pub(crate) mod cpu;

use crate::contract::{param_block, signature};

param_block! {
    /// Parameters of [`Program::Gather`](crate::program::Program::Gather).
    GatherParams as "LuxGatherParams" {
        /// Rays per texel.
        rays: u32,
        /// Bounce number, 1-based (the `pass` input of the RNG hash).
        bounce: u32,
        /// Seed of the RNG hash.
        seed: u32,
        /// The direction sampler's id ([`Sampler::id`](crate::rng::Sampler::id)).
        sampler: u32,
        /// Reduced resolution: only texels on the grid of every `stride`-th column and row,
        /// and texels with no such grid texel around them on their surface, are gathered
        /// ([`coarse`](crate::program::coarse));
        /// [`Program::Upsample`](crate::program::Program::Upsample) fills the rest. 1 (or 0): every
        /// texel.
        stride: u32,
        /// The chart test of [`coarse`](crate::program::coarse): farthest a grid texel on the
        /// centre's surface lies
        /// per texel of offset, metres
        /// ([`AtrousConfig::reach`](crate::program::AtrousConfig::reach)).
        reach: f32,
        /// Rays of an orphan ([`coarse`](crate::program::coarse)): it stands for itself, not for a
        /// grid cell of
        /// `stride²` texels, so [`coarse::orphan_rays`](crate::program::coarse::orphan_rays) gives
        /// it fewer than a grid texel.
        orphan_rays: u32,
        /// Lamp paths per texel combined with this gather ([`crate::lightpaths`]; the first
        /// bounce at stride 1 only): each hit's exitance is weighted by the balance heuristic
        /// and the slot `connected` (their part, uploaded) is added. 0: plain gather, the
        /// slot is not read.
        lamp_paths: u32,
        /// [`crate::lightpaths::LampPaths::density_scale`].
        density_scale: f32,
        /// Lamps uploaded (the density of [`crate::lightpaths::density`] sums over them).
        lamp_count: u32,
        /// With [`GatherParams::chunk_rays`]: the first of each texel's rays this dispatch
        /// traces; from the second chunk on (> 0) the slot `prior` holds the chunks before,
        /// which the output adds to, and the lamp paths' part is not added again.
        first_ray: u32,
        /// Most of a texel's rays one dispatch traces (0: all): a texel's rays split over
        /// dispatches, each adding its share (`sum / rays`) to the ones before, so that one
        /// shader invocation stays within a driver's loop limit
        /// ([`crate::Limits::loop_iterations`]).
        chunk_rays: u32,
    }
}

signature! {
    gather {
        reads: ["position", "normal", "reflected", "connected", "prior"],
        scene: [bvh, lamps, regions],
        params: GatherParams,
        libraries: [Common, Rng, Scene, Bvh, Ies, Gather, Coarse],
    }
}

/// Evaluations per texel, for the tile plan ([`crate::program::TilePlan`]).
pub fn work(p: &GatherParams) -> u64 {
    if p.chunk_rays > 0 {
        u64::from(p.rays.min(p.chunk_rays))
    } else {
        u64::from(p.rays)
    }
}
