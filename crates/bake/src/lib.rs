//! # luxbake
//!
//! Physically based light-map baking for rooms lit by IES lamps, after Roth & Cords,
//! *Texture-based Global Illumination for Physics-Based Light Propagation in Interactive Web
//! Applications*: a lamp's photometric data in, light maps in lux out.
//!
//! ## Pipeline
//! [`bake()`] runs the paper's Figure 4 on any [`GpuBackend`], as prepare → build → execute →
//! collect:
//!
//! 1. **prepare** the room ([`Room::prepare`], host work that does not depend on the lamps):
//!    [`Layout`](layout::Layout) (per-object light-map regions in texture arrays) →
//!    [`rasterize`](gbuffer::rasterize) (G-buffer: world position, normal, albedo per texel) →
//!    one BVH build (`luxbake-bvh`, encoded for the GPU and collapsed for the CPU, shared by
//!    every host step and the CPU backend) → [`validity::unocclude`]; then the lamps
//!    ([`prepare::Lamps`]: tables, reach, lamp paths). Each host step is a typed node that
//!    declares what it depends on ([`prepare::HostNode`]);
//! 2. **build** the [`BakeGraph`]: the passes as plain data, each marked with whether it
//!    depends on the lamps, and the decisions (where the bounces stop, the tail's weight) as
//!    typed checks ([`graph::Check`]);
//! 3. **execute** it pass by pass on the backend;
//! 4. **collect** the maps: read back, cropped per object ([`report::BakeOutput`]).
//!
//! [`bake_room`] bakes a prepared room under other lamps without repeating its work;
//! [`layers::bake_layers`] keeps each lamp's light apart, so that dimming, tinting or switching
//! a lamp recombines the maps without a ray ([`layers::LampLayers::combine`]).
//! The passes' CPU references ([`cpu`]) are the oracle for GPU backends; the crate
//! `luxbake-backend-cpu` (formerly `luxbake::cpu::CpuBackend`) runs them as a backend, and the
//! crate `luxbake-output` (formerly `luxbake::output`) writes EXR/PNG/JSON files.
//!
//! ## The pass contract
//! Each computed pass runs a [`program::Program`] whose [`program::Signature`] is data: the
//! texture slots it reads, the scene resources it needs and its `#[repr(C)]` parameter block.
//! [`shader`] holds every program's GLSL and WGSL side by side (`src/passes/<pass>/`) and generates
//! their declarations from the signature; [`pack`] packs the scene resources for both GPU
//! backends. The driver validates the graph against the signatures, splits each pass into row
//! tiles ([`program::TilePlan`]) and calls [`GpuBackend::dispatch`] per tile: a backend binds
//! and dispatches, and knows no pass kinds.
//!
//! ## Crates, and the route of one bake
//! The workspace by concern (arrows: "depends on", pointing down to what is depended on):
//!
//! ```text
//!   xtask (CLI) · luxbake-js (npm) · luxbake-viewer (wasm) · luxbake-tests
//!        │ each bake goes through
//!        ▼
//!   luxbake-backends ───────────────▶ luxbake-backend-cpu, -glow, -wgpu
//!        │ (a backend by kind,            │ textures, bind and dispatch each pass's CPU
//!        │  the image diff)               │ reference, GLSL or WGSL
//!        ├──▶ luxbake-output              │ EXR / PNG / manifest of a bake
//!        │    luxbake-assets              │ glTF/OBJ in, light-map UVs, glTF out
//!        ▼                                ▼
//!   luxbake (this crate)  layout, G-buffer, the host nodes, one folder per pass (signature,
//!        │                parameters, CPU reference, shaders), the graph, the driver, the
//!        │                GpuBackend contract
//!        ▼
//!   luxbake-scene         Scene, Object, Mesh, Lamp, Settings + SettingsPatch; built-in rooms,
//!        │                scene files, procedural meshes (here as `scene` and `sources`)
//!        ▼
//!   luxbake-ies · luxbake-bvh   photometry (tables, openings) · SAH BVH, encodings, traversal
//! ```
//!
//! One bake, `cargo xtask bake room.toml --texels-per-metre 32`: xtask turns the flags into a
//! [`SettingsPatch`](scene::SettingsPatch) → `luxbake-scene` reads the file, applies the patch
//! to its `[settings]` and only then builds the objects (their chart padding follows the final
//! density), reading each lamp's file with `luxbake-ies` → [`bake()`]: prepare (the layout, the
//! G-buffer, one `luxbake-bvh` build, unocclusion, the lamps' tables, reach and paths) → build
//! the [`BakeGraph`] → execute it on the backend `luxbake-backends` opened (cpu here, or glow,
//! wgpu) → collect the maps → `luxbake-output` writes the EXRs, PNGs and `manifest.json`.
//!
//! ## Modules
//! Each imports only what lies below it (arrows: "imports"), and no files import each other in
//! a circle (a test of `xtask` checks every crate):
//!
//! ```text
//!   bake                         bake(), bake_room(): prepare → build → execute → collect
//!     │
//!     ▼
//!   execute, prepare             run a graph on a backend / the host nodes: Room, Lamps
//!     │
//!     ▼
//!   report, graph, cpu,          what a bake reports; the pass graph; the CPU reference;
//!   backend, validity,           the backend contract; unocclusion, lamp paths, layout,
//!   lightpaths, layout, gbuffer, G-buffer, map reading, the stateless random numbers
//!   map, rng, probe, series
//!     │
//!     ▼
//!   program, shader, pack        the pass contract's public path, the generated shader
//!     │                          prefixes and entry points, the scene resources packed
//!     ▼
//!   passes/<label>/              one folder per pass and the registry (Program, Params)
//!     │
//!     ▼
//!   contract                     signature, parameter blocks, scene needs, libraries
//! ```
//!
//! The pipeline never reads a scene file and the scene model imports no source and no writer,
//! so an engine can build a [`Scene`](scene::Scene) itself and call [`bake()`]. The scene
//! model and its sources were this crate's `scene` and `sources` modules: they are the crate
//! `luxbake-scene` now, re-exported under the same paths (`luxbake::scene::Scene`,
//! `luxbake::sources::scenefile`, …), so code written against them keeps working; the gather's
//! draws of a [`Sampler`](scene::Sampler) are [`rng::Draw`]'s.

