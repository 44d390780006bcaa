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
        if params.points_only == 0
            && let Some(o) = near_opening(lamp, p)
        {
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

/// The direct illuminance at a gather ray's hit `p` (normal `n`, normalized here) from the first
/// `lamp_count` lamps, each as a point from its photometric centre with its shadow ray: the
/// direct pass's sum at a texel there with [`DirectParams::points_only`]
/// ([`crate::passes::gather`], "Direct light at the hits"); `None` where `p` lies within a
/// lamp's opening's near distance, whose light the point would miss.
pub(crate) fn points_at(
    scene: &CpuScene,
    trav: Trav,
    lamp_count: u32,
    p: [f32; 3],
    n: [f32; 3],
) -> Option<[f32; 3]> {
    let mut lamps = scene.lamps.iter().take(lamp_count as usize);
    if lamps.any(|lamp| near_opening(lamp, p).is_some()) {
        return None;
    }
    let params = DirectParams {
        lamp_count,
        points_only: 1,
        ..DirectParams::default()
    };
    let e = direct_texel(scene, params, trav, 0, [p[0], p[1], p[2], 1.0], [n[0], n[1], n[2], 0.0], [0.0; 3]);
    Some(xyz(e))
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
/// direction `back` from it toward the texel and the distance's square `r2` (the distance is
/// its square root, [`PointView::r`]).
struct PointView {
    value: f32,
    /// The numerator of the point's geometric share `cos θ_x · W · cos θ_p / r²` (the control
    /// variate's, [`control`], which divides it by `r2`).
    geom: f32,
    x: [f32; 3],
    back: [f32; 3],
    r2: f32,
}

impl PointView {
    /// The distance to the point: `√r2`, as [`OpeningView::point`] computed it (kept as its
    /// square alone, so that a view is no larger for its `geom`).
    #[inline]
    fn r(&self) -> f32 {
        self.r2.sqrt()
    }
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
        let (w, _, r2) = toward(p, x)?;
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
            geom: cos_x * s.weight * cos_p,
            x,
            back,
            r2,
        })
    }

    /// [`OpeningView::point`] at the points `ks` of a part's `count`, into `slots[k]`: eight at
    /// a time in AVX2 lanes where the CPU has it ([`avx2::points8`], the same values bit for
    /// bit; a last block of fewer repeats its first point, which costs less than taking them
    /// one by one), otherwise point by point.
    fn fill(
        &self,
        sampler: &opening::PartSampler<'_>,
        count: u32,
        ks: impl Iterator<Item = u32>,
        slots: &mut [Option<PointView>],
    ) {
        let mut block = [0u32; 8];
        let mut n = 0;
        let flush = |block: &mut [u32; 8], n: usize, slots: &mut [Option<PointView>]| {
            let first = block[0];
            block[n..].fill(first);
            #[cfg(target_arch = "x86_64")]
            if avx2::block(self, sampler, count, *block, slots) {
                return;
            }
            for &k in &block[..n] {
                slots[k as usize] = self.point(sampler, k, count);
            }
        };
        for k in ks {
            block[n] = k;
            n += 1;
            if n == block.len() {
                flush(&mut block, n, slots);
                n = 0;
            }
        }
        if n > 0 {
            flush(&mut block, n, slots);
        }
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
            if !start.sees(scene, trav, pt.x, pt.back, pt.r(), pt.r2) {
                return false;
            }
            seen = true;
        }
        base += count as usize;
    }
    seen
}

