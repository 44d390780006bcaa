//! Light from a lamp's luminous opening: the near field of a luminaire with a size.
//!
//! # The model
//! A photometric file gives the intensity `I(ω)` of the whole luminaire, measured far away, and
//! the size and shape of its luminous opening ([`luxbake_ies::Emitter`]). As Radiance's
//! `ies2rad` does, the opening is a surface of **uniform luminance** per direction,
//! `L(ω) = I(ω) / A_proj(ω)`, `A_proj(ω)` the projected area of its emitting parts seen from
//! direction `ω` ([`projected_area`]): far away it sends exactly the file's intensity, near it
//! the light comes from the whole opening — softer, lower under a long luminaire's ends, and
//! the top of a box pendant lights the ceiling from its real height.
//!
//! # The estimator
//! The illuminance of a receiver at `p` (unit normal `n`) is
//! `E(p) = ∫ L(ω_x)·cos θ_x·cos θ_p / r² · V(x, p) dA_x` over the emitting surface, `ω_x` the
//! direction from `x` toward `p`. [`sample_part`] maps two uniforms to a point `x` of one part,
//! its outward normal `n_x` and a weight `W` (area element over probability density), so that
//! `E[g(x)·W] = ∫ g dA` over the part; with `S` samples ([`texel_samples`])
//!
//! ```text
//! E(p) ≈ Σ_parts 1/S_j · Σ_k I(ω_k)·max(0, n_k·ω_k)·W_k / A_proj(ω_k) · cos θ_p / max(r², off², W_k/(π S_j))
//! ```
//!
//! each sample with its own shadow ray from `p` to `x_k`; the `S` samples of a texel are shared
//! among the parts it can see ([`visible_areas`], [`counts`]), `S_j` on part `j`. The last term
//! of the denominator bounds each sample's share where the receiver touches the opening (a
//! lamp against the ceiling): a sample stands for `W/S_j` of the surface, whose light on a
//! point is at most `π L` — so no single sample can exceed what its patch can give, and no
//! spike reaches a light map.
//!
//! The samples are a Fibonacci lattice ([`lattice`]) shifted per texel by the hash of
//! [`crate::rng`] (Cranley–Patterson rotation, pass [`OPENING_PASS`], the lamp's index as the
//! sample): well spread over the opening for every texel, independent between texels. A flat
//! part is sampled as the receiver sees it ([`toward`]), so that where the lamp is fully seen
//! the integrand is smooth and a few lattice points integrate it to under a per cent even a
//! fraction of the opening's size away; in a penumbra the shift turns the structured error
//! into noise.
//!
//! # Probes
//! Most texels see the whole opening or none of it, and there every shadow ray returns the same
//! answer. A bake's direct pass therefore first casts the rays of every `stride`-th point of each
//! part's lattice (`Settings::opening_probe_stride`, 4 in every preset: 12 probes of the
//! `default` preset's 48 points, 24 of 96), among those that give the texel light; when all of
//! them reach the opening the texel's other points are taken as seen without a ray — the very
//! sum every ray would give where the opening is wholly in view (or a part's control variate,
//! below) — and when any is blocked every point casts its own ray, as without probes. The
//! estimate differs from the exhaustive one only where an occluder hides part of the opening
//! between the probes of a texel whose probes all see it (there it is higher), and by the
//! control variate's noise; a texel in shadow casts at most one ray more than before.
//! Calculation points (`crate::probe::direct_at`) cast every ray.
//!
//! # Control variate
//! Where a texel's probes all see the opening, a box's rectangle or a cylinder's circular end
//! is not summed over its points: its share is estimated from its probes alone with the control
//! variate `g(x) = L_c·cos θ_x·cos θ_p / r²`, `L_c` the part's luminance toward the receiver
//! from the part's centre, whose integral `L_c·G` has a closed form ([`part_control`]:
//! Lambert's formula for a polygon, [`rectangle_control`], or on a circle, [`disk_control`]):
//!
//! ```text
//! E_j ≈ L_c·G + 1/P · Σ_probes (value_k − L_c·geom_k)
//! ```
//!
//! `value_k` a probe's share as in the sum above, `geom_k = cos θ_x·W_k·cos θ_p / r²` the same
//! point's share of `G`, `P` the part's probes. Its expectation over the lattice's shift is the
//! sum's, `∫ f dA`, whatever `L_c`; what the probes estimate is only how the luminance varies
//! over the part, `(L(ω_x) − L_c)·cos θ_x·cos θ_p / r²` (a Lambertian part, whose luminance is
//! the same in every direction, is its closed form at any sample count). That is small where
//! the part is seen from afar, and there 12 probes do what 48 points did; near a long
//! luminaire the luminance changes across the part as seen from the texel, and 12 probes would
//! not. So the probes judge themselves: the part takes their estimate only where the standard
//! error of their residuals' mean, from their scatter, is at most [`CONTROL_MAX_ERROR`] of it
//! (with at least [`CONTROL_MIN_PROBES`] probes); the other points of such a part are neither
//! evaluated nor summed. Elsewhere — a cylinder's mantle, an elliptical end, an ellipsoid, a
//! part partly behind the receiver's plane or whose formula's terms cancel
//! ([`CONTROL_MAX_CANCELLATION`]), a probe that gives the texel nothing, a luminance toward it
//! that is not positive, probes that scatter — every point is summed as above. (The disk's
//! form was first computed by the trapezoidal rule on its rim, 32 nodes: its CPU direct pass
//! took 1.21× as long, so it was not kept; [`disk_control`]'s integral of the rim in closed
//! form costs a square root.)
//!
//! # Where it is used
//! [`OpeningParams::near`]: texels nearer the lamp's photometric centre than that evaluate the
//! opening, farther ones the point as before ([`crate::scene::LampModel`] says how `auto`
//! chooses the lamps and the distance). A lamp without opening parameters is a
//! point everywhere and costs exactly what it cost before.
//!
//! The shaders' `luxOpening*` (`shaders/lib/opening.glsl`) and `lux_opening_*`
//! (`opening.wgsl`) mirror these functions operation for operation.

// `!(x > 0.0)` on purpose: a NaN fails the test, as in the shaders.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::exact::dot;
use crate::rng;

/// The RNG pass of the openings' per-texel lattice shift.
pub const OPENING_PASS: u32 = 0x6f70_656e;

/// The golden ratio's fraction `round(2³²·(√5 − 1)/2)`: the Fibonacci lattice's step.
pub const PHI: u32 = 2_654_435_769;

/// Opening samples per texel at most ([`crate::scene::Settings::opening_samples`]).
pub use luxbake_scene::MAX_OPENING_SAMPLES as MAX_SAMPLES;

/// A lamp's luminous opening as the shaders see it: [`luxbake_ies::Emitter`] in `f32`, and the
/// distance within which texels use it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OpeningParams {
    /// The solid: 0 box, 1 cylinder, 2 ellipsoid ([`luxbake_ies::SolidKind`]).
    pub kind: u32,
    /// Photometric axis of the solid's axis `w`: 0 = X, 1 = Y, 2 = Z (`u`, `v` follow
    /// cyclically).
    pub axis: u32,
    /// Emitting parts: 1 the end facing −w, 2 the end facing +w, 4 the sides.
    pub faces: u32,
    /// Semi-axes along `u`, `v`, `w`, metres.
    pub half: [f32; 3],
    /// Texels nearer than this to the photometric centre (metres) see the opening; farther
    /// ones the point. `f32::MAX`: everywhere.
    pub near: f32,
    /// The opening's size `D = 2·√(2⟨ρ²⟩)` (a disk's diameter; [`texel_samples`]), metres.
    pub size: f32,
}

