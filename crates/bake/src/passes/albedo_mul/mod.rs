//! Pass `albedo_mul`: the program's signature and its shaders
//! (albedo_mul.glsl, albedo_mul.wgsl) side by side, and its CPU reference (`cpu.rs`), the semantics
//! the shaders mirror.
//!
//! Illuminance × albedo.

pub(crate) mod cpu;

use crate::contract::{Library, SceneNeeds, Signature};

/// What the pass reads and which parameters it takes.
pub const SIGNATURE: Signature = Signature {
    reads: &["src", "albedo"],
    scene: SceneNeeds::NONE,
    params: &[],
    params_wgsl: "",
    libraries: &[Library::Common],
    glsl: include_str!("albedo_mul.glsl"),
    wgsl: include_str!("albedo_mul.wgsl"),
};
