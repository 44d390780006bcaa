//! Pass `copy`: the program's signature and its shaders
//! (copy.glsl, copy.wgsl) side by side, and its CPU reference (`cpu.rs`), the semantics the shaders
//! mirror.
//!
//! Texel-for-texel copy.

pub(crate) mod cpu;

use crate::contract::{Library, SceneNeeds, Signature};

/// What the pass reads and which parameters it takes.
pub const SIGNATURE: Signature = Signature {
    reads: &["src"],
    scene: SceneNeeds::NONE,
    params: &[],
    params_wgsl: "",
    libraries: &[Library::Common],
    glsl: include_str!("copy.glsl"),
    wgsl: include_str!("copy.wgsl"),
};
