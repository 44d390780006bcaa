//! One object's light map as an image, and the masked bilinear look-up shared by the gather pass,
//! `cargo xtask measure` and the tests.
//!
//! # Masked bilinear look-up (the paper's "edge cases handled explicitly")
//! A light-map UV `(u, v)` on an object with region `size = [w, h]` lands at continuous texel
//! coordinates `x = u·w − ½`, `y = v·h − ½` (texel centres at integers). Both are clamped to
//! the region's texel centres (`[0, w−1]`, `[0, h−1]`), so a look-up never reads a neighbour's
//! region or another layer. The four surrounding texels are weighted bilinearly **and by their
//! mask** (alpha: 1 valid, 0 empty) and the weights renormalised, so the empty texels between
//! charts never darken a look-up near a chart edge. If none of the four is valid the result is
//! zero. Non-finite input UVs also give zero.

/// An RGBA32F image, row 0 first; alpha is the texel mask (1 valid, 0 empty).
#[derive(Debug, Clone, PartialEq)]
pub struct MapImage {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// `4 × width × height` floats.
    pub texels: Vec<f32>,
}

impl MapImage {
    /// A zero (all-empty) image.
    pub fn zeros(width: u32, height: u32) -> MapImage {
        MapImage {
            width,
            height,
            texels: vec![0.0; 4 * width as usize * height as usize],
        }
    }

    /// Texel `(x, y)` as RGBA, zero outside the image.
    pub fn texel(&self, x: u32, y: u32) -> [f32; 4] {
        if x >= self.width || y >= self.height {
            return [0.0; 4];
        }
        let i = 4 * (y as usize * self.width as usize + x as usize);
        match self.texels.get(i..i + 4) {
            Some(t) => [t[0], t[1], t[2], t[3]],
            None => [0.0; 4],
        }
    }

    /// Whether texel `(x, y)` is a valid (masked-in) texel.
    pub fn is_valid(&self, x: u32, y: u32) -> bool {
        self.texel(x, y)[3] > 0.5
    }

    /// Masked bilinear look-up at light-map UV `(u, v)` (see the module docs).
    pub fn sample(&self, uv: [f32; 2]) -> [f32; 3] {
        sample_masked(
            |x, y| self.texel(x, y),
            [0, 0],
            [self.width, self.height],
            uv,
        )
    }

    /// The map with its empty texels (alpha ≤ ½) filled from the nearest valid texel, for
    /// engines that sample light maps bilinearly and with mipmaps: `passes` rounds of
    /// 8-neighbour dilation, so every empty texel within `passes` texels (Chebyshev distance)
    /// of a valid one takes the RGB of a valid texel at the least such distance. In each round
    /// an unfilled texel copies its first filled neighbour in the order left, right, up, down,
    /// then the diagonals up-left, up-right, down-left, down-right (deterministic). Alpha is
    /// kept as it was, so the mask stays recoverable; texels farther away stay as they were.
    pub fn dilated(&self, passes: u32) -> MapImage {
        const ORDER: [(i64, i64); 8] = [
            (-1, 0),
            (1, 0),
            (0, -1),
            (0, 1),
            (-1, -1),
            (1, -1),
            (-1, 1),
            (1, 1),
        ];
        let mut out = self.clone();
        let (w, h) = (i64::from(self.width), i64::from(self.height));
        let mut filled: Vec<bool> = self.texels.chunks_exact(4).map(|t| t[3] > 0.5).collect();
        let mut todo: Vec<usize> = (0..filled.len()).filter(|&i| !filled[i]).collect();
        for _ in 0..passes {
            let mut fills = Vec::new();
            todo.retain(|&i| {
                let (x, y) = ((i as i64) % w, (i as i64) / w);
                let from = ORDER.iter().find_map(|&(dx, dy)| {
                    let (nx, ny) = (x + dx, y + dy);
                    let j = (ny * w + nx) as usize;
                    (nx >= 0 && ny >= 0 && nx < w && ny < h && filled[j]).then_some(j)
                });
                match from {
                    Some(j) => {
                        fills.push((i, j));
                        false
                    }
                    None => true,
                }
            });
            if fills.is_empty() {
                break;
            }
            for &(i, j) in &fills {
                let rgb = [
                    out.texels[4 * j],
                    out.texels[4 * j + 1],
                    out.texels[4 * j + 2],
                ];
                out.texels[4 * i..4 * i + 3].copy_from_slice(&rgb);
                filled[i] = true;
            }
        }
        out
    }

