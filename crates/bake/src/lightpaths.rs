//! Lamp paths: the first bounce sampled from the lamps as well as from the texel, combined by
//! multiple importance sampling (Veach & Guibas 1995, the balance heuristic).
//!
//! # Why
//! The first bounce gathers the exitance `M = ρ·E_direct` of the surfaces a texel sees. A lamp
//! close to a surface (a pendant under the ceiling, a wall washer) lights a small patch
//! brightly, and that patch carries much of the room's first-bounce light: a cosine-weighted
//! gather of a few rays finds it rarely, so the first bounce is grainy where the texel sees it
//! from afar (measured on the box room of `cargo xtask bench grain`: 34 % relative standard
//! deviation of the walls' total illuminance at 6 rays per texel). Paths started at the lamps
//! land where the light is, in proportion to it.
//!
//! # The estimator
//! With `y` a surface point, `G(x, y) = cos θₓ cos θ_y / r²` and `f(y) = M(y)·G/π`, the first
//! bounce at texel `x` is `E₁(x) = ∫ f(y)·V(x, y) dA_y`. Two strategies sample `y`:
//! - **gather** (`N_C` cosine-weighted rays, [`crate::cpu`]'s gather): area density
//!   `p_C(y) = cos θₓ cos θ_y / (π r²)`, estimate `f/p_C = M(y)`;
//! - **lamp paths** (`K` per texel): a shared pool of [`pool_size`] rays leaves the lamps, each
//!   lamp and direction drawn in proportion to a bound of its intensity table; the
//!   receivers' front faces they hit first are the paths' points. A texel connects to `K` of
//!   them (uniform picks, stratified, [`CONNECT_PASS`]) with a shadow ray. The area density
//!   of a point is `p_V(y) = Σ_l q_l(ω_ly)·cos θ_ly / d_ly² · V_l(y) / P_hit`, `q_l` the
//!   emission density per solid angle and `P_hit` the fraction of rays that found a receiver,
//!   and its estimate is `f/p_V = ρ(y)·E_direct(y)·G/(π·p_V)` with `E_direct` evaluated
//!   exactly at `y` (the tables as the direct pass samples them, shadow rays to other lamps).
//!
//! Each sample is weighted by the balance heuristic, `w_s = N_s p̃_s / (N_C p̃_C + K p̃_V)`.
//! The weights only have to sum to one for every `y` (they do: both strategies evaluate the
//! same functions), so `p̃_V` need not be exact: it is the lamps' unshadowed illuminance
//! at `y`, luminance-weighted, times one constant ([`density`], [`LampPaths::density_scale`]),
//! each lamp's intensity read from a coarse grid of its table ([`DensityProxy`]) so that it is
//! cheap at every gather hit, on the GPU too. A point that no lamp path can reach has no direct
//! light, so the gather alone may count it with a weight below one without losing anything.
//! The result is unbiased up to what the gather already approximates (the direct light map's
//! texel-size interpolation, and shading normals in `cos θ_y`).
//!
//! The gather multiplies each hit's exitance by its weight (in every backend, the same
//! operations); the lamp-path part, `C(x) = Σ_k p̃_V cos θₓ cos θ_y ρE/p_V / (π K p̃_V r² +
//! N_C cos θₓ cos θ_y)`, is the `connect` pass ([`crate::passes::connect`]), run by the
//! backend before the gather adds it. Both are finite as `r → 0`. The pool is traced here on
//! the host ([`LampPaths::trace`], a few hundred thousand rays at most) and uploaded with the
//! scene ([`LampPaths::packed`]).
//!
//! # Lamps with an opening
//! A lamp baked with its luminous opening ([`crate::opening`]) starts each pool ray at a point
//! of the opening drawn uniformly over its area (the direction as for a point). The density of
//! a pool point `y` is then an integral over the opening, and `E_direct(y)` one too: both are
//! estimated at `y` with the same [`pool_samples`] points of the opening (each with
//! its shadow ray), so the quadrature's error largely cancels in their ratio, the path's
//! power. Pool points farther from the lamp than its opening's near distance see it as a
//! point, as the direct pass does.
//!
//! # Determinism
//! Pool directions come from the Sobol sampler (texel 0, sample `i`, pass [`EMIT_PASS`]) and
//! the hash sampler, in f64 (whose last-bit differences between maths libraries do not reach
//! the rounded f32 results). Traversal is the 8-wide BVH.
//!
//! # Stratified picks
//! The pool is stored along a Morton curve through its points ([`morton_order`]), so that a
//! stretch of the pool is a patch of the lit surfaces. Texel `x` picks path
//! `⌊u_k · count⌋` for `k = 0 .. K` with `u_k` the first dimension of the Sobol sampler's draws
//! `rng::Stream::gather(Sobol, …, stride 1, K)` in pass [`CONNECT_PASS`] — the gather's
//! blocks: each texel's `K` picks are a stratified run of its 2 × 2 block's sequence, so they
//! spread over the lit surfaces, and the block's `4K` picks together too. Each pick is
//! uniform over the pool, so the estimate is as unbiased as with independent picks. Measured
//! (`bench refcheck --seeds 16`, default): the noise at the reference points of `chairs_01`
//! 0.80 → 0.71 %, of `chairs_05` 0.78 → 0.72 % (docs/performance.md).

// `!(x > 0.0)` on purpose: a NaN fails the test, as in the shaders these functions mirror.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use luxbake_bvh::{EncodedScene, Ray, WideBvh};
use luxbake_ies::GpuTable;
use rayon::prelude::*;

use crate::backend::{LampParams, offset_origin};
use crate::exact::{div, dot, interpolate, luminance, normalize, sub};
use crate::gbuffer::GBuffer;
use crate::layout::Region;
use crate::map::sample_masked;
use crate::opening::{self, OpeningParams};
use crate::rng;

/// Most rays that leave the lamps per bake.
pub const MAX_POOL: u32 = 1 << 18;
/// Fewest rays that leave the lamps per bake.
pub const MIN_POOL: u32 = 1 << 12;
/// Connections per pool ray that [`pool_size`] aims at.
pub const USES_PER_PATH: u64 = 4;

/// Rays that leave the lamps for a bake of `texels` valid texels with `k` lamp paths each: the
/// power of two nearest above `texels · k /` [`USES_PER_PATH`], within [`MIN_POOL`] ..=
/// [`MAX_POOL`]. Texels share the pool, so a point picked by many texels makes their errors
/// agree: with 2¹⁶ points for 830 k connections (13 each) the chair of `chairs_01` came out
/// 1.6 % low or high by seed, with 2¹⁸ (3 each) within 0.5 %. Fewer texels need fewer rays:
/// the browser's `chairs_01` at 12 texels/m casts 2¹⁶, not 2¹⁸.
pub fn pool_size(texels: u64, k: u32) -> u32 {
    let want = (texels.saturating_mul(u64::from(k)) / USES_PER_PATH).max(1);
    let p = want.checked_next_power_of_two().unwrap_or(u64::MAX);
    p.clamp(u64::from(MIN_POOL), u64::from(MAX_POOL)) as u32
}
/// The RNG pass of the pool's directions (no bake pass uses it).
pub const EMIT_PASS: u32 = 0x1A11;
/// The RNG pass of a texel's choice of paths.
pub const CONNECT_PASS: u32 = 0x1A12;

