//! The CPU reference of pass `copy`: the texel as it is.

use crate::cpu::kernel::*;

/// The copy.
pub(crate) struct Pass;

impl TexelPass for Pass {
    fn new(_: &[u32], _: &Ctx<'_>) -> Self {
        Pass
    }

    #[inline]
    fn texel(&self, ctx: &Ctx<'_>, layer: u32, x: u32, y: u32) -> [f32; 4] {
        ctx.views[0].fetch(layer, x, y)
    }
}
