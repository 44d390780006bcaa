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
//! A new pass with parameters touches: its [`Program`] variant and [`Signature`] (and its
//! parameter struct) here — the signature names its shader files, `pass_files!("<label>")` —,
//! its CPU function in [`crate::cpu`], and one shader file per language under
//! `shaders/<label>/`. Backends and [`crate::shader`] need no change. Shader code that several
//! passes share is a [`Library`] (`shaders/lib/`).

use std::fmt;

/// Scalar type of a parameter field (every field is 4 bytes, so `#[repr(C)]`, std140 and WGSL
/// uniform layouts agree).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Scalar {
    /// `u32` / `uint`.
    U32,
    /// `i32` / `int`.
    I32,
    /// `f32` / `float`.
    F32,
}

impl Scalar {
    /// The GLSL ES 3.00 type name.
    pub fn glsl(self) -> &'static str {
        match self {
            Scalar::U32 => "uint",
            Scalar::I32 => "int",
            Scalar::F32 => "float",
        }
    }

    /// The WGSL type name.
    pub fn wgsl(self) -> &'static str {
        match self {
            Scalar::U32 => "u32",
            Scalar::I32 => "i32",
            Scalar::F32 => "f32",
        }
    }
}

/// A Rust scalar that can be a parameter field.
pub trait ParamScalar: Copy {
    /// Its [`Scalar`] type.
    const SCALAR: Scalar;
    /// Its bits, as a shader reads them.
    fn to_bits(self) -> u32;
    /// The value of `bits`.
    fn from_bits(bits: u32) -> Self;
}

impl ParamScalar for u32 {
    const SCALAR: Scalar = Scalar::U32;
    fn to_bits(self) -> u32 {
        self
    }
    fn from_bits(bits: u32) -> Self {
        bits
    }
}

impl ParamScalar for i32 {
    const SCALAR: Scalar = Scalar::I32;
    fn to_bits(self) -> u32 {
        self as u32
    }
    fn from_bits(bits: u32) -> Self {
        bits as i32
    }
}

impl ParamScalar for f32 {
    const SCALAR: Scalar = Scalar::F32;
    fn to_bits(self) -> u32 {
        f32::to_bits(self)
    }
    fn from_bits(bits: u32) -> Self {
        f32::from_bits(bits)
    }
}

/// One field of a parameter block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Field {
    /// Field name: `u_<name>` in GLSL, `<block>.<name>` in WGSL.
    pub name: &'static str,
    /// Scalar type.
    pub ty: Scalar,
    /// Byte offset in the `#[repr(C)]` struct (and the WGSL uniform struct).
    pub offset: usize,
}

impl Field {
    /// Whether the field only pads the block to 16 bytes (not declared in GLSL).
    pub fn is_padding(&self) -> bool {
        self.name.starts_with("pad")
    }
}

/// A `#[repr(C)]` uniform parameter block of 4-byte scalars, 16-byte aligned in size.
pub trait ParamBlock: Copy + fmt::Debug {
    /// The struct's name in WGSL.
    const WGSL_NAME: &'static str;
    /// Its fields in declaration order, offsets included.
    const FIELDS: &'static [Field];
    /// The field values as 32-bit words, in order (`FIELDS[i]` at word `i`).
    fn words(&self) -> Vec<u32>;
    /// The block from words written by [`words`](Self::words); missing words read as 0.
    fn from_words(words: &[u32]) -> Self;
}

