//! The CPU reference of pass `atrous` (the semantics the shaders mirror).

use std::sync::Arc;

use crate::contract::{B3, ParamBlock};
use crate::cpu::kernel::*;

use super::AtrousParams;

/// One à-trous iteration for one dispatch: its parameters, and the chart tests of its taps
/// when the backend keeps them ([`GuideMasks`]).
pub(crate) struct Pass {
    params: AtrousParams,
    masks: Option<Arc<GuideMasks>>,
}

impl Prepare for Pass {
    fn prepare(words: &[u32], ctx: &Ctx<'_>) -> Pass {
        let params = AtrousParams::from_words(words);
        let chart = Chart {
            step: i64::from(params.step),
            reach: [params.reach_min, params.reach],
        };
        Pass {
            params,
            // Read slot 2 is the position map.
            masks: ctx.guide_masks(2, chart),
        }
    }
}

impl TexelPass for Pass {
    #[inline]
    fn texel(&self, ctx: &Ctx<'_>, at: Texel) -> [f32; 4] {
        atrous_texel(ctx.maps(), self.params, self.masks.as_deref(), at)
    }
}

/// One à-trous iteration at one texel (see the module docs).
pub(crate) fn atrous_texel(
    [src, variance, pos, nrm]: [View<'_>; 4],
    params: AtrousParams,
    masks: Option<&GuideMasks>,
    at: Texel,
) -> [f32; 4] {
    let c = src.fetch(at);
    if c[3] <= 0.5 {
        return [0.0; 4];
    }
    let kept = [guard(c[0]), guard(c[1]), guard(c[2]), 1.0];
    let reach = [params.reach_min, params.reach];
    let Some(guide) = Guide::new([src, pos, nrm], reach, at) else {
        return kept;
    };
    let guide = guide.with_masks(masks, at);
    let scale = params.variance_scale * variance.fetch(at)[0];
    let step = i64::from(params.step);
    let mut sum = [0.0f32; 3];
    let mut wsum = 0.0f32;
    // A tap on the surface facing the centre's side.
    let tap = |a: usize, b: usize| {
        let o = [(a as i64 - 2) * step, (b as i64 - 2) * step];
        guide.tap_k(5 * b + a, o).filter(|&(_, cos)| cos > 0.0)
    };
    // Taps in mirrored pairs `o`, `−o` (the centre alone last): a pair counts only when both
    // of its taps are on the surface, so the kernel stays point-symmetric at a chart's edge
    // or a contact and a linear gradient is not biased there.
    for k in 0..13usize {
        let (i, j) = (k % 5, k / 5);
        let Some(near) = tap(i, j) else {
            continue;
        };
        let far = if k == 12 { None } else { tap(4 - i, 4 - j) };
        if k != 12 && far.is_none() {
            continue;
        }
        for (t, cos) in std::iter::once(near).chain(far) {
            let mut wn = cos;
            for _ in 0..params.normal_log2 {
                if wn == 0.0 || wn == 1.0 {
                    break;
                }
                wn *= wn;
            }
            let d = [t[0] - c[0], t[1] - c[1], t[2] - c[2]];
            let dl = luminance(d) * params.luminance_scale;
            let wl = if dl == 0.0 {
                1.0
            } else if scale > 0.0 {
                (-(dl * dl) / scale).exp()
            } else {
                0.0
            };
            let w = B3[i] * B3[j] * wn * wl;
            if w.is_nan() || w <= 0.0 {
                continue;
            }
            for k in 0..3 {
                sum[k] += w * d[k];
            }
            wsum += w;
        }
    }
    if wsum > 0.0 {
        [
            guard(c[0] + sum[0] / wsum),
            guard(c[1] + sum[1] / wsum),
            guard(c[2] + sum[2] / wsum),
            1.0,
        ]
    } else {
        kept
    }
}
