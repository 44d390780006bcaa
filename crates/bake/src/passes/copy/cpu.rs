//! The CPU reference of pass `copy`: the texel as it is.

use crate::cpu::kernel::*;

parameterless_pass! {
    /// The copy.
    Pass
}

impl TexelPass for Pass {
    #[inline]
    fn texel(&self, ctx: &Ctx<'_>, layer: u32, x: u32, y: u32) -> [f32; 4] {
        ctx.views[0].fetch(layer, x, y)
    }
}
