//! The interface every executor of a [`BakeGraph`](crate::graph::BakeGraph) implements.
//!
//! A backend owns textures (RGBA32F texture arrays, [`TexDesc`]) and the static scene data a
//! shader needs ([`SceneData`], uploaded once per bake), runs one [`Dispatch`] at a time — one
//! [`Program`] over one row tile of one layer — and reads texture layers back. It knows nothing
//! about pass kinds: what a program reads, which scene resources and which parameter block it
//! takes is its [`Signature`](crate::program::Signature); the order of the passes, their
//! tiling into dispatches ([`TilePlan`](crate::program::TilePlan)), progress and every binding
//! check are the [`bake`](crate::bake()) driver's, which is generic over the backend (static
//! dispatch); an enum of backends exists only at the edges (`luxbake-backends`).
//!
//! The shape follows what a WebGL2 fragment-shader implementation needs: a dispatch is one draw
//! into the written texture's layer, restricted to the tile's rows, reading the textures of the
//! program's slots, the scene data and uniforms; no pass reads a texture it writes. The program
//! semantics — bit for bit where they can be — are defined by the CPU reference backend
//! ([`crate::cpu`]).

use crate::opening::OpeningParams;
use std::sync::Arc;

use luxbake_bvh::{EncodedScene, WideBvh};
use luxbake_ies::GpuTable;

use crate::exact::{div, dot, sub};
use crate::graph::TexDesc;
use crate::layout::Region;
use crate::program::{Program, TileParams};
use crate::scene::BvhMode;

/// What a backend can do; the driver checks the layout and graph against it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// Largest texture width and height, texels.
    pub max_texture_size: u32,
    /// Most layers of one texture array.
    pub max_array_layers: u32,
    /// Most textures one pass may sample (WebGL2 guarantees 16).
    pub max_texture_units: u32,
    /// Most loop iterations one shader invocation runs, all its loops together, before the
    /// driver ends them silently (`None`: no such limit). Mesa's software drivers (llvmpipe
    /// for OpenGL ES, lavapipe for Vulkan) have one ([`MESA_LOOP_ITERATIONS`]): a texel whose
    /// rays or opening samples need more loses the rest, and its light reads low.
    pub loop_iterations: Option<u32>,
}

/// The loop limit of Mesa's software drivers: `LP_MAX_TGSI_LOOP_ITERATIONS` in gallivm,
/// "shared between every loop" of a shader invocation.
pub const MESA_LOOP_ITERATIONS: u32 = 65_535;

/// Most rays (or lamp paths) per texel a bake asks of one shader invocation before a
/// loop-limited driver ([`Limits::loop_iterations`]) may cut it short (the gathers stay under
/// it by passes of [`crate::graph::GATHER_CHUNK_RAYS`], the direct pass by passes of
/// [`crate::graph::DIRECT_CHUNK_SAMPLES`] opening samples):
/// each ray's traversal loops count too, so where it lies depends on the scene. Measured under
/// llvmpipe against the CPU backend, first bounce, raw: the box room (12 triangles) exact at
/// 512 rays, one texel 0.08 % off at 1 024, 70 % of the texels off by > 1 % (−3 % on average)
/// at 2 048; `chairs_05` at 16 texels/m (1 212 triangles, longer traversals) as at 32 rays up
/// to 256 (one chart's 14 texels differ from 32 rays on, brighter on the GPU: a cross-backend
/// gap, not a cut), then 28 % of its texels off at 512. So this bound keeps a factor 2–4 from
/// where furnished rooms start to lose rays.
pub const LOOP_LIMITED_SAMPLES: u32 = 128;

impl Limits {
    /// The [`crate::graph::GraphConfig::gather_chunk`] and
    /// [`crate::graph::GraphConfig::direct_chunk`] of a backend with these limits:
    /// [`crate::graph::GATHER_CHUNK_RAYS`] and [`crate::graph::DIRECT_CHUNK_SAMPLES`] where its
    /// driver cuts long shader loops ([`Limits::loop_iterations`]), else 0 (nothing split).
    pub fn loop_chunks(&self) -> (u32, u32) {
        if self.loop_iterations.is_some() {
            (
                crate::graph::GATHER_CHUNK_RAYS,
                crate::graph::DIRECT_CHUNK_SAMPLES,
            )
        } else {
            (0, 0)
        }
    }

