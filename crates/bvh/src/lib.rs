//! # luxbake-bvh
//!
//! A bounding volume hierarchy over triangles for stackless GPU ray tracing in WebGL2 fragment
//! shaders, after Roth & Cords §3.2 (Figures 8–10):
//!
//! 1. [`Bvh::build`] builds the one canonical binary BVH: top-down, binned surface area heuristic
//!    (Goldsmith & Salmon cost, [`BuildOptions`]). Nodes are stored in depth-first pre-order
//!    (left child = parent + 1), leaves hold contiguous ranges of a triangle permutation.
//! 2. [`Bvh::threaded_links`] derives the stackless link orders from it: the TBVH
//!    (Simonsen, Thrane, Ørbæk 2005; canonical child order, paper Figure 8) and the six MTBVH
//!    orders (Hachisuka 2015; one per dominant ray direction, near child first).
//! 3. [`encode`] packs everything into RGBA32F texel arrays ([`EncodedScene`]) laid out as
//!    documented in [`layout`]; the shader constants are generated from that module.
//! 4. [`EncodedScene::closest_hit`] / [`EncodedScene::any_hit`] walk the *encoded texels* on the
//!    CPU, written to mirror the GLSL ES 3.00 shader line for line. They are the oracle for every
//!    shader: a shader bug can be reproduced here.
//! 5. [`WideBvh::from_encoded`] collapses the same tree into an 8-wide BVH (AVX box tests where
//!    the CPU has them, else SSE, and SSE tests of four leaf triangles at once) for fast CPU
//!    traversal with the same triangle and slab arithmetic: the CPU backend's default.
//!
//! ```
//! use luxbake_bvh::{encode, BuildOptions, Bvh, EncodeOptions, Ray, Traversal, TriangleAttributes};
//!
//! let tris = [[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]];
//! let bvh = Bvh::build(&tris, &BuildOptions::default())?;
//! let attributes = [TriangleAttributes::default()];
//! let scene = encode(&bvh, &tris, &attributes, &EncodeOptions { max_texture_size: 4096 })?;
//! // scene.links, scene.tbvh_links, scene.bounds, scene.triangles: upload as RGBA32F arrays.
//! let ray = Ray { origin: [0.25, 0.25, 1.0], dir: [0.0, 0.0, -1.0] };
//! let hit = scene.closest_hit(&ray, 0.0, f32::INFINITY, Traversal::Mtbvh).expect("hit");
//! assert_eq!((hit.t, hit.u, hit.v), (1.0, 0.25, 0.25));
//! assert!(!scene.any_hit(&ray, 0.0, 0.5, Traversal::Tbvh)); // the triangle is at t = 1
//! # Ok::<(), luxbake_bvh::BvhError>(())
//! ```
//!
//! The TBVH links live in their own one-layer texture (`tbvh_links`) beside the paper's
//! six-layer MTBVH link array, so both traversals read the same node boxes.
//!
//! ## Builder choice
//! `obvhs` 0.4 (PLOC + reinsertion) was evaluated as the builder (`tests/models.rs`,
//! `benches/bvh.rs`, same cost constants, no spatial splits, ≤ 4 triangles per leaf): its trees'
//! SAH cost is within about ±8 % of ours (SheenChair: ours 29.8, obvhs medium preset 30.5;
//! GlamVelvetSofa 24.7 vs 25.8; the procedural room 24.0 vs 22.6) and it builds about 2–3×
//! faster. It is not used: it would bring glam, bytemuck, half and rdst into a crate meant to be
//! dependency-light, its node layout would need a conversion pass to the depth-first
//! pre-order the TBVH is defined on anyway, and the build (excluded from the paper's timings)
//! takes milliseconds here. `obvhs` stays a dev-dependency for comparison.
//!
//! ## Conventions
//! - Positions are `[f32; 3]` in any consistent unit (the bake uses metres); a triangle is three
//!   vertices `[[f32; 3]; 3]`. No handedness or winding is assumed: both faces are hit.
//! - Triangle indices returned by the traversal ([`Hit::triangle`]) are in the **encoded order**
//!   (the leaf order of the BVH); [`EncodedScene::triangle_order`] maps them back to input indices.
//! - A hit counts when its distance `t` lies in the open interval `(t_min, t_max)`, measured in
//!   units of the ray direction's length (the direction need not be normalised).
//! - Integers stored in `f32` texels (triangle indices, object ids) are exact only up to
//!   2^24 ([`layout::MAX_EXACT_INTEGER`]); [`encode`] checks this and fails with a clear error.
//!
//! ## Watertightness
//! The ray/triangle test is the watertight test of Woop, Benthin & Wald (2013) without the
//! double-precision fallback (GLSL ES has no doubles). Its edge functions are computed in the
//! same antisymmetric form for every edge, so a shared edge evaluates to exactly opposite values
//! in its two triangles and zero counts as inside: no ray slips between two triangles that share
//! an edge or a vertex. On the GPU this holds as long as the compiler does not contract the
//! edge-function products into fused multiply-adds differently for the two triangles.
//!
//! ## Slivers
//! A triangle whose vertices lie on a line up to a few roundings ([`is_sliver`]: height over its
//! longest edge at most [`SLIVER_HEIGHT_ULPS`] × `f32::EPSILON` × its largest coordinate
//! magnitude; a vertex that is the `f32` midpoint of the other two, a point, a segment) has no
//! area to hit, but a ray through or near its line gets edge functions that are all rounding
//! noise, and when they come out with one sign the watertight test reports a hit at a noise
//! `t`: on a seeded random scene, 0.12 outside the sliver's box, found by brute force and the
//! wide BVH and culled by the TBVH/MTBVH boxes (a shadow speck or light leak in a bake).
//! [`encode`] therefore stores a sliver's positions as its first vertex three times, which the
//! test rejects exactly (all edge functions `x·y − y·x` = 0, `det` = 0), for every traversal
//! alike since they all read these texels. The caller sees the same tree, triangle count,
//! order, leaf ranges and attributes; only [`EncodedScene::triangle_positions`] of a sliver
//! differs, and it is never hit. Other triangles' hits are unchanged bit for bit; a scene
//! without slivers encodes exactly as before (the shared models and the procedural room have
//! none: their thinnest triangles are over 1 000 such units high). On the GPU this relies on
//! the shader compiler not contracting the edge functions into fused multiply-adds, as
//! watertightness does.
//!
//! ## Traversal and its GLSL ES 3.00 mirror
//! | Rust here | GLSL ES 3.00 |
//! |---|---|
//! | `texel_fetch(&scene.bounds, scene.node_size, node, L)` (private helper) | `texelFetch(uBounds, ivec3(node, L), 0)` |
//! | `[f32; 3]`, `[f32; 4]`, `[i32; 2]` | `vec3`, `vec4`, `ivec2` |
//! | `v[k]` with `k: usize` from the ray setup | `v[k]` (dynamic vector index, allowed in ES 3.00) |
//! | `x as i32` | `int(x)` |
//! | `min`/`max`/`abs` helpers | `min`/`max`/`abs` |
//! | `while steps < node_count && node[0] >= 0` | `for (int s = 0; s < uNodeCount && node.x >= 0; ++s)` |
//!
//! There is no recursion, no stack and no `f64`: the state is the current node coordinate,
//! the closest distance so far and the closest triangle. The step bound `node_count` is never
//! reached by a valid encoding (each node is visited at most once per ray) and only guards
//! against corrupt data; the triangle range is clamped to `0 .. triangle_count` for the same
//! reason (so even corrupt textures cannot make a shader loop for long).
//!
//! ```glsl
//! // one traversal (closest hit; any hit returns at the first accepted triangle)
//! int layer = luxDominantDirection(dir);            // MTBVH; TBVH reads uTbvhLinks layer 0
//! LuxRay r = luxRaySetup(org, dir);                 // watertight shear + slab inverse
//! ivec2 node = ivec2(LUX_ROOT_X, LUX_ROOT_Y);
//! float closest = tMax; int best = -1; vec2 bary = vec2(0.0);
//! for (int s = 0; s < uNodeCount && node.x >= 0; ++s) {
//!     vec4 lo = texelFetch(uBounds, ivec3(node, LUX_BOUNDS_MIN_LAYER), 0);
//!     vec4 hi = texelFetch(uBounds, ivec3(node, LUX_BOUNDS_MAX_LAYER), 0);
//!     vec4 link = texelFetch(uLinks, ivec3(node, layer), 0);
//!     if (luxSlab(r, lo.xyz, hi.xyz, tMin, closest)) {
//!         int end = min(int(hi.w), uTriangleCount);
//!         for (int t = max(int(lo.w), 0); t < end; ++t) { /* luxTriangle(r, t, tMin, closest) */ }
//!         node = ivec2(link.xy);
//!     } else {
//!         node = ivec2(link.zw);
//!     }
//! }
//! ```
//!
//! The slab test ([`WatertightRay::hits_box`]) treats direction components with magnitude
//! below [`layout::PARALLEL_EPSILON`] (±0, subnormals) as parallel, deciding that axis by
//! whether the origin lies in the slab, so no infinite inverse or `0·∞ = NaN` ever arises (GLSL
//! `min`/`max` are undefined for NaN); it widens the box interval by [`layout::BOX_SLACK`]
//! relative on both ends. The triangle test is [`WatertightRay::hits_triangle`].
//!
//! `t_min`/`t_max`: a hit counts iff `t_min < t < t_max` (open interval; `t_max` may be
//! `f32::INFINITY`). Shadow rays use `t_max` = distance to the lamp (in direction lengths:
//! 1 for `dir = lamp − origin`) and a small `t_min` against self-intersection.

