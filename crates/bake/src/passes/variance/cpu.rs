//! The CPU reference of pass `variance` (the semantics the shaders mirror).

use std::sync::Arc;

use crate::contract::{BLUR_NORMAL_COS, ParamBlock};
use crate::cpu::kernel::*;
use crate::cpu::lanes;

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

impl CpuPass for Pass {
    type Scratch = ();

    fn row(&self, ctx: &Ctx<'_>, y: u32, texels: &mut [f32], _: &mut ()) {
        let (maps, params) = (ctx.maps(), self.params);
        let at = Texel {
            layer: ctx.tile.layer,
            x: ctx.tile.x0,
            y,
        };
        lanes::row(
            self.masks.as_deref(),
            at,
            texels,
            |m, t| variance_texel(maps, params, m, t),
            |m, t, out| variance_block(maps, params, m, t, out),
        );
    }
}

/// [`variance_texel`] at the [`LANES`](crate::cpu::lanes::LANES) texels of `out` from `at` along
/// its row: with AVX2 where the CPU has it, the texels whose chart tests `masks` holds
/// estimated together, one to a vector lane ([`crate::cpu::lanes`]); otherwise texel by
/// texel. Returns how many texels were estimated in vector lanes.
pub(crate) fn variance_block(
    maps: [View<'_>; 4],
    params: VarianceParams,
    masks: &GuideMasks,
    at: Texel,
    out: &mut [f32],
) -> usize {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2 (just checked).
        if let Some(vector) = unsafe { avx2::block(maps, params, masks, at, out) } {
            return vector;
        }
    }
    lanes::one_by_one(at, out, |t| variance_texel(maps, params, Some(masks), t));
    0
}