    /// The minimums WebGL2 guarantees: 2048² textures, 256 array layers, 16 texture units,
    /// no loop limit.
    pub const WEBGL2: Limits = Limits {
        max_texture_size: 2048,
        max_array_layers: 256,
        max_texture_units: 16,
        loop_iterations: None,
    };

    /// The loop limit of the GPU driver named `renderer` (`GL_RENDERER`, or a Vulkan
    /// adapter's name): [`MESA_LOOP_ITERATIONS`] for Mesa's llvmpipe, lavapipe (whose
    /// adapter is named llvmpipe too) and softpipe, else `None`.
    pub fn loop_iterations_of(renderer: &str) -> Option<u32> {
        let r = renderer.to_ascii_lowercase();
        (r.contains("llvmpipe") || r.contains("softpipe") || r.contains("lavapipe"))
            .then_some(MESA_LOOP_ITERATIONS)
    }
}

/// One lamp as the direct pass sees it (a uniform block entry in a shader).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LampParams {
    /// Photometric centre, world metres.
    pub position: [f32; 3],
    /// Rows of the rotation from a world direction to the lamp's photometric frame
    /// (`Lamp::world_to_photometric_matrix`): `photometric = M · world`.
    pub world_to_photometric: [[f32; 3]; 3],
    /// Per-channel factor on the table's candela: `multiplier × colour`.
    pub scale: [f32; 3],
    /// Index of the lamp's table in [`SceneData::ies_tables`].
    pub table: u32,
    /// The luminous opening near which the lamp is not a point ([`crate::opening`]); `None`: a
    /// point everywhere.
    pub opening: Option<OpeningParams>,
}

/// A lamp seen unshadowed from a surface point ([`lamp_toward`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LampView {
    /// Distance squared to the lamp.
    pub d2: f32,
    /// Distance.
    pub d: f32,
    /// Unit direction from the point toward the lamp.
    pub w: [f32; 3],
    /// Cosine between the surface normal and `w`.
    pub cos: f32,
    /// Intensity toward the point, candela, before the lamp's scale.
    pub intensity: f32,
}

/// The unit direction from `p` toward `q`, the distance and its square; `None` when the
/// distance is 0 or not finite. The lamp's, an opening point's and a pool point's direction
/// (the shaders compute it with the same operations).
#[inline]
pub(crate) fn toward(p: [f32; 3], q: [f32; 3]) -> Option<([f32; 3], f32, f32)> {
    let to = sub(q, p);
    let d2 = dot(to, to);
    let d = d2.sqrt();
    (d > 0.0 && d.is_finite()).then(|| (div(to, d), d, d2))
}

/// `lamp` seen unshadowed from surface point `p` with unit normal `n`: `None` when the lamp
/// stands at `p`, behind the surface or dark toward it. The direct pass's; the shaders'
/// `luxLampToward` / `lux_lamp_toward` mirror it operation for operation.
pub fn lamp_toward(
    lamp: &LampParams,
    tables: &[GpuTable],
    p: [f32; 3],
    n: [f32; 3],
) -> Option<LampView> {
    let table = tables.get(lamp.table as usize)?;
    let (w, d, d2) = toward(p, lamp.position)?;
    let cos = dot(n, w);
    if cos.is_nan() || cos <= 0.0 {
        return None;
    }
    let back = [-w[0], -w[1], -w[2]];
    let m = &lamp.world_to_photometric;
    let intensity = table.sample([dot(m[0], back), dot(m[1], back), dot(m[2], back)]);
    if intensity.is_nan() || intensity <= 0.0 {
        return None;
    }
    Some(LampView {
        d2,
        d,
        w,
        cos,
        intensity,
    })
}

/// The scene's BVH, built once per room: the GPU backends upload `encoded`, the CPU backend
/// and the host steps walk `wide` (collapsed from the same tree).
#[derive(Debug, Clone)]
pub struct SceneBvh {
    /// The encoded BVH and triangle data (object id = index of the scene's object).
    pub encoded: Arc<EncodedScene>,
    /// Its 8-wide form for CPU traversal.
    pub wide: Arc<WideBvh>,
}

impl SceneBvh {
    /// Shares `encoded` and collapses it to its 8-wide form.
    pub fn new(encoded: EncodedScene) -> SceneBvh {
        let wide = Arc::new(WideBvh::from_encoded(&encoded));
        SceneBvh {
            encoded: Arc::new(encoded),
            wide,
        }
    }
}

