//! The CPU reference backend: every pass in plain Rust (rayon over texel rows), tracing rays
//! through the 8-wide BVH collapsed from the encoded scene ([`WideBvh`], the default
//! [`BvhMode::Wide`]) or, with `mtbvh`, `tbvh` or `none`, through [`EncodedScene`]'s CPU
//! traversal of the *encoded textures* — the same data the shaders read. Both use the same
//! watertight triangle test and agree up to ties. Everything is `f32` and each texel's value is
//! computed as a fragment shader would compute it, so that it is the oracle every GPU backend is
//! diffed against. Two passes share work across texels without changing a bit of the result:
//! the gather takes a row's rays through its stages in chunks, tracing a chunk before it
//! fetches the previous chunk's look-ups (so that the look-ups' cache misses overlap), and then
//! sums each texel's rays in order (`gather_sums`); the blur computes its tap
//! weights and the normalised normals once per dispatch.
//!
//! # Pass semantics (what every backend must compute)
//! For a texel at `(layer, x, y)` with G-buffer position `p` (w = 1 valid), normal `n` (w =
//! object index) and the pass's inputs `a`, `b` (in [`PassDesc::reads`](crate::graph::PassDesc::reads) order):
//!
//! - **Direct**: for each listed lamp with position `L`, `to = L − p`, `d² = |to|²`,
//!   `ω = to / d`, `cos θ = n̂·ω` (n̂ = normalised `n`). Lamps with `cos θ ≤ 0` contribute 0.
//!   Intensity `I = table.sample(M · (−ω))` (M = world→photometric, the table's own bilinear
//!   rule) times the lamp's RGB `scale`. Shadow ray: origin `o₀ = offset(p, n̂)`
//!   ([`offset_origin`], size term `SceneData::ray_epsilon`),
//!   `δ² = |o₀ − p|²`; when the lamp is nearer than four offsets (`16δ² > d²`) the origin is
//!   `p + n̂·(d/4)` instead, else `o₀`. Direction `L − o` (unnormalised), any hit with
//!   `t ∈ (0, 1 − s/|L − o|)`, `s = min(|offset(L, −ω) − L|, d/4)` (the lamp's own offset
//!   toward the texel: the ray stops short of a lamp mounted on a surface): occluded lamps
//!   contribute 0. Else `E += I·cos θ / max(d², δ²)` (**the d² floor**, one rule in every
//!   backend: a lamp nearer to a texel than the texel's own ray offset counts as that far:
//!   finite, never a division by zero).
//!   Output `(E, 1)`; invalid texels `(0, 0, 0, 0)`.
//! - **Copy**: `a`.
//! - **Blur** (axis, σ): radius `R = min(⌈3σ⌉, 64)` texels along the axis; taps `k ∈ [−R, R]`
//!   inside the layer whose `a.w > ½` (valid), whose object index equals the centre's and whose
//!   normal is within 25° of the centre's (`n̂ₖ·n̂ ≥ 0.9063`), weighted `exp(−k²/(2σ²))`,
//!   normalised by the sum of the used weights. So the empty texels between charts never bleed
//!   in (the paper's black seams) and neither do charts facing elsewhere (floor into wall).
//!   Output `(Σ, 1)`; invalid centres `(0, 0, 0, 0)`.
//! - **AlbedoMul**: `(a.rgb × b.rgb, a.w)` — b is the G-buffer albedo.
//! - **Combine**: `(a.rgb + b.rgb, a.w)`.
//! - **Gather** (bounce k): N = `rays` directions, cosine-weighted about n̂: with
//!   `(u₀, u₁)` = [`rng::uniform2`]`(texel, s, k, seed)` (the hash sampler) or
//!   [`rng::sobol2`]`(texel, s, k, seed)` (the Sobol sampler, `GatherParams::sampler`),
//!   `r = √u₀`, `φ = 2π·u₁`, local `(r cos φ, r sin φ, √(1 − u₀))` (`cos φ`, `sin φ` by
//!   [`sin_cos_turns`], a polynomial as exact as `cosf`/`sinf`) in the orthonormal basis
//!   of Duff et al. (2017) built from n̂. Closest hit from `offset(p, n̂)` (t ∈ (0, ∞)). A hit counts when the hit object has a
//!   region and the ray meets the front of the surface (interpolated shading normal `n_h`,
//!   `n_h·dir < 0`); then it adds the reflected map `a` looked up at the hit's light-map UV in
//!   the hit object's region by [`map::sample_masked`](crate::map::sample_masked). Back faces,
//!   misses and non-receivers add 0. Output `(Σ / N, 1)`. Since `E = π·mean(L)` over a
//!   cosine-weighted hemisphere and a Lambertian surface's radiance is `L = M/π`, the mean
//!   exitance is the indirect illuminance.
//! - **Variance** (the à-trous filter's noise estimate; derivation in
//!   [`atrous_steps`](crate::program::atrous_steps)): `a` is the noisy map, `b` the G-buffer
//!   position, then the normal. The window is the 5×5 taps at offsets `o ∈ [−2, 2]²` that lie
//!   on the centre's surface (**guide**, below) with `n̂·n̂ₜ ≥ 0.9063` (25°), each with its
//!   luminance `l = 0.2126 r + 0.7152 g + 0.0722 b` (left to right). For each direction
//!   `d` in (1, 0), (0, 1), (1, 1), (1, −1) in that order, over the pairs `(o, o + d)` with
//!   both ends in the window (rows, then columns of `o`): `v_d = Σ(l_{o+d} − l_o)² / (2n)`;
//!   directions with `n < max(min_pairs, 1)` are skipped; `v` is the smallest `v_d` (first
//!   wins ties), or 0 when no direction counts. Output `(v, m, v₀, 1)`: `v` of the window,
//!   then, with the centre `o = 0` left out (so that they do not depend on the centre's own
//!   noise; for refinement), the mean luminance `m` of the taps (0 without taps) and their
//!   `v₀`; invalid centres `(0, 0, 0, 0)`;
//!   a centre whose normal cannot be normalised `(0, 0, 0, 1)`.
//! - **Atrous** (step `s`): `a` the map being filtered (value `c` at the centre), `b` the
//!   variance map (its `r` is `σ²`), then position and normal. Taps at `s·(i, j)`,
//!   `i, j ∈ −2..=2` (rows `j` outer, columns `i` inner) on the centre's surface (guide) with
//!   `cos = n̂·n̂ₜ > 0` get `w = B3[i]·B3[j]·cos^(2^normal_log2)·w_l` (the power by squaring,
//!   stopping once it is 0 or 1; `B3` = 1/16, 1/4, 3/8, 1/4, 1/16) with `Δ = v − c`,
//!   `Δl` = its luminance and `w_l = 1` if `Δl = 0`, else `exp(−Δl² / (variance_scale·σ²))`
//!   when `variance_scale·σ² > 0`, else 0. Taps with `w ≤ 0` (or NaN) are skipped. Output
//!   `(c + ΣwΔ / Σw, 1)` — the centre itself is a tap, so a constant field is returned exactly
//!   and a texel with no other usable tap keeps its value. A centre whose normal cannot be
//!   normalised, or with no usable tap at all (a NaN or infinite centre), keeps its value:
//!   `(c, 1)`. Invalid centres `(0, 0, 0, 0)`. A step beyond the layer's width and height
//!   leaves only the centre.
//!
//! The **guide** of the denoiser passes: a tap at offset `o` from the centre `p` is on the
//! centre's surface when it lies inside the layer, its `a.w > ½`, its object index equals the
//! centre's, its normal can be normalised and, for `o ≠ 0`, its world position lies in the
//! shell its offset allows on the centre's chart: `reach_min²·m² ≤ |x_t − x_p|² ≤
//! reach²·|o|²`, `m = max(0, max(|o.x|, |o.y|) − 2)` (the variance pass has no lower bound,
//! its offsets are at most 2). So taps of another chart — close in UV, elsewhere in the world
//! — are skipped (the test is derived in [`atrous_steps`](crate::program::atrous_steps)).
//!
//! Every output passes through a guard that maps NaN to 0 and clamps to `[0, f32::MAX]`, so no
//! NaN or infinity ever reaches a map.

use std::sync::Arc;

use luxbake_bvh::{EncodedScene, Hit, Ray, Traversal, TriangleAttributes, WideBvh};
use luxbake_ies::GpuTable;
use rayon::prelude::*;

use crate::backend::{
    DEFAULT_TILE_WORK, Dispatch, GpuBackend, LampParams, LampView, Limits, SceneData, lamp_toward,
    offset_origin,
};
use crate::exact::{basis, dot, guard, luminance, mad, normalize, sub};
use crate::graph::TexDesc;
use crate::layout::Region;
use crate::lightpaths;
use crate::map::{bilinear_footprint, masked_blend};
use crate::program::{
    AtrousParams, B3, BLUR_NORMAL_COS, BlurParams, CombineParams, DirectParams, GatherParams,
    MAX_BLUR_RADIUS, Params, Program, RefineParams, UpsampleParams, VarianceParams, coarse,
};
use crate::rng;
use crate::scene::BvhMode;

/// Errors of the CPU backend (all are misuse of the [`GpuBackend`] contract).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CpuError {
    /// A texture handle that this backend did not create.
    #[error("unknown texture {0}")]
    UnknownTexture(usize),
    /// An upload with the wrong number of floats.
    #[error("upload of {got} floats into a layer of {expected}")]
    WrongSize {
        /// Floats per layer.
        expected: usize,
        /// Floats given.
        got: usize,
    },
    /// A layer index beyond the texture's layers.
    #[error("layer {layer} of a texture with {layers} layers")]
    LayerOutOfRange {
        /// The layer asked for.
        layer: u32,
        /// Layers of the texture.
        layers: u32,
    },
    /// A pass was given the wrong number of textures or textures of different sizes.
    #[error("pass `{pass}`: {reason}")]
    BadBindings {
        /// The pass label.
        pass: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// A lamp refers to a table that was not uploaded.
    #[error("lamp {lamp} refers to intensity table {table}, but {tables} were uploaded")]
    MissingTable {
        /// Lamp index.
        lamp: usize,
        /// Table index.
        table: u32,
        /// Number of tables.
        tables: usize,
    },
    /// A texture too large to address.
    #[error("texture {size:?} × {layers} layers is too large")]
    TooLarge {
        /// Layer size.
        size: [u32; 2],
        /// Layers.
        layers: u32,
    },
}

/// Handle of a CPU texture.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CpuTexture(usize);

/// The uploaded scene of the CPU backend (owned copies, as a GPU upload would make).
#[derive(Debug, Clone)]
pub struct CpuScene {
    bvh: Arc<EncodedScene>,
    wide: Arc<WideBvh>,
    /// [`EncodedScene::triangle_attributes`] of every encoded triangle, decoded once at upload
    /// so that a gather hit reads them from an array, a cache line each.
    attributes: Vec<HitAttributes>,
    lamps: Vec<LampParams>,
    tables: Vec<GpuTable>,
    regions: Vec<Option<Region>>,
    layer_size: [u32; 2],
    ray_epsilon: f32,
}

/// The CPU reference backend.
#[derive(Debug, Default)]
pub struct CpuBackend {
    textures: Vec<(TexDesc, Vec<f32>)>,
}

impl CpuBackend {
    /// A backend with no textures.
    pub fn new() -> CpuBackend {
        CpuBackend::default()
    }

    fn get(&self, t: &CpuTexture) -> Result<&(TexDesc, Vec<f32>), CpuError> {
        self.textures.get(t.0).ok_or(CpuError::UnknownTexture(t.0))
    }
}