/// The MIS density proxy's lamp sum at surface point `y` with unit normal `n`: the
/// luminance-weighted illuminance of the lamps without shadows,
/// `Σ_l lum(scale_l)·Ĩ_l(ω)·cos θ / d²`, `Ĩ_l` lamp `l`'s [`DensityProxy`] (`proxies[table]`,
/// one per intensity table). Mirrored operation for operation by the gather shaders'
/// `luxLampDensity`; multiplied by [`LampPaths::density_scale`] it is `p̃_V(y)`.
pub fn density(lamps: &[LampParams], proxies: &[DensityProxy], y: [f32; 3], n: [f32; 3]) -> f32 {
    let mut sum = 0.0f32;
    for l in lamps {
        let Some(proxy) = proxies.get(l.table as usize) else {
            continue;
        };
        // Unnormalised: `cos θ / d² = n·t / d³` with `t` toward the lamp, and the proxy
        // takes a direction of any length.
        let to = sub(l.position, y);
        let d2 = dot(to, to);
        if !(d2 > 0.0 && d2.is_finite()) {
            continue;
        }
        let c = dot(n, to);
        if !(c > 0.0) {
            continue;
        }
        let back = [-to[0], -to[1], -to[2]];
        let m = &l.world_to_photometric;
        let intensity = proxy.sample([dot(m[0], back), dot(m[1], back), dot(m[2], back)]);
        if intensity > 0.0 {
            sum += luminance(l.scale) * (intensity * c / (d2 * d2.sqrt()));
        }
    }
    sum
}

/// Cells per side of a [`DensityProxy`]'s octahedral grid.
pub const PROXY_CELLS: u32 = 64;
/// Nodes per side of a [`DensityProxy`]'s grid, `PROXY_CELLS + 1`; it holds their square.
pub const PROXY_NODES: u32 = PROXY_CELLS + 1;

/// A lamp's intensity on a coarse octahedral grid of directions: the intensity the balance
/// heuristic's density proxy ([`density`]) reads at every gather hit.
///
/// # Why
/// The proxy only has to be the same function in both strategies (module docs), and close to
/// the pool's real density where that is large. The intensity table itself costs an `acos`,
/// an `atan2`, two integer divisions and a bilinear look-up in a table of up to 2 MB per
/// hit — measured on `chairs_05` (16 rays, one bounce) as the whole difference between the
/// converged gather and the paper's per ray. This grid needs one division by `|x|+|y|+|z|`
/// and a bilinear look-up in 16.9 KB, which stays in the first-level cache.
///
/// # Parametrisation (fixed; the shaders rely on it)
/// A direction `d` of the photometric frame (any length; `s = |x|+|y|+|z|`) maps to
/// `(p, q) = (x·r, y·r)` with `r = 1/s`, folded where `z > 0` (above the horizontal plane,
/// away from the nadir): `(p, q) ← ((1 − |q|)·sgn p, (1 − |p|)·sgn q)` with `sgn v = 1` for
/// `v ≥ 0` (also −0), else −1. Then `fu = clamp((p/2 + ½)·N, 0, N)`, `fv` likewise from `q` (`N` =
/// [`PROXY_CELLS`]); `i = min(⌊fu⌋, N − 1)`, `j = min(⌊fv⌋, N − 1)`, `tu = fu − i`,
/// `tv = fv − j`, and the value is the bilinear mix of nodes `(j, i)`, `(j, i+1)`,
/// `(j+1, i)`, `(j+1, i+1)`: `values[row·(N+1) + column]`, row `j` over `q`, column `i`
/// over `p`. Node `(j, i)` holds the table's [`GpuTable::sample`] toward the direction that
/// maps to `(2i/N − 1, 2j/N − 1)` ([`DensityProxy::node_direction`]). The fold is continuous:
/// the nodes on the fold's edges that stand for one direction hold one value, so the proxy
/// has no seam. Zero length or non-finite input gives 0. In `pack::ies_values` each table's
/// grid follows the table's own values; the glow backend stores it in the rows below the
/// table in the table's layer.
#[derive(Debug, Clone, PartialEq)]
pub struct DensityProxy {
    /// `PROXY_NODES²` values, candela, row-major (see the type docs).
    pub values: Vec<f32>,
}

impl DensityProxy {
    /// The grid of `table` (see the type docs).
    pub fn new(table: &GpuTable) -> DensityProxy {
        let mut values = Vec::with_capacity((PROXY_NODES * PROXY_NODES) as usize);
        for j in 0..PROXY_NODES {
            for i in 0..PROXY_NODES {
                values.push(table.sample(Self::node_direction(i, j)));
            }
        }
        DensityProxy { values }
    }

    /// The direction (photometric frame, unit) that the node in column `i`, row `j` stands
    /// for.
    pub fn node_direction(i: u32, j: u32) -> [f32; 3] {
        let n = f64::from(PROXY_CELLS);
        let (p, q) = (2.0 * f64::from(i) / n - 1.0, 2.0 * f64::from(j) / n - 1.0);
        let h = 1.0 - p.abs() - q.abs();
        let sgn = |v: f64| if v >= 0.0 { 1.0 } else { -1.0 };
        let (x, y) = if h < 0.0 {
            ((1.0 - q.abs()) * sgn(p), (1.0 - p.abs()) * sgn(q))
        } else {
            (p, q)
        };
        let z = -h;
        let len = (x * x + y * y + z * z).sqrt();
        [x, y, z].map(|c| (c / len) as f32)
    }

    /// The bilinear value toward `dir` (see the type docs).
    #[inline]
    pub fn sample(&self, dir: [f32; 3]) -> f32 {
        let [x, y, z] = dir;
        let s = x.abs() + y.abs() + z.abs();
        if !(s > 0.0 && s.is_finite()) || self.values.len() < (PROXY_NODES * PROXY_NODES) as usize {
            return 0.0;
        }
        let r = 1.0 / s;
        let (mut p, mut q) = (x * r, y * r);
        if z > 0.0 {
            let sgn = |v: f32| if v >= 0.0 { 1.0 } else { -1.0 };
            (p, q) = ((1.0 - q.abs()) * sgn(p), (1.0 - p.abs()) * sgn(q));
        }
        const N: f32 = PROXY_CELLS as f32;
        let fu = ((p * 0.5 + 0.5) * N).clamp(0.0, N);
        let fv = ((q * 0.5 + 0.5) * N).clamp(0.0, N);
        // ⌊·⌋ of a value in [0, N]: a truncation.
        let i = (fu as u32).min(PROXY_CELLS - 1);
        let j = (fv as u32).min(PROXY_CELLS - 1);
        let (tu, tv) = (fu - i as f32, fv - j as f32);
        let at = |row: u32, col: u32| self.values[(row * PROXY_NODES + col) as usize];
        let a = at(j, i) + (at(j, i + 1) - at(j, i)) * tu;
        let b = at(j + 1, i) + (at(j + 1, i + 1) - at(j + 1, i)) * tu;
        a + (b - a) * tv
    }
}