/// The static scene data of a bake, uploaded once before the first pass.
#[derive(Debug, Clone, Copy)]
pub struct SceneData<'a> {
    /// The BVH, built once per room: the encoded BVH and triangle data textures (object id =
    /// index into `regions`), and its 8-wide form, which the CPU backend shares.
    pub bvh: &'a SceneBvh,
    /// The lamps a direct pass evaluates, in order (the driver uploads only the lamps that
    /// light something).
    pub lamps: &'a [LampParams],
    /// One resampled intensity table per lamp, candela, sampled with [`GpuTable::sample`].
    pub ies_tables: &'a [GpuTable],
    /// Per object: its light-map region, `None` for non-receivers (which reflect nothing).
    pub regions: &'a [Option<Region>],
    /// Layer size of every light-map texture array, texels.
    pub layer_size: [u32; 2],
    /// Layers of every light-map texture array.
    pub layers: u32,
    /// The size term of the ray-origin offset, world units: the half-extent of the scene's
    /// geometry × 2^-16 (see [`ray_epsilon`] and [`offset_origin`]). It does not depend on
    /// where the scene lies or where its lamps are.
    pub ray_epsilon: f32,
    /// The lamp paths' points ([`crate::lightpaths::LampPaths::packed`]): [`LAMP_PATH_TEXELS`]
    /// RGBA texels per point — (position.xyz, density), (normal.xyz, 0), (power.rgb, 0) —
    /// that the `connect` pass joins every texel to; empty without lamp paths.
    pub lamp_paths: &'a [f32],
}

/// RGBA texels of one lamp path's point in [`SceneData::lamp_paths`].
pub const LAMP_PATH_TEXELS: usize = 3;

/// ULPs per unit of normal component that [`offset_origin`] steps each coordinate: the
/// texel's position and the triangle's vertices are each rounded to f32 (half an ULP per
/// coordinate), and `Σ_c |n_c|·⌊4|n_c|⌋ ≥ Σ_c |n_c|` for every unit normal, so the step along
/// the normal covers that rounding. No more: at 10 km an axis-aligned wall's origin already
/// moves 4 mm, and a shadow edge on a grazing face moves with it.
pub const OFFSET_ULPS: f32 = 4.0;

/// Coordinates smaller than this are not stepped in ULP space by [`offset_origin`] (only
/// the size term moves them): so no step crosses zero or reaches subnormals.
pub const OFFSET_MIN_MAGNITUDE: f32 = 1e-30;

/// The size term of the ray offset for a scene whose geometry's bounding box has half-extent
/// `half_extent` (the largest of its three half-sizes; lamps are not geometry):
/// `half_extent × 2^-16`, at least `f32::MIN_POSITIVE` — for a scene centred on the origin
/// the same as the former global offset (largest coordinate × 2^-16), but it does not grow
/// when the scene lies far from the origin or a lamp lies far away. It covers the ray–triangle
/// test's rounding, which is relative to the distances from the origin to the vertices, and
/// keeps grazing gather rays clear of neighbouring triangles whose shading normal turns away.
pub fn ray_epsilon(half_extent: f32) -> f32 {
    let e = half_extent.abs() * (1.0 / 65_536.0);
    if e.is_finite() && e > f32::MIN_POSITIVE {
        e
    } else if e.is_finite() {
        f32::MIN_POSITIVE
    } else {
        f32::MAX * (1.0 / 65_536.0)
    }
}

/// One coordinate of [`offset_origin`].
#[inline]
pub fn offset_coordinate(p: f32, n: f32, size: f32) -> f32 {
    let q = p + n * size;
    let steps = (OFFSET_ULPS * n) as i32;
    // NaN, tiny and infinite coordinates are not stepped.
    if q.is_nan() || q.abs() < OFFSET_MIN_MAGNITUDE || q.is_infinite() {
        return q;
    }
    let bits = q.to_bits() as i32;
    f32::from_bits(if q < 0.0 {
        bits.wrapping_sub(steps)
    } else {
        bits.wrapping_add(steps)
    } as u32)
}

