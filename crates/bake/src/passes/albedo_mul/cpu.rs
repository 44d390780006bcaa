//! The CPU reference of pass `albedo_mul`: `src.rgb × albedo.rgb`, guarded, the mask kept.

use crate::cpu::kernel::*;

parameterless_pass! {
    /// The albedo multiply.
    Pass
}

impl TexelPass for Pass {
    #[inline]
    fn texel(&self, ctx: &Ctx<'_>, at: Texel) -> [f32; 4] {
        let [a, b] = ctx.maps().map(|m| m.fetch(at));
        [
            guard(a[0] * b[0]),
            guard(a[1] * b[1]),
            guard(a[2] * b[2]),
            a[3],
        ]
    }
}