impl OpeningParams {
    /// The opening of `emitter` used within `near` metres; `None` when it has no emitting area.
    pub fn new(emitter: &luxbake_ies::Emitter, near: f32) -> Option<OpeningParams> {
        let o = OpeningParams {
            kind: emitter.kind as u32,
            axis: u32::from(emitter.axis).min(2),
            faces: u32::from(emitter.faces) & 7,
            half: emitter.half.map(|h| h as f32),
            near,
            size: (2.0 * (2.0 * emitter.mean_square_radius()).sqrt()) as f32,
        };
        (part_areas(&o).iter().sum::<f32>() > 0.0).then_some(o)
    }
}

/// One sample of an opening ([`sample`]), in the photometric frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OpeningSample {
    /// Point on the emitting surface, metres from the photometric centre.
    pub point: [f32; 3],
    /// Outward unit normal there.
    pub normal: [f32; 3],
    /// Area element over probability density: `E[g·weight] = ∫ g dA`.
    pub weight: f32,
}

/// The parts' areas that pick a part in [`sample`], in order: box `[end −w, end +w, +u, −u,
/// +v, −v]`; cylinder `[end −w, end +w, mantle]` (the mantle's by the perimeter
/// `2π·√((a² + b²)/2)`, exact for a circle); ellipsoid `[surface]` (its samples carry their
/// exact area element, so these need not be exact areas). Zero for parts that do not emit.
pub fn part_areas(o: &OpeningParams) -> [f32; 6] {
    let [a, b, c] = o.half;
    let on = |bit: u32, v: f32| if o.faces & bit != 0 { v } else { 0.0 };
    match o.kind {
        0 => {
            let end = 4.0 * a * b;
            [
                on(1, end),
                on(2, end),
                on(4, 4.0 * b * c),
                on(4, 4.0 * b * c),
                on(4, 4.0 * a * c),
                on(4, 4.0 * a * c),
            ]
        }
        1 => {
            let end = std::f32::consts::PI * a * b;
            let mantle = std::f32::consts::TAU * 2.0 * c * (0.5 * (a * a + b * b)).sqrt();
            [on(1, end), on(2, end), on(4, mantle), 0.0, 0.0, 0.0]
        }
        _ => {
            let s = 4.0 * std::f32::consts::PI * (a * b + b * c + a * c) / 3.0;
            [on(4, s), 0.0, 0.0, 0.0, 0.0, 0.0]
        }
    }
}

/// Photometric-frame vector of solid-frame `(u, v, w)`.
#[inline]
pub fn to_photometric(axis: u32, s: [f32; 3]) -> [f32; 3] {
    match axis {
        0 => [s[2], s[0], s[1]],
        1 => [s[1], s[2], s[0]],
        _ => s,
    }
}

/// Solid-frame `(u, v, w)` of photometric-frame vector `p`.
#[inline]
pub fn to_solid(axis: u32, p: [f32; 3]) -> [f32; 3] {
    match axis {
        0 => [p[1], p[2], p[0]],
        1 => [p[2], p[0], p[1]],
        _ => p,
    }
}

/// A flat part's plane: `(axis of its normal in (u, v, w), side ±1, half-extents along its
/// two in-plane axes, ellipse?)`; `None` for a curved part (a mantle, an ellipsoid).
fn flat_part(o: &OpeningParams, part: usize) -> Option<(usize, f32, [f32; 2], bool)> {
    let [a, b, c] = o.half;
    match (o.kind, part) {
        (0, 0 | 1) => Some((2, if part == 0 { -1.0 } else { 1.0 }, [a, b], false)),
        (0, 2 | 3) => Some((0, if part == 2 { 1.0 } else { -1.0 }, [b, c], false)),
        (0, _) => Some((1, if part == 4 { 1.0 } else { -1.0 }, [a, c], false)),
        (1, 0 | 1) => Some((2, if part == 0 { -1.0 } else { 1.0 }, [a, b], true)),
        _ => None,
    }
}

/// The in-plane axes of a plane whose normal lies along `axis`, in (u, v, w) order.
#[inline]
fn in_plane(axis: usize) -> (usize, usize) {
    match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

/// How far `receiver` (solid frame) lies in front of flat part `part`'s plane (≤ 0: behind or
/// in it: the part gives it no light); `f32::MAX` for a curved part.
fn height_over(o: &OpeningParams, part: usize, r: [f32; 3]) -> f32 {
    match flat_part(o, part) {
        Some((axis, side, _, _)) => side * (r[axis] - side * o.half[axis]),
        None => f32::MAX,
    }
}

/// The parts' areas ([`part_areas`]) that a receiver (photometric frame) can see: flat parts
/// it lies behind count 0.
pub fn visible_areas(o: &OpeningParams, receiver: [f32; 3]) -> [f32; 6] {
    let r = to_solid(o.axis, receiver);
    let mut areas = part_areas(o);
    for (part, a) in areas.iter_mut().enumerate() {
        if !(height_over(o, part, r) > 0.0) {
            *a = 0.0;
        }
    }
    areas
}

/// `n` samples shared among the parts of `areas` in proportion to them, at least one for every
/// part of positive area: `max(1, round(n·Aⱼ/ΣA))`. Each part gets its own lattice of that
/// many points ([`lattice`]), so every part is sampled evenly (drawing the part of each sample
/// from a third lattice dimension instead left bands of a part unsampled: its points are a
/// slice of one lattice).
pub fn counts(areas: &[f32; 6], n: u32) -> [u32; 6] {
    let total: f32 = areas.iter().sum();
    let mut out = [0u32; 6];
    if !(total > 0.0) {
        return out;
    }
    for (c, &a) in out.iter_mut().zip(areas) {
        if a > 0.0 {
            *c = ((n as f32 * a / total + 0.5) as u32).max(1);
        }
    }
    out
}

/// The point, normal and weight of uniforms `u` on part `part` of the opening (see the module
/// docs): `E[g·weight] = ∫ g dA` over the part. Toward a `receiver` (photometric frame, metres
/// from the centre) a flat part — a box face, a cylinder's end — is sampled as the receiver
/// sees it ([`toward`]; `None` when it lies behind the part), a curved one uniformly; without
/// one every part uniformly (the lamp paths' origins). `None` also for a degenerate point.
pub fn sample_part(
    o: &OpeningParams,
    part: usize,
    u: [f32; 2],
    receiver: Option<[f32; 3]>,
) -> Option<OpeningSample> {
    PartSampler::new(o, part, receiver).sample(u)
}

/// [`sample_part`] for one part and one receiver, prepared once for all of a texel's lattice
/// points: what does not depend on the uniforms (the receiver's height over the part's plane,
/// its foot, the first coordinate's range and its density's normalisation) is computed here,
/// the rest per point, by the operations the shaders' `luxOpening*` / `lux_opening_*` run
/// per point (the cross-backend tests compare the direct light of openings texel by texel:
/// `tests/tests/loop_limit.rs`, `tests/tests/opening.rs`).
#[derive(Debug, Clone, Copy)]
pub struct PartSampler<'a> {
    o: &'a OpeningParams,
    part: usize,
    flat: Option<FlatView>,
}

/// A flat part as a receiver in front of it sees it ([`PartSampler`]): `None` in
/// [`FlatView::toward`] when the receiver is behind it.
#[derive(Debug, Clone, Copy)]
struct FlatView {
    axis: usize,
    side: f32,
    plane: f32,
    toward: Option<Toward>,
}

