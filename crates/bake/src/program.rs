//! The pass contract: every shader program's signature as data.
//!
//! A computed pass of the [`BakeGraph`](crate::graph::BakeGraph) runs one [`Program`]. What a
//! program needs is declared here, once, and every backend reads it instead of knowing pass
//! kinds:
//!
//! - [`Signature::reads`]: the graph textures it samples, by slot name, in
//!   [`PassDesc::reads`](crate::graph::PassDesc::reads) order. A shader sees slot `s` as
//!   `u_s` (GLSL) or `lux_s` (WGSL, binding = slot index); the declarations are generated
//!   ([`crate::shader`]).
//! - [`Signature::scene`]: the static scene resources it needs ([`SceneNeeds`]).
//! - [`Signature::params`]: its uniform parameter block, one `#[repr(C)]` struct per program
//!   ([`DirectParams`], [`BlurParams`], [`GatherParams`], [`CombineParams`],
//!   [`VarianceParams`], [`AtrousParams`]; none for copy and albedo multiply) whose fields —
//!   names, scalar types and byte offsets — are [`ParamBlock::FIELDS`].
//!   The GLSL uniforms and the WGSL struct are generated from those fields, so a shader and the
//!   Rust side cannot disagree on a name, a type or an offset.
//! - [`Signature::libraries`]: the shared shader library files it includes.
//!
//! Every dispatch also gets a [`TileParams`] block: the rows of one layer it covers. The
//! [`TilePlan`] splitting a pass into such tiles lives here too, so that every backend reports
//! progress on the same tiles.
//!
//! # Adding a pass
//! See [`crate::passes`]: a folder and a registry line. Shader code that several passes share
//! is a [`Library`] (`shaders/lib/`).
//!
//! This module is the public path of the contract: it re-exports the vocabulary
//! ([`crate::contract`]) and the registry's types ([`crate::passes`]), and holds what the
//! graph builder and the backends share about passes: the blur and à-trous constants, the
//! denoiser's steps, the reduced-resolution grid ([`coarse`]) and the tile plan.

pub use crate::contract::{
    B3, BLUR_NORMAL_COS, Field, Library, MAX_BLUR_RADIUS, ParamBlock, ParamScalar, Scalar,
    SceneNeeds, Signature, TileParams, coarse,
};
pub use crate::passes::{
    AtrousParams, BlurParams, CombineParams, ConnectParams, DirectParams, GatherParams, Params,
    Program, RefineParams, UpsampleParams, VarianceParams,
};

impl Program {
    /// Whether the program casts rays (and so depends on the BVH traversal).
    pub fn traces_rays(self) -> bool {
        self.signature().scene.bvh
    }

    /// Whether `params` is this program's parameter block.
    pub fn takes(self, params: &Params) -> bool {
        params.fields() == self.signature().params
    }
}

/// Taps on each side of a Gaussian (the scene crate's rule: chart padding follows it).
pub use luxbake_scene::blur_radius;

/// The parameter block of a blur along `step` with standard deviation `sigma` texels.
pub fn blur_params(step: [i32; 2], sigma: f32) -> BlurParams {
    BlurParams {
        step_x: step[0],
        step_y: step[1],
        radius: blur_radius(sigma),
        inv: -0.5 / (sigma * sigma),
    }
}

/// Default [`AtrousConfig::chart_tolerance`]: a tap on the centre's chart lies at most 1.5 texel
/// sizes away per texel of offset (and at least 1/1.5 per texel beyond the first two). On the
/// built-in scenes' G-buffers, same-object taps facing the same way lie within 1.19·|o|
/// texel sizes (the sphere's cube-face charts) and, on the one-chart floor, beyond
/// 1.05·(‖o‖∞ − 2).
pub const ATROUS_CHART_TOLERANCE: f32 = 1.5;
/// Default [`AtrousConfig::normal_log2`]: exponent 128, SVGF's σₙ (weight ½ at 6°, 0.14 at 10°,
/// 0.01 at 15°).
pub const ATROUS_NORMAL_LOG2: u32 = 7;
/// Default [`AtrousConfig::sigma_luminance`]: a luminance step of 4σ (σ the noise's standard
/// deviation at that iteration) gets weight `e⁻¹`.
pub const ATROUS_SIGMA_LUMINANCE: f32 = 4.0;
/// Default [`AtrousConfig::wide_max_relative_variance`]: a relative standard deviation of
/// the noise under 10 %.
pub const ATROUS_WIDE_MAX_RELATIVE_VARIANCE: f32 = 0.01;
/// How far an iteration's taps may reach, as a fraction of the scene's size
/// ([`AtrousConfig::scene_size`]), for it to take the wide luminance term inside a wide chart
/// with little noise: `2·step` texels each way of the largest texel size (see
/// [`atrous_steps`], "Wide charts with little noise"). 1/32: 15.6 cm in a room 5 m long.
pub const ATROUS_WIDE_MAX_REACH: f32 = 1.0 / 32.0;
/// Default [`AtrousConfig::early_iterations`].
pub const ATROUS_EARLY_ITERATIONS: u32 = 2;
/// Default [`AtrousConfig::early_sigma_luminance`] at [`ATROUS_EARLY_RAYS`] first-bounce rays:
/// a luminance step of 64σ gets weight `e⁻¹` in the first iterations, where the noise is
/// still skewed (see [`atrous_steps`] and [`early_sigma_luminance_for`]).
pub const ATROUS_EARLY_SIGMA_LUMINANCE: f32 = 64.0;
/// The first-bounce rays per texel at which [`ATROUS_EARLY_SIGMA_LUMINANCE`] was measured
/// (the `default` preset's).
pub const ATROUS_EARLY_RAYS: u32 = 4;
/// Fewest texel pairs along one direction that give a variance estimate.
pub const ATROUS_MIN_PAIRS: u32 = 4;
/// Most à-trous iterations: step `2^9 = 512` texels already spans the largest WebGL2 layer
/// (2048) with its ±2 taps.
pub const MAX_ATROUS_ITERATIONS: u32 = 10;

/// The edge-stopping à-trous denoiser of the indirect illuminance: what [`atrous_steps`] turns
/// into passes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AtrousConfig {
    /// À-trous iterations (steps 1, 2, 4, …), at most [`MAX_ATROUS_ITERATIONS`].
    pub iterations: u32,
    /// World size of one texel, metres, `[smallest, largest]` over the receivers:
    /// `1 / (texels_per_metre · texel_scale)` for the largest and the smallest `texel_scale`
    /// (both `1 / texels_per_metre` at a uniform density). The chart test allows what the
    /// coarsest receiver needs as the farthest and what the densest needs as the nearest
    /// distance per texel of offset, so it never rejects a tap of a receiver's own chart for
    /// its density; a mixed-density scene's test is looser by the ratio.
    pub texel_size: [f32; 2],
    /// How much farther (and nearer) than `|offset| · texel_size` a tap on the same chart may
    /// lie (UV stretch, rounding of small maps), ≥ 1.
    pub chart_tolerance: f32,
    /// Normal weight exponent, as a power of two.
    pub normal_log2: u32,
    /// Width of the luminance edge-stopping term, in standard deviations of the noise.
    pub sigma_luminance: f32,
    /// The first iterations use [`AtrousConfig::early_sigma_luminance`] instead (see
    /// [`atrous_steps`]).
    pub early_iterations: u32,
    /// Width of the luminance term of the first [`AtrousConfig::early_iterations`].
    pub early_sigma_luminance: f32,
    /// [`AtrousConfig::early_sigma_luminance`] at a centre in a narrow gap
    /// ([`crate::validity::NARROW_GAP`]), whose first bounce has more rays
    /// ([`crate::scene::Settings::narrow_rays`]; [`AtrousConfig::with_narrow_rays`]); 0: the
    /// same as elsewhere.
    pub narrow_early_sigma_luminance: f32,
    /// The later iterations keep the early iterations' wide luminance term at a texel inside a
    /// wide chart (every mirrored pair of its taps on its surface) whose estimated noise
    /// variance is under this fraction of its window's squared mean luminance (see
    /// [`atrous_steps`], "Wide charts with little noise"); 0: never.
    pub wide_max_relative_variance: f32,
    /// The largest side of the bounding box of the scene's geometry, metres: an iteration
    /// takes the wide term only where its taps reach at most [`ATROUS_WIDE_MAX_REACH`] of it
    /// (0: never).
    pub scene_size: f32,
    /// A power of two the variance pass multiplies every luminance by, and the à-trous
    /// iterations every luminance difference, before squaring: the lux of a lamp of 10³⁰ cd
    /// would square past f32's 3.4·10³⁸, and an infinite variance turns the luminance term
    /// off. [`luminance_scale_for`] picks it from the lamps: 1 (the unscaled filter) for
    /// every real lamp; being a power of two it changes no bit of the result where nothing
    /// overflows or underflows (`Δl²/σ²` is the same quotient).
    pub luminance_scale: f32,
    /// Iterations of the bias correction's linear filter of the residual (see
    /// [`correction_steps`]); 0: no correction ([`AtrousConfig::new`]'s).
    /// [`AtrousConfig::with_correction`] sets one more than [`AtrousConfig::iterations`].
    pub correction_iterations: u32,
}