macro_rules! param_block {
    ($(#[$meta:meta])* $name:ident as $wgsl:literal {
        $($(#[$fmeta:meta])* $field:ident: $ty:ty),* $(,)?
    }) => {
        $(#[$meta])*
        #[repr(C)]
        #[derive(Debug, Clone, Copy, PartialEq, Default)]
        pub struct $name {
            $($(#[$fmeta])* pub $field: $ty),*
        }

        impl ParamBlock for $name {
            const WGSL_NAME: &'static str = $wgsl;
            const FIELDS: &'static [Field] = &[$(Field {
                name: stringify!($field),
                ty: <$ty as ParamScalar>::SCALAR,
                offset: std::mem::offset_of!($name, $field),
            }),*];

            fn words(&self) -> Vec<u32> {
                vec![$(ParamScalar::to_bits(self.$field)),*]
            }

            fn from_words(words: &[u32]) -> Self {
                let mut it = words.iter().copied();
                $name {
                    $($field: <$ty as ParamScalar>::from_bits(it.next().unwrap_or(0))),*
                }
            }
        }

        const _: () = assert!(std::mem::size_of::<$name>() % 16 == 0);
    };
}

param_block! {
    /// The tile one dispatch covers: texels `x0 .. x0 + width`, rows `y0 .. y0 + height` of
    /// layer `layer`, in a texture array of `layer_w × layer_h` texels per layer.
    TileParams as "LuxTile" {
        /// First column.
        x0: u32,
        /// First row.
        y0: u32,
        /// Columns.
        width: u32,
        /// Rows.
        height: u32,
        /// Texture-array layer.
        layer: u32,
        /// Layer width, texels.
        layer_w: u32,
        /// Layer height, texels.
        layer_h: u32,
        /// Padding.
        pad0: u32,
    }
}

param_block! {
    /// Parameters of [`Program::Direct`]: the lamps are the scene's uploaded lamps.
    DirectParams as "LuxDirectParams" {
        /// Lamps to evaluate (the first `lamp_count` of the uploaded lamps).
        lamp_count: u32,
        /// Padding.
        pad0: u32,
        /// Padding.
        pad1: u32,
        /// Padding.
        pad2: u32,
    }
}

param_block! {
    /// Parameters of [`Program::Blur`] (one axis of the masked Gaussian).
    BlurParams as "LuxBlurParams" {
        /// Texel step along the axis: (1, 0) for U.
        step_x: i32,
        /// Texel step along the axis: (0, 1) for V.
        step_y: i32,
        /// Taps on each side: [`blur_radius`]`(σ)`.
        radius: i32,
        /// Exponent factor `−1 / (2σ²)`.
        inv: f32,
    }
}

param_block! {
    /// Parameters of [`Program::Combine`]: `dst = a_weight · a + b_weight · b`.
    CombineParams as "LuxCombineParams" {
        /// Weight of the first input.
        a_weight: f32,
        /// Weight of the second input.
        b_weight: f32,
        /// Padding.
        pad0: u32,
        /// Padding.
        pad1: u32,
    }
}

impl CombineParams {
    /// `a + b` (the paper's combine): weights 1, bit-identical to an unweighted sum.
    pub const SUM: CombineParams = CombineParams {
        a_weight: 1.0,
        b_weight: 1.0,
        pad0: 0,
        pad1: 0,
    };
}

param_block! {
    /// Parameters of [`Program::Gather`].
    GatherParams as "LuxGatherParams" {
        /// Rays per texel.
        rays: u32,
        /// Bounce number, 1-based (the `pass` input of the RNG hash).
        bounce: u32,
        /// Seed of the RNG hash.
        seed: u32,
        /// The direction sampler's id ([`Sampler::id`](crate::rng::Sampler::id)).
        sampler: u32,
        /// Reduced resolution: only texels on the grid of every `stride`-th column and row,
        /// and texels with no such grid texel around them on their surface, are gathered
        /// ([`coarse`]); [`Program::Upsample`] fills the rest. 1 (or 0): every texel.
        stride: u32,
        /// The chart test of [`coarse`]: farthest a grid texel on the centre's surface lies
        /// per texel of offset, metres ([`AtrousConfig::reach`]).
        reach: f32,
        /// Rays of an orphan ([`coarse`]): it stands for itself, not for a grid cell of
        /// `stride²` texels, so [`coarse::orphan_rays`] gives it fewer than a grid texel.
        orphan_rays: u32,
        /// Lamp paths per texel combined with this gather ([`crate::lightpaths`]; the first
        /// bounce at stride 1 only): each hit's exitance is weighted by the balance heuristic
        /// and the slot `connected` (their part, uploaded) is added. 0: plain gather, the
        /// slot is not read.
        lamp_paths: u32,
        /// [`crate::lightpaths::LampPaths::density_scale`].
        density_scale: f32,
        /// Lamps uploaded (the density of [`crate::lightpaths::density`] sums over them).
        lamp_count: u32,
        /// Padding.
        pad0: u32,
        /// Padding.
        pad1: u32,
    }
}

param_block! {
    /// Parameters of [`Program::Upsample`]: the reduced-resolution gather's grid.
    UpsampleParams as "LuxUpsampleParams" {
        /// The gather's [`GatherParams::stride`].
        stride: u32,
        /// The gather's [`GatherParams::reach`].
        reach: f32,
        /// Padding.
        pad0: u32,
        /// Padding.
        pad1: u32,
    }
}

param_block! {
    /// Parameters of [`Program::Refine`]: progressive refinement of a gather of `first_rays`
    /// rays per texel (see [`Program::Refine`]).
    RefineParams as "LuxRefineParams" {
        /// Further rays per texel that misses the target: samples `first_rays ..
        /// first_rays + rays` of the texel's sequence.
        rays: u32,
        /// Bounce number, 1-based (the `pass` input of the RNG hash).
        bounce: u32,
        /// Seed of the RNG hash.
        seed: u32,
        /// The direction sampler's id ([`Sampler::id`](crate::rng::Sampler::id)).
        sampler: u32,
        /// Rays of the first gather.
        first_rays: u32,
        /// The target: a texel whose estimated relative standard error (√variance / the
        /// window's mean luminance, [`Program::Variance`]) is at most this is kept as it is.
        max_error: f32,
        /// Padding.
        pad0: u32,
        /// Padding.
        pad1: u32,
    }
}

param_block! {
    /// Parameters of [`Program::Variance`]: the noise variance of the luminance at a texel,
    /// estimated from neighbouring texels of its surface (the derivation is in
    /// [`atrous_steps`]' docs and [`crate::cpu`]).
    VarianceParams as "LuxVarianceParams" {
        /// Farthest a tap on the centre's chart lies per texel of offset, metres
        /// ([`AtrousConfig::reach`]).
        reach: f32,
        /// Fewest texel pairs a direction needs to give an estimate ([`ATROUS_MIN_PAIRS`]).
        min_pairs: u32,
        /// Padding.
        pad0: u32,
        /// Padding.
        pad1: u32,
    }
}

param_block! {
    /// Parameters of one iteration of [`Program::Atrous`] (edge-stopping à-trous wavelet
    /// filter; see [`atrous_steps`]).
    AtrousParams as "LuxAtrousParams" {
        /// Spacing of the 5×5 taps, texels: `2^i` at iteration `i`.
        step: i32,
        /// Farthest a tap on the centre's chart lies per texel of offset, metres
        /// ([`AtrousConfig::reach`]).
        reach: f32,
        /// Nearest a tap on the centre's chart lies per texel of offset beyond the first two,
        /// metres ([`AtrousConfig::reach_min`]).
        reach_min: f32,
        /// Normal weight `max(0, n̂·n̂ₜ)^(2^normal_log2)`.
        normal_log2: u32,
        /// Luminance weight `exp(−Δl² / (variance_scale · σ²))`, σ² the centre's variance
        /// estimate: `σ_l² · ρᵢ` ([`AtrousConfig::sigma_luminance`], [`b3_noise_factor`]).
        variance_scale: f32,
        /// Padding.
        pad0: u32,
        /// Padding.
        pad1: u32,
        /// Padding.
        pad2: u32,
    }
}

/// Largest blur radius, texels (a shader's loop bound).
pub const MAX_BLUR_RADIUS: i32 = 64;
/// Blur taps whose normal deviates more than this cosine (25°) from the centre's are skipped.
pub const BLUR_NORMAL_COS: f32 = 0.906_307_8;

/// Taps on each side of a Gaussian of standard deviation `sigma` texels:
/// `min(⌈3σ⌉, MAX_BLUR_RADIUS)`, at least 0.
pub fn blur_radius(sigma: f32) -> i32 {
    ((3.0 * sigma).ceil() as i32).clamp(0, MAX_BLUR_RADIUS)
}

/// The parameter block of a blur along `step` with standard deviation `sigma` texels.
pub fn blur_params(step: [i32; 2], sigma: f32) -> BlurParams {
    BlurParams {
        step_x: step[0],
        step_y: step[1],
        radius: blur_radius(sigma),
        inv: -0.5 / (sigma * sigma),
    }
}

/// The B3-spline kernel of the à-trous filter, one axis: taps `−2 ..= 2` (Dammertz et al.
/// 2010); the 5×5 weights are the products `B3[i] · B3[j]`.
pub const B3: [f32; 5] = [0.0625, 0.25, 0.375, 0.25, 0.0625];
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
/// Default [`AtrousConfig::early_iterations`].
pub const ATROUS_EARLY_ITERATIONS: u32 = 2;
/// Default [`AtrousConfig::early_sigma_luminance`]: a luminance step of 64σ gets weight
/// `e⁻¹` in the first iterations, where the noise is still skewed (see [`atrous_steps`]).
pub const ATROUS_EARLY_SIGMA_LUMINANCE: f32 = 64.0;
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
        }
    }

    /// Farthest a tap on the centre's chart lies per texel of offset: largest texel size ×
    /// chart tolerance, metres (0 when not finite and ≥ 0: then only the centre is a tap).
    pub fn reach(&self) -> f32 {
        finite_or_zero(self.texel_size[1] * self.chart_tolerance)
    }

    /// Nearest a tap on the centre's chart lies per texel of offset beyond the first two:
    /// smallest texel size / chart tolerance, metres (0 when not finite and ≥ 0: no lower
    /// bound).
    pub fn reach_min(&self) -> f32 {
        finite_or_zero(self.texel_size[0] / self.chart_tolerance)
    }
}

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

