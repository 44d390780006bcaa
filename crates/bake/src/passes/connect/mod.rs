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
        /// Padding.
        pad0: u32,
        /// Padding.
        pad1: u32,
        /// Padding.
        pad2: u32,
    }
}

signature! {
    connect {
        reads: ["position", "normal"],
        scene: [bvh, lamp_paths],
        params: ConnectParams,
        libraries: [Common, Rng, Scene, Bvh],
    }
}

/// Evaluations per texel, for the tile plan ([`crate::program::TilePlan`]): a shadow ray per
/// connection.
pub fn work(p: &ConnectParams) -> u64 {
    u64::from(p.k)
}
