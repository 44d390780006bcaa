//! The CPU reference of pass `connect` (the semantics the shaders mirror).

// `!(x > 0.0)` on purpose: a NaN fails the test, as in the shaders.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use luxbake_bvh::Ray;

use crate::backend::{offset_origin, toward};
use crate::cpu::kernel::*;
use crate::exact::div;
use crate::lightpaths::CONNECT_PASS;
use crate::rng;

use super::ConnectParams;

/// The connect pass for one dispatch.
pub(crate) type Pass = ConnectParams;

/// Picks of the next texel whose pool points a texel prefetches.
const PREFETCH: u32 = 32;

impl CpuPass for ConnectParams {
    /// The picks of the row's next texel, drawn once: prefetched at a texel, used at the next.
    type Scratch = Vec<usize>;

    fn row(&self, ctx: &Ctx<'_>, y: u32, texels: &mut [f32], next: &mut Vec<usize>) {
        let layer = ctx.tile.layer;
        let scene = ctx.scene;
        let count = self.count.min(scene.lamp_paths.len() as u32);
        let pick = |texel: u32, s: u32| {
            let [u, _] = rng::uniform2(texel, s, CONNECT_PASS, self.seed);
            ((u * count as f32) as u32).min(count - 1) as usize
        };
        let pos: View<'_> = ctx.views[0];
        // A valid texel's picks (none for the others, which connect nothing).
        let picks_of = |x: u32, out: &mut Vec<usize>| {
            out.clear();
            if count > 0 && pos.fetch(Texel { layer, x, y })[3] > 0.5 {
                let texel = rng::texel_index(scene.layer_size, layer, x, y);
                out.extend((0..self.k).map(|s| pick(texel, s)));
            }
        };
        let x0 = ctx.tile.x0;
        let mut picks = Vec::with_capacity(self.k as usize);
        picks_of(x0, next);
        for (x, out) in (x0..).zip(texels.chunks_exact_mut(4)) {
            std::mem::swap(&mut picks, next);
            // The next texel's points, prefetched: the pool (16 MB at 2^18 points) is larger
            // than the caches, so nearly every pick misses them, and each miss would wait
            // behind the previous connection's shadow ray (chairs_05 default: 12 % of a CPU
            // bake stalled on that load). A texel's shadow rays take far longer than a fetch,
            // so the next texel's points are in the cache when it needs them.
            if x + 1 < scene.layer_size[0] {
                picks_of(x + 1, next);
                for &j in next.iter().take(PREFETCH as usize) {
                    prefetch_point(&scene.lamp_paths, j);
                }
            } else {
                next.clear();
            }
            out.copy_from_slice(&self.texel(ctx, Texel { layer, x, y }, &picks));
        }
    }
}

/// Asks the cache for point `j`'s line (nothing out of range, or off x86_64).
#[inline(always)]
fn prefetch_point(points: &[LampPoint], j: usize) {
    #[cfg(target_arch = "x86_64")]
    if let Some(p) = points.get(j) {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: SSE is part of the x86_64 baseline, and a prefetch reads nothing the
        // program sees and never faults; the pointer is to an element of `points`.
        unsafe { _mm_prefetch::<_MM_HINT_T0>((p as *const LampPoint).cast()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (points, j);
}

impl ConnectParams {
    /// The connections of texel `at` to the pool points `picks` (its picks `0 .. k`, in
    /// order; empty when the pool is).
    fn texel(&self, ctx: &Ctx<'_>, at: Texel, picks: &[usize]) -> [f32; 4] {
        let [pw, nw] = ctx.maps().map(|m| m.fetch(at));
        if pw[3] <= 0.5 {
            return [0.0; 4];
        }
        let Some(n) = normalize(xyz(nw)) else {
            return [0.0, 0.0, 0.0, 1.0];
        };
        if picks.is_empty() || self.k == 0 {
            return [0.0, 0.0, 0.0, 1.0];
        }
        let p = xyz(pw);
        let scene = ctx.scene;
        let origin = offset_origin(p, n, scene.ray_epsilon);
        let (nc, kf) = (self.rays as f32, self.k as f32);
        let mut sum = [0.0f32; 3];
        for &j in picks {
            let Some(point) = scene.lamp_paths.get(j) else {
                continue;
            };
            let (position, normal) = (xyz(point.position), point.normal);
            let Some((w, _, r2)) = toward(p, position) else {
                continue;
            };
            let cx = dot(n, w);
            let cy = -dot(normal, w);
            if !(cx > 0.0 && cy > 0.0) {
                continue;
            }
            let sd = sub(point.target, origin);
            let len = dot(sd, sd).sqrt();
            if !(len > 0.0) {
                continue;
            }
            let ray = Ray {
                origin,
                dir: div(sd, len),
            };
            if scene.any_hit(&ray, 0.0, len * (1.0 - 1e-4), ctx.trav) {
                continue;
            }
            let pv = point.position[3] * self.density_scale;
            let geometry = cx * cy;
            let denominator = std::f32::consts::PI * kf * pv * r2 + nc * geometry;
            if !(denominator > 0.0) {
                continue;
            }
            let f = pv * geometry / denominator;
            for (sc, pc) in sum.iter_mut().zip(point.power) {
                *sc += f * pc;
            }
        }
        [guard(sum[0]), guard(sum[1]), guard(sum[2]), 1.0]
    }
}