impl AtrousConfig {
    /// `iterations` at a uniform density of `1 / texel_size` texels per metre, with the
    /// defaults [`ATROUS_CHART_TOLERANCE`], [`ATROUS_NORMAL_LOG2`] and
    /// [`ATROUS_SIGMA_LUMINANCE`].
    pub fn new(iterations: u32, texel_size: f32) -> AtrousConfig {
        AtrousConfig {
            iterations,
            texel_size: [texel_size; 2],
            chart_tolerance: ATROUS_CHART_TOLERANCE,
            normal_log2: ATROUS_NORMAL_LOG2,
            sigma_luminance: ATROUS_SIGMA_LUMINANCE,
            early_iterations: ATROUS_EARLY_ITERATIONS,
            early_sigma_luminance: ATROUS_EARLY_SIGMA_LUMINANCE,
            narrow_early_sigma_luminance: 0.0,
            wide_max_relative_variance: ATROUS_WIDE_MAX_RELATIVE_VARIANCE,
            scene_size: 0.0,
            luminance_scale: 1.0,
            correction_iterations: 0,
        }
    }

    /// Farthest a tap on the centre's chart lies per texel of offset: largest texel size ×
    /// chart tolerance, metres (0 when not finite and ≥ 0: then only the centre is a tap).
    pub fn reach(&self) -> f32 {
        finite_or_zero(self.texel_size[1] * self.chart_tolerance)
    }

    /// The filter for a first bounce of `rays` rays per texel: [`AtrousConfig::new`] with
    /// [`AtrousConfig::early_sigma_luminance`] from [`early_sigma_luminance_for`].
    pub fn for_rays(iterations: u32, texel_size: f32, rays: u32) -> AtrousConfig {
        AtrousConfig {
            early_sigma_luminance: early_sigma_luminance_for(rays),
            ..AtrousConfig::new(iterations, texel_size)
        }
    }

    /// The config with the bias correction ([`correction_steps`]) on — one iteration more
    /// than the filter's, none without iterations — or off.
    pub fn with_correction(self, on: bool) -> AtrousConfig {
        AtrousConfig {
            correction_iterations: if on && self.iterations > 0 {
                self.iterations + 1
            } else {
                0
            },
            ..self
        }
    }

    /// The config for a first bounce of `rays` rays per texel in narrow gaps (those of the
    /// estimate that stands for it there): their early luminance term from
    /// [`early_sigma_luminance_for`] (see [`atrous_steps`], "Narrow gaps").
    pub fn with_narrow_rays(self, rays: u32) -> AtrousConfig {
        AtrousConfig {
            narrow_early_sigma_luminance: early_sigma_luminance_for(rays),
            ..self
        }
    }

    /// [`AtrousConfig::luminance_scale`] when it is a usable scale (finite, > 0), else 1.
    pub fn luminance_scale(&self) -> f32 {
        let s = self.luminance_scale;
        if s.is_finite() && s > 0.0 { s } else { 1.0 }
    }

    /// Nearest a tap on the centre's chart lies per texel of offset beyond the first two:
    /// smallest texel size / chart tolerance, metres (0 when not finite and ≥ 0: no lower
    /// bound).
    pub fn reach_min(&self) -> f32 {
        finite_or_zero(self.texel_size[0] / self.chart_tolerance)
    }
}

/// [`AtrousConfig::luminance_scale`] for lamps whose luminance-weighted peak intensities sum
/// to `peak_cd` (candela; the illuminance they give at 1 m, in lux): 1 up to
/// [`UNSCALED_PEAK_CD`], so every real lamp is filtered in plain lux (bit for bit as without
/// a scale, on GPUs that flush subnormals too), else the power of two that brings `peak_cd`
/// down to at most that (within `2⁻⁹⁶`): a receiver a millimetre from the lamp then gets
/// 10¹⁸ lux at most, whose square f32 still holds. 1 when `peak_cd` is not finite and
/// positive.
pub fn luminance_scale_for(peak_cd: f64) -> f32 {
    if !(peak_cd.is_finite() && peak_cd > UNSCALED_PEAK_CD) {
        return 1.0;
    }
    let e = (peak_cd / UNSCALED_PEAK_CD).log2().ceil().min(96.0) as i32;
    2f32.powi(-e)
}

/// The brightest lamps (peak candela) whose maps the denoiser filters unscaled: 10¹², a
/// million times the brightest searchlight, whose 10¹⁸ lux a millimetre away square to
/// 10³⁶ < f32's 3.4·10³⁸.
pub const UNSCALED_PEAK_CD: f64 = 1e12;

fn finite_or_zero(v: f32) -> f32 {
    if v.is_finite() && v >= 0.0 { v } else { 0.0 }
}

/// The white-noise variance factor `ρᵢ` after `i` à-trous iterations: `(Σₖ cᵢ[k]²)²`, `cᵢ` the
/// one-axis equivalent kernel of iterations `0 .. i` (the B3 kernel dilated by 1, 2, …,
/// `2^(i−1)`, convolved). Independent noise of variance σ² has variance `ρᵢ·σ²` after them
/// (without edge stopping): 1, 0.0748, 0.0189, …
pub fn b3_noise_factor(i: u32) -> f64 {
    let mut c = vec![1.0f64];
    for j in 0..i.min(MAX_ATROUS_ITERATIONS) {
        let step = 1usize << j;
        let mut next = vec![0.0f64; c.len() + 4 * step];
        for (k, &ck) in c.iter().enumerate() {
            for (t, &b) in B3.iter().enumerate() {
                next[k + t * step] += ck * f64::from(b);
            }
        }
        c = next;
    }
    let s: f64 = c.iter().map(|v| v * v).sum();
    s * s
}

/// The width of the first iterations' luminance term, in σ, for a first bounce of `rays`
/// rays per texel: [`ATROUS_EARLY_SIGMA_LUMINANCE`] at [`ATROUS_EARLY_RAYS`], scaled by
/// `√(ATROUS_EARLY_RAYS / rays)`, never under [`ATROUS_SIGMA_LUMINANCE`] (so from 1 024 rays
/// on every iteration uses σ_l). The wide term exists for the skew of the noise of few rays
/// (see [`atrous_steps`]), and the skewness of a mean of `n` samples falls as `1/√n`; kept
/// wide at every ray count it blurs the signal itself, a bias that more rays do not remove
/// (issue 29: −0.5 % over the whole box-room floor at 4 096 rays, against −0.07 % with σ_l).
pub fn early_sigma_luminance_for(rays: u32) -> f32 {
    let scale = (f64::from(ATROUS_EARLY_RAYS) / f64::from(rays.max(1))).sqrt();
    (f64::from(ATROUS_EARLY_SIGMA_LUMINANCE) * scale).clamp(
        f64::from(ATROUS_SIGMA_LUMINANCE),
        f64::from(ATROUS_EARLY_SIGMA_LUMINANCE),
    ) as f32
}

