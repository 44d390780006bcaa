//! GLSL ES 3.00 sources (one file per pass in `shaders/`, side by side) and the generated
//! `#define` prefix.
//!
//! Every program is `#version 300 es` + precision + [`defines`] + library files + the pass file.
//! The texel-layout constants of the BVH encoding come from `luxbake_bvh::layout::glsl_defines`
//! at run time, so shader and encoder cannot drift.

use luxbake_bvh::layout;

/// The stateless RNG hash (`luxbake::rng`, bit-exact).
pub(crate) const RNG: &str = include_str!("../shaders/rng.glsl");
/// BVH traversal over the encoded textures (`luxbake_bvh::traverse`, line for line).
pub(crate) const BVH: &str = include_str!("../shaders/bvh.glsl");

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

/// The `#define` block of every program: the BVH layout constants and the traversal choice.
pub(crate) fn defines(traversal: Traversal) -> String {
    format!(
        "{}#define LUX_TRAVERSAL_MTBVH 0\n#define LUX_TRAVERSAL_TBVH 1\n\
         #define LUX_TRAVERSAL_NONE 2\n#define LUX_TRAVERSAL {}\n",
        layout::glsl_defines(),
        traversal.define()
    )
}

#[cfg(test)]
mod tests;