/// The ray origin for a surface point `p` with unit normal `n`: local, so a scene far from
/// the origin or a lamp far away does not widen it (Wächter & Binder, "A Fast and Robust
/// Method for Avoiding Self-Intersection", Ray Tracing Gems ch. 6, with an additive size
/// term). Per coordinate `c`: `q = p_c + n_c·size` (`size` = [`SceneData::ray_epsilon`],
/// the surface-size term), then `q` is stepped `trunc(OFFSET_ULPS·n_c)` ULPs away from or
/// toward zero along `n_c` in integer space (its bits ± the steps): it covers the rounding of
/// `p` and of the vertices, which grows with the coordinate's own magnitude. Coordinates
/// below [`OFFSET_MIN_MAGNITUDE`], and infinities, are not stepped. Every backend computes
/// it with the same operations (GLSL `floatBitsToInt`, WGSL `bitcast`).
#[inline]
pub fn offset_origin(p: [f32; 3], n: [f32; 3], size: f32) -> [f32; 3] {
    [
        offset_coordinate(p[0], n[0], size),
        offset_coordinate(p[1], n[1], size),
        offset_coordinate(p[2], n[2], size),
    ]
}

/// One program over one tile: what [`GpuBackend::dispatch`] runs.
#[derive(Debug)]
pub struct Dispatch<'a, T, S> {
    /// The pass label (for errors).
    pub label: &'static str,
    /// The program.
    pub program: Program,
    /// The traversal of a ray-casting program.
    pub bvh: BvhMode,
    /// The textures of the program's slots, in [`Signature::reads`](crate::program::Signature)
    /// order; the driver has checked their number and sizes.
    pub reads: &'a [&'a T],
    /// The written texture (never one of `reads`).
    pub write: &'a T,
    /// The uploaded scene.
    pub scene: &'a S,
    /// The words of the program's parameter block ([`ParamBlock`](crate::program::ParamBlock)),
    /// empty for programs without one.
    pub params: &'a [u32],
    /// The tile: rows of one layer of `write`.
    pub tile: TileParams,
    /// No texel of the tile does the pass's work: a refinement in narrow gaps alone
    /// ([`Params::gap_work`](crate::program::Params::gap_work)) over rows without a texel in a
    /// gap, where every texel writes what it reads, or a gather over rows without a valid
    /// texel ([`crate::program::RowKind::Empty`]), which writes 0 there. A backend may run the
    /// pass's idle program ([`Variant::Idle`](crate::kept::Variant::Idle)), which writes the
    /// same without the rays' code, and keeps no gather hits for it; the CPU backend computes
    /// the tile as any other.
    pub idle: bool,
    /// A texel of the tile may lie in a narrow region ([`crate::validity::NARROW`]: its
    /// position's w at least that): `true` unless the driver knows that none does. Where it is
    /// `false`, a strided gather's texels off its grid cast at most the orphans' rays
    /// ([`crate::contract::coarse::orphan_rays`]), and a backend keeps that many hits a texel
    /// for them ([`Part::Orphans`](crate::kept::Part::Orphans)) instead of a grid texel's.
    pub narrow: bool,
}

impl<T: PartialEq, S> Dispatch<'_, T, S> {
    /// The one binding check every backend runs before a dispatch: as many reads as the
    /// program has slots, none of them the target, every read of the target's size
    /// (`reads` and `target` are `(layer size, layers)`), the target of the scene's layer size
    /// (a reduction, [`Program::Energy`]: reads and target with as many layers, the target of
    /// any size), and the tile inside one layer of the target. The error says what is wrong.
    pub fn check(
        &self,
        target: ([u32; 2], u32),
        reads: &[([u32; 2], u32)],
        scene_layer_size: [u32; 2],
    ) -> Result<(), String> {
        let slots = self.program.signature().reads;
        if self.reads.len() != slots.len() || reads.len() != slots.len() {
            return Err(format!(
                "{} reads for the slots {slots:?}",
                self.reads.len()
            ));
        }
        if self.reads.contains(&self.write) {
            return Err("reads the texture it writes".into());
        }
        // A reduction ([`Program::Energy`]) writes a smaller target than it reads, with as
        // many layers.
        let reduces = self.program == Program::Energy;
        if let Some((i, r)) = reads.iter().enumerate().find(|(_, r)| {
            if reduces {
                r.1 != target.1
            } else {
                **r != target
            }
        }) {
            return Err(format!(
                "read `{}` is {:?} × {} layers, the target {:?} × {}",
                slots[i], r.0, r.1, target.0, target.1
            ));
        }
        let ([w, h], layers) = target;
        let t = self.tile;
        if (!reduces && [w, h] != scene_layer_size)
            || [t.layer_w, t.layer_h] != [w, h]
            || t.layer >= layers
            || t.x0.checked_add(t.width).is_none_or(|e| e > w)
            || t.y0.checked_add(t.height).is_none_or(|e| e > h)
        {
            return Err(format!(
                "tile {t:?} does not fit a target of {:?} × {layers} layers (scene layers {:?})",
                [w, h],
                scene_layer_size
            ));
        }
        Ok(())
    }
}

