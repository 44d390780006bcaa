//! Pass `direct`: the program's signature, its parameter block and its shaders
//! (direct.glsl, direct.wgsl) side by side, and its CPU reference (`cpu.rs`), the semantics the
//! shaders mirror.
//!
//! Direct illuminance with shadow rays.

pub(crate) mod cpu;

use crate::contract::{Field, Library, ParamBlock, ParamScalar, SceneNeeds, Signature, param_block};

param_block! {
    /// Parameters of [`Program::Direct`](crate::program::Program::Direct): the lamps are the
    /// scene's uploaded lamps.
    DirectParams as "LuxDirectParams" {
        /// Lamps to evaluate (the first `lamp_count` of the uploaded lamps).
        lamp_count: u32,
        /// Padding.
        pad0: u32,
        /// Padding.
        pad1: u32,
        /// Padding.
        pad2: u32,
    }
}

/// What the pass reads and which parameters it takes.
pub const SIGNATURE: Signature = Signature {
    reads: &["position", "normal"],
    scene: SceneNeeds {
        bvh: true,
        lamps: true,
        regions: false,
        lamp_paths: false,
    },
    params: DirectParams::FIELDS,
    params_wgsl: DirectParams::WGSL_NAME,
    libraries: &[
        Library::Common,
        Library::Scene,
        Library::Bvh,
        Library::Ies,
        Library::Lamp,
    ],
    glsl: include_str!("direct.glsl"),
    wgsl: include_str!("direct.wgsl"),
};

/// Evaluations per texel, for the tile plan ([`crate::program::TilePlan`]).
pub fn work(p: &DirectParams) -> u64 {
    u64::from(p.lamp_count)
}
