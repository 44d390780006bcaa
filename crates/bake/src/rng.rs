//! The stateless random numbers of the gather passes.
//!
//! Every random number of a bake is a pure function of `(texel, sample, pass, seed)`: no state
//! is carried between texels, rays or passes, so any backend (Rust, GLSL ES 3.00, WGSL) computes
//! the same numbers bit for bit, in any order, on any tile split. Two [`Sampler`]s draw the
//! gather directions' uniforms `(u0, u1)`: the paper's independent hash ([`uniform2`], the
//! default) and a scrambled Sobol (0,2)-sequence ([`sobol2`]) shared by blocks of 2 × 2
//! neighbouring texels, each texel a stratified run of it ([`Stream`]).
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
//! unit(h) = float(h >> 8u) * 2^-24      // the top 24 bits as a uniform in [0, 1)
//! ```
//!
//! **Hash sampler** ([`Sampler::Hash`], the paper's): with `h = hash(texel, sample, pass, seed)`,
//! `u0 = unit(h)`, `u1 = unit(pcg(h))`.
//!
//! **Sobol sampler** ([`Sampler::Sobol`]): the first two dimensions of the Sobol sequence — a
//! (0,2)-sequence in base 2 — shuffled and Owen-scrambled per texel as in Burley 2020,
//! "Practical Hash-based Owen Scrambling" (JCGT 9(4)), with that paper's Laine–Karras-style
//! hash:
//!
//! ```text
//! reverse(x)  = x with bit b moved to bit 31 - b, for every b
//! lk(x, k):                             // Burley 2020's laine_karras_permutation
//!     x = x + k
//!     x = x ^ (x * 0x6c50b47cu)
//!     x = x ^ (x * 0xb82f1e52u)
//!     x = x ^ (x * 0xc7afe638u)
//!     x = x ^ (x * 0x8d22f6e6u)
//!     return x
//! owen(x, k)  = reverse(lk(reverse(x), k))     // nested uniform (Owen) scramble of x's bits
//! pascal(x):                            // bit r of the result: XOR of the bits b of x whose
//!     x = x ^ ((x >> 1u) & 0x55555555u) // index b has every bit of r set (Pascal's triangle
//!     x = x ^ ((x >> 2u) & 0x33333333u) // mod 2, by Lucas' theorem)
//!     x = x ^ ((x >> 4u) & 0x0f0f0f0fu)
//!     x = x ^ ((x >> 8u) & 0x00ff00ffu)
//!     x = x ^ ((x >> 16u) & 0x0000ffffu)
//!     return x
//!
//! key = hash(texel, 0, pass, seed)      // one key per texel and pass
//! i   = owen(sample, key)               // the shuffled index
//! u0  = unit(reverse(lk(i, pcg(key))))             // = unit(owen(reverse(i), pcg(key)))
//! u1  = unit(reverse(lk(pascal(i), pcg(pcg(key)))))  // = unit(owen(sobol1(i), pcg(pcg(key))))
//! ```
//!
//! Sobol's dimension 0 of index `i` is `reverse(i)` (van der Corput) and dimension 1 is
//! `sobol1(i) = reverse(pascal(i))`, the XOR of the direction numbers `V[b]` over the set bits
//! `b` of `i` with `V[0] = 2^31`, `V[b] = V[b-1] ^ (V[b-1] >> 1)`: [`pascal`] computes that
//! matrix product in five steps instead of a 32-step loop over a table (checked against the
//! direction numbers in the tests). `owen(reverse(x), k) = reverse(lk(x, k))`, hence the two
//! final lines.
//!
//! `lk` only carries bits upward (`x * even` and `+ k` change bit `b` from bits below `b`), so
//! `owen` flips each bit of `x` by a function of the bits above it: a base-2 Owen scramble. For
//! `N = 2^m` rays the shuffled indices `owen(0 .. N-1, key)` fill one aligned block of `N`
//! consecutive Sobol indices, whose points form a (0,m,2)-net, and the scramble keeps it one:
//! every elementary interval `[a/2^j, (a+1)/2^j) × [b/2^(m-j), (b+1)/2^(m-j))` holds exactly
//! one of the texel's points (for `j`, `m - j` ≤ 24, the bits `unit` keeps). Each point is still
//! uniform on `[0, 1)²`, so the estimate stays unbiased. Other ray counts take a prefix of
//! such a block: still stratified, less evenly.
//!
//! **Blocks** ([`Stream`]): with the Sobol sampler a gather's texels do not each start their
//! own sequence. The texels on the gather's grid (every `stride`-th column and row; every
//! texel at stride 1) are grouped in blocks of `B × B` grid texels (`B` = [`SOBOL_BLOCK`] = 2)
//! that share the sequence of the block's first texel, each texel an aligned run of it:
//!
//! ```text
//! s   = max(stride, 1)                  // a texel is on the grid when s divides x and y
//! gx  = x / s, gy = y / s
//! key = texel_index(layer, (gx - gx mod B) * s, (gy - gy mod B) * s)   // the block's first texel
//! r   = gx mod B + B * (gy mod B)       // the texel's rank in its block
//! P   = rays rounded up to a power of two
//! ray k of the texel = sobol2(key, r * P + k, pass, seed)
//! refinement, ray k of `more` after `first_rays`:
//!       sobol2(key, B*B * max(P', Q) + r * Q + k, pass, seed)  // P' = first_rays, Q = more,
//!                                                                // rounded up
//! ```
//!
//! A texel's `P` indices are an aligned block of `P` consecutive indices, so its own points
//! are a (0,m,2)-net as before, and each of its draws is uniform: its estimate is as unbiased
//! as before. The block's `B² · P` indices are one aligned block too, so the four texels'
//! points together form a (0,m+2,2)-net: neighbouring texels' directions are stratified
//! against one another, and any average over neighbouring texels — the denoiser's — has less
//! variance than that of four independent nets. Measured (default preset, four seeds, against
//! the Radiance references): the noise at the calculation points of `chairs_05` fell 1.10 →
//! 0.87 % on the walls, 0.50 → 0.38 % on the floor, 1.43 → 1.22 % on the furniture, at the
//! same cost (docs/performance.md). Texels off the grid (a coarse gather's orphans) and every
//! texel of the hash sampler draw their own sequence from index 0 (the hash's refinement
//! continues it at `first_rays`).
//!
//! `h >> 8` has 24 significant bits, so its conversion to `float` is exact, and so is the
//! multiplication by 2^-24: the uniforms are bit-identical on every IEEE-754 binary32 target.
//! (What is done with them afterwards — `sqrt`, `cos`, `sin` — is only as exact as each
//! platform's functions.) The shaders compare `GatherParams::sampler` with the ids
//! [`Sampler::id`] generated into their prefix ([`crate::shader`]).

