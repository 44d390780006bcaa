//! The stateless random-number hash of the gather passes.
//!
//! Every random number of a bake is a pure function of `(texel, sample, pass, seed)`: no state
//! is carried between texels, rays or passes, so any backend (Rust, GLSL ES 3.00, WGSL) computes
//! the same numbers bit for bit, in any order, on any tile split.
//!
//! # Specification (reproduce exactly)
//! All arithmetic is on unsigned 32-bit integers with wrap-around (`uint` in GLSL ES 3.00 and
//! `u32` in WGSL both wrap on overflow; shifts are logical).
//!
//! ```text
//! pcg(v):                               // PCG-RXS-M-XS 32 as a hash (Jarzynski & Olano 2020)
//!     s = v * 747796405u + 2891336453u
//!     w = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u
//!     return (w >> 22u) ^ w
//!
//! hash(texel, sample, pass, seed) = pcg(texel + pcg(sample + pcg(pass + pcg(seed))))
//!
//! texel  = (layer * layer_height + y) * layer_width + x   // the texel's index in its array
//! sample = ray index within the texel, 0 .. rays-1
//! pass   = the gather's bounce number, 1 .. bounces
//! seed   = Settings::seed
//!
//! u0 = float(h >> 8u) * 2^-24          // h = hash(...): first uniform in [0, 1)
//! u1 = float(pcg(h) >> 8u) * 2^-24     // second uniform in [0, 1)
//! ```
//!
//! `h >> 8` has 24 significant bits, so its conversion to `float` is exact, and so is the
//! multiplication by 2^-24: the uniforms are bit-identical on every IEEE-754 binary32 target.
//! (What is done with them afterwards — `sqrt`, `cos`, `sin` — is only as exact as each
//! platform's functions.)

/// The PCG-RXS-M-XS 32-bit permutation used as a hash (see the module docs).
#[inline]
pub const fn pcg(v: u32) -> u32 {
    let s = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let w = ((s >> ((s >> 28) + 4)) ^ s).wrapping_mul(277_803_737);
    (w >> 22) ^ w
}

/// The hash of one random draw: `pcg(texel + pcg(sample + pcg(pass + pcg(seed))))`.
#[inline]
pub const fn hash(texel: u32, sample: u32, pass: u32, seed: u32) -> u32 {
    pcg(texel.wrapping_add(pcg(sample.wrapping_add(pcg(pass.wrapping_add(pcg(seed)))))))
}

/// The index of texel `(x, y)` of `layer` in a texture array of `layer_size` texels per layer:
/// `(layer * height + y) * width + x`, wrapping.
#[inline]
pub const fn texel_index(layer_size: [u32; 2], layer: u32, x: u32, y: u32) -> u32 {
    layer
        .wrapping_mul(layer_size[1])
        .wrapping_add(y)
        .wrapping_mul(layer_size[0])
        .wrapping_add(x)
}

/// A uniform number in `[0, 1)` from the top 24 bits of `h`: `(h >> 8) * 2^-24` (exact).
#[inline]
pub fn unit_f32(h: u32) -> f32 {
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// The two uniforms `(u0, u1)` of one draw (see the module docs).
#[inline]
pub fn uniform2(texel: u32, sample: u32, pass: u32, seed: u32) -> [f32; 2] {
    let h = hash(texel, sample, pass, seed);
    [unit_f32(h), unit_f32(pcg(h))]
}

#[cfg(test)]
mod tests {
    use super::*;

    // Reference values computed independently (Python, arbitrary-precision integers mod 2^32).
    #[test]
    fn pcg_known_values() {
        assert_eq!(pcg(0), 0x07bb_2fe2);
        assert_eq!(pcg(1), 0xa8be_ea3c);
        assert_eq!(pcg(2), 0x7a7e_cc88);
        assert_eq!(pcg(u32::MAX), 0xe62a_4902);
        assert_eq!(pcg(123_456_789), 0xfea7_91ca);
    }

    #[test]
    fn hash_known_values() {
        assert_eq!(hash(0, 0, 0, 0), 0x8d32_4821);
        assert_eq!(hash(1, 2, 3, 4), 0xade9_6895);
        assert_eq!(hash(123_456, 7, 1, 42), 0x3b13_06c1);
        assert_eq!(hash(u32::MAX, u32::MAX, u32::MAX, u32::MAX), 0x122e_9e70);
        let [u0, u1] = uniform2(1, 2, 3, 4);
        assert_eq!(u0, 0x00ad_e968 as f32 / 16_777_216.0);
        assert_eq!(u1, 0x007a_601a as f32 / 16_777_216.0);
        assert!((u0 - 0.679_342_7).abs() < 1e-7 && (u1 - 0.478_028_9).abs() < 1e-7);
    }

    #[test]
    fn unit_range_and_exactness() {
        assert_eq!(unit_f32(0), 0.0);
        assert_eq!(unit_f32(0xff), 0.0);
        assert_eq!(unit_f32(u32::MAX), 1.0 - 1.0 / 16_777_216.0);
        assert!(unit_f32(u32::MAX) < 1.0);
        assert_eq!(unit_f32(0x8000_0000), 0.5);
    }

    #[test]
    fn texel_index_layout() {
        assert_eq!(texel_index([4, 3], 0, 0, 0), 0);
        assert_eq!(texel_index([4, 3], 0, 3, 0), 3);
        assert_eq!(texel_index([4, 3], 0, 0, 1), 4);
        assert_eq!(texel_index([4, 3], 1, 0, 0), 12);
        assert_eq!(texel_index([4, 3], 2, 1, 2), 2 * 12 + 2 * 4 + 1);
    }

    #[test]
    fn uniforms_are_roughly_uniform_and_inputs_decorrelated() {
        // Mean of 64k draws near 1/2; neighbouring texels, samples, passes and seeds differ.
        let mut sum = [0.0f64; 2];
        let n = 65_536u32;
        for t in 0..n {
            let u = uniform2(t, 0, 1, 7);
            sum[0] += f64::from(u[0]);
            sum[1] += f64::from(u[1]);
        }
        for s in sum {
            assert!(
                (s / f64::from(n) - 0.5).abs() < 0.01,
                "mean {}",
                s / f64::from(n)
            );
        }
        let base = hash(10, 10, 1, 1);
        assert_ne!(base, hash(11, 10, 1, 1));
        assert_ne!(base, hash(10, 11, 1, 1));
        assert_ne!(base, hash(10, 10, 2, 1));
        assert_ne!(base, hash(10, 10, 1, 2));
    }
}