/// The passes of the à-trous denoiser, in order, for the graph builder to chain:
///
/// 1. `(Program::Variance, Params::Variance(_))`: reads `[noisy, position, normal]`, writes
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
/// [`ATROUS_EARLY_SIGMA_LUMINANCE`] (64σ): the noise passes as if the filter were linear
/// (−0.4 … −1.4 % per wall, −1.3 % linear), while a step of the signal far above the noise
/// (a contact shadow in low noise: 80σ) still stops it. The later iterations, over less
/// and less skewed noise, keep `σ_l`.
///
/// # The variance estimate
/// The gather pass averages N independent ray samples per texel and every texel has its own
/// random numbers, so the indirect map is `s + ε`: a smooth signal plus independent noise of
/// variance σ² per texel. Then the difference of two neighbouring texels along a direction in
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
pub fn atrous_steps(config: &AtrousConfig) -> Vec<(Program, Params)> {
    let (reach, reach_min) = (config.reach(), config.reach_min());
    let sigma2 = |i: u32| {
        let s = if i < config.early_iterations {
            config.early_sigma_luminance
        } else {
            config.sigma_luminance
        };
        f64::from(s) * f64::from(s)
    };
    let mut steps = vec![(
        Program::Variance,
        Params::Variance(VarianceParams {
            reach,
            min_pairs: ATROUS_MIN_PAIRS,
            ..VarianceParams::default()
        }),
    )];
    steps.extend((0..config.iterations.min(MAX_ATROUS_ITERATIONS)).map(|i| {
        (
            Program::Atrous,
            Params::Atrous(AtrousParams {
                step: 1 << i,
                reach,
                reach_min,
                normal_log2: config.normal_log2,
                variance_scale: (sigma2(i) * b3_noise_factor(i)) as f32,
                ..AtrousParams::default()
            }),
        )
    }));
    steps
}