/// `(sin 2πu, cos 2πu)`: a polynomial instead of `sinf`/`cosf` (whose one call per gather ray
/// cost about as much as the rest of the ray's direction), as exact as they are for what the
/// gather feeds it. `u` is split into the nearest quarter turn `k/4` and a remainder
/// `r ∈ [-1/8, 1/8]` — exactly, for the sampler's uniforms, multiples of 2^-24 — and
/// `sin 2πr ≈ r·P(r²)` (degree 7), `cos 2πr ≈ Q(r²)` (degree 8) are rotated by `k` quarter
/// turns. Coefficients: least squares on Chebyshev nodes of `[-1/8, 1/8]` (relative error of
/// the sine ≤ 1.3·10⁻⁷, absolute error of the cosine ≤ 7·10⁻⁸ in `f32`, checked in the tests
/// against `f64`). `|u|` up to 2^20 turns keeps the split exact; non-finite `u` gives NaN.
#[inline]
pub fn sin_cos_turns(u: f32) -> (f32, f32) {
    // 1.5·2^23: adding and subtracting it rounds `4u` to the nearest integer (ties to even).
    const ROUND: f32 = 12_582_912.0;
    let k = (4.0 * u + ROUND) - ROUND;
    let r = u - 0.25 * k;
    let r2 = r * r;
    let s = r * (6.283_185_5 + r2 * (-41.341_66 + r2 * (81.592_35 + r2 * -75.393_3)));
    let c = 1.0 + r2 * (-19.739_208 + r2 * (64.939_316 + r2 * (-85.442_85 + r2 * 59.220_27)));
    // `k mod 4` quarter turns: (s, c) → (c, -s) → (-s, -c) → (-c, s), without branches (the
    // quadrant is random per ray: branches on it were mispredicted half the time, which
    // doubled the direction's cost). Odd quadrants swap; the sine is negative in quadrants
    // 2 and 3, the cosine in 1 and 2.
    let q = (k as i32 as u32) & 3;
    let swap = 0u32.wrapping_sub(q & 1);
    let (sb, cb) = (s.to_bits(), c.to_bits());
    let sin = (sb & !swap) | (cb & swap);
    let cos = (cb & !swap) | (sb & swap);
    (
        f32::from_bits(sin ^ ((q >> 1) << 31)),
        f32::from_bits(cos ^ (((q ^ (q >> 1)) & 1) << 31)),
    )
}

/// The cosine-weighted direction of gather sample `(u0, u1)` about unit `n`.
#[inline]
pub fn cosine_direction(n: [f32; 3], u: [f32; 2]) -> [f32; 3] {
    Frame::new(n).cosine_direction(u)
}

/// A unit normal with its tangent and bitangent ([`basis`]): built once for the many rays
/// of one texel.
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    t: [f32; 3],
    b: [f32; 3],
    n: [f32; 3],
}

impl Frame {
    /// The frame of unit `n`.
    #[inline]
    pub fn new(n: [f32; 3]) -> Frame {
        let (t, b) = basis(n);
        Frame { t, b, n }
    }

    /// [`Frame::cosine_direction`] of four samples, bit for bit: the same operations written
    /// lane by lane over arrays, which the compiler turns into 4-wide SIMD (measured 1.4–1.7×
    /// faster per direction than one at a time on x86_64).
    #[inline(always)]
    pub fn cosine_directions4(&self, u: [[f32; 2]; 4]) -> [[f32; 3]; 4] {
        let Frame { t, b, n } = *self;
        let (mut x, mut y, mut z) = ([0.0f32; 4], [0.0f32; 4], [0.0f32; 4]);
        for i in 0..4 {
            let r = u[i][0].sqrt();
            let (sin, cos) = sin_cos_turns(u[i][1]);
            x[i] = r * cos;
            y[i] = r * sin;
            z[i] = (1.0 - u[i][0]).max(0.0).sqrt();
        }
        let mut out = [[0.0f32; 3]; 4];
        for c in 0..3 {
            for i in 0..4 {
                out[i][c] = t[c] * x[i] + b[c] * y[i] + n[c] * z[i];
            }
        }
        out
    }

    /// [`cosine_direction`]`(n, u)`, bit for bit.
    #[inline]
    pub fn cosine_direction(&self, u: [f32; 2]) -> [f32; 3] {
        let Frame { t, b, n } = *self;
        let r = u[0].sqrt();
        let (sin, cos) = sin_cos_turns(u[1]);
        let (x, y) = (r * cos, r * sin);
        let z = (1.0 - u[0]).max(0.0).sqrt();
        [
            t[0] * x + b[0] * y + n[0] * z,
            t[1] * x + b[1] * y + n[1] * z,
            t[2] * x + b[2] * y + n[2] * z,
        ]
    }
}

/// The structure rays are traced through.
#[derive(Clone, Copy, Debug)]
enum Trav {
    /// The wide BVH ([`CpuScene::wide`]).
    Wide,
    /// A traversal of the encoded textures.
    Encoded(Traversal),
}

fn traversal(mode: BvhMode) -> Trav {
    match mode {
        BvhMode::Wide => Trav::Wide,
        BvhMode::Mtbvh => Trav::Encoded(Traversal::Mtbvh),
        BvhMode::Tbvh => Trav::Encoded(Traversal::Tbvh),
        BvhMode::None => Trav::Encoded(Traversal::BruteForce),
    }
}

impl CpuScene {
    #[inline]
    fn closest_hit(&self, ray: &Ray, t_min: f32, t_max: f32, trav: Trav) -> Option<Hit> {
        match trav {
            Trav::Wide => self.wide.closest_hit(ray, t_min, t_max),
            Trav::Encoded(t) => self.bvh.closest_hit(ray, t_min, t_max, t),
        }
    }

    /// Encoded triangle `t`'s attributes (those of [`EncodedScene::triangle_attributes`], from
    /// [`decode_attributes`]' array), in place; `None` past the scene's triangles, which no
    /// hit names.
    #[inline]
    fn attributes(&self, t: u32) -> Option<&TriangleAttributes> {
        self.attributes.get(t as usize).map(|a| &a.0)
    }

    #[inline]
    fn any_hit(&self, ray: &Ray, t_min: f32, t_max: f32, trav: Trav) -> bool {
        match trav {
            Trav::Wide => self.wide.any_hit(ray, t_min, t_max),
            Trav::Encoded(t) => self.bvh.any_hit(ray, t_min, t_max, t),
        }
    }
}

/// Every encoded triangle's attributes ([`EncodedScene::triangle_attributes`]), decoded once
/// at upload so that a gather hit reads them from an array.
fn decode_attributes(bvh: &EncodedScene) -> Vec<HitAttributes> {
    (0..bvh.triangle_count)
        .map(|t| HitAttributes(bvh.triangle_attributes(t)))
        .collect()
}

/// A triangle's attributes on a cache line of their own (they are 64 bytes): a gather hit
/// reads them with one access to the cache, and in place.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct HitAttributes(TriangleAttributes);

/// Read access to one RGBA32F texture array.
#[derive(Clone, Copy)]
struct View<'a> {
    data: &'a [f32],
    size: [u32; 2],
    layers: u32,
}

impl View<'_> {
    /// The offset of texel `(x, y)` of `layer` in the data, if it is inside.
    #[inline]
    fn index(&self, layer: u32, x: u32, y: u32) -> Option<usize> {
        (x < self.size[0] && y < self.size[1] && layer < self.layers).then(|| {
            4 * ((layer as usize * self.size[1] as usize + y as usize) * self.size[0] as usize
                + x as usize)
        })
    }

    /// The texel at `index` (of [`View::index`] of a view of the same size), 0 outside.
    #[inline]
    fn at(&self, index: Option<usize>) -> [f32; 4] {
        index.map_or([0.0; 4], |i| self.at_offset(i))
    }

    /// The texel at `index` (of [`View::index`] of a view of the same size), 0 outside
    /// (`usize::MAX`, say).
    #[inline]
    fn at_offset(&self, index: usize) -> [f32; 4] {
        match index
            .checked_add(4)
            .and_then(|end| self.data.get(index..end))
        {
            Some(t) => [t[0], t[1], t[2], t[3]],
            None => [0.0; 4],
        }
    }

    /// [`View::index`] of `region`'s first texel when all of `region` lies inside the view:
    /// its texel `(x, y)` is then at `origin + 4x + 4·width·y`, `width` the view's.
    #[inline]
    fn rect_origin(&self, region: &Region) -> Option<usize> {
        let [ox, oy] = region.offset.map(u64::from);
        let [w, h] = region.size.map(u64::from);
        let inside = ox + w <= u64::from(self.size[0]) && oy + h <= u64::from(self.size[1]);
        inside
            .then(|| self.index(region.layer, region.offset[0], region.offset[1]))
            .flatten()
    }

    #[inline]
    fn fetch(&self, layer: u32, x: u32, y: u32) -> [f32; 4] {
        self.at(self.index(layer, x, y))
    }

    fn same_shape(&self, other: &View<'_>) -> bool {
        self.size == other.size && self.layers == other.layers
    }
}

fn xyz(t: [f32; 4]) -> [f32; 3] {
    [t[0], t[1], t[2]]
}

/// The direct illuminance at one texel (see the module docs).
fn direct_texel(
    scene: &CpuScene,
    params: DirectParams,
    trav: Trav,
    pos: [f32; 4],
    nrm: [f32; 4],
) -> [f32; 4] {
    if pos[3] <= 0.5 {
        return [0.0; 4];
    }
    let p = xyz(pos);
    let Some(n) = normalize(xyz(nrm)) else {
        return [0.0, 0.0, 0.0, 1.0];
    };
    let mut e = [0.0f32; 3];
    for lamp in scene.lamps.iter().take(params.lamp_count as usize) {
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
        let o0 = offset_origin(p, n, scene.ray_epsilon);
        let off = sub(o0, p);
        let off2 = dot(off, off);
        let o = if 16.0 * off2 > d2 {
            mad(p, n, 0.25 * d)
        } else {
            o0
        };
        let dir = sub(lamp.position, o);
        let len = dot(dir, dir).sqrt();
        let back = [-w[0], -w[1], -w[2]];
        let lamp_off = sub(
            offset_origin(lamp.position, back, scene.ray_epsilon),
            lamp.position,
        );
        let stop = dot(lamp_off, lamp_off).sqrt().min(0.25 * d);
        let t_max = 1.0 - stop / len;
        if len > 0.0 && t_max > 0.0 && scene.any_hit(&Ray { origin: o, dir }, 0.0, t_max, trav) {
            continue;
        }
        let k = intensity * cos / d2.max(off2);
        for (ec, sc) in e.iter_mut().zip(lamp.scale) {
            *ec += k * sc;
        }
    }
    [guard(e[0]), guard(e[1]), guard(e[2]), 1.0]
}

/// A gather ray that met the front of a receiver: where the texels of its masked look-up lie
/// in the reflected map ([`View::index`], `usize::MAX` for one outside it, which reads 0) and
/// their weights (`None`: the look-up is zero), and the hit's interpolated shading normal.
#[derive(Clone, Copy)]
struct Lookup {
    texels: [usize; 4],
    weights: Option<[f32; 4]>,
    normal: [f32; 3],
}

/// One texel's gather rays: samples `rays` of its sequence ([`rng::texel_index`] `texel`),
/// cast from `o` around the unit normal of `frame`.
struct GatherTexel {
    texel: u32,
    rays: std::ops::Range<u32>,
    o: [f32; 3],
    frame: Frame,
    mis: Mis,
}

