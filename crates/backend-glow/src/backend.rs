//! [`GlowBackend`]: the context, its texture arrays, its pass programs, and the
//! [`GpuBackend`] implementation that runs each pass of the graph as fragment-shader draws.

use std::collections::HashMap;

use glow::HasContext;
use luxbake::backend::{GpuBackend, Limits, SceneData};
use luxbake::graph::{Axis, PassDesc, PassKind, TexDesc};
use luxbake::scene::BvhMode;

use crate::context::{Capabilities, GlContext};
use crate::error::{GlowError, Result};
use crate::gl::{Program, Target, TextureArray, check};
use crate::scene::{GpuScene, lamp_texture};
use crate::shaders::{self, Pass, PassShaders, Traversal};

/// Default work per draw: texel × ray (or texel × tap) evaluations of one tile. About 2^20
/// keeps a draw in the tens of milliseconds on a laptop GPU, far from a browser's GPU watchdog
/// (a few seconds), and gives a progress report every few hundred milliseconds on llvmpipe.
pub const DEFAULT_TILE_WORK: u64 = 1 << 20;

/// A texture array owned by a [`GlowBackend`] (a handle; the backend frees the GL object when
/// it is dropped).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct GlowTexture(usize);

/// The static scene data of a bake on the GPU (a handle; the textures belong to the backend).
#[derive(Debug)]
pub struct GlowScene(usize);

/// The glow backend: a GL context, the RGBA32F texture arrays of a bake, the uploaded scene
/// data and one program per pass kind (and traversal), compiled on first use.
pub struct GlowBackend {
    ctx: GlContext,
    target: Target,
    textures: Vec<(String, TextureArray)>,
    scenes: Vec<GpuScene>,
    programs: HashMap<(Pass, Traversal), Program>,
    tile_work: u64,
}

impl std::fmt::Debug for GlowBackend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GlowBackend")
            .field("ctx", &self.ctx)
            .field("textures", &self.textures.len())
            .field("programs", &self.programs.len())
            .field("tile_work", &self.tile_work)
            .finish_non_exhaustive()
    }
}