/// The parameters of one computed pass: the block of its program.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Params {
    /// Programs without parameters (copy, albedo multiply).
    None,
    /// [`Program::Direct`].
    Direct(DirectParams),
    /// [`Program::Blur`].
    Blur(BlurParams),
    /// [`Program::Gather`].
    Gather(GatherParams),
    /// [`Program::Combine`].
    Combine(CombineParams),
    /// [`Program::Variance`].
    Variance(VarianceParams),
    /// [`Program::Atrous`].
    Atrous(AtrousParams),
    /// [`Program::Upsample`].
    Upsample(UpsampleParams),
    /// [`Program::Refine`].
    Refine(RefineParams),
}

impl Params {
    /// `program`'s block from its words (the inverse of [`words`](Self::words); missing words
    /// read as 0).
    pub fn decode(program: Program, words: &[u32]) -> Params {
        match program {
            Program::Direct => Params::Direct(DirectParams::from_words(words)),
            Program::Copy | Program::AlbedoMul => Params::None,
            Program::Blur => Params::Blur(BlurParams::from_words(words)),
            Program::Gather => Params::Gather(GatherParams::from_words(words)),
            Program::Combine => Params::Combine(CombineParams::from_words(words)),
            Program::Variance => Params::Variance(VarianceParams::from_words(words)),
            Program::Atrous => Params::Atrous(AtrousParams::from_words(words)),
            Program::Upsample => Params::Upsample(UpsampleParams::from_words(words)),
            Program::Refine => Params::Refine(RefineParams::from_words(words)),
        }
    }

