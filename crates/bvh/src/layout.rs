//! Texel layout of an [`EncodedScene`](crate::EncodedScene): the single source of truth the
//! GLSL and WGSL shaders are generated from ([`glsl_defines`], [`wgsl_constants`]).
//!
//! All textures are RGBA32F, stored as `Vec<f32>`: layer after layer, each layer row-major with
//! row 0 first, 4 floats per texel. Texel `(x, y)` of layer `l` of a `w × h` texture starts at
//! float `((l·h + y)·w + x)·4`. In GLSL ES 3.00 each is a `sampler2DArray` read with
//! `texelFetch(tex, ivec3(x, y, l), 0)` (upload with `texImage3D(TEXTURE_2D_ARRAY, 0, RGBA32F,
//! w, h, layers, 0, RGBA, FLOAT, data)`), in WGSL a `texture_2d_array<f32>` read with
//! `textureLoad(tex, vec2<i32>(x, y), l, 0)`.
//!
//! ## Node textures (`node_size = [w, h]`, node `i` at texel `(i % w, i / w)`)
//! - **links** ([`LINK_LAYERS`] = 6 layers): layer `d` holds the MTBVH links for dominant
//!   direction `d` ([`DIR_POS_X`] … [`DIR_NEG_Z`]: +x, −x, +y, −y, +z, −z); texel =
//!   `(hit.x, hit.y, miss.x, miss.y)`, a node's texel coordinate, or [`END_LINK`] (−1) in
//!   both components to end the traversal.
//! - **tbvh_links** ([`TBVH_LINK_LAYERS`] = 1 layer): the same for the TBVH order (canonical
//!   depth-first, left child first: the hit link of inner node `i` is node `i + 1`).
//! - **bounds** ([`BOUNDS_LAYERS`] = 2 layers): layer [`BOUNDS_MIN_LAYER`] =
//!   `(min.x, min.y, min.z, first_tri)`, layer [`BOUNDS_MAX_LAYER`] =
//!   `(max.x, max.y, max.z, end_tri)`. A leaf's triangles are `first_tri .. end_tri` (encoded
//!   order). An inner node has `first_tri == end_tri` (an empty range; the value is the first
//!   triangle of its subtree), so the traversal needs no leaf flag: it always tests the range
//!   and then follows the hit link.
//!
//! The traversal starts at the root, texel [`ROOT_X`], [`ROOT_Y`] = (0, 0), in every layer.
//!
//! ## Triangle textures (`tri_size = [w, h]`, triangle `t` at texel `(t % w, t / w)`)
//! [`TRIANGLE_LAYERS`] = 8 layers:
//! [`TRI_P0_LAYER`], [`TRI_P1_LAYER`], [`TRI_P2_LAYER`] = vertex positions `(x, y, z, 0)`;
//! [`TRI_N0_LAYER`], [`TRI_N1_LAYER`], [`TRI_N2_LAYER`] = vertex normals `(x, y, z, 0)`;
//! [`TRI_UV01_LAYER`] = `(uv0.x, uv0.y, uv1.x, uv1.y)`;
//! [`TRI_UV2_OBJECT_LAYER`] = `(uv2.x, uv2.y, object, 0)`.
//!
//! Empty textures are never produced: a scene without triangles has a 1 × 1 triangle texture of
//! zeros and `triangle_count` 0.

/// Floats per RGBA32F texel.
pub const FLOATS_PER_TEXEL: usize = 4;
/// Largest integer that, and every integer below which, `f32` represents exactly: 2^24.
pub const MAX_EXACT_INTEGER: u32 = 1 << 24;
/// Value of both link components that ends the traversal.
pub const END_LINK: f32 = -1.0;
/// Root node texel x.
pub const ROOT_X: i32 = 0;
/// Root node texel y.
pub const ROOT_Y: i32 = 0;

/// Layers of the MTBVH link texture (one per dominant direction).
pub const LINK_LAYERS: u32 = 6;
/// Layers of the TBVH link texture.
pub const TBVH_LINK_LAYERS: u32 = 1;
/// Direction / link layer for rays going mainly towards +x.
pub const DIR_POS_X: u32 = 0;
/// Direction / link layer for rays going mainly towards −x.
pub const DIR_NEG_X: u32 = 1;
/// Direction / link layer for rays going mainly towards +y.
pub const DIR_POS_Y: u32 = 2;
/// Direction / link layer for rays going mainly towards −y.
pub const DIR_NEG_Y: u32 = 3;
/// Direction / link layer for rays going mainly towards +z.
pub const DIR_POS_Z: u32 = 4;
/// Direction / link layer for rays going mainly towards −z.
pub const DIR_NEG_Z: u32 = 5;