/// The passes of the à-trous denoiser, in order, for the graph builder to chain:
///
/// 1. `(Program::Variance, Params::Variance(_))`: reads `[noisy, position, normal, direct]`, writes
///    the variance map `var`;
/// 2. for `i` in `0 .. iterations`: `(Program::Atrous, Params::Atrous(_))` with step `2^i`,
///    reading `[previous, var, position, normal]` (`previous` = the noisy map for `i = 0`, then
///    the last iteration's output: ping-pong between two textures) and writing the next.
///
/// The last output is the denoised map. `iterations` above [`MAX_ATROUS_ITERATIONS`] are
/// clamped; with 0 iterations only the variance pass is listed.
///
/// # The filter
/// Dammertz et al. 2010 / SVGF (Schied et al. 2017) without temporal history. Iteration `i`
/// computes, for a valid centre texel `p` with value `c` and taps `q = p + 2^i·(a, b)`,
/// `a, b ∈ −2..=2`:
///
/// `out = c + Σ w_q (v_q − c) / Σ w_q`, `w_q = B3[a]·B3[b] · max(0, n̂_p·n̂_q)^(2^normal_log2) ·
/// exp(−Δl² / (σ_l²·ρᵢ·σ²_p))`
///
/// over taps on the centre's surface only, with `Δl` the luminance of `v_q − c` and `σ²_p` the
/// variance estimate at `p`. Written relative to `c`, a constant field is returned bit for
/// bit.
///
/// # Mirrored pairs
/// The taps count in pairs `q = p + o`, `q' = p − o`: a pair is used only when both of its
/// taps are on the centre's surface (the centre is its own pair). Inside a chart that changes
/// nothing; at a chart's edge, a contact or a hole, where taps on one side are missing, it
/// keeps the kernel point-symmetric, so that a signal that is linear across the kernel is
/// returned unchanged (`Σ w_q (v_q − c)` cancels pair by pair: the pair's spline, normal and
/// luminance weights are equal when `v_{q'} − c = −(v_q − c)`). A one-sided kernel averages
/// the texels on the inner side only: on the box room's floor, whose indirect light falls by
/// a fifth over the last 6 texels before a wall, the row along the wall read +1.3 % at 4 096
/// rays with one-sided kernels and −0.1 % in pairs (issue 29, `crates/bake/tests/denoiser.rs`).
/// What is left at an edge is the signal's curvature, which shrinks with the luminance term's
/// width, i.e. with the noise.
///
/// A tap is on the centre's surface when it is valid, of the same object and on the same
/// chart. Charts are not labelled in the G-buffer, but every chart is laid out at the
/// receiver's uniform texel density, so a tap `o` texels away on the centre's chart lies
/// `≈ |o|·h` metres away in the world (h the texel size; a chord on a curved chart is
/// shorter, but only by a few per cent while the normals still pass the normal weight). A tap
/// beyond `reach·|o|` ([`AtrousConfig::reach`]) or nearer than `reach_min·(‖o‖∞ − 2)`
/// ([`AtrousConfig::reach_min`]; the 2 texels of slack cover the chart's edge texels, which
/// are sampled at the chart border up to ½√2 texel from their centre) lies on another chart
/// — close in UV, elsewhere in the world — and is skipped. Taps on another chart that happen
/// to lie in that shell at that distance still pass (the test is geometric); when they also
/// face the same way (normal weight) they are most likely the same surface continued.
///
/// # The first iterations
/// A gather of a few rays has skewed noise: most texels a little under the mean, a few far
/// over it (a ray that found a bright spot). A luminance term at `σ_l` = 4 treats those few
/// as edges and keeps their excess out of their neighbours while their own value is pulled
/// down by the neighbours: energy is lost, the filter is biased low (measured on the box room
/// of `bench grain` at `default`: −4.2 % on average, against −0.3 % unfiltered). The first
/// [`AtrousConfig::early_iterations`] therefore use a much wider luminance term,
/// [`ATROUS_EARLY_SIGMA_LUMINANCE`] (64σ at the `default` preset's 4 rays): the noise passes
/// as if the filter were linear (−0.4 … −1.4 % per wall, −1.3 % linear), while a step of the
/// signal far above the noise (a contact shadow in low noise: 80σ) still stops it. The later
/// iterations, over less and less skewed noise, keep `σ_l`. The skew fades as the rays grow
/// (as `1/√N`), and so does the wide term ([`early_sigma_luminance_for`]): a linear filter
/// of a curved signal is biased by the curvature times the kernel's spread whatever the
/// noise, so a term kept wide at every ray count would keep that bias (−0.5 % over the box
/// room's floor at 4 096 rays) where the noise has long fallen below it.
///
/// # Wide charts with little noise
/// From the first iteration with `σ_l` on (the third at the default), a texel that lies inside
/// a wide chart — every mirrored pair of its taps on its surface, i.e. at least `2·step`
/// texels from any edge or crease each way — and whose noise is low — the variance estimate
/// under [`AtrousConfig::wide_max_relative_variance`] (1 %, a relative standard deviation of
/// 10 %) times its window's squared mean luminance — keeps the early iterations' wide term
/// ([`AtrousParams::wide_variance_scale`], `σ_early² · ρᵢ`). There the noise that is left is
/// not the first gather's white noise that the variance estimate measures but the later
/// bounces' (gathered on a grid every few texels and upsampled, so their noise comes in
/// blotches a few texels wide whose neighbouring differences are small): a luminance term
/// scaled to the white noise takes those blotches for light and keeps them. The pass takes
/// both sums and keeps the wide one only where every pair counted. Measured with
/// `bench refcheck` (eight seeds, CPU default, hq references; mean |rel| %, before → with the
/// wide term): walls 0.44 → 0.32 (`chairs_01`), 0.64 → 0.54 (`chairs_10`), 0.48 → 0.36
/// (`chairs_03`), 0.57 → 0.44 (`chairs_05`), 0.60 → 0.50 (`sofa_01`); ceilings 0.53–0.64 →
/// 0.36–0.48; floors within ±0.02; the furniture unchanged (its narrow parts fail the pairs,
/// the seats' dark undersides the noise bound: with the pairs alone they read −1.7 … −2.0 %
/// instead of −1.0 … −1.2 %, and without the pairs the aprons −1.2 … −1.6 % instead of
/// −1.0 … −1.2 %). As the rays grow the early term narrows to `σ_l` and so does this one.
/// Only over a short span: an iteration whose taps reach farther than
/// [`ATROUS_WIDE_MAX_REACH`] of the scene's size ([`AtrousConfig::scene_size`]; in a room 5 m
/// long 15.6 cm: step 4 at 64 texels/m reaches 12.5 cm, at 48 texels/m 17 cm) keeps `σ_l`
/// everywhere, since across a longer span the light's own curvature biases a near-linear
/// average — CIE 171:2006 test 5.8's 4 m cube at 6 texels/m (step 4 reaches 1.33 m) read
/// −2.05 % instead of −1.83 % at ρ = 0.5 without the bound. A fraction of the scene, not a
/// length: the same room at a thousandth or a thousand times the size, at the same texels per
/// room, is filtered alike.
///
/// # Narrow gaps
/// A texel in a narrow gap ([`crate::validity::NARROW_GAP`]) gathers its first bounce with more
/// rays ([`crate::scene::Settings::narrow_rays`], the refinement's "Narrow gaps"), so its
/// noise is less skewed, and its early iterations take the early term of its own ray count,
/// [`early_sigma_luminance_for`] of its first bounce's rays there (`narrow_rays`, all the
/// refinement's where its estimate stands alone, the refinement's "The direct light at a
/// gap's mouth"; else `rays + narrow_rays`)
/// ([`AtrousConfig::narrow_early_sigma_luminance`], [`AtrousParams::narrow_variance_scale`]):
/// the rule above applied per texel. In a gap the light falls a hundredfold over a few
/// texels, and the early term, nearly linear at 8 rays, spreads the rim's light into the
/// gap's middle. Measured (`bench refcheck`, CPU, `default`, four seeds, the real rooms'
/// points in the gaps behind a bookcase and a sideboard; mean |rel| per seed): the narrower
/// term alone, at 8 rays, 18.7 → 16.6 % (lounge) and 9.2 → 18.6 % (dining: the skew of 8
/// rays' noise, read low); 56 more first-bounce rays alone 15.3 % and 9.8 % (as 24 more);
/// with their early term 13.1 % and 8.9 % (24 more), 10.3 % and 7.0 % (56 more).
///
/// An iteration whose taps reach farther than the gap,
/// [`NARROW_REACH_TEXELS`](crate::validity::NARROW_REACH_TEXELS) (`2·step > 6`: step 4 on),
/// leaves a centre in a gap as it is ([`AtrousParams::narrow_keep`], in the bias correction's
/// filter too). Near a gap's open side its light changes tenfold within a few texels, and the
/// wide taps carry the side's light into the gap: along the lounge's slot (`default`, sixteen
/// seeds, against Radiance points traced across it) the texels 2–10 texels in from its side
/// read +15 … +34 % with every iteration. Measured (`bench refcheck`, CPU, four seeds; the
/// furniture's mean |rel| %, then the gap's points'), every iteration → this rule: lounge
/// 2.19 → 1.78 (10.6 → 8.2), with 64 gap rays 1.05 → 0.96 (4.06 → 3.53); dining 0.90 →
/// 0.88 and 0.79 → 0.71; office 0.65 → 0.63 and 0.55 → 0.56. Keeping them from step 2 on
/// (reach 4) instead: lounge 2.60 and 1.13; unfiltered: 4.39 and 1.80, the gap's noise left.
///
/// # Consistency
/// With the variance estimate falling with the noise, `σ_l` fixed and the early term
/// narrowing to it, every luminance term narrows as the rays grow and the filter lets
/// through less and less of the signal's own variation: the denoised map converges to the raw
/// estimate. Measured against an independent quadrature of the box room's first bounce
/// (`crates/bake/tests/denoiser.rs`), floor at 16 texels/m: relative RMSE 0.45× the raw
/// estimate's at 1 024 rays and 0.70× at 4 096; bias within 3 texels of the walls −0.37 % and
/// −0.07 %, elsewhere −0.18 % and −0.07 % (before: 1.8× the raw error at 4 096 rays, +3.9 %
/// at the walls).
///
/// # The variance estimate
/// The gather pass averages N ray samples per texel, so the indirect map is `s + ε`: a smooth
/// signal plus noise of variance σ² per texel, independent from texel to texel (with the
/// Sobol sampler's blocks, see the end of this section, not quite). Then the difference of two neighbouring texels along a direction in
/// which `s` is constant is pure noise with variance 2σ², so `½·mean((l_{q+d} − l_q)²)` over
/// pairs along `d` estimates σ². Along other directions the signal's own gradient (a contact
/// shadow, a steep fall-off) adds to it. [`Program::Variance`] therefore takes, in a 5×5
/// window of the centre's surface, that estimate for each of the directions (1, 0), (0, 1),
/// (1, 1), (1, −1) with at least [`ATROUS_MIN_PAIRS`] pairs, and keeps the smallest: the
/// direction most nearly along the signal's iso-lines. A straight edge in the signal does not
/// inflate the estimate (the direction along it sees no step), so the luminance term keeps
/// the edge, while a noisy flat region gets σ² (somewhat under, being the smallest of four
/// estimates: 0.72 σ² measured on white noise, which narrows the luminance term by 15 %).
/// A lone outlier (one lucky ray) or sparse light in a dark corner raises every direction, so
/// it is smoothed; a median-based estimate would call it signal and keep it. A texel with no
/// such direction gets 0: no luminance smoothing. After `i` iterations the noise is reduced
/// by [`b3_noise_factor`]`(i)`, so iteration `i` scales the estimate by it; the factor assumes
/// that every tap counts, so near edges, where fewer do and more noise is left, the filter is
/// stricter, never looser.
///
/// With the Sobol sampler the texels of a 2 × 2 block draw their directions from one
/// stratified sequence ([`rng::Stream`](crate::rng::Stream)), so their noise is negatively
/// correlated: the difference of two texels of one block has more variance than 2σ², by at
/// most a third (with equal covariances `c` between the four, `4σ² + 12c ≥ 0`, so
/// `2σ² − 2c ≤ 8σ²/3`), and about half of a window's neighbouring pairs lie in one block. The
/// estimate is then at most about a sixth over σ² (the luminance term at most 8 % wider),
/// where the blocks' sums are nearly free of noise, i.e. where the denoiser averages them best.
pub fn atrous_steps(config: &AtrousConfig) -> Vec<(Program, Params)> {
    let early = |i: u32| i < config.early_iterations;
    let sigma2 = |i: u32| {
        let s = if early(i) {
            config.early_sigma_luminance
        } else {
            config.sigma_luminance
        };
        f64::from(s) * f64::from(s)
    };
    let wide2 = f64::from(config.early_sigma_luminance).powi(2);
    let narrow_early = match config.narrow_early_sigma_luminance {
        s if s > 0.0 => s,
        _ => config.early_sigma_luminance,
    };
    let narrow_sigma2 = |i: u32| {
        let s = if early(i) {
            narrow_early
        } else {
            config.sigma_luminance
        };
        f64::from(s) * f64::from(s)
    };
    let mut steps = vec![(
        Program::Variance,
        Params::Variance(VarianceParams {
            reach: config.reach(),
            min_pairs: ATROUS_MIN_PAIRS,
            luminance_scale: config.luminance_scale(),
            ..VarianceParams::default()
        }),
    )];
    steps.extend((0..config.iterations.min(MAX_ATROUS_ITERATIONS)).map(|i| {
        // The iteration's taps reach `2·step` texels each way (a broken size: never short).
        let short =
            (2 << i) as f32 * config.texel_size[1] <= ATROUS_WIDE_MAX_REACH * config.scene_size;
        (
            Program::Atrous,
            Params::Atrous(AtrousParams {
                variance_scale: (sigma2(i) * b3_noise_factor(i)) as f32,
                narrow_variance_scale: (narrow_sigma2(i) * b3_noise_factor(i)) as f32,
                wide_variance_scale: (wide2 * b3_noise_factor(i)) as f32,
                wide_max_relative_variance: if early(i) || !short {
                    0.0
                } else {
                    config.wide_max_relative_variance
                },
                ..iteration(config, i)
            }),
        )
    }));
    steps
}

