//! Every pass, one folder each: `passes/<label>/` holds the pass's [`Signature`], its
//! parameter block ([`ParamBlock`]), its work estimate and its GLSL and WGSL files side by
//! side. The registry below is the one list of passes: [`Program`] (with `ALL`, `label`,
//! `signature`), [`Params`] (with `decode`, `words`, `fields`, `work_per_texel`) and the CPU
//! backend's dispatch are generated from it.
//!
//! # Adding a pass
//! A new folder `passes/<label>/` with `mod.rs` (its `SIGNATURE`, declared with `signature!`,
//! and with parameters its `param_block!` and `fn work(&Params) -> u64`), `<label>.glsl` defining
//! `vec4 luxRun(ivec3 c)` and `<label>.wgsl` defining `fn lux_run(c: vec2<i32>) -> vec4<f32>`
//! (the entry points and every declaration are generated, [`crate::shader`]), plus one line in
//! the registry. `cpu.rs` beside them is the pass's CPU reference: a `Pass` implementing the
//! CPU kernel's `TexelPass` (texel by texel) or `CpuPass` (row by row; `cpu/kernel.rs`),
//! built from the parameter words (its `Prepare`: usually the parameter block itself). The
//! backends (`luxbake-backend-cpu`, `-glow`, `-wgpu`), the CPU dispatch ([`crate::cpu::run`])
//! and the shader generator need no change.

use crate::contract::{Field, ParamBlock, Signature};

/// Counts its arguments (the registry's length).
macro_rules! count {
    () => { 0 };
    ($head:ident $($tail:ident)*) => { 1 + count!($($tail)*) };
}

/// Generates the pass modules, [`Program`] and [`Params`] from the registry
/// (`with_registry!`).
macro_rules! registry {
    ($($(#[$doc:meta])* $variant:ident = $module:ident $(($params:ident))?;)*) => {
        $(pub mod $module;)*
        $($(pub use $module::$params;)?)*

        /// One shader program per computed pass kind: what a backend compiles, names in
        /// errors and keys its caches by.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum Program {
            $($(#[$doc])* $variant,)*
        }

        impl Program {
            /// Every program, in registry order.
            pub const ALL: [Program; count!($($variant)*)] = [$(Program::$variant),*];

            /// Short label for errors and file names (`passes/<label>/<label>.{glsl,wgsl}`).
            pub fn label(self) -> &'static str {
                match self {
                    $(Program::$variant => stringify!($module),)*
                }
            }

            /// The program's signature.
            pub fn signature(self) -> &'static Signature {
                match self {
                    $(Program::$variant => &$module::SIGNATURE,)*
                }
            }
        }

        /// The parameters of one computed pass: the block of its program.
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub enum Params {
            /// Programs without parameters.
            None,
            $($(
                #[doc = concat!("[`Program::", stringify!($variant), "`].")]
                $variant($params),
            )?)*
        }

        impl Params {
            /// The block of `program` from the words of [`Params::words`] (missing words
            /// read as 0).
            pub fn decode(program: Program, words: &[u32]) -> Params {
                match program {
                    $(Program::$variant => registry!(@decode $variant words $($params)?),)*
                }
            }

            /// The block as 32-bit words, in field order (empty without a block).
            pub fn words(&self) -> Vec<u32> {
                match self {
                    Params::None => Vec::new(),
                    $($(Params::$variant(p) => ParamBlock::words(p as &$params),)?)*
                }
            }

            /// The block's fields (empty without a block).
            pub fn fields(&self) -> &'static [Field] {
                match self {
                    Params::None => &[],
                    $($(Params::$variant(_) => <$params as ParamBlock>::FIELDS,)?)*
                }
            }

            /// Evaluations per texel (rays, taps, lamps), at least 1: how a pass is split into
            /// tiles of similar cost.
            pub fn work_per_texel(&self) -> u64 {
                match self {
                    Params::None => 1,
                    $($(Params::$variant(p) => $module::work(p as &$params),)?)*
                }
                .max(1)
            }
        }
    };
    (@decode $variant:ident $words:ident) => { Params::None };
    (@decode $variant:ident $words:ident $params:ident) => {
        Params::$variant(<$params as ParamBlock>::from_words($words))
    };
}

/// The registry, one line per pass: `Variant = module(ParamsType);`, or `Variant = module;`
/// for a pass without parameters. `with_registry!(generator)` hands the list to a generator
/// macro: `registry!` here, the CPU backend's dispatch in [`crate::cpu`].
macro_rules! with_registry {
    ($generator:ident) => {
        $generator! {
            /// Direct illuminance with shadow rays.
            Direct = direct(DirectParams);
            /// Texel-for-texel copy.
            Copy = copy;
            /// One axis of the masked separable Gaussian.
            Blur = blur(BlurParams);
            /// Illuminance × albedo.
            AlbedoMul = albedo_mul;
            /// One bounce of indirect illuminance.
            Gather = gather(GatherParams);
            /// Weighted sum of two maps (direct + indirect).
            Combine = combine(CombineParams);
            /// Noise variance of the luminance in a 5×5 window (red, for the à-trous filter's
            /// edge-stopping), and with the centre left out its mean luminance (green) and variance
            /// (blue), for refinement.
            Variance = variance(VarianceParams);
            /// One iteration of the edge-stopping à-trous wavelet filter.
            Atrous = atrous(AtrousParams);
            /// Fills the texels a reduced-resolution gather left out ([`GatherParams::stride`])
            /// from
            /// the grid texels around them on their surface ([`coarse`](crate::program::coarse)).
            Upsample = upsample(UpsampleParams);
            /// Progressive refinement of a gather: a texel whose variance estimate
            /// ([`Program::Variance`] of the first gather: `√variance / mean luminance` of its 5×5
            /// window without the texel itself) shows a relative standard error over
            /// [`RefineParams::max_error`] gets `rays`
            /// more rays, continuing its sequence, averaged with the first gather's by ray count;
            /// every
            /// other texel keeps the first gather's value. The decision leaves the texel's own
            /// value
            /// out: deciding on its own noisy estimate keeps the texels that came out high and
            /// refines
            /// those that came out low (measured: +5.5 % on `chairs_05` at a target of 0.3 when
            /// divided by the texel's own luminance; −2 % on the box room while its own value was
            /// in
            /// the variance). Then kept and refined texels are both unbiased.
            Refine = refine(RefineParams);
            /// The lamp paths' part of the first bounce: each texel joined to points of the
            /// pool by shadow rays ([`connect`]).
            Connect = connect(ConnectParams);
            /// The sum of each row of a map's valid texels: what a check of the driver reads
            /// back, applied twice ([`energy`]).
            Energy = energy;
        }
    };
}
pub(crate) use with_registry;

with_registry!(registry);