impl<'a> PartSampler<'a> {
    /// The sampler of part `part` of `o` toward `receiver` (photometric frame, metres from the
    /// centre; `None`: uniform in area, as for the lamp paths' origins).
    pub fn new(o: &'a OpeningParams, part: usize, receiver: Option<[f32; 3]>) -> PartSampler<'a> {
        let flat = match (flat_part(o, part), receiver) {
            (Some((axis, side, ext, ellipse)), Some(receiver)) => {
                let r = to_solid(o.axis, receiver);
                let (i, j) = in_plane(axis);
                let plane = side * o.half[axis];
                let h = side * (r[axis] - plane);
                Some(FlatView {
                    axis,
                    side,
                    plane,
                    toward: Toward::new(h, [r[i], r[j]], ext, ellipse),
                })
            }
            _ => None,
        };
        PartSampler { o, part, flat }
    }

    /// The point of uniforms `u` ([`sample_part`]).
    #[inline]
    pub fn sample(&self, u: [f32; 2]) -> Option<OpeningSample> {
        let (p, n, element) = match self.flat {
            Some(f) => {
                let (x, y, density) = f.toward?.draw(u)?;
                let (i, j) = in_plane(f.axis);
                let mut p = [0.0f32; 3];
                p[f.axis] = f.plane;
                p[i] = x;
                p[j] = y;
                let mut n = [0.0f32; 3];
                n[f.axis] = f.side;
                (p, n, 1.0 / density)
            }
            None => area_point(self.o, self.part, u)?,
        };
        Some(OpeningSample {
            point: to_photometric(self.o.axis, p),
            normal: to_photometric(self.o.axis, n),
            weight: element,
        })
    }
}

/// A point of the whole opening, uniform in area, for uniforms `u`: `u[2]` picks a part in
/// proportion to [`part_areas`] (`weight` includes that choice). The lamp paths' origins.
pub fn sample(o: &OpeningParams, u: [f32; 3]) -> Option<OpeningSample> {
    let areas = part_areas(o);
    let total: f32 = areas.iter().sum();
    if !(total > 0.0) {
        return None;
    }
    let part = pick(&areas, u[2] * total);
    let s = sample_part(o, part, [u[0], u[1]], None)?;
    Some(OpeningSample {
        weight: s.weight * total / areas[part],
        ..s
    })
}

/// The first part of positive area whose running sum of `areas` passes `target` (the last
/// such part at worst).
pub fn pick(areas: &[f32; 6], target: f32) -> usize {
    let mut part = 0usize;
    let mut run = 0.0f32;
    for (i, &a) in areas.iter().enumerate() {
        if a > 0.0 {
            part = i;
            run += a;
            if target < run {
                break;
            }
        }
    }
    part
}

/// A point of flat part `part`, or of a curved one, uniform in area: `(point, normal, area
/// element)` in the solid frame.
fn area_point(o: &OpeningParams, part: usize, u: [f32; 2]) -> Option<([f32; 3], [f32; 3], f32)> {
    let [a, b, c] = o.half;
    let (s0, s1) = (2.0 * u[0] - 1.0, 2.0 * u[1] - 1.0);
    Some(match (o.kind, part) {
        (0, 0) => ([a * s0, b * s1, -c], [0.0, 0.0, -1.0], 4.0 * a * b),
        (0, 1) => ([a * s0, b * s1, c], [0.0, 0.0, 1.0], 4.0 * a * b),
        (0, 2) => ([a, b * s0, c * s1], [1.0, 0.0, 0.0], 4.0 * b * c),
        (0, 3) => ([-a, b * s0, c * s1], [-1.0, 0.0, 0.0], 4.0 * b * c),
        (0, 4) => ([a * s0, b, c * s1], [0.0, 1.0, 0.0], 4.0 * a * c),
        (0, _) => ([a * s0, -b, c * s1], [0.0, -1.0, 0.0], 4.0 * a * c),
        (1, 0 | 1) => {
            let r = u[0].sqrt();
            let (sin, cos) = turns(u[1]);
            let side = if part == 0 { -1.0 } else { 1.0 };
            (
                [a * r * cos, b * r * sin, side * c],
                [0.0, 0.0, side],
                std::f32::consts::PI * a * b,
            )
        }
        (1, _) => {
            let (sin, cos) = turns(u[1]);
            let g = [b * cos, a * sin, 0.0];
            let len = dot(g, g).sqrt();
            if !(len > 0.0) {
                return None;
            }
            (
                [a * cos, b * sin, c * s0],
                [g[0] / len, g[1] / len, 0.0],
                std::f32::consts::TAU * 2.0 * c * len,
            )
        }
        _ => {
            let z = 1.0 - 2.0 * u[0];
            let r = (1.0 - z * z).max(0.0).sqrt();
            let (sin, cos) = turns(u[1]);
            let s = [r * cos, r * sin, z];
            let g = [b * c * s[0], a * c * s[1], a * b * s[2]];
            let len = dot(g, g).sqrt();
            if !(len > 0.0) {
                return None;
            }
            (
                [a * s[0], b * s[1], c * s[2]],
                [g[0] / len, g[1] / len, g[2] / len],
                4.0 * std::f32::consts::PI * len,
            )
        }
    })
}

/// A point of a flat part as a receiver `h` in front of its plane sees it: `(x, y, density
/// per unit area)`, `x`, `y` in the plane's axes, the part `[−e₀, e₀] × [−e₁, e₁]` with
/// `ext = [e₀, e₁]` (or the ellipse of those semi-axes), the receiver's foot on the plane at
/// `foot`. `None` when the receiver is not in front of the plane (the part gives it no light)
/// or the part is empty.
///
/// A uniform patch lights a receiver parallel to it as `h² / r⁴` (`cos θ_x cos θ_p / r²`),
/// brightest at the foot. Each coordinate is drawn from the density `∝ (s² + t²)^(−3/2)`
/// truncated to the part ([`falloff`]): `x − foot₀` with `s = √(h² + d₁²)` (`d₁` the foot's
/// distance outside the part's `y` range, 0 inside), then `y − foot₁` on the part's chord at
/// `x` with `s = √(h² + (x − foot₀)²)`. Their product falls off nearly as the light does, so
/// the light over the density is smooth and bounded, and a few lattice points integrate it
/// well for a receiver a fraction of the part's size away: under a disk at h/D = 0.25, 256
/// points are within 0.3 % (uniform points: ±4 %), 32 within 3 % at worst, 0.6 % on average.
pub fn toward(
    u: [f32; 2],
    h: f32,
    foot: [f32; 2],
    ext: [f32; 2],
    ellipse: bool,
) -> Option<(f32, f32, f32)> {
    Toward::new(h, foot, ext, ellipse)?.draw(u)
}

/// [`toward`] prepared for one receiver: its first coordinate's [`Falloff`], which does not
/// depend on the uniforms.
#[derive(Debug, Clone, Copy)]
struct Toward {
    h: f32,
    foot: [f32; 2],
    ext: [f32; 2],
    ellipse: bool,
    first: Falloff,
}

impl Toward {
    fn new(h: f32, foot: [f32; 2], [e0, e1]: [f32; 2], ellipse: bool) -> Option<Toward> {
        if !(h > 0.0 && e0 > 0.0 && e1 > 0.0) {
            return None;
        }
        let out = (foot[1].abs() - e1).max(0.0);
        let sx = (h * h + out * out).sqrt();
        Some(Toward {
            h,
            foot,
            ext: [e0, e1],
            ellipse,
            first: Falloff::new(sx, -e0 - foot[0], e0 - foot[0])?,
        })
    }

    #[inline]
    fn draw(&self, u: [f32; 2]) -> Option<(f32, f32, f32)> {
        let (h, foot, [e0, e1]) = (self.h, self.foot, self.ext);
        let (dx, px) = self.first.draw(u[0]);
        let x = (foot[0] + dx).clamp(-e0, e0);
        let half = if self.ellipse {
            let q = x / e0;
            e1 * (1.0 - q * q).max(0.0).sqrt()
        } else {
            e1
        };
        let sy = (h * h + dx * dx).sqrt();
        let (dy, py) = falloff(u[1], sy, -half - foot[1], half - foot[1])?;
        let y = (foot[1] + dy).clamp(-half, half);
        let density = px * py;
        (density > 0.0 && density.is_finite()).then_some((x, y, density))
    }
}

/// A draw `t ∈ [lo, hi]` of the density `∝ (s² + t²)^(−3/2)` by its inverse CDF, with that
/// density: `G(t) = t / √(s² + t²)` is uniform in `[G(lo), G(hi)]`, `t = s·g / √(1 − g²)`,
/// density `s² / ((s² + t²)^(3/2)·(G(hi) − G(lo)))`. `None` for an empty range.
#[inline]
pub fn falloff(u: f32, s: f32, lo: f32, hi: f32) -> Option<(f32, f32)> {
    Some(Falloff::new(s, lo, hi)?.draw(u))
}

/// [`falloff`] prepared for one range: `G(lo)` and the span `G(hi) − G(lo)`.
#[derive(Debug, Clone, Copy)]
struct Falloff {
    s: f32,
    lo: f32,
    hi: f32,
    g0: f32,
    span: f32,
}

impl Falloff {
    #[inline]
    fn new(s: f32, lo: f32, hi: f32) -> Option<Falloff> {
        let g = |t: f32| t / (s * s + t * t).sqrt();
        let (g0, g1) = (g(lo), g(hi));
        let span = g1 - g0;
        (span > 0.0).then_some(Falloff {
            s,
            lo,
            hi,
            g0,
            span,
        })
    }

