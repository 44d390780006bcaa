//! The pass contract's vocabulary: what a pass declares about itself, as data.
//!
//! A pass ([`crate::passes`]) declares its [`Signature`] — the texture slots it reads, the
//! scene resources it needs ([`SceneNeeds`]), its parameter block ([`ParamBlock`], defined
//! with `param_block!`, whose [`Field`]s generate the shaders' declarations) and the shared
//! shader [`Library`] files it includes. Every dispatch also gets the [`TileParams`] block.
//! [`crate::program`] re-exports all of it.

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

/// Declares a `#[repr(C)]` parameter block and its [`ParamBlock`] impl: `Name as
/// "WgslName" { field: type, … }`, every field a [`ParamScalar`], the size a multiple of 16
/// bytes (`pad*` fields pad it).
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

        impl $crate::contract::ParamBlock for $name {
            const WGSL_NAME: &'static str = $wgsl;
            const FIELDS: &'static [$crate::contract::Field] = &[$($crate::contract::Field {
                name: stringify!($field),
                ty: <$ty as $crate::contract::ParamScalar>::SCALAR,
                offset: std::mem::offset_of!($name, $field),
            }),*];

            fn words(&self) -> Vec<u32> {
                vec![$($crate::contract::ParamScalar::to_bits(self.$field)),*]
            }

            fn from_words(words: &[u32]) -> Self {
                let mut it = words.iter().copied();
                $name {
                    $($field: <$ty as $crate::contract::ParamScalar>::from_bits(
                        it.next().unwrap_or(0),
                    )),*
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
        /// A strided gather's compact grid (`coarse::grid_tile`), for the backends that
        /// dispatch it in two: 0 in every other dispatch; `s ≥ 2` in the dispatch of the grid
        /// texels alone, whose columns and rows `x0 .. x0 + width`, `y0 .. y0 + height` are
        /// then the grid's, its invocation `(i, j)` the layout's texel `(i·s, j·s)`; 1 in the
        /// dispatch over the tile that comes before it, which leaves the grid texels to it.
        grid: u32,
    }
}

pub(crate) use param_block;

/// Static scene resources a program reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SceneNeeds {
    /// The encoded BVH and triangle data (the program casts rays).
    pub bvh: bool,
    /// The uploaded lamps and their intensity tables.
    pub lamps: bool,
    /// The objects' light-map regions.
    pub regions: bool,
    /// The lamp paths' points ([`crate::backend::SceneData::lamp_paths`]).
    pub lamp_paths: bool,
}

impl SceneNeeds {
    /// No scene resource.
    pub const NONE: SceneNeeds = SceneNeeds {
        bvh: false,
        lamps: false,
        regions: false,
        lamp_paths: false,
    };
}

/// A shared shader library file (one per language in `shaders/lib/`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Library {
    /// The gather's ray loop: cosine-weighted directions (uniform ones, weighted `2 cos θ`, at
    /// a texel in a narrow gap: [`crate::lightpaths::gather_weight`]), the masked bilinear
    /// look-up of the hit's light-map texel (`cpu::gather_rays`); for programs reading the slot
    /// `reflected`.
    Gather,
    /// The reduced-resolution gather's grid test ([`coarse`]); for programs reading the slots
    /// `position` and `normal`.
    Coarse,
    /// Helpers every pass uses (`luxDot`, `luxNormalize`, `luxGuard`, `luxLuminance`, the
    /// output; in GLSL also `luxPick` and `luxDivMod`, a vector's component and a floor
    /// division without a variable index or an integer division, which SwiftShader runs
    /// slowly).
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
    /// Sampling a lamp's luminous opening ([`crate::opening`]); after [`Library::Rng`] and
    /// [`Library::Lamp`].
    Opening,
    /// The denoiser's guide: whether a tap lies on the centre's surface (`cpu::Guide`); for
    /// programs reading the slots `src`, `position` and `normal`.
    Guide,
}

/// What a program reads and which parameters it takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Signature {
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
    /// The pass file in GLSL ES 3.00: `passes/<label>/<label>.glsl`.
    pub glsl: &'static str,
    /// The pass file in WGSL: `passes/<label>/<label>.wgsl`.
    pub wgsl: &'static str,
}

/// Declares a pass's `SIGNATURE` (in `passes/<label>/mod.rs`): its label, which names its
/// shader files `<label>.glsl` and `<label>.wgsl` beside it, the slots it reads, the
/// [`SceneNeeds`] it sets (none when `scene` is left out), its parameter block's type (none
/// when `params` is left out) and its [`Library`] files, in order:
///
/// ```ignore
/// signature! {
///     upsample {
///         reads: ["src", "position", "normal"],
///         params: UpsampleParams,
///         libraries: [Common, Coarse],
///     }
/// }
/// ```
macro_rules! signature {
    ($label:ident {
        reads: [$($read:literal),* $(,)?],
        $(scene: [$($need:ident),* $(,)?],)?
        $(params: $params:ty,)?
        libraries: [$($library:ident),* $(,)?] $(,)?
    }) => {
        /// What the pass reads and which parameters it takes.
        pub const SIGNATURE: $crate::contract::Signature = $crate::contract::Signature {
            reads: &[$($read),*],
            scene: $crate::contract::signature!(@scene $($($need)*)?),
            params: $crate::contract::signature!(@fields $($params)?),
            params_wgsl: $crate::contract::signature!(@wgsl $($params)?),
            libraries: &[$($crate::contract::Library::$library),*],
            glsl: include_str!(concat!(stringify!($label), ".glsl")),
            wgsl: include_str!(concat!(stringify!($label), ".wgsl")),
        };
    };
    (@scene) => { $crate::contract::SceneNeeds::NONE };
    (@scene $($need:ident)+) => {
        $crate::contract::SceneNeeds { $($need: true,)+ ..$crate::contract::SceneNeeds::NONE }
    };
    (@fields) => { &[] };
    (@fields $params:ty) => { <$params as $crate::contract::ParamBlock>::FIELDS };
    (@wgsl) => { "" };
    (@wgsl $params:ty) => { <$params as $crate::contract::ParamBlock>::WGSL_NAME };
}