/// One lamp's emission cells: the table's (γ, C) cells, each with the largest of its four
/// corner values (a bound of the bilinear intensity inside it).
struct LampCells {
    /// World-to-photometric rows (f64).
    rows: [[f64; 3]; 3],
    /// Luminance of the lamp's scale.
    lum: f64,
    width: u32,
    /// Per cell `(row j, column i)`, `j < height − 1`: the corner maximum, candela.
    max: Vec<f64>,
    /// `cos γ` of the rows' edges, `γ = π·j/(height − 1)` for `j = 0 ..= height − 1`
    /// (falling).
    cos_edges: Vec<f64>,
    /// [`pseudo_angle`] of the columns' inner edges, `C = 2π·i/width` for `i = 1 .. width`
    /// (rising).
    c_edges: Vec<f64>,
}

/// A measure of the azimuth `atan2(y, x)` taken into `[0, 2π)` that rises with it, in
/// `[0, 4)`, from one division: `1 − x/(|x| + |y|)` for `y ≥ 0`, `3 + x/(|x| + |y|)` below
/// (0 for the zero vector, whose azimuth is 0).
fn pseudo_angle(x: f64, y: f64) -> f64 {
    let s = x.abs() + y.abs();
    if !(s > 0.0) {
        return 0.0;
    }
    let a = x / s;
    if y >= 0.0 { 1.0 - a } else { 3.0 + a }
}

/// `cos γ` of a table's row edges, `γ = π·j/(height − 1)` for `j = 0 ..= height − 1`
/// (`height ≥ 2`).
fn row_cosines(height: u32) -> Vec<f64> {
    let r = f64::from(height - 1);
    (0..height)
        .map(|j| (std::f64::consts::PI * f64::from(j) / r).cos())
        .collect()
}

impl LampCells {
    /// `cos_edges`: [`row_cosines`] of the table's height.
    fn new(
        rows: [[f64; 3]; 3],
        lum: f64,
        width: u32,
        cos_edges: Vec<f64>,
        max: Vec<f64>,
    ) -> LampCells {
        let width = width.max(1);
        let w = f64::from(width);
        LampCells {
            rows,
            lum,
            width,
            max,
            cos_edges,
            c_edges: (1..width)
                .map(|i| {
                    let c = std::f64::consts::TAU * f64::from(i) / w;
                    pseudo_angle(c.cos(), c.sin())
                })
                .collect(),
        }
    }

    /// The cell of photometric direction `photometric` (any length): the rows' and columns'
    /// edges it lies past, counted by bisection, in place of `⌊γ/π·(height − 1)⌋` and
    /// `⌊C/2π·width⌋` (the same cell but for directions within rounding of an edge), so that
    /// no inverse trigonometric function runs per look-up.
    fn cell_of(&self, photometric: [f64; 3]) -> Option<usize> {
        let [x, y, z] = photometric;
        let len = (x * x + y * y + z * z).sqrt();
        if !(len > 0.0 && len.is_finite()) {
            return None;
        }
        let cos_gamma = (-z / len).clamp(-1.0, 1.0);
        let inner = &self.cos_edges[1..self.cos_edges.len() - 1];
        let j = inner.partition_point(|&e| cos_gamma <= e);
        let c = pseudo_angle(x, y);
        let i = self.c_edges.partition_point(|&e| e <= c);
        Some(j * self.width as usize + i)
    }
}

/// The emission distribution of the pool: every lamp's cells in one cumulative table, each
/// weighted by `lum(scale)·max·Ω` (Ω the cell's solid angle); directions are uniform in
/// solid angle inside a cell, so the density per solid angle is `lum·max / total`.
struct Emitter {
    lamps: Vec<LampCells>,
    /// Cumulative weights over every lamp's cells, in lamp order.
    cdf: Vec<f64>,
    /// `(lamp, cell)` of each entry of `cdf`.
    cells: Vec<(u32, u32)>,
    total: f64,
}

impl Emitter {
    fn new(lamps: &[LampParams], tables: &[GpuTable]) -> Emitter {
        let mut out = Emitter {
            lamps: Vec::new(),
            cdf: Vec::new(),
            cells: Vec::new(),
            total: 0.0,
        };
        for (li, l) in lamps.iter().enumerate() {
            let Some(t) = tables.get(l.table as usize) else {
                continue;
            };
            let (width, height) = (t.width, t.height);
            let lum = f64::from(luminance(l.scale));
            if width == 0 || height < 2 || !(lum > 0.0 && lum.is_finite()) {
                out.lamps.push(LampCells::new(
                    [[0.0; 3]; 3],
                    0.0,
                    1,
                    row_cosines(2),
                    Vec::new(),
                ));
                continue;
            }
            let at = |j: u32, i: u32| {
                f64::from(
                    t.values
                        .get(j as usize * width as usize + (i % width) as usize)
                        .copied()
                        .unwrap_or(0.0),
                )
            };
            let cos_edges = row_cosines(height);
            let mut max = Vec::with_capacity((height as usize - 1) * width as usize);
            for j in 0..height - 1 {
                let (c0, c1) = (cos_edges[j as usize], cos_edges[j as usize + 1]);
                let omega = (c0 - c1) * std::f64::consts::TAU / f64::from(width);
                for i in 0..width {
                    let m = [at(j, i), at(j, i + 1), at(j + 1, i), at(j + 1, i + 1)]
                        .into_iter()
                        .fold(0.0f64, f64::max);
                    let m = if m.is_finite() { m } else { 0.0 };
                    max.push(m);
                    let w = lum * m * omega;
                    if w > 0.0 {
                        out.total += w;
                        out.cdf.push(out.total);
                        out.cells.push((li as u32, j * width + i));
                    }
                }
            }
            out.lamps.push(LampCells::new(
                l.world_to_photometric.map(|r| r.map(f64::from)),
                lum,
                width,
                cos_edges,
                max,
            ));
        }
        out
    }