/// Layers of the bounds texture.
pub const BOUNDS_LAYERS: u32 = 2;
/// Bounds layer holding `(min.xyz, first_tri)`.
pub const BOUNDS_MIN_LAYER: u32 = 0;
/// Bounds layer holding `(max.xyz, end_tri)`.
pub const BOUNDS_MAX_LAYER: u32 = 1;

/// Layers of the triangle texture.
pub const TRIANGLE_LAYERS: u32 = 8;
/// Triangle layer: vertex 0 position.
pub const TRI_P0_LAYER: u32 = 0;
/// Triangle layer: vertex 1 position.
pub const TRI_P1_LAYER: u32 = 1;
/// Triangle layer: vertex 2 position.
pub const TRI_P2_LAYER: u32 = 2;
/// Triangle layer: vertex 0 normal.
pub const TRI_N0_LAYER: u32 = 3;
/// Triangle layer: vertex 1 normal.
pub const TRI_N1_LAYER: u32 = 4;
/// Triangle layer: vertex 2 normal.
pub const TRI_N2_LAYER: u32 = 5;
/// Triangle layer: light-map UVs of vertices 0 and 1.
pub const TRI_UV01_LAYER: u32 = 6;
/// Triangle layer: light-map UV of vertex 2, object id.
pub const TRI_UV2_OBJECT_LAYER: u32 = 7;

/// RGBA32F texels per node over all node textures: 6 MTBVH links, 1 TBVH link, 2 bounds (the
/// paper's 8 plus the TBVH link).
pub const TEXELS_PER_NODE: u32 = LINK_LAYERS + TBVH_LINK_LAYERS + BOUNDS_LAYERS;
/// RGBA32F texels per triangle (one per triangle layer).
pub const TEXELS_PER_TRIANGLE: u32 = TRIANGLE_LAYERS;

/// Ray direction components with magnitude below this (zero, ±0, subnormal) are treated as
/// parallel to the slab, so the slab test never forms an infinite inverse or `0·∞`.
pub const PARALLEL_EPSILON: f32 = f32::MIN_POSITIVE;
/// "Infinite" slab distance used for parallel axes (finite, so no NaN arises).
pub const BIG: f32 = f32::MAX;
/// Relative slack of the slab test: the box's entry distance is lowered by
/// `|t_near| · BOX_SLACK` and its exit distance raised by `|t_far| · BOX_SLACK`. Ize (2013)
/// shows 2·γ₃ ≈ 3.6e-7 on the exit suffices for the slab test to be consistent with itself;
/// the extra margin (2^-20 ≈ 9.5e-7, about 8 ulps) also covers most of the rounding of the
/// watertight triangle test's `t`, so a box is not culled by a closer hit that is only closer
/// by rounding. Boxes are accepted slightly too often, never too rarely.
pub const BOX_SLACK: f32 = 1.0 / (1u32 << 20) as f32;

/// A layout constant, for generating shader code.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Constant {
    /// An integer constant.
    Int(i64),
    /// A float constant.
    Float(f32),
}

/// `(name, Constant)` per layout constant: its name in shader code is `LUX_` + its name here.
macro_rules! constants {
    ($($kind:ident $name:ident),* $(,)?) => {
        &[$((concat!("LUX_", stringify!($name)), constants!(@value $kind $name))),*]
    };
    (@value Int $name:ident) => {
        Constant::Int($name as i64)
    };
    (@value Float $name:ident) => {
        Constant::Float($name)
    };
}

/// Every layout constant by the name it has in shader code (prefix `LUX_`).
pub const CONSTANTS: &[(&str, Constant)] = constants![
    Int MAX_EXACT_INTEGER,
    Float END_LINK,
    Int ROOT_X,
    Int ROOT_Y,
    Int LINK_LAYERS,
    Int TBVH_LINK_LAYERS,
    Int DIR_POS_X,
    Int DIR_NEG_X,
    Int DIR_POS_Y,
    Int DIR_NEG_Y,
    Int DIR_POS_Z,
    Int DIR_NEG_Z,
    Int BOUNDS_LAYERS,
    Int BOUNDS_MIN_LAYER,
    Int BOUNDS_MAX_LAYER,
    Int TRIANGLE_LAYERS,
    Int TRI_P0_LAYER,
    Int TRI_P1_LAYER,
    Int TRI_P2_LAYER,
    Int TRI_N0_LAYER,
    Int TRI_N1_LAYER,
    Int TRI_N2_LAYER,
    Int TRI_UV01_LAYER,
    Int TRI_UV2_OBJECT_LAYER,
    Int TEXELS_PER_NODE,
    Int TEXELS_PER_TRIANGLE,
    Float PARALLEL_EPSILON,
    Float BIG,
    Float BOX_SLACK,
];

