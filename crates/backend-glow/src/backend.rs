//! [`GlowBackend`]: the context, its texture arrays and its pass programs.

use crate::context::{Capabilities, GlContext};
use crate::error::{GlowError, Result};
use crate::gl::{Target, TextureArray};

/// A texture array owned by a [`GlowBackend`] (a handle; the backend frees the GL object when
/// it is dropped).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct GlowTexture(usize);

/// The glow backend: a GL context, the RGBA32F texture arrays of a bake and the programs of its
/// passes.
pub struct GlowBackend {
    ctx: GlContext,
    target: Target,
    textures: Vec<(String, TextureArray)>,
}

impl std::fmt::Debug for GlowBackend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GlowBackend")
            .field("ctx", &self.ctx)
            .field("textures", &self.textures.len())
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
        })
    }

    /// The context's capabilities.
    pub fn capabilities(&self) -> &Capabilities {
        self.ctx.capabilities()
    }

    /// Allocates an RGBA32F texture array, within the context's size limit and WebGL2's layer
    /// count.
    ///
    /// # Errors
    /// [`GlowError::Limit`] over the limits, [`GlowError::InvalidInput`] for an empty size.
    pub fn create_texture(
        &mut self,
        label: &str,
        size: [u32; 2],
        layers: u32,
    ) -> Result<GlowTexture> {
        let caps = self.ctx.capabilities();
        for (what, v, max) in [
            ("texture width", size[0], caps.max_texture_size),
            ("texture height", size[1], caps.max_texture_size),
            ("texture array layers", layers, caps.max_array_layers),
        ] {
            if v > max {
                return Err(GlowError::Limit {
                    what,
                    requested: v.into(),
                    allowed: max.into(),
                });
            }
        }
        let tex = TextureArray::new(self.ctx.gl()?, label, size[0], size[1], layers)?;
        self.textures.push((label.to_owned(), tex));
        Ok(GlowTexture(self.textures.len() - 1))
    }

    fn texture(&self, tex: GlowTexture) -> Result<&(String, TextureArray)> {
        self.textures
            .get(tex.0)
            .ok_or_else(|| GlowError::InvalidInput(format!("unknown texture {tex:?}")))
    }

    /// Uploads one layer: `width * height * 4` floats (RGBA), row 0 first.
    ///
    /// # Errors
    /// Wrong length or layer, GL errors.
    pub fn upload(&mut self, tex: GlowTexture, layer: u32, texels: &[f32]) -> Result<()> {
        let (label, t) = self.texture(tex)?;
        t.upload(self.ctx.gl()?, label, layer, texels)
    }

    /// Reads one layer back: `width * height * 4` floats (RGBA), row 0 first.
    ///
    /// # Errors
    /// Wrong layer, GL errors.
    pub fn read_back(&mut self, tex: GlowTexture, layer: u32) -> Result<Vec<f32>> {
        let (label, t) = self.texture(tex)?;
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
            self.target.delete(gl);
        }
    }
}