    /// Iterator over the RGB of the valid texels.
    pub fn valid_rgb(&self) -> impl Iterator<Item = [f32; 3]> + '_ {
        self.texels
            .chunks_exact(4)
            .filter(|t| t[3] > 0.5)
            .map(|t| [t[0], t[1], t[2]])
    }
}

/// Masked bilinear look-up of `uv` in the rectangle `offset`, `size` of a texture whose texels
/// `fetch(x, y)` returns (absolute coordinates). See the module docs for the rule.
pub fn sample_masked(
    fetch: impl Fn(u32, u32) -> [f32; 4],
    offset: [u32; 2],
    size: [u32; 2],
    uv: [f32; 2],
) -> [f32; 3] {
    match bilinear_footprint(size, uv) {
        Some(corners) => {
            masked_blend(corners.map(|([x, y], w)| (fetch(offset[0] + x, offset[1] + y), w)))
        }
        None => [0.0; 3],
    }
}

/// The four texels a masked bilinear look-up of `uv` in a rectangle of `size` reads, relative
/// to the rectangle, with their bilinear weights, in the order `(x0, y0)`, `(x1, y0)`,
/// `(x0, y1)`, `(x1, y1)`; `None` when the look-up is zero whatever the texels (an empty
/// rectangle or a non-finite UV). [`sample_masked`] is [`masked_blend`] of these; the gather
/// pass fetches them for several rays before it blends them.
#[inline]
pub(crate) fn bilinear_footprint(size: [u32; 2], uv: [f32; 2]) -> Option<[([u32; 2], f32); 4]> {
    if size[0] == 0 || size[1] == 0 || !uv[0].is_finite() || !uv[1].is_finite() {
        return None;
    }
    let fx = (uv[0] * size[0] as f32 - 0.5).clamp(0.0, (size[0] - 1) as f32);
    let fy = (uv[1] * size[1] as f32 - 0.5).clamp(0.0, (size[1] - 1) as f32);
    // `fx` and `fy` are finite and in `[0, size - 1]`: truncation is their floor, exactly
    // (and not a call to `floorf`, which x86_64's baseline has no instruction for).
    let (x0, y0) = (fx as u32, fy as u32);
    let (tx, ty) = (fx - x0 as f32, fy - y0 as f32);
    let x1 = (x0 + 1).min(size[0] - 1);
    let y1 = (y0 + 1).min(size[1] - 1);
    Some([
        ([x0, y0], (1.0 - tx) * (1.0 - ty)),
        ([x1, y0], tx * (1.0 - ty)),
        ([x0, y1], (1.0 - tx) * ty),
        ([x1, y1], tx * ty),
    ])
}

