//! The CPU reference of pass `albedo_mul`: `src.rgb × albedo.rgb`, guarded, the mask kept.

use crate::cpu::kernel::*;

parameterless_pass! {
    /// The albedo multiply.
    Pass
}

impl TexelPass for Pass {
    #[inline]
    fn texel(&self, ctx: &Ctx<'_>, layer: u32, x: u32, y: u32) -> [f32; 4] {
        let a = ctx.views[0].fetch(layer, x, y);
        let b = ctx.views[1].fetch(layer, x, y);
        [
            guard(a[0] * b[0]),
            guard(a[1] * b[1]),
            guard(a[2] * b[2]),
            a[3],
        ]
    }
}