    /// The block's words (empty for [`Params::None`]).
    pub fn words(&self) -> Vec<u32> {
        match self {
            Params::None => Vec::new(),
            Params::Direct(p) => p.words(),
            Params::Blur(p) => p.words(),
            Params::Gather(p) => p.words(),
            Params::Combine(p) => p.words(),
            Params::Variance(p) => p.words(),
            Params::Atrous(p) => p.words(),
            Params::Upsample(p) => p.words(),
            Params::Refine(p) => p.words(),
        }
    }

    /// The fields of the block (empty for [`Params::None`]).
    pub fn fields(&self) -> &'static [Field] {
        match self {
            Params::None => &[],
            Params::Direct(_) => DirectParams::FIELDS,
            Params::Blur(_) => BlurParams::FIELDS,
            Params::Gather(_) => GatherParams::FIELDS,
            Params::Combine(_) => CombineParams::FIELDS,
            Params::Variance(_) => VarianceParams::FIELDS,
            Params::Atrous(_) => AtrousParams::FIELDS,
            Params::Upsample(_) => UpsampleParams::FIELDS,
            Params::Refine(_) => RefineParams::FIELDS,
        }
    }

    /// Evaluations per texel (lamps, taps or rays): what the tile plan sizes tiles by.
    pub fn work_per_texel(&self) -> u64 {
        match self {
            Params::None => 1,
            Params::Direct(p) => u64::from(p.lamp_count),
            Params::Blur(p) => u64::from(p.radius.unsigned_abs()) * 2 + 1,
            Params::Gather(p) => u64::from(p.rays),
            Params::Combine(_) => 1,
            // 25 taps, then 4 directions × 20 pairs.
            Params::Variance(_) => 105,
            Params::Atrous(_) => 25,
            Params::Upsample(_) => 4,
            Params::Refine(p) => u64::from(p.rays),
        }
        .max(1)
    }
}

/// Static scene resources a program reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SceneNeeds {
    /// The encoded BVH and triangle data (the program casts rays).
    pub bvh: bool,
    /// The uploaded lamps and their intensity tables.
    pub lamps: bool,
    /// The objects' light-map regions.
    pub regions: bool,
}

/// A shared shader library file (one per language in `shaders/lib/`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Library {
    /// The gather's ray loop: cosine-weighted directions, the masked bilinear look-up of the
    /// hit's light-map texel (`cpu::gather_rays`); for programs reading the slot `reflected`.
    Gather,
    /// The reduced-resolution gather's grid test ([`coarse`]); for programs reading the slots
    /// `position` and `normal`.
    Coarse,
    /// Helpers every pass uses (`luxDot`, `luxNormalize`, `luxGuard`, `luxLuminance`, the
    /// output).
    Common,
    /// The stateless RNG hash ([`crate::rng`], bit-exact).
    Rng,
    /// Scene resources: ray epsilon, lamps, regions (WGSL: the scene bind group).
    Scene,
    /// BVH traversal over the encoded textures (`luxbake_bvh::traverse`, line for line).
    Bvh,
    /// Bilinear intensity-table sampling (`luxbake_ies::GpuTable::sample`).
    Ies,
    /// A lamp seen unshadowed from a surface point ([`crate::backend::lamp_toward`]); after
    /// [`Library::Scene`] and [`Library::Ies`].
    Lamp,
    /// The denoiser's guide: whether a tap lies on the centre's surface (`cpu::Guide`); for
    /// programs reading the slots `src`, `position` and `normal`.
    Guide,
}