fn traversal(mode: BvhMode) -> Traversal {
    match mode {
        BvhMode::Mtbvh => Traversal::Mtbvh,
        BvhMode::Tbvh => Traversal::Tbvh,
        BvhMode::None => Traversal::None,
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
            programs: HashMap::new(),
            tile_work: DEFAULT_TILE_WORK,
        })
    }

    /// Sets the work per draw (texel × ray evaluations, at least 1): long passes are split into
    /// row tiles of about this much work, each a separate draw followed by a progress report.
    pub fn with_tile_work(mut self, work: u64) -> Self {
        self.tile_work = work.max(1);
        self
    }

    /// The context's capabilities.
    pub fn capabilities(&self) -> &Capabilities {
        self.ctx.capabilities()
    }

    fn texture(&self, tex: &GlowTexture) -> Result<&(String, TextureArray)> {
        self.textures
            .get(tex.0)
            .ok_or_else(|| GlowError::InvalidInput(format!("unknown texture {tex:?}")))
    }

    /// Compiles (once) and returns the program of `pass` for `traversal`.
    fn program(&mut self, pass: Pass, traversal: Traversal) -> Result<&Program> {
        let key = (pass, traversal);
        if !self.programs.contains_key(&key) {
            let program = Program::new(
                self.ctx.gl()?,
                pass.label(),
                &shaders::defines(traversal),
                &pass.sources(),
            )?;
            self.programs.insert(key, program);
        }
        self.programs
            .get(&key)
            .ok_or_else(|| GlowError::InvalidInput("program cache".into()))
    }

    /// Draws `program` (bound, uniforms set) into every layer of `out`, in row tiles of about
    /// `self.tile_work / work_per_texel` texels, reporting progress after each tile.
    fn draw_tiled(
        &self,
        pass: &str,
        program: &Program,
        out: &TextureArray,
        work_per_texel: u64,
        progress: &mut dyn FnMut(f32),
    ) -> Result<()> {
        let gl = self.ctx.gl()?;
        let (w, h) = (out.width, out.height);
        let per_row = u64::from(w) * work_per_texel.max(1);
        let rows = u32::try_from((self.tile_work / per_row).clamp(1, u64::from(h))).unwrap_or(h);
        let tiles_per_layer = h.div_ceil(rows);
        let total = (u64::from(tiles_per_layer) * u64::from(out.layers)).max(1);
        let mut done = 0u64;
        for layer in 0..out.layers {
            self.target.bind(gl, pass, out, layer)?;
            program.set_i32(gl, "u_layer", i32::try_from(layer).unwrap_or(i32::MAX));
            for tile in 0..tiles_per_layer {
                let y0 = tile * rows;
                let y1 = (y0 + rows).min(h);
                self.target.draw(gl, pass, [0, y0, w, y1 - y0])?;
                // Wait for the tile: honest progress, and no unbounded queue of GPU work.
                // SAFETY: glFinish has no preconditions.
                unsafe { gl.finish() };
                check(gl, pass, "finishing a tile")?;
                done += 1;
                progress(done as f32 / total as f32);
            }
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
        t.upload(self.ctx.gl()?, label, layer, texels)
    }

    fn upload_scene(&mut self, scene: &SceneData<'_>) -> Result<GlowScene> {
        let s = GpuScene::upload(self.ctx.gl()?, self.ctx.capabilities(), scene)?;
        self.scenes.push(s);
        Ok(GlowScene(self.scenes.len() - 1))
    }

    fn run_pass(
        &mut self,
        pass: &PassDesc,
        reads: &[&GlowTexture],
        writes: &[&GlowTexture],
        scene: &GlowScene,
        progress: &mut dyn FnMut(f32),
    ) -> Result<()> {
        let Some(kind) = pass.kind.program() else {
            // The G-buffer is uploaded, not computed.
            progress(1.0);
            return Ok(());
        };
        let names = kind.sampler_names();
        if reads.len() != names.len() || writes.len() != 1 {
            return Err(GlowError::InvalidInput(format!(
                "pass `{}`: expected {} reads and 1 write, got {} and {}",
                pass.label,
                names.len(),
                reads.len(),
                writes.len()
            )));
        }
        if reads.iter().any(|r| r.0 == writes[0].0) {
            return Err(GlowError::InvalidInput(format!(
                "pass `{}` reads the texture it writes",
                pass.label
            )));
        }
        let trav = if kind.traces_rays() {
            traversal(pass.params.bvh)
        } else {
            Traversal::None
        };
        self.program(kind, trav)?;
        let gpu_scene = self
            .scenes
            .get(scene.0)
            .ok_or_else(|| GlowError::InvalidInput(format!("unknown scene {scene:?}")))?;
        let out = &self.texture(writes[0])?.1;
        if [out.width, out.height] != gpu_scene.layer_size {
            return Err(GlowError::InvalidInput(format!(
                "pass `{}`: target size differs from the scene's layer size",
                pass.label
            )));
        }
        let gl = self.ctx.gl()?;
        let mut samplers: Vec<(&str, &TextureArray)> = Vec::with_capacity(8);
        for (name, r) in names.iter().zip(reads) {
            let t = &self.texture(r)?.1;
            if (t.width, t.height, t.layers) != (out.width, out.height, out.layers) {
                return Err(GlowError::InvalidInput(format!(
                    "pass `{}`: input `{name}` differs in size from the target",
                    pass.label
                )));
            }
            samplers.push((name, t));
        }
        let lamps = match pass.kind {
            PassKind::Direct => Some(lamp_texture(gl, gpu_scene, &pass.params.lamps)?),
            _ => None,
        };
        if kind.traces_rays() {
            samplers.extend(gpu_scene.bvh.samplers(trav));
        }
        match (&lamps, pass.kind) {
            (Some((tex, _)), _) => {
                samplers.push(("u_lamps", tex));
                samplers.push(("u_ies", &gpu_scene.ies));
            }
            (None, PassKind::Gather { .. }) => samplers.push(("u_regions", &gpu_scene.regions)),
            _ => {}
        }
        let program = self
            .programs
            .get(&(kind, trav))
            .ok_or_else(|| GlowError::InvalidInput("program cache".into()))?;
        program.use_with(gl, pass.label, &samplers)?;
        if kind.traces_rays() {
            gpu_scene.bvh.set_uniforms(gl, program);
            program.set_f32(gl, "u_ray_epsilon", gpu_scene.ray_epsilon);
        }
        let work = match pass.kind {
            PassKind::Direct => {
                let count = lamps.as_ref().map_or(0, |(_, n)| *n);
                program.set_i32(gl, "u_lamp_count", count);
                u64::try_from(count).unwrap_or(1)
            }
            PassKind::Gather { bounce } => {
                program.set_u32(gl, "u_rays", pass.params.rays);
                program.set_u32(gl, "u_bounce", bounce);
                program.set_u32(gl, "u_seed", pass.params.seed);
                u64::from(pass.params.rays)
            }
            PassKind::Blur { axis, sigma } => {
                // Exactly cpu::blur_texel's radius and exponent factor.
                let radius = ((3.0 * sigma).ceil() as i32).clamp(0, luxbake::cpu::MAX_BLUR_RADIUS);
                let step = match axis {
                    Axis::U => [1, 0],
                    Axis::V => [0, 1],
                };
                program.set_ivec2(gl, "u_step", step);
                program.set_i32(gl, "u_radius", radius);
                program.set_f32(gl, "u_inv", -0.5 / (sigma * sigma));
                u64::from(radius.unsigned_abs()) * 2 + 1
            }
            _ => 1,
        };
        let result = self.draw_tiled(pass.label, program, out, work, progress);
        if let Some((tex, _)) = lamps {
            tex.delete(gl);
        }
        result
    }

    fn read_back(&mut self, texture: &GlowTexture, layer: u32) -> Result<Vec<f32>> {
        let (label, t) = self.texture(texture)?;
        self.target.read(self.ctx.gl()?, label, t, layer)
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
            self.target.delete(gl);
        }
    }
}