/// An executor of the pass graph.
///
/// Textures are created from [`TexDesc`]s, filled by [`upload`](Self::upload) (the G-buffer) or
/// by dispatches, and read back layer by layer. Texel data is RGBA32F, row 0 first, `4 × width
/// × height` floats per layer.
pub trait GpuBackend {
    /// A texture array handle.
    type Texture;
    /// The uploaded static scene data.
    type Scene;
    /// The backend's error.
    type Error: std::error::Error + Send + Sync + 'static;

    /// Short name for reports ("cpu", "glow", "wgpu").
    fn name(&self) -> &'static str;

    /// What this backend supports.
    fn limits(&self) -> Limits;

    /// Evaluations (texels × lamps, taps or rays) one dispatch should cover: the driver splits
    /// passes into row tiles of about this much work and reports progress after each.
    fn tile_work(&self) -> u64;

    /// Creates a zero-filled texture array.
    fn create_texture(&mut self, desc: &TexDesc) -> Result<Self::Texture, Self::Error>;

    /// Replaces one layer of `texture` with `texels` (`4 × width × height` floats).
    fn upload(
        &mut self,
        texture: &Self::Texture,
        layer: u32,
        texels: &[f32],
    ) -> Result<(), Self::Error>;

    /// Uploads the static scene data.
    fn upload_scene(&mut self, scene: &SceneData<'_>) -> Result<Self::Scene, Self::Error>;

    /// Runs `call.program` over `call.tile` and waits for it (honest progress, no unbounded
    /// queue of GPU work).
    fn dispatch(
        &mut self,
        call: &Dispatch<'_, Self::Texture, Self::Scene>,
    ) -> Result<(), Self::Error>;

    /// Reads one layer back (`4 × width × height` floats, row 0 first).
    fn read_back(&mut self, texture: &Self::Texture, layer: u32) -> Result<Vec<f32>, Self::Error>;

    /// Frees every texture and uploaded scene (their handles are not used again); what the
    /// backend compiled stays. The driver calls it when a bake's maps are read back, so that
    /// one backend bakes a room under many lamps without growing and without compiling its
    /// programs again.
    fn release(&mut self) -> Result<(), Self::Error>;
}

/// Default work per dispatch: texel × ray (or texel × tap) evaluations of one tile. About 2^20
/// keeps a GPU dispatch in the tens of milliseconds on a laptop GPU, far from a browser's GPU
/// watchdog (a few seconds), and gives a progress report every few hundred milliseconds on a
/// software rasteriser or the CPU.
pub const DEFAULT_TILE_WORK: u64 = 1 << 20;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mesa_software_drivers_have_a_loop_limit_and_a_bake_that_exceeds_it_says_so() {
        use crate::report::Skipped;
        use crate::scene::Settings;
        for r in ["llvmpipe (LLVM 15.0.6, 256 bits)", "softpipe", "lavapipe"] {
            assert_eq!(
                Limits::loop_iterations_of(r),
                Some(MESA_LOOP_ITERATIONS),
                "{r}"
            );
        }
        for r in [
            "NVIDIA GeForce RTX 4090",
            "ANGLE (Google, Vulkan 1.3.0 (SwiftShader Device))",
        ] {
            assert_eq!(Limits::loop_iterations_of(r), None, "{r}");
        }
        let mesa = Limits {
            loop_iterations: Some(MESA_LOOP_ITERATIONS),
            ..Limits::WEBGL2
        };
        let at = |lamp_paths: u32, opening_samples: u32, limits: &Limits| {
            let s = Settings {
                rays: 4096,
                lamp_paths,
                opening_samples,
                ..Settings::default()
            };
            Skipped::loop_limit(&s, limits)
        };
        // The presets stay within it, and the gathers' rays and the openings' samples are
        // split over passes there; many lamp paths are not, and only a limited driver warns.
        assert_eq!(at(12, 48, &mesa), None);
        assert_eq!(at(128, 128, &mesa), None);
        assert_eq!(at(12, 2048, &mesa), None, "opening samples are split");
        let warned = at(512, 48, &mesa).expect("512 lamp paths");
        assert_eq!(
            warned,
            Skipped::LoopLimit {
                samples: 512,
                limit: MESA_LOOP_ITERATIONS
            }
        );
        assert!(warned.to_string().contains("65535"), "{warned}");
        assert_eq!(at(1024, 1024, &Limits::WEBGL2), None);
    }

