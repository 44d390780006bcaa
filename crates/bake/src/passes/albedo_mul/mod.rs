//! Pass `albedo_mul`: the program's signature and its shaders
//! (albedo_mul.glsl, albedo_mul.wgsl) side by side, and its CPU reference (`cpu.rs`), the semantics
//! the shaders mirror.
//!
//! Illuminance × albedo.

pub(crate) mod cpu;

use crate::contract::signature;

signature! {
    albedo_mul {
        reads: ["src", "albedo"],
        libraries: [Common],
    }
}