    /// Lamp and world direction of pool ray `i`.
    fn sample(&self, i: u32, seed: u32) -> Option<(usize, [f64; 3])> {
        if !(self.total > 0.0) {
            return None;
        }
        let [u0, u1] = rng::sobol2(0, i, EMIT_PASS, seed);
        let [h0, _] = rng::uniform2(i, 0, EMIT_PASS, seed);
        let target = f64::from(u0) * self.total;
        let k = self
            .cdf
            .partition_point(|&c| c <= target)
            .min(self.cdf.len() - 1);
        let (li, cell) = self.cells[k];
        let lamp = &self.lamps[li as usize];
        let (j, col) = (cell / lamp.width, cell % lamp.width);
        let (c0, c1) = (lamp.cos_edges[j as usize], lamp.cos_edges[j as usize + 1]);
        let cos_g = c0 + f64::from(h0) * (c1 - c0);
        let sin_g = (1.0 - cos_g * cos_g).max(0.0).sqrt();
        let c = std::f64::consts::TAU * (f64::from(col) + f64::from(u1)) / f64::from(lamp.width);
        let d = [sin_g * c.cos(), sin_g * c.sin(), -cos_g];
        // photometric = M · world, M orthonormal: world = Mᵀ · photometric.
        let r = &lamp.rows;
        let world = [0, 1, 2].map(|k| r[0][k] * d[0] + r[1][k] * d[1] + r[2][k] * d[2]);
        Some((li as usize, world))
    }

    /// Emission density per solid angle of lamp `li` toward world direction `w` (unit, from
    /// the lamp), lamp choice included.
    fn density(&self, li: usize, w: [f64; 3]) -> f64 {
        let Some(lamp) = self.lamps.get(li) else {
            return 0.0;
        };
        let r = &lamp.rows;
        let p = [0, 1, 2].map(|k| r[k][0] * w[0] + r[k][1] * w[1] + r[k][2] * w[2]);
        lamp.cell_of(p)
            .and_then(|c| lamp.max.get(c))
            .map_or(0.0, |m| lamp.lum * m / self.total)
    }
}

/// One point lit by a lamp path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LampPath {
    /// World position.
    pub position: [f32; 3],
    /// Unit shading normal (front face, toward the lamp).
    pub normal: [f32; 3],
    /// `ρ(y)·E_direct(y) / p_V(y)`, per channel: the point's contribution before the texel's
    /// geometry term and weight.
    pub power: [f32; 3],
    /// [`density`] at the point (times [`LampPaths::density_scale`]: `p̃_V`).
    pub density: f32,
}

/// The pool of a bake: the points its lamp paths found.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LampPaths {
    /// Points with light to pass on, in pool order.
    pub paths: Vec<LampPath>,
    /// `1 / (total · P_hit)`: turns [`density`] into the density of a pool point per unit
    /// area, up to the proxy's approximation (the weights need only be consistent).
    pub density_scale: f32,
}

/// Ray origin offsets and the triangle/region data the pool and the connections need.
pub struct Geometry<'a> {
    /// The encoded scene (triangle attributes).
    pub encoded: &'a EncodedScene,
    /// Its 8-wide BVH.
    pub wide: &'a WideBvh,
    /// Per object its light-map region (`None`: reflects nothing).
    pub regions: &'a [Option<Region>],
    /// The G-buffer after [`crate::validity::unocclude`] (albedo at a path's point).
    pub gbuffer: &'a GBuffer,
    /// The size term of ray offsets ([`crate::backend::ray_epsilon`]).
    pub eps: f32,
}

impl Geometry<'_> {
    /// Whether nothing lies between `origin` (already offset off its surface) and `target`
    /// (stopping 10⁻⁴ of the way short of it); `false` when they coincide.
    fn sees(&self, origin: [f32; 3], target: [f32; 3]) -> bool {
        let sd = sub(target, origin);
        let len = dot(sd, sd).sqrt();
        if !(len > 0.0) {
            return false;
        }
        let ray = Ray {
            origin,
            dir: div(sd, len),
        };
        !self.wide.any_hit(&ray, 0.0, len * (1.0 - 1e-4))
    }
}

impl LampPaths {
    /// Casts `pool` rays ([`pool_size`]) from `lamps` (the direct pass's lamps and tables) and
    /// keeps the receivers' front faces they hit with light to pass on.
    pub fn trace(
        g: &Geometry<'_>,
        lamps: &[LampParams],
        tables: &[GpuTable],
        pool: u32,
        seed: u32,
    ) -> Self {
        LampPaths::trace_reporting(g, lamps, tables, pool, seed, &mut |_| {})
    }