/// Per texel of `texels`, the sum of the reflected exitance seen along its rays (see the
/// module docs), pushed to `sums` (cleared first), the directions drawn with the gather's
/// `[sampler, bounce, seed]`; `chunks` are the stage buffers, reused from call to call. The
/// rays are processed as a stream, in chunks of about `CHUNK_RAYS`, one stage at a time over
/// a chunk: their directions, their closest hits, the hits' shading and look-up footprints
/// (each prefetching the look-up's texels), then — after the next chunk's traversal — the
/// look-ups' texels (independent loads whose cache misses overlap, instead of each stalling
/// the next ray's traversal) and last each texel's contributions, added in ray order as one
/// ray at a time would. Each stage is a short loop that keeps its own code and data hot
/// (docs/performance.md, issue 15, measures the stages and the alternatives).
fn gather_sums(
    scene: &CpuScene,
    reflected: View<'_>,
    trav: Trav,
    [sampler_id, bounce, seed]: [u32; 3],
    texels: &[GatherTexel],
    [ahead, behind]: &mut [GatherChunk; 2],
    sums: &mut Vec<[f32; 3]>,
) {
    let first = texels.iter().map(|t| t.rays.start).min().unwrap_or(0);
    let end = texels.iter().map(|t| t.rays.end).max().unwrap_or(0);
    let sampler = rng::Sampler::from_id(sampler_id);
    let draws = rng::PassDraws::new(sampler, bounce, seed, first..end);
    // Chunks of texels with about CHUNK_RAYS rays (at least one texel each), software
    // pipelined: chunk k's rays are traced and their look-ups prefetched, then chunk k - 1's
    // look-ups fetched and summed, so that a whole chunk's traversal lies between a look-up's
    // prefetch and its fetch.
    sums.clear();
    let mut rest = texels;
    let mut pending: &[GatherTexel] = &[];
    while !rest.is_empty() {
        let mut rays = 0;
        let n = rest
            .iter()
            .position(|t| {
                rays += t.rays.len();
                rays > CHUNK_RAYS
            })
            .unwrap_or(rest.len())
            .max(1);
        let (chunk, tail) = rest.split_at(n);
        ahead.trace(scene, reflected, trav, &draws, chunk);
        behind.sum(scene, reflected, pending, sums);
        std::mem::swap(ahead, behind);
        pending = chunk;
        rest = tail;
    }
    behind.sum(scene, reflected, pending, sums);
}

/// The rays of one chunk of [`gather_sums`]: few enough that the chunk's buffers and
/// prefetched look-up texels (about 330 bytes a ray) stay in a core's L2 cache and mostly in
/// its L1 (1 024 rays a chunk fetched 1.5 times slower; docs/performance.md, issue 15), enough
/// that a chunk's traversal (tens of microseconds) hides a prefetch's latency.
const CHUNK_RAYS: usize = 256;

/// One chunk's stage buffers in [`gather_sums`], reused from chunk to chunk.
#[derive(Default)]
struct GatherChunk {
    dirs: Vec<[f32; 3]>,
    traced: Vec<Option<Hit>>,
    lookups: Vec<Option<Lookup>>,
    fetched: Vec<[[f32; 4]; 4]>,
}

impl GatherChunk {
    /// The first stages over `texels`' rays: directions, closest hits, shading and look-up
    /// footprints (prefetched).
    fn trace(
        &mut self,
        scene: &CpuScene,
        reflected: View<'_>,
        trav: Trav,
        draws: &rng::PassDraws,
        texels: &[GatherTexel],
    ) {
        let GatherChunk {
            dirs,
            traced,
            lookups,
            ..
        } = self;
        directions(dirs, draws, texels);
        traced.clear();
        let mut rest = dirs.iter();
        for t in texels {
            for &dir in rest.by_ref().take(t.rays.len()) {
                let ray = Ray { origin: t.o, dir };
                traced.push(scene.closest_hit(&ray, 0.0, f32::INFINITY, trav));
            }
        }
        lookups.clear();
        lookups.extend(traced.iter().zip(dirs.iter()).map(|(hit, &dir)| {
            hit.as_ref()
                .and_then(|hit| gather_lookup(scene, reflected, hit, dir))
        }));
    }

    /// The last stages over `texels` (those of the last [`GatherChunk::trace`]): the
    /// look-ups' texels, then each texel's sum, pushed to `sums`.
    fn sum(
        &mut self,
        scene: &CpuScene,
        reflected: View<'_>,
        texels: &[GatherTexel],
        sums: &mut Vec<[f32; 3]>,
    ) {
        let GatherChunk {
            dirs,
            traced,
            lookups,
            fetched,
        } = self;
        fetched.clear();
        fetched.extend(lookups.iter().map(|lookup| match lookup {
            Some(Lookup {
                texels: [a, b, c, d],
                weights: Some(_),
                ..
            }) => [
                reflected.at_offset(*a),
                reflected.at_offset(*b),
                reflected.at_offset(*c),
                reflected.at_offset(*d),
            ],
            _ => [[0.0; 4]; 4],
        }));
        let mut rest = lookups
            .iter()
            .zip(fetched.iter())
            .zip(traced.iter().zip(dirs.iter()));
        sums.extend(texels.iter().map(|t| {
            let mut sum = [0.0f32; 3];
            for ((lookup, texels), (hit, &dir)) in rest.by_ref().take(t.rays.len()) {
                let (Some(lookup), Some(hit)) = (lookup, hit) else {
                    continue;
                };
                let m = lookup.weights.map_or([0.0; 3], |w| {
                    masked_blend([
                        (texels[0], w[0]),
                        (texels[1], w[1]),
                        (texels[2], w[2]),
                        (texels[3], w[3]),
                    ])
                });
                let weight = gather_weight(scene, hit, lookup.normal, dir, t);
                for c in 0..3 {
                    sum[c] += weight * m[c];
                }
            }
            sum
        }));
    }
}

/// The directions of `texels`' rays, in order, pushed to `dirs` (cleared first): with AVX2
/// where the CPU has it, the same operations bit for bit (integer operations and IEEE
/// arithmetic, no fused multiply-adds), the hash sampler's draws then four to a vector.
fn directions(dirs: &mut Vec<[f32; 3]>, draws: &rng::PassDraws, texels: &[GatherTexel]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2 (just checked).
        unsafe { directions_avx2(dirs, draws, texels) };
        return;
    }
    directions_inline(dirs, draws, texels);
}

/// [`directions`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn directions_avx2(dirs: &mut Vec<[f32; 3]>, draws: &rng::PassDraws, texels: &[GatherTexel]) {
    directions_inline(dirs, draws, texels);
}

/// [`directions`] for the instruction set of the caller.
#[inline(always)]
fn directions_inline(dirs: &mut Vec<[f32; 3]>, draws: &rng::PassDraws, texels: &[GatherTexel]) {
    dirs.clear();
    for t in texels {
        let d = draws.texel(t.texel);
        let mut s = t.rays.start;
        while t.rays.end - s >= 4 {
            dirs.extend(t.frame.cosine_directions4(d.uniform2x4(s)));
            s += 4;
        }
        dirs.extend((s..t.rays.end).map(|s| t.frame.cosine_direction(d.uniform2(s))));
    }
}

/// The interpolated shading normal of `hit` on a triangle with `attr`.
#[inline]
fn shading_normal(attr: &TriangleAttributes, hit: &Hit) -> [f32; 3] {
    // Written out per component (no array::map closures, which the dev profile does not
    // always inline on this hot path).
    let w0 = 1.0 - hit.u - hit.v;
    let [n0, n1, n2] = attr.normals;
    [
        w0 * n0[0] + hit.u * n1[0] + hit.v * n2[0],
        w0 * n0[1] + hit.u * n1[1] + hit.v * n2[1],
        w0 * n0[2] + hit.u * n1[2] + hit.v * n2[2],
    ]
}

/// The weight of texel `t`'s gather ray along `dir` that met `hit` (a front hit of a
/// receiver, interpolated shading normal `nh`): 1, or with lamp paths the balance heuristic
/// against them ([`crate::lightpaths`]).
#[inline]
fn gather_weight(scene: &CpuScene, hit: &Hit, nh: [f32; 3], dir: [f32; 3], t: &GatherTexel) -> f32 {
    let mis = t.mis;
    if mis.lamp_paths == 0 {
        return 1.0;
    }
    let ny = normalize(nh).unwrap_or([0.0; 3]);
    let y = [0, 1, 2].map(|c| t.o[c] + hit.t * dir[c]);
    let lamps = &scene.lamps[..(mis.lamp_count as usize).min(scene.lamps.len())];
    let lamp_density = lightpaths::density(lamps, &scene.tables, y, ny);
    lightpaths::gather_weight(
        mis.rays,
        mis.lamp_paths,
        mis.density_scale,
        lamp_density,
        hit.t,
        dot(t.frame.n, dir),
        -dot(ny, dir),
    )
}

/// The gather ray along `dir` that met `hit`: when it met the front of a receiver, its masked
/// look-up in `reflected` (see the module docs), its rows prefetched; `None` adds nothing.
#[inline]
fn gather_lookup(
    scene: &CpuScene,
    reflected: View<'_>,
    hit: &Hit,
    dir: [f32; 3],
) -> Option<Lookup> {
    let attr = scene.attributes(hit.triangle)?;
    let Some(Some(region)) = scene.regions.get(attr.object as usize) else {
        return None;
    };
    let normal = shading_normal(attr, hit);
    let facing = dot(normal, dir);
    if facing.is_nan() || facing >= 0.0 {
        return None;
    }
    let w0 = 1.0 - hit.u - hit.v;
    let [uv0, uv1, uv2] = attr.uvs;
    let uv = [
        w0 * uv0[0] + hit.u * uv1[0] + hit.v * uv2[0],
        w0 * uv0[1] + hit.u * uv1[1] + hit.v * uv2[1],
    ];
    let Some(c) = bilinear_footprint(region.size, uv) else {
        return Some(Lookup {
            texels: [usize::MAX; 4],
            weights: None,
            normal,
        });
    };
    let [(t0, w0), (t1, w1), (t2, w2), (t3, w3)] = c;
    let texels = match reflected.rect_origin(region) {
        Some(origin) => {
            let row = 4 * reflected.size[0] as usize;
            let at = |[x, y]: [u32; 2]| origin + 4 * x as usize + row * y as usize;
            [at(t0), at(t1), at(t2), at(t3)]
        }
        None => {
            let [ox, oy] = region.offset;
            let at = |[x, y]: [u32; 2]| {
                reflected
                    .index(region.layer, ox.saturating_add(x), oy.saturating_add(y))
                    .unwrap_or(usize::MAX)
            };
            [at(t0), at(t1), at(t2), at(t3)]
        }
    };
    // The look-up's texels, asked for now: the look-ups are fetched after the next chunk's
    // traversal and their texels are usually not cached (the maps are megabytes). Each row
    // of two texels lies on one cache line or straddles two.
    prefetch(reflected.data, texels[0]);
    prefetch(reflected.data, texels[1]);
    prefetch(reflected.data, texels[2]);
    prefetch(reflected.data, texels[3]);
    Some(Lookup {
        texels,
        weights: Some([w0, w1, w2, w3]),
        normal,
    })
}

