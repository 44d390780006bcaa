//! Pass `copy`: the program's signature and its shaders
//! (copy.glsl, copy.wgsl) side by side, and its CPU reference (`cpu.rs`), the semantics the shaders
//! mirror.
//!
//! Texel-for-texel copy.

pub(crate) mod cpu;

use crate::contract::signature;

signature! {
    copy {
        reads: ["src"],
        libraries: [Common],
    }
}
