//! [`GlowBackend`]: the context, its texture arrays, its pass programs, and the
//! [`GpuBackend`] implementation that runs each pass of the graph as fragment-shader draws.

use std::collections::HashMap;

use glow::HasContext;
use luxbake::backend::{DEFAULT_TILE_WORK, Dispatch, GpuBackend, Limits, SceneData};
use luxbake::graph::TexDesc;
use luxbake::kept::{self, HitKey, KeptHitStats, KeptHits, Part, Uploads, Variant};
use luxbake::program::{GatherParams, ParamBlock, Scalar, TileParams, coarse};
use luxbake::scene::BvhMode;
use luxbake::shader::{glsl_param, glsl_slot, glsl_variant, program_traversal};

use crate::context::{Capabilities, GlContext};
use crate::error::{GlowError, Result};
use crate::gl::{MAX_ATTACHMENTS, Program, Target, TextureArray, check};
use crate::scene::GpuScene;
use crate::shaders::Pass;

/// A texture array owned by a [`GlowBackend`] (a handle; the backend frees the GL object when
/// it is dropped).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct GlowTexture(usize);

/// The static scene data of a bake on the GPU (a handle; the textures belong to the backend).
#[derive(Debug)]
pub struct GlowScene(usize);

/// A draw's hit texture: the one a trace pass writes `rays` of, or the one the replay reads;
/// `origin` the tile's first texel.
struct Hits<'a> {
    texture: &'a TextureArray,
    origin: [u32; 2],
    rays: u32,
}

/// How a gather draw uses the compact grid of a strided gather ([`coarse::grid_tile`]): the
/// uniforms `u_grid`, `u_grid_origin`, `u_from_grid` and the sampler `u_grid_values` of
/// `coarse.glsl` and `gather.glsl`.
#[derive(Clone, Copy)]
enum GridUse<'a> {
    /// Any draw but a strided gather's.
    None,
    /// A strided gather's grid texels alone: the compact tile whose first grid column and row
    /// are `origin`, at `stride`.
    Draw { stride: u32, origin: [u32; 2] },
    /// The strided gather's tile: its grid texels copied from `values` (the compact tile whose
    /// first grid column and row are `origin`), the orphans gathered.
    From {
        origin: [u32; 2],
        values: &'a TextureArray,
    },
}

/// The glow backend: a GL context, the RGBA32F texture arrays of a bake, the uploaded scene
/// data and one program per pass kind (and traversal), compiled on first use.
pub struct GlowBackend {
    ctx: GlContext,
    target: Target,
    textures: Vec<(String, TextureArray)>,
    scenes: Vec<GpuScene>,
    /// Per uploaded scene, the address of its BVH object (what kept hits are cast in).
    scene_bvh: Vec<usize>,
    programs: HashMap<(Pass, BvhMode, Variant), Program>,
    tile_work: u64,
    /// With kept gather hits: per texture, the hash of each layer's upload (`None` until
    /// uploaded, or once a pass writes the texture).
    uploads: Uploads,
    /// The gather hits kept from bake to bake ([`GlowBackend::keep_gather_hits`]).
    kept: Option<KeptHits<TextureArray>>,
}

impl std::fmt::Debug for GlowBackend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GlowBackend")
            .field("ctx", &self.ctx)
            .field("textures", &self.textures.len())
            .field("scenes", &self.scenes.len())
            .field("programs", &self.programs.len())
            .field("tile_work", &self.tile_work)
            .finish_non_exhaustive()
    }
}

impl GlowBackend {
    /// A backend on a headless EGL context (native only).
    ///
    /// # Errors
    /// See [`GlContext::headless`].
    #[cfg(not(target_arch = "wasm32"))]
    pub fn headless() -> Result<Self> {
        Self::new(GlContext::headless()?)
    }

    /// A backend on an existing context.
    ///
    /// # Errors
    /// GL object creation failures.
    pub fn new(ctx: GlContext) -> Result<Self> {
        let target = Target::new(ctx.gl()?)?;
        Ok(Self {
            ctx,
            target,
            textures: Vec::new(),
            scenes: Vec::new(),
            scene_bvh: Vec::new(),
            programs: HashMap::new(),
            tile_work: DEFAULT_TILE_WORK,
            uploads: Uploads::default(),
            kept: None,
        })
    }

