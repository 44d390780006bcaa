//! What the passes' CPU references share: the uploaded scene ([`CpuScene`]) and its
//! traversals, read access to a texture ([`View`]), the operations every backend computes the
//! same way (the guard, the normalisation, the basis, cosine directions), the
//! reduced-resolution grid and the denoiser's surface test ([`Guide`]), and the one interface
//! a pass implements on the CPU ([`CpuPass`], or [`TexelPass`] for a pass computed texel by
//! texel). Each pass's reference lives in its folder (`passes/<label>/cpu.rs`); the registry
//! dispatches to it ([`crate::passes::run_on_cpu`]).

use std::sync::Arc;

use luxbake_bvh::{EncodedScene, Hit, Ray, Traversal, TriangleAttributes, WideBvh};
use luxbake_ies::GpuTable;
use rayon::prelude::*;

use crate::backend::{LAMP_PATH_TEXELS, LampParams, SceneData};
use crate::contract::{BLUR_NORMAL_COS, ParamBlock, TileParams, coarse};
use crate::cpu::hits::GatherHits;
pub(crate) use crate::exact::{basis, dot, guard, luminance, mad, normalize, sub};
use crate::layout::Region;
use crate::passes::gather::GatherParams;
use crate::scene::BvhMode;

/// What one dispatch of a pass reads: the scene, the views of its read slots (in
/// [`Signature::reads`](crate::program::Signature::reads) order), the traversal and the tile.
pub(crate) struct Ctx<'a> {
    /// The uploaded scene.
    pub(crate) scene: &'a CpuScene,
    /// The read slots.
    pub(crate) views: &'a [View<'a>],
    /// The traversal of a ray-casting pass.
    pub(crate) trav: Trav,
    /// The tile.
    pub(crate) tile: TileParams,
    /// The denoiser's chart tests kept by the backend, and per read slot what identifies its
    /// texels ([`GuideCache`]).
    pub(crate) guides: Option<(&'a GuideCache, &'a [Option<u64>])>,
}

