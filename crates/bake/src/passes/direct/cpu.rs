//! The CPU reference of pass `direct` (the semantics the shaders mirror).

// `!(x > 0.0)` on purpose: a NaN fails the test, as in the shaders.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use luxbake_bvh::Ray;
use luxbake_ies::GpuTable;

use crate::backend::{LampParams, LampView, lamp_toward, offset_origin, toward};
use crate::cpu::kernel::*;
use crate::opening::{self, OpeningParams};
use crate::rng;

use super::DirectParams;

/// The direct pass for one dispatch.
pub(crate) type Pass = DirectParams;

impl TexelPass for DirectParams {
    #[inline]
    fn texel(&self, ctx: &Ctx<'_>, at: Texel) -> [f32; 4] {
        let texel = rng::texel_index(ctx.scene.layer_size, at.layer, at.x, at.y);
        let [pos, nrm, prior] = ctx.maps().map(|m| m.fetch(at));
        // Before the first chunk nothing is added (the slot holds a stand-in).
        let prior = if self.first_sample > 0 {
            xyz(prior)
        } else {
            [0.0; 3]
        };
        direct_texel(ctx.scene, *self, ctx.trav, texel, pos, nrm, prior)
    }
}

/// The direct illuminance at one texel (see the module docs) added to `prior` (the chunks
/// before, [`DirectParams::first_sample`]); `texel` its index ([`rng::texel_index`]).
pub(crate) fn direct_texel(
    scene: &CpuScene,
    params: DirectParams,
    trav: Trav,
    texel: u32,
    pos: [f32; 4],
    nrm: [f32; 4],
    prior: [f32; 3],
) -> [f32; 4] {
    if pos[3] <= 0.5 {
        return [0.0; 4];
    }
    let p = xyz(pos);
    let Some(n) = normalize(xyz(nrm)) else {
        return [0.0, 0.0, 0.0, 1.0];
    };
    let start = Start::new(p, n, scene.ray_epsilon);
    // A chunk of the opening samples: flattened indices `first..end` of each opening's.
    let first = params.first_sample;
    let end = if params.chunk_samples > 0 {
        first.saturating_add(params.chunk_samples)
    } else {
        u32::MAX
    };
    let mut e = prior;
    for (li, lamp) in scene.lamps.iter().take(params.lamp_count as usize).enumerate() {
        if let Some(o) = near_opening(lamp, p) {
            let shift = opening::shift(texel, li as u32, params.seed);
            let k = from_opening(
                scene,
                trav,
                lamp,
                &o,
                &start,
                [params.samples, params.probe_stride],
                shift,
                [first, end],
            );
            for (ec, sc) in e.iter_mut().zip(lamp.scale) {
                *ec += k * sc;
            }
            continue;
        }
        // A lamp without an opening is the first chunk's.
        if first > 0 {
            continue;
        }
        let Some(LampView {
            d2,
            d,
            w,
            cos,
            intensity,
        }) = lamp_toward(lamp, &scene.tables, p, n)
        else {
            continue;
        };
        let back = [-w[0], -w[1], -w[2]];
        if !start.sees(scene, trav, lamp.position, back, d, d2) {
            continue;
        }
        let k = intensity * cos / d2.max(start.off2);
        for (ec, sc) in e.iter_mut().zip(lamp.scale) {
            *ec += k * sc;
        }
    }
    [guard(e[0]), guard(e[1]), guard(e[2]), 1.0]
}

/// Where a texel's shadow rays start: its point `p`, unit normal `n`, the offset origin `o0`
/// ([`offset_origin`]) and the offset squared.
pub(crate) struct Start {
    p: [f32; 3],
    n: [f32; 3],
    o0: [f32; 3],
    off2: f32,
}

impl Start {
    fn new(p: [f32; 3], n: [f32; 3], eps: f32) -> Start {
        let o0 = offset_origin(p, n, eps);
        let off = sub(o0, p);
        Start {
            p,
            n,
            o0,
            off2: dot(off, off),
        }
    }