    #[inline]
    fn draw(&self, u: f32) -> (f32, f32) {
        let (s, span) = (self.s, self.span);
        let q = self.g0 + u * span;
        let t = (s * q / (1.0 - q * q).max(0.0).sqrt()).clamp(self.lo, self.hi);
        let r2 = s * s + t * t;
        (t, s * s / (r2 * r2.sqrt() * span))
    }
}

/// `(sin 2πu, cos 2πu)` as the shaders compute it (`sin(6.2831855 * u)`, `cos(…)`).
#[inline]
fn turns(u: f32) -> (f32, f32) {
    let phi = std::f32::consts::TAU * u;
    (phi.sin(), phi.cos())
}

/// The projected area of the opening's emitting parts seen from photometric direction `w`
/// (unit, pointing away from the lamp): Σ over emitting parts of `∫ max(0, n·w) dA`. Box: the
/// end facing `w` `4ab·|w_w|`, the sides `4bc·|w_u| + 4ac·|w_v|`; cylinder: the end
/// `πab·|w_w|`, the mantle `4c·√(a²w_v² + b²w_u²)` (its silhouette's width times its height);
/// ellipsoid `π·√((bc·w_u)² + (ac·w_v)² + (ab·w_w)²)`.
pub fn projected_area(o: &OpeningParams, w: [f32; 3]) -> f32 {
    let s = to_solid(o.axis, w);
    let [a, b, c] = o.half;
    let end_bit = if s[2] < 0.0 { 1 } else { 2 };
    let ends = if o.faces & end_bit != 0 {
        s[2].abs()
    } else {
        0.0
    };
    let sides = o.faces & 4 != 0;
    match o.kind {
        0 => {
            let mut area = 4.0 * a * b * ends;
            if sides {
                area += 4.0 * b * c * s[0].abs() + 4.0 * a * c * s[1].abs();
            }
            area
        }
        1 => {
            let mut area = std::f32::consts::PI * a * b * ends;
            if sides {
                area += 4.0 * c * (a * a * s[1] * s[1] + b * b * s[0] * s[0]).sqrt();
            }
            area
        }
        _ => {
            if !sides {
                return 0.0;
            }
            let (x, y, z) = (b * c * s[0], a * c * s[1], a * b * s[2]);
            std::f32::consts::PI * (x * x + y * y + z * z).sqrt()
        }
    }
}

/// The control variate's bound (module docs, "Control variate"): a part takes the estimate
/// from its probes alone where the standard error of their residuals' mean, as their scatter
/// gives it, is at most this share of the estimate; elsewhere every point is summed. Measured
/// (`bench nearfield` against Radiance, 747 points; `chairs_05`'s direct light from `rw_5`
/// against 1 024 points with every ray, 24 texels/m, two seeds): at 0.3 % every near-field
/// room reads as with every point summed (dining 0.15, office 0.21, round 0.27, box 0.22 %
/// mean) and `chairs_05` 0.493 against 0.509 %; at 0.5 % `chairs_05` 0.491 %, the round
/// room's disks 0.28 %; without the bound the probes took the office's 2 m linear luminaire
/// 0.5 m over a desk to 0.69 % and the box pendant under a ceiling to 0.88 %, where the
/// luminance varies across the part as seen from near; at 0.1 % `chairs_05` 0.507 %.
pub const CONTROL_MAX_ERROR: f32 = 0.003;

/// The fewest probes of a part whose scatter [`CONTROL_MAX_ERROR`] judges.
pub const CONTROL_MIN_PROBES: u32 = 4;

/// A rectangular part's geometric integral toward a receiver at `receiver` with unit normal
/// `normal` (both in the photometric frame): `G = ∫ cos θ_x · cos θ_p / r² dA` over flat part
/// `part` of a box, in closed form by Lambert's formula for a polygon seen from a point,
/// `G = ½·|Σᵢ γᵢ · n·(vᵢ × vᵢ₊₁) / |vᵢ × vᵢ₊₁||` over its four edges (`vᵢ` its corners less the
/// receiver, `γᵢ = atan2(|vᵢ × vᵢ₊₁|, vᵢ·vᵢ₊₁)` the angle an edge subtends), and the unit
/// direction from the part's centre toward the receiver. The estimator's control variate where
/// a texel sees the whole opening ([`crate::opening`], "Control variate"). `None` for a part
/// that is no rectangle, or that the receiver does not see wholly: the receiver on or behind
/// the part's plane, or a corner on or under the receiver's.
pub fn rectangle_control(
    o: &OpeningParams,
    part: usize,
    receiver: [f32; 3],
    normal: [f32; 3],
) -> Option<(f32, [f32; 3])> {
    if o.kind != 0 {
        return None;
    }
    let (axis, plane, _, ext) = facing(o, part, receiver)?;
    let (i, j) = in_plane(axis);
    let at = |x: f32, y: f32| {
        let mut c = [0.0f32; 3];
        c[axis] = plane;
        c[i] = x;
        c[j] = y;
        crate::exact::sub(to_photometric(o.axis, c), receiver)
    };
    let v = [
        at(-ext[0], -ext[1]),
        at(ext[0], -ext[1]),
        at(ext[0], ext[1]),
        at(-ext[0], ext[1]),
    ];
    if !v.iter().all(|&c| dot(normal, c) > 0.0) {
        return None;
    }
    let (mut sum, mut magnitude) = (0.0f32, 0.0f32);
    for k in 0..4 {
        let c = crate::exact::cross(v[k], v[(k + 1) % 4]);
        let len = dot(c, c).sqrt();
        if !(len > 0.0) {
            return None;
        }
        let gamma = luxbake_ies::atan2_f32(len, dot(v[k], v[(k + 1) % 4]));
        let term = gamma * (dot(normal, c) / len);
        sum += term;
        magnitude += term.abs();
    }
    closed_form([sum, magnitude], 0.5 * sum.abs(), at(0.0, 0.0))
}

/// A flat part that a receiver (photometric frame) lies in front of: the axis of its normal
/// in (u, v, w), its plane's coordinate there, its side (±1) and its half-extents; `None` for
/// a curved part or a receiver on or behind the plane.
fn facing(
    o: &OpeningParams,
    part: usize,
    receiver: [f32; 3],
) -> Option<(usize, f32, f32, [f32; 2])> {
    let (axis, side, ext, _) = flat_part(o, part)?;
    (height_over(o, part, to_solid(o.axis, receiver)) > 0.0).then_some((
        axis,
        side * o.half[axis],
        side,
        ext,
    ))
}

/// A closed form `g` whose terms sum to `sum` with magnitudes adding to `magnitude`, and the
/// unit direction toward the receiver from the part's centre (`centre`: the centre less the
/// receiver); `None` where the terms cancel past [`CONTROL_MAX_CANCELLATION`] or a value is
/// not finite and positive.
fn closed_form([sum, magnitude]: [f32; 2], g: f32, centre: [f32; 3]) -> Option<(f32, [f32; 3])> {
    if !(magnitude <= CONTROL_MAX_CANCELLATION * sum.abs()) {
        return None;
    }
    let d = dot(centre, centre).sqrt();
    let toward = [-centre[0] / d, -centre[1] / d, -centre[2] / d];
    (g > 0.0 && g.is_finite() && d > 0.0 && d.is_finite()).then_some((g, toward))
}

/// A circular flat part's geometric integral toward a receiver ([`rectangle_control`]'s
/// `G = ∫ cos θ_x · cos θ_p / r² dA` and direction from the part's centre): a cylinder's end
/// whose semi-axes are equal (a disk of radius `R`), in closed form. Lambert's formula on the
/// disk's rim, `G = ½·|∮ n·(r × dr) / |r|²|`, with `r = d + R·(u cos t + v sin t)` (`d` the
/// centre less the receiver, `u`, `v`, `f = u × v` the disk's axes), is a rational function of
/// `cos t` and `sin t` over a full turn, which integrates to
///
/// ```text
/// G = π R² / s · |n·f − 2·((n·f)·|d|² − (n·d)(d·f)) / (|d|² + R² + s)|,
/// s = √((|d|² − R²)² + 4 R² (d·f)²)
/// ```
///
/// (`∫ dt / (a + b cos t + c sin t) = 2π / s` and `∫ cos t / (…) dt = −2π b / (s (a + s))`
/// over a turn, `s² = a² − b² − c²`): on the axis `π R² / (h² + R²)`, far away
/// `π R² cos θ_x cos θ_p / |d|²`. `None` for a part that is no circle, or that the receiver
/// does not see wholly: the receiver on or behind the disk's plane, or a point of its rim on or
/// under the receiver's plane (`n·d ≤ R·√(1 − (n·f)²)`), or terms that cancel past
/// [`CONTROL_MAX_CANCELLATION`] (far away at a grazing angle).
pub fn disk_control(
    o: &OpeningParams,
    part: usize,
    receiver: [f32; 3],
    normal: [f32; 3],
) -> Option<(f32, [f32; 3])> {
    if o.kind != 1 {
        return None;
    }
    let (axis, plane, side, [radius, other]) = facing(o, part, receiver)?;
    if radius != other {
        return None;
    }
    let mut c = [0.0f32; 3];
    c[axis] = plane;
    let mut f = [0.0f32; 3];
    f[axis] = side;
    let d = crate::exact::sub(to_photometric(o.axis, c), receiver);
    let f = to_photometric(o.axis, f);
    let (nf, nd, df, dd) = (dot(normal, f), dot(normal, d), dot(d, f), dot(d, d));
    if !(nd - radius * (1.0 - nf * nf).max(0.0).sqrt() > 0.0) {
        return None;
    }
    let r2 = radius * radius;
    let q = dd - r2;
    let s = (q * q + 4.0 * r2 * (df * df)).sqrt();
    let denominator = dd + r2 + s;
    let inner = nf * dd - nd * df;
    let sum = nf - 2.0 * inner / denominator;
    let magnitude = nf.abs() + 2.0 * (nf.abs() * dd + (nd * df).abs()) / denominator;
    closed_form(
        [sum, magnitude],
        std::f32::consts::PI * r2 / s * sum.abs(),
        d,
    )
}

/// The closed form of part `part`'s geometric integral toward a receiver, where it has one:
/// [`rectangle_control`] for a box's face, [`disk_control`] for a cylinder's circular end.
pub fn part_control(
    o: &OpeningParams,
    part: usize,
    receiver: [f32; 3],
    normal: [f32; 3],
) -> Option<(f32, [f32; 3])> {
    match o.kind {
        0 => rectangle_control(o, part, receiver, normal),
        _ => disk_control(o, part, receiver, normal),
    }
}

/// Whether part `part` of `o` has a closed form ([`part_control`]) toward some receiver: a
/// box's faces, a cylinder's ends whose semi-axes are equal.
pub fn has_control(o: &OpeningParams, part: usize) -> bool {
    match flat_part(o, part) {
        Some((_, _, [a, b], ellipse)) => !ellipse || a == b,
        None => false,
    }
}

/// How much the terms of [`rectangle_control`]'s and [`disk_control`]'s closed forms may cancel:
/// the sum of their magnitudes at most this many times the magnitude of their sum. Lambert's
/// formula sums terms of about the part's size over its distance into the part's solid angle,
/// times the cosines: for a small part seen from afar, or at a grazing angle, most of them
/// cancel, and single precision keeps only `ε·Σ|term|` of the sum (a box pendant's 5 × 4 cm side
/// 1.7 m away at a grazing angle: 8·10⁻⁴ off, the terms 3 000 times the sum). At 512 a
/// closed form is within about 10⁻⁴, far under the lattice's noise the control variate
/// competes with; a part whose terms cancel more sums its points. (A linear pendant's
/// 6 × 61 cm opening seen from 2 m: its long edges' terms nearly cancel, about 60 times the
/// sum; at a bound of 64 `chairs_05`'s direct light from `rw_5` read 0.502 % against 1 024
/// points with every ray, 0.493 % at 512.)
pub const CONTROL_MAX_CANCELLATION: f32 = 512.0;

/// The uniforms of sample `k` of `n` on one part for a texel whose shift is `shift`
/// ([`shift`]): the Fibonacci lattice `((k + ½)/n, k·φ)` (φ = (√5 − 1)/2 as [`PHI`]), shifted
/// and wrapped: `u₀ = fract((k + 0.5)/n + unit(shift₀))`, `u₁ = unit(k·PHI + shift₁)`.
#[inline]
pub fn lattice(k: u32, n: u32, shift: [u32; 2]) -> [f32; 2] {
    let a = (k as f32 + 0.5) / n as f32 + rng::unit_f32(shift[0]);
    [
        a - a.floor(),
        rng::unit_f32(k.wrapping_mul(PHI).wrapping_add(shift[1])),
    ]
}

/// Opening samples of a texel `d` metres from the centre of opening `o`, for the setting
/// `samples` ([`crate::scene::Settings::opening_samples`]): `samples` from twice the opening's
/// size on, up to twice as many nearer, where the light varies most over the opening —
/// `round(samples · clamp(2·size/d, 1, 2))`. Measured against Radiance (`bench nearfield`): a
/// box pendant's top 0.46 m under a ceiling (rw_1, size 0.58 m) was up to 3.8 % off at 48
/// samples and 1.7 % at 96; fewer samples farther away (down to a quarter) let a disk's
/// uplight on a ceiling 1.5 m away err by 2.4 % where 48 gave 0.3 %, so there are none fewer.
#[inline]
pub fn texel_samples(o: &OpeningParams, d: f32, samples: u32) -> u32 {
    let f = (2.0 * o.size / d).clamp(1.0, 2.0);
    ((samples as f32 * f + 0.5) as u32).max(1)
}

/// The per-texel shift of lamp `lamp`'s lattices: `h = hash(texel, lamp, OPENING_PASS, seed)`,
/// `(h, pcg(h))`.
#[inline]
pub fn shift(texel: u32, lamp: u32, seed: u32) -> [u32; 2] {
    let h0 = rng::hash(texel, lamp, OPENING_PASS, seed);
    [h0, rng::pcg(h0)]
}

/// [`PartSampler::sample`] toward a receiver for eight uniforms at once, one to a lane of an
/// AVX2 vector: each lane runs the scalar operations in their order (IEEE single precision, no
/// fused multiply-adds), so its sample is the scalar one bit for bit (test
/// `points_in_lanes_equal_the_point_by_point_ones` in `passes/direct/cpu.rs`). The direct
/// pass's opening points on the CPU.
#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2 {
    use std::arch::x86_64::*;