/// How a pass is prepared for one dispatch from its parameter words. A pass whose state is
/// its parameter block implements its CPU reference on the block itself, built by the blanket
/// impl; a pass without parameters is declared by [`parameterless_pass!`]; any other says how.
pub(crate) trait Prepare: Sized {
    /// The pass for one dispatch.
    fn prepare(words: &[u32], ctx: &Ctx<'_>) -> Self;
}

impl<P: ParamBlock> Prepare for P {
    fn prepare(words: &[u32], _: &Ctx<'_>) -> Self {
        P::from_words(words)
    }
}

/// Declares the unit struct `$name`, the CPU state of a pass without parameters.
macro_rules! parameterless_pass {
    ($(#[$meta:meta])* $name:ident) => {
        $(#[$meta])*
        pub(crate) struct $name;

        impl $crate::cpu::kernel::Prepare for $name {
            fn prepare(_: &[u32], _: &$crate::cpu::kernel::Ctx<'_>) -> Self {
                $name
            }
        }
    };
}

pub(crate) use parameterless_pass;

/// A pass's CPU reference: prepared once per dispatch from its parameter words ([`Prepare`]),
/// then run row by row (rows in parallel, each thread with its own scratch).
pub(crate) trait CpuPass: Prepare + Sync {
    /// Per-thread scratch, reused from row to row.
    type Scratch: Default + Send;
    /// The RGBA texels `ctx.tile.x0 ..` of row `y` of the tile's layer.
    fn row(&self, ctx: &Ctx<'_>, y: u32, texels: &mut [f32], scratch: &mut Self::Scratch);
}

impl<'a> Ctx<'a> {
    /// The first `N` read slots, in [`Signature::reads`](crate::program::Signature::reads)
    /// order.
    #[inline]
    pub(crate) fn maps<const N: usize>(&self) -> [View<'a>; N] {
        std::array::from_fn(|i| self.views[i])
    }

    /// The chart tests of the taps `step` texels apart ([`GuideMasks`]) of the position map
    /// in read slot `slot`, when the backend keeps them and knows that map's texels.
    pub(crate) fn guide_masks(&self, slot: usize, chart: Chart) -> Option<Arc<GuideMasks>> {
        let (cache, ids) = self.guides?;
        let id = (*ids.get(slot)?)?;
        Some(cache.masks(id, *self.views.get(slot)?, chart))
    }

    /// The grid corners ([`CoarseMasks`]) of the position and normal maps in read slots
    /// `slots`, when the backend keeps them and knows both maps' texels.
    pub(crate) fn coarse_masks(
        &self,
        slots: [usize; 2],
        stride: u32,
        reach: f32,
    ) -> Option<Arc<CoarseMasks>> {
        let (cache, ids) = self.guides?;
        let id = |s: usize| *ids.get(s)?;
        let view = |s: usize| self.views.get(s).copied();
        let ids = [id(slots[0])?, id(slots[1])?];
        let maps = [view(slots[0])?, view(slots[1])?];
        Some(cache.corners(ids, maps, stride, reach))
    }
}

/// Texel `(x, y)` of `layer` of a texture array: where a pass computes, and what it reads
/// from each map there ([`View::fetch`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Texel {
    /// Texture-array layer.
    pub(crate) layer: u32,
    /// Column.
    pub(crate) x: u32,
    /// Row.
    pub(crate) y: u32,
}

#[cfg(test)]
impl Texel {
    /// Texel `(x, y)` of layer 0.
    pub(crate) fn layer0(x: u32, y: u32) -> Texel {
        Texel { layer: 0, x, y }
    }
}

/// A pass computed texel by texel.
pub(crate) trait TexelPass: Prepare + Sync {
    /// The pass's value at `at`.
    fn texel(&self, ctx: &Ctx<'_>, at: Texel) -> [f32; 4];
}

impl<T: TexelPass> CpuPass for T {
    type Scratch = ();

    #[inline]
    fn row(&self, ctx: &Ctx<'_>, y: u32, texels: &mut [f32], _: &mut ()) {
        let layer = ctx.tile.layer;
        for (x, out) in (ctx.tile.x0..).zip(texels.chunks_exact_mut(4)) {
            out.copy_from_slice(&self.texel(ctx, Texel { layer, x, y }));
        }
    }
}

/// Runs pass `P` with parameter words `words` over the tile of `ctx` into `out`, the written
/// texture's data (`row_floats` floats per row, `layer_rows` rows per layer).
pub(crate) fn run<P: CpuPass>(
    words: &[u32],
    ctx: &Ctx<'_>,
    out: &mut [f32],
    [row_floats, layer_rows]: [usize; 2],
) {
    let t = ctx.tile;
    if row_floats == 0 || t.height == 0 {
        return;
    }
    let pass = P::prepare(words, ctx);
    let start = (t.layer as usize * layer_rows + t.y0 as usize) * row_floats;
    let end = start + t.height as usize * row_floats;
    out[start..end]
        .par_chunks_mut(row_floats)
        .enumerate()
        .for_each_init(P::Scratch::default, |scratch, (r, row)| {
            let texels = &mut row[4 * t.x0 as usize..4 * (t.x0 + t.width) as usize];
            pass.row(ctx, t.y0 + r as u32, texels, scratch);
        });
}

/// The uploaded scene of the CPU backend (owned copies, as a GPU upload would make).
#[derive(Debug, Clone)]
pub struct CpuScene {
    pub(crate) bvh: Arc<EncodedScene>,
    pub(crate) wide: Arc<WideBvh>,
    /// [`EncodedScene::triangle_attributes`] of every encoded triangle, decoded once at upload
    /// so that a gather hit reads them from an array, a cache line each.
    pub(crate) attributes: Vec<HitAttributes>,
    pub(crate) lamps: Vec<LampParams>,
    pub(crate) tables: Vec<GpuTable>,
    /// One [`crate::lightpaths::DensityProxy`] per table, for the gather's MIS weight.
    pub(crate) proxies: Vec<crate::lightpaths::DensityProxy>,
    pub(crate) regions: Vec<Option<Region>>,
    pub(crate) layer_size: [u32; 2],
    pub(crate) ray_epsilon: f32,
    /// [`crate::backend::SceneData::lamp_paths`], a cache line per point ([`LampPoint`]).
    pub(crate) lamp_paths: Vec<LampPoint>,
    /// Gather hits kept across bakes of this room ([`CpuScene::keep_gather_hits`]).
    pub(crate) hits: Option<Arc<GatherHits>>,
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
    // Rounds `4u` to the nearest integer (ties to even).
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

/// `e^x` for the denoiser's range weight (`x ≤ 0` there; NaN passes through): `2^n · e^r`,
/// `n = round(x·log₂e)`, `r = x − n·ln 2` with ln 2 in two parts (Cody and Waite, so `r` is
/// exact to a few ulp), `e^r` by Cephes' degree-6 polynomial for `expf` on `|r| ≤ ln 2 / 2`,
/// `2^n` built from its bits. Relative error ≤ 3·10⁻⁷ against `f64` on `[−87, 88]` (tests);
/// below −87 (`e^x < 1.7·10⁻³⁸`, where `f32` turns subnormal) it gives 0, above 88 infinity.
/// Only multiplications, additions and bit operations, so that the denoiser's AVX2 lanes
/// (`lanes::exp8`) compute the same bits eight at a time and the blocks equal the texel-by-texel
/// reference (alone, one at a time, it is no faster than the C library's `expf`); the bits are
/// the same in the native and the wasm32 builds. The shaders call their own `exp`, which their
/// platforms round as they do.
#[inline(always)]
pub(crate) fn exp_f32(x: f32) -> f32 {
    if x.is_nan() {
        return x;
    }
    if x < EXP_LOW {
        return 0.0;
    }
    if x > EXP_HIGH {
        return f32::INFINITY;
    }
    let n = (x * std::f32::consts::LOG2_E + ROUND) - ROUND;
    let r = (x - n * EXP_LN2[0]) - n * EXP_LN2[1];
    let mut p = EXP_POLY[0];
    for c in &EXP_POLY[1..] {
        p = p * r + c;
    }
    let e = (p * r) * r + r + 1.0;
    e * f32::from_bits(((n as i32 + 127) as u32) << 23)
}

/// 1.5·2^23: adding and subtracting it rounds an `f32` under 2^22 to the nearest integer
/// (ties to even).
pub(crate) const ROUND: f32 = 12_582_912.0;
/// [`exp_f32`]'s domain: 0 below, infinity above.
pub(crate) const EXP_LOW: f32 = -87.0;
/// See [`EXP_LOW`].
pub(crate) const EXP_HIGH: f32 = 88.0;
/// ln 2 in two parts (Cody and Waite): the first exact in few bits, so `n·EXP_LN2[0]` is exact.
pub(crate) const EXP_LN2: [f32; 2] = [0.693_359_4, -2.121_944_4e-4];
/// Cephes' `expf` polynomial, highest power first: `e^r ≈ 1 + r + r²·P(r)` (its last
/// coefficient, 0.50000001, is 0.5 in `f32`).
pub(crate) const EXP_POLY: [f32; 6] = [
    1.987_569_1e-4,
    1.398_199_9e-3,
    8.333_452e-3,
    4.166_579_6e-2,
    1.666_666_5e-1,
    0.5,
];

/// The cosine-weighted direction of gather sample `(u0, u1)` about unit `n`.
#[inline]
pub fn cosine_direction(n: [f32; 3], u: [f32; 2]) -> [f32; 3] {
    Frame::new(n).cosine_direction(u)
}

/// A unit normal with its tangent and bitangent ([`basis`]): built once for the many rays
/// of one texel.
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    pub(crate) t: [f32; 3],
    pub(crate) b: [f32; 3],
    pub(crate) n: [f32; 3],
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

    /// The uniformly distributed direction over the hemisphere of sample `(u0, u1)`: the
    /// cosine of its angle to the normal is `1 − u0` (density `1/2π` per steradian), its
    /// azimuth that of [`Frame::cosine_direction`]. The gather draws a texel's rays so in a
    /// narrow gap ([`crate::validity::NARROW_GAP`]; see [`crate::lightpaths::gather_weight`]).
    #[inline]
    pub fn uniform_direction(&self, u: [f32; 2]) -> [f32; 3] {
        let Frame { t, b, n } = *self;
        let r = (u[0] * (2.0 - u[0])).max(0.0).sqrt();
        let (sin, cos) = sin_cos_turns(u[1]);
        let (x, y) = (r * cos, r * sin);
        let z = 1.0 - u[0];
        [
            t[0] * x + b[0] * y + n[0] * z,
            t[1] * x + b[1] * y + n[1] * z,
            t[2] * x + b[2] * y + n[2] * z,
        ]
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
pub(crate) enum Trav {
    /// The wide BVH ([`CpuScene::wide`]).
    Wide,
    /// A traversal of the encoded textures.
    Encoded(Traversal),
}

impl Trav {
    /// A number per traversal ([`crate::cpu::hits`]' row keys).
    pub(crate) fn id(self) -> u32 {
        match self {
            Trav::Wide => 0,
            Trav::Encoded(Traversal::Mtbvh) => 1,
            Trav::Encoded(Traversal::Tbvh) => 2,
            Trav::Encoded(Traversal::BruteForce) => 3,
        }
    }
}

/// A point of the lamp paths' pool as the `connect` pass reads it: the packed rows of
/// [`crate::lightpaths::LampPaths::packed`] (position and density, normal, power) and the
/// shadow ray's end, [`offset_origin`] of the point along its normal — computed once per
/// upload instead of at each of the point's connections (the same bits) — in one 64-byte
/// cache line, so that a pick prefetches one line and waits for one.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
pub(crate) struct LampPoint {
    /// Position (xyz) and density (w): the pool's first row.
    pub(crate) position: [f32; 4],
    /// The unit normal.
    pub(crate) normal: [f32; 3],
    /// The power (RGB): the pool's third row.
    pub(crate) power: [f32; 3],
    /// Where the shadow ray toward the point ends: `offset_origin(position, normal, ε)`.
    pub(crate) target: [f32; 3],
}

impl LampPoint {
    /// The points of the packed pool `paths` ([`LAMP_PATH_TEXELS`] RGBA rows each), for the
    /// ray offset's size term `eps`.
    pub(crate) fn unpack(paths: &[f32], eps: f32) -> Vec<LampPoint> {
        paths
            .chunks_exact(4 * LAMP_PATH_TEXELS)
            .map(|p| {
                let normal = [p[4], p[5], p[6]];
                let position = [p[0], p[1], p[2]];
                LampPoint {
                    position: [p[0], p[1], p[2], p[3]],
                    normal,
                    power: [p[8], p[9], p[10]],
                    target: crate::backend::offset_origin(position, normal, eps),
                }
            })
            .collect()
    }
}

pub(crate) fn traversal(mode: BvhMode) -> Trav {
    match mode {
        BvhMode::Wide => Trav::Wide,
        BvhMode::Mtbvh => Trav::Encoded(Traversal::Mtbvh),
        BvhMode::Tbvh => Trav::Encoded(Traversal::Tbvh),
        BvhMode::None => Trav::Encoded(Traversal::BruteForce),
    }
}

impl CpuScene {
    /// The scene of a bake as the passes' CPU references read it: the BVHs shared, each
    /// triangle's attributes decoded once, the lamps, tables (and their density proxies), regions
    /// and lamp paths copied.
    pub fn new(scene: &SceneData<'_>) -> CpuScene {
        CpuScene {
            bvh: Arc::clone(&scene.bvh.encoded),
            wide: Arc::clone(&scene.bvh.wide),
            attributes: decode_attributes(&scene.bvh.encoded),
            lamps: scene.lamps.to_vec(),
            tables: scene.ies_tables.to_vec(),
            proxies: scene
                .ies_tables
                .iter()
                .map(crate::lightpaths::DensityProxy::new)
                .collect(),
            regions: scene.regions.to_vec(),
            layer_size: scene.layer_size,
            ray_epsilon: scene.ray_epsilon,
            lamp_paths: LampPoint::unpack(scene.lamp_paths, scene.ray_epsilon),
            hits: None,
        }
    }

    /// Lets the gather passes on this scene replay the rows `hits` recorded in its BVH and
    /// record the others ([`crate::cpu::hits`]).
    pub fn keep_gather_hits(&mut self, hits: Arc<GatherHits>) {
        hits.keep_for(&self.bvh);
        self.hits = Some(hits);
    }

    #[inline]
    pub(crate) fn closest_hit(&self, ray: &Ray, t_min: f32, t_max: f32, trav: Trav) -> Option<Hit> {
        match trav {
            Trav::Wide => self.wide.closest_hit(ray, t_min, t_max),
            Trav::Encoded(t) => self.bvh.closest_hit(ray, t_min, t_max, t),
        }
    }

    /// Encoded triangle `t`'s attributes (those of [`EncodedScene::triangle_attributes`], from
    /// [`decode_attributes`]' array), in place; `None` past the scene's triangles, which no
    /// hit names.
    #[inline]
    pub(crate) fn attributes(&self, t: u32) -> Option<&TriangleAttributes> {
        self.attributes.get(t as usize).map(|a| &a.0)
    }

    #[inline]
    pub(crate) fn any_hit(&self, ray: &Ray, t_min: f32, t_max: f32, trav: Trav) -> bool {
        match trav {
            Trav::Wide => self.wide.any_hit(ray, t_min, t_max),
            Trav::Encoded(t) => self.bvh.any_hit(ray, t_min, t_max, t),
        }
    }
}

/// Every encoded triangle's attributes ([`EncodedScene::triangle_attributes`]), decoded once
/// at upload so that a gather hit reads them from an array.
pub(crate) fn decode_attributes(bvh: &EncodedScene) -> Vec<HitAttributes> {
    (0..bvh.triangle_count)
        .map(|t| HitAttributes(bvh.triangle_attributes(t)))
        .collect()
}

/// A triangle's attributes on a cache line of their own (they are 64 bytes): a gather hit
/// reads them with one access to the cache, and in place.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
pub(crate) struct HitAttributes(pub(crate) TriangleAttributes);

/// Read access to one RGBA32F texture array: `layers` layers of `size` texels, row 0 first,
/// four floats a texel.
#[derive(Clone, Copy)]
pub struct View<'a> {
    pub(crate) data: &'a [f32],
    pub(crate) size: [u32; 2],
    pub(crate) layers: u32,
}

impl<'a> View<'a> {
    /// A view of `data`, a texture of `layers` layers of `size` texels.
    pub fn new(data: &'a [f32], size: [u32; 2], layers: u32) -> View<'a> {
        View { data, size, layers }
    }
}

impl View<'_> {
    /// The offset of texel `(x, y)` of `layer` in the data, if it is inside.
    #[inline]
    pub(crate) fn index(&self, layer: u32, x: u32, y: u32) -> Option<usize> {
        (x < self.size[0] && y < self.size[1] && layer < self.layers).then(|| {
            4 * ((layer as usize * self.size[1] as usize + y as usize) * self.size[0] as usize
                + x as usize)
        })
    }

    /// The texel at `index` (of [`View::index`] of a view of the same size), 0 outside.
    #[inline]
    pub(crate) fn at(&self, index: Option<usize>) -> [f32; 4] {
        index.map_or([0.0; 4], |i| self.at_offset(i))
    }

    /// The texel at `index` (of [`View::index`] of a view of the same size), 0 outside
    /// (`usize::MAX`, say).
    #[inline]
    pub(crate) fn at_offset(&self, index: usize) -> [f32; 4] {
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
    pub(crate) fn rect_origin(&self, region: &Region) -> Option<usize> {
        let [ox, oy] = region.offset.map(u64::from);
        let [w, h] = region.size.map(u64::from);
        let inside = ox + w <= u64::from(self.size[0]) && oy + h <= u64::from(self.size[1]);
        inside
            .then(|| self.index(region.layer, region.offset[0], region.offset[1]))
            .flatten()
    }

    /// The texel at `t`, 0 outside.
    #[inline]
    pub(crate) fn fetch(&self, t: Texel) -> [f32; 4] {
        self.at(self.index(t.layer, t.x, t.y))
    }

    pub(crate) fn same_shape(&self, other: &View<'_>) -> bool {
        self.size == other.size && self.layers == other.layers
    }
}

pub(crate) fn xyz(t: [f32; 4]) -> [f32; 3] {
    [t[0], t[1], t[2]]
}

/// The weights of texel `at`'s grid-cell corners ([`program::coarse`]) that count
/// (`corners`: [`coarse_corners`]' bits), 0 for the others, and their sum.
pub(crate) fn coarse_weights(corners: u8, stride: u32, at: Texel) -> ([([i64; 2], f32); 4], f32) {
    let mut cell = coarse::cell(at.x, at.y, stride);
    let mut total = 0.0f32;
    for (k, (_, weight)) in cell.iter_mut().enumerate() {
        if corners & (1 << k) != 0 {
            total += *weight;
        } else {
            *weight = 0.0;
        }
    }
    (cell, total)
}

/// Which of texel `at`'s grid-cell corners ([`program::coarse`], bit `k` for corner `k`) have
/// a positive weight and lie on its surface; none where its normal cannot be normalised or it
/// lies in a narrow gap.
pub(crate) fn coarse_corners([pos, nrm]: [View<'_>; 2], stride: u32, reach: f32, at: Texel) -> u8 {
    let Some(centre) = CoarseCentre::new([pos, nrm], reach, at) else {
        return 0;
    };
    let mut bits = 0u8;
    for (k, &(corner, weight)) in coarse::cell(at.x, at.y, stride).iter().enumerate() {
        if weight > 0.0 && centre.on_surface(corner) {
            bits |= 1 << k;
        }
    }
    bits
}

/// [`coarse_corners`] of texel `at`: read from `masks` where given (kept by the backend), else
/// tested — the same bits.
pub(crate) fn corners_at(
    masks: Option<&CoarseMasks>,
    maps: [View<'_>; 2],
    stride: u32,
    reach: f32,
    at: Texel,
) -> u8 {
    masks
        .and_then(|m| m.at(at))
        .unwrap_or_else(|| coarse_corners(maps, stride, reach, at))
}

/// A texel of [`coarse_corners`] and the test of its grid corners.
struct CoarseCentre<'a> {
    pos: View<'a>,
    nrm: View<'a>,
    at: Texel,
    p: [f32; 3],
    n: [f32; 3],
    object: f32,
    reach2: f32,
}

impl<'a> CoarseCentre<'a> {
    /// `None` when the texel's normal cannot be normalised or it lies in a narrow gap
    /// ([`crate::validity::NARROW`]: no corner counts, it is an orphan).
    fn new([pos, nrm]: [View<'a>; 2], reach: f32, at: Texel) -> Option<CoarseCentre<'a>> {
        let (pc, nc) = (pos.fetch(at), nrm.fetch(at));
        if pc[3] >= crate::validity::NARROW {
            return None;
        }
        Some(CoarseCentre {
            pos,
            nrm,
            at,
            p: xyz(pc),
            n: normalize(xyz(nc))?,
            object: nc[3],
            reach2: reach * reach,
        })
    }

    /// Whether grid texel `corner` is valid and on the centre's surface: same object, normals
    /// within [`BLUR_NORMAL_COS`], within the reach per texel of offset.
    fn on_surface(&self, [tx, ty]: [i64; 2]) -> bool {
        let (pos, nrm) = (self.pos, self.nrm);
        if tx >= i64::from(pos.size[0]) || ty >= i64::from(pos.size[1]) {
            return false;
        }
        let (tx, ty) = (tx as u32, ty as u32);
        let t = Texel {
            x: tx,
            y: ty,
            ..self.at
        };
        let (pt, nt) = (pos.fetch(t), nrm.fetch(t));
        let d = sub(xyz(pt), self.p);
        let (ox, oy) = (
            tx as i64 - i64::from(self.at.x),
            ty as i64 - i64::from(self.at.y),
        );
        pt[3] > 0.5
            && nt[3] == self.object
            // The G-buffer's normals are unit: used as stored (module docs of `crate::cpu`).
            && dot(self.n, xyz(nt)) >= BLUR_NORMAL_COS
            && dot(d, d) <= self.reach2 * (ox * ox + oy * oy) as f32
    }
}

/// The rays the gather casts at texel `at`: `rays` at every texel at stride 1, at grid texels
/// and at texels in a narrow gap ([`crate::validity::NARROW`]), `orphan_rays` at the other
/// orphans, else 0 ([`program::coarse`]).
/// The bits of [`CoarseMasks`] stand in for the corners' tests where given.
pub(crate) fn coarse_rays(
    maps: [View<'_>; 2],
    params: &GatherParams,
    masks: Option<&CoarseMasks>,
    at: Texel,
) -> u32 {
    let stride = params.stride;
    // Covered: some corner of its cell counts (then the upsampling fills it in).
    let covered = || corners_at(masks, maps, stride, params.reach, at) != 0;
    let [pos, _] = maps;
    if stride <= 1
        || (at.x.is_multiple_of(stride) && at.y.is_multiple_of(stride))
        || pos.fetch(at)[3] >= crate::validity::NARROW
    {
        params.rays
    } else if covered() {
        0
    } else {
        params.orphan_rays
    }
}

/// Per texel of a G-buffer, which corners of its grid cell count (`coarse_corners`: a positive
/// weight and on its surface) for one grid stride and reach: the later
/// bounces' gathers (which texels are orphans) and upsamplings of a bake, and of every bake
/// of the same room, read them instead of testing the corners' positions and normals again
/// (the CPU backend keeps them in its [`GuideCache`]): the same corners, bit for bit. One byte
/// per texel (0.7 MB for `chairs_05` at 64 texels/m).
#[derive(Debug)]
pub struct CoarseMasks {
    size: [u32; 2],
    layers: u32,
    bits: Vec<u8>,
}

impl CoarseMasks {
    /// The corners of every valid texel of `[pos, nrm]` (0 for the others).
    pub(crate) fn new(maps: [View<'_>; 2], stride: u32, reach: f32) -> CoarseMasks {
        let [pos, _] = maps;
        let [w, h] = pos.size;
        let mut bits = vec![0u8; pos.layers as usize * h as usize * w as usize];
        if w > 0 {
            bits.par_chunks_mut(w as usize)
                .enumerate()
                .for_each(|(r, row)| {
                    let (layer, y) = ((r / h as usize) as u32, (r % h as usize) as u32);
                    for (x, out) in (0..w).zip(row.iter_mut()) {
                        let at = Texel { layer, x, y };
                        if pos.fetch(at)[3] > 0.5 {
                            *out = coarse_corners(maps, stride, reach, at);
                        }
                    }
                });
        }
        CoarseMasks {
            size: pos.size,
            layers: pos.layers,
            bits,
        }
    }

    /// Texel `at`'s corners; `None` outside the map.
    #[inline]
    pub(crate) fn at(&self, at: Texel) -> Option<u8> {
        let i = flat_index(self.size, self.layers, at)?;
        self.bits.get(i).copied()
    }

    /// Bytes of the bits.
    pub fn bytes(&self) -> usize {
        self.bits.len()
    }
}

/// The centre of a denoiser pass and the surface its taps must lie on (module docs: guide).
pub(crate) struct Guide<'a> {
    pub(crate) src: View<'a>,
    pub(crate) pos: View<'a>,
    pub(crate) nrm: View<'a>,
    pub(crate) layer: u32,
    pub(crate) x: i64,
    pub(crate) y: i64,
    pub(crate) p: [f32; 3],
    pub(crate) n: [f32; 3],
    pub(crate) object: f32,
    pub(crate) reach2: f32,
    pub(crate) reach_min2: f32,
    /// When the three maps have one shape (every dispatch's do): the centre's offset in
    /// them, from which a tap's is a sum ([`Guide::tap`]).
    pub(crate) centre: Option<usize>,
    /// The centre's chart tests from [`GuideMasks`] ([`Guide::with_masks`]).
    pub(crate) mask: Option<u32>,
}

impl<'a> Guide<'a> {
    /// The guide of texel `at` of `src` (its position and normal in `pos` and `nrm`) with the
    /// chart test's `[reach_min, reach]`; `None` when its normal cannot be normalised.
    pub(crate) fn new(
        [src, pos, nrm]: [View<'a>; 3],
        reach: [f32; 2],
        at: Texel,
    ) -> Option<Guide<'a>> {
        let nc = nrm.fetch(at);
        Some(Guide {
            src,
            pos,
            nrm,
            layer: at.layer,
            x: i64::from(at.x),
            y: i64::from(at.y),
            p: xyz(pos.fetch(at)),
            n: normalize(xyz(nc))?,
            object: nc[3],
            reach2: reach[1] * reach[1],
            reach_min2: reach[0] * reach[0],
            centre: (src.same_shape(&pos) && src.same_shape(&nrm))
                .then(|| src.index(at.layer, at.x, at.y))
                .flatten(),
            mask: None,
        })
    }

    /// The guide with the centre's chart tests from `masks` (made for this guide's position
    /// map and `[reach_min, reach]` at the step of the taps asked for), when it has them.
    #[inline]
    pub(crate) fn with_masks(mut self, masks: Option<&GuideMasks>, at: Texel) -> Guide<'a> {
        if let (Some(m), Some(_)) = (masks, self.centre) {
            self.mask = m.at(at);
        }
        self
    }

    /// Tap `k` of the 5 × 5 (rows outer, `k = 5·row + column`) at `offset` texels:
    /// [`Guide::tap`], its chart test read from the centre's mask when there is one.
    #[inline(always)]
    pub(crate) fn tap_k(&self, k: usize, offset: [i64; 2]) -> Option<([f32; 4], f32)> {
        let (Some(mask), Some(c)) = (self.mask, self.centre) else {
            return self.tap(offset);
        };
        if mask & (1 << k) == 0 {
            return None;
        }
        // In the layer (the mask says so), the three maps of one shape.
        let i =
            Some((c as i64 + 4 * (offset[1] * i64::from(self.src.size[0]) + offset[0])) as usize);
        let (t, nt) = self.of_object(i, i)?;
        Some((t, dot(self.n, xyz(nt))))
    }

    /// The tap's value (at `is` in the filtered map) and its stored normal (at `inr`) when it
    /// is valid and of the centre's object.
    #[inline(always)]
    fn of_object(&self, is: Option<usize>, inr: Option<usize>) -> Option<([f32; 4], [f32; 4])> {
        let t = self.src.at(is);
        if t[3] <= 0.5 {
            return None;
        }
        let nt = self.nrm.at(inr);
        (nt[3] == self.object).then_some((t, nt))
    }

    /// The tap at `offset` texels: its value and `n̂·nₜ` (the tap's normal as stored, unit)
    /// when it lies on the centre's surface.
    #[inline(always)]
    pub(crate) fn tap(&self, offset: [i64; 2]) -> Option<([f32; 4], f32)> {
        let (tx, ty) = (self.x + offset[0], self.y + offset[1]);
        let size = self.src.size;
        if tx < 0 || ty < 0 || tx >= i64::from(size[0]) || ty >= i64::from(size[1]) {
            return None;
        }
        // One offset for the three maps when they have one shape (every dispatch's do): the
        // centre's plus the tap's offset, the same as `View::index` of the tap, inside the
        // layer (just checked).
        let (is, ip, inr) = if let Some(c) = self.centre {
            let d = 4 * (offset[1] * i64::from(size[0]) + offset[0]);
            let i = Some((c as i64 + d) as usize);
            (i, i, i)
        } else {
            let (tx, ty) = (tx as u32, ty as u32);
            (
                self.src.index(self.layer, tx, ty),
                self.pos.index(self.layer, tx, ty),
                self.nrm.index(self.layer, tx, ty),
            )
        };
        let (t, nt) = self.of_object(is, inr)?;
        let d = sub(xyz(self.pos.at(ip)), self.p);
        if !Shell::new(offset, self.reach2, self.reach_min2).holds(dot(d, d)) {
            return None;
        }
        // The G-buffer's normals are unit: used as stored (module docs of `crate::cpu`).
        Some((t, dot(self.n, xyz(nt))))
    }
}

/// The chart test of a tap `offset` texels from the centre (module docs of [`crate::cpu`]:
/// guide): the squared distances `[reach_min²·m², reach²·|o|²]`, `m = max(0, ‖o‖∞ − 2)`, its
/// world position may lie at; the centre itself passes at any distance. One rule for
/// [`Guide::tap`] and [`GuideMasks`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct Shell {
    centre: bool,
    lo: f32,
    hi: f32,
}

impl Shell {
    /// The shell of `offset` for the squared reaches `reach2` and `reach_min2`.
    #[inline(always)]
    pub(crate) fn new(offset: [i64; 2], reach2: f32, reach_min2: f32) -> Shell {
        let o2 = (offset[0] * offset[0] + offset[1] * offset[1]) as f32;
        let m = (offset[0].abs().max(offset[1].abs()) - 2).max(0);
        Shell {
            centre: offset == [0, 0],
            lo: reach_min2 * (m * m) as f32,
            hi: reach2 * o2,
        }
    }

    /// Whether a tap at squared distance `d2` from the centre lies in it.
    #[inline(always)]
    pub(crate) fn holds(self, d2: f32) -> bool {
        self.centre || (d2 <= self.hi && d2 >= self.lo)
    }
}

/// The chart test's parameters ([`Guide::tap`]): the taps' step and `[reach_min, reach]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Chart {
    pub(crate) step: i64,
    pub(crate) reach: [f32; 2],
}

impl Chart {
    /// Per tap of the 5 × 5 (rows outer) its offset and its shell.
    fn taps(self) -> [([i64; 2], Shell); 25] {
        let [reach_min2, reach2] = self.reach.map(|r| r * r);
        std::array::from_fn(|k| {
            let o = [
                (k as i64 % 5 - 2) * self.step,
                (k as i64 / 5 - 2) * self.step,
            ];
            (o, Shell::new(o, reach2, reach_min2))
        })
    }

    /// The parameters as bits, the nearest bound cleared where no tap reaches it (a step of
    /// 1: every offset within 2 texels).
    fn key(self) -> [u64; 3] {
        // With no offset beyond 2 texels the test is `d² ≥ reach_min²·0`: true whatever a
        // finite `reach_min` is.
        let nearest = self.reach[0] * self.reach[0];
        let reach_min = if self.step.abs() <= 1 && nearest.is_finite() {
            0.0
        } else {
            self.reach[0]
        };
        [
            self.step as u64,
            u64::from(reach_min.to_bits()),
            u64::from(self.reach[1].to_bits()),
        ]
    }
}

/// Texel `at`'s index in a per-texel array of `layers` layers of `size` (one element a
/// texel, row by row, layer after layer); `None` outside.
#[inline]
fn flat_index(size: [u32; 2], layers: u32, at: Texel) -> Option<usize> {
    if at.layer >= layers || at.x >= size[0] || at.y >= size[1] {
        return None;
    }
    Some((at.layer as usize * size[1] as usize + at.y as usize) * size[0] as usize + at.x as usize)
}

/// Per texel of a position map, which of the 25 taps `step·(i, j)`, `i, j ∈ −2..=2` (bit
/// `5·(j + 2) + i + 2`) lie in the layer and pass the chart test of the denoiser's guide (the
/// module docs of [`crate::cpu`]: a tap's distance within its offset's shell) — the part
/// of a tap's test that reads the tap's position. The denoiser's passes read a
/// tap's position only for it, so with the bits they skip that read (a bake of a room whose
/// masks are kept: the denoiser 0.77× on the CPU), and test the rest (the tap's validity, its
/// object, its normal) as before: the same taps, bit for bit. Texels whose position is not
/// valid have none (their guide tests its taps itself).
#[derive(Debug)]
pub struct GuideMasks {
    size: [u32; 2],
    layers: u32,
    bits: Vec<u32>,
}

/// One row of a position map and the chart tests of [`GuideMasks::new`]: the taps' offsets and
/// shells.
struct MaskRows<'a> {
    /// The position map's floats.
    pos: &'a [f32],
    /// Its layer size, texels.
    size: [i64; 2],
    /// The row's layer's first float.
    layer_start: usize,
    /// The row.
    y: i64,
    /// Per tap (the 5 × 5, rows outer) its offset and shell.
    taps: &'a [([i64; 2], Shell); 25],
}

impl MaskRows<'_> {
    /// The bits of texel `x` of the row: tap `k`'s bit where it lies in the map and in its
    /// shell; none where the centre's position is not valid.
    fn at(&self, x: i64) -> u32 {
        let [w, h] = self.size;
        let row_floats = 4 * w as usize;
        let c = self.layer_start + self.y as usize * row_floats + 4 * x as usize;
        if self.pos[c + 3] <= 0.5 {
            return 0;
        }
        let p = [self.pos[c], self.pos[c + 1], self.pos[c + 2]];
        let mut m = 0u32;
        for (k, &(o, shell)) in self.taps.iter().enumerate() {
            let (tx, ty) = (x + o[0], self.y + o[1]);
            if tx < 0 || ty < 0 || tx >= w || ty >= h {
                continue;
            }
            let t = self.layer_start + ty as usize * row_floats + 4 * tx as usize;
            let d = sub([self.pos[t], self.pos[t + 1], self.pos[t + 2]], p);
            if shell.holds(dot(d, d)) {
                m |= 1 << k;
            }
        }
        m
    }

    /// The bits of the row's texels (`row`) from the first to the last whose taps at `step`
    /// all lie inside it, eight at a time in AVX2 lanes ([`MaskRows::block`]), and of the
    /// texels before them one by one; returns the first texel left to the caller (0 without
    /// AVX2).
    fn blocks(&self, row: &mut [u32], step: i64) -> i64 {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            let w = self.size[0];
            let reach = 2 * step.abs();
            let mut x = reach.min(w);
            while x + 8 + reach <= w {
                // SAFETY: the CPU has AVX2 (just checked).
                let bits = unsafe { self.block(x) };
                row[x as usize..x as usize + 8].copy_from_slice(&bits);
                x += 8;
            }
            for (x, out) in (0..reach.min(w)).zip(row.iter_mut()) {
                *out = self.at(x);
            }
            return x;
        }
        let _ = (row, step);
        0
    }

    /// [`MaskRows::at`] at the eight texels from `x`, one to a lane of an AVX2 vector, with
    /// the same operations (`d² = (d₀·d₀ + d₁·d₁) + d₂·d₂`, the shell's ordered comparisons):
    /// the same bits. Every tap of the eight must lie inside the row (`x ≥ 2·step`, `x + 8 +
    /// 2·step ≤ width`); rows above or below the map are left out as [`MaskRows::at`] does.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn block(&self, x: i64) -> [u32; 8] {
        use crate::cpu::texels::Texels;
        use std::arch::x86_64::*;
        let [w, h] = self.size;
        let row_floats = 4 * w;
        let start = self.layer_start as i64 + self.y * row_floats + 4 * x;
        let Texels(p) = Texels::load(self.pos, start);
        let mut m = _mm256_setzero_si256();
        for (k, &(o, shell)) in self.taps.iter().enumerate() {
            let ty = self.y + o[1];
            if ty < 0 || ty >= h {
                continue;
            }
            let holds = if shell.centre {
                _mm256_set1_epi32(-1)
            } else {
                let Texels(t) = Texels::load(self.pos, start + o[1] * row_floats + 4 * o[0]);
                let d = [0, 1, 2].map(|i| _mm256_sub_ps(t[i], p[i]));
                let d2 = _mm256_add_ps(
                    _mm256_add_ps(_mm256_mul_ps(d[0], d[0]), _mm256_mul_ps(d[1], d[1])),
                    _mm256_mul_ps(d[2], d[2]),
                );
                _mm256_castps_si256(_mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_LE_OQ>(d2, _mm256_set1_ps(shell.hi)),
                    _mm256_cmp_ps::<_CMP_GE_OQ>(d2, _mm256_set1_ps(shell.lo)),
                ))
            };
            m = _mm256_or_si256(m, _mm256_and_si256(holds, _mm256_set1_epi32(1 << k)));
        }
        // None where the centre's position is not valid (`!(w ≤ 0.5)`, as [`MaskRows::at`]).
        let valid = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_NLE_UQ>(p[3], _mm256_set1_ps(0.5)));
        let mut out = [0u32; 8];
        // SAFETY: eight integers into an array of eight.
        unsafe { _mm256_storeu_si256(out.as_mut_ptr().cast(), _mm256_and_si256(m, valid)) };
        out
    }
}

impl GuideMasks {
    /// The masks of `pos` for `chart`.
    pub(crate) fn new(pos: View<'_>, chart: Chart) -> GuideMasks {
        let [w, h] = pos.size;
        let taps = chart.taps();
        let row_floats = 4 * w as usize;
        let rows = pos.layers as usize * h as usize;
        let mut bits = vec![0u32; rows * w as usize];
        if row_floats == 0 || pos.data.len() < rows * row_floats {
            return GuideMasks {
                size: pos.size,
                layers: pos.layers,
                bits,
            };
        }
        bits.par_chunks_mut(w as usize)
            .enumerate()
            .for_each(|(r, row)| {
                let (layer, y) = (r / h as usize, (r % h as usize) as i64);
                let rows = MaskRows {
                    pos: pos.data,
                    size: [i64::from(w), i64::from(h)],
                    layer_start: layer * h as usize * row_floats,
                    y,
                    taps: &taps,
                };
                // Blocks of eight texels whose taps all lie inside the row, eight at a time
                // where the CPU has AVX2 (the same bits), the rest one by one.
                let x = rows.blocks(row, chart.step);
                for (x, out) in (x..i64::from(w)).zip(row[x as usize..].iter_mut()) {
                    *out = rows.at(x);
                }
            });
        GuideMasks {
            size: pos.size,
            layers: pos.layers,
            bits,
        }
    }

