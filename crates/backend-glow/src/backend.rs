//! [`GlowBackend`]: the context, its texture arrays, its pass programs, and the
//! [`GpuBackend`] implementation that runs each pass of the graph as fragment-shader draws.

use std::collections::HashMap;

use glow::HasContext;
use luxbake::backend::{DEFAULT_TILE_WORK, Dispatch, GpuBackend, Limits, SceneData};
use luxbake::graph::TexDesc;
use luxbake::program::Scalar;
use luxbake::scene::BvhMode;
use luxbake::shader::{glsl_param, glsl_slot, program_traversal};

use crate::context::{Capabilities, GlContext};
use crate::error::{GlowError, Result};
use crate::gl::{Program, Target, TextureArray, check};
use crate::scene::GpuScene;
use crate::shaders::{Pass, program_sources};

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
    programs: HashMap<(Pass, BvhMode), Program>,
    tile_work: u64,
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
            programs: HashMap::new(),
            tile_work: DEFAULT_TILE_WORK,
        })
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

    fn texture(&self, tex: &GlowTexture) -> Result<&(String, TextureArray)> {
        self.textures
            .get(tex.0)
            .ok_or_else(|| GlowError::InvalidInput(format!("unknown texture {tex:?}")))
    }

    /// Compiles (once) and returns the program of `pass` for `traversal`.
    fn program(&mut self, pass: Pass, traversal: BvhMode) -> Result<&Program> {
        let key = (pass, traversal);
        if !self.programs.contains_key(&key) {
            let (prefix, sources) = program_sources(pass, traversal);
            let program = Program::new(self.ctx.gl()?, pass.label(), &prefix, &sources)?;
            self.programs.insert(key, program);
        }
        self.programs
            .get(&key)
            .ok_or_else(|| GlowError::InvalidInput("program cache".into()))
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
        t.upload(self.ctx.gl()?, label, layer, texels)
    }

    fn upload_scene(&mut self, scene: &SceneData<'_>) -> Result<GlowScene> {
        let s = GpuScene::upload(self.ctx.gl()?, self.ctx.capabilities(), scene)?;
        self.scenes.push(s);
        Ok(GlowScene(self.scenes.len() - 1))
    }

    fn tile_work(&self) -> u64 {
        self.tile_work
    }

    fn dispatch(&mut self, call: &Dispatch<'_, GlowTexture, GlowScene>) -> Result<()> {
        let (label, sig) = (call.label, call.program.signature());
        let trav = program_traversal(call.program, call.bvh);
        self.program(call.program, trav)?;
        let gpu_scene = self
            .scenes
            .get(call.scene.0)
            .ok_or_else(|| GlowError::InvalidInput(format!("unknown scene {:?}", call.scene)))?;
        let out = &self.texture(call.write)?.1;
        let size = |t: &TextureArray| ([t.width, t.height], t.layers);
        let reads = call
            .reads
            .iter()
            .map(|r| Ok(&self.texture(r)?.1))
            .collect::<Result<Vec<_>>>()?;
        let sizes: Vec<_> = reads.iter().map(|t| size(t)).collect();
        call.check(size(out), &sizes, gpu_scene.layer_size)
            .map_err(|reason| GlowError::InvalidInput(format!("pass `{label}`: {reason}")))?;
        let t = call.tile;
        let gl = self.ctx.gl()?;
        let mut samplers: Vec<(String, &TextureArray)> = sig
            .reads
            .iter()
            .zip(reads)
            .map(|(slot, t)| (glsl_slot(slot), t))
            .collect();
        if sig.scene.bvh {
            samplers.extend(
                gpu_scene
                    .bvh
                    .samplers(trav)
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
        let program = self
            .programs
            .get(&(call.program, trav))
            .ok_or_else(|| GlowError::InvalidInput("program cache".into()))?;
        let named: Vec<(&str, &TextureArray)> =
            samplers.iter().map(|(n, tex)| (n.as_str(), *tex)).collect();
        self.target.bind(gl, label, out, t.layer)?;
        program.use_with(gl, label, &named)?;
        program.set_i32(gl, "u_layer", i32::try_from(t.layer).unwrap_or(i32::MAX));
        if sig.scene.bvh {
            gpu_scene.bvh.set_uniforms(gl, program);
            program.set_f32(gl, "u_ray_epsilon", gpu_scene.ray_epsilon);
        }
        for (field, &word) in sig.params.iter().zip(call.params) {
            let name = glsl_param(field);
            match field.ty {
                Scalar::U32 => program.set_u32(gl, &name, word),
                Scalar::I32 => program.set_i32(gl, &name, word as i32),
                Scalar::F32 => program.set_f32(gl, &name, f32::from_bits(word)),
            }
        }
        self.target
            .draw(gl, label, [t.x0, t.y0, t.width, t.height])?;
        // Wait for the tile: honest progress and timings, and no unbounded queue of GPU work.
        // SAFETY: glFinish has no preconditions.
        unsafe { gl.finish() };
        // WebGL's `finish` need not wait (browsers run the GPU work in another process): reading
        // one texel of the tile back does.
        #[cfg(target_arch = "wasm32")]
        self.target.wait(gl, label, [t.x0, t.y0])?;
        check(gl, label, "finishing a tile")
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
            self.target.delete(gl);
        }
    }
}
