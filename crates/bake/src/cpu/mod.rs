//! The passes' CPU references and what runs them: every pass in plain Rust (rayon over texel
//! rows), tracing rays through the 8-wide BVH collapsed from the encoded scene
//! ([`WideBvh`](luxbake_bvh::WideBvh), the default [`BvhMode::Wide`](crate::scene::BvhMode::Wide))
//! or, with `mtbvh`, `tbvh` or `none`, through [`EncodedScene`](luxbake_bvh::EncodedScene)'s CPU
//! traversal of the *encoded textures* — the same data the shaders read. Both use the same
//! watertight triangle test and agree up to ties. Everything is `f32` and each texel's value is
//! computed as a fragment shader would compute it, so that it is the oracle every GPU backend is
//! diffed against. Two passes share work across texels without changing a bit of the result:
//! the gather takes a row's rays through its stages in chunks, tracing a chunk before it
//! fetches the previous chunk's look-ups (so that the look-ups' cache misses overlap), and then
//! sums each texel's rays in order (`gather_sums`); the blur computes its tap
//! weights and the normalised normals once per dispatch.
//!
//! The backend that stores the textures and dispatches the passes here is the crate
//! `luxbake-backend-cpu` (`CpuBackend`, formerly `luxbake::cpu::CpuBackend`), beside
//! `luxbake-backend-glow` and `luxbake-backend-wgpu`: this module is to it what the passes'
//! shaders are to them. It calls [`run`] per dispatch on the [`CpuScene`] it uploaded with
//! [`CpuScene::new`].
//!
//! # Pass semantics (what every backend must compute)
//! For a texel at `(layer, x, y)` with G-buffer position `p` (w = 1 valid), normal `n` (w =
//! object index) and the pass's inputs `a`, `b` (in [`PassDesc::reads`](crate::graph::PassDesc::reads) order):
//!
//! - **Direct**: for each listed lamp with position `L`, `to = L − p`, `d² = |to|²`,
//!   `ω = to / d`, `cos θ = n̂·ω` (n̂ = normalised `n`). Lamps with `cos θ ≤ 0` contribute 0.
//!   Intensity `I = table.sample(M · (−ω))` (M = world→photometric, the table's own bilinear
//!   rule) times the lamp's RGB `scale`. Shadow ray: origin `o₀ = offset(p, n̂)`
//!   ([`offset_origin`](crate::backend::offset_origin), size term `SceneData::ray_epsilon`),
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
//!   `(u₀, u₁)` = [`rng::uniform2`](crate::rng::uniform2)`(texel, s, k, seed)` (the hash sampler) or
//!   [`rng::sobol2`](crate::rng::sobol2)`(key, first + s, k, seed)` (the Sobol sampler,
//!   `GatherParams::sampler`; `key` and `first` the texel's [`rng::Stream`](crate::rng::Stream),
//!   shared by blocks of neighbouring texels),
//!   `r = √u₀`, `φ = 2π·u₁`, local `(r cos φ, r sin φ, √(1 − u₀))` (`cos φ`, `sin φ` by
//!   [`sin_cos_turns`], a polynomial as exact as `cosf`/`sinf`) in the orthonormal basis
//!   of Duff et al. (2017) built from n̂. Closest hit from `offset(p, n̂)` (t ∈ (0, ∞)). A hit counts when the hit object has a
//!   region and the ray meets the front of the surface (interpolated shading normal `n_h`,
//!   `n_h·dir < 0`); then it adds the reflected map `a` looked up at the hit's light-map UV in
//!   the hit object's region by [`map::sample_masked`](crate::map::sample_masked). Back faces,
//!   misses and non-receivers add 0. Output `(Σ / N, 1)`. Since `E = π·mean(L)` over a
//!   cosine-weighted hemisphere and a Lambertian surface's radiance is `L = M/π`, the mean
//!   exitance is the indirect illuminance. A texel in a narrow gap (position `w ≥`
//!   [`NARROW_GAP`](crate::validity::NARROW_GAP)) draws its directions uniformly over the
//!   hemisphere instead, local `(r cos φ, r sin φ, 1 − u₀)` with `r = √(u₀(2 − u₀))`
//!   ([`Frame::uniform_direction`]), and weights each hit by `2·n̂·dir`
//!   ([`lightpaths::gather_weight`](crate::lightpaths::gather_weight) says why).
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
//! centre's and, for `o ≠ 0`, its world position lies in the
//! shell its offset allows on the centre's chart: `reach_min²·m² ≤ |x_t − x_p|² ≤
//! reach²·|o|²`, `m = max(0, max(|o.x|, |o.y|) − 2)` (the variance pass has no lower bound,
//! its offsets are at most 2). So taps of another chart — close in UV, elsewhere in the world
//! — are skipped (the test is derived in [`atrous_steps`](crate::program::atrous_steps)). Its
//! cosine is `n̂·n_t`, the centre's normal normalised, the tap's as the G-buffer stores it (unit,
//! [`crate::gbuffer`]; normalising it again cost a square root and three divisions per tap,
//! about 5 % of a default bake on the CPU, for a change of a rounding); a tap whose normal is zero
//! or not finite has cosine 0 or NaN, which every pass's cosine test rejects. The coarse grid's
//! corners ([`program::coarse`](crate::program::coarse)) are tested the same way.
//!
//! Every output passes through a guard that maps NaN to 0 and clamps to `[0, f32::MAX]`, so no
//! NaN or infinity ever reaches a map.

use crate::backend::Dispatch;
use crate::graph::TexDesc;
use crate::passes::with_registry;
use crate::program::Program;

pub mod hits;
pub(crate) mod kernel;
pub(crate) mod lanes;
#[cfg(target_arch = "x86_64")]
pub(crate) mod texels;

pub use crate::exact::{basis, guard, normalize};
pub use hits::{GatherHitStats, GatherHits};
pub use kernel::{
    CoarseMasks, CpuScene, Frame, GuideCache, GuideMasks, View, cosine_direction, sin_cos_turns,
};
use kernel::{Ctx, traversal};