    /// Texel `at`'s bits; `None` outside the map or where its position is not valid (the
    /// guide then tests its taps itself).
    #[inline]
    pub(crate) fn at(&self, at: Texel) -> Option<u32> {
        let i = flat_index(self.size, self.layers, at)?;
        self.bits.get(i).copied().filter(|&m| m != 0)
    }

    /// The bits of the eight texels from `at` along its row, as [`GuideMasks::at`] reads them
    /// (0 where it gives `None`), when all eight lie in the map.
    #[cfg(target_arch = "x86_64")]
    #[inline]
    pub(crate) fn eight(&self, at: Texel) -> Option<&[u32; 8]> {
        if at.x.checked_add(8)? > self.size[0] {
            return None;
        }
        let i = flat_index(self.size, self.layers, at)?;
        self.bits.get(i..i + 8)?.try_into().ok()
    }

    /// Bytes of the bits.
    pub fn bytes(&self) -> usize {
        self.bits.len() * 4
    }
}

/// The [`GuideMasks`] a backend keeps from dispatch to dispatch and bake to bake, per position
/// map (named by what identifies its texels: the CPU backend's hash of an uploaded texture)
/// and chart test: the variance pass and the first à-trous iteration share one, a lamp swap
/// reuses all. Up to [`GuideCache::KEEP`] of them (the oldest goes first); 4 bytes per texel
/// each (4.7 MB for `chairs_05` at 64 texels/m).
///
/// It keeps the grid corners of the later bounces ([`CoarseMasks`]) the same way, per
/// position and normal map, stride and reach.
#[derive(Debug, Default)]
pub struct GuideCache {
    kept: std::sync::Mutex<Vec<([u64; 4], Arc<GuideMasks>)>>,
    corners: std::sync::Mutex<Vec<([u64; 4], Arc<CoarseMasks>)>>,
}

impl GuideCache {
    /// Masks kept at most: three steps of the default denoiser for two rooms, and more.
    pub const KEEP: usize = 8;