/// Eight texels of a row estimated together: each lane's window, pairs and sums in
/// [`variance_texel`]'s order with its operations, a pair or tap that does not count adding
/// zero — bit for bit its result (test `variance_blocks_equal_the_texel_by_texel_estimate`).
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use super::*;
    use crate::cpu::lanes::{Centres, LANES, floats, luminance8};

    /// [`variance_block`] with AVX2; `None`, with nothing written, when the block's centres
    /// cannot go in lanes (then the caller takes them one by one).
    #[target_feature(enable = "avx2")]
    pub(super) fn block(
        maps: [View<'_>; 4],
        params: VarianceParams,
        masks: &GuideMasks,
        at: Texel,
        out: &mut [f32],
    ) -> Option<usize> {
        let [src, pos, nrm, _] = maps;
        let centres =
            Centres::new([src, pos, nrm], masks, at).filter(|_| out.len() == 4 * LANES)?;
        let set = _mm256_set1_ps;
        let zero = _mm256_setzero_ps();
        // The 5×5 window, row by row: each tap's luminance and whether it is on the surface.
        let mut lum = [zero; 25];
        let mut on = [zero; 25];
        for k in 0..25 {
            let o = [k as i64 % 5 - 2, k as i64 / 5 - 2];
            let (t, cos, valid) = centres.tap([src.data, nrm.data], src.size[0], k, o);
            let facing = _mm256_cmp_ps::<_CMP_GE_OQ>(cos, set(BLUR_NORMAL_COS));
            on[k] = _mm256_and_ps(valid, facing);
            lum[k] = _mm256_mul_ps(luminance8([t[0], t[1], t[2]]), set(params.luminance_scale));
        }
        // `window_variances`: per estimate (with the centre, without it) the smallest over
        // the directions with enough pairs, else 0.
        let min_pairs = _mm256_set1_epi32(params.min_pairs as i32);
        let one = _mm256_set1_epi32(1);
        let mut best = [zero; 2];
        let mut found = [_mm256_setzero_si256(); 2];
        for d in VARIANCE_DIRECTIONS {
            let mut sum = [zero; 2];
            let mut n = [_mm256_setzero_si256(); 2];
            for k in 0..25i64 {
                let (i, j) = (k % 5 + d[0], k / 5 + d[1]);
                if !(0..5).contains(&i) || !(0..5).contains(&j) {
                    continue;
                }
                let (a, b) = (k as usize, (j * 5 + i) as usize);
                let pair = _mm256_and_ps(on[a], on[b]);
                let diff = _mm256_sub_ps(lum[b], lum[a]);
                let d2 = _mm256_and_ps(pair, _mm256_mul_ps(diff, diff));
                // A counted pair's mask is all ones: −1 as an integer.
                let count = _mm256_castps_si256(pair);
                sum[0] = _mm256_add_ps(sum[0], d2);
                n[0] = _mm256_sub_epi32(n[0], count);
                if a != 12 && b != 12 {
                    sum[1] = _mm256_add_ps(sum[1], d2);
                    n[1] = _mm256_sub_epi32(n[1], count);
                }
            }
            for e in 0..2 {
                let enough = _mm256_andnot_si256(
                    _mm256_cmpgt_epi32(min_pairs, n[e]),
                    _mm256_cmpgt_epi32(n[e], _mm256_setzero_si256()),
                );
                let v = _mm256_div_ps(sum[e], _mm256_cvtepi32_ps(_mm256_slli_epi32::<1>(n[e])));
                let lower = _mm256_or_si256(
                    _mm256_cmpeq_epi32(found[e], _mm256_setzero_si256()),
                    _mm256_castps_si256(_mm256_cmp_ps::<_CMP_LT_OQ>(v, best[e])),
                );
                let take = _mm256_and_si256(enough, lower);
                best[e] = _mm256_blendv_ps(best[e], v, _mm256_castsi256_ps(take));
                found[e] = _mm256_or_si256(found[e], _mm256_and_si256(take, one));
            }
        }
        // The window's mean luminance without the centre.
        let (mut sum, mut n) = (zero, _mm256_setzero_si256());
        for k in (0..25).filter(|&k| k != 12) {
            sum = _mm256_add_ps(sum, _mm256_and_ps(on[k], lum[k]));
            n = _mm256_sub_epi32(n, _mm256_castps_si256(on[k]));
        }
        let mean = _mm256_div_ps(sum, _mm256_cvtepi32_ps(n));
        let has_mean = _mm256_castsi256_ps(_mm256_cmpgt_epi32(n, _mm256_setzero_si256()));
        let mean = floats(_mm256_and_ps(has_mean, mean));
        let [with_centre, without_centre] = best.map(|b| floats(b));
        for (l, o) in out.chunks_exact_mut(4).enumerate() {
            let t = Texel {
                x: at.x + l as u32,
                ..at
            };
            if centres.alone[l] {
                o.copy_from_slice(&variance_texel(maps, params, Some(masks), t));
                continue;
            }
            let r = [
                guard(with_centre[l]),
                guard(mean[l]),
                guard(without_centre[l]),
                direct_luminance(maps, params, t),
            ];
            o.copy_from_slice(&r);
        }
        Some(centres.alone.iter().filter(|&&a| !a).count())
    }
}

/// The pairs directions of the variance estimate, in order.
pub(crate) const VARIANCE_DIRECTIONS: [[i64; 2]; 4] = [[1, 0], [0, 1], [1, 1], [1, -1]];

/// The noise variance of the luminance at one texel (see the module docs).
pub(crate) fn variance_texel(
    maps: [View<'_>; 4],
    params: VarianceParams,
    masks: Option<&GuideMasks>,
    at: Texel,
) -> [f32; 4] {
    if maps[0].fetch(at)[3] <= 0.5 {
        return [0.0; 4];
    }
    let direct = direct_luminance(maps, params, at);
    let [src, pos, nrm, _] = maps;
    let Some(guide) = Guide::new([src, pos, nrm], [0.0, params.reach], at) else {
        return [0.0, 0.0, 0.0, direct];
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
    // The window's mean luminance without the centre: what refinement and the denoiser's
    // wide term (`atrous`) compare the noise with.
    let (mut sum, mut n) = (0.0f32, 0u32);
    for l in window.iter().flatten() {
        sum += l;
        n += 1;
    }
    let mean = if n > 0 { guard(sum / n as f32) } else { 0.0 };
    [with_centre, mean, without_centre, direct]
}

/// The luminance of texel `at`'s direct light (slot `direct`) in the estimate's units: the
/// variance map's alpha, for refinement's decision ([`crate::passes::refine::refines`]).
#[inline]
fn direct_luminance(maps: [View<'_>; 4], params: VarianceParams, at: Texel) -> f32 {
    guard(luminance(xyz(maps[3].fetch(at))) * params.luminance_scale)
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