#![warn(missing_docs)]

mod build;
mod encode;
pub mod layout;
mod links;
mod sliver;
mod traverse;
mod wide;

pub use build::{BuildOptions, Bvh, Node, NodeKind, sah_cost};
pub use encode::{EncodeOptions, EncodedNode, EncodedScene, TextureSize, encode, texture_size};
pub use links::{ChildOrder, Link};
pub use sliver::{SLIVER_HEIGHT_ULPS, is_sliver};
pub use traverse::{
    Hit, LinkTexture, Ray, Traversal, TraversalStats, WatertightRay, dominant_direction,
};
pub use wide::WideBvh;

/// Per-triangle shading data carried into the triangle data textures.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct TriangleAttributes {
    /// Shading normal at each vertex (not necessarily normalised; stored as given).
    pub normals: [[f32; 3]; 3],
    /// Light-map UV at each vertex.
    pub uvs: [[f32; 2]; 3],
    /// Object id (index of the object's light map). At most [`layout::MAX_EXACT_INTEGER`].
    pub object: u32,
}

/// Everything that can go wrong building or encoding a BVH.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum BvhError {
    /// A vertex coordinate is NaN or infinite.
    #[error("triangle {triangle}: vertex {vertex} has a non-finite coordinate {position:?}")]
    NonFiniteVertex {
        /// Input index of the offending triangle.
        triangle: usize,
        /// Vertex 0, 1 or 2.
        vertex: usize,
        /// The vertex as given.
        position: [f32; 3],
    },
    /// A normal or UV is NaN or infinite.
    #[error("triangle {triangle}: non-finite normal or light-map UV")]
    NonFiniteAttribute {
        /// Input index of the offending triangle.
        triangle: usize,
    },
    /// An option is out of its valid range.
    #[error("invalid option `{name}`: {reason}")]
    InvalidOption {
        /// Name of the option field.
        name: &'static str,
        /// What is allowed.
        reason: &'static str,
    },
    /// The attribute slice does not have one entry per triangle.
    #[error("{attributes} triangle attributes given for {triangles} triangles")]
    AttributeCountMismatch {
        /// Number of triangles.
        triangles: usize,
        /// Number of attribute entries.
        attributes: usize,
    },
    /// The triangles passed to [`encode`] are not the ones the BVH was built from.
    #[error("the BVH was built over {bvh} triangles, but {given} were given")]
    TriangleCountMismatch {
        /// Triangle count of the BVH.
        bvh: usize,
        /// Triangle count given to `encode`.
        given: usize,
    },
    /// A triangle given to [`encode`] lies outside the leaf box that should contain it.
    #[error(
        "triangle {triangle} lies outside its BVH leaf: the BVH was built from other triangles"
    )]
    TriangleOutsideLeaf {
        /// Input index of the offending triangle.
        triangle: usize,
    },
    /// More triangles than integers that `f32` texels represent exactly.
    #[error(
        "{count} triangles exceed the limit of {max} (indices are stored exactly in f32 only up to 2^24)"
    )]
    TooManyTriangles {
        /// Number of triangles.
        count: usize,
        /// The limit.
        max: usize,
    },
    /// An object id exceeds the exact-integer range of `f32`.
    #[error(
        "triangle {triangle}: object id {object} exceeds {max} (ids are stored exactly in f32 only up to 2^24)"
    )]
    ObjectIdTooLarge {
        /// Input index of the offending triangle.
        triangle: usize,
        /// The object id.
        object: u32,
        /// The limit.
        max: u32,
    },
    /// The data does not fit in square-limited textures of the given maximum size.
    #[error("{what}: {count} texels per layer do not fit in a {max_size}×{max_size} texture")]
    TextureTooSmall {
        /// Which texture ("nodes" or "triangles").
        what: &'static str,
        /// Texels needed per layer.
        count: usize,
        /// The maximum texture width and height.
        max_size: u32,
    },
}
