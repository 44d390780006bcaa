//! The CPU reference of pass `atrous` (the semantics the shaders mirror).

use crate::contract::B3;
use crate::cpu::kernel::*;

use super::AtrousParams;

/// One à-trous iteration for one dispatch.
pub(crate) type Pass = AtrousParams;

impl TexelPass for AtrousParams {
    #[inline]
    fn texel(&self, ctx: &Ctx<'_>, at: Texel) -> [f32; 4] {
        atrous_texel(ctx.maps(), *self, at)
    }
}

/// One à-trous iteration at one texel (see the module docs).
pub(crate) fn atrous_texel(
    [src, variance, pos, nrm]: [View<'_>; 4],
    params: AtrousParams,
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
    let scale = params.variance_scale * variance.fetch(at)[0];
    let step = i64::from(params.step);
    let mut sum = [0.0f32; 3];
    let mut wsum = 0.0f32;
    for (j, &bj) in B3.iter().enumerate() {
        for (i, &bi) in B3.iter().enumerate() {
            let o = [(i as i64 - 2) * step, (j as i64 - 2) * step];
            let Some((t, cos)) = guide.tap(o) else {
                continue;
            };
            if cos.is_nan() || cos <= 0.0 {
                continue;
            }
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
            let w = bi * bj * wn * wl;
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