/// The bias correction of the denoiser ([`atrous_steps`]): a linear filter `B` of the
/// luminances `L(x)` and `L(y)` (`x` the noisy map, `y` the à-trous output), whose ratio
/// scales `y`: the denoised map is `y · B(L(x)) / B(L(y))` (`y` where `B(L(y))` is 0).
/// [`AtrousConfig::correction_iterations`] iterations of
/// [`Program::Atrous`] with [`AtrousParams::linear`]: steps 1, 2, 4, …, the B3 spline, the
/// normal weight and the chart test in mirrored pairs as in [`atrous_steps`], no luminance
/// term. Empty when the config has no iterations or no correction
/// ([`AtrousConfig::with_correction`]; the bake's [`crate::scene::Settings::denoise_correction`]).
///
/// # Why
/// A symmetric filter of a curved signal is biased by the curvature times the kernel's
/// second moment: for a kernel `K` of unit weight, `E[Kx](p) − s(p) ≈ ½·m₂(K)·∇²s(p)`. The
/// luminance term narrows the kernel only where the signal's steps stand out of the noise;
/// below the noise the à-trous filter averages the light's curvature away. The chairs'
/// furniture reads low at the reference points at the `default` preset (sixteen seeds,
/// `bench refcheck`: −0.41 … −0.66 %; more rays narrow the luminance term and remove it:
/// `final` reads −0.03 %), and a wider luminance term makes it worse (σ_l 16 in the last
/// iteration: −1.0 … −1.2 %), so it is the curvature, not the luminance term's skew.
///
/// # The rule
/// With `A` the à-trous filter and `B` any filter of unit weight that is symmetric, the
/// corrected filter `A + B − B·A` (i.e. `y + B(x − y)`) has unit weight and, since the second
/// moments of a convolution add, second moment `m₂(A) + m₂(B) − (m₂(A) + m₂(B)) = 0`: the
/// curvature's bias cancels whatever `B` is (Tukey's "twicing" is `B = A`). The bake applies
/// it as a ratio, `y · B(x) / B(y)` (of luminances, `L` below): with `y ≈ s + ½m₂(A)∇²s`,
/// `B(x) ≈ s + ½m₂(B)∇²s` and `B(y) ≈ s + ½(m₂(A) + m₂(B))∇²s`, the ratio is
/// `1 − ½m₂(A)∇²s / s` to first order and the product `s`, as the sum's: the same
/// cancellation where the light is smooth (the chairs rooms' figures below agree to the
/// second decimal). Where it is not — light entering a gap 2.5 cm wide behind a bookcase, a
/// hundredfold over a few texels — the sum's `B(x − y)` carried the bright texels' residuals
/// onto the dark ones and pushed them below 0, where the clamp left 0: the gap's points under
/// 1 lx read −40 … −95 % at `default`. The ratio cannot go below 0 and there stays near 1
/// (both of `B`'s sums are the same bright texels'): those points read −21 … +6 %
/// (`docs/performance.md`, "Narrow gaps"). Of the colour, the ratio of luminances scales the
/// three channels alike: one texture of two channels for `B`, as the sum's residual took.
/// What `B` decides
/// is the noise that comes back with the residual: the residual is mostly the noise the
/// à-trous filter removed, and `B` must average it again. A `B` as wide as `A` (twicing)
/// gave back much of the noise (`chairs_01`'s furniture 1.26 → 1.38 % mean |rel|); one
/// iteration wider than `A` keeps the noise where it was while the furniture's bias falls by
/// 40 % — on the chairs' aprons, legs and backs from −0.8 … −0.9 % to −0.3 %, while the
/// seats' undersides, dark and lit from below, keep most of theirs (−1.2 … −1.3 % to
/// −1.0 … −1.2 %) — (the figures are in `docs/performance.md`, "The denoiser's bias
/// corrected"). Skipping `B`'s fine steps
/// (steps 4 and 8 only) aliases the residual's noise (7.6 % on the furniture). `B` needs no luminance term: with σ_l 4 in its iterations the
/// result was the same within the seeds' spread, and without it `B` is linear, so the
/// residual's noise averages as white noise does and the iterations are cheaper (no
/// exponential per tap).
///
/// [`Program::Combine`] with [`CombineParams::PAIR`] writes `L(x)` and `L(y)` side by side
/// (the pass labelled `residual`), `B`'s iterations filter both, and
/// [`CombineParams::RATIO`] scales `y` by their ratio (the pass labelled `corrected`); every
/// value is non-negative. At a chart's edge and at a contact the mirrored pairs keep `B`
/// point-symmetric, so a linear signal passes unchanged, as in [`atrous_steps`]. As the rays
/// grow, `y` tends to `x`, the ratio to 1, and the corrected filter stays consistent.
pub fn correction_steps(config: &AtrousConfig) -> Vec<(Program, Params)> {
    if config.iterations == 0 {
        return Vec::new();
    }
    (0..config.correction_iterations.min(MAX_ATROUS_ITERATIONS))
        .map(|i| {
            (
                Program::Atrous,
                Params::Atrous(AtrousParams {
                    linear: 1,
                    ..iteration(config, i)
                }),
            )
        })
        .collect()
}