/// Runs one dispatch of a pass — its CPU reference — over the dispatch's tile: `reads` are its
/// read slots' textures in order, `out` the data of the texture it writes, described by
/// `write`. `Err` says why the textures do not fit the pass ([`Dispatch::check`]); `out` is
/// then unchanged.
pub fn run<T: PartialEq>(
    call: &Dispatch<'_, T, CpuScene>,
    reads: &[View<'_>],
    write: &TexDesc,
    out: &mut [f32],
) -> Result<(), String> {
    run_with(call, reads, write, out, None)
}

/// What identifies a texture's texels for [`run_with`]: a 64-bit hash of its size, layers
/// and every float's bits.
pub fn texels_id(size: [u32; 2], layers: u32, texels: &[f32]) -> u64 {
    let mut h = hits::WordHash::new();
    for w in [size[0], size[1], layers] {
        h.add(w);
    }
    for v in texels {
        h.add(v.to_bits());
    }
    h.finish()
}

/// [`run`], with the [`GuideCache`] the backend keeps and, per read slot, what identifies its
/// texels (`None`: unknown; a backend's hash of an uploaded texture that no pass has written
/// since): the denoiser's passes then read their taps' chart tests from it ([`GuideMasks`])
/// instead of testing each tap's position, with the same result bit for bit.
pub fn run_with<T: PartialEq>(
    call: &Dispatch<'_, T, CpuScene>,
    reads: &[View<'_>],
    write: &TexDesc,
    out: &mut [f32],
    guides: Option<(&GuideCache, &[Option<u64>])>,
) -> Result<(), String> {
    let sizes: Vec<_> = reads.iter().map(|v| (v.size, v.layers)).collect();
    call.check((write.size, write.layers), &sizes, call.scene.layer_size)?;
    let ctx = Ctx {
        scene: call.scene,
        views: reads,
        trav: traversal(call.bvh),
        tile: call.tile,
        guides,
    };
    let shape = [4 * write.size[0] as usize, write.size[1] as usize];
    run_on_cpu(call.program, call.params, &ctx, out, shape);
    Ok(())
}

/// Generates [`run_on_cpu`] from the pass registry.
macro_rules! cpu_dispatch {
    ($($(#[$doc:meta])* $variant:ident = $module:ident $(($params:ident))?;)*) => {
        /// Runs `program`'s CPU reference (`passes/<label>/cpu.rs`) with the parameter words
        /// `words` over the tile of `ctx` into `out`, the written texture's data of
        /// `shape = [floats per row, rows per layer]`.
        fn run_on_cpu(
            program: Program,
            words: &[u32],
            ctx: &Ctx<'_>,
            out: &mut [f32],
            shape: [usize; 2],
        ) {
            match program {
                $(Program::$variant => {
                    kernel::run::<crate::passes::$module::cpu::Pass>(words, ctx, out, shape)
                })*
            }
        }
    };
}

with_registry!(cpu_dispatch);

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::backend::LampParams;
    use crate::cpu::kernel::*;
    use crate::layout::Region;
    use crate::map::masked_blend;
    use crate::passes::blur::cpu::*;
    use crate::passes::direct::cpu::*;
    use crate::passes::gather::cpu::*;
    use crate::program::DirectParams;
    use crate::program::blur_params;
    use crate::rng;
    use crate::rng::Draw;
    use luxbake_bvh::{Hit, Traversal, WideBvh};

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
    fn exp_f32_is_within_three_tenths_of_a_millionth() {
        let mut worst = 0.0f64;
        // Every x on a fine grid of [−87, 88], and each binade's ends.
        let grid = (0..=1_750_000).map(|i| -87.0 + i as f32 * 1e-4);
        let ends = (-126..=126).flat_map(|e| {
            let v = 2f32.powi(e);
            [v, -v]
        });
        for x in grid.chain(ends).filter(|x| (-87.0..=88.0).contains(x)) {
            let (got, want) = (f64::from(exp_f32(x)), f64::from(x).exp());
            let rel = (got - want).abs() / want;
            worst = worst.max(rel);
            assert!(
                rel <= 3e-7,
                "exp({x}) = {got}, want {want}: {rel:e} relative"
            );
        }
        assert!(worst > 0.0, "nothing compared");
        assert_eq!(exp_f32(0.0), 1.0);
        assert_eq!(exp_f32(-0.0), 1.0);
        assert_eq!(exp_f32(-87.5), 0.0);
        assert_eq!(exp_f32(f32::NEG_INFINITY), 0.0);
        assert_eq!(exp_f32(88.5), f32::INFINITY);
        assert!(exp_f32(f32::NAN).is_nan());
        // Monotone where the weight is used: never above 1, never growing as x falls.
        let mut last = 1.0f32;
        for i in 0..=870_000 {
            let v = exp_f32(-(i as f32) * 1e-4);
            assert!(v <= last, "exp_f32 grows at x = {}", -(i as f32) * 1e-4);
            last = v;
        }
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

    /// A gap's uniform directions ([`Frame::uniform_direction`]) lie in the hemisphere, and
    /// their cosine is uniform on [0, 1] (mean ½, mean square ⅓, a tenth of them within 0.1
    /// of the surface against a hundredth of the cosine-weighted ones). So the weight `2 cos θ`
    /// that [`crate::lightpaths::gather_weight`] gives each of them has mean 1: under an even
    /// sky of exitance `M` (the furnace) the gather reads `M`, as the cosine-weighted rays do.
    #[test]
    fn uniform_directions_have_a_uniform_cosine_and_a_weight_of_mean_one() {
        for n in [[0.3f32, -0.8, 0.2], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]] {
            let frame = Frame::new(normalize(n).expect("unit"));
            let count = 20_000u32;
            let (mut weight, mut square, mut grazing, mut grazing_cos) = (0.0f64, 0.0f64, 0, 0);
            for s in 0..count {
                let u = rng::sobol2(17, s, 1, 3);
                let d = frame.uniform_direction(u);
                let c = dot(d, frame.n);
                assert!((0.0..=1.0).contains(&c), "sample {s}: {c}");
                assert!((dot(d, d) - 1.0).abs() < 1e-5, "sample {s}");
                weight += 2.0 * f64::from(c);
                square += f64::from(c * c);
                grazing += u32::from(c < 0.1);
                grazing_cos += u32::from(dot(frame.cosine_direction(u), frame.n) < 0.1);
            }
            let count = f64::from(count);
            let (w, q) = (weight / count, square / count);
            assert!((w - 1.0).abs() < 1e-3, "{n:?}: mean weight {w}");
            assert!((q - 1.0 / 3.0).abs() < 1e-3, "{n:?}: mean square {q}");
            let (g, gc) = (f64::from(grazing) / count, f64::from(grazing_cos) / count);
            assert!(
                (g - 0.1).abs() < 2e-3 && (gc - 0.01).abs() < 1e-3,
                "{n:?}: {g} / {gc}"
            );
        }
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
        let table = luxbake_ies::Photometry::isotropic(1e6).gpu_table();
        CpuScene {
            wide: Arc::new(WideBvh::from_encoded(&enc)),
            attributes: decode_attributes(&enc),
            bvh: Arc::new(enc),
            lamps: vec![LampParams {
                position: lamp,
                world_to_photometric: [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]],
                scale: [1.0; 3],
                table: 0,
                opening: None,
            }],
            proxies: vec![crate::lightpaths::DensityProxy::new(&table)],
            tables: vec![table],
            regions: vec![None],
            layer_size: [1, 1],
            ray_epsilon: crate::backend::ray_epsilon(1.0),
            lamp_paths: Vec::new(),
            hits: None,
        }
    }

    /// The connect pass's lanes ([`ConnectParams::texel_with`], eight connections computed
    /// together up to their shadow rays) give every texel the scalar connections' sums bit for
    /// bit: pool points on both sides of a floor triangle (so some shadow rays are blocked),
    /// normals toward and away from the texels, zero and tiny densities, a point at a texel,
    /// picks past the pool's end, 1 to 20 picks a texel (groups of eight and a remainder).
    #[test]
    fn connect_lanes_equal_the_scalar_connections() {
        use crate::contract::TileParams;
        use crate::passes::connect::ConnectParams;
        if !lanes_available() {
            eprintln!("no AVX2 on this CPU: the lanes are not used, nothing to compare");
            return;
        }
        let mut scene = one_triangle_scene([0.0, 2.0, 0.0]);
        let u = |i: u32, j: u32| rng::uniform2(i, j, 5, 11);
        let unit = |i: u32| {
            let [a, b] = u(i, 1);
            let z = 2.0 * a - 1.0;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let (s, c) = sin_cos_turns(b);
            [r * c, r * s, z]
        };
        let mut points: Vec<f32> = Vec::new();
        for i in 0..500u32 {
            let [a, b] = u(i, 0);
            let [c, d] = u(i, 2);
            let position = match i % 50 {
                // A point at a texel's position below.
                0 => [0.25, 0.0, 0.25],
                _ => [3.0 * a - 1.5, 2.0 * b - 1.0, 3.0 * c - 1.5],
            };
            let density = match i % 7 {
                0 => 0.0,
                1 => 1e-30,
                _ => 0.1 + d,
            };
            let normal = unit(i);
            points.extend([position[0], position[1], position[2], density]);
            points.extend([normal[0], normal[1], normal[2], 0.0]);
            points.extend([1.0 + a, 0.5 + b, 2.0 * c, 0.0]);
        }
        scene.lamp_paths = LampPoint::unpack(&points, scene.ray_epsilon);
        // Texels above the floor (some on it, some tilted, some not valid).
        let size = [16u32, 16];
        let (mut pos, mut nrm) = (Vec::new(), Vec::new());
        for i in 0..size[0] * size[1] {
            let [a, b] = u(1000 + i, 0);
            let y = if i % 3 == 0 { 0.0 } else { 0.5 * b };
            // Some in a narrow gap, whose gather's rays are uniform (the weights differ).
            let valid = match i % 11 {
                0 => 0.0,
                3 | 7 => crate::validity::NARROW_GAP,
                _ => 1.0,
            };
            let p = if i == 5 {
                [0.25, 0.0, 0.25]
            } else {
                [2.0 * a - 1.0, y, 2.0 * b - 1.0]
            };
            pos.extend([p[0], p[1], p[2], valid]);
            let n = if i % 4 == 0 {
                unit(2000 + i)
            } else {
                [0.0, 1.0, 0.0]
            };
            nrm.extend([n[0], n[1], n[2], 0.0]);
        }
        // The variance map's slot: the first connections do not read it.
        let views = [
            View::new(&pos, size, 1),
            View::new(&nrm, size, 1),
            View::new(&pos, size, 1),
        ];
        let ctx = Ctx {
            scene: &scene,
            views: &views,
            trav: Trav::Wide,
            tile: TileParams::default(),
            guides: None,
        };
        let (mut compared, mut lit) = (0, 0);
        for k in [1u32, 7, 8, 12, 20] {
            let params = ConnectParams {
                rays: 4,
                k,
                seed: 3,
                count: 500,
                density_scale: 0.8,
                ..ConnectParams::default()
            };
            for i in 0..size[0] * size[1] {
                let at = Texel::layer0(i % size[0], i / size[0]);
                // Picks from the pool, every 13th past its end.
                let picks: Vec<usize> = (0..k)
                    .map(|s| {
                        let [a, _] = u(i, 100 + s);
                        if (i + s) % 13 == 0 {
                            600
                        } else {
                            (a * 500.0) as usize
                        }
                    })
                    .collect();
                let got = params.texel_with(&ctx, at, &picks, true);
                let want = params.texel_with(&ctx, at, &picks, false);
                assert_eq!(
                    got.map(f32::to_bits),
                    want.map(f32::to_bits),
                    "{at:?}, {k} picks"
                );
                compared += 1;
                lit += usize::from(want[0] > 0.0);
            }
        }
        println!("{compared} texels compared, {lit} lit");
        assert!(compared == 5 * 256 && lit > 200, "{lit} lit");
    }

    /// Whether this CPU runs the AVX2 lanes; under CI (`CI=true`), whose machines have AVX2,
    /// a test that would compare nothing without them fails instead of skipping.
    pub(crate) fn lanes_available() -> bool {
        #[cfg(target_arch = "x86_64")]
        let avx2 = std::arch::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let avx2 = false;
        assert!(
            avx2 || std::env::var("CI").as_deref() != Ok("true"),
            "CI=true, but this CPU has no AVX2: the lanes cannot be tested"
        );
        avx2
    }

    /// The gather's directions (four draws at a time, with AVX2 where the CPU has it) are the
    /// module docs' per-ray rule bit for bit, `cosine_direction(n̂, uniform2(texel, s, bounce,
    /// seed))` (a gap's texels: `uniform_direction`), for both samplers, ray counts with and
    /// without a remainder of four, and samples inside and past the pass's precomputed ones.
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
                    uniform: i % 7 == 3,
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
                        let d = if t.uniform {
                            t.frame.uniform_direction(u)
                        } else {
                            cosine_direction(t.frame.n, u)
                        };
                        d.map(f32::to_bits)
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
                let want = crate::map::sample_masked(
                    |x, y| map.fetch(Texel { layer, x, y }),
                    offset,
                    rect,
                    uv,
                );
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
        seed: 0,
        samples: 0,
        openings: 0,
        first_sample: 0,
        chunk_samples: 0,
        probe_stride: 0,
        points_only: 0,
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
            let e = direct_texel(
                &scene,
                ONE_LAMP,
                Trav::Encoded(Traversal::BruteForce),
                0,
                p,
                n,
                [0.0; 3],
            );
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
            0,
            p,
            n,
            [0.0; 3],
        );
        assert!((f64::from(e[0]) - 1e12).abs() < 1e12 * 1e-5, "{e:?}");
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
        let a = blur_texel([s, n], blur_params([1, 0], 1.0), Texel::layer0(0, 0));
        let b = blur_texel([s, n], blur_params([1, 0], 1.0), Texel::layer0(1, 0));
        let w = (-0.5f32).exp();
        let expected_a = (1.0 + 3.0 * w) / (1.0 + w);
        assert!((a[0] - expected_a).abs() < 1e-6, "{a:?}");
        let expected_b = (3.0 + 1.0 * w) / (1.0 + w);
        assert!((b[0] - expected_b).abs() < 1e-6, "{b:?}");
        assert_eq!(
            blur_texel([s, n], blur_params([1, 0], 1.0), Texel::layer0(2, 0)),
            [0.0; 4]
        );
        assert_eq!(
            blur_texel([s, n], blur_params([1, 0], 5.0), Texel::layer0(3, 0)),
            [100.0, 100.0, 100.0, 1.0]
        );
        // A vertical pass over a one-row image sees only the centre.
        assert_eq!(
            blur_texel([s, n], blur_params([0, 1], 3.0), Texel::layer0(1, 0)),
            [3.0, 3.0, 3.0, 1.0]
        );
    }
}