pub(crate) use signature;

/// Largest blur radius, texels (a shader's loop bound; the scene crate's, which sizes chart
/// padding by it).
pub use luxbake_scene::MAX_BLUR_RADIUS;
/// Blur taps whose normal deviates more than this cosine (25°) from the centre's are skipped.
pub const BLUR_NORMAL_COS: f32 = 0.906_307_8;
/// The B3-spline kernel of the à-trous filter, one axis: taps `−2 ..= 2` (Dammertz et al.
/// 2010); the 5×5 weights are the products `B3[i] · B3[j]`.
pub const B3: [f32; 5] = [0.0625, 0.25, 0.375, 0.25, 0.0625];

/// The reduced-resolution gather's grid
/// ([`GatherParams::stride`](crate::program::GatherParams::stride),
/// [`Program::Upsample`](crate::program::Program::Upsample)).
///
/// With stride `s`, the grid texels are those whose column and row are multiples of `s`. A
/// texel `(x, y)` lies in the grid cell of corners `(x₀, y₀)`, `(x₀ + s, y₀)`, `(x₀, y₀ + s)`,
/// `(x₀ + s, y₀ + s)`, `x₀ = s·⌊x/s⌋`, with bilinear weights `(1 − fx)(1 − fy)` …, `fx = (x −
/// x₀)/s`. A corner counts when its weight is positive and it lies on the texel's surface: in
/// the layer, valid in the G-buffer, the texel's object, its normal within 25°
/// ([`BLUR_NORMAL_COS`]) and its position within `reach·|offset|` (the denoiser's chart test,
/// [`atrous_steps`](crate::program::atrous_steps)). A texel with counted corners is interpolated
/// from them; one without —
/// a chart narrower than the grid, a chart's rim — is an **orphan**: the gather traces it
/// itself, so no texel is left without light. A texel in a narrow gap (its position's w is
/// [`NARROW`](crate::validity::NARROW): it faces another surface a few texels away, where the
/// light changes faster than the grid) counts no corner and is an orphan too, grid texels
/// included. The gather and the upsample evaluate the same test on the same G-buffer, so they
/// agree on the orphans. Other grid texels count themselves (weight 1).
///
/// A grid texel's rays stand for its cell of `stride²` texels; an orphan lies in a strip
/// narrower than the grid (a chair leg's chart, a chart's corner) and stands for itself, so it
/// gets [`orphan_rays`](coarse::orphan_rays)`(rays, stride)` = ⌈rays / stride⌉: still more
/// rays per texel of surface than the grid's `rays / stride²`. A texel in a narrow gap gets the
/// grid's `rays`: the gap's light is gathered at full resolution, each texel with a grid texel's
/// rays (`docs/performance.md`, "Narrow gaps").
pub mod coarse {
    use super::TileParams;

    /// The grid texels of `tile` at `stride` as a compact tile: its texel `(i, j)` is the
    /// layout's texel `(i·stride, j·stride)` of the tile's layer, `x0 .. x0 + width` the grid
    /// columns and `y0 .. y0 + height` the grid rows the tile holds, `grid` the stride
    /// ([`TileParams::grid`]; the layer's size the tile's). `None` at stride 1 (or 0) or where
    /// the tile holds no grid texel.
    ///
    /// A GPU backend may gather a strided dispatch's grid texels in a dispatch of this size,
    /// every lane a grid texel, where one over the tile runs the grid texels' rays with a lane
    /// of every few busy, and gather the tile's other texels (the orphans) in one over the
    /// tile (docs/performance.md, "The strided gathers on a compact grid").
    pub fn grid_tile(tile: TileParams, stride: u32) -> Option<TileParams> {
        if stride <= 1 {
            return None;
        }
        let first = |v: u32| v.div_ceil(stride);
        let (i0, i1) = (first(tile.x0), first(tile.x0.saturating_add(tile.width)));
        let (j0, j1) = (first(tile.y0), first(tile.y0.saturating_add(tile.height)));
        (i1 > i0 && j1 > j0).then_some(TileParams {
            x0: i0,
            y0: j0,
            width: i1 - i0,
            height: j1 - j0,
            layer: tile.layer,
            layer_w: tile.layer_w,
            layer_h: tile.layer_h,
            grid: stride,
        })
    }

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