    /// Keeps the gather rays' hits from bake to bake, up to `budget` bytes (`luxbake::kept`):
    /// a later bake of the same prepared room (another lamp, a swap) reads them instead of
    /// traversing the BVH, with the same maps. For a backend that bakes one room several
    /// times (the JavaScript package's rooms, `--lamp` repeated); a single bake would pay the
    /// hit textures' memory and writes for nothing. A room's hits stay while the room (its
    /// BVH) exists and the backend lives, [`GpuBackend::release`] keeps them; a new call
    /// frees them and starts empty.
    ///
    /// # Errors
    /// Without a current context, when kept hits are to be freed.
    pub fn keep_gather_hits(&mut self, budget: u64) -> Result<()> {
        self.free_kept()?;
        self.kept = Some(KeptHits::new(budget));
        Ok(())
    }

    /// What the kept gather hits hold and served ([`GlowBackend::keep_gather_hits`]; `None`
    /// without).
    pub fn gather_hit_stats(&self) -> Option<KeptHitStats> {
        self.kept.as_ref().map(KeptHits::stats)
    }

    /// Frees the kept hits of rooms that no longer exist (they also go at the next scene
    /// upload): for a caller that drops a room and may not bake again soon.
    ///
    /// # Errors
    /// Without a current context, when kept hits are to be freed.
    pub fn free_dropped_hits(&mut self) -> Result<()> {
        let freed = self.kept.as_mut().map(KeptHits::prune);
        self.delete(freed.unwrap_or_default())
    }

    /// Frees every kept hit texture.
    fn free_kept(&mut self) -> Result<()> {
        let freed = self.kept.as_mut().map(KeptHits::drain);
        self.delete(freed.unwrap_or_default())
    }

    /// Deletes `textures` (kept hits let go of).
    fn delete(&self, textures: Vec<TextureArray>) -> Result<()> {
        if !textures.is_empty() {
            let gl = self.ctx.gl()?;
            for t in textures {
                t.delete(gl);
            }
        }
        Ok(())
    }

    /// Sets the work per draw (texel × ray evaluations, at least 1): the driver splits long
    /// passes into row tiles of about this much work, each a separate draw followed by a
    /// progress report.
    pub fn with_tile_work(mut self, work: u64) -> Self {
        self.tile_work = work.max(1);
        self
    }

    /// The context's capabilities.
    pub fn capabilities(&self) -> &Capabilities {
        self.ctx.capabilities()
    }

    fn scene(&self, scene: &GlowScene) -> Result<&GpuScene> {
        self.scenes
            .get(scene.0)
            .ok_or_else(|| GlowError::InvalidInput(format!("unknown scene {scene:?}")))
    }

    fn texture(&self, tex: &GlowTexture) -> Result<&(String, TextureArray)> {
        self.textures
            .get(tex.0)
            .ok_or_else(|| GlowError::InvalidInput(format!("unknown texture {tex:?}")))
    }

    /// Compiles (once) the program `variant` of `pass` for `traversal`.
    fn compile(&mut self, pass: Pass, traversal: BvhMode, variant: Variant) -> Result<()> {
        let key = (pass, traversal, variant);
        if !self.programs.contains_key(&key) {
            let (prefix, sources) = glsl_variant(pass, traversal, variant);
            let program = Program::new(self.ctx.gl()?, &variant.label(pass), &prefix, &sources)?;
            self.programs.insert(key, program);
        }
        Ok(())
    }

