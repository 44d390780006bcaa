//! The CPU reference of pass `upsample` (the semantics the shaders mirror).

use crate::cpu::kernel::*;

use super::UpsampleParams;

/// The upsample for one dispatch.
pub(crate) type Pass = UpsampleParams;

impl TexelPass for UpsampleParams {
    #[inline]
    fn texel(&self, ctx: &Ctx<'_>, layer: u32, x: u32, y: u32) -> [f32; 4] {
        let v = ctx.views;
        upsample_texel([v[0], v[1], v[2]], *self, layer, x, y)
    }
}

/// [`Program::Upsample`] at one texel.
pub(crate) fn upsample_texel(
    [src, pos, nrm]: [View<'_>; 3],
    params: UpsampleParams,
    layer: u32,
    x: u32,
    y: u32,
) -> [f32; 4] {
    if pos.fetch(layer, x, y)[3] <= 0.5 {
        return [0.0; 4];
    }
    let own = src.fetch(layer, x, y);
    let (corners, total) = coarse_weights(pos, nrm, params.stride, params.reach, layer, x, y);
    if total.is_nan() || total <= 0.0 {
        return own;
    }
    let mut sum = [0.0f32; 3];
    for ([tx, ty], w) in corners {
        if w > 0.0 {
            let v = src.fetch(layer, tx as u32, ty as u32);
            for c in 0..3 {
                sum[c] += w * v[c];
            }
        }
    }
    [
        guard(sum[0] / total),
        guard(sum[1] / total),
        guard(sum[2] / total),
        1.0,
    ]
}
