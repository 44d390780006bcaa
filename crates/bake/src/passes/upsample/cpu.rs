//! The CPU reference of pass `upsample` (the semantics the shaders mirror).

use crate::cpu::kernel::*;

use super::UpsampleParams;

/// The upsample for one dispatch.
pub(crate) type Pass = UpsampleParams;

impl TexelPass for UpsampleParams {
    #[inline]
    fn texel(&self, ctx: &Ctx<'_>, at: Texel) -> [f32; 4] {
        upsample_texel(ctx.maps(), *self, at)
    }
}

/// [`Program::Upsample`] at one texel.
pub(crate) fn upsample_texel(
    [src, pos, nrm]: [View<'_>; 3],
    params: UpsampleParams,
    at: Texel,
) -> [f32; 4] {
    if pos.fetch(at)[3] <= 0.5 {
        return [0.0; 4];
    }
    let own = src.fetch(at);
    let (corners, total) = coarse_weights([pos, nrm], params.stride, params.reach, at);
    if total.is_nan() || total <= 0.0 {
        return own;
    }
    let mut sum = [0.0f32; 3];
    for ([tx, ty], w) in corners {
        if w > 0.0 {
            let v = src.fetch(Texel {
                x: tx as u32,
                y: ty as u32,
                ..at
            });
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