    /// The key of `part` of a gather dispatch's hits, over `tile` (the call's, or for
    /// [`Part::Grid`] its compact grid's), where they can be kept: with kept hits on, the
    /// gather reading uploaded position and normal maps, at least one ray and at most as many
    /// as a texture has layers (an idle gather is a clear, [`GpuBackend::dispatch`]).
    fn hit_key(
        &self,
        call: &Dispatch<'_, GlowTexture, GlowScene>,
        traversal: BvhMode,
        tile: TileParams,
        part: Part,
    ) -> Option<HitKey> {
        if call.program != Pass::Gather || self.kept.is_none() || !kept::replayable(call.params) {
            return None;
        }
        // Read slots 0 and 1 are the position and normal maps.
        let gbuffer = [
            self.uploads.hash(call.reads.first()?.0)?,
            self.uploads.hash(call.reads.get(1)?.0)?,
        ];
        let scene = self.scenes.get(call.scene.0)?;
        let bvh = *self.scene_bvh.get(call.scene.0)?;
        let key = HitKey::new(
            bvh,
            scene.ray_epsilon,
            traversal,
            call.params,
            call.tile,
            gbuffer,
        )
        .part(part, [tile.width, tile.height]);
        let layers = self
            .ctx
            .capabilities()
            .max_array_layers
            .min(crate::webgl2::ARRAY_LAYERS);
        (key.rays() > 0 && key.rays() <= layers).then_some(key)
    }

    /// One draw of `variant` of the call's program into `layers` of `out` (`None`: the call's
    /// tile of the texture it writes), restricted to `rect`, with the call's reads, scene and
    /// `params`; `hits`: the replay's kept hits, or what the trace writes; `grid`: a strided
    /// gather's use of its compact grid. With `finish`, waits for it.
    #[allow(clippy::too_many_arguments)]
    fn draw(
        &self,
        call: &Dispatch<'_, GlowTexture, GlowScene>,
        traversal: BvhMode,
        variant: Variant,
        out: Option<(&TextureArray, &[u32])>,
        rect: [u32; 4],
        params: &[u32],
        hits: Option<Hits<'_>>,
        grid: GridUse<'_>,
        finish: bool,
    ) -> Result<()> {
        let (label, sig) = (call.label, call.program.signature());
        let gpu_scene = self.scene(call.scene)?;
        let gl = self.ctx.gl()?;
        let mut samplers: Vec<(String, &TextureArray)> = sig
            .reads
            .iter()
            .zip(call.reads)
            .map(|(slot, t)| Ok((glsl_slot(slot), &self.texture(t)?.1)))
            .collect::<Result<_>>()?;
        if sig.scene.bvh {
            samplers.extend(
                gpu_scene
                    .bvh
                    .samplers(traversal)
                    .into_iter()
                    .map(|(n, tex)| (n.to_owned(), tex)),
            );
        }
        if sig.scene.lamps {
            samplers.push(("u_lamps".into(), &gpu_scene.lamps));
            samplers.push(("u_ies".into(), &gpu_scene.ies));
        }
        if sig.scene.regions {
            samplers.push(("u_regions".into(), &gpu_scene.regions));
        }
        if sig.scene.lamp_paths {
            samplers.push(("u_path_points".into(), &gpu_scene.lamp_paths));
        }
        if let (Variant::Replay, Some(h)) = (variant, &hits) {
            samplers.push(("u_hits".into(), h.texture));
        }
        if call.program == Pass::Gather {
            // Bound in every gather draw (read only with `u_from_grid` 1).
            let values = match grid {
                GridUse::From { values, .. } => values,
                _ => samplers.first().map(|(_, tex)| *tex).ok_or_else(|| {
                    GlowError::InvalidInput(format!("pass `{label}`: no position map"))
                })?,
            };
            samplers.push(("u_grid_values".into(), values));
        }
        let program = self
            .programs
            .get(&(call.program, traversal, variant))
            .ok_or_else(|| GlowError::InvalidInput("program cache".into()))?;
        let named: Vec<(&str, &TextureArray)> =
            samplers.iter().map(|(n, tex)| (n.as_str(), *tex)).collect();
        let t = call.tile;
        match out {
            Some((out, layers)) => self.target.bind_layers(gl, label, out, layers)?,
            None => self
                .target
                .bind(gl, label, &self.texture(call.write)?.1, t.layer)?,
        }
        program.use_with(gl, label, &named)?;
        program.set_i32(gl, "u_layer", i32::try_from(t.layer).unwrap_or(i32::MAX));
        if let Some(h) = &hits {
            let at = |v: u32| i32::try_from(v).unwrap_or(i32::MAX);
            program.set_ivec2(gl, "u_hit_origin", h.origin.map(at));
            program.set_u32(gl, "u_hit_rays", h.rays);
        }
        if call.program == Pass::Gather {
            let at = |v: u32| i32::try_from(v).unwrap_or(i32::MAX);
            let (stride, origin, from) = match grid {
                GridUse::None => (0, [0, 0], 0),
                GridUse::Draw { stride, origin } => (stride, origin, 0),
                GridUse::From { origin, .. } => (0, origin, 1),
            };
            program.set_i32(gl, "u_grid", at(stride));
            program.set_ivec2(gl, "u_grid_origin", origin.map(at));
            program.set_i32(gl, "u_from_grid", from);
        }
        if sig.scene.bvh {
            gpu_scene.bvh.set_uniforms(gl, program);
            program.set_f32(gl, "u_ray_epsilon", gpu_scene.ray_epsilon);
        }
        for (field, &word) in sig.params.iter().zip(params) {
            let name = glsl_param(field);
            match field.ty {
                Scalar::U32 => program.set_u32(gl, &name, word),
                Scalar::I32 => program.set_i32(gl, &name, word as i32),
                Scalar::F32 => program.set_f32(gl, &name, f32::from_bits(word)),
            }
        }
        self.target.draw(gl, label, rect)?;
        if finish {
            // Wait for the tile: honest progress and timings, and no unbounded queue of GPU
            // work.
            // SAFETY: glFinish has no preconditions.
            unsafe { gl.finish() };
            // WebGL's `finish` need not wait (browsers run the GPU work in another process):
            // reading one texel of the tile back does.
            #[cfg(target_arch = "wasm32")]
            self.target.wait(gl, label, [rect[0], rect[1]])?;
        }
        check(gl, label, "finishing a tile")
    }