use std::ops::Range;

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

/// `unit(h)`: a uniform number in `[0, 1)` from the top 24 bits of `h`: `(h >> 8) * 2^-24`
/// (exact).
#[inline]
pub fn unit_f32(h: u32) -> f32 {
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// The two uniforms `(u0, u1)` of one draw of the hash sampler (see the module docs).
#[inline]
pub fn uniform2(texel: u32, sample: u32, pass: u32, seed: u32) -> [f32; 2] {
    hash_uniforms(hash(texel, sample, pass, seed))
}

/// The hash sampler's `(unit(h), unit(pcg(h)))` of a draw's hash `h`.
#[inline]
fn hash_uniforms(h: u32) -> [f32; 2] {
    [unit_f32(h), unit_f32(pcg(h))]
}

pub use luxbake_scene::Sampler;

/// The draws of a [`Sampler`] (the enum is a setting of the scene crate; its numbers are this
/// module's).
pub trait Draw {
    /// The two uniforms of ray `sample` of `texel` in bounce `pass`.
    fn uniform2(self, texel: u32, sample: u32, pass: u32, seed: u32) -> [f32; 2];
}

impl Draw for Sampler {
    #[inline]
    fn uniform2(self, texel: u32, sample: u32, pass: u32, seed: u32) -> [f32; 2] {
        match self {
            Sampler::Hash => uniform2(texel, sample, pass, seed),
            Sampler::Sobol => sobol2(texel, sample, pass, seed),
        }
    }
}

/// One pass's draws of a [`Sampler`], what does not depend on the texel computed once: the
/// same numbers as [`Sampler::uniform2`], bit for bit, for loops that draw many rays per
/// texel. For the hash sampler that is `pcg(sample + pcg(pass + pcg(seed)))` per sample of a
/// range, leaving two [`pcg`]s per draw instead of five; for the Sobol sampler the texel's
/// keys ([`TexelDraws`]).
#[derive(Debug, Clone)]
pub struct PassDraws {
    sampler: Sampler,
    pass: u32,
    seed: u32,
    /// The first sample of `sample_keys`.
    first: u32,
    /// Hash sampler: `pcg(sample + pcg(pass + pcg(seed)))` of samples `first ..`.
    sample_keys: Vec<u32>,
}

impl PassDraws {
    /// The draws of `sampler` in `pass` with `seed`; samples in `samples` draw fastest.
    pub fn new(sampler: Sampler, pass: u32, seed: u32, samples: Range<u32>) -> PassDraws {
        let first = samples.start;
        let sample_keys = match sampler {
            Sampler::Hash => {
                let p = pcg(pass.wrapping_add(pcg(seed)));
                samples.map(|s| pcg(s.wrapping_add(p))).collect()
            }
            Sampler::Sobol => Vec::new(),
        };
        PassDraws {
            sampler,
            pass,
            seed,
            first,
            sample_keys,
        }
    }

    /// The draws of `texel`.
    #[inline]
    pub fn texel(&self, texel: u32) -> TexelDraws<'_> {
        let keys = match self.sampler {
            Sampler::Hash => [0; 3],
            Sampler::Sobol => sobol_keys(texel, self.pass, self.seed),
        };
        TexelDraws {
            pass: self,
            texel,
            keys,
        }
    }
}