/// What a program reads and which parameters it takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Signature {
    /// The program.
    pub program: Program,
    /// Slot names of the graph textures read, in `PassDesc::reads` order.
    pub reads: &'static [&'static str],
    /// Scene resources read.
    pub scene: SceneNeeds,
    /// The parameter block's fields (empty: no block).
    pub params: &'static [Field],
    /// The block's name in WGSL (`""` without a block).
    pub params_wgsl: &'static str,
    /// Library files included before the pass file, in order.
    pub libraries: &'static [Library],
    /// The pass file in GLSL ES 3.00: `shaders/<label>/<label>.glsl`.
    pub glsl: &'static str,
    /// The pass file in WGSL: `shaders/<label>/<label>.wgsl`.
    pub wgsl: &'static str,
}

/// The GLSL and WGSL pass files of the program labelled `$label`.
macro_rules! pass_files {
    ($label:literal) => {
        (
            include_str!(concat!("../shaders/", $label, "/", $label, ".glsl")),
            include_str!(concat!("../shaders/", $label, "/", $label, ".wgsl")),
        )
    };
}

/// One shader program per computed pass kind: what a backend compiles, names in errors and
/// keys its caches by.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Program {
    /// Direct illuminance with shadow rays.
    Direct,
    /// Texel-for-texel copy.
    Copy,
    /// One axis of the masked separable Gaussian.
    Blur,
    /// Illuminance × albedo.
    AlbedoMul,
    /// One bounce of indirect illuminance.
    Gather,
    /// Weighted sum of two maps (direct + indirect).
    Combine,
    /// Noise variance of the luminance in a 5×5 window (red, for the à-trous filter's
    /// edge-stopping), and with the centre left out its mean luminance (green) and variance
    /// (blue), for refinement.
    Variance,
    /// One iteration of the edge-stopping à-trous wavelet filter.
    Atrous,
    /// Fills the texels a reduced-resolution gather left out ([`GatherParams::stride`]) from
    /// the grid texels around them on their surface ([`coarse`]).
    Upsample,
    /// Progressive refinement of a gather: a texel whose variance estimate
    /// ([`Program::Variance`] of the first gather: `√variance / mean luminance` of its 5×5
    /// window without the texel itself) shows a relative standard error over [`RefineParams::max_error`] gets `rays`
    /// more rays, continuing its sequence, averaged with the first gather's by ray count; every
    /// other texel keeps the first gather's value. The decision leaves the texel's own value
    /// out: deciding on its own noisy estimate keeps the texels that came out high and refines
    /// those that came out low (measured: +5.5 % on `chairs_05` at a target of 0.3 when
    /// divided by the texel's own luminance; −2 % on the box room while its own value was in
    /// the variance). Then kept and refined texels are both unbiased.
    Refine,
}

/// The reduced-resolution gather's grid ([`GatherParams::stride`], [`Program::Upsample`]).
///
/// With stride `s`, the grid texels are those whose column and row are multiples of `s`. A
/// texel `(x, y)` lies in the grid cell of corners `(x₀, y₀)`, `(x₀ + s, y₀)`, `(x₀, y₀ + s)`,
/// `(x₀ + s, y₀ + s)`, `x₀ = s·⌊x/s⌋`, with bilinear weights `(1 − fx)(1 − fy)` …, `fx = (x −
/// x₀)/s`. A corner counts when its weight is positive and it lies on the texel's surface: in
/// the layer, valid in the G-buffer, the texel's object, its normal within 25°
/// ([`BLUR_NORMAL_COS`]) and its position within `reach·|offset|` (the denoiser's chart test,
/// [`atrous_steps`]). A texel with counted corners is interpolated from them; one without —
/// a chart narrower than the grid, a chart's rim — is an **orphan**: the gather traces it
/// itself, so no texel is left without light. The gather and the upsample evaluate the same
/// test on the same G-buffer, so they agree on the orphans. Grid texels count themselves
/// (weight 1).
///
/// A grid texel's rays stand for its cell of `stride²` texels; an orphan lies in a strip
/// narrower than the grid (a chair leg's chart, a chart's corner) and stands for itself, so it
/// gets [`orphan_rays`](coarse::orphan_rays)`(rays, stride)` = ⌈rays / stride⌉: still more
/// rays per texel of surface than the grid's `rays / stride²`.
pub mod coarse {
    /// Rays of an orphan of a gather of `rays` rays per grid texel at `stride`.
    pub fn orphan_rays(rays: u32, stride: u32) -> u32 {
        rays.div_ceil(stride.max(1))
    }

