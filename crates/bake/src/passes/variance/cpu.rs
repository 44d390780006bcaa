//! The CPU reference of pass `variance` (the semantics the shaders mirror).

use std::sync::Arc;

use crate::contract::{BLUR_NORMAL_COS, ParamBlock};
use crate::cpu::kernel::*;

use super::VarianceParams;

/// The variance estimate for one dispatch: its parameters, and the chart tests of its taps
/// when the backend keeps them ([`GuideMasks`]).
pub(crate) struct Pass {
    params: VarianceParams,
    masks: Option<Arc<GuideMasks>>,
}

impl Prepare for Pass {
    fn prepare(words: &[u32], ctx: &Ctx<'_>) -> Pass {
        let params = VarianceParams::from_words(words);
        let chart = Chart {
            step: 1,
            reach: [0.0, params.reach],
        };
        Pass {
            params,
            // Read slot 1 is the position map.
            masks: ctx.guide_masks(1, chart),
        }
    }
}

impl TexelPass for Pass {
    #[inline]
    fn texel(&self, ctx: &Ctx<'_>, at: Texel) -> [f32; 4] {
        variance_texel(ctx.maps(), self.params, self.masks.as_deref(), at)
    }
}

/// The pairs directions of the variance estimate, in order.
pub(crate) const VARIANCE_DIRECTIONS: [[i64; 2]; 4] = [[1, 0], [0, 1], [1, 1], [1, -1]];

/// The noise variance of the luminance at one texel (see the module docs).
pub(crate) fn variance_texel(
    maps: [View<'_>; 3],
    params: VarianceParams,
    masks: Option<&GuideMasks>,
    at: Texel,
) -> [f32; 4] {
    if maps[0].fetch(at)[3] <= 0.5 {
        return [0.0; 4];
    }
    let Some(guide) = Guide::new(maps, [0.0, params.reach], at) else {
        return [0.0, 0.0, 0.0, 1.0];
    };
    let guide = guide.with_masks(masks, at);
    // The 5×5 window, row by row: the luminance of each tap on the surface.
    let mut window = [None; 25];
    for (k, w) in window.iter_mut().enumerate() {
        let o = [k as i64 % 5 - 2, k as i64 / 5 - 2];
        *w = match guide.tap_k(k, o) {
            Some((t, cos)) if cos >= BLUR_NORMAL_COS => {
                Some(luminance(xyz(t)) * params.luminance_scale)
            }
            _ => None,
        };
    }
    // With the centre, for the denoiser (a lone outlier raises its own estimate, so it is
    // smoothed); without it, for refinement (whose decision must not depend on the centre's
    // own noise).
    let [with_centre, without_centre] = window_variances(&window, params.min_pairs);
    window[12] = None;
    // The window's mean luminance without the centre: what refinement compares the noise with.
    let (mut sum, mut n) = (0.0f32, 0u32);
    for l in window.iter().flatten() {
        sum += l;
        n += 1;
    }
    let mean = if n > 0 { guard(sum / n as f32) } else { 0.0 };
    [with_centre, mean, without_centre, 1.0]
}

/// The variance estimates of a 5×5 window of luminances (`None`: not on the surface), with
/// and without its centre: per estimate the smallest over [`VARIANCE_DIRECTIONS`] with enough
/// pairs, else 0 (see the module docs). One pass over the pairs; each estimate sums its pairs
/// in the same order as a pass of its own would.
pub(crate) fn window_variances(window: &[Option<f32>; 25], min_pairs: u32) -> [f32; 2] {
    let mut best: [Option<f32>; 2] = [None; 2];
    for d in VARIANCE_DIRECTIONS {
        // [with the centre, without it].
        let (mut sum, mut n) = ([0.0f32; 2], [0u32; 2]);
        for k in 0..25i64 {
            let (i, j) = (k % 5 + d[0], k / 5 + d[1]);
            if !(0..5).contains(&i) || !(0..5).contains(&j) {
                continue;
            }
            let b = j * 5 + i;
            if let (Some(va), Some(vb)) = (window[k as usize], window[b as usize]) {
                let diff = vb - va;
                let d2 = diff * diff;
                sum[0] += d2;
                n[0] += 1;
                if k != 12 && b != 12 {
                    sum[1] += d2;
                    n[1] += 1;
                }
            }
        }
        for e in 0..2 {
            if n[e] >= min_pairs && n[e] > 0 {
                let v = sum[e] / (2 * n[e]) as f32;
                if best[e].is_none_or(|b| v < b) {
                    best[e] = Some(v);
                }
            }
        }
    }
    best.map(|b| guard(b.unwrap_or(0.0)))
}