/// One texel's draws in one pass ([`PassDraws::texel`]).
#[derive(Debug, Clone, Copy)]
pub struct TexelDraws<'a> {
    pass: &'a PassDraws,
    texel: u32,
    /// Sobol sampler: the texel's [`sobol_keys`]; unused by the hash.
    keys: [u32; 3],
}

impl TexelDraws<'_> {
    /// [`Sampler::uniform2`]`(texel, sample, pass, seed)`.
    #[inline(always)]
    pub fn uniform2(&self, sample: u32) -> [f32; 2] {
        let d = self.pass;
        match d.sampler {
            Sampler::Hash => match d.sample_keys.get(sample.wrapping_sub(d.first) as usize) {
                Some(&k) => hash_uniforms(pcg(self.texel.wrapping_add(k))),
                None => uniform2(self.texel, sample, d.pass, d.seed),
            },
            Sampler::Sobol => sobol2_keyed(sample, self.keys).map(unit_f32),
        }
    }

    /// [`TexelDraws::uniform2`] of samples `sample .. sample + 4`, bit for bit. The hash
    /// sampler's four draws are written lane by lane, so that a caller compiled for a vector
    /// unit with per-lane shifts and multiplications (AVX2) computes them as one vector.
    #[inline(always)]
    pub fn uniform2x4(&self, sample: u32) -> [[f32; 2]; 4] {
        let d = self.pass;
        let at = sample.wrapping_sub(d.first) as usize;
        if let (Sampler::Hash, Some(&[k0, k1, k2, k3])) =
            (d.sampler, d.sample_keys.get(at..at.saturating_add(4)))
        {
            let mut h = [k0, k1, k2, k3];
            for h in &mut h {
                *h = pcg(self.texel.wrapping_add(*h));
            }
            let mut u = [[0.0f32; 2]; 4];
            for (u, h) in u.iter_mut().zip(h) {
                *u = [unit_f32(h), unit_f32(pcg(h))];
            }
            return u;
        }
        [
            self.uniform2(sample),
            self.uniform2(sample.wrapping_add(1)),
            self.uniform2(sample.wrapping_add(2)),
            self.uniform2(sample.wrapping_add(3)),
        ]
    }
}