//! ## Physics
//! - Surfaces are **Lambertian** (diffuse); no specular, no spectra: RGB is a lamp tint times
//!   an albedo, each channel baked independently.
//! - Light maps store **illuminance E in lux** (lm/m²) *before* albedo; the reflected maps
//!   store **exitance M = ρ·E** (lm/m²) *after* it. A Lambertian surface's luminance is `M/π`.
//! - **Direct**: `E = I(ω)·multiplier·colour·cos θ / d²` per lamp, `I` the lamp's intensity in
//!   candela toward the texel (its IES table, bilinear, in the lamp's photometric frame), θ the
//!   angle between the surface normal and the direction to the lamp, `d` the distance, times a
//!   shadow ray (any hit between texel and lamp). Ray origins are offset locally
//!   ([`backend::offset_origin`]): a size term from the extent of the scene's geometry
//!   ([`backend::ray_epsilon`]) plus a few ULPs of the texel's own coordinates, and at most a
//!   quarter of the lamp distance, so scenes in millimetres or kilometres, far from the origin
//!   or with lamps far away, lamps 1 mm from a wall and grazing angles all work; `d²` is
//!   floored at the texel's offset squared (the same rule in every backend) and every map value
//!   is guarded (no NaN or infinity is ever stored). A scene far from the origin is baked moved
//!   next to it ([`bake::recentring_shift`]): the maps do not depend on where it stands.
//!   Object translations and lamp positions are f64 (scene-file numbers are kept as read), so
//!   a room placed at 10 km keeps its millimetres and bakes exactly like the room at the origin.
//!   Near a lamp with a size (a linear pendant over a table, a box pendant under the ceiling)
//!   the light comes from its file's luminous opening instead, uniform luminance
//!   `I(ω)/A_proj(ω)` on its emitting faces sampled with a shadow ray each ([`opening`],
//!   [`scene::LampModel`]): where the scene needs it, so a scene of small lamps costs what it
//!   did.
//! - **Indirect**: per texel, N cosine-weighted hemisphere rays; at each closest hit the hit
//!   object's reflected map is read (masked bilinear, [`map`]) at the hit's light-map UV.
//!   With `L = M/π` and cosine-weighted sampling, `E_ind = π·mean(L) = mean(M_hit)`. Back-face
//!   hits (the ray meets the side the shading normal points away from), misses and hits on
//!   non-receivers contribute 0. A texel facing a surface a few centimetres away (a narrow
//!   gap, [`validity`]) draws its rays uniformly instead, each weighted by `2 cos θ`, so that
//!   the grazing directions along the gap, its only view of the lit room, are drawn 19 times
//!   as often ([`lightpaths::gather_weight`]). The directions come from the stateless random numbers of
//!   [`rng`]: the paper's independent hash per ray, or a scrambled Sobol sequence whose error
//!   falls faster with N, shared by blocks of 2 × 2 texels whose directions it stratifies
//!   against one another ([`scene::Settings::sampler`], [`rng::Stream`]). The converged method's
//!   first bounce also connects each texel to points lit by the lamps and weights both
//!   estimates by multiple importance sampling ([`lightpaths`], [`scene::Settings::lamp_paths`]).
//! - **Bounces**: `ind_k = gather(ρ × blur(direct + ind_{k−1}))`, `ind_0 = 0`, and
//!   `combined = direct + ind_k`: a Jacobi iteration. For a closed sphere of albedo ρ with an
//!   isotropic lamp of intensity I at its centre it gives `E = (I/R²)·Σ_{i=0..k} ρ^i`.
//! - **Blur**: separable Gaussian in texels over valid texels of the same object (and facing
//!   within 25°) only, with renormalised weights: the empty texels between UV charts do not
//!   bleed in, which removes the paper's black seams. Order as in the paper: direct → copy →
//!   blur → ×albedo → gather → combine → blur → ×albedo. `blur = none` disables it.
//! - **Denoising** (the converged method, after the bounces): an edge-stopping à-trous wavelet
//!   filter of the indirect illuminance guided by world position, normal and object, with a
//!   robust per-texel estimate of the noise variance ([`program::atrous_steps`] lists its
//!   passes and derives it; [`cpu`] specifies them). It never mixes objects or charts and
//!   returns a constant field exactly.
//!
//! ## Conventions
//! Right-handed, +Y up, metres; the lamp frame and light-map UV conventions are in [`scene`].
//! Texture arrays are RGBA32F, row 0 first; light-map texture alpha is the texel mask.

#![warn(missing_docs)]

pub mod backend;
pub mod bake;
pub mod contract;
pub mod cpu;
pub mod exact;
mod execute;
pub mod gbuffer;
pub mod graph;
pub mod kept;
pub mod layers;
pub mod layout;
pub mod lightpaths;
pub mod map;
pub mod opening;
pub mod pack;
pub mod passes;
pub mod prepare;
pub mod probe;
pub mod program;
pub mod report;
pub mod rng;
pub mod series;
pub mod shader;
pub mod validity;

pub use luxbake_scene as scene;
pub use luxbake_scene::sources;

pub use backend::{GpuBackend, Limits};
pub use bake::{
    BakeError, BakeOutput, BakeReport, DirectStage, Progress, ReadBack, bake, bake_room,
    bake_room_direct_first, bake_room_reading,
};
pub use graph::BakeGraph;
pub use prepare::Room;