/// How far a narrow gap reaches, texels: [`crate::validity::NARROW_REACH_TEXELS`] (test
/// `the_narrow_reach_is_the_gaps`; a constant of its own, as `validity` builds on the backend
/// contract this module is part of). An iteration whose taps reach farther leaves a centre in a
/// gap as it is ([`AtrousParams::narrow_keep`], [`atrous_steps`], "Narrow gaps").
pub const ATROUS_NARROW_REACH: f32 = 6.0;

/// What iteration `i` of [`atrous_steps`] and of [`correction_steps`] share: its step
/// `2^i`, its chart test, its normal weight, the luminance scale (no luminance term) and
/// whether a centre in a narrow gap keeps its value.
fn iteration(config: &AtrousConfig, i: u32) -> AtrousParams {
    AtrousParams {
        step: 1 << i,
        // The taps reach `2·step` texels each way.
        narrow_keep: u32::from((2u32 << i) as f32 > ATROUS_NARROW_REACH),
        reach: config.reach(),
        reach_min: config.reach_min(),
        normal_log2: config.normal_log2,
        luminance_scale: config.luminance_scale(),
        ..AtrousParams::default()
    }
}

/// How one pass is split into dispatches: row tiles of about `tile_work` evaluations
/// (texels × [`Params::work_per_texel`]), layer by layer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TilePlan {
    /// Layer size, texels.
    pub size: [u32; 2],
    /// Layers.
    pub layers: u32,
    /// Rows per tile (the last tile of a layer may have fewer).
    pub rows: u32,
}

impl TilePlan {
    /// The plan for a pass over `layers` layers of `size` texels with `work_per_texel`
    /// evaluations per texel, in tiles of about `tile_work` evaluations (at least one row).
    pub fn new(size: [u32; 2], layers: u32, work_per_texel: u64, tile_work: u64) -> TilePlan {
        let per_row = u64::from(size[0]).max(1) * work_per_texel.max(1);
        let rows = (tile_work.max(1) / per_row).clamp(1, u64::from(size[1].max(1)));
        TilePlan {
            size,
            layers,
            rows: u32::try_from(rows).unwrap_or(u32::MAX),
        }
    }

    /// Tiles per layer.
    pub fn tiles_per_layer(&self) -> u32 {
        self.size[1].div_ceil(self.rows.max(1))
    }

    /// Number of tiles.
    pub fn len(&self) -> u64 {
        u64::from(self.tiles_per_layer()) * u64::from(self.layers)
    }

    /// Whether the plan has no tile (an empty texture).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The tiles in order: layer by layer, rows top to bottom.
    pub fn tiles(&self) -> impl Iterator<Item = TileParams> + '_ {
        let per_layer = self.tiles_per_layer();
        (0..self.layers).flat_map(move |layer| {
            (0..per_layer).map(move |t| {
                let y0 = t * self.rows;
                TileParams {
                    x0: 0,
                    y0,
                    width: self.size[0],
                    height: self.rows.min(self.size[1] - y0),
                    layer,
                    layer_w: self.size[0],
                    layer_h: self.size[1],
                    grid: 0,
                }
            })
        })
    }
}

/// What a row of the layout holds, for cutting a gather's tiles by rows
/// ([`crate::program::TilePlan::tiles_by_kind`]), in the order of what its texels may cast.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum RowKind {
    /// No valid texel: a gather there casts no ray ([`crate::backend::Dispatch::idle`]).
    Empty,
    /// Valid texels, none of them narrow ([`crate::backend::Dispatch::narrow`] `false`).
    Plain,
    /// A narrow texel ([`crate::validity::NARROW`]) among them.
    Narrow,
}

/// The fewest rows of one kind ([`RowKind`]) that the driver cuts a gather's tile around
/// ([`TilePlan::tiles_by_kind`], rows from [`crate::validity::row_kinds`]): rows without a valid
/// texel keep no hits ([`crate::backend::Dispatch::idle`]), and a strided gather's rows without
/// a narrow texel keep the orphans' rays' alone ([`crate::kept::Part::Orphans`]), a quarter of a
/// grid texel's at the `default`'s stride 4. Shorter runs share their neighbours' piece, since
/// each cut is another dispatch: in the browser (SwiftShader) cutting `chairs_05` at 24
/// texels/m around every run of rows without a narrow texel (66 pieces instead of 4 tiles) took
/// the swap's gathers from 0.23 to 0.33 GPU s; at 32 rows it becomes 8 pieces
/// (docs/performance.md, "Kept hits: the orphans' rays alone").
pub const ORPHAN_ROWS_MIN: u32 = 32;

impl TilePlan {
    /// [`TilePlan::tiles`], each cut into pieces of rows of one kind (`kinds`: its rows layer
    /// by layer, top to bottom; rows past its end count as [`RowKind::Narrow`]), with that kind.
    /// A run shorter than `min_rows` takes the most demanding kind of itself and the runs
    /// beside it in the tile (so that a tile is cut only around long runs), and runs of one
    /// kind make one piece. The pieces cover the plan's tiles in order, each row once, none
    /// larger than its tile, none of a kind below any of its rows'.
    pub fn tiles_by_kind(&self, kinds: &[RowKind], min_rows: u32) -> Vec<(TileParams, RowKind)> {
        let rows = self.size[1] as usize;
        let mut pieces: Vec<(TileParams, RowKind)> = Vec::new();
        for t in self.tiles() {
            let kind = |y: u32| {
                kinds
                    .get(t.layer as usize * rows + y as usize)
                    .copied()
                    .unwrap_or(RowKind::Narrow)
            };
            // The tile's runs of one kind: (first row, rows, kind).
            let mut runs: Vec<(u32, u32, RowKind)> = Vec::new();
            let (mut y0, end) = (t.y0, t.y0 + t.height);
            while y0 < end {
                let k = kind(y0);
                let y1 = (y0 + 1..end).find(|&y| kind(y) != k).unwrap_or(end);
                runs.push((y0, y1 - y0, k));
                y0 = y1;
            }
            let taken: Vec<RowKind> = (0..runs.len())
                .map(|i| {
                    let (_, n, k) = runs[i];
                    if n >= min_rows {
                        return k;
                    }
                    let before = i.checked_sub(1).map_or(k, |b| runs[b].2);
                    let after = runs.get(i + 1).map_or(k, |r| r.2);
                    k.max(before).max(after)
                })
                .collect();
            let first = pieces.len();
            for (&(y0, n, _), &k) in runs.iter().zip(&taken) {
                let within = pieces.len() > first;
                match pieces.last_mut() {
                    Some((last, lk)) if within && *lk == k => last.height += n,
                    _ => pieces.push((TileParams { y0, height: n, ..t }, k)),
                }
            }
        }
        pieces
    }
}