    /// The four corners of texel `(x, y)`'s grid cell, in the order `(x₀, y₀)`, `(x₁, y₀)`,
    /// `(x₀, y₁)`, `(x₁, y₁)`, with their bilinear weights (before the surface test).
    pub fn cell(x: u32, y: u32, stride: u32) -> [([i64; 2], f32); 4] {
        let s = stride.max(1);
        let (x0, y0) = (x / s * s, y / s * s);
        let fx = (x - x0) as f32 / s as f32;
        let fy = (y - y0) as f32 / s as f32;
        let (x0, y0, s) = (i64::from(x0), i64::from(y0), i64::from(s));
        [
            ([x0, y0], (1.0 - fx) * (1.0 - fy)),
            ([x0 + s, y0], fx * (1.0 - fy)),
            ([x0, y0 + s], (1.0 - fx) * fy),
            ([x0 + s, y0 + s], fx * fy),
        ]
    }
}

const NO_SCENE: SceneNeeds = SceneNeeds {
    bvh: false,
    lamps: false,
    regions: false,
};

const SIGNATURES: [Signature; 10] = [
    Signature {
        program: Program::Direct,
        reads: &["position", "normal"],
        scene: SceneNeeds {
            bvh: true,
            lamps: true,
            regions: false,
        },
        params: DirectParams::FIELDS,
        params_wgsl: DirectParams::WGSL_NAME,
        libraries: &[
            Library::Common,
            Library::Scene,
            Library::Bvh,
            Library::Ies,
            Library::Lamp,
        ],
        glsl: pass_files!("direct").0,
        wgsl: pass_files!("direct").1,
    },
    Signature {
        program: Program::Copy,
        reads: &["src"],
        scene: NO_SCENE,
        params: &[],
        params_wgsl: "",
        libraries: &[Library::Common],
        glsl: pass_files!("copy").0,
        wgsl: pass_files!("copy").1,
    },
    Signature {
        program: Program::Blur,
        reads: &["src", "normal"],
        scene: NO_SCENE,
        params: BlurParams::FIELDS,
        params_wgsl: BlurParams::WGSL_NAME,
        libraries: &[Library::Common],
        glsl: pass_files!("blur").0,
        wgsl: pass_files!("blur").1,
    },
    Signature {
        program: Program::AlbedoMul,
        reads: &["src", "albedo"],
        scene: NO_SCENE,
        params: &[],
        params_wgsl: "",
        libraries: &[Library::Common],
        glsl: pass_files!("albedo_mul").0,
        wgsl: pass_files!("albedo_mul").1,
    },
    Signature {
        program: Program::Gather,
        reads: &["position", "normal", "reflected", "connected"],
        scene: SceneNeeds {
            bvh: true,
            lamps: true,
            regions: true,
        },
        params: GatherParams::FIELDS,
        params_wgsl: GatherParams::WGSL_NAME,
        libraries: &[
            Library::Common,
            Library::Rng,
            Library::Scene,
            Library::Bvh,
            Library::Ies,
            Library::Lamp,
            Library::Gather,
            Library::Coarse,
        ],
        glsl: pass_files!("gather").0,
        wgsl: pass_files!("gather").1,
    },
    Signature {
        program: Program::Combine,
        reads: &["direct", "indirect"],
        scene: NO_SCENE,
        params: CombineParams::FIELDS,
        params_wgsl: CombineParams::WGSL_NAME,
        libraries: &[Library::Common],
        glsl: pass_files!("combine").0,
        wgsl: pass_files!("combine").1,
    },
    Signature {
        program: Program::Variance,
        reads: &["src", "position", "normal"],
        scene: NO_SCENE,
        params: VarianceParams::FIELDS,
        params_wgsl: VarianceParams::WGSL_NAME,
        libraries: &[Library::Common, Library::Guide],
        glsl: pass_files!("variance").0,
        wgsl: pass_files!("variance").1,
    },
    Signature {
        program: Program::Atrous,
        reads: &["src", "variance", "position", "normal"],
        scene: NO_SCENE,
        params: AtrousParams::FIELDS,
        params_wgsl: AtrousParams::WGSL_NAME,
        libraries: &[Library::Common, Library::Guide],
        glsl: pass_files!("atrous").0,
        wgsl: pass_files!("atrous").1,
    },
    Signature {
        program: Program::Upsample,
        reads: &["src", "position", "normal"],
        scene: NO_SCENE,
        params: UpsampleParams::FIELDS,
        params_wgsl: UpsampleParams::WGSL_NAME,
        libraries: &[Library::Common, Library::Coarse],
        glsl: pass_files!("upsample").0,
        wgsl: pass_files!("upsample").1,
    },
    Signature {
        program: Program::Refine,
        reads: &["position", "normal", "reflected", "first", "variance"],
        // The lamps and their tables: the shared gather loop can weight against lamp paths
        // (the refine pass never does: lamp paths require no refinement).
        scene: SceneNeeds {
            bvh: true,
            lamps: true,
            regions: true,
        },
        params: RefineParams::FIELDS,
        params_wgsl: RefineParams::WGSL_NAME,
        libraries: &[
            Library::Common,
            Library::Rng,
            Library::Scene,
            Library::Bvh,
            Library::Ies,
            Library::Lamp,
            Library::Gather,
        ],
        glsl: pass_files!("refine").0,
        wgsl: pass_files!("refine").1,
    },
];

