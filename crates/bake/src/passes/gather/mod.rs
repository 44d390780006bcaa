//! Pass `gather`: the program's signature, its parameter block and its shaders
//! (gather.glsl, gather.wgsl) side by side, and its CPU reference (`cpu.rs`), the semantics the
//! shaders mirror.
//!
//! One bounce of indirect illuminance.
//!
//! # Direct light at the hits
//! The first bounce gathers the exitance `ρ·E_direct` of the surfaces its rays meet. Read
//! from the light maps, `E_direct` is the direct pass's value at the nearest texel centres,
//! interpolated: where a shadow's edge crosses a texel, the read is off by up to the texel's
//! share of the edge, with a sign that depends on where the edge falls in the texel. A
//! surface that sees such a patch from near (a seat's underside over its own shadow on the
//! floor) gathers these errors: at 64 texels/m the furniture of `chairs_10` read 0.35 % from
//! Radiance at `final`, 0.26 % with maps at twice the density. With
//! [`GatherParams::direct_at_hits`] a hit's `E_direct` is the direct pass's own sum at the
//! hit (every lamp as a point from its photometric centre, one shadow ray each; the
//! preview's rule, [`crate::passes::direct::DirectParams::points_only`]) and its albedo is
//! read from the albedo map with the reflected map's mask and weights, so that a gather ray
//! reads the light where it lands. A hit within a lamp's opening's near distance, whose
//! direct light the point would miss, reads `reflected` as without it. The estimator stays
//! the lamp paths' balance heuristic's partner: both now evaluate `ρ·E_direct` at the point
//! itself ([`crate::lightpaths`]).

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
        /// 1: the lamps' direct light evaluated at each hit (every lamp as a point, a shadow
        /// ray each) times the albedo read there (slot `albedo`, masked as `reflected`),
        /// instead of `reflected` read there, at the hits that lie within no lamp's opening's
        /// near distance (module docs, "Direct light at the hits"); the first bounce's, with
        /// [`crate::scene::Settings::direct_at_hits`]. 0: `reflected` everywhere, `albedo` not
        /// read.
        direct_at_hits: u32,
        /// Padding.
        pad0: u32,
        /// Padding.
        pad1: u32,
        /// Padding.
        pad2: u32,
    }
}

signature! {
    gather {
        reads: ["position", "normal", "reflected", "connected", "prior", "albedo"],
        scene: [bvh, lamps, regions],
        params: GatherParams,
        libraries: [Common, Rng, Scene, Bvh, Ies, Lamp, Gather, Coarse],
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