impl TilePlan {
    /// A gather's pieces ([`TilePlan::tiles_by_kind`] at [`ORPHAN_ROWS_MIN`]): what the driver
    /// dispatches for a gather at `stride` over rows of `kinds`. At stride 1 a narrow row keeps
    /// as many hits as any other, so only the rows without a valid texel are cut around.
    pub fn gather_tiles(&self, kinds: &[RowKind], stride: u32) -> Vec<(TileParams, RowKind)> {
        if stride > 1 {
            return self.tiles_by_kind(kinds, ORPHAN_ROWS_MIN);
        }
        let unstrided: Vec<RowKind> = kinds.iter().map(|&k| k.min(RowKind::Plain)).collect();
        self.tiles_by_kind(&unstrided, ORPHAN_ROWS_MIN)
    }
}

impl Params {
    /// Evaluations at each texel in a narrow gap ([`crate::validity::NARROW_GAP`]) of a pass
    /// that works there alone, every other texel keeping a value it reads (one evaluation):
    /// the refinements in gaps only (a refine pass without refinement by noise, and its
    /// connect pass). `None` for every other pass. Such a pass is split by where its work lies
    /// ([`tiles_by_rows`]).
    pub fn gap_work(&self) -> Option<u64> {
        match self {
            Params::Refine(r) if r.rays == 0 && r.narrow_rays > 0 => Some(u64::from(r.span())),
            Params::Connect(c) if c.is_refinement() && c.picks == 0 => {
                Some(u64::from(c.narrow_picks))
            }
            _ => None,
        }
    }
}