    /// [`LampPaths::trace`], calling `report` with the fraction of the pool traced after each
    /// of [`POOL_REPORTS`] parts (the same pool: each ray's draws depend on its index only).
    pub fn trace_reporting(
        g: &Geometry<'_>,
        lamps: &[LampParams],
        tables: &[GpuTable],
        pool: u32,
        seed: u32,
        report: &mut dyn FnMut(f32),
    ) -> Self {
        let emitter = Emitter::new(lamps, tables);
        if !(emitter.total > 0.0) {
            return LampPaths::default();
        }
        let proxies: Vec<DensityProxy> = tables.iter().map(DensityProxy::new).collect();
        // One ray of the pool: the point it lights, if any.
        let trace_one = |i: u32| -> Option<LampPath> {
            let (li, w) = emitter.sample(i, seed)?;
            let lamp = &lamps[li];
            let dir = w.map(|c| c as f32);
            // A lamp with an opening emits from a point of it ([`crate::opening`]).
            let origin = match lamp.opening {
                Some(o) => {
                    let [h0, h1] = opening::shift(i, li as u32, seed);
                    let u = [h0, h1, rng::pcg(h1)].map(rng::unit_f32);
                    opening_point(lamp, &o, |o| opening::sample(o, u))?.0
                }
                None => lamp.position,
            };
            let ray = Ray { origin, dir };
            let hit = g.wide.closest_hit(&ray, 0.0, f32::INFINITY)?;
            let attr = g.encoded.triangle_attributes(hit.triangle);
            let region = (*g.regions.get(attr.object as usize)?)?;
            let (n, uv) = interpolate(&attr, hit.u, hit.v);
            let n = normalize(n)?;
            if !(dot(n, dir) < 0.0) {
                return None;
            }
            let y = [0, 1, 2].map(|c| (f64::from(origin[c]) + f64::from(hit.t) * w[c]) as f32);
            let gb = g.gbuffer;
            let albedo = sample_masked(
                |x, yy| {
                    let k = gb.index(region.layer, x, yy);
                    let a = &gb.albedo[k..k + 4];
                    [a[0], a[1], a[2], gb.position[k + 3]]
                },
                region.offset,
                region.size,
                uv,
            );
            if albedo.iter().all(|&a| !(a > 0.0)) {
                return None;
            }
            // E_direct and the pool's density at y, over every lamp that sees it.
            let mut e = [0.0f64; 3];
            let mut p = 0.0f64;
            let o = offset_origin(y, n, g.eps);
            for (lj, l) in lamps.iter().enumerate() {
                let to = sub(l.position, y);
                let dist = dot(to, to).sqrt();
                if let Some(o) = l.opening.filter(|o| dist < o.near) {
                    let shift = opening::shift(i, lj as u32, seed ^ EMIT_PASS);
                    let samples = pool_samples(&o, dist);
                    let (el, pl) =
                        from_opening(g, &emitter, (lj, l, &o), tables, (y, n), samples, shift);
                    for (ec, sc) in e.iter_mut().zip(l.scale) {
                        *ec += f64::from(sc) * el;
                    }
                    p += pl;
                    continue;
                }
                let to = [0, 1, 2].map(|c| f64::from(l.position[c]) - f64::from(y[c]));
                let d2 = to.iter().map(|c| c * c).sum::<f64>();
                let d = d2.sqrt();
                if !(d > 0.0 && d.is_finite()) {
                    continue;
                }
                let wl = to.map(|c| c / d);
                let cos =
                    f64::from(n[0]) * wl[0] + f64::from(n[1]) * wl[1] + f64::from(n[2]) * wl[2];
                if !(cos > 0.0) {
                    continue;
                }
                // The pool ray left lamp `li`'s centre, which therefore sees `y` — unless it
                // left a point of the lamp's opening.
                if (lj != li || l.opening.is_some()) && !g.sees(o, l.position) {
                    continue;
                }
                let back = wl.map(|c| (-c) as f32);
                let m = &l.world_to_photometric;
                let photometric = [dot(m[0], back), dot(m[1], back), dot(m[2], back)];
                let intensity = tables
                    .get(l.table as usize)
                    .map_or(0.0, |t| f64::from(t.sample(photometric)));
                let k = cos / d2;
                for (ec, sc) in e.iter_mut().zip(l.scale) {
                    *ec += f64::from(sc) * intensity * k;
                }
                p += emitter.density(lj, wl.map(|c| -c)) * k;
            }
            if !(p > 0.0 && p.is_finite()) {
                return None;
            }
            let power: [f32; 3] = [0, 1, 2].map(|c| (f64::from(albedo[c]) * e[c] / p) as f32);
            if !power.iter().all(|v| v.is_finite()) || power.iter().all(|&v| !(v > 0.0)) {
                return None;
            }
            Some(LampPath {
                position: y,
                normal: n,
                power,
                density: density(lamps, &proxies, y, n),
            })
        };
        // The rays in the order of their emission cells (the Sobol draw that picks the cell
        // rises with it): neighbouring rays leave in neighbouring directions, so they walk the
        // same BVH nodes and read the same cells of the emission and intensity tables while
        // those are in the caches. Each ray's result goes to its own index: the pool is the
        // same in any order.
        let mut order: Vec<(f32, u32)> = (0..pool)
            .map(|i| (rng::sobol2(0, i, EMIT_PASS, seed)[0], i))
            .collect();
        order.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut found: Vec<Option<LampPath>> = vec![None; pool as usize];
        let part = pool.div_ceil(POOL_REPORTS).max(1) as usize;
        let mut done = 0usize;
        for rays in order.chunks(part) {
            let traced: Vec<(u32, Option<LampPath>)> =
                rays.par_iter().map(|&(_, i)| (i, trace_one(i))).collect();
            for (i, path) in traced {
                found[i as usize] = path;
            }
            done += rays.len();
            report(done as f32 / pool as f32);
        }
        let paths = morton_order(found.into_iter().flatten().collect());

        if paths.is_empty() {
            return LampPaths::default();
        }
        // Picking uniformly among the points found: density p_V / P_hit, P_hit = found / pool.
        let p_hit = paths.len() as f64 / f64::from(pool);
        let scale = 1.0 / (emitter.total * p_hit);
        let paths = paths
            .into_iter()
            .map(|mut p| {
                p.power = p.power.map(|v| (f64::from(v) * p_hit) as f32);
                p
            })
            .collect();
        LampPaths {
            paths,
            density_scale: scale as f32,
        }
    }

    /// The points as the `connect` pass reads them ([`crate::backend::SceneData::lamp_paths`]):
    /// per point (position.xyz, density), (normal.xyz, 0), (power.rgb, 0).
    pub fn packed(&self) -> Vec<f32> {
        self.paths
            .iter()
            .flat_map(|p| {
                let [x, y, z] = p.position;
                let [nx, ny, nz] = p.normal;
                let [r, g, b] = p.power;
                [x, y, z, p.density, nx, ny, nz, 0.0, r, g, b, 0.0]
            })
            .collect()
    }
}

/// `paths` in the order of a Morton curve through their points (ten bits per axis over their
/// bounding box's largest side; ties in the order given): neighbouring paths lie near each
/// other, so picks stratified over the pool's indices are spread over the lit surfaces (see
/// the module docs, "Stratified picks").
pub fn morton_order(paths: Vec<LampPath>) -> Vec<LampPath> {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in &paths {
        for c in 0..3 {
            lo[c] = lo[c].min(p.position[c]);
            hi[c] = hi[c].max(p.position[c]);
        }
    }
    let side = (0..3).map(|c| hi[c] - lo[c]).fold(0.0f32, f32::max);
    let cell = |v: f32, c: usize| -> u32 {
        let q = if side > 0.0 {
            (v - lo[c]) / side * 1023.0
        } else {
            0.0
        };
        // `as` saturates (and sends NaN to 0): every code within 0 ..= 1023.
        (q as u32).min(1023)
    };
    let code = |p: &LampPath| -> u32 {
        let q = [0, 1, 2].map(|c| cell(p.position[c], c));
        (0..10).fold(0u32, |m, b| {
            (0..3).fold(m, |m, c| m | (((q[c] >> b) & 1) << (3 * b + c)))
        })
    };
    // Code and index in one key: ties keep the order of the pool's indices.
    let mut keys: Vec<u64> = paths
        .iter()
        .enumerate()
        .map(|(i, p)| u64::from(code(p)) << 32 | i as u64)
        .collect();
    keys.sort_unstable();
    keys.into_iter().map(|k| paths[k as u32 as usize]).collect()
}

/// Parts of the pool [`LampPaths::trace_reporting`] traces one after the other, reporting
/// after each (each part in parallel).
pub const POOL_REPORTS: u32 = 16;

/// Rays the pool of `pool` paths casts, about: each path's ray, and per lamp its shadow ray to
/// the point — [`OPENING_POOL_SAMPLES`] of them where the lamp has an opening. For progress.
pub fn pool_rays(pool: u32, lamps: &[LampParams]) -> f64 {
    let per_path: u32 = 1 + lamps
        .iter()
        .map(|l| {
            if l.opening.is_some() {
                OPENING_POOL_SAMPLES
            } else {
                1
            }
        })
        .sum::<u32>();
    f64::from(pool) * f64::from(per_path)
}

