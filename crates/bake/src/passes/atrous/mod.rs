//! Pass `atrous`: the program's signature, its parameter block and its shaders
//! (atrous.glsl, atrous.wgsl) side by side, and its CPU reference (`cpu.rs`), the semantics the
//! shaders mirror.
//!
//! One iteration of the edge-stopping à-trous wavelet filter, or (`linear`) of the bias
//! correction's linear filter.

pub(crate) mod cpu;

use crate::contract::{param_block, signature};

param_block! {
    /// Parameters of one iteration of [`Program::Atrous`](crate::program::Program::Atrous)
    /// (edge-stopping à-trous wavelet
    /// filter; see [`atrous_steps`](crate::program::atrous_steps)).
    AtrousParams as "LuxAtrousParams" {
        /// Spacing of the 5×5 taps, texels: `2^i` at iteration `i`.
        step: i32,
        /// Farthest a tap on the centre's chart lies per texel of offset, metres
        /// ([`AtrousConfig::reach`](crate::program::AtrousConfig::reach)).
        reach: f32,
        /// Nearest a tap on the centre's chart lies per texel of offset beyond the first two,
        /// metres ([`AtrousConfig::reach_min`](crate::program::AtrousConfig::reach_min)).
        reach_min: f32,
        /// Normal weight `max(0, n̂·n̂ₜ)^(2^normal_log2)`.
        normal_log2: u32,
        /// Luminance weight `exp(−Δl² / (variance_scale · σ²))`, σ² the centre's variance
        /// estimate: `σ_l² · ρᵢ`
        /// ([`AtrousConfig::sigma_luminance`](crate::program::AtrousConfig::sigma_luminance),
        /// [`b3_noise_factor`](crate::program::b3_noise_factor)).
        variance_scale: f32,
        /// The variance pass's power of two: luminance differences are multiplied by it
        /// before they are compared with the variance
        /// ([`AtrousConfig::luminance_scale`](crate::program::AtrousConfig::luminance_scale)).
        luminance_scale: f32,
        /// The luminance term's `variance_scale` where the centre lies inside a wide chart
        /// with little noise (every mirrored pair passes and the variance is under
        /// `wide_max_relative_variance` times the window's squared mean luminance): the early
        /// iterations' wide term
        /// ([`AtrousConfig::wide_max_relative_variance`](crate::program::AtrousConfig::wide_max_relative_variance)).
        wide_variance_scale: f32,
        /// That bound on the relative variance; 0: never (`variance_scale` everywhere).
        wide_max_relative_variance: f32,
        /// 1: the bias correction's filter ([`correction_steps`](crate::program::correction_steps)):
        /// no luminance term (a tap's weight is its spline and normal weights alone, so the
        /// filter is linear in its input); the variance map is not read.
        linear: u32,
        /// `variance_scale` where the centre lies in a narrow gap
        /// ([`crate::validity::NARROW_GAP`]), whose first bounce has more rays
        /// ([`AtrousConfig::narrow_early_sigma_luminance`](crate::program::AtrousConfig::narrow_early_sigma_luminance)).
        narrow_variance_scale: f32,
        /// 1: a centre in a narrow gap keeps its value in this iteration, whose taps reach
        /// farther than [`crate::validity::NARROW_REACH_TEXELS`]
        /// ([`atrous_steps`](crate::program::atrous_steps), "Narrow gaps").
        narrow_keep: u32,
        /// Padding.
        pad2: u32,
    }
}

signature! {
    atrous {
        reads: ["src", "variance", "position", "normal"],
        params: AtrousParams,
        libraries: [Common, Guide],
    }
}

/// Evaluations per texel, for the tile plan ([`crate::program::TilePlan`]).
pub fn work(_: &AtrousParams) -> u64 {
    25
}
