//! # luxbake-backend-glow
//!
//! luxbake's OpenGL ES 3.0 / WebGL2 backend: the bake of Roth & Cords' *Texture-based Global
//! Illumination for Physics-Based Light Propagation in Interactive Web Applications* as GLSL ES
//! 3.00 fragment-shader passes over texture arrays, written with raw [`glow`] so that the same
//! code runs natively (headless, for tests and `cargo xtask bake --backend glow`) and in a
//! browser on WebGL2.
//!
//! [`GlowBackend`] implements [`luxbake::GpuBackend`]; [`luxbake::bake()`] drives it. It
//! executes the pass graph it is given, in order; it never decides the order.
//!
//! ```no_run
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! use luxbake::scene::Scene;
//! let mut backend = luxbake_backend_glow::GlowBackend::headless()?;
//! let scene = Scene::builtin("chairs_01")?;
//! let out = luxbake::bake(&mut backend, &scene, &scene.settings, &mut |_| {})?;
//! println!("{} texels baked", out.report.texels);
//! # Ok(())
//! # }
//! ```
//!
//! ## Programs and shaders (paper Figure 4)
//! The backend knows no pass kinds: it runs one `luxbake::program::Program` per
//! [`Dispatch`](luxbake::backend::Dispatch), binding what the program's
//! `luxbake::program::Signature` lists — its read slots as `u_<slot>` samplers, the scene
//! resources it needs, its parameter block field by field as `u_<field>` uniforms (types from
//! the block's fields). The GLSL sources are the core's (`crates/bake/src/passes/<pass>/<pass>.glsl`
//! beside the WGSL twin, libraries in `crates/bake/shaders/lib/`), compiled once per program
//! and traversal as `#version 300 es` + precision + `luxbake::shader::glsl_prefix` (generated
//! constants and declarations) + library files + the pass file:
//!
//! | box | program | reads (texture units) |
//! |---|---|---|
//! | 2 | direct: IES intensity × cos θ / d², shadow ray | position, normal, BVH (3), lamps, IES tables: 7 |
//! | 2→3, 6→7 | copy | source: 1 |
//! | 3, 7 | masked separable Gaussian, one axis | source, normal: 2 |
//! | 4, 8 | × albedo | source, albedo: 2 |
//! | 5 | gather: cosine-weighted rays, closest hit, masked bilinear look-up | position, normal, reflected map, BVH (3), regions: 7 |
//! | 6 | combine: direct + indirect | direct, indirect: 2 |
//!
//! Library files: `common.glsl` (helpers of `luxbake::cpu`), `rng.glsl` (`luxbake::rng`, bit
//! for bit), `scene.glsl` (ray epsilon, lamps, regions), `bvh.glsl` (`luxbake_bvh`'s CPU
//! traversal line for line), `ies.glsl` (`luxbake_ies::GpuTable::sample`, with f32
//! `acos`/`atan2` polynomials because driver versions are up to ~2000 ulps off on llvmpipe).
//! Every program computes exactly what the CPU reference (`luxbake::cpu`, the oracle)
//! documents, with the same f32 operations in the same order.
//!
//! ## Textures
//! Every graph texture is an RGBA32F `TEXTURE_2D_ARRAY` (one layer per light-map layer, maps in
//! sub-rectangles, alpha = texel mask), rendered one layer at a time with
//! `framebufferTextureLayer` and read only with `texelFetch`: no filtering and no wrap mode is
//! relied on; edges (layer borders, empty texels between charts, region borders in the gather's
//! look-up) are handled in the shaders. Texel `(x, y)` is fragment `(x + ½, y + ½)`; row 0 is
//! the first row in memory. Static scene data, uploaded once by `upload_scene`:
//! - BVH, exactly `luxbake_bvh::EncodedScene`'s texels: MTBVH links (6 layers), TBVH links
//!   (1 layer), node bounds (2 layers), triangles (8 layers); a node is one 2D texel coordinate
//!   in all of them. The texel-layout constants are `luxbake_bvh::layout::glsl_defines()`,
//!   prefixed at run time, so shader and encoder cannot drift.
//! - Intensity tables: one layer per lamp table, four table columns per texel.
//! - Regions: one column per object id, `(layer, x, y, receiver)` and `(width, height)`.
//! - Lamps: one column per uploaded lamp, the six rows of `luxbake::pack::lamp_rows`.
//!   Regions and lamps are packed by `luxbake::pack`, as for the wgpu backend.
//!
//! ## Kept gather hits
//! [`GlowBackend::keep_gather_hits`]: for a backend that bakes one room several times (a lamp
//! swap in the JavaScript package, `--lamp` repeated), each gather dispatch first casts its rays
//! in a trace pass (`passes/gather/trace.glsl`, up to four rays a draw, one colour attachment
//! each) that writes every ray's hit
//! `(t, triangle, u, v)` to a texture of the tile's size, and the gather compiled with
//! `LUX_REPLAY` reads them instead of traversing the BVH; a later bake of the same room reads the
//! kept textures and casts no gather ray. The maps are the same bit for bit
//! (the workspace harness's `tests/tests/gather_hits.rs`); 16 bytes per tile texel and ray ([`HIT_BYTES`]). The rules of
//! what may be read back are `luxbake::kept`'s.
//!
//! ## Traversal
//! MTBVH, TBVH or brute force ("no BVH"), chosen per pass (`PassDesc::bvh`) and compiled in
//! (`LUX_TRAVERSAL`), so each program contains one loop only.
//!
//! ## WebGL2 limits, asserted in code
//! At context creation the context must offer `EXT_color_buffer_float`
//! ([`GlowError::MissingExtension`] names it), 16 texture units, 256 array layers and 2048²
//! textures. The backend never uses more than WebGL2 guarantees whatever the context offers:
//! at most [`webgl2::TEXTURE_UNITS`] textures per pass (checked at every bind), at most
//! [`webgl2::ARRAY_LAYERS`] layers per array; texture sizes are bounded by the context's own
//! `MAX_TEXTURE_SIZE` (as the paper does), see [`Capabilities`].
//!
//! ## Tiles and progress
//! The driver (`luxbake::bake`) splits long passes into row tiles of about
//! [`DEFAULT_TILE_WORK`](luxbake::backend::DEFAULT_TILE_WORK) texel × ray evaluations
//! ([`GlowBackend::with_tile_work`]), one dispatch per tile: one draw (scissored) followed by
//! `glFinish`, then a progress report, so that a browser's GPU watchdog never sees a long draw. The random numbers
//! are a stateless hash of the texel, so tiling does not change any result.
//!
//! ## Strided gathers on a compact grid
//! A gather at reduced resolution (`GatherParams::stride` > 1: the converged presets' later
//! bounces, 16 rays on every fourth texel per axis) is drawn in two (wgpu dispatches it in
//! two the other way round, writing in place): first the tile's grid texels alone into a
//! texture of `1/stride²` the tile's size
//! ([`coarse::grid_tile`](luxbake::program::coarse::grid_tile)), every fragment a grid texel
//! with its rays, then the tile, whose grid texels copy those values and whose orphans and
//! narrow-gap texels gather as before. Over the whole tile, a grid texel's rays ran in a SIMD
//! group of which it was the only busy lane. The same random numbers and operations: the
//! maps are bit for bit those of one draw. With kept hits ([`GlowBackend::keep_gather_hits`])
//! each of the two keeps its own (`luxbake::kept::Part`).
//!
//! ## Contexts
//! Native: [`GlContext::headless`], EGL loaded at run time (`khronos-egl`, `dynamic`) on Mesa's
//! surfaceless platform (`EGL_PLATFORM_SURFACELESS_MESA`), an OpenGL ES 3.0 context without any
//! surface; on a machine without a GPU this is llvmpipe (`apt-get install libegl1
//! libgl1-mesa-dri`). wasm32: `GlContext::from_canvas` asks a canvas for `webgl2`,
//! `GlContext::from_offscreen_canvas` an `OffscreenCanvas` (in a Web Worker). The
//! `cfg(target_arch = "wasm32")` split is confined to the `context` module. A context is bound
//! to the thread that created it ([`GlContext`] is neither `Send` nor `Sync`).
//!
//! ## Errors
//! [`GlowError`]: shader compile and link failures name the pass and carry the driver's log and
//! the numbered source; GL errors name the pass and the operation.
//!
//! ## Agreement with the CPU reference (measured on llvmpipe)
//! The workspace harness (`tests/tests/cross_backend.rs`) bakes `chairs_01`, `floor` and `sphere` (and `chairs_01` with
//! the Sobol sampler) on every backend (12
//! texels/m, 16 rays, one bounce, σ = 2) and compares every Figure 5 stage: relative RMSE at
//! most 1.3e-7 and 99th-percentile relative error at most 3.7e-6 on every stage; the direct
//! maps of `floor` and `sphere` are bit-identical. The RNG is bit-exact, BVH hits are
//! bit-identical on 1,872 of 1,872 test rays per traversal, IES look-ups are within 4e-6 of a
//! table's maximum.
//!
//! ## Speed
//! `cargo xtask bench --backends glow` measures the paper's Table 1 on this backend (MTBVH,
//! TBVH and brute force, median and spread per pass, beside the CPU reference in the same
//! run); the latest figures are in `docs/performance.md`.
#![warn(missing_docs)]

mod backend;
mod context;
mod error;
mod gl;
mod scene;
mod shaders;

pub use backend::{GlowBackend, GlowScene, GlowTexture};
pub use context::{Capabilities, GlContext, webgl2};
pub use error::{GlowError, Result};
pub use luxbake::kept::{HIT_BYTES, KeptHitStats};

/// The GPU memory a browser worker's backend may keep for the gather hits of the rooms it
/// bakes ([`GlowBackend::keep_gather_hits`]; the JavaScript package and the viewer): 256 MiB.
/// `chairs_05` at 24 texels/m and the default preset keeps 75.5 MB.
pub const WEB_GATHER_HITS_BUDGET: u64 = 256 << 20;

#[cfg(test)]
mod testutil;