impl Program {
    /// Every program.
    pub const ALL: [Program; 10] = [
        Program::Direct,
        Program::Copy,
        Program::Blur,
        Program::AlbedoMul,
        Program::Gather,
        Program::Combine,
        Program::Variance,
        Program::Atrous,
        Program::Upsample,
        Program::Refine,
    ];

    /// Short label for errors and shader file names (`shaders/<label>/<label>.{glsl,wgsl}`).
    pub fn label(self) -> &'static str {
        match self {
            Program::Direct => "direct",
            Program::Copy => "copy",
            Program::Blur => "blur",
            Program::AlbedoMul => "albedo_mul",
            Program::Gather => "gather",
            Program::Combine => "combine",
            Program::Variance => "variance",
            Program::Atrous => "atrous",
            Program::Upsample => "upsample",
            Program::Refine => "refine",
        }
    }

    /// The program's signature.
    pub fn signature(self) -> &'static Signature {
        let s = &SIGNATURES[self as usize];
        debug_assert_eq!(s.program, self);
        s
    }

    /// Whether the program casts rays (and so depends on the BVH traversal).
    pub fn traces_rays(self) -> bool {
        self.signature().scene.bvh
    }

    /// Whether `params` is this program's parameter block.
    pub fn takes(self, params: &Params) -> bool {
        params.fields() == self.signature().params
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
                    pad0: 0,
                }
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signatures_are_indexed_by_program_and_labels_are_unique() {
        for p in Program::ALL {
            assert_eq!(p.signature().program, p);
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
    fn atrous_steps_list_the_variance_pass_then_doubling_steps() {
        assert_eq!(b3_noise_factor(0), 1.0);
        assert!((b3_noise_factor(1) - (70.0f64 / 256.0).powi(2)).abs() < 1e-15);
        let config = AtrousConfig {
            texel_size: [0.01, 0.04],
            ..AtrousConfig::new(4, 0.0)
        };
        let steps = atrous_steps(&config);
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
                ..AtrousParams::default()
            })
        );
        let Params::Atrous(third) = steps[3].1 else {
            panic!("{:?}", steps[3]);
        };
        assert_eq!(third.variance_scale, (16.0 * b3_noise_factor(2)) as f32);
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
