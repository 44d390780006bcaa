//! Eight texels of a row loaded from a map of four floats per texel, a vector per channel:
//! what the denoiser's lanes (`cpu::lanes`) and the chart tests (`kernel::GuideMasks`) read
//! their taps with. x86_64 with AVX2 only.

use std::arch::x86_64::*;

/// Texels a load takes, one to a lane of an AVX2 vector (`cpu::lanes::LANES`).
const LANES: usize = 8;

/// Four channels of eight texels, a vector each.
pub(crate) struct Texels(pub(crate) [__m256; 4]);

impl Texels {
    /// The eight texels from float `start` of `data` (four floats each); texels outside
    /// `data` are 0.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) fn load(data: &[f32], start: i64) -> Texels {
        let inside = start >= 0
            && (start as usize)
                .checked_add(4 * LANES)
                .is_some_and(|e| e <= data.len());
        let mut rows = [_mm_setzero_ps(); LANES];
        for (l, r) in rows.iter_mut().enumerate() {
            let i = start + 4 * l as i64;
            *r = if inside {
                // SAFETY: floats `i .. i + 4` lie in `data` (`inside`).
                unsafe { _mm_loadu_ps(data.as_ptr().add(i as usize)) }
            } else {
                let t = usize::try_from(i)
                    .ok()
                    .and_then(|i| data.get(i..i.checked_add(4)?))
                    .unwrap_or(&[0.0; 4]);
                _mm_setr_ps(t[0], t[1], t[2], t[3])
            };
        }
        // Texels l and l + 4 in the two halves, then a 4 × 4 transpose in each half.
        let half = |a: __m128, b: __m128| _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(a), b);
        let [r0, r1, r2, r3] = [0, 1, 2, 3].map(|l| half(rows[l], rows[l + 4]));
        let (a, b) = (_mm256_unpacklo_ps(r0, r1), _mm256_unpacklo_ps(r2, r3));
        let (c, d) = (_mm256_unpackhi_ps(r0, r1), _mm256_unpackhi_ps(r2, r3));
        Texels([
            _mm256_shuffle_ps::<0x44>(a, b),
            _mm256_shuffle_ps::<0xEE>(a, b),
            _mm256_shuffle_ps::<0x44>(c, d),
            _mm256_shuffle_ps::<0xEE>(c, d),
        ])
    }
}
