//! The CPU reference of pass `combine`: `a_weight · a + b_weight · b`, the luminances of `a`
//! and `b`, or `a` scaled by `b.r / b.g` (by `mode`), guarded, `a`'s mask.

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
    match w.mode {
        CombineParams::LUMINANCES => [
            guard(luminance(xyz(a))),
            guard(luminance(xyz(b))),
            0.0,
            a[3],
        ],
        CombineParams::SCALED => {
            let r = if b[1] > 0.0 { b[0] / b[1] } else { 1.0 };
            [guard(a[0] * r), guard(a[1] * r), guard(a[2] * r), a[3]]
        }
        _ => [
            guard(w.a_weight * a[0] + w.b_weight * b[0]),
            guard(w.a_weight * a[1] + w.b_weight * b[1]),
            guard(w.a_weight * a[2] + w.b_weight * b[2]),
            a[3],
        ],
    }
}
