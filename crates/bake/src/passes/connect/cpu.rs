//! The CPU reference of pass `connect` (the semantics the shaders mirror).

// `!(x > 0.0)` on purpose: a NaN fails the test, as in the shaders.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use luxbake_bvh::Ray;

use crate::backend::{LAMP_PATH_TEXELS, offset_origin, toward};
use crate::cpu::kernel::*;
use crate::exact::div;
use crate::lightpaths::CONNECT_PASS;
use crate::rng;

use super::ConnectParams;

/// The connect pass for one dispatch.
pub(crate) type Pass = ConnectParams;

/// Picks of the next texel whose pool points a texel prefetches.
const PREFETCH: u32 = 32;

impl TexelPass for ConnectParams {
    fn texel(&self, ctx: &Ctx<'_>, at: Texel) -> [f32; 4] {
        let Texel { layer, x, y } = at;
        let [pw, nw] = ctx.maps().map(|m| m.fetch(at));
        if pw[3] <= 0.5 {
            return [0.0; 4];
        }
        let Some(n) = normalize(xyz(nw)) else {
            return [0.0, 0.0, 0.0, 1.0];
        };
        let paths = &ctx.scene.lamp_paths;
        let stored = (paths.len() / (4 * LAMP_PATH_TEXELS)) as u32;
        let count = self.count.min(stored);
        if count == 0 || self.k == 0 {
            return [0.0, 0.0, 0.0, 1.0];
        }
        let p = xyz(pw);
        let scene = ctx.scene;
        let texel = rng::texel_index(scene.layer_size, layer, x, y);
        let origin = offset_origin(p, n, scene.ray_epsilon);
        let (nc, kf) = (self.rays as f32, self.k as f32);
        let pick = |texel: u32, s: u32| {
            let [u, _] = rng::uniform2(texel, s, CONNECT_PASS, self.seed);
            ((u * count as f32) as u32).min(count - 1) as usize
        };
        // The next texel's points, prefetched: the pool (up to 12 MB) is larger than the
        // caches, so nearly every pick misses them, and each miss would wait behind the
        // previous connection's shadow ray (chairs_05 default: 12 % of a CPU bake stalled on
        // that load). A texel's shadow rays take far longer than a fetch, so the next
        // texel's points are in the cache when it needs them.
        if x + 1 < scene.layer_size[0] {
            let next = rng::texel_index(scene.layer_size, layer, x + 1, y);
            for s in 0..self.k.min(PREFETCH) {
                let i = 4 * LAMP_PATH_TEXELS * pick(next, s);
                prefetch(paths, i);
                prefetch(paths, i + 4 * LAMP_PATH_TEXELS - 1);
            }
        }
        let mut sum = [0.0f32; 3];
        for s in 0..self.k {
            let j = pick(texel, s);
            let at = |row: usize| {
                let i = 4 * (LAMP_PATH_TEXELS * j + row);
                [paths[i], paths[i + 1], paths[i + 2], paths[i + 3]]
            };
            let (a, b, power) = (at(0), at(1), at(2));
            let (position, normal) = (xyz(a), xyz(b));
            let Some((w, _, r2)) = toward(p, position) else {
                continue;
            };
            let cx = dot(n, w);
            let cy = -dot(normal, w);
            if !(cx > 0.0 && cy > 0.0) {
                continue;
            }
            let target = offset_origin(position, normal, scene.ray_epsilon);
            let sd = sub(target, origin);
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
            let pv = a[3] * self.density_scale;
            let geometry = cx * cy;
            let denominator = std::f32::consts::PI * kf * pv * r2 + nc * geometry;
            if !(denominator > 0.0) {
                continue;
            }
            let f = pv * geometry / denominator;
            for (sc, pc) in sum.iter_mut().zip(power) {
                *sc += f * pc;
            }
        }
        [guard(sum[0]), guard(sum[1]), guard(sum[2]), 1.0]
    }
}
