//! The CPU reference of pass `copy`: the texel as it is.

use crate::cpu::kernel::*;

parameterless_pass! {
    /// The copy.
    Pass
}

impl TexelPass for Pass {
    #[inline]
    fn texel(&self, ctx: &Ctx<'_>, at: Texel) -> [f32; 4] {
        ctx.views[0].fetch(at)
    }
}
