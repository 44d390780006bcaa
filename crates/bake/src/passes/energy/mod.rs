//! Pass `energy`: the program's signature and its shaders (energy.glsl, energy.wgsl) side by
//! side, and its CPU reference (`cpu.rs`), the semantics the shaders mirror.
//!
//! The sum of one row of the source: texel `(i, 0)` of the written texture is `Σ (r + g + b)`
//! over the valid texels (alpha > 0.5) of row `i` of the source, in f32, in runs of
//! [`RUN`] texels (each run summed, then added to the total: the rounding error grows with
//! the run length plus the number of runs, not with the row's length), alpha 1. The graph
//! applies it twice after a pass whose result the driver checks
//! ([`crate::graph::Check`]): the map's rows into a row of row sums (`[height, 1]` per
//! layer), that row into one texel (`[1, 1]` per layer). The driver then reads back 16 bytes
//! per layer instead of the map.

pub(crate) mod cpu;

use crate::contract::signature;

/// Texels summed before a run is added to the row's total.
pub const RUN: u32 = 64;

signature! {
    energy {
        reads: ["src"],
        libraries: [Common],
    }
}
