//! Eight texels of a row at once, one to a lane of an AVX2 vector: what the denoiser's
//! passes share when they filter a row in blocks (`passes/atrous/cpu.rs`,
//! `passes/variance/cpu.rs`). Each lane computes what the texel-by-texel reference computes,
//! with the same IEEE operations in the same order (Rust does not fuse multiply-adds), so the
//! blocks equal the reference bit for bit; a tap that does not count adds zero.

use crate::cpu::kernel::{GuideMasks, Texel};

/// Texels of a row filtered together, one to a vector lane.
pub(crate) const LANES: usize = 8;

/// The texels of `out` (four floats each) from `at` along its row, one by one with `texel`.
pub(crate) fn one_by_one(at: Texel, out: &mut [f32], texel: impl Fn(Texel) -> [f32; 4]) {
    for (x, t) in (at.x..).zip(out.chunks_exact_mut(4)) {
        t.copy_from_slice(&texel(Texel { x, ..at }));
    }
}

/// A row of a pass that filters in blocks: `block` at each whole block of [`LANES`] texels
/// when the pass has chart tests (`masks`), `texel` (the reference) at the others, from `at`
/// along the row.
pub(crate) fn row(
    masks: Option<&GuideMasks>,
    at: Texel,
    texels: &mut [f32],
    texel: impl Fn(Option<&GuideMasks>, Texel) -> [f32; 4],
    block: impl Fn(&GuideMasks, Texel, &mut [f32]) -> usize,
) {
    let mut blocks = texels.chunks_exact_mut(4 * LANES);
    let mut x = at.x;
    for out in &mut blocks {
        let at = Texel { x, ..at };
        match masks {
            Some(m) => {
                block(m, at, out);
            }
            None => one_by_one(at, out, |t| texel(None, t)),
        }
        x += LANES as u32;
    }
    one_by_one(Texel { x, ..at }, blocks.into_remainder(), |t| {
        texel(masks, t)
    });
}