#[cfg(test)]
mod denoiser_tests {
    use crate::cpu::kernel::*;
    use crate::passes::atrous::cpu::*;
    use crate::passes::blur::cpu::*;
    use crate::passes::combine::CombineParams;
    use crate::passes::combine::cpu::combine_texel;
    use crate::passes::upsample::cpu::*;
    use crate::passes::variance::cpu::*;
    use crate::program::{AtrousConfig, Params, atrous_steps, blur_params, correction_steps};
    use crate::program::{GatherParams, UpsampleParams, coarse};
    use crate::rng;

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
    fn apply(size: [u32; 2], f: impl Fn(Texel) -> [f32; 4]) -> Vec<f32> {
        (0..size[1])
            .flat_map(|y| (0..size[0]).map(move |x| Texel::layer0(x, y)))
            .flat_map(f)
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

        /// The denoiser as the graph chains it: the variance estimate, the à-trous iterations
        /// and the bias correction `y · B(L(x)) / B(L(y))` ([`correction_steps`]): the variance
        /// map and the result.
        fn denoise(&self, config: &AtrousConfig) -> (Vec<f32>, Vec<f32>) {
            let (variance, y) = self.atrous(config);
            let correction = correction_steps(config);
            if correction.is_empty() {
                return (variance, y);
            }
            let size = self.size;
            let (pos, nrm) = (view(&self.pos, size), view(&self.nrm, size));
            // `Program::Combine`'s texels over the whole maps.
            let combine = |w: CombineParams, a: &[f32], b: &[f32]| -> Vec<f32> {
                a.chunks_exact(4)
                    .zip(b.chunks_exact(4))
                    .flat_map(|(a, b)| {
                        combine_texel(w, a.try_into().unwrap(), b.try_into().unwrap())
                    })
                    .collect()
            };
            let mut pair = combine(CombineParams::PAIR, &self.map, &y);
            for (_, params) in correction {
                let Params::Atrous(p) = params else {
                    panic!("{params:?}")
                };
                let src = pair.clone();
                let maps = [view(&src, size), view(&variance, size), pos, nrm];
                pair = apply(size, |at| atrous_texel(maps, p, None, at));
            }
            (variance, combine(CombineParams::RATIO, &y, &pair))
        }

        /// The variance estimate and the à-trous iterations alone ([`atrous_steps`]): the
        /// variance map and the filtered map.
        fn atrous(&self, config: &AtrousConfig) -> (Vec<f32>, Vec<f32>) {
            let size = self.size;
            let (pos, nrm) = (view(&self.pos, size), view(&self.nrm, size));
            let mut variance = Vec::new();
            let mut out = self.map.clone();
            for (_, params) in atrous_steps(config) {
                let src = out.clone();
                let s = view(&src, size);
                match params {
                    Params::Variance(p) => {
                        // The map stands in for the direct light, whose luminance only
                        // refinement reads (alpha).
                        variance = apply(size, |at| variance_texel([s, pos, nrm, s], p, None, at));
                    }
                    Params::Atrous(p) => {
                        let v = view(&variance, size);
                        out = apply(size, |at| atrous_texel([s, v, pos, nrm], p, None, at));
                    }
                    other => panic!("{other:?}"),
                }
            }
            (variance, out)
        }

        /// The separable Gaussian of the blur passes (U, then V).
        fn gaussian(&self, sigma: f32) -> Vec<f32> {
            let (size, nrm) = (self.size, view(&self.nrm, self.size));
            let map = view(&self.map, size);
            let u = apply(size, |at| {
                blur_texel([map, nrm], blur_params([1, 0], sigma), at)
            });
            apply(size, |at| {
                blur_texel([view(&u, size), nrm], blur_params([0, 1], sigma), at)
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

    /// The bias correction `y · B(L(x)) / B(L(y))` ([`correction_steps`]) cancels the à-trous
    /// filter's curvature bias: on a noiseless paraboloid peaking mid-chart (as the light on a seat's
    /// underside does), with a luminance term wide enough for the à-trous filter to average
    /// it (as noise makes it do), the à-trous filter alone reads low by half its kernel's
    /// second moment times the Laplacian (3 iterations: 21 texels² per axis), and the
    /// corrected filter returns the paraboloid within a twentieth of that where every tap of
    /// both lies on the chart (the ratio's second-order term: the two filters' biases `a`, `b`
    /// leave `a·b / (s + a + b)`, 7·10⁻⁴ of a field of 40 here); at the chart's edges
    /// (mirrored pairs) its error is still smaller.
    #[test]
    fn the_correction_cancels_the_curvature_bias() {
        let light = |x: u32, y: u32| {
            let (dx, dy) = (x as f32 - 49.5, y as f32 - 49.5);
            40.0 - 0.002 * (dx * dx + dy * dy)
        };
        let f = Field::flat([100, 100], light);
        let config = AtrousConfig {
            sigma_luminance: 1e4,
            early_sigma_luminance: 1e4,
            ..AtrousConfig::new(3, H).with_correction(true)
        };
        assert_eq!(config.correction_iterations, 4);
        let (_, a) = f.atrous(&config);
        let (_, c) = f.denoise(&config);
        // Taps of B (4 iterations) reach 2·15 texels; those of A 2·7.
        let inner = 30..70u32;
        let (mut worst_a, mut worst_c, mut inner_a, mut inner_c) = (0f32, 0f32, 0f32, 0f32);
        for y in 0..100 {
            for x in 0..100 {
                let (i, s) = (f.index(x, y), light(x, y));
                let (ea, ec) = (a[i] - s, c[i] - s);
                (worst_a, worst_c) = (worst_a.max(ea.abs()), worst_c.max(ec.abs()));
                if inner.contains(&x) && inner.contains(&y) {
                    // ½ · 21 · ∇²s = ½ · 21 · (−0.008) = −0.084.
                    assert!((ea + 0.084).abs() < 2e-3, "({x}, {y}): à-trous {ea}");
                    (inner_a, inner_c) = (inner_a.max(ea.abs()), inner_c.max(ec.abs()));
                }
            }
        }
        // What is left is a twentieth of the bias (of a field of 40: 5e-5 relative).
        assert!(
            inner_c < 0.05 * inner_a,
            "corrected {inner_c} against {inner_a}"
        );
        assert!(
            worst_c < 0.5 * worst_a,
            "corrected {worst_c} against {worst_a}"
        );
    }

    /// Light that falls a hundredfold over a few texels (into a gap behind a bookcase): an
    /// exponential `s = 100·e^(−x/2 − y/3)` (not constant along any of the variance
    /// estimate's four directions, so the luminance term sees it). A symmetric filter of unit
    /// weight multiplies an exponential by a constant away from the edges, `A·s = c_A·s`, so
    /// the ratio `y·B(L(x))/B(L(y))` returns `s` exactly there, while the sum `y + B(x − y)`
    /// gives `(c_A + c_B − c_A·c_B)·s`, below 0 (clamped: a dark texel read as black) once both
    /// filters are wide. Checked where every tap of both, and of A under B's, lies on the
    /// chart.
    #[test]
    fn the_correction_keeps_light_that_falls_steeply() {
        let light = |x: u32, y: u32| 100.0 * (-(x as f32) / 2.0 - y as f32 / 3.0).exp();
        let f = Field::flat([100, 100], light);
        let config = AtrousConfig {
            sigma_luminance: 1e4,
            early_sigma_luminance: 1e4,
            ..AtrousConfig::new(3, H).with_correction(true)
        };
        let (_, a) = f.atrous(&config);
        let (_, c) = f.denoise(&config);
        let (mut worst_a, mut worst_c) = (0f32, 0f32);
        // Taps of B (4 iterations) reach 2·15 texels, of A 2·7: B reads only A's outputs whose
        // taps were all on the chart from 44 texels in.
        for y in 44..56 {
            for x in 44..56 {
                let (i, s) = (f.index(x, y), light(x, y));
                let (ra, rc) = (a[i] / s - 1.0, c[i] / s - 1.0);
                (worst_a, worst_c) = (worst_a.max(ra.abs()), worst_c.max(rc.abs()));
            }
        }
        // The à-trous filter alone reads the dark side many times too bright.
        assert!(worst_a > 1.0, "à-trous {worst_a}");
        assert!(worst_c < 1e-3, "corrected {worst_c} (à-trous {worst_a})");
    }

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
                    // field's (one grey level per surface here), and so is the alpha, the
                    // direct light's luminance, for which the field stands in.
                    let (var, mean) = (&variance[i..i + 4], luminance(xyz(v)));
                    assert_eq!([var[0], var[2], var[3]], [0.0, 0.0, mean], "({x}, {y})");
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
            let guide = Guide::new([src, pos, nrm], reach, Texel::layer0(2, 0)).expect("normal");
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
        coarse_rays([pos, nrm], &params, None, Texel::layer0(x, y))
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
        let out = apply(size, |at| {
            upsample_texel([view(&f.map, size), pos, nrm], params, None, at)
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

#[cfg(test)]
mod guide_mask_tests {
    use crate::backend::Limits;
    use crate::bake::Room;
    use crate::cpu::kernel::*;
    use crate::cpu::lanes::LANES;
    use crate::program::AtrousConfig;
    use crate::scene::{Quality, Scene, Settings};

    /// The kept chart tests ([`GuideMasks`]) give every tap of every texel what `Guide::tap`
    /// gives — value and cosine bit for bit, or none — at every step the denoiser uses and
    /// beyond, on a furnished room's G-buffer (charts side by side, contacts, chart edges).
    /// The denoiser passes ask for the masks of the position map by read slot (2 for the
    /// à-trous pass, 1 for the variance pass): their signatures put it there.
    #[test]
    fn the_denoiser_passes_read_the_position_map_where_they_ask_its_masks() {
        use crate::program::Program;
        assert_eq!(Program::Atrous.signature().reads[2], "position");
        assert_eq!(Program::Variance.signature().reads[1], "position");
    }

    /// `chairs_01` prepared at 12 texels/m: a furnished room's G-buffer (charts side by side,
    /// contacts, chart edges, empty texels) for the tests below.
    fn chairs_01_room() -> Room {
        let settings = Settings {
            texels_per_metre: 12.0,
            ..Settings::preset(Quality::Default)
        };
        let scene = Scene::builtin_with_settings("chairs_01", settings.clone()).expect("scene");
        Room::prepare(&scene, &settings, Limits::WEBGL2, &mut |_| {}).expect("room")
    }

    #[test]
    fn the_kept_chart_tests_give_the_taps_the_guide_gives() {
        let room = chairs_01_room();
        let g = &room.gbuffer;
        let (size, layers) = (g.layer_size, g.layers);
        let pos = View::new(&g.position, size, layers);
        let nrm = View::new(&g.normal, size, layers);
        // The G-buffer's positions as the filtered map: valid where the G-buffer is.
        let src = pos;
        let config = AtrousConfig::new(3, 1.0 / 12.0);
        let (mut same, mut taken, mut charted) = (0u64, 0u64, 0u64);
        for step in [1i64, 2, 4, 8] {
            for reach in [[config.reach_min(), config.reach()], [0.0, config.reach()]] {
                let masks = GuideMasks::new(pos, Chart { step, reach });
                for layer in 0..layers {
                    for y in 0..size[1] {
                        for x in 0..size[0] {
                            let at = Texel { layer, x, y };
                            let Some(guide) = Guide::new([src, pos, nrm], reach, at) else {
                                continue;
                            };
                            let kept = Guide::new([src, pos, nrm], reach, at)
                                .expect("guide")
                                .with_masks(Some(&masks), at);
                            for k in 0..25usize {
                                let o = [(k as i64 % 5 - 2) * step, (k as i64 / 5 - 2) * step];
                                let bits = |t: Option<([f32; 4], f32)>| {
                                    t.map(|(v, c)| (v.map(f32::to_bits), c.to_bits()))
                                };
                                let want = guide.tap(o);
                                assert_eq!(bits(kept.tap_k(k, o)), bits(want), "{at:?} {o:?}");
                                same += 1;
                                taken += u64::from(want.is_some());
                                // In the layer and valid, yet off the chart.
                                let (tx, ty) = (i64::from(x) + o[0], i64::from(y) + o[1]);
                                let inside = tx >= 0
                                    && ty >= 0
                                    && tx < i64::from(size[0])
                                    && ty < i64::from(size[1]);
                                if inside
                                    && pos.fetch(Texel {
                                        layer,
                                        x: tx as u32,
                                        y: ty as u32,
                                    })[3]
                                        > 0.5
                                    && kept.mask.is_some_and(|m| m & (1 << k) == 0)
                                {
                                    charted += 1;
                                }
                            }
                        }
                    }
                }
            }
        }
        println!("{same} taps compared, {taken} taken, {charted} rejected by the chart test");
        assert!(taken > 100_000 && charted > 1_000 && same > taken);
    }

    /// The kept grid corners ([`CoarseMasks`]) give the later bounces' gather the same
    /// orphans and the upsampling the same value, bit for bit, at every texel of a furnished
    /// room's G-buffer, at the strides the presets use and beyond; the passes ask for them by
    /// the read slots of the position and normal maps.
    #[test]
    fn the_kept_grid_corners_give_the_orphans_and_the_upsampling_the_tests_give() {
        use crate::passes::gather::GatherParams;
        use crate::passes::upsample::UpsampleParams;
        use crate::passes::upsample::cpu::upsample_texel;
        use crate::program::Program;
        assert_eq!(
            Program::Gather.signature().reads[..2],
            ["position", "normal"]
        );
        assert_eq!(
            Program::Upsample.signature().reads[1..3],
            ["position", "normal"]
        );
        let room = chairs_01_room();
        let g = &room.gbuffer;
        let (size, layers) = (g.layer_size, g.layers);
        let pos = View::new(&g.position, size, layers);
        let nrm = View::new(&g.normal, size, layers);
        // A map that differs from texel to texel, so that every corner's weight shows.
        let map: Vec<f32> = (0..g.position.len())
            .map(|i| 1.0 + (i % 97) as f32 * 0.37)
            .collect();
        let src = View::new(&map, size, layers);
        let reach = AtrousConfig::new(3, 1.0 / 12.0).reach();
        let (mut orphans, mut covered, mut compared) = (0u64, 0u64, 0u64);
        for stride in [2u32, 4, 8] {
            for reach in [reach, 0.5 * reach] {
                let masks = CoarseMasks::new([pos, nrm], stride, reach);
                let gather = GatherParams {
                    rays: 16,
                    stride,
                    reach,
                    orphan_rays: 5,
                    ..GatherParams::default()
                };
                let upsample = UpsampleParams {
                    stride,
                    reach,
                    ..UpsampleParams::default()
                };
                for layer in 0..layers {
                    for y in 0..size[1] {
                        for x in 0..size[0] {
                            let at = Texel { layer, x, y };
                            if pos.fetch(at)[3] <= 0.5 {
                                continue;
                            }
                            let rays = coarse_rays([pos, nrm], &gather, None, at);
                            let kept = coarse_rays([pos, nrm], &gather, Some(&masks), at);
                            assert_eq!(kept, rays, "{at:?} stride {stride}");
                            orphans += u64::from(rays == 5);
                            covered += u64::from(rays == 0);
                            let bits = |v: [f32; 4]| v.map(f32::to_bits);
                            let want = upsample_texel([src, pos, nrm], upsample, None, at);
                            let got = upsample_texel([src, pos, nrm], upsample, Some(&masks), at);
                            assert_eq!(bits(got), bits(want), "{at:?} stride {stride}");
                            compared += 1;
                        }
                    }
                }
            }
        }
        println!("{compared} texels compared, {covered} covered, {orphans} orphans");
        assert!(compared > 50_000 && covered > 10_000 && orphans > 1_000);
    }

    /// The variance pass's blocks of eight texels ([`variance_block`], vector lanes with
    /// AVX2) give every texel what the texel-by-texel estimate gives without kept chart tests,
    /// bit for bit, on a furnished room's G-buffer with a noisy map (spikes, zeros), at the
    /// denoiser's settings and with fewer and more pairs required.
    #[test]
    fn variance_blocks_equal_the_texel_by_texel_estimate() {
        use crate::passes::variance::VarianceParams;
        use crate::passes::variance::cpu::{variance_block, variance_texel};
        use crate::program::{Params, atrous_steps};
        use crate::rng;
        let room = chairs_01_room();
        let g = &room.gbuffer;
        let (size, layers) = (g.layer_size, g.layers);
        let pos = View::new(&g.position, size, layers);
        let nrm = View::new(&g.normal, size, layers);
        let texels = g.position.len() / 4;
        let mut map = vec![0.0f32; 4 * texels];
        for i in (0..texels).filter(|&i| g.position[4 * i + 3] > 0.5) {
            let [u, _] = rng::uniform2(i as u32, 0, 9, 2);
            let l = match i % 41 {
                0 => 900.0,
                1 => 0.0,
                _ => 20.0 + 10.0 * u,
            };
            map[4 * i..4 * i + 4].copy_from_slice(&[l, 0.7 * l, 1.2 * l, 1.0]);
        }
        let src = View::new(&map, size, layers);
        // A direct light of its own, for the alpha every texel carries.
        let direct: Vec<f32> = map
            .chunks_exact(4)
            .enumerate()
            .flat_map(|(i, t)| [t[1] * (i % 7) as f32, 3.0, t[0], t[3]])
            .collect();
        let direct = View::new(&direct, size, layers);
        let config = AtrousConfig::new(3, 1.0 / 12.0);
        let base = atrous_steps(&config)
            .into_iter()
            .find_map(|(_, p)| match p {
                Params::Variance(v) => Some(v),
                _ => None,
            })
            .expect("a variance pass");
        let (mut compared, mut vector) = (0usize, 0usize);
        for min_pairs in [base.min_pairs, 0, 1, 12] {
            let p = VarianceParams { min_pairs, ..base };
            let chart = Chart {
                step: 1,
                reach: [0.0, p.reach],
            };
            let masks = GuideMasks::new(pos, chart);
            let maps = [src, pos, nrm, direct];
            let (c, v) = compare_blocks(
                (size, layers),
                |at, out| variance_block(maps, p, &masks, at, out),
                |at| variance_texel(maps, p, None, at),
            );
            (compared, vector) = (compared + c, vector + v);
        }
        assert_lanes_used(compared, vector);
    }

    /// The à-trous pass's blocks of eight texels ([`atrous_block`], vector lanes with AVX2)
    /// give every texel what the texel-by-texel filter gives without kept chart tests, bit for
    /// bit: on a furnished room's G-buffer (charts side by side, contacts, chart edges, empty
    /// texels), a noisy map with spikes, variances from 0 (no range weight) to large, at
    /// every step the denoiser uses and normal powers 1, 2⁰ … 2⁵; and the bias correction's
    /// linear filter on a pair of luminances.
    #[test]
    fn atrous_blocks_equal_the_texel_by_texel_filter() {
        use crate::passes::atrous::cpu::{atrous_block, atrous_texel};
        use crate::program::{Params, atrous_steps, correction_steps};
        use crate::rng;
        let room = chairs_01_room();
        let g = &room.gbuffer;
        let (size, layers) = (g.layer_size, g.layers);
        // Texels in narrow gaps take their own early term: besides the room's own (few: gaps
        // closed to their sides), every 11th valid texel is marked as one.
        let mut position = g.position.clone();
        for t in position
            .chunks_exact_mut(4)
            .step_by(11)
            .filter(|t| t[3] > 0.5)
        {
            t[3] = crate::validity::NARROW_GAP;
        }
        let pos = View::new(&position, size, layers);
        let nrm = View::new(&g.normal, size, layers);
        // Grey-ish light with noise, every 37th texel a spike; valid where the G-buffer is.
        let texels = g.position.len() / 4;
        let mut map = vec![0.0f32; 4 * texels];
        let mut var = vec![0.0f32; 4 * texels];
        for i in (0..texels).filter(|&i| g.position[4 * i + 3] > 0.5) {
            let [u, v] = rng::uniform2(i as u32, 0, 7, 1);
            let spike = if i % 37 == 0 { 40.0 } else { 1.0 };
            let l = (20.0 + 10.0 * u) * spike;
            map[4 * i..4 * i + 4].copy_from_slice(&[l, 0.8 * l, 1.1 * l, 1.0]);
            var[4 * i] = match i % 5 {
                0 => 0.0,
                1 => 1e-6 * v,
                _ => 50.0 * v,
            };
            // The window's mean: where it is set, the texels with little variance are quiet
            // (`AtrousParams::wide_max_relative_variance`), the others not.
            var[4 * i + 1] = if i % 3 == 0 { 0.0 } else { 25.0 };
        }
        // The bias correction's linear filter reads two luminances side by side
        // (`CombineParams::PAIR`): the light's and, for the second, its square root.
        let pair: Vec<f32> = map
            .chunks_exact(4)
            .flat_map(|t| {
                let l = crate::exact::luminance([t[0], t[1], t[2]]);
                [l, l.sqrt(), 0.0, t[3]]
            })
            .collect();
        let variance = View::new(&var, size, layers);
        // With the texels in narrow gaps taking their own early term.
        let config = AtrousConfig::new(4, 1.0 / 12.0)
            .with_correction(true)
            .with_narrow_rays(64);
        let narrow = (0..texels)
            .filter(|&i| position[4 * i + 3] >= crate::validity::NARROW_GAP)
            .count();
        assert!(narrow > 100, "{narrow} texels in narrow gaps");
        let (mut compared, mut vector, mut wide) = (0usize, 0usize, 0usize);
        for (_, params) in atrous_steps(&config)
            .into_iter()
            .chain(correction_steps(&config))
        {
            let Params::Atrous(base) = params else {
                continue;
            };
            let linear = base.linear != 0;
            let src = View::new(if linear { &pair } else { &map }, size, layers);
            for normal_log2 in [base.normal_log2, 0, 5] {
                // The later iterations with the wide term where the noise is low (at this
                // texel size their taps reach too far for the default to allow it).
                let wide_max_relative_variance = if base.step >= 4 {
                    crate::program::ATROUS_WIDE_MAX_RELATIVE_VARIANCE
                } else {
                    0.0
                };
                let p = crate::passes::atrous::AtrousParams {
                    normal_log2,
                    wide_max_relative_variance,
                    ..base
                };
                let chart = Chart {
                    step: i64::from(p.step),
                    reach: [p.reach_min, p.reach],
                };
                let masks = GuideMasks::new(pos, chart);
                let maps = [src, variance, pos, nrm];
                let (c, v) = compare_blocks(
                    (size, layers),
                    |at, out| atrous_block(maps, p, &masks, at, out),
                    |at| atrous_texel(maps, p, None, at),
                );
                (compared, vector) = (compared + c, vector + v);
                // Iterations whose taps reach beyond a gap (2·step > 6 texels) leave its
                // texels as they are; the nearer ones filter them.
                assert_eq!(p.narrow_keep, u32::from(p.step >= 4), "step {}", p.step);
                let (mut kept, mut moved) = (0, 0);
                for i in (0..texels).filter(|&i| position[4 * i + 3] >= crate::validity::NARROW_GAP)
                {
                    let x = (i as u32) % size[0];
                    let y = (i as u32 / size[0]) % size[1];
                    let at = Texel {
                        layer: i as u32 / (size[0] * size[1]),
                        x,
                        y,
                    };
                    let same = atrous_texel(maps, p, None, at)[..3] == src.fetch(at)[..3];
                    assert!(same || p.narrow_keep == 0, "step {}: {at:?}", p.step);
                    (kept, moved) = (kept + usize::from(same), moved + usize::from(!same));
                }
                if p.narrow_keep == 0 {
                    assert!(
                        moved > kept,
                        "step {}: {moved} filtered, {kept} not",
                        p.step
                    );
                }
                // The wide term is taken, and changes texels, where the rule says (never in
                // the linear filter).
                if p.wide_max_relative_variance > 0.0 && !linear {
                    let narrow = crate::passes::atrous::AtrousParams {
                        wide_max_relative_variance: 0.0,
                        ..p
                    };
                    for layer in 0..layers {
                        for y in (0..size[1]).step_by(3) {
                            for x in 0..size[0] {
                                let at = Texel { layer, x, y };
                                let a = atrous_texel(maps, p, None, at);
                                let b = atrous_texel(maps, narrow, None, at);
                                wide += usize::from(a != b);
                            }
                        }
                    }
                }
            }
        }
        assert_lanes_used(compared, vector);
        assert!(wide > 100, "the wide term changed {wide} texels");
    }

    /// Every texel of maps of `size` and `layers`, in blocks of [`LANES`] along each row with
    /// `block` (which returns how many texels it computed in lanes), against `texel` bit for
    /// bit: the texels compared and those computed in lanes.
    fn compare_blocks(
        (size, layers): ([u32; 2], u32),
        block: impl Fn(Texel, &mut [f32]) -> usize,
        texel: impl Fn(Texel) -> [f32; 4],
    ) -> (usize, usize) {
        let (mut compared, mut vector) = (0, 0);
        for layer in 0..layers {
            for y in 0..size[1] {
                for x0 in (0..size[0]).step_by(LANES) {
                    let n = (size[0] - x0).min(LANES as u32);
                    let mut out = vec![0.0f32; 4 * n as usize];
                    vector += block(Texel { layer, x: x0, y }, &mut out);
                    for (x, got) in (x0..).zip(out.chunks_exact(4)) {
                        let at = Texel { layer, x, y };
                        assert_eq!(
                            got.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                            texel(at).map(f32::to_bits),
                            "{at:?}"
                        );
                        compared += 1;
                    }
                }
            }
        }
        (compared, vector)
    }

    /// Enough texels compared, and with AVX2 enough of them in lanes.
    fn assert_lanes_used(compared: usize, vector: usize) {
        println!("{compared} texels compared, {vector} in vector lanes");
        assert!(compared > 100_000);
        if super::tests::lanes_available() {
            assert!(
                vector > compared / 10,
                "{vector} of {compared} in vector lanes"
            );
        }
    }
}