/// The tiles of a pass that works at the texels in narrow gaps alone ([`Params::gap_work`]:
/// `gap` evaluations at each, one at every other texel) over `layers` layers of `size` texels,
/// `row_gaps` its texels in gaps per row (layer by layer, rows top to bottom): row tiles of at
/// most about `tile_work` evaluations (at least one row each), so that rows with little work
/// share a dispatch and rows with much get their own, each dispatch's cost bounded as in
/// [`TilePlan`]. A tile's rows all have a texel in a gap or none has; a tile of rows without
/// one is idle (`true`): no texel there does the pass's work
/// ([`crate::backend::Dispatch::idle`]). Every row of every layer lies in exactly one tile;
/// rows past `row_gaps`' end count `size[0]` evaluations and are not idle.
pub fn tiles_by_rows(
    size: [u32; 2],
    layers: u32,
    row_gaps: &[u64],
    gap: u64,
    tile_work: u64,
) -> Vec<(TileParams, bool)> {
    let mut tiles = Vec::new();
    let tile = |layer: u32, y0: u32, height: u32| TileParams {
        x0: 0,
        y0,
        width: size[0],
        height,
        layer,
        layer_w: size[0],
        layer_h: size[1],
        grid: 0,
    };
    let width = u64::from(size[0]);
    for layer in 0..layers {
        let (mut y0, mut work, mut idle) = (0u32, 0u64, false);
        for y in 0..size[1] {
            let at = layer as usize * size[1] as usize + y as usize;
            let (w, row_idle) = match row_gaps.get(at) {
                Some(&n) => (
                    width.saturating_add(n.saturating_mul(gap.saturating_sub(1))),
                    n == 0,
                ),
                None => (width, false),
            };
            if y > y0 && (row_idle != idle || work.saturating_add(w) > tile_work) {
                tiles.push((tile(layer, y0, y - y0), idle));
                (y0, work) = (y, 0);
            }
            if y == y0 {
                idle = row_idle;
            }
            work = work.saturating_add(w);
        }
        if size[1] > y0 {
            tiles.push((tile(layer, y0, size[1] - y0), idle));
        }
    }
    tiles
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The compact grid of a tile holds exactly the tile's texels on the stride's grid, each
    /// once over the tiles of a layer; a tile without one, and stride 1, has none.
    #[test]
    fn a_tiles_grid_holds_its_grid_texels_once() {
        let (w, h, s) = (37u32, 23u32, 4u32);
        let tile = |y0: u32, height: u32| TileParams {
            x0: 0,
            y0,
            width: w,
            height,
            layer: 1,
            layer_w: w,
            layer_h: h,
            grid: 0,
        };
        for rows in [1u32, 2, 3, 5, 7, 23] {
            let mut seen = std::collections::HashSet::new();
            for y0 in (0..h).step_by(rows as usize) {
                let t = tile(y0, rows.min(h - y0));
                let grid = coarse::grid_tile(t, s);
                let want: Vec<[u32; 2]> = (t.y0..t.y0 + t.height)
                    .flat_map(|y| (0..w).map(move |x| [x, y]))
                    .filter(|&[x, y]| x % s == 0 && y % s == 0)
                    .collect();
                let Some(g) = grid else {
                    assert!(want.is_empty(), "{t:?}");
                    continue;
                };
                assert_eq!((g.layer, g.layer_w, g.layer_h, g.grid), (1, w, h, s));
                let got: Vec<[u32; 2]> = (g.y0..g.y0 + g.height)
                    .flat_map(|j| (g.x0..g.x0 + g.width).map(move |i| [i * s, j * s]))
                    .collect();
                assert_eq!(got, want, "{t:?}");
                assert!(got.iter().all(|&x| seen.insert(x)));
            }
            assert_eq!(seen.len(), 10 * 6);
        }
        assert_eq!(coarse::grid_tile(tile(0, h), 1), None);
        assert_eq!(coarse::grid_tile(tile(1, 3), s), None);
    }

    /// A row's kind from the G-buffer's w, as the gather tests it: a narrow texel makes it
    /// narrow, no texel over 0.5 empty (a NaN is not empty: the gather's `w <= 0.5` fails).
    #[test]
    fn rows_are_empty_plain_or_narrow_by_their_texels_w() {
        let row = |ws: [f32; 3]| {
            ws.iter()
                .flat_map(|&w| [1.0, 2.0, 3.0, w])
                .collect::<Vec<_>>()
        };
        let map: Vec<f32> = [
            row([0.0, 0.0, 0.5]),
            row([0.0, 1.0, 0.0]),
            row([1.0, crate::validity::NARROW, 0.0]),
            row([crate::validity::NARROW_GAP, 0.0, 0.0]),
            row([0.0, f32::NAN, 0.0]),
        ]
        .concat();
        use RowKind::{Empty, Narrow, Plain};
        assert_eq!(
            crate::validity::row_kinds(&map, 3),
            [Empty, Plain, Narrow, Narrow, Plain]
        );
        assert!(crate::validity::row_kinds(&[], 3).is_empty());
    }

    /// A plan's tiles cut around long runs of rows of one kind: pieces within their tiles,
    /// every row once, each piece of one kind and none below its rows' (a short run takes the
    /// most demanding kind beside it), the rows past a short list narrow.
    #[test]
    fn tiles_cut_by_kind_cover_every_row_once_around_long_runs() {
        use RowKind::{Empty, Narrow, Plain};
        let (size, layers) = ([8u32, 100u32], 2u32);
        let plan = TilePlan::new(size, layers, 1, 8 * 40);
        assert_eq!(plan.rows, 40);
        // Layer 0: narrow rows 10, 11, 50 and 51 among plain ones, rows 70.. empty; layer 1:
        // plain rows 0..5, then empty but for a plain row 60.
        let mut kinds = vec![Plain; 200];
        for y in [10, 11, 50, 51] {
            kinds[y] = Narrow;
        }
        kinds[70..100].fill(Empty);
        kinds[105..200].fill(Empty);
        kinds[160] = Plain;
        let spans = |min_rows: u32, kinds: &[RowKind]| -> Vec<(u32, u32, u32, RowKind)> {
            let pieces = plan.tiles_by_kind(kinds, min_rows);
            // Every row of every layer once, in order, each piece inside one of the plan's
            // tiles and of no kind below its rows'.
            let rows: Vec<(u32, u32)> = pieces
                .iter()
                .flat_map(|(t, _)| (t.y0..t.y0 + t.height).map(move |y| (t.layer, y)))
                .collect();
            let want: Vec<(u32, u32)> = (0..layers)
                .flat_map(|l| (0..size[1]).map(move |y| (l, y)))
                .collect();
            assert_eq!(rows, want);
            for (t, k) in &pieces {
                assert!(
                    t.height > 0 && t.y0 / 40 == (t.y0 + t.height - 1) / 40,
                    "{t:?}"
                );
                assert_eq!((t.x0, t.width, t.grid), (0, 8, 0));
                for y in t.y0..t.y0 + t.height {
                    let row = kinds.get((t.layer * 100 + y) as usize).copied();
                    assert!(*k >= row.unwrap_or(Narrow), "{t:?} {k:?}");
                }
            }
            pieces
                .iter()
                .map(|(t, k)| (t.layer, t.y0, t.height, *k))
                .collect()
        };
        // Layer 0: rows 0..10 and 40..50 short beside narrow rows, 70..80 short empty rows
        // beside plain ones. Layer 1: the plain rows 0..5 stand apart from the long empty run
        // after them; row 60 alone is plain between two long empty runs.
        assert_eq!(
            spans(16, &kinds),
            vec![
                (0, 0, 12, Narrow),
                (0, 12, 28, Plain),
                (0, 40, 12, Narrow),
                (0, 52, 28, Plain),
                (0, 80, 20, Empty),
                (1, 0, 5, Plain),
                (1, 5, 35, Empty),
                (1, 40, 20, Empty),
                (1, 60, 1, Plain),
                (1, 61, 19, Empty),
                (1, 80, 20, Empty),
            ]
        );
        assert_eq!(
            spans(1, &kinds)[..3],
            [(0, 0, 10, Plain), (0, 10, 2, Narrow), (0, 12, 28, Plain)]
        );
        // A gather at stride 1 cuts around the empty rows alone; at stride 4 as above.
        assert_eq!(
            plan.gather_tiles(&kinds, 4),
            plan.tiles_by_kind(&kinds, ORPHAN_ROWS_MIN)
        );
        let unstrided: Vec<(u32, u32, u32, RowKind)> = (plan.gather_tiles(&kinds, 1).iter())
            .map(|(t, k)| (t.layer, t.y0, t.height, *k))
            .collect();
        assert_eq!(
            unstrided[..4],
            [
                (0, 0, 40, Plain),
                (0, 40, 40, Plain),
                (0, 80, 20, Empty),
                (1, 0, 5, Plain)
            ]
        );
        // Past the list every row is narrow: the plan's tiles as they are.
        let plain: Vec<(u32, u32, u32, RowKind)> = plan
            .tiles()
            .map(|t| (t.layer, t.y0, t.height, Narrow))
            .collect();
        assert_eq!(spans(16, &[]), plain);
        assert_eq!(spans(1, &[]), plain);
    }

    /// Row-weighted tiles cover every row of every layer once, in order, within the budget
    /// but for a single heavy row; rows without work share one tile, where the uniform plan
    /// of the heaviest row's work would cut many.
    #[test]
    fn tiles_by_rows_cover_every_row_once_and_follow_the_work() {
        let (size, layers, budget, gap) = ([100u32, 50u32], 2u32, 1_000u64, 64u64);
        // Layer 0: 5 texels in a gap on rows 10..13 and 80 on row 30 (heavier than the
        // budget); layer 1: no gap.
        let mut rows = vec![0u64; 100];
        rows[10..13].fill(5);
        rows[30] = 80;
        let tiles = tiles_by_rows(size, layers, &rows, gap, budget);
        let work = |layer: u32, y: u32| 100 + rows[(layer * 50 + y) as usize] * (gap - 1);
        for layer in 0..layers {
            let mut next = 0;
            for (t, idle) in tiles.iter().filter(|(t, _)| t.layer == layer) {
                assert_eq!((t.y0, t.x0, t.width), (next, 0, 100), "{t:?}");
                assert_eq!((t.layer_w, t.layer_h), (100, 50));
                let w: u64 = (t.y0..t.y0 + t.height).map(|y| work(layer, y)).sum();
                assert!(w <= budget || t.height == 1, "{t:?}: {w}");
                // Idle exactly when none of its rows has a texel in a gap, and never mixed.
                let gaps: Vec<bool> = (t.y0..t.y0 + t.height)
                    .map(|y| rows[(layer * 50 + y) as usize] > 0)
                    .collect();
                assert!(gaps.iter().all(|&g| g != *idle), "{t:?} {idle}: {gaps:?}");
                next += t.height;
            }
            assert_eq!(next, 50);
        }
        let at = |layer: u32, y0: u32| {
            tiles
                .iter()
                .find(|(t, _)| t.layer == layer && t.y0 == y0)
                .map(|&(t, idle)| (t.height, idle))
        };
        assert_eq!(at(0, 30), Some((1, false)));
        assert_eq!(at(0, 31), Some((10, true)));
        assert_eq!(at(0, 10).map(|(_, idle)| idle), Some(false));
        // A layer without a gap: five idle tiles of ten rows at the budget, against fifty
        // tiles for the gap's 64 evaluations a texel.
        assert_eq!(tiles.iter().filter(|(t, _)| t.layer == 1).count(), 5);
        assert!(
            tiles
                .iter()
                .filter(|(t, _)| t.layer == 1)
                .all(|&(_, idle)| idle)
        );
        assert_eq!(TilePlan::new(size, 1, 64, budget).len(), 50);
        // Rows past a short list count whole rows and are not idle; no layer, no tile.
        let short = tiles_by_rows(size, 1, &[], gap, budget);
        assert_eq!(short.len(), 5);
        assert!(short.iter().all(|&(_, idle)| !idle));
        assert!(tiles_by_rows(size, 0, &rows, gap, budget).is_empty());
    }

    #[test]
    fn the_narrow_reach_is_the_gaps() {
        assert_eq!(ATROUS_NARROW_REACH, crate::validity::NARROW_REACH_TEXELS);
    }

    #[test]
    fn signatures_are_indexed_by_program_and_labels_are_unique() {
        for p in Program::ALL {
            // The registry pairs each program with its own block and shader files.
            assert!(p.takes(&Params::decode(p, &[])), "{}", p.label());
        }
        let labels: std::collections::HashSet<_> = Program::ALL.iter().map(|p| p.label()).collect();
        assert_eq!(labels.len(), Program::ALL.len());
        assert!(Program::Direct.traces_rays() && Program::Gather.traces_rays());
        assert!(!Program::Blur.traces_rays());
        assert!(!Program::Variance.traces_rays() && !Program::Atrous.traces_rays());
    }

    #[test]
    fn fields_have_repr_c_offsets_and_round_trip() {
        for fields in [
            TileParams::FIELDS,
            DirectParams::FIELDS,
            BlurParams::FIELDS,
            GatherParams::FIELDS,
            CombineParams::FIELDS,
            VarianceParams::FIELDS,
            AtrousParams::FIELDS,
        ] {
            for (i, f) in fields.iter().enumerate() {
                assert_eq!(f.offset, 4 * i, "{}", f.name);
            }
        }
        assert_eq!(std::mem::size_of::<TileParams>(), 32);
        let b = blur_params([0, 1], 2.0);
        assert_eq!(b.radius, 6);
        assert_eq!(b.inv, -0.125);
        assert_eq!(BlurParams::from_words(&b.words()), b);
        assert_eq!(b.words()[1], 1);
        assert_eq!(BlurParams::FIELDS[3].ty, Scalar::F32);
        assert!(Program::Blur.takes(&Params::Blur(b)));
        assert!(!Program::Gather.takes(&Params::Blur(b)));
        assert!(Program::Copy.takes(&Params::None));
    }

    #[test]
    fn the_luminance_scale_is_one_for_real_lamps_and_a_power_of_two_beyond() {
        for real in [1e-3, 1.0, 1000.0, 1e9, UNSCALED_PEAK_CD] {
            assert_eq!(luminance_scale_for(real), 1.0, "{real}");
        }
        // 10³⁰ cd: 10¹⁸ over the bound, ⌈log2 10¹⁸⌉ = 60.
        assert_eq!(luminance_scale_for(1e30), 2f32.powi(-60));
        assert!(1e30 * f64::from(luminance_scale_for(1e30)) <= UNSCALED_PEAK_CD);
        assert_eq!(luminance_scale_for(2.0 * UNSCALED_PEAK_CD), 0.5);
        assert_eq!(luminance_scale_for(1e300), 2f32.powi(-96));
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert_eq!(luminance_scale_for(bad), 1.0, "{bad}");
        }
        // An unusable configured scale falls back to 1; the steps carry the usable one.
        let mut config = AtrousConfig::new(2, 0.04);
        for (bad, want) in [(0.0, 1.0), (f32::NAN, 1.0), (-2.0, 1.0), (0.25, 0.25)] {
            config.luminance_scale = bad;
            assert_eq!(config.luminance_scale(), want);
            for (_, params) in atrous_steps(&config) {
                match params {
                    Params::Variance(v) => assert_eq!(v.luminance_scale, want),
                    Params::Atrous(a) => assert_eq!(a.luminance_scale, want),
                    other => panic!("{other:?}"),
                }
            }
        }
    }

    #[test]
    fn the_correction_is_one_linear_iteration_more_than_the_filter() {
        let config = AtrousConfig::new(3, 0.04).with_correction(true);
        let steps = correction_steps(&config);
        assert_eq!(steps.len(), 4);
        for (i, (program, params)) in steps.iter().enumerate() {
            assert!(program.takes(params), "{program:?} {params:?}");
            let Params::Atrous(a) = *params else {
                panic!("{params:?}");
            };
            assert_eq!((a.step, a.linear), (1 << i, 1));
            assert_eq!((a.reach, a.reach_min), (config.reach(), config.reach_min()));
            assert_eq!(a.normal_log2, ATROUS_NORMAL_LOG2);
            assert_eq!(a.wide_max_relative_variance, 0.0);
        }
        // None unless asked for, and no filter, no correction.
        assert!(correction_steps(&AtrousConfig::new(3, 0.04)).is_empty());
        assert!(correction_steps(&config.with_correction(false)).is_empty());
        let none = AtrousConfig::new(0, 0.04).with_correction(true);
        assert_eq!(none.correction_iterations, 0);
        assert!(correction_steps(&none).is_empty());
    }

    #[test]
    fn atrous_steps_list_the_variance_pass_then_doubling_steps() {
        assert_eq!(b3_noise_factor(0), 1.0);
        assert!((b3_noise_factor(1) - (70.0f64 / 256.0).powi(2)).abs() < 1e-15);
        let config = AtrousConfig {
            texel_size: [0.01, 0.04],
            ..AtrousConfig::new(4, 0.0)
        };
        let steps = atrous_steps(&config);
        // In a room 5 m long at 64 texels/m the third iteration's taps reach 12.5 cm: it may
        // take the wide term; the fourth's reach 25 cm, and at 0.04 m per texel the third's
        // 32 cm: not; nor without a scene size; the same at a thousandth of the size.
        let wide_bounds = |config: &AtrousConfig| {
            atrous_steps(config)
                .into_iter()
                .filter_map(|(_, p)| match p {
                    Params::Atrous(a) => Some(a.wide_max_relative_variance),
                    _ => None,
                })
                .collect::<Vec<_>>()
        };
        let room = |texel: f32, size: f32| AtrousConfig {
            scene_size: size,
            ..AtrousConfig::new(4, texel)
        };
        let tau = ATROUS_WIDE_MAX_RELATIVE_VARIANCE;
        assert_eq!(wide_bounds(&room(1.0 / 64.0, 5.0)), [0.0, 0.0, tau, 0.0]);
        assert_eq!(wide_bounds(&room(1e-3 / 64.0, 5e-3)), [0.0, 0.0, tau, 0.0]);
        assert_eq!(wide_bounds(&room(1.0 / 48.0, 5.0)), [0.0; 4]);
        assert_eq!(wide_bounds(&room(1.0 / 64.0, 0.0)), [0.0; 4]);
        assert_eq!(
            wide_bounds(&AtrousConfig {
                scene_size: 5.0,
                ..config
            }),
            [0.0; 4]
        );
        assert_eq!(steps.len(), 5);
        for (program, params) in &steps {
            assert!(program.takes(params), "{program:?} {params:?}");
        }
        let Params::Variance(v) = steps[0].1 else {
            panic!("{:?}", steps[0]);
        };
        assert_eq!((v.reach, v.min_pairs), (0.04 * 1.5, ATROUS_MIN_PAIRS));
        let mut previous = f32::INFINITY;
        for (i, (_, params)) in steps[1..].iter().enumerate() {
            let Params::Atrous(a) = *params else {
                panic!("{params:?}");
            };
            assert_eq!(a.step, 1 << i);
            assert_eq!((a.reach, a.reach_min), (0.04 * 1.5, 0.01 / 1.5));
            assert_eq!(a.normal_log2, ATROUS_NORMAL_LOG2);
            assert!(a.variance_scale < previous && a.variance_scale > 0.0);
            previous = a.variance_scale;
            assert_eq!(AtrousParams::from_words(&a.words()), a);
        }
        assert_eq!(
            steps[1].1,
            Params::Atrous(AtrousParams {
                step: 1,
                reach: 0.06,
                reach_min: 0.01 / 1.5,
                normal_log2: 7,
                // The first two iterations: σ_l = 64 (see the docs), then 4.
                variance_scale: 4096.0,
                luminance_scale: 1.0,
                // Already wide: no texel takes another term.
                wide_variance_scale: 4096.0,
                wide_max_relative_variance: 0.0,
                // No rays in narrow gaps asked: their term is the same.
                narrow_variance_scale: 4096.0,
                ..AtrousParams::default()
            })
        );
        let Params::Atrous(third) = steps[3].1 else {
            panic!("{:?}", steps[3]);
        };
        assert_eq!(third.variance_scale, (16.0 * b3_noise_factor(2)) as f32);
        // From the third on, inside a wide chart with little noise: the early term.
        assert_eq!(
            third.wide_variance_scale,
            (4096.0 * b3_noise_factor(2)) as f32
        );
        // Iterations are clamped; broken texel sizes reach nothing.
        let many = atrous_steps(&AtrousConfig::new(99, 0.1));
        assert_eq!(many.len(), 1 + MAX_ATROUS_ITERATIONS as usize);
        assert_eq!(AtrousConfig::new(1, f32::NAN).reach(), 0.0);
        assert_eq!(AtrousConfig::new(1, -1.0).reach_min(), 0.0);
        assert_eq!(atrous_steps(&AtrousConfig::new(0, 0.1)).len(), 1);
    }

    #[test]
    fn blur_radius_is_clamped() {
        assert_eq!(blur_radius(0.0), 0);
        assert_eq!(blur_radius(1.5), 5);
        assert_eq!(blur_radius(1e9), MAX_BLUR_RADIUS);
        assert_eq!(blur_radius(f32::NAN), 0);
    }

    #[test]
    fn the_tile_plan_covers_every_row_once() {
        for (size, layers, work, tile) in [
            ([64, 37], 2, 4, 1000),
            ([64, 37], 1, 1, 1 << 20),
            ([5, 3], 3, 1_000_000, 1),
            ([1, 1], 1, 1, 1),
        ] {
            let plan = TilePlan::new(size, layers, work, tile);
            let mut covered = vec![0u32; (size[1] * layers) as usize];
            for t in plan.tiles() {
                assert_eq!((t.width, t.layer_w, t.layer_h), (size[0], size[0], size[1]));
                assert!(t.height >= 1);
                for y in t.y0..t.y0 + t.height {
                    covered[(t.layer * size[1] + y) as usize] += 1;
                }
            }
            assert!(covered.iter().all(|&c| c == 1), "{size:?} {work} {tile}");
            assert_eq!(plan.tiles().count() as u64, plan.len());
        }
        assert_eq!(TilePlan::new([64, 37], 1, 4, 1000).rows, 3);
    }
}
