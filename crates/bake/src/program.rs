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
//!   ([`DirectParams`], [`BlurParams`], [`GatherParams`]; none for copy, albedo multiply and
//!   combine) whose fields — names, scalar types and byte offsets — are [`ParamBlock::FIELDS`].
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
//! parameter struct) here, its CPU function in [`crate::cpu`], and one shader file per
//! language under `shaders/<pass>/`.

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

/// The parameters of one computed pass: the block of its program.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Params {
    /// Programs without parameters (copy, albedo multiply, combine).
    None,
    /// [`Program::Direct`].
    Direct(DirectParams),
    /// [`Program::Blur`].
    Blur(BlurParams),
    /// [`Program::Gather`].
    Gather(GatherParams),
}

impl Params {
    /// The block's words (empty for [`Params::None`]).
    pub fn words(&self) -> Vec<u32> {
        match self {
            Params::None => Vec::new(),
            Params::Direct(p) => p.words(),
            Params::Blur(p) => p.words(),
            Params::Gather(p) => p.words(),
        }
    }

    /// The fields of the block (empty for [`Params::None`]).
    pub fn fields(&self) -> &'static [Field] {
        match self {
            Params::None => &[],
            Params::Direct(_) => DirectParams::FIELDS,
            Params::Blur(_) => BlurParams::FIELDS,
            Params::Gather(_) => GatherParams::FIELDS,
        }
    }

    /// Evaluations per texel (lamps, taps or rays): what the tile plan sizes tiles by.
    pub fn work_per_texel(&self) -> u64 {
        match self {
            Params::None => 1,
            Params::Direct(p) => u64::from(p.lamp_count),
            Params::Blur(p) => u64::from(p.radius.unsigned_abs()) * 2 + 1,
            Params::Gather(p) => u64::from(p.rays),
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
    /// Helpers every pass uses (`luxDot`, `luxNormalize`, `luxGuard`, the output).
    Common,
    /// The stateless RNG hash ([`crate::rng`], bit-exact).
    Rng,
    /// Scene resources: ray epsilon, lamps, regions (WGSL: the scene bind group).
    Scene,
    /// BVH traversal over the encoded textures (`luxbake_bvh::traverse`, line for line).
    Bvh,
    /// Bilinear intensity-table sampling (`luxbake_ies::GpuTable::sample`).
    Ies,
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
    /// Direct + indirect.
    Combine,
}

const NO_SCENE: SceneNeeds = SceneNeeds {
    bvh: false,
    lamps: false,
    regions: false,
};

const SIGNATURES: [Signature; 6] = [
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
        libraries: &[Library::Common, Library::Scene, Library::Bvh, Library::Ies],
    },
    Signature {
        program: Program::Copy,
        reads: &["src"],
        scene: NO_SCENE,
        params: &[],
        params_wgsl: "",
        libraries: &[Library::Common],
    },
    Signature {
        program: Program::Blur,
        reads: &["src", "normal"],
        scene: NO_SCENE,
        params: BlurParams::FIELDS,
        params_wgsl: BlurParams::WGSL_NAME,
        libraries: &[Library::Common],
    },
    Signature {
        program: Program::AlbedoMul,
        reads: &["src", "albedo"],
        scene: NO_SCENE,
        params: &[],
        params_wgsl: "",
        libraries: &[Library::Common],
    },
    Signature {
        program: Program::Gather,
        reads: &["position", "normal", "reflected"],
        scene: SceneNeeds {
            bvh: true,
            lamps: false,
            regions: true,
        },
        params: GatherParams::FIELDS,
        params_wgsl: GatherParams::WGSL_NAME,
        libraries: &[Library::Common, Library::Rng, Library::Scene, Library::Bvh],
    },
    Signature {
        program: Program::Combine,
        reads: &["direct", "indirect"],
        scene: NO_SCENE,
        params: &[],
        params_wgsl: "",
        libraries: &[Library::Common],
    },
];

impl Program {
    /// Every program.
    pub const ALL: [Program; 6] = [
        Program::Direct,
        Program::Copy,
        Program::Blur,
        Program::AlbedoMul,
        Program::Gather,
        Program::Combine,
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
    }

    #[test]
    fn fields_have_repr_c_offsets_and_round_trip() {
        for fields in [
            TileParams::FIELDS,
            DirectParams::FIELDS,
            BlurParams::FIELDS,
            GatherParams::FIELDS,
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