    use super::*;

    /// Eight samples of one part in the photometric frame (lane by lane what
    /// [`PartSampler::sample`] returns); `ok` all ones in the lanes that have one.
    #[derive(Clone, Copy)]
    pub(crate) struct Samples8 {
        pub point: [__m256; 3],
        pub normal: [__m256; 3],
        pub weight: __m256,
        pub ok: __m256,
    }

    impl Samples8 {
        /// Samples whose point and normal are in the solid frame `(u, v, w)` of an opening
        /// whose axis is `axis` ([`to_photometric`] in every lane).
        fn solid(axis: u32, [p, n]: [[__m256; 3]; 2], weight: __m256, ok: __m256) -> Samples8 {
            let photometric = |v: [__m256; 3]| match axis {
                0 => [v[2], v[0], v[1]],
                1 => [v[1], v[2], v[0]],
                _ => v,
            };
            Samples8 {
                point: photometric(p),
                normal: photometric(n),
                weight,
                ok,
            }
        }
    }

    /// `x.clamp(lo, hi)` in every lane, as Rust computes it (a NaN stays a NaN).
    #[target_feature(enable = "avx2")]
    pub(crate) fn clamp8(x: __m256, lo: __m256, hi: __m256) -> __m256 {
        let x = _mm256_blendv_ps(x, lo, _mm256_cmp_ps::<_CMP_LT_OQ>(x, lo));
        _mm256_blendv_ps(x, hi, _mm256_cmp_ps::<_CMP_GT_OQ>(x, hi))
    }