/// Part `part`'s share where the texel sees the whole opening, estimated with a control
/// variate ([`crate::opening`], "Control variate"): `L_c·G + mean over the probes of
/// (value − L_c·geom)`, `G` the part's geometric integral in closed form
/// ([`opening::part_control`]) and `L_c` the part's luminance toward the receiver from its
/// centre; `points` the part's views (its probes every `stride`-th). `None` (every point is
/// summed as before) for a part without the closed form, a luminance there that is not
/// positive, a probe that gives the texel nothing, fewer than
/// [`opening::CONTROL_MIN_PROBES`] probes, or probes whose residuals scatter so that their
/// mean's standard error (their variance over `P − 1`, over `P`) exceeds
/// [`opening::CONTROL_MAX_ERROR`] of the estimate.
fn control(
    view: &OpeningView<'_>,
    part: usize,
    receiver: [f32; 3],
    normal: [f32; 3],
    points: &[Option<PointView>],
    stride: u32,
) -> Option<f32> {
    let (g, toward) = opening::part_control(view.o, part, receiver, normal)?;
    let area = opening::projected_area(view.o, toward);
    let luminance = view.table.sample(toward) / area;
    if !(area > 0.0 && luminance > 0.0 && luminance.is_finite()) {
        return None;
    }
    let (mut residual, mut square, mut n) = (0.0f32, 0.0f32, 0u32);
    for pt in points.iter().step_by(stride as usize) {
        let pt = pt.as_ref()?;
        let d = pt.value - luminance * (pt.geom / pt.r2);
        residual += d;
        square += d * d;
        n += 1;
    }
    let nf = n as f32;
    let estimate = luminance * g + residual / nf;
    // The probes' own estimate of their mean's error: the residual's variance over them.
    let mean = residual / nf;
    let variance = (square / nf - mean * mean).max(0.0) / (nf - 1.0);
    let tau = opening::CONTROL_MAX_ERROR;
    (n >= opening::CONTROL_MIN_PROBES && variance <= tau * tau * estimate * estimate)
        .then_some(estimate)
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
        // Each part's `count` slots, part after part, each point evaluated once: the probes
        // and the chunk's points at once where no control variate can spare the latter (a
        // part without a closed form, [`opening::has_control`]: the blocks of eight in the
        // order of the points), else the probes first, their last block filled up with the
        // chunk's first other points (`early` of them).
        points.clear();
        let probe = |k: u32| probe_stride > 1 && k.is_multiple_of(probe_stride);
        let controlled: [bool; 6] =
            std::array::from_fn(|part| probe_stride > 1 && opening::has_control(o, part));
        let mut early = [0usize; 6];
        let mut base = 0u32;
        for (part, &count) in counts.iter().enumerate() {
            let lo = range[0].saturating_sub(base).min(count);
            let hi = range[1].saturating_sub(base).min(count);
            let first = base as usize;
            base = base.saturating_add(count);
            points.resize_with(first + count as usize, || None);
            if count == 0 {
                continue;
            }
            let sampler = opening::PartSampler::new(o, part, Some(receiver));
            let slots = &mut points[first..];
            if !controlled[part] {
                let wanted = (0..count).filter(|&k| probe(k) || (lo..hi).contains(&k));
                view.fill(&sampler, count, wanted, slots);
                continue;
            }
            let probes = count.div_ceil(probe_stride) as usize;
            early[part] = probes.next_multiple_of(8) - probes;
            let rest = (lo..hi).filter(|&k| !probe(k)).take(early[part]);
            view.fill(&sampler, count, (0..count).step_by(probe_stride as usize).chain(rest), slots);
        }
        let trace = !sees_all(start, scene, trav, points, &counts, probe_stride);
        // Where the probes all see the opening, each share of a part with a closed form is its
        // control variate's estimate from its probes alone ([`control`]; `cv_parts`), added by
        // the chunk of its first point, before the other parts' sums.
        let normal = [dot(m[0], start.n), dot(m[1], start.n), dot(m[2], start.n)];
        let (mut cv_parts, mut sum) = (0u32, 0.0f32);
        let mut base = 0u32;
        let cv_counts = if trace { &[][..] } else { &counts[..] };
        for (part, &count) in cv_counts.iter().enumerate() {
            let first = base as usize;
            let lo = range[0].saturating_sub(base).min(count);
            let hi = range[1].saturating_sub(base).min(count);
            base = base.saturating_add(count);
            if count == 0 || !controlled[part] {
                continue;
            }
            let probes = &points[first..first + count as usize];
            if let Some(cv) = control(&view, part, receiver, normal, probes, probe_stride) {
                cv_parts |= 1 << part;
                if lo == 0 && hi > 0 {
                    sum += cv;
                }
            }
        }
        // Index of the part's first point among all the opening's.
        let mut base = 0u32;
        for (part, &count) in counts.iter().enumerate() {
            let lo = range[0].saturating_sub(base).min(count);
            let hi = range[1].saturating_sub(base).min(count);
            let first = base as usize;
            base = base.saturating_add(count);
            if lo >= hi || cv_parts & (1 << part) != 0 {
                continue;
            }
            let slots = &mut points[first..first + count as usize];
            // A controlled part's other points of the chunk than those in their slots.
            if controlled[part] {
                let sampler = opening::PartSampler::new(o, part, Some(receiver));
                let rest = (lo..hi).filter(|&k| !probe(k)).skip(early[part]);
                view.fill(&sampler, count, rest, slots);
            }
            let mut part_sum = 0.0f32;
            for pt in slots[lo as usize..hi as usize].iter().flatten() {
                if trace && !start.sees(scene, trav, pt.x, pt.back, pt.r(), pt.r2) {
                    continue;
                }
                part_sum += pt.value;
            }
            sum += part_sum / count as f32;
        }
        sum
    })
}

