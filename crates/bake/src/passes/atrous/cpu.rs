//! The CPU reference of pass `atrous` (the semantics the shaders mirror).

use std::sync::Arc;

use crate::contract::{B3, ParamBlock};
use crate::cpu::kernel::*;
use crate::cpu::lanes;

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
            |m, t| atrous_texel(maps, params, m, t),
            |m, t, out| atrous_block(maps, params, m, t, out),
        );
    }
}

/// [`atrous_texel`] at the [`LANES`](crate::cpu::lanes::LANES) texels of `out` from `at` along
/// its row: with AVX2 where the CPU has it, the texels whose chart tests `masks` holds
/// filtered together, one to a vector lane ([`crate::cpu::lanes`]); otherwise texel by
/// texel. Returns how many texels were filtered in vector lanes.
pub(crate) fn atrous_block(
    maps: [View<'_>; 4],
    params: AtrousParams,
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
    lanes::one_by_one(at, out, |t| atrous_texel(maps, params, Some(masks), t));
    0
}

/// Eight texels of a row filtered together: every texel's taps in [`atrous_texel`]'s order
/// with its operations (IEEE single precision, no fused multiply-adds, [`exp_f32`] lane by
/// lane), a tap that does not count adding zero and a pair that counts in no lane skipped — so
/// each texel's result is [`atrous_texel`]'s bit for bit (test
/// `atrous_blocks_equal_the_texel_by_texel_filter`). With the variance pass's blocks, the
/// denoiser of a default CPU bake of `chairs_05` took 293 ms against 501 ms texel by texel
/// (medians of 5 alternated runs). The linear filter and the edge-stopping one are compiled
/// apart, and a pair's two normal weights squared side by side: the à-trous iterations of
/// the `default` bake 252 → 161 ms, the bias correction's 185 → 113 ms (three runs each).
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use super::*;
    use crate::cpu::lanes::{Centres, LANES, exp8, floats, luminance8, vector};

    /// [`atrous_block`] with AVX2; `None`, with nothing written, when the block's centres
    /// cannot go in lanes (then the caller takes them one by one).
    #[target_feature(enable = "avx2")]
    pub(super) fn block(
        maps: [View<'_>; 4],
        params: AtrousParams,
        masks: &GuideMasks,
        at: Texel,
        out: &mut [f32],
    ) -> Option<usize> {
        // The linear filter (the bias correction's) and the edge-stopping one compiled apart,
        // so that neither carries the other's branches through its taps.
        if params.linear != 0 {
            filter::<true>(maps, params, masks, at, out)
        } else {
            filter::<false>(maps, params, masks, at, out)
        }
    }

    /// [`block`] for `LINEAR` equal to `params.linear != 0`.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn filter<const LINEAR: bool>(
        maps: [View<'_>; 4],
        params: AtrousParams,
        masks: &GuideMasks,
        at: Texel,
        out: &mut [f32],
    ) -> Option<usize> {
        let [src, variance, pos, nrm] = maps;
        let centres = Centres::new([src, pos, nrm], masks, at).filter(|_| out.len() == 4 * LANES)?;
        // The lanes filtered here: not those left to the texel's reference, nor a centre that
        // keeps its value (in a narrow gap), which the reference returns as it is.
        let filtered: [bool; LANES] = std::array::from_fn(|l| {
            !centres.alone[l] && !keeps(params, pos.at_offset(centres.base + 4 * l)[3])
        });
        // Per lane the centre's value, its variance scales and whether it is quiet
        // (`quiet`: all ones).
        let mut lanes = [[0.0f32; LANES]; 6];
        for l in (0..LANES).filter(|&l| filtered[l]) {
            let c = src.at_offset(centres.base + 4 * l);
            let t = Texel {
                x: at.x + l as u32,
                ..at
            };
            // The linear filter does not read the variance map.
            let v = if LINEAR { [0.0; 4] } else { variance.fetch(t) };
            let own = centre_scale(params, pos.at_offset(centres.base + 4 * l)[3]);
            let scales = [own * v[0], params.wide_variance_scale * v[0]];
            let flag = if !LINEAR && quiet(params, v) {
                f32::from_bits(!0)
            } else {
                0.0
            };
            for (v, lane) in [c[0], c[1], c[2], scales[0], scales[1], flag]
                .into_iter()
                .zip(&mut lanes)
            {
                lane[l] = v;
            }
        }
        let [c0, c1, c2, scale, wide, quiet] = lanes.each_ref().map(|a| vector(a));
        let any_quiet = _mm256_movemask_ps(quiet) != 0;
        let set = _mm256_set1_ps;
        let zero = _mm256_setzero_ps();
        let step = i64::from(params.step);
        // Tap `(a, b)` in every lane, on the centre's surface facing its side.
        let tap = |a: usize, b: usize| {
            let o = [(a as i64 - 2) * step, (b as i64 - 2) * step];
            let (t, cos, on) = centres.tap([src.data, nrm.data], src.size[0], 5 * b + a, o);
            (t, cos, _mm256_and_ps(on, _mm256_cmp_ps::<_CMP_GT_OQ>(cos, zero)))
        };
        // The normal weights `cos^(2^normal_log2)` of two taps, squared side by side.
        let normal_weights = |a: __m256, b: __m256| {
            let (mut a, mut b) = (a, b);
            for _ in 0..params.normal_log2 {
                a = _mm256_mul_ps(a, a);
                b = _mm256_mul_ps(b, b);
            }
            (a, b)
        };
        // [with `scale`, with `wide`] × (rgb, weight); the wide sums only when a lane is quiet.
        let mut sums = [[zero; 4]; 2];
        let sets = 1 + usize::from(!LINEAR && any_quiet);
        // Tap value `t` with normal weight `wn` and spline weight `b3` into the sums of the
        // lanes where its pair counts (`pair`). A macro, not a closure: the edge-stopping
        // filter's closure stayed a call (2 % of a bake with an opening).
        macro_rules! add_tap {
            ($t:expr, $wn:expr, $b3:expr, $pair:expr) => {{
                let (t, wn, b3, pair): ([__m256; 4], __m256, __m256, __m256) =
                    ($t, $wn, $b3, $pair);
                let d = [
                    _mm256_sub_ps(t[0], c0),
                    _mm256_sub_ps(t[1], c1),
                    _mm256_sub_ps(t[2], c2),
                ];
                let (minus_dl2, dl_zero) = if LINEAR {
                    (zero, zero)
                } else {
                    let dl = _mm256_mul_ps(luminance8(d), set(params.luminance_scale));
                    (
                        _mm256_xor_ps(_mm256_mul_ps(dl, dl), set(-0.0)),
                        _mm256_cmp_ps::<_CMP_EQ_OQ>(dl, zero),
                    )
                };
                for (s, scale) in sums.iter_mut().zip([scale, wide]).take(sets) {
                    let w = if LINEAR {
                        // No luminance term (a factor 1 in the texel's reference).
                        _mm256_mul_ps(b3, wn)
                    } else {
                        // −(dl²) / scale, its exponential where scale > 0, and 1 where dl = 0.
                        let x = _mm256_div_ps(minus_dl2, scale);
                        let wl = _mm256_and_ps(exp8(x), _mm256_cmp_ps::<_CMP_GT_OQ>(scale, zero));
                        let wl = _mm256_blendv_ps(wl, set(1.0), dl_zero);
                        _mm256_mul_ps(_mm256_mul_ps(b3, wn), wl)
                    };
                    let counts = _mm256_and_ps(pair, _mm256_cmp_ps::<_CMP_GT_OQ>(w, zero));
                    let add = |s: __m256, v: __m256| _mm256_add_ps(s, _mm256_and_ps(counts, v));
                    s[0] = add(s[0], _mm256_mul_ps(w, d[0]));
                    s[1] = add(s[1], _mm256_mul_ps(w, d[1]));
                    s[2] = add(s[2], _mm256_mul_ps(w, d[2]));
                    s[3] = add(s[3], w);
                }
            }};
        }
        // Pairs that counted, per lane (the wide term needs all twelve).
        let mut pairs = zero;
        for k in 0..13usize {
            let (i, j) = (k % 5, k / 5);
            let b3 = set(B3[i] * B3[j]);
            let near = tap(i, j);
            if k == 12 {
                // The centre, alone.
                let (wn, _) = normal_weights(near.1, near.1);
                add_tap!(near.0, wn, b3, near.2);
                continue;
            }
            // A pair no lane counts adds nothing (as in the texel's reference): its far tap
            // is not even read.
            if _mm256_movemask_ps(near.2) == 0 {
                continue;
            }
            let far = tap(4 - i, 4 - j);
            let pair = _mm256_and_ps(near.2, far.2);
            if _mm256_movemask_ps(pair) == 0 {
                continue;
            }
            if !LINEAR {
                pairs = _mm256_add_ps(pairs, _mm256_and_ps(pair, set(1.0)));
            }
            let (wn_near, wn_far) = normal_weights(near.1, far.1);
            add_tap!(near.0, wn_near, b3, pair);
            add_tap!(far.0, wn_far, b3, pair);
        }
        // Per lane the wide sums where it is quiet and every pair counted.
        let take_wide = _mm256_and_ps(quiet, _mm256_cmp_ps::<_CMP_EQ_OQ>(pairs, set(12.0)));
        let sums =
            [0, 1, 2, 3].map(|q| floats(_mm256_blendv_ps(sums[0][q], sums[1][q], take_wide)));
        for (l, o) in out.chunks_exact_mut(4).enumerate() {
            let t = Texel {
                x: at.x + l as u32,
                ..at
            };
            if !filtered[l] {
                o.copy_from_slice(&atrous_texel(maps, params, Some(masks), t));
                continue;
            }
            let c = [lanes[0][l], lanes[1][l], lanes[2][l]];
            let wsum = sums[3][l];
            let r = if wsum > 0.0 {
                [0, 1, 2].map(|q| guard(c[q] + sums[q][l] / wsum))
            } else {
                c.map(guard)
            };
            o.copy_from_slice(&[r[0], r[1], r[2], 1.0]);
        }
        Some(filtered.iter().filter(|&&f| f).count())
    }
}

/// The luminance term's scale at a centre whose position's w is `w`: in a narrow gap
/// ([`crate::validity::NARROW_GAP`]) [`AtrousParams::narrow_variance_scale`], else
/// [`AtrousParams::variance_scale`].
#[inline]
fn centre_scale(params: AtrousParams, w: f32) -> f32 {
    if w >= crate::validity::NARROW_GAP {
        params.narrow_variance_scale
    } else {
        params.variance_scale
    }
}

/// Whether a centre whose position's w is `w` keeps its value in this iteration: in a narrow
/// gap ([`crate::validity::NARROW_GAP`]) where the taps reach beyond the gap
/// ([`AtrousParams::narrow_keep`]).
#[inline]
fn keeps(params: AtrousParams, w: f32) -> bool {
    params.narrow_keep != 0 && w >= crate::validity::NARROW_GAP
}

/// Whether the centre's noise is low enough for the wide luminance term (`v`: its variance
/// estimate, `[variance, window mean luminance, …]`; `program::atrous_steps`, "Wide charts
/// with little noise"): the variance under `wide_max_relative_variance` times the squared
/// mean. Never where the bound or the mean is 0.
#[inline]
fn quiet(params: AtrousParams, v: [f32; 4]) -> bool {
    let bound = params.wide_max_relative_variance;
    bound > 0.0 && v[0] < bound * (v[1] * v[1])
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
    let linear = params.linear != 0;
    let kept = [guard(c[0]), guard(c[1]), guard(c[2]), 1.0];
    if keeps(params, pos.fetch(at)[3]) {
        return kept;
    }
    let reach = [params.reach_min, params.reach];
    let Some(guide) = Guide::new([src, pos, nrm], reach, at) else {
        return kept;
    };
    let guide = guide.with_masks(masks, at);
    // The linear filter does not read the variance map.
    let v = if linear { [0.0; 4] } else { variance.fetch(at) };
    let scale = centre_scale(params, pos.fetch(at)[3]) * v[0];
    // Inside a wide chart with little noise the wide term (`program::atrous_steps`, "Wide
    // charts with little noise"): both sums are taken, the wide one only where the noise is
    // low, and which one counts is known once every pair has been tested.
    let quiet = !linear && quiet(params, v);
    let scales = [scale, params.wide_variance_scale * v[0]];
    let step = i64::from(params.step);
    let mut sums = [[0.0f32; 4]; 2];
    let mut pairs = 0u32;
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
        pairs += u32::from(k != 12);
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
            for (sum, scale) in sums.iter_mut().zip(scales).take(1 + usize::from(quiet)) {
                let wl = if linear || dl == 0.0 {
                    1.0
                } else if scale > 0.0 {
                    exp_f32(-(dl * dl) / scale)
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
                sum[3] += w;
            }
        }
    }
    let [sum, wide] = sums;
    let [s0, s1, s2, wsum] = if quiet && pairs == 12 { wide } else { sum };
    let sum = [s0, s1, s2];
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
