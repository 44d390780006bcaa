//! # luxbake-backend-wgpu
//!
//! luxbake's wgpu backend: the paper's pass graph (Figure 4) as WGSL compute shaders, headless,
//! on any wgpu adapter — Mesa's lavapipe Vulkan driver in CI, a desktop GPU's Vulkan driver
//! elsewhere. It produces the same light maps as the CPU reference backend
//! ([`luxbake::cpu`], the oracle) and the glow backend, pass for pass; the workspace's
//! cross-backend harness (`tests/`) diffs every stage of every backend pair.
//!
//! ## Contract
//! [`WgpuBackend`] implements [`luxbake::GpuBackend`]: RGBA32F texture arrays (texels row 0
//! first, alpha = texel mask), one compute pipeline per pass kind and traversal, executed in
//! the graph's order. Each pass computes what `luxbake::cpu` documents, with the same f32
//! operations in the same order, the same RNG hash (`luxbake::rng`, bit-exact in `rng.wgsl`)
//! and the same acos/atan2 polynomials as the glow backend and the CPU
//! (`luxbake_ies::acos_f32` / `atan2_f32`; the driver's are far from exact).
//! Units are those of the core: lux before albedo, lm/m² after.
//!
//! ## Programs and shaders
//! The backend knows no pass kinds: it runs one `luxbake::program::Program` per
//! [`Dispatch`](luxbake::backend::Dispatch) and binds what the program's signature lists — its
//! read slots at group 0 bindings 0.., the output, the tile block and the program's parameter
//! block (bytes of its `#[repr(C)]` struct), and the scene (group 1) when the program needs it
//! — at the bindings of `luxbake::shader::wgsl`. The WGSL is the core's
//! (`crates/bake/src/passes/<pass>/<pass>.wgsl` beside the GLSL twin, libraries in
//! `crates/bake/shaders/lib/`), assembled by `luxbake::shader::wgsl_source` after a prefix
//! generated from the signature (slot bindings, parameter structs, BVH layout constants,
//! traversal and blur constants), so shader and Rust cannot drift; every module is validated with
//! naga in a unit test, and the parameter structs are checked field by field, offsets included,
//! against the Rust blocks. Lamps, regions and intensity tables are packed by `luxbake::pack`,
//! as for the glow backend. Programs are compute shaders (8 × 8 workgroups) that read inputs
//! with `textureLoad` and write one layer of a write-only `rgba32float` storage texture.
//!
//! ## BVH in storage buffers (measured choice)
//! The encoded BVH ([`luxbake_bvh::EncodedScene`]) is uploaded unchanged either as storage
//! buffers (`array<vec4<f32>>`, index `(layer·h + y)·w + x`) or as the paper's texture arrays
//! ([`BvhStorage`]). Both are implemented behind the same three fetch functions and give
//! bit-identical light maps (unit test). Measured with `benches/table1.rs` on lavapipe
//! (chairs_01, 64 texels/m, 16 rays, 2 shared cores): direct 1.25 s with buffers vs 1.45 s with
//! textures, gather 15.1 s vs 16.1 s. Buffers are faster (no texel-format conversion or
//! descriptor indirection per fetch in lavapipe), and WebGPU's storage-buffer limits (8 per
//! stage, 128 MiB per binding by default) are far above what a scene needs, so buffers are the
//! default.
//!
//! ## Long passes, progress, errors
//! The driver (`luxbake::bake`) splits a pass into row tiles of about
//! [`DEFAULT_TILE_WORK`](luxbake::backend::DEFAULT_TILE_WORK) texel × ray evaluations
//! ([`WgpuOptions::tile_work`]); each is one dispatch: one queue submission, waited for before
//! the next: no dispatch runs long enough for a GPU
//! watchdog, and `progress` is called after every tile. A missing adapter, a refused device,
//! a lost device, out-of-memory and validation failures are [`WgpuError`] values with a clear
//! message (error scopes around every call, a device-lost callback and an uncaptured-error
//! handler that only record), never panics.
//!
//! ## Strided gathers on a compact grid
//! A gather at reduced resolution (`GatherParams::stride` > 1: the converged presets' later
//! bounces, 16 rays on every fourth texel per axis) is dispatched in two: first over the tile
//! but for its grid texels (the orphans and narrow-gap texels; `TileParams::grid` 1), then over
//! the tile's compact grid ([`coarse::grid_tile`](luxbake::program::coarse::grid_tile),
//! `TileParams::grid` the stride), each invocation a grid texel with its rays, written in place.
//! Over the whole tile, a grid texel's rays ran in a SIMD group of which it was the only busy
//! lane. The same random numbers and operations: the maps are bit for bit those of one
//! dispatch. With kept hits ([`WgpuBackend::keep_gather_hits`]) each of the two keeps its own
//! (`luxbake::kept::Part`).
//!
//! ## Drivers and environment
//! - This build compiles wgpu's **Vulkan** backend only (lean: no GL, Metal or DX12 code).
//!   On Linux without a GPU, install Mesa's lavapipe: `apt-get install mesa-vulkan-drivers`
//!   (brings `libvulkan1`). `WGPU_BACKEND=vulkan` selects it explicitly; the adapter is
//!   `llvmpipe (LLVM …)`, device type `Cpu`.
//! - wgpu's **GL** backend (if a build enables wgpu's `gles` feature) picks desktop GL on Mesa,
//!   whose llvmpipe does not advertise `GL_ARB_color_buffer_float`, which wgpu requires to
//!   render to or store into `Rgba32Float`; run with
//!   `MESA_EXTENSION_OVERRIDE=+GL_ARB_color_buffer_float` there.
#![warn(missing_docs)]

mod backend;
mod device;
mod error;
mod scene;
mod shaders;

pub use backend::{WgpuBackend, WgpuOptions, WgpuScene, WgpuTexture};
pub use error::{Result, WgpuError};
pub use shaders::BvhStorage;
pub use wgpu;