    /// Draws the call over `tile` — its own tile into the texture it writes (`out` `None`),
    /// or a strided gather's compact grid into layer 0 of `out` — with the call's program,
    /// or for a gather whose hits are kept, their trace (once) and replay.
    fn gather_or_draw(
        &mut self,
        call: &Dispatch<'_, GlowTexture, GlowScene>,
        trav: BvhMode,
        tile: TileParams,
        out: Option<&TextureArray>,
        grid: GridUse<'_>,
    ) -> Result<()> {
        let t = tile;
        // Where the draw writes, and the tile's first texel there (what the hits are placed
        // by).
        let (target, rect, origin) = match out {
            None => (None, [t.x0, t.y0, t.width, t.height], [t.x0, t.y0]),
            Some(out) => (Some((out, &[0u32][..])), [0, 0, t.width, t.height], [0, 0]),
        };
        let part = match grid {
            GridUse::None => Part::Whole,
            GridUse::Draw { .. } => Part::Grid,
            GridUse::From { .. } if call.narrow => Part::Rest,
            GridUse::From { .. } => Part::Orphans,
        };
        let key = self
            .hit_key(call, trav, tile, part)
            .filter(|k| self.kept.as_ref().is_some_and(|kept| kept.usable(k)));
        let Some(key) = key else {
            let variant = Variant::plain_or_idle(call.program, call.idle);
            self.compile(call.program, trav, variant)?;
            return self.draw(
                call,
                trav,
                variant,
                target,
                rect,
                call.params,
                None,
                grid,
                true,
            );
        };
        self.compile(call.program, trav, Variant::Replay)?;
        if self.kept.as_ref().is_some_and(|k| k.get(&key).is_none()) {
            // Trace the dispatch's rays once, one layer of hits per ray.
            self.compile(call.program, trav, Variant::Trace)?;
            let gl = self.ctx.gl()?;
            let hits = TextureArray::new(gl, "gather hits", t.width, t.height, key.rays())?;
            let mut params = GatherParams::from_words(call.params);
            let first = params.first_ray;
            let per_draw = MAX_ATTACHMENTS as u32;
            let traced = (0..key.rays()).step_by(MAX_ATTACHMENTS).try_for_each(|k| {
                // Up to four rays a draw, one colour attachment (hit layer) each.
                let rays = per_draw.min(key.rays() - k);
                let layers: Vec<u32> = (k..k + rays).collect();
                params.first_ray = first + k;
                self.draw(
                    call,
                    trav,
                    Variant::Trace,
                    Some((&hits, &layers)),
                    [0, 0, t.width, t.height],
                    &params.words(),
                    Some(Hits {
                        texture: &hits,
                        origin,
                        rays,
                    }),
                    grid,
                    false,
                )
            });
            if let Err(e) = traced {
                hits.delete(gl);
                return Err(e);
            }
            let replaced = self.kept.as_mut().and_then(|k| k.insert(key, hits));
            self.delete(replaced.into_iter().collect())?;
        }
        let kept = self.kept.as_ref().and_then(|k| k.get(&key));
        let hits = kept.ok_or_else(|| GlowError::InvalidInput("kept hits".into()))?;
        self.draw(
            call,
            trav,
            Variant::Replay,
            target,
            rect,
            call.params,
            Some(Hits {
                texture: hits,
                origin,
                rays: key.rays(),
            }),
            grid,
            true,
        )?;
        if let Some(k) = &mut self.kept {
            k.replayed();
        }
        Ok(())
    }
}