/// `pascal(x)`: `x` times Pascal's triangle mod 2 (see the module docs); `reverse(pascal(i))`
/// is Sobol's dimension 1 of index `i`.
#[inline]
pub const fn pascal(mut x: u32) -> u32 {
    x ^= (x >> 1) & 0x5555_5555;
    x ^= (x >> 2) & 0x3333_3333;
    x ^= (x >> 4) & 0x0f0f_0f0f;
    x ^= (x >> 8) & 0x00ff_00ff;
    x ^= (x >> 16) & 0x0000_ffff;
    x
}

/// `lk(x, k)`: the Laine–Karras-style permutation of Burley 2020 (see the module docs).
#[inline]
pub const fn laine_karras(mut x: u32, key: u32) -> u32 {
    x = x.wrapping_add(key);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// `owen(x, k)`: the nested uniform (Owen) scramble of the bits of `x` keyed by `key`,
/// `reverse(lk(reverse(x), key))`.
#[inline]
pub const fn owen(x: u32, key: u32) -> u32 {
    laine_karras(x.reverse_bits(), key).reverse_bits()
}

/// The scrambled Sobol point of ray `sample` of `texel` in bounce `pass`, as 32-bit fractions
/// (before [`unit_f32`]; see the module docs).
#[inline]
pub const fn sobol2_bits(texel: u32, sample: u32, pass: u32, seed: u32) -> [u32; 2] {
    sobol2_keyed(sample, sobol_keys(texel, pass, seed))
}

/// A texel's Sobol keys in a pass: `[key, pcg(key), pcg(pcg(key))]` (see the module docs).
#[inline]
const fn sobol_keys(texel: u32, pass: u32, seed: u32) -> [u32; 3] {
    let key = hash(texel, 0, pass, seed);
    let kx = pcg(key);
    [key, kx, pcg(kx)]
}

/// [`sobol2_bits`] of ray `sample` from its texel's [`sobol_keys`].
#[inline]
const fn sobol2_keyed(sample: u32, [key, kx, ky]: [u32; 3]) -> [u32; 2] {
    let i = owen(sample, key);
    [
        laine_karras(i, kx).reverse_bits(),
        laine_karras(pascal(i), ky).reverse_bits(),
    ]
}

/// The two uniforms `(u0, u1)` of one draw of the Sobol sampler (see the module docs).
#[inline]
pub fn sobol2(texel: u32, sample: u32, pass: u32, seed: u32) -> [f32; 2] {
    sobol2_bits(texel, sample, pass, seed).map(unit_f32)
}

/// Grid texels per side of the blocks whose gathers share one Sobol sequence ([`Stream`]).
pub const SOBOL_BLOCK: u32 = 2;

/// Where a texel's draws in one pass come from (see the module docs, "Blocks"): draw `k` of
/// the texel is `sampler.uniform2(key, first + k, pass, seed)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stream {
    /// The texel index whose keys scramble the draws.
    pub key: u32,
    /// The index of the texel's first draw in that sequence.
    pub first: u32,
}