    /// `√(max(x, 0))` in every lane (`x.max(0.0).sqrt()`: a NaN gives 0).
    #[target_feature(enable = "avx2")]
    fn sqrt_max0(x: __m256) -> __m256 {
        _mm256_sqrt_ps(_mm256_max_ps(x, _mm256_setzero_ps()))
    }

    /// All ones in the lanes where `x` is finite.
    #[target_feature(enable = "avx2")]
    pub(crate) fn finite8(x: __m256) -> __m256 {
        let abs = _mm256_andnot_ps(_mm256_set1_ps(-0.0), x);
        _mm256_cmp_ps::<_CMP_LT_OQ>(abs, _mm256_set1_ps(f32::INFINITY))
    }

    /// [`Falloff::draw`] in every lane: `(t, density)`.
    #[target_feature(enable = "avx2")]
    fn draw8([s, lo, hi, g0, span]: [__m256; 5], u: __m256) -> (__m256, __m256) {
        let q = _mm256_add_ps(g0, _mm256_mul_ps(u, span));
        let one = _mm256_set1_ps(1.0);
        let root = sqrt_max0(_mm256_sub_ps(one, _mm256_mul_ps(q, q)));
        let t = clamp8(_mm256_div_ps(_mm256_mul_ps(s, q), root), lo, hi);
        let ss = _mm256_mul_ps(s, s);
        let r2 = _mm256_add_ps(ss, _mm256_mul_ps(t, t));
        let density = _mm256_div_ps(
            ss,
            _mm256_mul_ps(_mm256_mul_ps(r2, _mm256_sqrt_ps(r2)), span),
        );
        (t, density)
    }