impl GpuBackend for GlowBackend {
    type Texture = GlowTexture;
    type Scene = GlowScene;
    type Error = GlowError;

    fn name(&self) -> &'static str {
        "glow"
    }

    fn limits(&self) -> Limits {
        let caps = self.ctx.capabilities();
        Limits {
            max_texture_size: caps.max_texture_size,
            max_array_layers: caps.max_array_layers,
            max_texture_units: caps.texture_units,
            loop_iterations: Limits::loop_iterations_of(&caps.renderer),
        }
    }

    fn create_texture(&mut self, desc: &TexDesc) -> Result<GlowTexture> {
        let caps = self.ctx.capabilities();
        for (what, v, max) in [
            ("texture width", desc.size[0], caps.max_texture_size),
            ("texture height", desc.size[1], caps.max_texture_size),
            ("texture array layers", desc.layers, caps.max_array_layers),
        ] {
            if v > max {
                return Err(GlowError::Limit {
                    what,
                    requested: v.into(),
                    allowed: max.into(),
                });
            }
        }
        let gl = self.ctx.gl()?;
        let tex = TextureArray::new(gl, desc.label, desc.size[0], desc.size[1], desc.layers)?;
        // Texture storage starts undefined in OpenGL ES: clear every layer to zero.
        for layer in 0..desc.layers {
            self.target.bind(gl, desc.label, &tex, layer)?;
            // SAFETY: clearing colour attachment 0 of our complete framebuffer.
            unsafe { gl.clear_buffer_f32_slice(glow::COLOR, 0, &[0.0; 4]) };
        }
        check(gl, desc.label, "clearing a new texture")?;
        self.textures.push((desc.label.to_owned(), tex));
        Ok(GlowTexture(self.textures.len() - 1))
    }

    fn upload(&mut self, texture: &GlowTexture, layer: u32, texels: &[f32]) -> Result<()> {
        let (label, t) = self.texture(texture)?;
        let per_layer = t.width as usize * t.height as usize * 4;
        if texels.len() != per_layer {
            return Err(GlowError::InvalidInput(format!(
                "upload to `{label}` layer {layer}: {} floats, expected {per_layer}",
                texels.len()
            )));
        }
        let layers = t.layers;
        t.upload(self.ctx.gl()?, label, layer, texels)?;
        if self.kept.is_some() {
            // What tells one room's G-buffer from another's for the kept hits.
            self.uploads.record(texture.0, layers, layer, texels);
        }
        Ok(())
    }

    fn upload_scene(&mut self, scene: &SceneData<'_>) -> Result<GlowScene> {
        let s = GpuScene::upload(self.ctx.gl()?, self.ctx.capabilities(), scene)?;
        // Hits of rooms that no longer exist go.
        let freed = self.kept.as_mut().map(|k| k.upload(&scene.bvh.encoded));
        self.delete(freed.unwrap_or_default())?;
        self.scenes.push(s);
        self.scene_bvh
            .push(std::sync::Arc::as_ptr(&scene.bvh.encoded) as usize);
        Ok(GlowScene(self.scenes.len() - 1))
    }

    fn tile_work(&self) -> u64 {
        self.tile_work
    }

    fn dispatch(&mut self, call: &Dispatch<'_, GlowTexture, GlowScene>) -> Result<()> {
        let label = call.label;
        let trav = program_traversal(call.program, call.bvh);
        let gpu_scene = self.scene(call.scene)?;
        let size = |t: &TextureArray| ([t.width, t.height], t.layers);
        let sizes = call
            .reads
            .iter()
            .map(|r| Ok(size(&self.texture(r)?.1)))
            .collect::<Result<Vec<_>>>()?;
        call.check(
            size(&self.texture(call.write)?.1),
            &sizes,
            gpu_scene.layer_size,
        )
        .map_err(|reason| GlowError::InvalidInput(format!("pass `{label}`: {reason}")))?;
        // A texture a pass writes is no upload any more.
        self.uploads.forget(call.write.0);
        let t = call.tile;
        // A gather over rows without a valid texel (`Dispatch::idle`) writes 0 at each of
        // them, as a clear does: no program, no grid texture, no hits.
        if call.program == Pass::Gather && call.idle {
            let gl = self.ctx.gl()?;
            let (_, out) = self.texture(call.write)?;
            self.target.bind(gl, label, out, t.layer)?;
            return self
                .target
                .clear(gl, label, [t.x0, t.y0, t.width, t.height]);
        }
        let stride = if call.program == Pass::Gather {
            GatherParams::from_words(call.params).stride
        } else {
            0
        };
        let Some(grid) = coarse::grid_tile(t, stride) else {
            return self.gather_or_draw(call, trav, t, None, GridUse::None);
        };
        // A strided gather: its grid texels alone into a texture of the compact tile's size,
        // every fragment a grid texel, then the tile, which copies them and gathers the
        // orphans (`coarse::grid_tile`).
        let gl = self.ctx.gl()?;
        let values = TextureArray::new(gl, "gather grid", grid.width, grid.height, 1)?;
        let origin = [grid.x0, grid.y0];
        let drawn = self
            .gather_or_draw(
                call,
                trav,
                grid,
                Some(&values),
                GridUse::Draw { stride, origin },
            )
            .and_then(|()| {
                let from = GridUse::From {
                    origin,
                    values: &values,
                };
                self.gather_or_draw(call, trav, t, None, from)
            });
        values.delete(self.ctx.gl()?);
        drawn
    }

    fn read_back(&mut self, texture: &GlowTexture, layer: u32) -> Result<Vec<f32>> {
        let (label, t) = self.texture(texture)?;
        self.target.read(self.ctx.gl()?, label, t, layer)
    }

    fn release(&mut self) -> Result<()> {
        let gl = self.ctx.gl()?;
        for (_, t) in self.textures.drain(..) {
            t.delete(gl);
        }
        for s in self.scenes.drain(..) {
            s.delete(gl);
        }
        self.scene_bvh.clear();
        self.uploads.clear();
        check(gl, "release", "freeing the textures")
    }
}

impl Drop for GlowBackend {
    fn drop(&mut self) {
        // Without a current context there is nothing to free: the context goes with us.
        if let Ok(gl) = self.ctx.gl() {
            for (_, t) in self.textures.drain(..) {
                t.delete(gl);
            }
            for s in self.scenes.drain(..) {
                s.delete(gl);
            }
            for (_, p) in self.programs.drain() {
                p.delete(gl);
            }
            if let Some(kept) = &mut self.kept {
                for t in kept.drain() {
                    t.delete(gl);
                }
            }
            self.target.delete(gl);
        }
    }
}