    /// Whether nothing lies between the texel and `x` — a lamp's centre or a point of its
    /// opening — `r` away (`r2` its square), `back` the unit direction from `x` toward the
    /// texel. Within 4 offsets of the texel the ray starts a quarter of the way along its
    /// normal; it stops short of `x` by `x`'s own offset (at most a quarter of `r`).
    fn sees(
        &self,
        scene: &CpuScene,
        trav: Trav,
        x: [f32; 3],
        back: [f32; 3],
        r: f32,
        r2: f32,
    ) -> bool {
        let origin = if 16.0 * self.off2 > r2 {
            mad(self.p, self.n, 0.25 * r)
        } else {
            self.o0
        };
        let dir = sub(x, origin);
        let len = dot(dir, dir).sqrt();
        let x_off = sub(offset_origin(x, back, scene.ray_epsilon), x);
        let stop = dot(x_off, x_off).sqrt().min(0.25 * r);
        let t_max = 1.0 - stop / len;
        !(len > 0.0 && t_max > 0.0 && scene.any_hit(&Ray { origin, dir }, 0.0, t_max, trav))
    }
}

/// `lamp`'s opening when `p` lies within its [`OpeningParams::near`] distance.
#[inline]
pub(crate) fn near_opening(lamp: &LampParams, p: [f32; 3]) -> Option<OpeningParams> {
    let o = lamp.opening?;
    let to = sub(lamp.position, p);
    (dot(to, to).sqrt() < o.near).then_some(o)
}

/// One opening's lattice points as a texel sees them: what [`from_opening`] sums, each point
/// before its shadow ray.
struct OpeningView<'a> {
    table: &'a GpuTable,
    lamp: &'a LampParams,
    o: &'a OpeningParams,
    start: &'a Start,
    shift: [u32; 2],
}

/// A lattice point's share before its shadow ray, and that ray's end: the point `x`, the unit
/// direction `back` from it toward the texel, the distance `r` and its square.
struct PointView {
    value: f32,
    x: [f32; 3],
    back: [f32; 3],
    r: f32,
    r2: f32,
}

impl OpeningView<'_> {
    /// Point `k` of `count` of a part ([`opening::lattice`] drawn by `sampler`): `None` when it
    /// gives the texel nothing whatever its shadow ray finds (behind the receiver, on the
    /// part's far side, dark toward it).
    #[inline]
    fn point(&self, sampler: &opening::PartSampler<'_>, k: u32, count: u32) -> Option<PointView> {
        let (p, n, off2) = (self.start.p, self.start.n, self.start.off2);
        let m = &self.lamp.world_to_photometric;
        let s = sampler.sample(opening::lattice(k, count, self.shift))?;
        // World point: the photometric centre plus Mᵀ·point (M is a rotation).
        let q = s.point;
        let x = [0, 1, 2]
            .map(|c| self.lamp.position[c] + q[0] * m[0][c] + q[1] * m[1][c] + q[2] * m[2][c]);
        let (w, r, r2) = toward(p, x)?;
        let cos_p = dot(n, w);
        if !(cos_p > 0.0) {
            return None;
        }
        let back = [-w[0], -w[1], -w[2]];
        let emit = [dot(m[0], back), dot(m[1], back), dot(m[2], back)];
        let cos_x = dot(s.normal, emit);
        if !(cos_x > 0.0) {
            return None;
        }
        let area = opening::projected_area(self.o, emit);
        if !(area > 0.0) {
            return None;
        }
        let intensity = self.table.sample(emit);
        if !(intensity > 0.0) {
            return None;
        }
        let nf = count as f32;
        let r2e = r2.max(off2).max(s.weight / (std::f32::consts::PI * nf));
        Some(PointView {
            value: intensity * cos_x * s.weight / area * cos_p / r2e,
            x,
            back,
            r,
            r2,
        })
    }
}