/// Samples of an opening per pool point for its illuminance and density there, at most
/// ([`pool_samples`]).
pub const OPENING_POOL_SAMPLES: u32 = 8;

/// Samples of opening `o` for a pool point `d` metres from its centre:
/// [`OPENING_POOL_SAMPLES`] within twice the opening's size, fewer farther —
/// `round(OPENING_POOL_SAMPLES · clamp(2·size/d, ¼, 1))`, at least 2. What the samples
/// estimate is a ratio, the path's power `ρ·E/p` (module docs): where the opening looks
/// small its two integrands vary alike over it, and in a penumbra both lose the same hidden
/// samples, so the ratio needs fewer samples than either integral. This is most of a swap's
/// host work for a lamp with an opening (`chairs_05` with `rw_5.IES` at 24 texels/m, one
/// thread: the pool 0.79 s against 0.15 s for a point).
pub fn pool_samples(o: &OpeningParams, d: f32) -> u32 {
    let f = if d > 0.0 {
        (2.0 * o.size / d).clamp(0.25, 1.0)
    } else {
        1.0
    };
    ((OPENING_POOL_SAMPLES as f32 * f + 0.5) as u32).clamp(2, OPENING_POOL_SAMPLES)
}

/// The world point and photometric-frame sample `draw` makes on `lamp`'s opening `o`.
fn opening_point(
    lamp: &LampParams,
    o: &OpeningParams,
    draw: impl FnOnce(&OpeningParams) -> Option<opening::OpeningSample>,
) -> Option<([f32; 3], opening::OpeningSample)> {
    let s = draw(o)?;
    let (q, m) = (s.point, &lamp.world_to_photometric);
    let x = [0, 1, 2].map(|c| lamp.position[c] + q[0] * m[0][c] + q[1] * m[1][c] + q[2] * m[2][c]);
    Some((x, s))
}

/// At pool point `y` (unit normal `n`), the illuminance from lamp `li`'s opening `o` before
/// the lamp's scale, and the density per unit area of the pool's rays from that lamp: the same
/// `samples` points for both ([`pool_samples`], shared among the parts, [`opening::counts`]), so
/// that their ratio, the path's power, keeps little of the quadrature's error. A pool ray
/// starts at a point drawn as [`opening::sample`] draws it (part `j` with probability `Pⱼ`,
/// then density `Pⱼ/W` per area) toward a direction of density `q(ω)` per solid angle
/// ([`Emitter::density`]); the density of `y` is `Σⱼ ∫ Pⱼ/W · q(ω_x)·cos θ_y / r² · V dA_x`,
/// estimated by `Σⱼ Pⱼ/Sⱼ Σ_k q(ω_k)·cos θ_y / r_k² · V_k`. Both bound `r²` below as the
/// direct pass does.
fn from_opening(
    g: &Geometry<'_>,
    emitter: &Emitter,
    (li, lamp, o): (usize, &LampParams, &OpeningParams),
    tables: &[GpuTable],
    (y, n): ([f32; 3], [f32; 3]),
    samples: u32,
    shift: [u32; 2],
) -> (f64, f64) {
    let origin = offset_origin(y, n, g.eps);
    let Some(table) = tables.get(lamp.table as usize) else {
        return (0.0, 0.0);
    };
    let m = &lamp.world_to_photometric;
    let areas = opening::part_areas(o);
    let total: f32 = areas.iter().sum();
    let (mut e, mut p) = (0.0f64, 0.0f64);
    for (part, &count) in opening::counts(&areas, samples).iter().enumerate() {
        // A pool ray leaves this part with probability `chosen`, uniformly over its area:
        // density `chosen / W` per area, so `density × W = chosen`.
        let chosen = f64::from(areas[part] / total);
        let nf = f64::from(count);
        for k in 0..count {
            let u = opening::lattice(k, count, shift);
            let Some((x, s)) = opening_point(lamp, o, |o| opening::sample_part(o, part, u, None))
            else {
                continue;
            };
            let to = [0, 1, 2].map(|c| f64::from(x[c]) - f64::from(y[c]));
            let r2 = to.iter().map(|c| c * c).sum::<f64>();
            let r = r2.sqrt();
            if !(r > 0.0 && r.is_finite()) {
                continue;
            }
            let w = to.map(|c| c / r);
            let cos_y = f64::from(n[0]) * w[0] + f64::from(n[1]) * w[1] + f64::from(n[2]) * w[2];
            if !(cos_y > 0.0) {
                continue;
            }
            if !g.sees(origin, x) {
                continue;
            }
            let back = w.map(|c| (-c) as f32);
            let emit = [dot(m[0], back), dot(m[1], back), dot(m[2], back)];
            let r2e = r2.max(f64::from(s.weight) / (std::f64::consts::PI * nf));
            let cos_x = f64::from(dot(s.normal, emit));
            let area = f64::from(opening::projected_area(o, emit));
            if cos_x > 0.0 && area > 0.0 {
                let intensity = f64::from(table.sample(emit));
                if intensity > 0.0 {
                    e += intensity * cos_x * f64::from(s.weight) / area * cos_y / r2e / nf;
                }
            }
            p += chosen * emitter.density(li, w.map(|c| -c)) * cos_y / r2e / nf;
        }
    }
    (e, p)
}

