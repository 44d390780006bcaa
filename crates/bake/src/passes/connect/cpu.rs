//! The CPU reference of pass `connect` (the semantics the shaders mirror).

// `!(x > 0.0)` on purpose: a NaN fails the test, as in the shaders.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use luxbake_bvh::Ray;

use crate::backend::{offset_origin, toward};
use crate::cpu::kernel::*;
use crate::exact::div;
use crate::lightpaths::CONNECT_PASS;
use crate::rng;
use crate::validity::NARROW_GAP;

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
        // The picks' draws (lightpaths, "Stratified picks"), the keys once per texel.
        let draws = rng::PassDraws::new(rng::Sampler::Sobol, CONNECT_PASS, self.seed, 0..0);
        let pick = |texel: &rng::TexelDraws<'_>, first: u32, s: u32| {
            let [u, _] = texel.uniform2(first + s);
            ((u * count as f32) as u32).min(count - 1) as usize
        };
        let (pos, variance): (View<'_>, View<'_>) = (ctx.views[0], ctx.views[2]);
        // A valid texel's picks (none for the others, which connect nothing; in the
        // refinement's pass the texels it refines, continuing their picks).
        let picks_of = |x: u32, out: &mut Vec<usize>| {
            out.clear();
            let here = Texel { layer, x, y };
            let w = pos.fetch(here)[3];
            if count == 0 || w <= 0.5 {
                return;
            }
            let n = self.connections_at(w >= NARROW_GAP, || variance.fetch(here));
            if n > 0 {
                let at = [layer, x, y];
                let sobol = rng::Sampler::Sobol;
                let stream = if self.is_refinement() {
                    let span = self.connections();
                    rng::Stream::refine(sobol, scene.layer_size, at, self.k, span)
                } else {
                    rng::Stream::gather(sobol, scene.layer_size, at, 1, self.k)
                };
                let texel = draws.texel(stream.key);
                out.extend((0..n).map(|s| pick(&texel, stream.first, s)));
            }
        };
        let x0 = ctx.tile.x0;
        let end = x0 + (texels.len() / 4) as u32;
        // The connections in AVX2 lanes where the CPU has them.
        #[cfg(target_arch = "x86_64")]
        let lanes = std::arch::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let lanes = false;
        let mut picks = Vec::with_capacity(self.k as usize);
        picks_of(x0, next);
        for (x, out) in (x0..).zip(texels.chunks_exact_mut(4)) {
            std::mem::swap(&mut picks, next);
            // The next texel's points, prefetched: the pool (16 MB at 2^18 points) is larger
            // than the caches, so nearly every pick misses them, and each miss would wait
            // behind the previous connection's shadow ray (chairs_05 default: 12 % of a CPU
            // bake stalled on that load). A texel's shadow rays take far longer than a fetch,
            // so the next texel's points are in the cache when it needs them.
            if x + 1 < end {
                picks_of(x + 1, next);
                for &j in next.iter().take(PREFETCH as usize) {
                    prefetch(&scene.lamp_paths, j);
                }
            } else {
                next.clear();
            }
            let at = Texel { layer, x, y };
            out.copy_from_slice(&self.texel_with(ctx, at, &picks, lanes));
        }
    }
}

impl ConnectParams {
    /// The connections of texel `at` to the pool points `picks` (its picks, in order; empty
    /// when the pool is, or when the texel does not connect): with `lanes` (only where the
    /// CPU has AVX2), up to
    /// [`LANES`] connections computed together up to their shadow rays
    /// ([`avx2::connections`]), else one by one.
    pub(crate) fn texel_with(
        &self,
        ctx: &Ctx<'_>,
        at: Texel,
        picks: &[usize],
        lanes: bool,
    ) -> [f32; 4] {
        let [pos, nrm, _] = ctx.maps();
        let pw = pos.fetch(at);
        if pw[3] <= 0.5 {
            return [0.0; 4];
        }
        // A texel that connects nothing (most, in the refinement's pass) reads no more.
        if picks.is_empty() || self.k == 0 {
            return [0.0, 0.0, 0.0, 1.0];
        }
        let Some(n) = normalize(xyz(nrm.fetch(at))) else {
            return [0.0, 0.0, 0.0, 1.0];
        };
        let p = xyz(pw);
        let scene = ctx.scene;
        let origin = offset_origin(p, n, scene.ray_epsilon);
        // The gather's density per steradian times π at the point's direction: `cx` for its
        // cosine-weighted rays, ½ for a gap's uniform ones (lightpaths::gather_weight).
        let uniform = pw[3] >= NARROW_GAP;
        let mut sum = [0.0f32; 3];
        #[cfg(target_arch = "x86_64")]
        if lanes {
            for group in picks.chunks(LANES) {
                // SAFETY: `lanes` only where the CPU has AVX2 (`row`, the tests).
                let c = unsafe { avx2::connections(self, scene, group, (p, n, origin), uniform) };
                for (l, &j) in group.iter().enumerate() {
                    let Some(point) = scene.lamp_paths.get(j).filter(|_| c.ok & (1 << l) != 0)
                    else {
                        continue;
                    };
                    let ray = Ray {
                        origin,
                        dir: [c.dir[0][l], c.dir[1][l], c.dir[2][l]],
                    };
                    if scene.any_hit(&ray, 0.0, c.len[l] * (1.0 - 1e-4), ctx.trav) {
                        continue;
                    }
                    for (sc, pc) in sum.iter_mut().zip(point.power) {
                        *sc += c.f[l] * pc;
                    }
                }
            }
            let k = self.scale(picks.len() as u32);
            return [guard(sum[0] * k), guard(sum[1] * k), guard(sum[2] * k), 1.0];
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = lanes;
        let (nc, kf) = (self.rays as f32, self.k as f32);
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
            let gathered = if uniform { 0.5 * cy } else { geometry };
            let denominator = std::f32::consts::PI * kf * pv * r2 + nc * gathered;
            if !(denominator > 0.0) {
                continue;
            }
            let f = pv * geometry / denominator;
            for (sc, pc) in sum.iter_mut().zip(point.power) {
                *sc += f * pc;
            }
        }
        let k = self.scale(picks.len() as u32);
        [guard(sum[0] * k), guard(sum[1] * k), guard(sum[2] * k), 1.0]
    }
}