    #[test]
    fn the_binding_check_names_what_is_wrong() {
        use crate::program::{Program, TilePlan};
        let tile = TilePlan::new([8, 4], 2, 1, 1 << 20)
            .tiles()
            .next()
            .expect("tile");
        let call = |reads: &'static [&'static u32], write: &'static u32| Dispatch {
            label: "t",
            program: Program::Combine,
            bvh: BvhMode::None,
            reads,
            write,
            scene: &(),
            params: &[],
            tile,
            idle: false,
            narrow: true,
        };
        let target = ([8, 4], 2);
        let ok = call(&[&1, &2], &3);
        assert_eq!(ok.check(target, &[target; 2], [8, 4]), Ok(()));
        let e = |c: &Dispatch<'_, u32, ()>, reads: &[([u32; 2], u32)], scene| {
            c.check(target, reads, scene).expect_err("invalid")
        };
        assert!(e(&call(&[&1], &3), &[target], [8, 4]).contains("slots"));
        assert!(e(&call(&[&1, &3], &3), &[target; 2], [8, 4]).contains("it writes"));
        assert!(e(&ok, &[target, ([8, 4], 1)], [8, 4]).contains("`indirect`"));
        assert!(e(&ok, &[target; 2], [8, 8]).contains("does not fit"));
        let mut past = ok;
        past.tile.layer = 2;
        assert!(e(&past, &[target; 2], [8, 4]).contains("does not fit"));
    }

    #[test]
    fn the_offset_is_local_and_moves_along_the_normal() {
        let size = ray_epsilon(4.0);
        // Near the origin the size term dominates.
        let o = offset_origin([0.5, 0.0, -0.5], [0.0, 1.0, 0.0], size);
        assert_eq!((o[0], o[2]), (0.5, -0.5));
        assert!(o[1] > 0.0 && o[1] < 1.01 * size, "{o:?}");
        // 10 km out, a wall facing +x (and one facing -x at -10 km) moves 4 ULPs of 10⁴
        // (about 4 mm), and only along x; the floor at y = 0 moves by the size term alone.
        for (x, nx) in [(10_000.0f32, 1.0f32), (-10_000.0, -1.0), (10_000.0, -1.0)] {
            let o = offset_origin([x, 1.0, 10_000.0], [nx, 0.0, 0.0], size);
            let moved = (o[0] - x) * nx;
            assert!(moved > 0.0 && moved < 0.01, "{x} {nx}: {o:?}");
            assert_eq!((o[1], o[2]), (1.0, 10_000.0));
        }
        let o = offset_origin([10_000.0, 0.0, 10_000.0], [0.0, 1.0, 0.0], size);
        assert!(o[1] > 0.0 && o[1] < 1.01 * size, "{o:?}");
        // A tilted normal moves every coordinate it has a component along, the right way.
        let n = [0.6, -0.8, 0.0];
        let p = [-3.0, 2.0, 7.0];
        let o = offset_origin(p, n, size);
        assert!(o[0] > p[0] && o[1] < p[1] && o[2] == p[2], "{o:?}");
        // Tiny and non-finite coordinates stay finite or pass through.
        assert!(offset_origin([1e-35, 0.0, 0.0], [1.0, 0.0, 0.0], size)[0] > 0.0);
        assert!(offset_coordinate(f32::INFINITY, 1.0, size).is_infinite());
        assert!(offset_coordinate(f32::NAN, 1.0, size).is_nan());
    }

    #[test]
    fn epsilon_scales_with_the_scene_and_stays_finite() {
        assert_eq!(ray_epsilon(4.0), 4.0 / 65_536.0);
        assert_eq!(ray_epsilon(4.0e3), 1000.0 * ray_epsilon(4.0));
        assert!(ray_epsilon(0.0) > 0.0);
        assert!(ray_epsilon(f32::INFINITY).is_finite());
        assert!(ray_epsilon(f32::NAN).is_finite());
    }
}