impl Stream {
    /// The draws of a gather of `rays` rays at texel `(x, y)` of `layer`, on the grid of every
    /// `stride`-th texel (1 or 0: every texel): the Sobol sampler's grid texels draw their
    /// rays from their block's sequence, rank `r` of the block from index `r · P` on
    /// (`P = rays` rounded up to a power of two); any other texel, and every texel of the
    /// hash sampler, from its own sequence's index 0.
    pub fn gather(
        sampler: Sampler,
        layer_size: [u32; 2],
        [layer, x, y]: [u32; 3],
        stride: u32,
        rays: u32,
    ) -> Stream {
        match (sampler, block(layer_size, [layer, x, y], stride)) {
            (Sampler::Sobol, Some((key, rank))) => Stream {
                key,
                first: rank.wrapping_mul(sequence(rays)),
            },
            _ => Stream {
                key: texel_index(layer_size, layer, x, y),
                first: 0,
            },
        }
    }

    /// The draws of `more` rays refining a gather of `first_rays` rays at every texel
    /// (`Program::Refine`): the Sobol sampler's from index `B² · max(P, Q) + r · Q` of the
    /// block's sequence on (`B` [`SOBOL_BLOCK`], `P` and `Q` the two counts rounded up to
    /// powers of two, `r` the texel's rank): past every block texel's first gather, and the
    /// block's refinements together an aligned run of `B² · Q` indices; the hash sampler's the
    /// texel's own draws `first_rays ..`, which continue its gather.
    pub fn refine(
        sampler: Sampler,
        layer_size: [u32; 2],
        [layer, x, y]: [u32; 3],
        first_rays: u32,
        more: u32,
    ) -> Stream {
        // At stride 1 every texel is on the grid: the gather of `more` rays, moved past the
        // block's first gathers (Sobol) or the texel's own (hash).
        let g = Stream::gather(sampler, layer_size, [layer, x, y], 1, more);
        let skip = match sampler {
            Sampler::Sobol => {
                (SOBOL_BLOCK * SOBOL_BLOCK).wrapping_mul(sequence(first_rays).max(sequence(more)))
            }
            Sampler::Hash => first_rays,
        };
        Stream {
            key: g.key,
            first: skip.wrapping_add(g.first),
        }
    }
}

/// `rays` rounded up to a power of two (1 for 0; 2^31 for more than that).
#[inline]
fn sequence(rays: u32) -> u32 {
    rays.max(1).checked_next_power_of_two().unwrap_or(1 << 31)
}