/// Eight opening points of a texel at once, one to a lane of an AVX2 vector: each lane runs
/// [`OpeningView::point`]'s operations in their order (the table's angles by
/// [`luxbake_ies::acos_f32`] and [`luxbake_ies::atan2_f32`] in lanes), so its point is the
/// scalar one bit for bit (test
/// `points_in_lanes_equal_the_point_by_point_ones`).
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use super::*;
    use crate::cpu::lanes::{LANES as LANES_USIZE, floats};
    use crate::opening::avx2::{clamp8, finite8, projected_area8};

    /// [`OpeningView::fill`]'s block of the eight points `ks` where the CPU has AVX2, into
    /// `slots`: whether it was done ([`points8`]).
    pub(super) fn block(
        view: &OpeningView<'_>,
        sampler: &opening::PartSampler<'_>,
        count: u32,
        ks: [u32; LANES_USIZE],
        slots: &mut [Option<PointView>],
    ) -> bool {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return false;
        }
        // SAFETY: the CPU has AVX2 (just checked).
        let Some(points) = (unsafe { points8(view, sampler, ks, count) }) else {
            return false;
        };
        for (k, pt) in ks.into_iter().zip(points) {
            slots[k as usize] = pt;
        }
        true
    }

    /// `a·b` summed left to right in every lane.
    #[target_feature(enable = "avx2")]
    fn dot8(a: [__m256; 3], b: [__m256; 3]) -> __m256 {
        _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(a[0], b[0]), _mm256_mul_ps(a[1], b[1])),
            _mm256_mul_ps(a[2], b[2]),
        )
    }

    /// [`OpeningView::point`] at the eight lattice points `ks` of a part's `count`; `None`
    /// (nothing computed) where the part cannot go in lanes ([`opening::PartSampler`]'s
    /// `sample8`), which the caller takes point by point.
    #[target_feature(enable = "avx2")]
    pub(super) fn points8(
        view: &OpeningView<'_>,
        sampler: &opening::PartSampler<'_>,
        ks: [u32; LANES_USIZE],
        count: u32,
    ) -> Option<[Option<PointView>; LANES_USIZE]> {
        let set = _mm256_set1_ps;
        let zero = _mm256_setzero_ps();
        // The lattice (`opening::lattice`): u₀ = fract((k + ½)/n + unit(shift₀)),
        // u₁ = unit(k·PHI + shift₁).
        // SAFETY: eight u32s, read unaligned.
        let k = unsafe { _mm256_loadu_si256(ks.as_ptr().cast()) };
        let nf = count as f32;
        let a = _mm256_add_ps(
            _mm256_div_ps(_mm256_add_ps(_mm256_cvtepi32_ps(k), set(0.5)), set(nf)),
            set(rng::unit_f32(view.shift[0])),
        );
        let u0 = _mm256_sub_ps(a, _mm256_floor_ps(a));
        let h = _mm256_add_epi32(
            _mm256_mullo_epi32(k, _mm256_set1_epi32(opening::PHI as i32)),
            _mm256_set1_epi32(view.shift[1] as i32),
        );
        let u1 = _mm256_mul_ps(
            _mm256_cvtepi32_ps(_mm256_srli_epi32::<8>(h)),
            set(1.0 / 16_777_216.0),
        );
        let s = sampler.sample8([u0, u1])?;
        let (p, n, off2) = (view.start.p, view.start.n, view.start.off2);
        let m = &view.lamp.world_to_photometric;
        let q = s.point;
        // World point: the photometric centre plus Mᵀ·point.
        let x: [__m256; 3] = [0, 1, 2].map(|c| {
            let v = _mm256_add_ps(set(view.lamp.position[c]), _mm256_mul_ps(q[0], set(m[0][c])));
            let v = _mm256_add_ps(v, _mm256_mul_ps(q[1], set(m[1][c])));
            _mm256_add_ps(v, _mm256_mul_ps(q[2], set(m[2][c])))
        });
        // `toward(p, x)`.
        let to = [0, 1, 2].map(|c| _mm256_sub_ps(x[c], set(p[c])));
        let r2 = dot8(to, to);
        let r = _mm256_sqrt_ps(r2);
        let w = to.map(|t| _mm256_div_ps(t, r));
        let cos_p = dot8(n.map(|v| set(v)), w);
        let back = w.map(|v| _mm256_xor_ps(v, set(-0.0)));
        let emit = [0, 1, 2].map(|row| dot8(m[row].map(|v| set(v)), back));
        let cos_x = dot8(s.normal, emit);
        let area = projected_area8(view.o, emit);
        let intensity = table8(view.table, emit);
        let gt0 = |v| _mm256_cmp_ps::<_CMP_GT_OQ>(v, zero);
        let ok = [
            _mm256_and_ps(gt0(r), finite8(r)),
            gt0(cos_p),
            gt0(cos_x),
            gt0(area),
            gt0(intensity),
        ]
        .into_iter()
        .fold(s.ok, |a, b| _mm256_and_ps(a, b));
        let r2e = _mm256_max_ps(
            _mm256_max_ps(r2, set(off2)),
            _mm256_div_ps(s.weight, set(std::f32::consts::PI * nf)),
        );
        let value = _mm256_div_ps(
            _mm256_mul_ps(
                _mm256_div_ps(
                    _mm256_mul_ps(_mm256_mul_ps(intensity, cos_x), s.weight),
                    area,
                ),
                cos_p,
            ),
            r2e,
        );
        let geom = _mm256_mul_ps(_mm256_mul_ps(cos_x, s.weight), cos_p);
        let ok = _mm256_movemask_ps(ok);
        let [value, geom, r2] = [value, geom, r2].map(|v| floats(v));
        let x = x.map(|v| floats(v));
        let back = back.map(|v| floats(v));
        Some(std::array::from_fn(|l| {
            (ok & (1 << l) != 0).then(|| PointView {
                value: value[l],
                geom: geom[l],
                x: [x[0][l], x[1][l], x[2][l]],
                back: [back[0][l], back[1][l], back[2][l]],
                r2: r2[l],
            })
        }))
    }

    /// [`luxbake_ies::atan_unit_f32`] in every lane (`x` in `[0, 1]`).
    #[target_feature(enable = "avx2")]
    fn atan8(x: __m256) -> __m256 {
        let set = _mm256_set1_ps;
        let one = set(1.0);
        let reduced = _mm256_cmp_ps::<_CMP_GT_OQ>(x, set(luxbake_ies::TAN_PI_8));
        let z = _mm256_blendv_ps(
            x,
            _mm256_div_ps(_mm256_sub_ps(x, one), _mm256_add_ps(x, one)),
            reduced,
        );
        let base = _mm256_and_ps(reduced, set(std::f32::consts::FRAC_PI_4));
        let w = _mm256_mul_ps(z, z);
        let [c0, c1, c2, c3] = luxbake_ies::ATAN_POLY.map(|c| set(c));
        let p = _mm256_add_ps(_mm256_mul_ps(c0, w), c1);
        let p = _mm256_add_ps(_mm256_mul_ps(p, w), c2);
        let p = _mm256_add_ps(_mm256_mul_ps(p, w), c3);
        let p = _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(p, w), z), z);
        _mm256_add_ps(base, p)
    }

    /// All ones in the lanes whose sign bit is set (`is_sign_negative`).
    #[target_feature(enable = "avx2")]
    fn sign_bit(v: __m256) -> __m256 {
        _mm256_castsi256_ps(_mm256_srai_epi32::<31>(_mm256_castps_si256(v)))
    }

    /// [`luxbake_ies::atan2_f32`] in every lane.
    #[target_feature(enable = "avx2")]
    fn atan2_8(y: __m256, x: __m256) -> __m256 {
        use std::f32::consts::{FRAC_PI_2, PI};
        let set = _mm256_set1_ps;
        let zero = _mm256_setzero_ps();
        let abs = |v: __m256| _mm256_andnot_ps(set(-0.0), v);
        let (ax, ay) = (abs(x), abs(y));
        let larger_x = _mm256_cmp_ps::<_CMP_GE_OQ>(ax, ay);
        let a = _mm256_blendv_ps(
            _mm256_sub_ps(set(FRAC_PI_2), atan8(_mm256_div_ps(ax, ay))),
            atan8(_mm256_div_ps(ay, ax)),
            larger_x,
        );
        let zeros = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_EQ_OQ>(ax, zero),
            _mm256_cmp_ps::<_CMP_EQ_OQ>(ay, zero),
        );
        let a = _mm256_blendv_ps(a, zero, zeros);
        let a = _mm256_blendv_ps(a, _mm256_sub_ps(set(PI), a), sign_bit(x));
        _mm256_xor_ps(a, _mm256_and_ps(y, set(-0.0)))
    }

    /// `asin x` for `|x| ≤ ½` in every lane (`luxbake_ies::ASIN_POLY`).
    #[target_feature(enable = "avx2")]
    fn asin_small8(x: __m256) -> __m256 {
        let set = _mm256_set1_ps;
        let w = _mm256_mul_ps(x, x);
        let [c0, c1, c2, c3, c4] = luxbake_ies::ASIN_POLY.map(|c| set(c));
        let p = _mm256_add_ps(_mm256_mul_ps(c0, w), c1);
        let p = _mm256_add_ps(_mm256_mul_ps(p, w), c2);
        let p = _mm256_add_ps(_mm256_mul_ps(p, w), c3);
        let p = _mm256_add_ps(_mm256_mul_ps(p, w), c4);
        _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(p, w), x), x)
    }

    /// [`luxbake_ies::acos_f32`] in every lane.
    #[target_feature(enable = "avx2")]
    fn acos8(x: __m256) -> __m256 {
        use std::f32::consts::{FRAC_PI_2, PI};
        let set = _mm256_set1_ps;
        let (one, half, two) = (set(1.0), set(0.5), set(2.0));
        let high = _mm256_mul_ps(
            two,
            asin_small8(_mm256_sqrt_ps(_mm256_mul_ps(half, _mm256_sub_ps(one, x)))),
        );
        let low = _mm256_sub_ps(
            set(PI),
            _mm256_mul_ps(
                two,
                asin_small8(_mm256_sqrt_ps(_mm256_mul_ps(half, _mm256_add_ps(one, x)))),
            ),
        );
        let middle = _mm256_sub_ps(set(FRAC_PI_2), asin_small8(x));
        let a = _mm256_blendv_ps(middle, low, _mm256_cmp_ps::<_CMP_LT_OQ>(x, set(-0.5)));
        _mm256_blendv_ps(a, high, _mm256_cmp_ps::<_CMP_GT_OQ>(x, half))
    }

    /// [`GpuTable::sample`] toward the directions `dir` of eight lanes, bit for bit.
    #[target_feature(enable = "avx2")]
    pub(super) fn table8(table: &GpuTable, dir: [__m256; 3]) -> __m256 {
        use std::f32::consts::{PI, TAU};
        let set = _mm256_set1_ps;
        let zero = _mm256_setzero_ps();
        if table.width == 0 || table.height < 2 {
            return zero;
        }
        let [x, y, z] = dir;
        let len = _mm256_sqrt_ps(dot8(dir, dir));
        let ok = _mm256_and_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(len, zero), finite8(len));
        let cos = clamp8(
            _mm256_div_ps(_mm256_xor_ps(z, set(-0.0)), len),
            set(-1.0),
            set(1.0),
        );
        let gamma = acos8(cos);
        let c = atan2_8(y, x);
        let c = _mm256_blendv_ps(
            c,
            _mm256_add_ps(c, set(TAU)),
            _mm256_cmp_ps::<_CMP_LT_OQ>(c, zero),
        );
        let (w, h1) = (table.width as f32, (table.height - 1) as f32);
        let fy = _mm256_mul_ps(_mm256_div_ps(gamma, set(PI)), set(h1));
        let fx = _mm256_mul_ps(_mm256_div_ps(c, set(TAU)), set(w));
        let x0 = _mm256_floor_ps(fx);
        let tx = _mm256_sub_ps(fx, x0);
        // `(x0 as i64).rem_euclid(width)`: x0 lies in [0, width] (c in [0, 2π]).
        let width = _mm256_set1_epi32(table.width as i32);
        let wrap = |i: __m256i| {
            let over = _mm256_cmpgt_epi32(i, _mm256_sub_epi32(width, _mm256_set1_epi32(1)));
            _mm256_sub_epi32(i, _mm256_and_si256(over, width))
        };
        let i0 = wrap(_mm256_cvttps_epi32(x0));
        let i1 = wrap(_mm256_add_epi32(i0, _mm256_set1_epi32(1)));
        let y0f = clamp8(_mm256_floor_ps(fy), zero, set(h1));
        let ty = clamp8(_mm256_sub_ps(fy, y0f), zero, set(1.0));
        let y0 = _mm256_cvttps_epi32(y0f);
        let y1 = _mm256_min_epi32(
            _mm256_add_epi32(y0, _mm256_set1_epi32(1)),
            _mm256_set1_epi32(table.height as i32 - 1),
        );
        let base = table.values.as_ptr();
        let at = |row: __m256i, col: __m256i| {
            let index = _mm256_add_epi32(_mm256_mullo_epi32(row, width), col);
            // SAFETY: in the lanes of `ok` the row is below the height and the column below
            // the width, so the index lies in the table; the other lanes read nothing.
            unsafe { _mm256_mask_i32gather_ps::<4>(zero, base, index, ok) }
        };
        let (v00, v01, v10, v11) = (at(y0, i0), at(y0, i1), at(y1, i0), at(y1, i1));
        let a = _mm256_add_ps(v00, _mm256_mul_ps(_mm256_sub_ps(v01, v00), tx));
        let b = _mm256_add_ps(v10, _mm256_mul_ps(_mm256_sub_ps(v11, v10), tx));
        let v = _mm256_add_ps(a, _mm256_mul_ps(_mm256_sub_ps(b, a), ty));
        _mm256_and_ps(v, ok)
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use luxbake_ies::Photometry;

    use super::*;

    /// A rotation: `angle` radians about the unit axis `a` (Rodrigues), as rows.
    fn rotation(a: [f32; 3], angle: f32) -> [[f32; 3]; 3] {
        let (s, c) = angle.sin_cos();
        let t = 1.0 - c;
        [
            [t * a[0] * a[0] + c, t * a[0] * a[1] - s * a[2], t * a[0] * a[2] + s * a[1]],
            [t * a[0] * a[1] + s * a[2], t * a[1] * a[1] + c, t * a[1] * a[2] - s * a[0]],
            [t * a[0] * a[2] - s * a[1], t * a[1] * a[2] + s * a[0], t * a[2] * a[2] + c],
        ]
    }

    /// The tables of the real-world photometric files `files` for a test of the AVX2 lanes;
    /// `None` after [`luxbake_testkit::skip_or_fail`] when the CPU has no AVX2 or a file is
    /// missing (which fails the test under CI).
    fn lane_tables(test: &str, files: &[&str]) -> Option<Vec<GpuTable>> {
        if !std::arch::is_x86_feature_detected!("avx2") {
            luxbake_testkit::skip_or_fail(test, &"the CPU has no AVX2");
            return None;
        }
        let mut tables = Vec::new();
        for file in files {
            let path = luxbake_testkit::shared_data(test, &format!("photometry/real-world/{file}"))?;
            let bytes = std::fs::read(&path).expect("read the photometric file");
            tables.push(Photometry::parse(&bytes).expect("parse").gpu_table());
        }
        Some(tables)
    }

    /// The CPU's table angles are the shaders' polynomials: the literals of `luxAsinSmall` /
    /// `lux_asin_small` and `luxAtanUnit` / `lux_atan_unit` (and the latter's split) are
    /// `luxbake_ies::ASIN_POLY`, `ATAN_POLY` and `TAN_PI_8` as f32 (up to the signs the
    /// shaders write as subtractions).
    #[test]
    fn the_table_angles_are_the_shaders_polynomials() {
        let sources = [
            (include_str!("../../../shaders/lib/ies.glsl"), ["float luxAsinSmall", "float luxAtanUnit"]),
            (include_str!("../../../shaders/lib/ies.wgsl"), ["fn lux_asin_small", "fn lux_atan_unit"]),
        ];
        for (source, names) in sources {
            let literals = |name: &str| -> Vec<f32> {
                let body = source.split(name).nth(1).expect(name);
                let body = &body[..body.find("\n}").expect("the function's end")];
                body.split(|c: char| !(c.is_ascii_digit() || c == '.' || c == 'e' || c == '-'))
                    .filter(|t| t.contains('.'))
                    .map(|t| t.trim_start_matches('-').parse::<f32>().expect(t))
                    .collect()
            };
            let abs = |a: &[f32]| a.iter().map(|v| v.abs()).collect::<Vec<f32>>();
            assert_eq!(literals(names[0]), abs(&luxbake_ies::ASIN_POLY), "{}", names[0]);
            let atan = literals(names[1]);
            // `0.0` (the start), the split, `0.25` (of π), `1.0` twice (the reduction), then
            // the polynomial.
            let reduction = [0.0, luxbake_ies::TAN_PI_8, 0.25, 1.0, 1.0];
            assert_eq!(atan[..5], reduction, "{}", names[1]);
            assert_eq!(atan[5..], abs(&luxbake_ies::ATAN_POLY), "{}", names[1]);
        }
    }

    /// The table's look-up in lanes ([`avx2::table8`]) equals [`GpuTable::sample`] bit for bit
    /// along the axes and their signed zeros (where `atan2` turns), in the planes between
    /// them, and in random directions, for a table with one column and one with many.
    #[test]
    fn table_in_lanes_equals_the_look_up() {
        use std::arch::x86_64::*;
        let Some(mut tables) = lane_tables("table_in_lanes_equals_the_look_up", &["rw_5.IES"])
        else {
            return;
        };
        tables.push(Photometry::isotropic(10.0).gpu_table());
        let mut dirs = Vec::new();
        for x in [0.0f32, -0.0, 1.0, -1.0, 0.3] {
            for y in [0.0f32, -0.0, 1.0, -1.0, -0.7] {
                for z in [0.0f32, -0.0, 1.0, -1.0, 0.5] {
                    dirs.push([x, y, z]);
                }
            }
        }
        let mut state = 7u32;
        for _ in 0..4000 {
            dirs.push([0; 3].map(|_| {
                state = rng::pcg(state);
                rng::unit_f32(state) * 2.0 - 1.0
            }));
        }
        while dirs.len() % 8 != 0 {
            dirs.push([0.0, 0.0, -1.0]);
        }
        for table in &tables {
            for block in dirs.chunks_exact(8) {
                let lanes: [[f32; 8]; 3] = std::array::from_fn(|c| std::array::from_fn(|l| block[l][c]));
                // SAFETY: the CPU has AVX2 (checked above); eight floats each.
                let got = unsafe {
                    let v = lanes.map(|a| _mm256_loadu_ps(a.as_ptr()));
                    crate::cpu::lanes::floats(avx2::table8(table, v))
                };
                for (d, g) in block.iter().zip(got) {
                    assert_eq!(g.to_bits(), table.sample(*d).to_bits(), "{d:?}");
                }
            }
        }
    }

    /// Every opening point of a texel computed in AVX2 blocks ([`avx2::points8`]) equals
    /// [`OpeningView::point`] bit for bit (value, end point, direction, distance), and is absent
    /// where it is: boxes with one end, both ends or every face, cylinders with and without
    /// their mantle, ellipsoids, along each photometric axis, a rotated lamp, real tables (a
    /// linear pendant, a box pendant) and an isotropic one, receivers from a millimetre to
    /// metres away in every direction, on every side of the parts.
    #[test]
    fn points_in_lanes_equal_the_point_by_point_ones() {
        const TEST: &str = "points_in_lanes_equal_the_point_by_point_ones";
        let Some(mut tables) = lane_tables(TEST, &["rw_5.IES", "rw_1.IES"]) else {
            return;
        };
        tables.push(Photometry::isotropic(250.0).gpu_table());
        let axis = normalize([0.3, 0.8, -0.5]).expect("unit axis");
        let mut openings = Vec::new();
        for (kind, faces, half) in [
            (0, 1, [0.03, 0.31, 0.0]),
            (0, 3, [0.2, 0.1, 0.05]),
            (0, 7, [0.25, 0.15, 0.1]),
            (1, 1, [0.08, 0.08, 0.0]),
            (1, 7, [0.12, 0.06, 0.2]),
            (2, 4, [0.1, 0.15, 0.07]),
        ] {
            for axis in 0..3 {
                openings.push(OpeningParams {
                    kind,
                    axis,
                    faces,
                    half,
                    near: f32::MAX,
                    size: 0.3,
                });
            }
        }
        let mut state = 0x2545_f491u32;
        let mut uniform = || {
            state = rng::pcg(state);
            rng::unit_f32(state)
        };
        let (mut compared, mut lit) = (0usize, 0usize);
        for (t, table) in tables.iter().enumerate() {
            for (i, o) in openings.iter().enumerate() {
                let lamp = LampParams {
                    position: [0.4, 2.1, -0.3],
                    world_to_photometric: rotation(axis, 0.7 * (i + t) as f32),
                    scale: [1.0; 3],
                    table: 0,
                    opening: Some(*o),
                };
                for r in 0..24 {
                    // Receivers from a millimetre to three metres away, every direction.
                    let reach = [0.001, 0.05, 0.3, 1.0, 3.0][r % 5];
                    let dir = normalize([uniform() - 0.5, uniform() - 0.5, uniform() - 0.5])
                        .unwrap_or([0.0, -1.0, 0.0]);
                    let p = [0, 1, 2].map(|c| lamp.position[c] + dir[c] * (reach + 0.3));
                    let n = normalize([uniform() - 0.5, uniform() - 0.5, uniform() - 0.5])
                        .unwrap_or([0.0, 1.0, 0.0]);
                    let start = Start::new(p, n, 1e-4);
                    let view = OpeningView {
                        table,
                        lamp: &lamp,
                        o,
                        start: &start,
                        shift: [rng::pcg(r as u32), rng::pcg(r as u32 + 99)],
                    };
                    let m = &lamp.world_to_photometric;
                    let rel = sub(p, lamp.position);
                    let receiver = [dot(m[0], rel), dot(m[1], rel), dot(m[2], rel)];
                    for part in 0..6 {
                        if !(opening::part_areas(o)[part] > 0.0) {
                            continue;
                        }
                        let sampler = opening::PartSampler::new(o, part, Some(receiver));
                        for count in [8, 48, 96, 200] {
                            for k0 in (0..count).step_by(8) {
                                // Consecutive points, and every fourth as the probes.
                                let step = if k0 % 16 == 0 { 1 } else { 4 };
                                let ks = std::array::from_fn(|l| k0 + step * l as u32);
                                // SAFETY: the CPU has AVX2 (checked above).
                                let block = unsafe { avx2::points8(&view, &sampler, ks, count) };
                                let block = block.expect("every part toward a receiver in lanes");
                                for (k, lane) in ks.into_iter().zip(block) {
                                    let scalar = view.point(&sampler, k, count);
                                    let bits = |p: &PointView| {
                                        let mut b = vec![p.value, p.geom, p.r(), p.r2];
                                        b.extend(p.x);
                                        b.extend(p.back);
                                        b.iter().map(|v| v.to_bits()).collect::<Vec<u32>>()
                                    };
                                    assert_eq!(
                                        lane.as_ref().map(bits),
                                        scalar.as_ref().map(bits),
                                        "table {t}, opening {o:?}, part {part}, receiver {p:?}, \
                                         normal {n:?}, point {k} of {count}"
                                    );
                                    compared += 1;
                                    lit += usize::from(scalar.is_some());
                                }
                            }
                            // The blocks as the pass fills them: the probes (every fifth
                            // here) eight at a time, the last block padded, then a chunk's
                            // other points.
                            let wanted = |k: u32| k.is_multiple_of(5) || (count / 3..count / 2).contains(&k);
                            let mut out: Vec<Option<PointView>> = (0..count).map(|_| None).collect();
                            view.fill(&sampler, count, (0..count).step_by(5), &mut out);
                            let rest = (count / 3..count / 2).filter(|k| !k.is_multiple_of(5));
                            view.fill(&sampler, count, rest, &mut out);
                            let expected: Vec<Option<PointView>> = (0..count)
                                .map(|k| wanted(k).then(|| view.point(&sampler, k, count)).flatten())
                                .collect();
                            let bits = |p: &Option<PointView>| {
                                p.as_ref().map(|p| {
                                    [p.value, p.geom, p.r(), p.x[0], p.back[2]].map(f32::to_bits)
                                })
                            };
                            assert_eq!(
                                out.iter().map(bits).collect::<Vec<_>>(),
                                expected.iter().map(bits).collect::<Vec<_>>(),
                                "points of {count}, opening {o:?}, part {part}"
                            );
                        }
                    }
                }
            }
        }
        // Both outcomes were compared many times.
        assert!(lit > 10_000 && compared - lit > 10_000, "{lit} lit of {compared}");
    }
}
