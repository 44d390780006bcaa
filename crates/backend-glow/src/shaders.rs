//! GLSL ES 3.00 sources (one file per pass in `shaders/`, side by side) and the generated
//! `#define` prefix.
//!
//! Every program is `#version 300 es` + precision + [`defines`] + library files + the pass file.
//! The texel-layout constants of the BVH encoding come from `luxbake_bvh::layout::glsl_defines`
//! and the blur constants from `luxbake::cpu` at run time, so shaders and Rust cannot drift.
//!
//! | pass (paper Figure 4 box) | file | library files |
//! |---|---|---|
//! | direct (2) | `direct.frag.glsl` | `common`, `bvh`, `ies` |
//! | copy (2 → 3, 6 → 7) | `copy.frag.glsl` | `common` |
//! | blur (3, 7) | `blur.frag.glsl` | `common` |
//! | albedo multiply (4, 8) | `albedo_mul.frag.glsl` | `common` |
//! | gather (5) | `gather.frag.glsl` | `common`, `rng`, `bvh` |
//! | combine (6) | `combine.frag.glsl` | `common` |

pub(crate) use luxbake::graph::Program as Pass;
use luxbake_bvh::layout;

/// Shared helpers (`luxDot`, `luxNormalize`, `luxGuard`, the output and layer uniform).
pub(crate) const COMMON: &str = include_str!("../shaders/common.glsl");
/// The stateless RNG hash (`luxbake::rng`, bit-exact).
pub(crate) const RNG: &str = include_str!("../shaders/rng.glsl");
/// BVH traversal over the encoded textures (`luxbake_bvh::traverse`, line for line).
pub(crate) const BVH: &str = include_str!("../shaders/bvh.glsl");
/// Bilinear IES table sampling (`luxbake_ies::GpuTable::sample`).
pub(crate) const IES: &str = include_str!("../shaders/ies.glsl");
const DIRECT: &str = include_str!("../shaders/direct.frag.glsl");
const COPY: &str = include_str!("../shaders/copy.frag.glsl");
const BLUR: &str = include_str!("../shaders/blur.frag.glsl");
const ALBEDO_MUL: &str = include_str!("../shaders/albedo_mul.frag.glsl");
const GATHER: &str = include_str!("../shaders/gather.frag.glsl");
const COMBINE: &str = include_str!("../shaders/combine.frag.glsl");

/// Which traversal a ray-casting program is compiled for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Traversal {
    /// Six link orders; the layer is picked from the ray's dominant direction.
    Mtbvh,
    /// One threaded link order.
    Tbvh,
    /// Every triangle tested.
    None,
}

impl Traversal {
    fn define(self) -> &'static str {
        match self {
            Traversal::Mtbvh => "LUX_TRAVERSAL_MTBVH",
            Traversal::Tbvh => "LUX_TRAVERSAL_TBVH",
            Traversal::None => "LUX_TRAVERSAL_NONE",
        }
    }
}

/// The GLSL sources and sampler names of each [`Pass`] (the core's shader program enum).
pub(crate) trait PassShaders {
    /// Library files and the pass file, in order.
    fn sources(self) -> Vec<&'static str>;
    /// The sampler uniforms of the pass's graph reads, in `PassDesc::reads` order.
    fn sampler_names(self) -> &'static [&'static str];
}

impl PassShaders for Pass {
    fn sources(self) -> Vec<&'static str> {
        match self {
            Pass::Direct => vec![COMMON, BVH, IES, DIRECT],
            Pass::Copy => vec![COMMON, COPY],
            Pass::Blur => vec![COMMON, BLUR],
            Pass::AlbedoMul => vec![COMMON, ALBEDO_MUL],
            Pass::Gather => vec![COMMON, RNG, BVH, GATHER],
            Pass::Combine => vec![COMMON, COMBINE],
        }
    }

    fn sampler_names(self) -> &'static [&'static str] {
        match self {
            Pass::Direct => &["u_position", "u_normal"],
            Pass::Copy => &["u_src"],
            Pass::Blur => &["u_src", "u_normal"],
            Pass::AlbedoMul => &["u_src", "u_albedo"],
            Pass::Gather => &["u_position", "u_normal", "u_reflected"],
            Pass::Combine => &["u_direct", "u_indirect"],
        }
    }
}

/// The `#define` block of every program: the BVH layout constants, the traversal choice and
/// the blur constants of the CPU reference.
pub(crate) fn defines(traversal: Traversal) -> String {
    format!(
        "{}#define LUX_TRAVERSAL_MTBVH 0\n#define LUX_TRAVERSAL_TBVH 1\n\
         #define LUX_TRAVERSAL_NONE 2\n#define LUX_TRAVERSAL {}\n\
         #define LUX_BLUR_NORMAL_COS {:?}\n#define LUX_MAX_BLUR_RADIUS {}\n",
        layout::glsl_defines(),
        traversal.define(),
        luxbake::cpu::BLUR_NORMAL_COS,
        luxbake::cpu::MAX_BLUR_RADIUS,
    )
}

#[cfg(test)]
mod tests;