/// Asks the cache for the line holding `data[index]` (nothing when `index` is out of range,
/// or off x86_64).
#[inline(always)]
fn prefetch(data: &[f32], index: usize) {
    #[cfg(target_arch = "x86_64")]
    if let Some(v) = data.get(index) {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: SSE is part of the x86_64 baseline, and a prefetch reads nothing the
        // program sees and never faults; the pointer is to an element of `data`.
        unsafe { _mm_prefetch::<_MM_HINT_T0>((v as *const f32).cast()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (data, index);
}

/// The gather's multiple-importance-sampling weights ([`crate::lightpaths`]): none when
/// `lamp_paths` is 0.
#[derive(Debug, Clone, Copy)]
struct Mis {
    /// Rays per texel of the gather (`N_C`).
    rays: u32,
    /// Lamp paths per texel (`K`).
    lamp_paths: u32,
    /// [`crate::lightpaths::LampPaths::density_scale`].
    density_scale: f32,
    /// Uploaded lamps the density sums over.
    lamp_count: u32,
}

impl Mis {
    const NONE: Mis = Mis {
        rays: 0,
        lamp_paths: 0,
        density_scale: 0.0,
        lamp_count: 0,
    };
}

/// The buffers of [`gather_row`], reused from row to row.
#[derive(Default)]
struct GatherScratch {
    /// The row's texels with rays.
    texels: Vec<GatherTexel>,
    /// Their columns in the row, from `x0`.
    at: Vec<usize>,
    /// The stage buffers of [`gather_sums`].
    chunks: [GatherChunk; 2],
    /// Per texel of `texels`, its sum.
    sums: Vec<[f32; 3]>,
}

/// The gathered indirect illuminance at texels `x0 ..` of row `y` (`out`: RGBA per texel; see
/// the module docs), their rays traced together ([`gather_sums`]); with
/// [`GatherParams::stride`] > 1 only grid texels and orphans are gathered ([`coarse_rays`]),
/// the others written as 0 for [`upsample_texel`].
#[allow(clippy::too_many_arguments)]
fn gather_row(
    scene: &CpuScene,
    [pos_map, nrm_map, reflected, connected]: [View<'_>; 4],
    trav: Trav,
    params: GatherParams,
    layer: u32,
    x0: u32,
    y: u32,
    out: &mut [f32],
    scratch: &mut GatherScratch,
) {
    let GatherScratch {
        texels,
        at,
        chunks,
        sums,
    } = scratch;
    texels.clear();
    at.clear();
    for (i, texel) in out.chunks_exact_mut(4).enumerate() {
        let x = x0 + i as u32;
        let pos = pos_map.fetch(layer, x, y);
        if pos[3] <= 0.5 {
            texel.copy_from_slice(&[0.0; 4]);
            continue;
        }
        texel.copy_from_slice(&[0.0, 0.0, 0.0, 1.0]);
        let Some(n) = normalize(xyz(nrm_map.fetch(layer, x, y))) else {
            continue;
        };
        let rays = coarse_rays(pos_map, nrm_map, &params, layer, x, y);
        if rays == 0 {
            continue;
        }
        texels.push(GatherTexel {
            texel: rng::texel_index(scene.layer_size, layer, x, y),
            rays: 0..rays,
            o: offset_origin(xyz(pos), n, scene.ray_epsilon),
            frame: Frame::new(n),
            mis: Mis {
                rays,
                lamp_paths: params.lamp_paths,
                density_scale: params.density_scale,
                lamp_count: params.lamp_count,
            },
        });
        at.push(i);
    }
    let sampler = [params.sampler, params.bounce, params.seed];
    gather_sums(scene, reflected, trav, sampler, texels, chunks, sums);
    for ((t, sum), &i) in texels.iter().zip(sums.iter()).zip(at.iter()) {
        let inv = 1.0 / t.rays.len() as f32;
        let c = if params.lamp_paths > 0 {
            connected.fetch(layer, x0 + i as u32, y)
        } else {
            [0.0; 4]
        };
        out[4 * i..4 * i + 4].copy_from_slice(&[
            guard(sum[0] * inv + c[0]),
            guard(sum[1] * inv + c[1]),
            guard(sum[2] * inv + c[2]),
            1.0,
        ]);
    }
}

/// The weights of texel `(x, y)`'s grid-cell corners that lie on its surface
/// ([`program::coarse`]), 0 for the others, and their sum.
fn coarse_weights(
    pos: View<'_>,
    nrm: View<'_>,
    stride: u32,
    reach: f32,
    layer: u32,
    x: u32,
    y: u32,
) -> ([([i64; 2], f32); 4], f32) {
    let mut cell = coarse::cell(x, y, stride);
    let nc = nrm.fetch(layer, x, y);
    let p = xyz(pos.fetch(layer, x, y));
    let Some(n) = normalize(xyz(nc)) else {
        return (cell.map(|(c, _)| (c, 0.0)), 0.0);
    };
    let reach2 = reach * reach;
    let mut total = 0.0f32;
    for (corner, weight) in &mut cell {
        let [tx, ty] = *corner;
        let on_surface =
            *weight > 0.0 && tx < i64::from(pos.size[0]) && ty < i64::from(pos.size[1]) && {
                let (tx, ty) = (tx as u32, ty as u32);
                let pt = pos.fetch(layer, tx, ty);
                let nt = nrm.fetch(layer, tx, ty);
                let d = sub(xyz(pt), p);
                let (ox, oy) = (tx as i64 - i64::from(x), ty as i64 - i64::from(y));
                pt[3] > 0.5
                    && nt[3] == nc[3]
                    && normalize(xyz(nt)).is_some_and(|n1| dot(n, n1) >= BLUR_NORMAL_COS)
                    && dot(d, d) <= reach2 * (ox * ox + oy * oy) as f32
            };
        if on_surface {
            total += *weight;
        } else {
            *weight = 0.0;
        }
    }
    (cell, total)
}

/// The rays the gather casts at texel `(x, y)`: `rays` at every texel at stride 1 and at grid
/// texels, `orphan_rays` at orphans, else 0 ([`program::coarse`]).
fn coarse_rays(
    pos: View<'_>,
    nrm: View<'_>,
    params: &GatherParams,
    layer: u32,
    x: u32,
    y: u32,
) -> u32 {
    let stride = params.stride;
    if stride <= 1 || (x.is_multiple_of(stride) && y.is_multiple_of(stride)) {
        params.rays
    } else if coarse_weights(pos, nrm, stride, params.reach, layer, x, y).1 > 0.0 {
        0
    } else {
        params.orphan_rays
    }
}

/// [`Program::Upsample`] at one texel.
fn upsample_texel(
    [src, pos, nrm]: [View<'_>; 3],
    params: UpsampleParams,
    layer: u32,
    x: u32,
    y: u32,
) -> [f32; 4] {
    if pos.fetch(layer, x, y)[3] <= 0.5 {
        return [0.0; 4];
    }
    let own = src.fetch(layer, x, y);
    let (corners, total) = coarse_weights(pos, nrm, params.stride, params.reach, layer, x, y);
    if total.is_nan() || total <= 0.0 {
        return own;
    }
    let mut sum = [0.0f32; 3];
    for ([tx, ty], w) in corners {
        if w > 0.0 {
            let v = src.fetch(layer, tx as u32, ty as u32);
            for c in 0..3 {
                sum[c] += w * v[c];
            }
        }
    }
    [
        guard(sum[0] / total),
        guard(sum[1] / total),
        guard(sum[2] / total),
        1.0,
    ]
}

/// [`Program::Refine`] at one texel.
fn refine_texel(
    scene: &CpuScene,
    [pos_map, nrm_map, reflected, first_map, variance]: [View<'_>; 5],
    trav: Trav,
    params: RefineParams,
    layer: u32,
    x: u32,
    y: u32,
) -> [f32; 4] {
    let pos = pos_map.fetch(layer, x, y);
    let first = first_map.fetch(layer, x, y);
    if pos[3] <= 0.5 {
        return [0.0; 4];
    }
    let n = normalize(xyz(nrm_map.fetch(layer, x, y)));
    let (Some(n), 1..) = (n, params.rays) else {
        return first;
    };
    let noise = variance.fetch(layer, x, y);
    if noise[2].max(0.0).sqrt() <= params.max_error * noise[1] {
        return first;
    }
    let texel = GatherTexel {
        texel: rng::texel_index(scene.layer_size, layer, x, y),
        rays: params.first_rays..params.first_rays + params.rays,
        o: offset_origin(xyz(pos), n, scene.ray_epsilon),
        frame: Frame::new(n),
        mis: Mis::NONE,
    };
    let sampler = [params.sampler, params.bounce, params.seed];
    let mut sums = Vec::with_capacity(1);
    let mut chunks = [GatherChunk::default(), GatherChunk::default()];
    gather_sums(
        scene,
        reflected,
        trav,
        sampler,
        &[texel],
        &mut chunks,
        &mut sums,
    );
    let [sum] = sums[..] else {
        return first;
    };
    let total = (params.first_rays + params.rays) as f32;
    let k = params.first_rays as f32;
    [
        guard((k * first[0] + sum[0]) / total),
        guard((k * first[1] + sum[1]) / total),
        guard((k * first[2] + sum[2]) / total),
        1.0,
    ]
}

/// One axis of the masked Gaussian (see the module docs), prepared once per dispatch: the tap
/// weights and the normalised normals of every texel the dispatch's taps can reach, so that a
/// tap costs a look-up instead of an `exp` and a normalisation. Each weight and normal is
/// computed by the same expression as per tap, so the result is the same bit for bit.
struct BlurKernel {
    /// Texel step along the axis.
    step: [i64; 2],
    /// `exp(k²·inv)` of tap `k ∈ [−R, R]` at index `k + R`, `R` the radius clamped to
    /// [`MAX_BLUR_RADIUS`] (empty for a negative radius: no taps).
    weights: Vec<f32>,
    /// Texel of the layer at `normals[0]`.
    origin: [i64; 2],
    /// Columns of `normals`.
    columns: i64,
    /// Per texel of the reachable rectangle, row by row: the normal normalised by
    /// [`normalize`] (NaN where it cannot be), w = the object index.
    normals: Vec<[f32; 4]>,
}

impl BlurKernel {
    /// The kernel of a blur with `params` over the centres `x ∈ [x0, x1)`, `y ∈ [y0, y1)` of
    /// `layer`, whose normals `nrm` holds.
    fn new(params: BlurParams, nrm: View<'_>, layer: u32, [x0, y0, x1, y1]: [u32; 4]) -> Self {
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
                        let t = nrm.fetch(layer, (origin[0] + i as i64) as u32, y);
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
    fn normal(&self, x: i64, y: i64) -> Option<[f32; 4]> {
        let (i, j) = (x - self.origin[0], y - self.origin[1]);
        if i < 0 || j < 0 || i >= self.columns {
            return None;
        }
        self.normals.get((j * self.columns + i) as usize).copied()
    }

    /// The blurred value of texel `(x, y)` of `src` (a centre of [`BlurKernel::new`]'s).
    fn texel(&self, src: View<'_>, layer: u32, x: u32, y: u32) -> [f32; 4] {
        let centre = src.fetch(layer, x, y);
        if centre[3] <= 0.5 {
            return [0.0; 4];
        }
        let (x, y) = (i64::from(x), i64::from(y));
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
fn blur_texel(
    src: View<'_>,
    nrm: View<'_>,
    params: BlurParams,
    layer: u32,
    x: u32,
    y: u32,
) -> [f32; 4] {
    BlurKernel::new(params, nrm, layer, [x, y, x + 1, y + 1]).texel(src, layer, x, y)
}

/// The centre of a denoiser pass and the surface its taps must lie on (module docs: guide).
struct Guide<'a> {
    src: View<'a>,
    pos: View<'a>,
    nrm: View<'a>,
    layer: u32,
    x: i64,
    y: i64,
    p: [f32; 3],
    n: [f32; 3],
    object: f32,
    reach2: f32,
    reach_min2: f32,
    same_shape: bool,
}

impl<'a> Guide<'a> {
    /// The guide of texel `(x, y)` with the chart test's `[reach_min, reach]`; `None` when its
    /// normal cannot be normalised.
    #[allow(clippy::too_many_arguments)]
    fn new(
        src: View<'a>,
        pos: View<'a>,
        nrm: View<'a>,
        reach: [f32; 2],
        layer: u32,
        x: u32,
        y: u32,
    ) -> Option<Guide<'a>> {
        let nc = nrm.fetch(layer, x, y);
        Some(Guide {
            src,
            pos,
            nrm,
            layer,
            x: i64::from(x),
            y: i64::from(y),
            p: xyz(pos.fetch(layer, x, y)),
            n: normalize(xyz(nc))?,
            object: nc[3],
            reach2: reach[1] * reach[1],
            reach_min2: reach[0] * reach[0],
            same_shape: src.same_shape(&pos) && src.same_shape(&nrm),
        })
    }

    /// The tap at `offset` texels: its value and `n̂·n̂ₜ` when it lies on the centre's surface.
    fn tap(&self, offset: [i64; 2]) -> Option<([f32; 4], f32)> {
        let (tx, ty) = (self.x + offset[0], self.y + offset[1]);
        let size = self.src.size;
        if tx < 0 || ty < 0 || tx >= i64::from(size[0]) || ty >= i64::from(size[1]) {
            return None;
        }
        let (tx, ty) = (tx as u32, ty as u32);
        // One offset for the three maps when they have one shape (every dispatch's do).
        let (is, ip, inr) = if self.same_shape {
            let i = self.src.index(self.layer, tx, ty);
            (i, i, i)
        } else {
            (
                self.src.index(self.layer, tx, ty),
                self.pos.index(self.layer, tx, ty),
                self.nrm.index(self.layer, tx, ty),
            )
        };
        let t = self.src.at(is);
        if t[3] <= 0.5 {
            return None;
        }
        let nt = self.nrm.at(inr);
        if nt[3] != self.object {
            return None;
        }
        let d = sub(xyz(self.pos.at(ip)), self.p);
        let d2 = dot(d, d);
        let o2 = (offset[0] * offset[0] + offset[1] * offset[1]) as f32;
        let m = (offset[0].abs().max(offset[1].abs()) - 2).max(0);
        if o2 > 0.0 && !(d2 <= self.reach2 * o2 && d2 >= self.reach_min2 * (m * m) as f32) {
            return None;
        }
        Some((t, dot(self.n, normalize(xyz(nt))?)))
    }
}

/// The pairs directions of the variance estimate, in order.
const VARIANCE_DIRECTIONS: [[i64; 2]; 4] = [[1, 0], [0, 1], [1, 1], [1, -1]];

/// The noise variance of the luminance at one texel (see the module docs).
#[allow(clippy::too_many_arguments)]
fn variance_texel(
    src: View<'_>,
    pos: View<'_>,
    nrm: View<'_>,
    params: VarianceParams,
    layer: u32,
    x: u32,
    y: u32,
) -> [f32; 4] {
    if src.fetch(layer, x, y)[3] <= 0.5 {
        return [0.0; 4];
    }
    let Some(guide) = Guide::new(src, pos, nrm, [0.0, params.reach], layer, x, y) else {
        return [0.0, 0.0, 0.0, 1.0];
    };
    // The 5×5 window, row by row: the luminance of each tap on the surface.
    let mut window = [None; 25];
    for (k, w) in window.iter_mut().enumerate() {
        let o = [k as i64 % 5 - 2, k as i64 / 5 - 2];
        *w = match guide.tap(o) {
            Some((t, cos)) if cos >= BLUR_NORMAL_COS => Some(luminance(xyz(t))),
            _ => None,
        };
    }
    // With the centre, for the denoiser (a lone outlier raises its own estimate, so it is
    // smoothed); without it, for refinement (whose decision must not depend on the centre's
    // own noise).
    let [with_centre, without_centre] = window_variances(&window, params.min_pairs);
    window[12] = None;
    // The window's mean luminance without the centre: what refinement compares the noise with.
    let (mut sum, mut n) = (0.0f32, 0u32);
    for l in window.iter().flatten() {
        sum += l;
        n += 1;
    }
    let mean = if n > 0 { guard(sum / n as f32) } else { 0.0 };
    [with_centre, mean, without_centre, 1.0]
}

/// The variance estimates of a 5×5 window of luminances (`None`: not on the surface), with
/// and without its centre: per estimate the smallest over [`VARIANCE_DIRECTIONS`] with enough
/// pairs, else 0 (see the module docs). One pass over the pairs; each estimate sums its pairs
/// in the same order as a pass of its own would.
fn window_variances(window: &[Option<f32>; 25], min_pairs: u32) -> [f32; 2] {
    let mut best: [Option<f32>; 2] = [None; 2];
    for d in VARIANCE_DIRECTIONS {
        // [with the centre, without it].
        let (mut sum, mut n) = ([0.0f32; 2], [0u32; 2]);
        for k in 0..25i64 {
            let (i, j) = (k % 5 + d[0], k / 5 + d[1]);
            if !(0..5).contains(&i) || !(0..5).contains(&j) {
                continue;
            }
            let b = j * 5 + i;
            if let (Some(va), Some(vb)) = (window[k as usize], window[b as usize]) {
                let diff = vb - va;
                let d2 = diff * diff;
                sum[0] += d2;
                n[0] += 1;
                if k != 12 && b != 12 {
                    sum[1] += d2;
                    n[1] += 1;
                }
            }
        }
        for e in 0..2 {
            if n[e] >= min_pairs && n[e] > 0 {
                let v = sum[e] / (2 * n[e]) as f32;
                if best[e].is_none_or(|b| v < b) {
                    best[e] = Some(v);
                }
            }
        }
    }
    best.map(|b| guard(b.unwrap_or(0.0)))
}

/// One à-trous iteration at one texel (see the module docs).
#[allow(clippy::too_many_arguments)]
fn atrous_texel(
    src: View<'_>,
    variance: View<'_>,
    pos: View<'_>,
    nrm: View<'_>,
    params: AtrousParams,
    layer: u32,
    x: u32,
    y: u32,
) -> [f32; 4] {
    let c = src.fetch(layer, x, y);
    if c[3] <= 0.5 {
        return [0.0; 4];
    }
    let kept = [guard(c[0]), guard(c[1]), guard(c[2]), 1.0];
    let reach = [params.reach_min, params.reach];
    let Some(guide) = Guide::new(src, pos, nrm, reach, layer, x, y) else {
        return kept;
    };
    let scale = params.variance_scale * variance.fetch(layer, x, y)[0];
    let step = i64::from(params.step);
    let mut sum = [0.0f32; 3];
    let mut wsum = 0.0f32;
    for (j, &bj) in B3.iter().enumerate() {
        for (i, &bi) in B3.iter().enumerate() {
            let o = [(i as i64 - 2) * step, (j as i64 - 2) * step];
            let Some((t, cos)) = guide.tap(o) else {
                continue;
            };
            if cos.is_nan() || cos <= 0.0 {
                continue;
            }
            let mut wn = cos;
            for _ in 0..params.normal_log2 {
                if wn == 0.0 || wn == 1.0 {
                    break;
                }
                wn *= wn;
            }
            let d = [t[0] - c[0], t[1] - c[1], t[2] - c[2]];
            let dl = luminance(d);
            let wl = if dl == 0.0 {
                1.0
            } else if scale > 0.0 {
                (-(dl * dl) / scale).exp()
            } else {
                0.0
            };
            let w = bi * bj * wn * wl;
            if w.is_nan() || w <= 0.0 {
                continue;
            }
            for k in 0..3 {
                sum[k] += w * d[k];
            }
            wsum += w;
        }
    }
    if wsum > 0.0 {
        [
            guard(c[0] + sum[0] / wsum),
            guard(c[1] + sum[1] / wsum),
            guard(c[2] + sum[2] / wsum),
            1.0,
        ]
    } else {
        kept
    }
}

impl GpuBackend for CpuBackend {
    type Texture = CpuTexture;
    type Scene = CpuScene;
    type Error = CpuError;

    fn name(&self) -> &'static str {
        "cpu"
    }

    fn tile_work(&self) -> u64 {
        DEFAULT_TILE_WORK
    }

    fn limits(&self) -> Limits {
        Limits {
            max_texture_size: 16_384,
            max_array_layers: 2048,
            max_texture_units: 16,
        }
    }

    fn create_texture(&mut self, desc: &TexDesc) -> Result<CpuTexture, CpuError> {
        let n = (desc.size[0] as usize)
            .checked_mul(desc.size[1] as usize)
            .and_then(|n| n.checked_mul(desc.layers as usize))
            .and_then(|n| n.checked_mul(4))
            .filter(|&n| n <= isize::MAX as usize / 4)
            .ok_or(CpuError::TooLarge {
                size: desc.size,
                layers: desc.layers,
            })?;
        self.textures.push((desc.clone(), vec![0.0; n]));
        Ok(CpuTexture(self.textures.len() - 1))
    }

    fn upload(&mut self, texture: &CpuTexture, layer: u32, texels: &[f32]) -> Result<(), CpuError> {
        let (desc, data) = self
            .textures
            .get_mut(texture.0)
            .ok_or(CpuError::UnknownTexture(texture.0))?;
        if layer >= desc.layers {
            return Err(CpuError::LayerOutOfRange {
                layer,
                layers: desc.layers,
            });
        }
        let per_layer = 4 * desc.size[0] as usize * desc.size[1] as usize;
        if texels.len() != per_layer {
            return Err(CpuError::WrongSize {
                expected: per_layer,
                got: texels.len(),
            });
        }
        let start = layer as usize * per_layer;
        data[start..start + per_layer].copy_from_slice(texels);
        Ok(())
    }

    fn upload_scene(&mut self, scene: &SceneData<'_>) -> Result<CpuScene, CpuError> {
        for (i, l) in scene.lamps.iter().enumerate() {
            if l.table as usize >= scene.ies_tables.len() {
                return Err(CpuError::MissingTable {
                    lamp: i,
                    table: l.table,
                    tables: scene.ies_tables.len(),
                });
            }
        }
        Ok(CpuScene {
            bvh: Arc::clone(&scene.bvh.encoded),
            wide: Arc::clone(&scene.bvh.wide),
            attributes: decode_attributes(&scene.bvh.encoded),
            lamps: scene.lamps.to_vec(),
            tables: scene.ies_tables.to_vec(),
            regions: scene.regions.to_vec(),
            layer_size: scene.layer_size,
            ray_epsilon: scene.ray_epsilon,
        })
    }

    fn dispatch(&mut self, call: &Dispatch<'_, CpuTexture, CpuScene>) -> Result<(), CpuError> {
        let out_index = call.write.0;
        let (desc, mut out) = {
            let (d, data) = self
                .textures
                .get_mut(out_index)
                .ok_or(CpuError::UnknownTexture(out_index))?;
            (d.clone(), std::mem::take(data))
        };
        let result = (|| {
            let mut views = Vec::with_capacity(call.reads.len());
            for r in call.reads {
                let (d, data) = self.get(r)?;
                views.push(View {
                    data,
                    size: d.size,
                    layers: d.layers,
                });
            }
            let sizes: Vec<_> = views.iter().map(|v| (v.size, v.layers)).collect();
            call.check((desc.size, desc.layers), &sizes, call.scene.layer_size)
                .map_err(|reason| CpuError::BadBindings {
                    pass: call.label,
                    reason,
                })?;
            run_tile(call, &views, &desc, &mut out);
            Ok(())
        })();
        if let Some((_, data)) = self.textures.get_mut(out_index) {
            *data = out;
        }
        result
    }

    fn read_back(&mut self, texture: &CpuTexture, layer: u32) -> Result<Vec<f32>, CpuError> {
        let (desc, data) = self.get(texture)?;
        if layer >= desc.layers {
            return Err(CpuError::LayerOutOfRange {
                layer,
                layers: desc.layers,
            });
        }
        let per_layer = 4 * desc.size[0] as usize * desc.size[1] as usize;
        let start = layer as usize * per_layer;
        Ok(data[start..start + per_layer].to_vec())
    }
}

/// What a dispatch runs per row of its tile, prepared once per dispatch.
enum RowWork {
    /// The gather: a row's rays traced together ([`gather_row`]).
    Gather(GatherParams),
    /// The blur, its weights and normals prepared for the tile.
    Blur(BlurKernel),
    /// Any other program, texel by texel.
    Texels(TexelProgram),
}

/// The programs a dispatch computes texel by texel ([`texel`]), with their parameter blocks.
#[derive(Clone, Copy)]
enum TexelProgram {
    Direct(DirectParams),
    Copy,
    AlbedoMul,
    Combine(CombineParams),
    Variance(VarianceParams),
    Atrous(AtrousParams),
    Upsample(UpsampleParams),
    Refine(RefineParams),
}

/// Runs one dispatch: the tile's rows in parallel.
fn run_tile(
    call: &Dispatch<'_, CpuTexture, CpuScene>,
    views: &[View<'_>],
    desc: &TexDesc,
    out: &mut [f32],
) {
    let t = call.tile;
    let row_floats = 4 * desc.size[0] as usize;
    if row_floats == 0 || t.height == 0 {
        return;
    }
    let trav = traversal(call.bvh);
    let work = match Params::decode(call.program, call.params) {
        Params::Gather(p) => RowWork::Gather(p),
        Params::Blur(p) => {
            let rect = [t.x0, t.y0, t.x0 + t.width, t.y0 + t.height];
            RowWork::Blur(BlurKernel::new(p, views[1], t.layer, rect))
        }
        Params::Direct(p) => RowWork::Texels(TexelProgram::Direct(p)),
        Params::None if call.program == Program::AlbedoMul => {
            RowWork::Texels(TexelProgram::AlbedoMul)
        }
        // Copy, the one other program without parameters.
        Params::None => RowWork::Texels(TexelProgram::Copy),
        Params::Combine(p) => RowWork::Texels(TexelProgram::Combine(p)),
        Params::Variance(p) => RowWork::Texels(TexelProgram::Variance(p)),
        Params::Atrous(p) => RowWork::Texels(TexelProgram::Atrous(p)),
        Params::Upsample(p) => RowWork::Texels(TexelProgram::Upsample(p)),
        Params::Refine(p) => RowWork::Texels(TexelProgram::Refine(p)),
    };
    let start = (t.layer as usize * desc.size[1] as usize + t.y0 as usize) * row_floats;
    let end = start + t.height as usize * row_floats;
    out[start..end]
        .par_chunks_mut(row_floats)
        .enumerate()
        .for_each_init(GatherScratch::default, |scratch, (r, row)| {
            let y = t.y0 + r as u32;
            let texels = &mut row[4 * t.x0 as usize..4 * (t.x0 + t.width) as usize];
            match &work {
                RowWork::Gather(p) => {
                    let v = [views[0], views[1], views[2], views[3]];
                    gather_row(call.scene, v, trav, *p, t.layer, t.x0, y, texels, scratch);
                }
                RowWork::Blur(kernel) => {
                    each_texel(t.x0, texels, |x| kernel.texel(views[0], t.layer, x, y));
                }
                RowWork::Texels(p) => {
                    each_texel(t.x0, texels, |x| {
                        texel(call.scene, *p, views, trav, t.layer, x, y)
                    });
                }
            }
        });
}

/// Fills the RGBA texels `x0 ..` of a row with `f(x)`.
#[inline]
fn each_texel(x0: u32, texels: &mut [f32], f: impl Fn(u32) -> [f32; 4]) {
    for (x, out) in (x0..).zip(texels.chunks_exact_mut(4)) {
        out.copy_from_slice(&f(x));
    }
}

/// One texel of a program computed texel by texel.
#[inline]
fn texel(
    scene: &CpuScene,
    program: TexelProgram,
    v: &[View<'_>],
    trav: Trav,
    layer: u32,
    x: u32,
    y: u32,
) -> [f32; 4] {
    match program {
        TexelProgram::Direct(p) => direct_texel(
            scene,
            p,
            trav,
            v[0].fetch(layer, x, y),
            v[1].fetch(layer, x, y),
        ),
        TexelProgram::AlbedoMul => {
            let a = v[0].fetch(layer, x, y);
            let b = v[1].fetch(layer, x, y);
            [
                guard(a[0] * b[0]),
                guard(a[1] * b[1]),
                guard(a[2] * b[2]),
                a[3],
            ]
        }
        TexelProgram::Copy => v[0].fetch(layer, x, y),
        TexelProgram::Combine(w) => {
            let a = v[0].fetch(layer, x, y);
            let b = v[1].fetch(layer, x, y);
            [
                guard(w.a_weight * a[0] + w.b_weight * b[0]),
                guard(w.a_weight * a[1] + w.b_weight * b[1]),
                guard(w.a_weight * a[2] + w.b_weight * b[2]),
                a[3],
            ]
        }
        TexelProgram::Variance(p) => variance_texel(v[0], v[1], v[2], p, layer, x, y),
        TexelProgram::Atrous(p) => atrous_texel(v[0], v[1], v[2], v[3], p, layer, x, y),
        TexelProgram::Upsample(p) => upsample_texel([v[0], v[1], v[2]], p, layer, x, y),
        TexelProgram::Refine(p) => {
            refine_texel(scene, [v[0], v[1], v[2], v[3], v[4]], trav, p, layer, x, y)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::program::blur_params;

    #[test]
    fn basis_is_orthonormal_for_any_normal() {
        for n in [
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [1.0, 0.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.577_350_3, -0.577_350_3, 0.577_350_3],
            [0.0, 1e-8, -1.0],
        ] {
            let (t, b) = basis(n);
            for (a, c) in [(t, b), (t, n), (b, n)] {
                assert!(dot(a, c).abs() < 1e-6, "{n:?}");
            }
            for a in [t, b] {
                assert!((dot(a, a) - 1.0).abs() < 1e-6, "{n:?}");
            }
        }
    }

    #[test]
    fn four_directions_at_once_are_four_single_ones() {
        for (k, n) in [
            [0.0, 0.0, 1.0],
            [0.0, -1.0, 0.0],
            [0.3, -0.8, 0.2],
            [0.0, 1e-8, -1.0],
        ]
        .into_iter()
        .enumerate()
        {
            let frame = Frame::new(normalize(n).expect("unit"));
            for s in (0..400).step_by(4) {
                let u = [0, 1, 2, 3].map(|i| rng::uniform2(k as u32, s + i, 1, 9));
                let four = frame.cosine_directions4(u);
                for (i, d) in four.iter().enumerate() {
                    let one = frame.cosine_direction(u[i]);
                    assert_eq!(
                        d.map(f32::to_bits),
                        one.map(f32::to_bits),
                        "{n:?} {:?}",
                        u[i]
                    );
                }
            }
        }
    }

    #[test]
    fn sin_cos_turns_is_as_exact_as_libm() {
        let check = |u: f32| {
            let (s, c) = sin_cos_turns(u);
            let phi = 2.0 * std::f64::consts::PI * f64::from(u);
            let (es, ec) = phi.sin_cos();
            // 1.3e-7 relative on the reduced sine, 7e-8 absolute on the reduced cosine; after
            // the rotation either can be either.
            let tol = |e: f64| 1.5e-7 * e.abs().max(0.5);
            assert!(
                (f64::from(s) - es).abs() <= tol(es),
                "sin at u = {u}: {s} vs {es}"
            );
            assert!(
                (f64::from(c) - ec).abs() <= tol(ec),
                "cos at u = {u}: {c} vs {ec}"
            );
            assert!(
                s.abs() <= 1.0 && c.abs() <= 1.0,
                "u = {u}: |{s}|, |{c}| > 1"
            );
        };
        // Every 2^-24 multiple the sampler can draw in a few windows, and a dense sweep.
        for start in [0u32, 1 << 21, 1 << 22, 3 << 22, (1 << 24) - 4096] {
            for i in start..start + 4096 {
                check(i as f32 / 16_777_216.0);
            }
        }
        for i in 0..200_000 {
            check(i as f32 / 200_000.0);
        }
        // Exact at the quarter turns.
        assert_eq!(sin_cos_turns(0.0), (0.0, 1.0));
        assert_eq!(sin_cos_turns(0.25), (1.0, 0.0));
        assert_eq!(sin_cos_turns(0.5), (0.0, -1.0));
        assert_eq!(sin_cos_turns(0.75), (-1.0, 0.0));
        assert!(sin_cos_turns(f32::NAN).0.is_nan());
        assert!(sin_cos_turns(f32::INFINITY).1.is_nan());
    }

    #[test]
    fn cosine_directions_lie_in_the_hemisphere_with_mean_cosine_two_thirds() {
        let n = normalize([0.3, -0.8, 0.2]).expect("unit");
        let mut mean_cos = 0.0f64;
        let count = 20_000;
        for s in 0..count {
            let d = cosine_direction(n, rng::uniform2(17, s, 1, 3));
            let c = dot(d, n);
            assert!(c >= 0.0, "sample {s}");
            assert!((dot(d, d) - 1.0).abs() < 1e-5);
            mean_cos += f64::from(c);
        }
        // E[cos θ] under p(ω) = cos θ / π is 2/3.
        let m = mean_cos / f64::from(count);
        assert!((m - 2.0 / 3.0).abs() < 0.01, "{m}");
    }

    fn one_triangle_scene(lamp: [f32; 3]) -> CpuScene {
        use luxbake_bvh::{BuildOptions, Bvh, EncodeOptions, TriangleAttributes, encode};
        let tris = vec![[[-1.0, 0.0, -1.0], [-1.0, 0.0, 1.0], [1.0, 0.0, 0.0]]];
        let attrs = vec![TriangleAttributes {
            normals: [[0.0, 1.0, 0.0]; 3],
            uvs: [[0.0, 0.0], [0.0, 1.0], [1.0, 0.5]],
            object: 0,
        }];
        let bvh = Bvh::build(&tris, &BuildOptions::default()).expect("bvh");
        let enc = encode(&bvh, &tris, &attrs, &EncodeOptions::default()).expect("encode");
        CpuScene {
            wide: Arc::new(WideBvh::from_encoded(&enc)),
            attributes: decode_attributes(&enc),
            bvh: Arc::new(enc),
            lamps: vec![LampParams {
                position: lamp,
                world_to_photometric: [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]],
                scale: [1.0; 3],
                table: 0,
            }],
            tables: vec![luxbake_ies::Photometry::isotropic(1e6).gpu_table()],
            regions: vec![None],
            layer_size: [1, 1],
            ray_epsilon: crate::backend::ray_epsilon(1.0),
        }
    }

    /// The gather's directions (four draws at a time, with AVX2 where the CPU has it) are the
    /// module docs' per-ray rule bit for bit, `cosine_direction(n̂, uniform2(texel, s, bounce,
    /// seed))`, for both samplers, ray counts with and without a remainder of four, and
    /// samples inside and past the pass's precomputed ones.
    #[test]
    fn gather_directions_are_the_per_ray_rule_bit_for_bit() {
        let (pass, seed) = (2, 77);
        let texels: Vec<GatherTexel> = (0..60u32)
            .map(|i| {
                let start = i % 3;
                let angle = i as f32 * 0.37;
                let n = normalize([angle.sin(), 0.3 - (i % 2) as f32, angle.cos()]).expect("n");
                GatherTexel {
                    texel: i * 1013,
                    rays: start..start + i % 11,
                    o: [0.0; 3],
                    frame: Frame::new(n),
                    mis: Mis::NONE,
                }
            })
            .collect();
        let mut dirs = Vec::new();
        for sampler in rng::Sampler::ALL {
            let want: Vec<[u32; 3]> = texels
                .iter()
                .flat_map(|t| {
                    t.rays.clone().map(move |s| {
                        let u = sampler.uniform2(t.texel, s, pass, seed);
                        cosine_direction(t.frame.n, u).map(f32::to_bits)
                    })
                })
                .collect();
            assert!(want.len() > 250, "{}", want.len());
            for precomputed in [0..13, 1..5] {
                let draws = rng::PassDraws::new(sampler, pass, seed, precomputed.clone());
                directions(&mut dirs, &draws, &texels);
                let got: Vec<[u32; 3]> = dirs.iter().map(|d| d.map(f32::to_bits)).collect();
                assert_eq!(got, want, "{sampler}, samples {precomputed:?} precomputed");
            }
        }
    }

    /// The gather's look-up (footprint, texel indices, prefetch, fetch, masked blend) reads
    /// what `map::sample_masked` reads, bit for bit, for regions inside the map (the indices
    /// from the region's first texel) and for regions reaching past its edges or layers (the
    /// indices texel by texel, texels outside reading 0).
    #[test]
    fn a_gather_look_up_is_the_masked_sample_inside_and_across_the_map_edges() {
        let mut scene = one_triangle_scene([0.0, 1.0, 0.0]);
        let (size, layers) = ([8u32, 6u32], 2u32);
        let mut state = 12_345u32;
        let mut next = || {
            state = crate::rng::pcg(state);
            crate::rng::unit_f32(state)
        };
        let data: Vec<f32> = (0..4 * size[0] * size[1] * layers)
            .map(|i| {
                if i % 4 == 3 {
                    f32::from(next() > 0.2)
                } else {
                    10.0 * next()
                }
            })
            .collect();
        let map = View {
            data: &data,
            size,
            layers,
        };
        let regions = [
            (0, [0, 0], [8, 6]),
            (1, [2, 1], [3, 4]),
            (0, [6, 0], [5, 3]),
            (1, [1, 4], [3, 5]),
            (2, [0, 0], [2, 2]),
            (0, [7, 5], [1, 1]),
        ];
        let attr = scene.attributes[0].0;
        let mut compared = 0;
        for (layer, offset, rect) in regions {
            let region = Region {
                layer,
                offset,
                size: rect,
            };
            scene.regions = vec![Some(region)];
            for _ in 0..500 {
                let (u, v) = (next(), next());
                let (u, v) = if u + v > 1.0 {
                    (1.0 - u, 1.0 - v)
                } else {
                    (u, v)
                };
                let hit = Hit {
                    t: 1.0,
                    triangle: 0,
                    u,
                    v,
                };
                let lookup = gather_lookup(&scene, map, &hit, [0.1, -1.0, 0.2])
                    .expect("a front hit on a receiver");
                let got = lookup.weights.map_or([0.0; 3], |w| {
                    let t = lookup.texels.map(|i| map.at_offset(i));
                    masked_blend([(t[0], w[0]), (t[1], w[1]), (t[2], w[2]), (t[3], w[3])])
                });
                let w0 = 1.0 - u - v;
                let [a, b, c] = attr.uvs;
                let uv = [
                    w0 * a[0] + u * b[0] + v * c[0],
                    w0 * a[1] + u * b[1] + v * c[1],
                ];
                let want =
                    crate::map::sample_masked(|x, y| map.fetch(layer, x, y), offset, rect, uv);
                assert_eq!(
                    got.map(f32::to_bits),
                    want.map(f32::to_bits),
                    "region {region:?} uv {uv:?}"
                );
                compared += 1;
            }
        }
        assert_eq!(compared, 3000);
        // A region whose offset overflows the texel coordinates reads 0 (no panic).
        scene.regions = vec![Some(Region {
            layer: 0,
            offset: [u32::MAX - 1, 0],
            size: [4, 4],
        })];
        let hit = Hit {
            t: 1.0,
            triangle: 0,
            u: 0.3,
            v: 0.3,
        };
        let lookup = gather_lookup(&scene, map, &hit, [0.0, -1.0, 0.0]).expect("front hit");
        assert!(lookup.texels.iter().all(|&i| map.at_offset(i) == [0.0; 4]));
    }

    const ONE_LAMP: DirectParams = DirectParams {
        lamp_count: 1,
        pad0: 0,
        pad1: 0,
        pad2: 0,
    };

    #[test]
    fn direct_stays_finite_for_a_lamp_on_or_next_to_the_surface() {
        let p = [0.0, 0.0, 0.0, 1.0];
        let n = [0.0, 1.0, 0.0, 0.0];
        for (lamp, expect_lit) in [
            ([0.0, 0.0, 0.0], false),
            ([0.0, 1e-9, 0.0], true),
            ([0.0, 1e-3, 0.0], true),
            // |to|² underflows to 0: the lamp is on the texel, which it does not light.
            ([1e-30, 1e-30, 0.0], false),
            ([1e-20, 1e-20, 0.0], true),
            ([0.0, -1e-3, 0.0], false),
        ] {
            let scene = one_triangle_scene(lamp);
            let e = direct_texel(&scene, ONE_LAMP, Trav::Encoded(Traversal::BruteForce), p, n);
            assert!(
                e.iter().all(|v| v.is_finite() && *v >= 0.0),
                "{lamp:?}: {e:?}"
            );
            assert_eq!(e[0] > 0.0, expect_lit, "{lamp:?}: {e:?}");
            // Never more than I / ε².
            let eps = scene.ray_epsilon;
            assert!(
                f64::from(e[0]) <= 1e6 / f64::from(eps * eps) * 1.0001,
                "{e:?}"
            );
        }
        // 1 mm above: I / d² exactly (cos = 1).
        let e = direct_texel(
            &one_triangle_scene([0.0, 1e-3, 0.0]),
            ONE_LAMP,
            Trav::Wide,
            p,
            n,
        );
        assert!((f64::from(e[0]) - 1e12).abs() < 1e12 * 1e-5, "{e:?}");
    }

    #[test]
    fn guard_maps_nan_and_inf() {
        assert_eq!(guard(f32::NAN), 0.0);
        assert_eq!(guard(f32::INFINITY), f32::MAX);
        assert_eq!(guard(-1.0), 0.0);
        assert_eq!(guard(2.5), 2.5);
    }

    #[test]
    fn blur_keeps_empty_texels_and_other_objects_out() {
        // One row: [obj0 1.0] [obj0 3.0] [empty] [obj1 100.0]
        let size = [4, 1];
        let src = [
            1.0, 1.0, 1.0, 1.0, 3.0, 3.0, 3.0, 1.0, 0.0, 0.0, 0.0, 0.0, 100.0, 100.0, 100.0, 1.0,
        ];
        let nrm = [
            0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0,
        ];
        let s = View {
            data: &src,
            size,
            layers: 1,
        };
        let n = View {
            data: &nrm,
            size,
            layers: 1,
        };
        let a = blur_texel(s, n, blur_params([1, 0], 1.0), 0, 0, 0);
        let b = blur_texel(s, n, blur_params([1, 0], 1.0), 0, 1, 0);
        let w = (-0.5f32).exp();
        let expected_a = (1.0 + 3.0 * w) / (1.0 + w);
        assert!((a[0] - expected_a).abs() < 1e-6, "{a:?}");
        let expected_b = (3.0 + 1.0 * w) / (1.0 + w);
        assert!((b[0] - expected_b).abs() < 1e-6, "{b:?}");
        assert_eq!(
            blur_texel(s, n, blur_params([1, 0], 1.0), 0, 2, 0),
            [0.0; 4]
        );
        assert_eq!(
            blur_texel(s, n, blur_params([1, 0], 5.0), 0, 3, 0),
            [100.0, 100.0, 100.0, 1.0]
        );
        // A vertical pass over a one-row image sees only the centre.
        assert_eq!(
            blur_texel(s, n, blur_params([0, 1], 3.0), 0, 1, 0),
            [3.0, 3.0, 3.0, 1.0]
        );
    }
}

#[cfg(test)]
mod denoiser_tests {
    use super::*;
    use crate::program::{AtrousConfig, Params, atrous_steps, blur_params};

    /// Texel size of the synthetic fields, metres.
    const H: f32 = 0.1;

    /// A synthetic one-layer light map with its G-buffer.
    #[derive(Clone)]
    struct Field {
        size: [u32; 2],
        map: Vec<f32>,
        pos: Vec<f32>,
        nrm: Vec<f32>,
    }

    fn view(data: &[f32], size: [u32; 2]) -> View<'_> {
        View {
            data,
            size,
            layers: 1,
        }
    }

    /// One pass over every texel of a one-layer map of `size`.
    fn apply(size: [u32; 2], f: impl Fn(u32, u32) -> [f32; 4]) -> Vec<f32> {
        (0..size[1])
            .flat_map(|y| (0..size[0]).map(move |x| (x, y)))
            .flat_map(|(x, y)| f(x, y))
            .collect()
    }

    /// A standard normal number from the RNG hash (Box–Muller).
    fn gauss(texel: u32, seed: u32) -> f32 {
        let [u0, u1] = rng::uniform2(texel, 0, 0, seed);
        (-2.0 * (1.0 - u0).ln()).sqrt() * (2.0 * std::f32::consts::PI * u1).cos()
    }

    impl Field {
        /// A floor chart (normal +Y, object 0) of texels `H` metres apart, all valid with
        /// grey value `value(x, y)`.
        fn flat(size: [u32; 2], value: impl Fn(u32, u32) -> f32) -> Field {
            let mut f = Field {
                size,
                map: Vec::new(),
                pos: Vec::new(),
                nrm: Vec::new(),
            };
            for y in 0..size[1] {
                for x in 0..size[0] {
                    let v = value(x, y);
                    f.map.extend([v, v, v, 1.0]);
                    f.pos
                        .extend([(x as f32 + 0.5) * H, 0.0, (y as f32 + 0.5) * H, 1.0]);
                    f.nrm.extend([0.0, 1.0, 0.0, 0.0]);
                }
            }
            f
        }

        fn index(&self, x: u32, y: u32) -> usize {
            4 * (y * self.size[0] + x) as usize
        }

        fn value(&self, x: u32, y: u32) -> [f32; 4] {
            let i = self.index(x, y);
            [0, 1, 2, 3].map(|c| self.map[i + c])
        }

        /// Makes texel `(x, y)` empty (all zeros, as the G-buffer has it) with `garbage` in
        /// the map's RGB.
        fn clear(&mut self, x: u32, y: u32, garbage: f32) {
            let i = self.index(x, y);
            self.map[i..i + 4].copy_from_slice(&[garbage, garbage, garbage, 0.0]);
            self.pos[i..i + 4].fill(0.0);
            self.nrm[i..i + 4].fill(0.0);
        }

        /// The variance map and the output of `config`'s passes.
        fn denoise(&self, config: &AtrousConfig) -> (Vec<f32>, Vec<f32>) {
            let size = self.size;
            let (pos, nrm) = (view(&self.pos, size), view(&self.nrm, size));
            let mut variance = Vec::new();
            let mut out = self.map.clone();
            for (_, params) in atrous_steps(config) {
                let src = out.clone();
                let s = view(&src, size);
                match params {
                    Params::Variance(p) => {
                        variance = apply(size, |x, y| variance_texel(s, pos, nrm, p, 0, x, y));
                    }
                    Params::Atrous(p) => {
                        let v = view(&variance, size);
                        out = apply(size, |x, y| atrous_texel(s, v, pos, nrm, p, 0, x, y));
                    }
                    other => panic!("{other:?}"),
                }
            }
            (variance, out)
        }

        /// The separable Gaussian of the blur passes (U, then V).
        fn gaussian(&self, sigma: f32) -> Vec<f32> {
            let (size, nrm) = (self.size, view(&self.nrm, self.size));
            let u = apply(size, |x, y| {
                blur_texel(
                    view(&self.map, size),
                    nrm,
                    blur_params([1, 0], sigma),
                    0,
                    x,
                    y,
                )
            });
            apply(size, |x, y| {
                blur_texel(view(&u, size), nrm, blur_params([0, 1], sigma), 0, x, y)
            })
        }
    }

    /// RMSE of the red channel of `map` against `truth(x, y)` over the texels `keep` accepts.
    fn rmse(
        f: &Field,
        map: &[f32],
        truth: impl Fn(u32, u32) -> f32,
        keep: impl Fn(u32, u32) -> bool,
    ) -> f64 {
        let (mut se, mut n) = (0.0f64, 0usize);
        for y in 0..f.size[1] {
            for x in (0..f.size[0]).filter(|&x| keep(x, y)) {
                let e = f64::from(map[f.index(x, y)]) - f64::from(truth(x, y));
                se += e * e;
                n += 1;
            }
        }
        assert!(n > 0);
        (se / n as f64).sqrt()
    }

    const ITERATIONS: u32 = 5;

    #[test]
    fn a_constant_field_is_returned_exactly() {
        // A floor of object 0 (value 3.7) with a hole, object 1 (value 0.25) on the right and a
        // wall strip facing +X at the top (value 12), whose texels are an edge apart.
        let mut f = Field::flat([40, 24], |x, _| if x >= 30 { 0.25 } else { 3.7 });
        for y in 8..12 {
            for x in 10..15 {
                f.clear(x, y, 1e6);
            }
        }
        for y in 0..24 {
            for x in 30..40 {
                let i = f.index(x, y);
                f.nrm[i + 3] = 1.0;
            }
        }
        for y in 0..3 {
            for x in 0..30 {
                let i = f.index(x, y);
                f.map[i..i + 3].fill(12.0);
                f.pos[i..i + 3].copy_from_slice(&[0.0, (3 - y) as f32 * H, x as f32 * H]);
                f.nrm[i..i + 3].copy_from_slice(&[1.0, 0.0, 0.0]);
            }
        }
        let (variance, out) = f.denoise(&AtrousConfig::new(ITERATIONS, H));
        for y in 0..24 {
            for x in 0..40 {
                let i = f.index(x, y);
                let v = f.value(x, y);
                if v[3] > 0.5 {
                    assert_eq!(out[i..i + 4], v, "({x}, {y})");
                    // No noise; the mean luminance of the window without the centre is the
                    // field's (one grey level per surface here).
                    let (var, mean) = (&variance[i..i + 4], luminance(xyz(v)));
                    assert_eq!([var[0], var[2], var[3]], [0.0, 0.0, 1.0], "({x}, {y})");
                    assert!((var[1] - mean).abs() <= 1e-6 * mean, "({x}, {y}): {var:?}");
                } else {
                    assert_eq!(out[i..i + 4], [0.0; 4], "({x}, {y})");
                    assert_eq!(variance[i..i + 4], [0.0; 4], "({x}, {y})");
                }
            }
        }
    }

    /// A noisy field split at x = 24: the left half around 1, the right half around `right`.
    fn split_field(right: f32) -> Field {
        Field::flat([48, 32], |x, y| {
            let base = if x < 24 { 1.0 } else { right };
            base * (1.0 + 0.2 * gauss(y * 48 + x, 5))
        })
    }

    /// Asserts that each half of `f` is denoised exactly as if the other half were empty.
    fn halves_are_independent(f: &Field, config: &AtrousConfig) {
        let (_, both) = f.denoise(config);
        for left in [true, false] {
            let mut alone = f.clone();
            for y in 0..32 {
                for x in (0..48).filter(|&x| (x < 24) != left) {
                    alone.clear(x, y, 0.0);
                }
            }
            let (_, out) = alone.denoise(config);
            for y in 0..32 {
                for x in (0..48).filter(|&x| (x < 24) == left) {
                    let i = f.index(x, y);
                    assert_eq!(both[i..i + 4], out[i..i + 4], "({x}, {y})");
                }
            }
        }
    }

    #[test]
    fn no_light_moves_between_objects_or_charts() {
        let config = AtrousConfig::new(ITERATIONS, H);
        // Two objects side by side on one plane: contiguous positions and normals.
        let mut objects = split_field(40.0);
        for y in 0..32 {
            for x in 24..48 {
                let i = objects.index(x, y);
                objects.nrm[i + 3] = 1.0;
            }
        }
        halves_are_independent(&objects, &config);
        // Two charts of one object, adjacent in the map, 20 m apart in the world (as far as
        // five iterations reach: 32·√2 texels × 1.5 × 0.1 m = 6.8 m, and more).
        for right in [40.0, 1.5] {
            let mut charts = split_field(right);
            for y in 0..32 {
                for x in 24..48 {
                    let i = charts.index(x, y);
                    charts.pos[i + 2] += 20.0;
                }
            }
            halves_are_independent(&charts, &config);
            // Without the chart test they do exchange light: the other chart's texels then
            // also inflate the variance estimate, which lets even the large step through.
            let loose = AtrousConfig {
                chart_tolerance: 1e6,
                ..config
            };
            let (_, mixed) = charts.denoise(&loose);
            let (_, kept) = charts.denoise(&config);
            let left = |m: &[f32]| (0..32).map(|y| m[charts.index(23, y)]).sum::<f32>() / 32.0;
            println!(
                "charts 1 | {right}: mean next to the seam {} (without the chart test {})",
                left(&kept),
                left(&mixed)
            );
            assert!(left(&mixed) > left(&kept) + 0.05);
        }
    }

    #[test]
    fn the_chart_test_rejects_taps_nearer_or_farther_than_their_offset_allows() {
        // Along a row of texels H apart, move the texel 8 to the right of the centre to a
        // distance `d`: on the chart it may lie (8 − 2)·H/1.5 = 0.4 m to 8·1.5·H = 1.2 m away.
        let config = AtrousConfig::new(1, H);
        let reach = [config.reach_min(), config.reach()];
        for (d, accepted) in [
            (0.8, true),
            (0.41, true),
            (1.19, true),
            (0.1, false),
            (0.39, false),
            (1.21, false),
        ] {
            let mut f = Field::flat([16, 1], |_, _| 1.0);
            let i = f.index(10, 0);
            f.pos[i] = f.pos[f.index(2, 0)] + d;
            let (src, pos, nrm) = (
                view(&f.map, f.size),
                view(&f.pos, f.size),
                view(&f.nrm, f.size),
            );
            let guide = Guide::new(src, pos, nrm, reach, 0, 2, 0).expect("normal");
            assert_eq!(guide.tap([8, 0]).is_some(), accepted, "{d}");
            // Within two texels only the upper bound applies.
            assert!(guide.tap([1, 0]).is_some() && guide.tap([0, 0]).is_some());
        }
    }

    #[test]
    fn noise_on_a_flat_field_is_reduced() {
        let sigma = 0.1f32;
        let f = Field::flat([64, 64], |x, y| 1.0 + sigma * gauss(y * 64 + x, 11));
        let (variance, out) = f.denoise(&AtrousConfig::new(ITERATIONS, H));
        let all = |_, _| true;
        let before = rmse(&f, &f.map, |_, _| 1.0, all);
        let after = rmse(&f, &out, |_, _| 1.0, all);
        let mean_var = variance
            .chunks_exact(4)
            .map(|t| f64::from(t[0]))
            .sum::<f64>()
            / 4096.0;
        println!(
            "flat field: RMSE {before:.4} → {after:.4} ({:.1}× less); mean variance estimate \
             {mean_var:.5} (true {:.5})",
            before / after,
            sigma * sigma
        );
        assert!(before / after > 8.0, "{before} → {after}");
        // The estimate is the smallest of four: a little under σ².
        let rel = mean_var / f64::from(sigma * sigma);
        assert!((0.6..=1.05).contains(&rel), "{rel}");
    }

    #[test]
    fn a_low_noise_shadow_edge_survives_better_than_under_the_gaussian() {
        // A contact shadow: 1.0 lit, 0.2 shadowed from x = 32 on, with 1 % noise.
        let signal = |x: u32, _| if x < 32 { 1.0 } else { 0.2 };
        let f = Field::flat([64, 64], |x, y| {
            signal(x, y) * (1.0 + 0.01 * gauss(y * 64 + x, 3))
        });
        let (variance, out) = f.denoise(&AtrousConfig::new(ITERATIONS, H));
        let gaussian = f.gaussian(2.0);
        let near = |x: u32, _| (28..36).contains(&x);
        let far = |x: u32, _| !(20..44).contains(&x);
        let atrous_edge = rmse(&f, &out, signal, near);
        let gauss_edge = rmse(&f, &gaussian, signal, near);
        let noisy_far = rmse(&f, &f.map, signal, far);
        let atrous_far = rmse(&f, &out, signal, far);
        println!(
            "shadow edge (±4 texels): RMSE à-trous {atrous_edge:.5}, Gaussian σ = 2 \
             {gauss_edge:.5} ({:.0}× less); away from it noise {noisy_far:.5} → {atrous_far:.5}",
            gauss_edge / atrous_edge
        );
        assert!(
            atrous_edge * 10.0 < gauss_edge,
            "{atrous_edge} vs {gauss_edge}"
        );
        assert!(atrous_far * 3.0 < noisy_far, "{noisy_far} → {atrous_far}");
        // The edge does not inflate the variance estimate next to it.
        let i = f.index(31, 32);
        assert!(variance[i] < 4.0 * 0.01 * 0.01, "{}", variance[i]);
    }

    #[test]
    fn outputs_stay_finite_and_lonely_texels_keep_their_value() {
        let mut f = Field::flat([12, 12], |x, y| (x * 12 + y) as f32);
        let specials = [
            ((2, 2), f32::NAN),
            ((3, 2), f32::INFINITY),
            ((4, 2), f32::MAX),
            ((5, 2), -1.0),
        ];
        for ((x, y), v) in specials {
            let i = f.index(x, y);
            f.map[i..i + 3].fill(v);
        }
        // A centre without a usable normal, and a texel alone among empty ones.
        let i = f.index(8, 8);
        f.nrm[i..i + 3].fill(0.0);
        for y in 9..12 {
            for x in 0..3 {
                if (x, y) != (1, 10) {
                    f.clear(x, y, 0.0);
                }
            }
        }
        let (variance, out) = f.denoise(&AtrousConfig::new(ITERATIONS, H));
        for v in variance.iter().chain(&out) {
            assert!(v.is_finite() && *v >= 0.0, "{v}");
        }
        assert_eq!(out[f.index(8, 8)..f.index(8, 8) + 4], f.value(8, 8));
        assert_eq!(out[f.index(1, 10)..f.index(1, 10) + 4], f.value(1, 10));
        assert_eq!(variance[f.index(1, 10)], 0.0);
    }

    /// The reduced-resolution gather's reach on a [`Field`]: the denoiser's chart test.
    const COARSE_REACH: f32 = H * 1.5;

    /// The rays the gather at `stride` (16 rays per grid texel, 5 per orphan) casts at `(x, y)`.
    fn rays_at(pos: View<'_>, nrm: View<'_>, stride: u32, x: u32, y: u32) -> u32 {
        let params = GatherParams {
            rays: 16,
            stride,
            reach: COARSE_REACH,
            orphan_rays: 5,
            ..GatherParams::default()
        };
        coarse_rays(pos, nrm, &params, 0, x, y)
    }

    /// A 13×13 floor with column 11 and row 11 a one-texel strip of another object, valued
    /// `strip`, the floor `floor(x, y)`.
    fn floor_with_strip(floor: impl Fn(u32, u32) -> f32, strip: f32) -> Field {
        let mut f = Field::flat([13, 13], floor);
        for k in 0..13 {
            for (x, y) in [(11, k), (k, 11)] {
                let i = f.index(x, y);
                f.nrm[i + 3] = 1.0;
                f.map[i..i + 3].fill(strip);
            }
        }
        f
    }

    #[test]
    fn the_coarse_grid_traces_grid_texels_and_orphans_only() {
        let f = floor_with_strip(|_, _| 1.0, 1.0);
        let (pos, nrm) = (view(&f.pos, f.size), view(&f.nrm, f.size));
        for stride in [2u32, 3, 4] {
            for y in (0..13).filter(|&y| y != 11) {
                for x in (0..13).filter(|&x| x != 11) {
                    // Every floor texel's corner (x₀, y₀) is floor, so only grid texels are
                    // traced, with the grid's rays.
                    let grid = x % stride == 0 && y % stride == 0;
                    assert_eq!(
                        rays_at(pos, nrm, stride, x, y),
                        if grid { 16 } else { 0 },
                        "stride {stride} ({x}, {y})"
                    );
                }
            }
            // No grid line runs along the strip (11 is no multiple of 2, 3 or 4): every strip
            // texel is an orphan, with the orphans' rays.
            for k in 0..13 {
                assert_eq!(rays_at(pos, nrm, stride, 11, k), 5, "stride {stride}");
                assert_eq!(rays_at(pos, nrm, stride, k, 11), 5, "stride {stride}");
            }
        }
        // Stride 1 traces everything with the grid's rays.
        assert_eq!(rays_at(pos, nrm, 1, 5, 7), 16);
        assert_eq!(rays_at(pos, nrm, 1, 11, 7), 16);
        assert_eq!(coarse::orphan_rays(16, 3), 6);
        assert_eq!(coarse::orphan_rays(1, 4), 1);
    }

    #[test]
    fn upsampling_reproduces_a_linear_field_and_keeps_grid_texels_and_orphans() {
        let linear = |x: u32, y: u32| 2.0 + 0.25 * x as f32 + 0.5 * y as f32;
        let mut f = floor_with_strip(linear, 7.0);
        // Garbage where the gather at stride 4 writes nothing (the gather writes 0 there).
        for y in (0..13).filter(|&y| y != 11) {
            for x in (0..13).filter(|&x| x != 11 && (x % 4 != 0 || y % 4 != 0)) {
                let i = f.index(x, y);
                f.map[i..i + 3].fill(1e6);
            }
        }
        let size = f.size;
        let (pos, nrm) = (view(&f.pos, size), view(&f.nrm, size));
        let params = UpsampleParams {
            stride: 4,
            reach: COARSE_REACH,
            ..UpsampleParams::default()
        };
        let out = apply(size, |x, y| {
            upsample_texel([view(&f.map, size), pos, nrm], params, 0, x, y)
        });
        let mut compared = 0;
        for y in 0..13 {
            for x in 0..13 {
                let (got, want) = (out[f.index(x, y)], linear(x, y));
                if x == 11 || y == 11 {
                    // Orphans keep their own value: no floor light crosses into the strip.
                    assert_eq!(got, 7.0, "strip ({x}, {y})");
                } else {
                    // Bilinear interpolation of a linear field between floor corners (across
                    // the strip too: it is the same floor) is exact.
                    assert!(
                        (got - want).abs() <= 1e-5 * want,
                        "({x}, {y}): {got} vs {want}"
                    );
                }
                compared += 1;
            }
        }
        assert_eq!(compared, 169);
    }
}