/// Formats a float so that it parses back to the same `f32` and is a float literal in both
/// GLSL and WGSL (always has a `.` or an exponent).
fn float_literal(v: f32) -> String {
    let s = format!("{v:e}");
    // `{:e}` gives the shortest round-trip digits, e.g. "1.1754944e-38", "-1e0".
    match s.split_once('e') {
        Some((mantissa, exp)) if !mantissa.contains('.') => format!("{mantissa}.0e{exp}"),
        _ => s,
    }
}

/// `#define` lines for every layout constant, for GLSL ES 3.00 (no `#version` line).
pub fn glsl_defines() -> String {
    let mut out = String::from("// Generated by luxbake-bvh::layout::glsl_defines; do not edit.\n");
    for (name, value) in CONSTANTS {
        let value = match value {
            Constant::Int(i) => i.to_string(),
            Constant::Float(f) => float_literal(*f),
        };
        out.push_str(&format!("#define {name} {value}\n"));
    }
    out
}

/// `const` declarations for every layout constant, for WGSL (`i32` / `f32`).
pub fn wgsl_constants() -> String {
    let mut out =
        String::from("// Generated by luxbake-bvh::layout::wgsl_constants; do not edit.\n");
    for (name, value) in CONSTANTS {
        let line = match value {
            Constant::Int(i) => format!("const {name}: i32 = {i};\n"),
            Constant::Float(f) => format!("const {name}: f32 = {};\n", float_literal(*f)),
        };
        out.push_str(&line);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn float_literals_round_trip() {
        for (_, c) in CONSTANTS {
            if let Constant::Float(f) = c {
                let s = float_literal(*f);
                assert!(s.contains('.'), "{s}");
                assert_eq!(s.parse::<f32>().ok(), Some(*f), "{s}");
            }
        }
    }

    #[test]
    fn every_constant_is_emitted_once_per_language() {
        let glsl = glsl_defines();
        let wgsl = wgsl_constants();
        for (name, _) in CONSTANTS {
            assert_eq!(
                glsl.matches(&format!("#define {name} ")).count(),
                1,
                "{name}"
            );
            assert_eq!(
                wgsl.matches(&format!("const {name}: ")).count(),
                1,
                "{name}"
            );
        }
        assert_eq!(glsl.lines().count(), CONSTANTS.len() + 1);
        assert!(glsl.contains("#define LUX_LINK_LAYERS 6\n"));
        assert!(wgsl.contains("const LUX_TRIANGLE_LAYERS: i32 = 8;\n"));
    }

    #[test]
    fn layer_indices_are_distinct_and_in_range() {
        let dirs = [
            DIR_POS_X, DIR_NEG_X, DIR_POS_Y, DIR_NEG_Y, DIR_POS_Z, DIR_NEG_Z,
        ];
        let mut sorted = dirs;
        sorted.sort_unstable();
        assert_eq!(sorted, [0, 1, 2, 3, 4, 5]);
        assert!(dirs.iter().all(|&d| d < LINK_LAYERS));
        let tri = [
            TRI_P0_LAYER,
            TRI_P1_LAYER,
            TRI_P2_LAYER,
            TRI_N0_LAYER,
            TRI_N1_LAYER,
            TRI_N2_LAYER,
            TRI_UV01_LAYER,
            TRI_UV2_OBJECT_LAYER,
        ];
        let mut sorted = tri;
        sorted.sort_unstable();
        assert_eq!(sorted, [0, 1, 2, 3, 4, 5, 6, 7]);
        assert_eq!(tri.len() as u32, TRIANGLE_LAYERS);
        assert_ne!(BOUNDS_MIN_LAYER, BOUNDS_MAX_LAYER);
        const { assert!(BOUNDS_MIN_LAYER < BOUNDS_LAYERS && BOUNDS_MAX_LAYER < BOUNDS_LAYERS) };
    }

    #[test]
    fn max_exact_integer_is_the_f32_boundary() {
        let m = MAX_EXACT_INTEGER;
        assert_eq!(m as f32 as u32, m);
        assert_eq!((m - 1) as f32 as u32, m - 1);
        assert_ne!((m + 1) as f32 as u32, m + 1);
    }
}
