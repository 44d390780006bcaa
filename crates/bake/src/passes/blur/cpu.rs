//! The CPU reference of pass `blur` (the semantics the shaders mirror).

use rayon::prelude::*;

use crate::contract::{BLUR_NORMAL_COS, MAX_BLUR_RADIUS};
use crate::cpu::kernel::*;
use crate::contract::ParamBlock;

use super::BlurParams;

/// The blur for one dispatch: its kernel.
pub(crate) type Pass = BlurKernel;

impl Prepare for BlurKernel {
    fn prepare(words: &[u32], ctx: &Ctx<'_>) -> Self {
        let t = ctx.tile;
        let rect = [t.x0, t.y0, t.x0 + t.width, t.y0 + t.height];
        BlurKernel::new(BlurParams::from_words(words), ctx.views[1], t.layer, rect)
    }
}

impl TexelPass for BlurKernel {
    #[inline]
    fn texel(&self, ctx: &Ctx<'_>, at: Texel) -> [f32; 4] {
        BlurKernel::texel(self, ctx.views[0], at)
    }
}

/// One axis of the masked Gaussian (see the module docs), prepared once per dispatch: the tap
/// weights and the normalised normals of every texel the dispatch's taps can reach, so that a
/// tap costs a look-up instead of an `exp` and a normalisation. Each weight and normal is
/// computed by the same expression as per tap, so the result is the same bit for bit.
pub(crate) struct BlurKernel {
    /// Texel step along the axis.
    pub(crate) step: [i64; 2],
    /// `exp(k²·inv)` of tap `k ∈ [−R, R]` at index `k + R`, `R` the radius clamped to
    /// [`MAX_BLUR_RADIUS`] (empty for a negative radius: no taps).
    pub(crate) weights: Vec<f32>,
    /// Texel of the layer at `normals[0]`.
    pub(crate) origin: [i64; 2],
    /// Columns of `normals`.
    pub(crate) columns: i64,
    /// Per texel of the reachable rectangle, row by row: the normal normalised by
    /// [`normalize`] (NaN where it cannot be), w = the object index.
    pub(crate) normals: Vec<[f32; 4]>,
}

impl BlurKernel {
    /// The kernel of a blur with `params` over the centres `x ∈ [x0, x1)`, `y ∈ [y0, y1)` of
    /// `layer`, whose normals `nrm` holds.
    pub(crate) fn new(params: BlurParams, nrm: View<'_>, layer: u32, [x0, y0, x1, y1]: [u32; 4]) -> Self {
        let radius = params.radius.min(MAX_BLUR_RADIUS);
        let weights = (-radius..=radius)
            .map(|k| ((k * k) as f32 * params.inv).exp())
            .collect();
        let step = [i64::from(params.step_x), i64::from(params.step_y)];
        let reach = |s: i64| i64::from(radius.max(0)) * s.abs();
        let (w, h) = (i64::from(nrm.size[0]), i64::from(nrm.size[1]));
        let origin = [
            (i64::from(x0) - reach(step[0])).clamp(0, w),
            (i64::from(y0) - reach(step[1])).clamp(0, h),
        ];
        let end = [
            (i64::from(x1) + reach(step[0])).clamp(origin[0], w),
            (i64::from(y1) + reach(step[1])).clamp(origin[1], h),
        ];
        let columns = end[0] - origin[0];
        let mut normals = vec![[0.0f32; 4]; (columns * (end[1] - origin[1])) as usize];
        if columns > 0 {
            normals
                .par_chunks_mut(columns as usize)
                .enumerate()
                .for_each(|(r, row)| {
                    let y = (origin[1] + r as i64) as u32;
                    for (i, n) in row.iter_mut().enumerate() {
                        let x = (origin[0] + i as i64) as u32;
                        let t = nrm.fetch(Texel { layer, x, y });
                        let [a, b, c] = normalize(xyz(t)).unwrap_or([f32::NAN; 3]);
                        *n = [a, b, c, t[3]];
                    }
                });
        }
        BlurKernel {
            step,
            weights,
            origin,
            columns,
            normals,
        }
    }

    /// The prepared normal of texel `(x, y)`, if it is in the reachable rectangle.
    #[inline]
    pub(crate) fn normal(&self, x: i64, y: i64) -> Option<[f32; 4]> {
        let (i, j) = (x - self.origin[0], y - self.origin[1]);
        if i < 0 || j < 0 || i >= self.columns {
            return None;
        }
        self.normals.get((j * self.columns + i) as usize).copied()
    }

    /// The blurred value of texel `at` of `src` (a centre of [`BlurKernel::new`]'s).
    pub(crate) fn texel(&self, src: View<'_>, at: Texel) -> [f32; 4] {
        let centre = src.fetch(at);
        if centre[3] <= 0.5 {
            return [0.0; 4];
        }
        let (layer, x, y) = (at.layer, i64::from(at.x), i64::from(at.y));
        let Some(nc) = self.normal(x, y) else {
            return centre;
        };
        // A normal that cannot be normalised is NaN.
        if nc[0].is_nan() {
            return centre;
        }
        let (n0, object) = (xyz(nc), nc[3]);
        let radius = (self.weights.len() / 2) as i64;
        let (w, h) = (i64::from(src.size[0]), i64::from(src.size[1]));
        // The layer's texels: every tap inside the layer is inside these.
        let Some(layer_texels) = src.index(layer, 0, 0).and_then(|start| {
            let len = 4 * src.size[0] as usize * src.size[1] as usize;
            src.data.get(start..start + len)
        }) else {
            return centre;
        };
        let mut sum = [0.0f32; 3];
        let mut wsum = 0.0f32;
        for (k, &wk) in (-radius..=radius).zip(&self.weights) {
            let (tx, ty) = (x + k * self.step[0], y + k * self.step[1]);
            if tx < 0 || ty < 0 || tx >= w || ty >= h {
                continue;
            }
            let i = 4 * (ty * w + tx) as usize;
            let t = &layer_texels[i..i + 4];
            if t[3] <= 0.5 {
                continue;
            }
            let Some(nt) = self.normal(tx, ty) else {
                continue;
            };
            // NaN (a normal that cannot be normalised) fails the test.
            let cos = dot(n0, xyz(nt));
            if nt[3] != object || cos.is_nan() || cos < BLUR_NORMAL_COS {
                continue;
            }
            for c in 0..3 {
                sum[c] += wk * t[c];
            }
            wsum += wk;
        }
        if wsum > 0.0 {
            [
                guard(sum[0] / wsum),
                guard(sum[1] / wsum),
                guard(sum[2] / wsum),
                1.0,
            ]
        } else {
            centre
        }
    }
}

/// One axis of the masked Gaussian at one texel, with a kernel of its own (dispatches prepare
/// one per tile).
#[cfg(test)]
pub(crate) fn blur_texel([src, nrm]: [View<'_>; 2], params: BlurParams, at: Texel) -> [f32; 4] {
    let Texel { layer, x, y } = at;
    BlurKernel::new(params, nrm, layer, [x, y, x + 1, y + 1]).texel(src, at)
}