/// The gather's weight of a hit at distance `r` with cosines `cx` (texel) and `cy` (hit),
/// `lamp_density` = [`density`] at the hit: the sample's share `cx / p̂` of the reflected
/// exitance times the balance heuristic against `k` lamp paths, `N_C p̂ cy / (N_C p̂ cy + π K
/// p̃_V r²)` (1 without lamp paths), where `π·p̂` is the gather's density per steradian: `p̂ =
/// cx` for the cosine-weighted rays (the share is 1) and `p̂ = ½` for the `uniform` rays of a
/// texel in a narrow gap (the share `2·cx`). Mirrored by the shaders' `luxGatherWeight`.
///
/// Why a gap's rays are uniform: a texel facing a surface a few centimetres away sees the
/// lit room only along grazing directions down the gap, which cosine-weighted rays almost
/// never draw (within 3° of the surface: 0.3 % of them, 5 % of uniform ones), so its estimate
/// is a rare bright ray among many dim ones. Uniform rays draw them 19 times as often, each
/// weighted down by `2·cx`; the weight is bounded (at most 2), so the estimate stays as
/// unbiased as the cosine's and, where the light is even, costs a variance of ⅓ per ray.
#[allow(clippy::too_many_arguments)]
pub fn gather_weight(
    rays: u32,
    k: u32,
    density_scale: f32,
    lamp_density: f32,
    r: f32,
    cx: f32,
    cy: f32,
    uniform: bool,
) -> f32 {
    let (pdf, share) = if uniform { (0.5, 2.0 * cx) } else { (cx, 1.0) };
    if k == 0 {
        return share;
    }
    let v = std::f32::consts::PI * k as f32 * (density_scale * lamp_density) * (r * r);
    if !(v > 0.0) {
        return share;
    }
    let g = rays as f32 * (pdf * cy);
    let d = g + v;
    if d.is_finite() { share * (g / d) } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use luxbake_ies::Photometry;

    fn isotropic(cd: f64, position: [f32; 3]) -> (LampParams, GpuTable) {
        let lamp = LampParams {
            position,
            world_to_photometric: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            scale: [1.0; 3],
            table: 0,
            opening: None,
        };
        (lamp, Photometry::isotropic(cd).gpu_table())
    }

    #[test]
    fn the_pool_grows_with_the_connections() {
        assert_eq!(pool_size(0, 12), MIN_POOL);
        assert_eq!(pool_size(14_906, 12), 1 << 16);
        assert_eq!(pool_size(375_401, 12), MAX_POOL);
        assert_eq!(pool_size(u64::MAX, 1024), MAX_POOL);
    }

    #[test]
    fn the_density_is_the_unshadowed_illuminance() {
        let (lamp, table) = isotropic(100.0, [0.0, 2.0, 0.0]);
        let proxy = [DensityProxy::new(&table)];
        let d = density(&[lamp], &proxy, [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        assert!((d - 25.0).abs() < 1e-4, "{d}");
        let d = density(&[lamp], &proxy, [1.5, 0.0, 0.0], [0.0, 1.0, 0.0]);
        let want = 100.0 * 2.0 / 2.5f32.powi(3);
        assert!((d / want - 1.0).abs() < 1e-5, "{d} vs {want}");
        // Facing away: nothing; a lamp whose table is missing: nothing.
        assert_eq!(density(&[lamp], &proxy, [0.0; 3], [0.0, -1.0, 0.0]), 0.0);
        assert_eq!(density(&[lamp], &[], [0.0; 3], [0.0, 1.0, 0.0]), 0.0);
    }

    #[test]
    fn the_density_proxy_follows_the_table_without_a_seam() {
        let downlight =
            Photometry::parse(include_bytes!("../../scene/lamps/luxbake_downlight.ies"))
                .expect("downlight")
                .gpu_table();
        let proxy = DensityProxy::new(&downlight);
        assert_eq!(proxy.values.len(), (PROXY_NODES * PROXY_NODES) as usize);
        let max = downlight.values.iter().fold(0.0f32, |m, &v| m.max(v));
        // At its nodes it is the table.
        for j in 0..PROXY_NODES {
            for i in 0..PROXY_NODES {
                let d = DensityProxy::node_direction(i, j);
                let (got, want) = (proxy.sample(d), downlight.sample(d));
                assert!(
                    (got - want).abs() <= 1e-5 * max,
                    "node ({i}, {j}) {d:?}: {got} vs {want}"
                );
            }
        }
        // Between them, close to it (the downlight's cut-off is the steepest part).
        let dirs: Vec<[f32; 3]> = luxbake_testkit::fibonacci_sphere(20_000)
            .into_iter()
            .map(|d| d.map(|c| c as f32))
            .collect();
        let mean = dirs
            .iter()
            .map(|&d| f64::from((proxy.sample(d) - downlight.sample(d)).abs() / max))
            .sum::<f64>()
            / dirs.len() as f64;
        eprintln!("density proxy of the downlight: mean deviation {mean:.2e} of the maximum");
        assert!(mean < 2e-3, "mean deviation {mean} of the maximum");
        // No seam: where the grid folds (the horizontal plane, and the fold's edges above it)
        // directions on either side read the same.
        for &d in &dirs {
            let (x, y) = (d[0], d[1]);
            for pair in [
                ([x, y, 1e-7], [x, y, -1e-7]),
                ([1e-7, y, d[2].abs()], [-1e-7, y, d[2].abs()]),
                ([x, 1e-7, d[2].abs()], [x, -1e-7, d[2].abs()]),
            ] {
                let (a, b) = (proxy.sample(pair.0), proxy.sample(pair.1));
                assert!((a - b).abs() <= 1e-4 * max, "{pair:?}: {a} vs {b}");
            }
        }
        // Any length; nothing for no direction.
        assert_eq!(
            proxy.sample([0.0, 0.0, -5.0]),
            proxy.sample([0.0, 0.0, -1.0])
        );
        assert_eq!(proxy.sample([0.0; 3]), 0.0);
        assert_eq!(proxy.sample([f32::NAN, 0.0, -1.0]), 0.0);
        assert_eq!(proxy.sample([f32::INFINITY, 0.0, -1.0]), 0.0);
        // An isotropic table is one value everywhere.
        let iso = DensityProxy::new(&Photometry::isotropic(7.0).gpu_table());
        for &d in &dirs {
            assert!((iso.sample(d) - 7.0).abs() < 1e-5, "{d:?}");
        }
    }

    #[test]
    fn pool_points_far_from_an_opening_take_fewer_samples() {
        let o = OpeningParams {
            kind: 0,
            axis: 2,
            faces: 1,
            half: [0.3, 0.03, 0.01],
            near: 10.0,
            size: 0.5,
        };
        let n = OPENING_POOL_SAMPLES;
        for (d, want) in [
            (0.0, n),
            (0.2, n),
            (1.0, n),
            (2.0, n / 2),
            (4.0, n / 4),
            (9.0, n / 4),
            (f32::NAN, n),
        ] {
            assert_eq!(pool_samples(&o, d), want, "{d} m");
        }
        // Never fewer than two, never more than the most.
        let tiny = OpeningParams { size: 1e-6, ..o };
        assert_eq!(pool_samples(&tiny, 1.0), 2);
        let huge = OpeningParams { size: 1e6, ..o };
        assert_eq!(pool_samples(&huge, 1.0), n);
    }

    #[test]
    fn the_two_strategies_weights_sum_to_one() {
        // The gather's weight of a hit and the lamp path's weight of the same point, for the
        // cosine-weighted rays and a gap's uniform ones (whose weight carries the share 2·cx).
        for (density, r, cx, cy) in [
            (1.0f32, 0.5f32, 0.9f32, 0.3f32),
            (50.0, 2.0, 0.1, 0.99),
            (1e-3, 1e-3, 0.5, 0.5),
        ] {
            let (rays, k, scale) = (4u32, 12u32, 0.02f32);
            for (uniform, pdf, share) in [(false, cx, 1.0), (true, 0.5, 2.0 * cx)] {
                let wc = gather_weight(rays, k, scale, density, r, cx, cy, uniform) / share;
                let pv = density * scale;
                let wv = k as f32 * pv
                    / (k as f32 * pv + rays as f32 * pdf * cy / (std::f32::consts::PI * r * r));
                assert!((wc + wv - 1.0).abs() < 1e-5, "{uniform}: {wc} + {wv}");
            }
        }
        assert_eq!(gather_weight(4, 0, 1.0, 1.0, 1.0, 1.0, 1.0, false), 1.0);
        assert_eq!(gather_weight(4, 8, 1.0, 0.0, 1.0, 1.0, 1.0, false), 1.0);
        // Without lamp paths a uniform ray's weight is its share alone.
        assert_eq!(gather_weight(4, 0, 1.0, 1.0, 1.0, 0.25, 1.0, true), 0.5);
        assert_eq!(gather_weight(4, 8, 1.0, 0.0, 1.0, 0.25, 1.0, true), 0.5);
    }

    #[test]
    fn emission_follows_the_intensity_bound() {
        // A lamp lighting only its lower hemisphere (nadir −Z in its frame): no pool ray goes up.
        let p = Photometry::from_grid(
            luxbake_ies::PhotometricType::C,
            vec![0.0, 45.0, 90.0, 135.0, 180.0],
            vec![0.0],
            vec![100.0, 80.0, 0.0, 0.0, 0.0],
        )
        .expect("grid");
        let lamp = LampParams {
            position: [0.0; 3],
            world_to_photometric: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            scale: [1.0; 3],
            table: 0,
            opening: None,
        };
        let e = Emitter::new(&[lamp], &[p.gpu_table()]);
        let mut down = 0;
        for i in 0..4096 {
            let (_, w) = e.sample(i, 0).expect("sample");
            assert!(w[2] <= 1e-9, "{w:?}");
            down += usize::from(w[2] < -0.7);
            // The density is positive where rays go, and integrates the bound.
            assert!(e.density(0, w) > 0.0);
        }
        // Most of the bound lies within 45° of nadir.
        assert!(down > 2000, "{down}");
    }

    #[test]
    fn a_cell_found_by_its_edges_is_the_cell_of_its_angles() {
        // `⌊γ/π·rows⌋` and `⌊C/2π·width⌋` from acos and atan2, as the cells were found
        // before the bisection.
        let by_angles = |cells: &LampCells, rows: u32, [x, y, z]: [f64; 3]| {
            let len = (x * x + y * y + z * z).sqrt();
            let gamma = (-z / len).clamp(-1.0, 1.0).acos();
            let mut c = y.atan2(x);
            if c < 0.0 {
                c += std::f64::consts::TAU;
            }
            let gf = gamma / std::f64::consts::PI * f64::from(rows);
            let cf = c / std::f64::consts::TAU * f64::from(cells.width);
            // Within rounding of an edge either side may be found.
            let near = |f: f64| (f - f.round()).abs() < 1e-9;
            let j = (gf.floor() as u32).min(rows - 1) as usize;
            let i = (cf.floor() as u32).min(cells.width - 1) as usize;
            (j * cells.width as usize + i, near(gf) || near(cf))
        };
        for (width, height) in [(1u32, 2u32), (4, 3), (72, 37), (360, 181)] {
            let rows = height - 1;
            let cells = LampCells::new(
                [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                1.0,
                width,
                row_cosines(height),
                vec![1.0; (rows * width) as usize],
            );
            let mut checked = 0;
            // Poles, the azimuth's seam (C = 0 from both sides, −0), then scattered
            // directions.
            let mut dirs = vec![
                [0.0, 0.0, -1.0],
                [0.0, 0.0, 1.0],
                [1.0, 0.0, 0.3],
                [1.0, -0.0, 0.3],
                [1.0, -1e-12, 0.3],
                [-1.0, 0.0, 0.0],
                [-1.0, -1e-12, 0.0],
                [0.0, -1.0, 0.5],
            ];
            for k in 0..20_000u32 {
                let [a, b] = rng::uniform2(k, 0, 7, width);
                let [c, _] = rng::uniform2(k, 1, 7, width);
                dirs.push([f64::from(a) - 0.5, f64::from(b) - 0.5, f64::from(c) - 0.5]);
            }
            for d in dirs {
                let (want, edge) = by_angles(&cells, rows, d);
                let got = cells.cell_of(d).expect("a direction");
                assert!(got < (rows * width) as usize, "{d:?}: cell {got}");
                if !edge {
                    assert_eq!(got, want, "{width} × {height}: {d:?}");
                    checked += 1;
                }
            }
            assert!(checked > 19_000, "{checked}");
            assert_eq!(cells.cell_of([0.0; 3]), None);
        }
    }

    /// The pool's Morton order: a permutation of the points, neighbours along the order near
    /// each other (a stretch of the pool is a patch of the surfaces), ties in the given order,
    /// and nothing lost to a degenerate or non-finite position.
    #[test]
    fn the_pool_in_morton_order_is_a_permutation_along_a_curve() {
        let point = |x: f32, y: f32, z: f32, i: u32| LampPath {
            position: [x, y, z],
            normal: [0.0, 1.0, 0.0],
            power: [i as f32, 0.0, 0.0],
            density: 1.0,
        };
        // A 16 × 16 grid on the floor, given row by row in a scrambled order.
        let mut pool: Vec<LampPath> = (0..256u32)
            .map(|i| {
                let k = (i * 97) % 256;
                point((k % 16) as f32 * 0.25, 0.0, (k / 16) as f32 * 0.25, k)
            })
            .collect();
        pool.push(point(0.0, 0.0, 0.0, 1000));
        let sorted = morton_order(pool.clone());
        let mut ids: Vec<u32> = sorted.iter().map(|p| p.power[0] as u32).collect();
        // The duplicate of point 0 follows it (a tie keeps the given order).
        let at0 = ids.iter().position(|&i| i == 0).expect("0");
        assert_eq!(ids[at0 + 1], 1000);
        ids.sort_unstable();
        let mut want: Vec<u32> = (0..256).collect();
        want.push(1000);
        assert_eq!(ids, want);
        // Along a Morton curve each aligned run of 4 points is a 2 × 2 cell of the grid
        // (0.25 m apart): the mean step is far below a random order's (about 1.9 m here).
        let steps: f32 = sorted[..256]
            .windows(2)
            .filter(|w| w[0].power[0] != 1000.0 && w[1].power[0] != 1000.0)
            .map(|w| {
                let d = [0, 1, 2].map(|c| w[1].position[c] - w[0].position[c]);
                (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
            })
            .sum();
        assert!(steps / 255.0 < 0.6, "mean step {}", steps / 255.0);
        // Degenerate and non-finite positions keep every point.
        let odd = vec![
            point(1.0, 1.0, 1.0, 0),
            point(f32::NAN, 0.0, f32::INFINITY, 1),
        ];
        assert_eq!(morton_order(odd).len(), 2);
        assert!(morton_order(Vec::new()).is_empty());
        assert_eq!(morton_order(vec![point(2.0, 2.0, 2.0, 5)]).len(), 1);
    }
}