    /// The masks of map `id` (its texels `pos`) for `chart`, made when not kept.
    pub(crate) fn masks(&self, id: u64, pos: View<'_>, chart: Chart) -> Arc<GuideMasks> {
        let [a, b, c] = chart.key();
        keep(&self.kept, [id, a, b, c], || GuideMasks::new(pos, chart))
    }

    /// The grid corners of maps `ids = [position, normal]` (their texels `maps`) for `stride`
    /// and `reach`, made when not kept.
    pub(crate) fn corners(
        &self,
        ids: [u64; 2],
        maps: [View<'_>; 2],
        stride: u32,
        reach: f32,
    ) -> Arc<CoarseMasks> {
        let key = [
            ids[0],
            ids[1],
            u64::from(stride),
            u64::from(reach.to_bits()),
        ];
        keep(&self.corners, key, || CoarseMasks::new(maps, stride, reach))
    }

    /// Bytes of the masks kept.
    pub fn bytes(&self) -> usize {
        let guides = self
            .kept
            .lock()
            .map_or(0, |k| k.iter().map(|(_, m)| m.bytes()).sum::<usize>());
        let corners = self
            .corners
            .lock()
            .map_or(0, |k| k.iter().map(|(_, m)| m.bytes()).sum::<usize>());
        guides + corners
    }
}

/// The value kept under `key` in `kept`, or `make`'s, then kept (up to [`GuideCache::KEEP`],
/// the oldest going first).
fn keep<T>(
    kept: &std::sync::Mutex<Vec<([u64; 4], Arc<T>)>>,
    key: [u64; 4],
    make: impl FnOnce() -> T,
) -> Arc<T> {
    let found = kept.lock().ok().and_then(|k| {
        k.iter()
            .find(|(k, _)| *k == key)
            .map(|(_, m)| Arc::clone(m))
    });
    if let Some(m) = found {
        return m;
    }
    let m = Arc::new(make());
    if let Ok(mut k) = kept.lock()
        && !k.iter().any(|(k, _)| *k == key)
    {
        if k.len() >= GuideCache::KEEP {
            k.remove(0);
        }
        k.push((key, Arc::clone(&m)));
    }
    m
}

/// Asks the cache for the line holding `data[index]` (nothing when `index` is out of range,
/// or off x86_64).
#[inline(always)]
pub(crate) fn prefetch<T>(data: &[T], index: usize) {
    #[cfg(target_arch = "x86_64")]
    if let Some(v) = data.get(index) {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: SSE is part of the x86_64 baseline, and a prefetch reads nothing the
        // program sees and never faults; the pointer is to an element of `data`.
        unsafe { _mm_prefetch::<_MM_HINT_T0>((v as *const T).cast()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (data, index);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A position map of two layers with what the chart tests meet: charts side by side at
    /// different depths, empty texels, a NaN, and rows narrower than the widest taps.
    fn positions(size: [u32; 2], layers: u32) -> Vec<f32> {
        let texels = (size[0] * size[1] * layers) as usize;
        (0..texels)
            .flat_map(|i| {
                let (x, y) = ((i as u32 % size[0]) as f32, (i as u32 / size[0]) as f32);
                let depth = if (x as u32 / 13 + y as u32 / 7).is_multiple_of(3) {
                    0.4
                } else {
                    0.0
                };
                let w = if i.is_multiple_of(11) { 0.0 } else { 1.0 };
                let z = if i == 77 {
                    f32::NAN
                } else {
                    depth + 0.001 * x * y
                };
                [x / 16.0, y / 16.0, z, w]
            })
            .collect()
    }

    #[test]
    fn the_chart_tests_in_lanes_equal_the_texel_by_texel_ones() {
        let mut blocks = 0u64;
        for size in [[67, 41], [9, 5], [40, 3]] {
            let data = positions(size, 2);
            let pos = View::new(&data, size, 2);
            for step in [1i64, 2, 4, 8] {
                for reach in [[0.0, 0.1], [0.04, 0.1], [0.02, 0.3]] {
                    let chart = Chart { step, reach };
                    let masks = GuideMasks::new(pos, chart);
                    let taps = chart.taps();
                    let mut set = 0;
                    for layer in 0..2usize {
                        for y in 0..i64::from(size[1]) {
                            let rows = MaskRows {
                                pos: &data,
                                size: [i64::from(size[0]), i64::from(size[1])],
                                layer_start: layer * 4 * (size[0] * size[1]) as usize,
                                y,
                                taps: &taps,
                            };
                            for x in 0..i64::from(size[0]) {
                                let i = (layer as i64 * i64::from(size[1]) + y)
                                    * i64::from(size[0])
                                    + x;
                                let want = rows.at(x);
                                assert_eq!(
                                    masks.bits[i as usize], want,
                                    "{size:?} {chart:?} {x} {y}"
                                );
                                set += u64::from(want.count_ones());
                                // Eight lanes from every `x` whose taps lie in the row.
                                #[cfg(target_arch = "x86_64")]
                                if std::arch::is_x86_feature_detected!("avx2")
                                    && x >= 2 * step
                                    && x + 8 + 2 * step <= i64::from(size[0])
                                {
                                    // SAFETY: the CPU has AVX2 (just checked).
                                    let lanes = unsafe { rows.block(x) };
                                    let want: [u32; 8] =
                                        std::array::from_fn(|l| rows.at(x + l as i64));
                                    assert_eq!(lanes, want, "{size:?} {chart:?} {x} {y}");
                                    blocks += 1;
                                }
                            }
                        }
                    }
                    // Something was tested: taps pass.
                    assert!(set > 0, "{size:?} {chart:?}");
                }
            }
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            assert!(blocks > 1000, "{blocks} blocks compared");
        }
    }
}