#[cfg(target_arch = "x86_64")]
pub(crate) use avx2::*;

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use crate::cpu::kernel::*;
    use crate::cpu::texels::Texels;

    use super::LANES;

    /// Eight lanes of [`exp_f32`], bit for bit.
    #[target_feature(enable = "avx2")]
    pub(crate) fn exp8(x: __m256) -> __m256 {
        let set = _mm256_set1_ps;
        let round = set(ROUND);
        let n = _mm256_sub_ps(
            _mm256_add_ps(_mm256_mul_ps(x, set(std::f32::consts::LOG2_E)), round),
            round,
        );
        let r = _mm256_sub_ps(
            _mm256_sub_ps(x, _mm256_mul_ps(n, set(EXP_LN2[0]))),
            _mm256_mul_ps(n, set(EXP_LN2[1])),
        );
        let mut p = set(EXP_POLY[0]);
        for &c in &EXP_POLY[1..] {
            p = _mm256_add_ps(_mm256_mul_ps(p, r), set(c));
        }
        let e = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(p, r), r), r),
            set(1.0),
        );
        let scale = _mm256_slli_epi32::<23>(_mm256_add_epi32(
            _mm256_cvttps_epi32(n),
            _mm256_set1_epi32(127),
        ));
        let v = _mm256_mul_ps(e, _mm256_castsi256_ps(scale));
        let v = _mm256_blendv_ps(
            v,
            set(f32::INFINITY),
            _mm256_cmp_ps::<_CMP_GT_OQ>(x, set(EXP_HIGH)),
        );
        // Below the domain 0, NaN itself.
        let nan = _mm256_and_ps(_mm256_cmp_ps::<_CMP_UNORD_Q>(x, x), x);
        _mm256_blendv_ps(v, nan, _mm256_cmp_ps::<_CMP_NGE_UQ>(x, set(EXP_LOW)))
    }

    /// The centres of a block: per lane its unit normal, object and chart tests (the rest a
    /// pass reads itself), and which lanes the block leaves to the texel-by-texel reference
    /// (not valid in `src`, a normal that cannot be normalised, or no chart tests).
    pub(crate) struct Centres {
        /// The block's first texel's offset in the maps.
        pub(crate) base: usize,
        /// The unit normals, a vector per component.
        pub(crate) n: [__m256; 3],
        /// The normals' object ids.
        pub(crate) object: __m256,
        /// The chart tests' bits ([`GuideMasks`]).
        pub(crate) mask: __m256i,
        /// Lanes left to the reference.
        pub(crate) alone: [bool; LANES],
    }

    impl Centres {
        /// The centres of the [`LANES`] texels from `at` along its row, when `src`, `pos` and
        /// `nrm` have one shape, the block lies in them and its chart tests lie side by side
        /// ([`GuideMasks::eight`]): per lane the texel reference's tests (valid in `src`, a
        /// normal of positive finite length, chart tests known) and its normalisation
        /// ([`normalize`]: `n / ‖n‖`, `‖n‖ = √((x² + y²) + z²)`), eight lanes at once; a lane
        /// left alone holds zeros.
        #[target_feature(enable = "avx2")]
        pub(crate) fn new(
            [src, pos, nrm]: [View<'_>; 3],
            masks: &GuideMasks,
            at: Texel,
        ) -> Option<Centres> {
            let base = (src.same_shape(&pos) && src.same_shape(&nrm))
                .then(|| src.index(at.layer, at.x, at.y))
                .flatten()
                .filter(|b| b + 4 * LANES <= src.data.len())?;
            let bits = masks.eight(at)?;
            let Texels(c) = Texels::load(src.data, base as i64);
            let Texels(v) = Texels::load(nrm.data, base as i64);
            let set = _mm256_set1_ps;
            let l = _mm256_sqrt_ps(_mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(v[0], v[0]), _mm256_mul_ps(v[1], v[1])),
                _mm256_mul_ps(v[2], v[2]),
            ));
            // SAFETY: eight integers from an array of eight.
            let m = unsafe { _mm256_loadu_si256(bits.as_ptr().cast()) };
            let untested = _mm256_castsi256_ps(_mm256_cmpeq_epi32(m, _mm256_setzero_si256()));
            let keep = _mm256_andnot_ps(
                untested,
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_GT_OQ>(c[3], set(0.5)),
                    _mm256_and_ps(
                        _mm256_cmp_ps::<_CMP_GT_OQ>(l, _mm256_setzero_ps()),
                        _mm256_cmp_ps::<_CMP_LT_OQ>(l, set(f32::INFINITY)),
                    ),
                ),
            );
            let lanes = _mm256_movemask_ps(keep);
            Some(Centres {
                base,
                n: [
                    _mm256_and_ps(keep, _mm256_div_ps(v[0], l)),
                    _mm256_and_ps(keep, _mm256_div_ps(v[1], l)),
                    _mm256_and_ps(keep, _mm256_div_ps(v[2], l)),
                ],
                object: _mm256_and_ps(keep, v[3]),
                mask: _mm256_and_si256(_mm256_castps_si256(keep), m),
                alone: std::array::from_fn(|l| lanes & (1 << l) == 0),
            })
        }

        /// Tap `k` of the 5 × 5 (rows outer) at `offset` texels in every lane: its value, `n̂·nₜ`
        /// (summed as [`dot`]), and whether it passes the chart test, is valid and is of the
        /// centre's object (`Guide::tap_k`).
        #[target_feature(enable = "avx2")]
        #[inline]
        pub(crate) fn tap(
            &self,
            [src, nrm]: [&[f32]; 2],
            width: u32,
            k: usize,
            offset: [i64; 2],
        ) -> ([__m256; 4], __m256, __m256) {
            let start = self.base as i64 + 4 * (offset[1] * i64::from(width) + offset[0]);
            let Texels(t) = Texels::load(src, start);
            let Texels(nt) = Texels::load(nrm, start);
            let [n0, n1, n2] = self.n;
            let cos = _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(n0, nt[0]), _mm256_mul_ps(n1, nt[1])),
                _mm256_mul_ps(n2, nt[2]),
            );
            let bit = _mm256_set1_epi32(1 << k);
            let charted =
                _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(self.mask, bit), bit));
            let on = _mm256_and_ps(
                _mm256_and_ps(
                    charted,
                    _mm256_cmp_ps::<_CMP_GT_OQ>(t[3], _mm256_set1_ps(0.5)),
                ),
                _mm256_cmp_ps::<_CMP_EQ_OQ>(nt[3], self.object),
            );
            (t, cos, on)
        }
    }

    /// Eight floats as a vector.
    #[target_feature(enable = "avx2")]
    pub(crate) fn vector(a: &[f32; LANES]) -> __m256 {
        // SAFETY: eight floats from an array of eight.
        unsafe { _mm256_loadu_ps(a.as_ptr()) }
    }

    /// A vector as eight floats.
    #[target_feature(enable = "avx2")]
    pub(crate) fn floats(v: __m256) -> [f32; LANES] {
        let mut a = [0.0f32; LANES];
        // SAFETY: eight floats into an array of eight.
        unsafe { _mm256_storeu_ps(a.as_mut_ptr(), v) };
        a
    }

    /// [`luminance`] of eight lanes, summed as it sums.
    #[target_feature(enable = "avx2")]
    pub(crate) fn luminance8(c: [__m256; 3]) -> __m256 {
        let set = _mm256_set1_ps;
        _mm256_add_ps(
            _mm256_add_ps(
                _mm256_mul_ps(set(0.2126), c[0]),
                _mm256_mul_ps(set(0.7152), c[1]),
            ),
            _mm256_mul_ps(set(0.0722), c[2]),
        )
    }
}