/// Whether the texel sees the whole opening by its probes: the shadow rays of the lattice
/// points `k = 0, stride, 2·stride, …` of every part (`counts` points each, their views in
/// `points`, part after part) that give the texel light ([`OpeningView::point`]) all reach it
/// — then the other points are taken as seen without a ray. `false` (every point casts its
/// ray) for `stride ≤ 1`, at the first probe that is blocked, or when no probe gives light.
fn sees_all(
    start: &Start,
    scene: &CpuScene,
    trav: Trav,
    points: &[Option<PointView>],
    counts: &[u32; 6],
    stride: u32,
) -> bool {
    if stride <= 1 {
        return false;
    }
    let mut seen = false;
    let mut base = 0usize;
    for &count in counts {
        for k in (0..count as usize).step_by(stride as usize) {
            let Some(pt) = &points[base + k] else {
                continue;
            };
            if !start.sees(scene, trav, pt.x, pt.back, pt.r, pt.r2) {
                return false;
            }
            seen = true;
        }
        base += count as usize;
    }
    seen
}

thread_local! {
    /// [`from_opening`]'s views of a texel's opening points, kept from texel to texel.
    static POINTS: std::cell::RefCell<Vec<Option<PointView>>> =
        const { std::cell::RefCell::new(Vec::new()) };
}

/// The illuminance at `p` (unit normal `n`) from lattice points of `lamp`'s opening `o`
/// ([`opening::texel_samples`] of `samples`), shared among the parts `p` can see, before the
/// lamp's scale ([`crate::opening`]'s estimator, each point with its shadow ray unless the
/// probes of `probe_stride` all see the opening, [`sees_all`]): the share of the points whose
/// index, counted over the parts in order, lies in `range` (all of them: `[0, u32::MAX]`).
/// Each point is evaluated once, for its probe and its share alike (the shaders evaluate a
/// probe twice, with the same result).
#[allow(clippy::too_many_arguments)]
pub(crate) fn from_opening(
    scene: &CpuScene,
    trav: Trav,
    lamp: &LampParams,
    o: &OpeningParams,
    start: &Start,
    [samples, probe_stride]: [u32; 2],
    shift: [u32; 2],
    range: [u32; 2],
) -> f32 {
    let Some(table) = scene.tables.get(lamp.table as usize) else {
        return 0.0;
    };
    let m = &lamp.world_to_photometric;
    // The receiver in the lamp's photometric frame: M·(p − centre).
    let rel = sub(start.p, lamp.position);
    let receiver = [dot(m[0], rel), dot(m[1], rel), dot(m[2], rel)];
    let d = dot(rel, rel).sqrt();
    let n_texel = opening::texel_samples(o, d, samples);
    let counts = opening::counts(&opening::visible_areas(o, receiver), n_texel);
    // A chunk past the texel's points adds nothing (and asks no probe).
    if range[0] >= counts.iter().fold(0u32, |a, &c| a.saturating_add(c)) {
        return 0.0;
    }
    let view = OpeningView {
        table,
        lamp,
        o,
        start,
        shift,
    };
    POINTS.with_borrow_mut(|points| {
        // The points this chunk sums and the probes, each evaluated once.
        points.clear();
        let mut base = 0u32;
        for (part, &count) in counts.iter().enumerate() {
            let lo = range[0].saturating_sub(base).min(count);
            let hi = range[1].saturating_sub(base).min(count);
            base = base.saturating_add(count);
            let sampler = opening::PartSampler::new(o, part, Some(receiver));
            points.extend((0..count).map(|k| {
                let probe = probe_stride > 1 && k % probe_stride == 0;
                (probe || (lo..hi).contains(&k))
                    .then(|| view.point(&sampler, k, count))
                    .flatten()
            }));
        }
        let trace = !sees_all(start, scene, trav, points, &counts, probe_stride);
        let mut sum = 0.0f32;
        // Index of the part's first point among all the opening's.
        let mut base = 0u32;
        for &count in &counts {
            let mut part_sum = 0.0f32;
            let lo = range[0].saturating_sub(base).min(count);
            let hi = range[1].saturating_sub(base).min(count);
            let first = base as usize;
            base = base.saturating_add(count);
            if lo >= hi {
                continue;
            }
            for pt in points[first + lo as usize..first + hi as usize].iter().flatten() {
                if trace && !start.sees(scene, trav, pt.x, pt.back, pt.r, pt.r2) {
                    continue;
                }
                part_sum += pt.value;
            }
            if count > 0 {
                sum += part_sum / count as f32;
            }
        }
        sum
    })
}