/// The block of grid texel `(x, y)` on the grid of every `stride`-th texel: the index of its
/// first texel (its smallest column and row) and the texel's rank in it,
/// `gx mod B + B · (gy mod B)` for grid coordinates `(gx, gy)`; `None` off the grid.
#[inline]
fn block(layer_size: [u32; 2], [layer, x, y]: [u32; 3], stride: u32) -> Option<(u32, u32)> {
    let s = stride.max(1);
    if x % s != 0 || y % s != 0 {
        return None;
    }
    let (gx, gy, b) = (x / s, y / s, SOBOL_BLOCK);
    let key = texel_index(layer_size, layer, (gx - gx % b) * s, (gy - gy % b) * s);
    Some((key, gx % b + b * (gy % b)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pass_draws_equal_the_samplers_draws() {
        for sampler in Sampler::ALL {
            for (pass, seed) in [(0, 0), (1, 7), (3, u32::MAX), (u32::MAX, 12_345)] {
                let draws = PassDraws::new(sampler, pass, seed, 2..6);
                for texel in [0, 1, 999, 1 << 20, u32::MAX] {
                    let t = draws.texel(texel);
                    // Samples outside the 4 precomputed ones take the direct path.
                    for sample in (0..9).chain([1 << 16, u32::MAX]) {
                        let want = sampler.uniform2(texel, sample, pass, seed);
                        let got = t.uniform2(sample);
                        assert_eq!(
                            got.map(f32::to_bits),
                            want.map(f32::to_bits),
                            "{sampler} texel {texel} sample {sample} pass {pass} seed {seed}"
                        );
                        // Four at once: inside, across and past the precomputed samples.
                        let four = t.uniform2x4(sample);
                        for (i, got) in (0..4).zip(four) {
                            let s = sample.wrapping_add(i);
                            let want = sampler.uniform2(texel, s, pass, seed);
                            assert_eq!(
                                got.map(f32::to_bits),
                                want.map(f32::to_bits),
                                "{sampler} x4 texel {texel} sample {s} pass {pass} seed {seed}"
                            );
                        }
                    }
                }
            }
        }
    }

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

    /// Sobol dimension 1 from its definition: the XOR of the direction numbers
    /// `V[0] = 2^31`, `V[b] = V[b-1] ^ (V[b-1] >> 1)` over the set bits `b` of `i`.
    fn sobol1(i: u32) -> u32 {
        let mut v = 1u32 << 31;
        let mut y = 0;
        for b in 0..32 {
            if i >> b & 1 == 1 {
                y ^= v;
            }
            v ^= v >> 1;
        }
        y
    }

    // Reference values from crates/bake/tools/rng_reference.py, written from the module docs
    // in Python (dimension 1 from Lucas' theorem there, neither from the direction-number
    // recurrence nor from the shift steps of `pascal`).
    #[test]
    fn pascal_is_sobol_dimension_one() {
        assert_eq!(sobol1(1 << 4), 0x8800_0000);
        assert_eq!(sobol1(1 << 31), 0xffff_ffff);
        assert_eq!(pascal(3).reverse_bits(), 0x4000_0000);
        assert_eq!(pascal(5).reverse_bits(), 0x2000_0000);
        assert_eq!(pascal(u32::MAX).reverse_bits(), 1);
        let mut x = 0x9e37_79b9u32;
        for i in (0..1u32 << 12).chain((0..4096).map(|_| {
            x = pcg(x);
            x
        })) {
            assert_eq!(pascal(i).reverse_bits(), sobol1(i), "index {i:#x}");
        }
        // owen(reverse(x), k) = reverse(lk(x, k)): the shortcut of sobol2_bits.
        assert_eq!(
            owen(0x1234_5678u32.reverse_bits(), 99),
            laine_karras(0x1234_5678, 99).reverse_bits()
        );
    }

    // Reference values from crates/bake/tools/rng_reference.py.
    #[test]
    fn sobol_known_values() {
        assert_eq!(laine_karras(0x1234_5678, 0x9abc_def0), 0x14ef_64c8);
        assert_eq!(owen(0x1234_5678, 0x9abc_def0), 0x180f_3b55);
        assert_eq!(sobol2_bits(0, 0, 1, 0), [0xeb37_07d2, 0x8354_9e88]);
        assert_eq!(sobol2_bits(1, 2, 3, 4), [0x04c7_c62f, 0x90b2_632a]);
        assert_eq!(sobol2_bits(123_456, 7, 1, 42), [0xd212_f1c1, 0xfcf8_d029]);
        assert_eq!(
            sobol2_bits(5, 1000, 2, 0xdead_beef),
            [0x3e6c_b620, 0x748e_6251]
        );
        let [u0, u1] = sobol2(1, 2, 3, 4);
        assert_eq!(u0, 0x0004_c7c6 as f32 / 16_777_216.0);
        assert_eq!(u1, 0x0090_b263 as f32 / 16_777_216.0);
        assert_eq!(Sampler::Sobol.uniform2(1, 2, 3, 4), [u0, u1]);
        assert_eq!(Sampler::Hash.uniform2(1, 2, 3, 4), uniform2(1, 2, 3, 4));
    }

    /// Asserts that `points` (2^m of them) are a (0,m,2)-net: every elementary interval of
    /// area 2^-m holds exactly one.
    fn assert_net(points: &[[f32; 2]], what: &str) {
        let n = points.len() as u32;
        assert!(n.is_power_of_two(), "{what}: {n} points");
        let m = n.trailing_zeros();
        for j in 0..=m {
            let (cols, rows) = (1u32 << j, 1u32 << (m - j));
            let mut seen = vec![false; n as usize];
            for p in points {
                // Exact: 2^j · u only moves the exponent.
                let cx = (p[0] * cols as f32) as u32;
                let cy = (p[1] * rows as f32) as u32;
                let cell = &mut seen[(cy * cols + cx) as usize];
                assert!(!*cell, "{what}: N {n} interval {cols}×{rows}: two points");
                *cell = true;
            }
        }
    }

    /// For N = 2^m rays, every elementary interval of area 1/N holds exactly one of a texel's
    /// points (a (0,m,2)-net), for every texel, pass and seed tried.
    #[test]
    fn sobol_points_of_a_texel_are_stratified() {
        for (texel, pass, seed) in [(0, 1, 0), (1, 1, 0), (77_777, 2, 9), (u32::MAX, 5, 0xdead)] {
            for m in 0..=11u32 {
                let n = 1u32 << m;
                let points: Vec<[f32; 2]> = (0..n).map(|s| sobol2(texel, s, pass, seed)).collect();
                assert_net(&points, &format!("texel {texel}"));
            }
        }
        // The hash sampler is not stratified: 16 draws leave some of the 4 × 4 cells empty.
        let cells: std::collections::HashSet<(u32, u32)> = (0..16)
            .map(|s| uniform2(3, s, 1, 0))
            .map(|u| ((u[0] * 4.0) as u32, (u[1] * 4.0) as u32))
            .collect();
        assert!(cells.len() < 16);
    }

    /// Blocks (module docs): the grid texels of a block draw disjoint runs of one sequence,
    /// each run a (0,m,2)-net and all four together a (0,m+2,2)-net, on grids of stride 1 and
    /// 3; their refinements lie past every gather of the block and form a net too; texels off
    /// the grid, and the hash sampler, draw their own sequence.
    #[test]
    fn a_block_of_texels_draws_one_net() {
        let size = [37, 23];
        let (pass, seed) = (2, 9);
        let draws = |s: Stream, count: u32| -> Vec<[f32; 2]> {
            (0..count)
                .map(|k| sobol2(s.key, s.first + k, pass, seed))
                .collect()
        };
        for stride in [1u32, 3] {
            let anchor = [2 * stride, 4 * stride];
            let key = texel_index(size, 1, anchor[0], anchor[1]);
            let texels = [[0, 0], [1, 0], [0, 1], [1, 1]]
                .map(|[i, j]| [1, anchor[0] + i * stride, anchor[1] + j * stride]);
            for m in 0..=6u32 {
                let n = 1u32 << m;
                let gathers = texels.map(|at| Stream::gather(Sampler::Sobol, size, at, stride, n));
                let refines = texels.map(|at| Stream::refine(Sampler::Sobol, size, at, n, 2 * n));
                let mut all = Vec::new();
                let mut indices = std::collections::HashSet::new();
                for (rank, g) in gathers.iter().enumerate() {
                    assert_eq!(
                        *g,
                        Stream {
                            key,
                            first: rank as u32 * n
                        },
                        "stride {stride}"
                    );
                    let own = draws(*g, n);
                    assert_net(&own, &format!("stride {stride}, rank {rank}"));
                    all.extend(own);
                    indices.extend(g.first..g.first + n);
                }
                assert_net(&all, &format!("stride {stride}, block of {n}"));
                if stride == 1 {
                    let mut more = Vec::new();
                    for (rank, r) in refines.iter().enumerate() {
                        assert_eq!(r.key, key);
                        assert_eq!(r.first, 8 * n + rank as u32 * 2 * n);
                        more.extend(draws(*r, 2 * n));
                        for i in r.first..r.first + 2 * n {
                            assert!(indices.insert(i), "index {i} drawn twice");
                        }
                    }
                    assert_net(&more, &format!("refinements of {n}"));
                }
            }
            if stride > 1 {
                // Off the grid (an orphan of a coarse gather): its own sequence.
                let at = [1, anchor[0] + 1, anchor[1]];
                assert_eq!(
                    Stream::gather(Sampler::Sobol, size, at, stride, 4),
                    Stream {
                        key: texel_index(size, 1, anchor[0] + 1, anchor[1]),
                        first: 0
                    }
                );
            }
        }
        // Odd counts take the next power of two; the hash sampler keeps the texel's own
        // sequence, and its refinement continues it.
        let own = texel_index(size, 0, 5, 7);
        let first = texel_index(size, 0, 4, 6);
        assert_eq!(
            Stream::gather(Sampler::Sobol, size, [0, 5, 7], 1, 5),
            Stream {
                key: first,
                first: 3 * 8
            }
        );
        assert_eq!(
            Stream::refine(Sampler::Sobol, size, [0, 5, 7], 5, 3),
            Stream {
                key: first,
                first: 4 * 8 + 3 * 4
            }
        );
        assert_eq!(
            Stream::refine(Sampler::Sobol, size, [0, 5, 7], 2, 16),
            Stream {
                key: first,
                first: 4 * 16 + 3 * 16
            }
        );
        assert_eq!(
            Stream::gather(Sampler::Hash, size, [0, 5, 7], 1, 4),
            Stream { key: own, first: 0 }
        );
        assert_eq!(
            Stream::refine(Sampler::Hash, size, [0, 5, 7], 4, 8),
            Stream { key: own, first: 4 }
        );
        // Counts past 2^31 round to 2^31 and the index wraps, as in the shaders.
        let g = Stream::gather(Sampler::Sobol, size, [0, 5, 7], 1, u32::MAX);
        assert_eq!(g.first, 3u32.wrapping_mul(1 << 31));
        assert_eq!(
            Stream::gather(Sampler::Sobol, size, [0, 4, 6], 0, 0).first,
            0
        );
    }

    #[test]
    fn sampler_names_and_ids() {
        for s in Sampler::ALL {
            assert_eq!(s.name().to_uppercase().parse::<Sampler>(), Ok(s));
            assert_eq!(Sampler::from_id(s.id()), s);
            assert_eq!(s.to_string(), s.name());
        }
        assert_eq!(Sampler::default(), Sampler::Hash);
        assert_eq!(Sampler::from_id(7), Sampler::Hash);
        assert!("halton".parse::<Sampler>().is_err());
    }

    #[test]
    fn uniforms_are_roughly_uniform_and_inputs_decorrelated() {
        // For both samplers: the first draws of 64k texels lie in [0, 1) with means near 1/2,
        // and neighbouring texels, samples, passes and seeds draw other numbers.
        for sampler in Sampler::ALL {
            let n = 65_536u32;
            let mut sum = [0.0f64; 2];
            for t in 0..n {
                let u = sampler.uniform2(t, 0, 1, 7);
                assert!(u.iter().all(|v| (0.0..1.0).contains(v)), "{sampler} {u:?}");
                sum[0] += f64::from(u[0]);
                sum[1] += f64::from(u[1]);
            }
            for s in sum {
                let mean = s / f64::from(n);
                assert!((mean - 0.5).abs() < 0.01, "{sampler}: mean {mean}");
            }
            let base = sampler.uniform2(10, 10, 1, 1);
            for [t, s, p, k] in [
                [11, 10, 1, 1],
                [10, 11, 1, 1],
                [10, 10, 2, 1],
                [10, 10, 1, 2],
            ] {
                assert_ne!(base, sampler.uniform2(t, s, p, k), "{sampler}");
            }
        }
        // owen is a bijection: 2^16 inputs, 2^16 distinct outputs.
        let outputs: std::collections::HashSet<u32> =
            (0..1u32 << 16).map(|x| owen(x << 7, 0x1234_5678)).collect();
        assert_eq!(outputs.len(), 1 << 16);
    }
}