/// The masked blend of a [`bilinear_footprint`]'s texels (RGBA, alpha the mask) with their
/// weights: the valid texels' weighted mean, in the footprint's order, or zero when none is
/// valid.
#[inline]
pub(crate) fn masked_blend(corners: [([f32; 4], f32); 4]) -> [f32; 3] {
    let mut sum = [0.0f32; 3];
    let mut wsum = 0.0f32;
    for (t, w) in corners {
        if t[3] > 0.5 {
            sum[0] += w * t[0];
            sum[1] += w * t[1];
            sum[2] += w * t[2];
            wsum += w;
        }
    }
    if wsum > 0.0 {
        [sum[0] / wsum, sum[1] / wsum, sum[2] / wsum]
    } else {
        [0.0; 3]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(values: &[(f32, bool)], width: u32) -> MapImage {
        let mut texels = Vec::new();
        for &(v, valid) in values {
            texels.extend_from_slice(&[v, 2.0 * v, 3.0 * v, if valid { 1.0 } else { 0.0 }]);
        }
        MapImage {
            width,
            height: values.len() as u32 / width,
            texels,
        }
    }

    #[test]
    fn bilinear_between_centres_and_clamped_at_edges() {
        let m = image(&[(0.0, true), (4.0, true), (8.0, true), (12.0, true)], 2);
        // Texel centres.
        assert_eq!(m.sample([0.25, 0.25]), [0.0, 0.0, 0.0]);
        assert_eq!(m.sample([0.75, 0.75]), [12.0, 24.0, 36.0]);
        // Halfway between the four centres.
        assert_eq!(m.sample([0.5, 0.5]), [6.0, 12.0, 18.0]);
        // Beyond the edges: clamped to the outer centres, never outside.
        assert_eq!(m.sample([0.0, 0.0]), [0.0, 0.0, 0.0]);
        assert_eq!(m.sample([1.0, 0.25]), [4.0, 8.0, 12.0]);
        assert_eq!(m.sample([-5.0, 7.0]), [8.0, 16.0, 24.0]);
        assert_eq!(m.sample([f32::NAN, 0.5]), [0.0; 3]);
    }

    #[test]
    fn empty_texels_do_not_darken() {
        let m = image(&[(5.0, true), (0.0, false), (5.0, true), (0.0, false)], 2);
        assert_eq!(m.sample([0.5, 0.5]), [5.0, 10.0, 15.0]);
        assert_eq!(m.sample([0.625, 0.9]), [5.0, 10.0, 15.0]);
        let empty = image(&[(1.0, false)], 1);
        assert_eq!(empty.sample([0.5, 0.5]), [0.0; 3]);
        assert_eq!(MapImage::zeros(0, 0).sample([0.5, 0.5]), [0.0; 3]);
    }

    /// Every empty texel within the dilation's reach holds the RGB of a valid texel at its
    /// least Chebyshev distance from the valid ones; alpha is untouched.
    #[test]
    fn dilation_copies_the_nearest_valid_texel() {
        let (w, h) = (9u32, 7u32);
        let mut m = MapImage::zeros(w, h);
        for (x, y, v) in [(2u32, 2u32, 1.0f32), (3, 2, 2.0), (6, 4, 5.0)] {
            let i = 4 * (y * w + x) as usize;
            m.texels[i..i + 4].copy_from_slice(&[v, 2.0 * v, 3.0 * v, 1.0]);
        }
        let d = m.dilated(2);
        let valid: Vec<(i64, i64, [f32; 4])> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter(|&(x, y)| m.is_valid(x, y))
            .map(|(x, y)| (i64::from(x), i64::from(y), m.texel(x, y)))
            .collect();
        for y in 0..h {
            for x in 0..w {
                let (t, o) = (d.texel(x, y), m.texel(x, y));
                assert_eq!(t[3], o[3], "alpha kept at ({x}, {y})");
                let dist = |&(vx, vy, _): &(i64, i64, [f32; 4])| {
                    (vx - i64::from(x)).abs().max((vy - i64::from(y)).abs())
                };
                let nearest = valid.iter().map(dist).min().expect("valid texels");
                if nearest > 2 {
                    assert_eq!(t, o, "beyond the reach at ({x}, {y})");
                    continue;
                }
                assert!(
                    valid
                        .iter()
                        .any(|v| dist(v) == nearest && v.2[..3] == t[..3]),
                    "({x}, {y}) holds {t:?}"
                );
            }
        }
        assert_eq!(d.texel(0, 0), [1.0, 2.0, 3.0, 0.0]);
        assert_eq!(d.texel(8, 6), [5.0, 10.0, 15.0, 0.0]);
        assert_eq!(MapImage::zeros(0, 0).dilated(3), MapImage::zeros(0, 0));
        assert_eq!(MapImage::zeros(2, 2).dilated(3), MapImage::zeros(2, 2));
    }

    #[test]
    fn region_offset_reads_only_the_region() {
        // A 4×1 texture: the region is texels 1..3; texels 0 and 3 must never be read.
        let m = image(&[(100.0, true), (1.0, true), (3.0, true), (100.0, true)], 4);
        let f = |x, y| m.texel(x, y);
        assert_eq!(
            sample_masked(f, [1, 0], [2, 1], [0.0, 0.5]),
            [1.0, 2.0, 3.0]
        );
        assert_eq!(
            sample_masked(f, [1, 0], [2, 1], [1.0, 0.5]),
            [3.0, 6.0, 9.0]
        );
        assert_eq!(
            sample_masked(f, [1, 0], [2, 1], [0.5, 0.5]),
            [2.0, 4.0, 6.0]
        );
    }
}