    impl PartSampler<'_> {
        /// [`PartSampler::sample`] at the uniforms `u` of eight lanes (a curved part's by
        /// `curved8`); `None` (nothing computed) for a flat part sampled without a receiver,
        /// which the caller samples point by point.
        #[target_feature(enable = "avx2")]
        pub(crate) fn sample8(&self, u: [__m256; 2]) -> Option<Samples8> {
            let Some(f) = self.flat else {
                return self.curved8(u);
            };
            let set = _mm256_set1_ps;
            let zero = _mm256_setzero_ps();
            let Some(t) = f.toward else {
                return Some(Samples8 {
                    point: [zero; 3],
                    normal: [zero; 3],
                    weight: zero,
                    ok: zero,
                });
            };
            let first = t.first;
            let (dx, px) = draw8(
                [first.s, first.lo, first.hi, first.g0, first.span].map(|v| set(v)),
                u[0],
            );
            let [e0, e1] = t.ext;
            let x = clamp8(_mm256_add_ps(set(t.foot[0]), dx), set(-e0), set(e0));
            let half = if t.ellipse {
                let q = _mm256_div_ps(x, set(e0));
                let root = sqrt_max0(_mm256_sub_ps(set(1.0), _mm256_mul_ps(q, q)));
                _mm256_mul_ps(set(e1), root)
            } else {
                set(e1)
            };
            let sy = _mm256_sqrt_ps(_mm256_add_ps(set(t.h * t.h), _mm256_mul_ps(dx, dx)));
            // The second coordinate's `Falloff::new` on the chord at `x`.
            let minus_half = _mm256_xor_ps(half, set(-0.0));
            let foot1 = set(t.foot[1]);
            let (lo, hi) = (_mm256_sub_ps(minus_half, foot1), _mm256_sub_ps(half, foot1));
            let ss = _mm256_mul_ps(sy, sy);
            let g = |v: __m256| {
                _mm256_div_ps(v, _mm256_sqrt_ps(_mm256_add_ps(ss, _mm256_mul_ps(v, v))))
            };
            let g0 = g(lo);
            let span = _mm256_sub_ps(g(hi), g0);
            let (dy, py) = draw8([sy, lo, hi, g0, span], u[1]);
            let y = clamp8(_mm256_add_ps(foot1, dy), minus_half, half);
            let density = _mm256_mul_ps(px, py);
            let ok = _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GT_OQ>(span, zero),
                _mm256_and_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(density, zero), finite8(density)),
            );
            let (i, j) = in_plane(f.axis);
            let mut p = [zero; 3];
            p[f.axis] = set(f.plane);
            p[i] = x;
            p[j] = y;
            let mut n = [zero; 3];
            n[f.axis] = set(f.side);
            Some(Samples8::solid(
                self.o.axis,
                [p, n],
                _mm256_div_ps(set(1.0), density),
                ok,
            ))
        }
    }

    impl PartSampler<'_> {
        /// [`PartSampler::sample`] of a curved part (a cylinder's mantle, an ellipsoid) at the
        /// uniforms of eight lanes: [`area_point`]'s operations, `sin` and `cos` of [`turns`]
        /// lane by lane with the scalar functions. `None` for a flat part sampled without a
        /// receiver (uniform in area: the lamp paths' origins, not the direct pass's).
        #[target_feature(enable = "avx2")]
        fn curved8(&self, u: [__m256; 2]) -> Option<Samples8> {
            use std::f32::consts::{PI, TAU};
            let set = _mm256_set1_ps;
            let zero = _mm256_setzero_ps();
            let [a, b, c] = self.o.half;
            let mut phi = [0.0f32; 8];
            // SAFETY: eight floats into an array of eight.
            unsafe { _mm256_storeu_ps(phi.as_mut_ptr(), _mm256_mul_ps(set(TAU), u[1])) };
            let (sin, cos) = (phi.map(f32::sin), phi.map(f32::cos));
            // SAFETY: eight floats from arrays of eight.
            let (sin, cos) =
                unsafe { (_mm256_loadu_ps(sin.as_ptr()), _mm256_loadu_ps(cos.as_ptr())) };
            let mul = _mm256_mul_ps;
            let dot = |g: [__m256; 3]| {
                _mm256_add_ps(
                    _mm256_add_ps(mul(g[0], g[0]), mul(g[1], g[1])),
                    mul(g[2], g[2]),
                )
            };
            let (p, g, element) = match (self.o.kind, self.part) {
                (1, 2) => {
                    let s0 = _mm256_sub_ps(mul(set(2.0), u[0]), set(1.0));
                    let g = [mul(set(b), cos), mul(set(a), sin), zero];
                    let p = [mul(set(a), cos), mul(set(b), sin), mul(set(c), s0)];
                    (p, g, set(TAU * 2.0 * c))
                }
                (2, _) => {
                    let z = _mm256_sub_ps(set(1.0), mul(set(2.0), u[0]));
                    let r = sqrt_max0(_mm256_sub_ps(set(1.0), mul(z, z)));
                    let s = [mul(r, cos), mul(r, sin), z];
                    let g = [
                        mul(set(b * c), s[0]),
                        mul(set(a * c), s[1]),
                        mul(set(a * b), s[2]),
                    ];
                    let p = [mul(set(a), s[0]), mul(set(b), s[1]), mul(set(c), s[2])];
                    (p, g, set(4.0 * PI))
                }
                _ => return None,
            };
            let len = _mm256_sqrt_ps(dot(g));
            // The mantle's normal has no w component (0, as the scalar writes it).
            let mantle = self.o.kind == 1;
            let n = [
                _mm256_div_ps(g[0], len),
                _mm256_div_ps(g[1], len),
                if mantle {
                    zero
                } else {
                    _mm256_div_ps(g[2], len)
                },
            ];
            Some(Samples8::solid(
                self.o.axis,
                [p, n],
                mul(element, len),
                _mm256_cmp_ps::<_CMP_GT_OQ>(len, zero),
            ))
        }
    }

    /// [`projected_area`] toward the photometric directions `w` of eight lanes.
    #[target_feature(enable = "avx2")]
    pub(crate) fn projected_area8(o: &OpeningParams, w: [__m256; 3]) -> __m256 {
        let s = match o.axis {
            0 => [w[1], w[2], w[0]],
            1 => [w[2], w[0], w[1]],
            _ => w,
        };
        let set = _mm256_set1_ps;
        let zero = _mm256_setzero_ps();
        let abs = |v: __m256| _mm256_andnot_ps(set(-0.0), v);
        let [a, b, c] = o.half;
        // The end facing `w` (−w where s₂ < 0), where it emits.
        let below = _mm256_cmp_ps::<_CMP_LT_OQ>(s[2], zero);
        let on = |bit: u32| {
            if o.faces & bit != 0 {
                set(f32::from_bits(!0))
            } else {
                zero
            }
        };
        let ends = _mm256_and_ps(abs(s[2]), _mm256_blendv_ps(on(2), on(1), below));
        let sides = o.faces & 4 != 0;
        match o.kind {
            0 => {
                let mut area = _mm256_mul_ps(set(4.0 * a * b), ends);
                if sides {
                    area = _mm256_add_ps(
                        area,
                        _mm256_add_ps(
                            _mm256_mul_ps(set(4.0 * b * c), abs(s[0])),
                            _mm256_mul_ps(set(4.0 * a * c), abs(s[1])),
                        ),
                    );
                }
                area
            }
            1 => {
                let mut area = _mm256_mul_ps(set(std::f32::consts::PI * a * b), ends);
                if sides {
                    let aa = _mm256_mul_ps(_mm256_mul_ps(set(a * a), s[1]), s[1]);
                    let bb = _mm256_mul_ps(_mm256_mul_ps(set(b * b), s[0]), s[0]);
                    let root = _mm256_sqrt_ps(_mm256_add_ps(aa, bb));
                    area = _mm256_add_ps(area, _mm256_mul_ps(set(4.0 * c), root));
                }
                area
            }
            _ => {
                if !sides {
                    return zero;
                }
                let x = _mm256_mul_ps(set(b * c), s[0]);
                let y = _mm256_mul_ps(set(a * c), s[1]);
                let z = _mm256_mul_ps(set(a * b), s[2]);
                let sum = _mm256_add_ps(
                    _mm256_add_ps(_mm256_mul_ps(x, x), _mm256_mul_ps(y, y)),
                    _mm256_mul_ps(z, z),
                );
                _mm256_mul_ps(set(std::f32::consts::PI), _mm256_sqrt_ps(sum))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(kind: u32, axis: u32, faces: u32, half: [f32; 3]) -> OpeningParams {
        OpeningParams {
            kind,
            axis,
            faces,
            half,
            near: f32::MAX,
            size: 0.1,
        }
    }

    /// Σ over parts of the mean of max(0, n·w)·W over a lattice on the part: the projected
    /// area.
    fn integrated(o: &OpeningParams, w: [f32; 3]) -> f64 {
        let n = counts(&part_areas(o), 1 << 16);
        let mut sum = 0.0f64;
        for (part, &nj) in n.iter().enumerate() {
            let mut part_sum = 0.0f64;
            for k in 0..nj {
                let u = lattice(k, nj, [0x1234_5678, 0x9abc_def0]);
                let s = sample_part(o, part, u, None).unwrap();
                part_sum += f64::from(dot(s.normal, w).max(0.0) * s.weight);
            }
            sum += part_sum / f64::from(nj.max(1));
        }
        sum
    }

    /// The closed forms of the control variate ([`part_control`]) against the geometric
    /// integral `∫ max(0, cos θ_x)·max(0, cos θ_p) / r² dA` summed over 2¹⁶ lattice points of
    /// the part in f64: every face of a box and a linear pendant's one rectangle, a cylinder's
    /// and a flat disk's circular ends, along each photometric axis, receivers from 0.2 to 3 m
    /// in every direction with every normal. Where a closed form is given it is within
    /// 2·10⁻⁴; it is refused where the part is partly behind the receiver's plane (the
    /// integral's cosine clips it) or the receiver behind the part, where its terms cancel
    /// ([`CONTROL_MAX_CANCELLATION`]: a small part far away or at a grazing angle), and for an
    /// elliptical end.
    #[test]
    fn part_controls_are_the_parts_geometric_integral() {
        let mut state = 0x9e37_79b9u32;
        let mut uniform = || {
            state = rng::pcg(state);
            rng::unit_f32(state)
        };
        let unit = |v: [f32; 3]| {
            let l = dot(v, v).sqrt();
            [v[0] / l, v[1] / l, v[2] / l]
        };
        let bound = f64::from(CONTROL_MAX_CANCELLATION);
        // Given, refused, refused for the terms' cancelling: rectangles, disks.
        let mut tally = [[0usize; 3]; 2];
        for axis in 0..3 {
            for o in [
                params(0, axis, 7, [0.3, 0.05, 0.04]),
                params(0, axis, 1, [0.03, 0.31, 0.0]),
                params(1, axis, 3, [0.1, 0.06, 0.05]),
                params(1, axis, 7, [0.08, 0.08, 0.05]),
                params(1, axis, 1, [0.11, 0.11, 0.0]),
            ] {
                let parts = if o.kind == 0 { 6 } else { 2 };
                for _ in 0..80 {
                    let dir = unit([uniform() - 0.5, uniform() - 0.5, uniform() - 0.5]);
                    let reach = 0.2 + 2.8 * uniform();
                    let receiver = dir.map(|c| c * reach);
                    let normal = unit([uniform() - 0.5, uniform() - 0.5, uniform() - 0.5]);
                    for part in 0..parts {
                        if part_areas(&o)[part] == 0.0 {
                            continue;
                        }
                        let n = 1u32 << 16;
                        let mut brute = 0.0f64;
                        let mut clipped = false;
                        for k in 0..n {
                            let sample = sample_part(&o, part, lattice(k, n, [3, 5]), None);
                            let Some(x) = sample else { continue };
                            let v: [f64; 3] =
                                std::array::from_fn(|c| f64::from(x.point[c] - receiver[c]));
                            let r2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
                            let r = r2.sqrt();
                            let cos_x =
                                -(0..3).map(|c| f64::from(x.normal[c]) * v[c]).sum::<f64>() / r;
                            let cos_p =
                                (0..3).map(|c| f64::from(normal[c]) * v[c]).sum::<f64>() / r;
                            clipped |= cos_p <= 0.0 && cos_x > 0.0;
                            brute += cos_x.max(0.0) * cos_p.max(0.0) / r2 * f64::from(x.weight);
                        }
                        brute /= f64::from(n);
                        let solid = to_solid(o.axis, receiver);
                        let behind = !(height_over(&o, part, solid) > 0.0);
                        let tally = &mut tally[o.kind as usize];
                        match part_control(&o, part, receiver, normal) {
                            Some((g, toward)) => {
                                tally[0] += 1;
                                assert!(has_control(&o, part));
                                assert!(!clipped && !behind, "{o:?} part {part} from {receiver:?}");
                                let g = f64::from(g);
                                assert!(
                                    (g - brute).abs() <= 2e-4 * brute,
                                    "{o:?} part {part} from {receiver:?}, normal {normal:?}: \
                                     {g} vs {brute}"
                                );
                                assert!((dot(toward, toward) - 1.0).abs() < 1e-5);
                            }
                            None => {
                                tally[1] += 1;
                                // Rectangle: the part's solid angle times the cosines over its
                                // size over the distance. Disk: `G·s / (π R²)` is the sum of
                                // terms whose magnitudes add to at most 5. Either way the terms
                                // cancel more than allowed.
                                let size = f64::from(o.half[0].max(o.half[1]).max(o.half[2]));
                                let cancels = if o.kind == 0 {
                                    brute * f64::from(reach) / size < 2.0 / bound
                                } else {
                                    let radius = f64::from(o.half[0]);
                                    let h = f64::from(o.half[2]);
                                    let w = if part == 0 { -h } else { h };
                                    let [u, v, z] = solid.map(f64::from);
                                    let dd = u * u + v * v + (z - w) * (z - w);
                                    let q = dd - radius * radius;
                                    let s =
                                        (q * q + 4.0 * radius * radius * (z - w) * (z - w)).sqrt();
                                    brute * s / (std::f64::consts::PI * radius * radius)
                                        < 10.0 / bound
                                };
                                tally[2] += usize::from(cancels && !clipped && !behind);
                                assert!(
                                    !has_control(&o, part) || clipped || behind || cancels,
                                    "{o:?} part {part} from {receiver:?}, normal {normal:?}: \
                                     refused, the integral {brute}"
                                );
                            }
                        }
                    }
                }
            }
        }
        for (kind, [given, refused, cancelled]) in tally.into_iter().enumerate() {
            assert!(
                given > 100 && refused > 200 && cancelled > 0,
                "kind {kind}: {given} given, {refused} refused ({cancelled} for their terms' \
                 cancelling)"
            );
        }
    }

    /// The closed forms are scale-free (`G` is a solid angle weighted by cosines): a room at
    /// ×10⁻³ or ×10³ gives every part the same `G` and direction within single precision's
    /// rounding, a rectangle and a disk alike, and nothing that is not finite.
    #[test]
    fn part_controls_do_not_depend_on_the_scale() {
        let normal = [0.3f32, 0.9, -0.1];
        let l = dot(normal, normal).sqrt();
        let normal = normal.map(|c| c / l);
        let mut compared = 0;
        for o in [
            params(0, 1, 7, [0.3, 0.05, 0.04]),
            params(1, 1, 1, [0.11, 0.11, 0.0]),
        ] {
            for receiver in [[0.4f32, -0.5, 0.2], [-1.3, 0.7, -0.9], [0.05, -2.5, 0.0]] {
                for part in 0..6 {
                    let at = |k: f32| {
                        let scaled = OpeningParams {
                            half: o.half.map(|h| h * k),
                            ..o
                        };
                        part_control(&scaled, part, receiver.map(|c| c * k), normal)
                    };
                    let one = at(1.0);
                    for k in [1e-3f32, 1e3] {
                        match (one, at(k)) {
                            (Some((g, t)), Some((gk, tk))) => {
                                assert!(
                                    (gk - g).abs() <= 2e-5 * g,
                                    "{o:?} {part} ×{k}: {gk} vs {g}"
                                );
                                assert!((0..3).all(|c| (tk[c] - t[c]).abs() < 1e-5));
                                compared += 1;
                            }
                            (None, None) => {}
                            (a, b) => panic!("{o:?} part {part} ×{k}: {a:?} against {b:?}"),
                        }
                    }
                }
            }
        }
        assert!(compared >= 8, "{compared} closed forms compared");
    }

    #[test]
    fn sampling_toward_a_receiver_integrates_each_flat_part() {
        // A box's bottom and its +u side, a disk: the weights average to the part's area from
        // receivers in front of it, near and far, under it and beside it.
        let cases = [
            (
                params(0, 2, 5, [0.3, 0.05, 0.04]),
                0usize,
                0.3f32 * 0.05 * 4.0,
            ),
            (params(0, 2, 5, [0.3, 0.05, 0.04]), 2, 0.05 * 0.04 * 4.0),
            (
                params(1, 2, 1, [0.1, 0.1, 0.0]),
                0,
                std::f32::consts::PI * 0.01,
            ),
        ];
        let receivers = [
            [0.0, 0.0, -0.1],
            [0.2, 0.1, -0.05],
            [1.0, -0.4, -2.0],
            [0.5, 0.0, 0.0],
            [0.05, 0.3, -0.01],
        ];
        for (o, part, area) in cases {
            for r in receivers {
                if !(height_over(&o, part, to_solid(o.axis, r)) > 0.0) {
                    assert_eq!(sample_part(&o, part, [0.5, 0.5], Some(r)), None);
                    continue;
                }
                let n = 1u32 << 14;
                let mean = (0..n)
                    .map(|k| {
                        let u = lattice(k, n, [7, 11]);
                        f64::from(sample_part(&o, part, u, Some(r)).map_or(0.0, |s| s.weight))
                    })
                    .sum::<f64>()
                    / f64::from(n);
                let area = f64::from(area);
                assert!(
                    (mean - area).abs() < 2e-3 * area,
                    "{o:?} part {part} from {r:?}: {mean} vs {area}"
                );
            }
        }
    }

    #[test]
    fn every_visible_part_gets_samples_in_proportion_to_its_area() {
        let o = params(0, 2, 7, [0.2, 0.2, 0.05]);
        // From below: the bottom and no top; the sides by their areas.
        let areas = visible_areas(&o, [0.3, 0.0, -1.0]);
        assert_eq!(areas[1], 0.0);
        assert!(areas[0] > 0.0 && areas[2] > 0.0 && areas[3] == 0.0);
        let c = counts(&areas, 48);
        assert_eq!(c[1], 0);
        assert!(c[0] > c[2] && c[2] >= 1, "{c:?}");
        assert_eq!(counts(&[0.0; 6], 48), [0; 6]);
    }

    #[test]
    fn samples_integrate_the_projected_area_of_every_solid() {
        let shapes = [
            params(0, 2, 1, [0.3, 0.05, 0.0]),
            params(0, 2, 7, [0.2, 0.2, 0.04]),
            params(0, 0, 3, [0.1, 0.15, 0.0]),
            params(1, 2, 1, [0.1, 0.1, 0.0]),
            params(1, 2, 7, [0.15, 0.1, 0.02]),
            params(1, 1, 4, [0.05, 0.05, 0.3]),
            params(2, 2, 4, [0.1, 0.1, 0.1]),
            params(2, 0, 4, [0.1, 0.2, 0.05]),
        ];
        let dirs = [
            [0.0, 0.0, -1.0],
            [0.0, 0.0, 1.0],
            [0.6, 0.0, -0.8],
            [0.36, 0.48, 0.8],
            [1.0, 0.0, 0.0],
            [-0.48, 0.6, -0.64],
        ];
        for o in &shapes {
            for w in dirs {
                let exact = f64::from(projected_area(o, w));
                let got = integrated(o, w);
                assert!(
                    (got - exact).abs() <= 2e-3 * exact.max(1e-4),
                    "{o:?} {w:?}: sampled {got}, closed form {exact}"
                );
            }
        }
    }

    #[test]
    fn degenerate_openings_have_no_samples() {
        let o = params(0, 2, 1, [0.0, 0.3, 0.0]);
        assert_eq!(sample(&o, [0.5; 3]), None);
        assert_eq!(projected_area(&o, [0.0, 0.0, -1.0]), 0.0);
        let flat = params(2, 2, 4, [0.1, 0.1, 0.0]);
        let s = sample(&flat, [0.3, 0.7, 0.1]).unwrap();
        assert!(s.weight.is_finite() && s.normal.iter().all(|c| c.is_finite()));
    }
}