/// Connections computed together, one to a lane.
#[cfg(target_arch = "x86_64")]
pub(crate) const LANES: usize = 8;

/// Up to [`LANES`] connections of one texel (picks in order, one to a lane) computed together
/// up to their shadow rays: the scalar path's operations in its order (IEEE single precision,
/// no fused multiply-adds), so each lane's direction, length and weight are the scalar path's
/// bit for bit, and a lane counts where every test of the scalar path but the shadow ray
/// passes (test `connect_lanes_equal_the_scalar_connections`; `chairs_05`'s EXRs byte-equal).
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use super::*;
    use crate::cpu::lanes::{floats, vector};

    /// What [`connections`] gives per lane.
    pub(super) struct Lanes {
        /// Bit `l`: lane `l`'s connection counts unless its shadow ray is blocked.
        pub(super) ok: u32,
        /// The shadow ray's unit direction, a row per component.
        pub(super) dir: [[f32; LANES]; 3],
        /// The shadow ray's length (to the point's offset end).
        pub(super) len: [f32; LANES],
        /// The connection's weight: the balance heuristic's share of the point's power.
        pub(super) f: [f32; LANES],
    }

    /// The connections of a texel at `p` (unit normal `n`, ray origin `origin`) to the pool
    /// points `picks` (at most [`LANES`]); `uniform`: its gather's rays are a gap's uniform
    /// ones.
    #[target_feature(enable = "avx2")]
    pub(super) fn connections(
        params: &ConnectParams,
        scene: &CpuScene,
        picks: &[usize],
        (p, n, origin): ([f32; 3], [f32; 3], [f32; 3]),
        uniform: bool,
    ) -> Lanes {
        // The points' fields, a row of lanes each (lanes without a point stay 0 and fail).
        let mut rows = [[0.0f32; LANES]; 10];
        let mut present = 0u32;
        for (l, &j) in picks.iter().enumerate().take(LANES) {
            let Some(q) = scene.lamp_paths.get(j) else {
                continue;
            };
            present |= 1 << l;
            let fields = [
                q.position[0],
                q.position[1],
                q.position[2],
                q.position[3],
                q.normal[0],
                q.normal[1],
                q.normal[2],
                q.target[0],
                q.target[1],
                q.target[2],
            ];
            for (row, v) in rows.iter_mut().zip(fields) {
                row[l] = v;
            }
        }
        let [x0, x1, x2, density, m0, m1, m2, t0, t1, t2] = rows.each_ref().map(|r| vector(r));
        let set = _mm256_set1_ps;
        let zero = _mm256_setzero_ps();
        let (add, sub, mul, div) = (_mm256_add_ps, _mm256_sub_ps, _mm256_mul_ps, _mm256_div_ps);
        let dot = |a: [__m256; 3], b: [__m256; 3]| {
            add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2]))
        };
        // `toward(p, point)`: the unit direction, the distance and its square.
        let to = [sub(x0, set(p[0])), sub(x1, set(p[1])), sub(x2, set(p[2]))];
        let r2 = dot(to, to);
        let r = _mm256_sqrt_ps(r2);
        let ok = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GT_OQ>(r, zero),
            _mm256_cmp_ps::<_CMP_LT_OQ>(r, set(f32::INFINITY)),
        );
        let w = [div(to[0], r), div(to[1], r), div(to[2], r)];
        let cx = dot([set(n[0]), set(n[1]), set(n[2])], w);
        let cy = _mm256_xor_ps(dot([m0, m1, m2], w), set(-0.0));
        let ok = _mm256_and_ps(
            ok,
            _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GT_OQ>(cx, zero),
                _mm256_cmp_ps::<_CMP_GT_OQ>(cy, zero),
            ),
        );
        // The shadow ray toward the point's offset end.
        let sd = [
            sub(t0, set(origin[0])),
            sub(t1, set(origin[1])),
            sub(t2, set(origin[2])),
        ];
        let len = _mm256_sqrt_ps(dot(sd, sd));
        let ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_GT_OQ>(len, zero));
        let dir = [div(sd[0], len), div(sd[1], len), div(sd[2], len)];
        // The balance heuristic's weight.
        let pv = mul(density, set(params.density_scale));
        let geometry = mul(cx, cy);
        let gathered = if uniform { mul(set(0.5), cy) } else { geometry };
        let pi_k = std::f32::consts::PI * params.k as f32;
        let denominator = add(
            mul(mul(set(pi_k), pv), r2),
            mul(set(params.rays as f32), gathered),
        );
        let ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_GT_OQ>(denominator, zero));
        let f = div(mul(pv, geometry), denominator);
        Lanes {
            ok: _mm256_movemask_ps(ok) as u32 & present,
            dir: dir.map(|v| floats(v)),
            len: floats(len),
            f: floats(f),
        }
    }
}
