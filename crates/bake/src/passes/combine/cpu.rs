//! The CPU reference of pass `combine`: `a_weight · a + b_weight · b`, guarded (signed where
//! `signed`), `a`'s mask.

use crate::cpu::kernel::*;

use super::CombineParams;

/// The weighted sum for one dispatch.
pub(crate) type Pass = CombineParams;

impl TexelPass for CombineParams {
    #[inline]
    fn texel(&self, ctx: &Ctx<'_>, at: Texel) -> [f32; 4] {
        let [a, b] = ctx.maps().map(|m| m.fetch(at));
        combine_texel(*self, a, b)
    }
}

/// One texel of the pass from its two inputs' texels.
#[inline]
pub(crate) fn combine_texel(w: CombineParams, a: [f32; 4], b: [f32; 4]) -> [f32; 4] {
    let g = if w.signed != 0 { guard_signed } else { guard };
    [
        g(w.a_weight * a[0] + w.b_weight * b[0]),
        g(w.a_weight * a[1] + w.b_weight * b[1]),
        g(w.a_weight * a[2] + w.b_weight * b[2]),
        a[3],
    ]
}
