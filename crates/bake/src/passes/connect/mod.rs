//! Pass `connect`: the program's signature and its shaders (connect.glsl, connect.wgsl) side
//! by side, and its CPU reference (`cpu.rs`), the semantics the shaders mirror.
//!
//! The lamp paths' part `C(x)` of the first bounce ([`crate::lightpaths`]): each valid texel
//! picks [`ConnectParams::k`] points of the pool (stratified picks from its block's Sobol
//! draws, pass [`CONNECT_PASS`](crate::lightpaths::CONNECT_PASS); `lightpaths`, "Stratified
//! picks"), joins each with a shadow ray and
//! adds its power weighted by the balance heuristic against a gather of
//! [`ConnectParams::rays`] rays. The pool's points are a scene resource
//! ([`SceneData::lamp_paths`](crate::backend::SceneData::lamp_paths)); the gather adds the
//! result (its slot `connected`). Formerly computed on the host for every backend; now the
//! backend runs it, and a lamp swap leaves only the pool's tracing on the host.
//!
//! With [`ConnectParams::picks`] > 0 the pass makes a second, independent estimate of the same
//! part for the first bounce's refinement ([`Program::Refine`](crate::program::Program::Refine)):
//! `picks` further points per texel, continuing the texel's picks past the first `k` (the
//! draws of [`Stream::refine`](crate::rng::Stream::refine)), weighted by the same balance
//! heuristic (for `rays` and `k`) and scaled by `k / picks`, at the texels the refinement
//! refines only (the same test of the variance map, slot `variance`; the others read 0).
//! [`ConnectParams::narrow_picks`] does the same at the texels in a narrow gap, whatever their
//! noise (the refinement's "Narrow gaps"): a texel takes the larger count where both apply,
//! its picks continue its first ones over the larger of the two counts, and its sum is scaled
//! by `k` over its own count.

pub(crate) mod cpu;

use crate::contract::{param_block, signature};

param_block! {
    /// Parameters of [`Program::Connect`](crate::program::Program::Connect).
    ConnectParams as "LuxConnectParams" {
        /// Rays of the first bounce's gather (`N_C` of the balance heuristic).
        rays: u32,
        /// Connections per texel (`K`).
        k: u32,
        /// Seed of the RNG hash.
        seed: u32,
        /// Points in the pool ([`SceneData::lamp_paths`](crate::backend::SceneData::lamp_paths)).
        count: u32,
        /// [`crate::lightpaths::LampPaths::density_scale`].
        density_scale: f32,
        /// With [`ConnectParams::narrow_picks`], 0: the first bounce's `k` connections at
        /// every texel. Otherwise the refinement's: this many further connections, at the
        /// texels whose estimated relative error exceeds [`ConnectParams::max_error`] (see the
        /// module docs).
        picks: u32,
        /// With `picks` > 0: the refinement's target
        /// ([`RefineParams::max_error`](crate::passes::refine::RefineParams::max_error)).
        max_error: f32,
        /// The refinement's further connections at the texels in a narrow gap
        /// ([`crate::validity::NARROW_GAP`]), whatever their noise; 0: none.
        narrow_picks: u32,
    }
}

signature! {
    connect {
        reads: ["position", "normal", "variance"],
        scene: [bvh, lamp_paths],
        params: ConnectParams,
        libraries: [Common, Rng, Scene, Bvh],
    }
}

/// Evaluations per texel, for the tile plan ([`crate::program::TilePlan`]): a shadow ray per
/// connection.
pub fn work(p: &ConnectParams) -> u64 {
    u64::from(p.connections())
}

impl ConnectParams {
    /// The refinement's connections beside these first ones: `k · more / rays` further
    /// picks (rounded, at least 1, at most
    /// [`MAX_LAMP_PATHS`](crate::scene::Settings::MAX_LAMP_PATHS)), so that a refined
    /// texel's second estimate has the first's ratio of rays to connections, at the texels
    /// whose relative error exceeds `max_error`, and likewise for `narrow_more` further rays
    /// at the texels in a narrow gap (0 rays: none).
    pub fn refinement(self, more: u32, max_error: f32, narrow_more: u32) -> ConnectParams {
        let (k, rays) = (u64::from(self.k), u64::from(self.rays.max(1)));
        let max = u64::from(crate::scene::Settings::MAX_LAMP_PATHS);
        let picks = |more: u32| {
            if more == 0 {
                0
            } else {
                ((k * u64::from(more) + rays / 2) / rays).clamp(1, max) as u32
            }
        };
        ConnectParams {
            picks: picks(more),
            max_error,
            narrow_picks: picks(narrow_more),
            ..self
        }
    }

    /// Whether this is the refinement's pass ([`ConnectParams::picks`] or
    /// [`ConnectParams::narrow_picks`] > 0), not the first connections.
    pub fn is_refinement(&self) -> bool {
        self.picks > 0 || self.narrow_picks > 0
    }

    /// Most connections per texel this pass makes: `k`, or the refinement's larger count
    /// (the span of its picks' draws).
    pub fn connections(&self) -> u32 {
        if self.is_refinement() {
            self.picks.max(self.narrow_picks)
        } else {
            self.k
        }
    }

    /// Connections at a texel that is `narrow`, with variance estimate `noise` (read only by
    /// the refinement with `picks` > 0): `k` for the first; the refinement's larger count that
    /// applies, or 0.
    pub fn connections_at(&self, narrow: bool, noise: impl FnOnce() -> [f32; 4]) -> u32 {
        if !self.is_refinement() {
            return self.k;
        }
        crate::passes::refine::larger_count(
            narrow,
            [self.narrow_picks, self.picks],
            noise,
            self.max_error,
        )
    }

    /// What the sum of a texel's `count` connections is multiplied by: `k / count` for the
    /// refinement's (an estimate of the same part from `count` points), 1 for the first.
    pub fn scale(&self, count: u32) -> f32 {
        if self.is_refinement() && count > 0 {
            self.k as f32 / count as f32
        } else {
            1.0
        }
    }
}
