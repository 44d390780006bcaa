//! The CPU reference of pass `upsample` (the semantics the shaders mirror).

use std::sync::Arc;

use crate::contract::ParamBlock;
use crate::cpu::kernel::*;

use super::UpsampleParams;

/// The upsample for one dispatch: its parameters, and the grid corners of its texels when
/// the backend keeps them ([`CoarseMasks`]).
pub(crate) struct Pass {
    params: UpsampleParams,
    masks: Option<Arc<CoarseMasks>>,
}

impl Prepare for Pass {
    fn prepare(words: &[u32], ctx: &Ctx<'_>) -> Pass {
        let params = UpsampleParams::from_words(words);
        Pass {
            params,
            // Read slots 1 and 2 are the position and normal maps.
            masks: ctx.coarse_masks([1, 2], params.stride, params.reach),
        }
    }
}

impl TexelPass for Pass {
    #[inline]
    fn texel(&self, ctx: &Ctx<'_>, at: Texel) -> [f32; 4] {
        upsample_texel(ctx.maps(), self.params, self.masks.as_deref(), at)
    }
}

/// [`Program::Upsample`] at one texel; the bits of `masks` stand in for the corners' tests
/// where given.
pub(crate) fn upsample_texel(
    [src, pos, nrm]: [View<'_>; 3],
    params: UpsampleParams,
    masks: Option<&CoarseMasks>,
    at: Texel,
) -> [f32; 4] {
    if pos.fetch(at)[3] <= 0.5 {
        return [0.0; 4];
    }
    let own = src.fetch(at);
    let bits = corners_at(masks, [pos, nrm], params.stride, params.reach, at);
    let (corners, total) = coarse_weights(bits, params.stride, at);
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
