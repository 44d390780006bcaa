//! Creating the GL context: the only place where native and wasm32 differ.
//!
//! Native: a headless EGL context on Mesa's surfaceless platform ([`GlContext::headless`]).
//! wasm32: a WebGL2 context from a canvas ([`GlContext::from_canvas`]) or an `OffscreenCanvas`
//! (`GlContext::from_offscreen_canvas`). Everything after creation
//! goes through `glow::HasContext`, identical on both.

#[cfg(not(target_arch = "wasm32"))]
mod egl;
#[cfg(target_arch = "wasm32")]
mod web;

use glow::HasContext;

use crate::error::{GlowError, Result};

/// WebGL2's guaranteed minimums, which the backend never exceeds whatever the context offers, so
/// that a bake that runs here also runs in any browser.
pub mod webgl2 {
    /// Texture image units a fragment shader may use (`MAX_TEXTURE_IMAGE_UNITS`).
    pub const TEXTURE_UNITS: u32 = 16;
    /// Layers of a texture array (`MAX_ARRAY_TEXTURE_LAYERS`; WebGL2 / GLES 3.0 guarantee 256).
    pub const ARRAY_LAYERS: u32 = 256;
    /// Width and height of a 2D texture or array layer (`MAX_TEXTURE_SIZE`).
    pub const TEXTURE_SIZE: u32 = 2048;
}

/// What the context offers, read once at creation.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Capabilities {
    /// `GL_RENDERER`, e.g. `llvmpipe (LLVM 15.0.6, 256 bits)`.
    pub renderer: String,
    /// `GL_VERSION`, e.g. `OpenGL ES 3.2 Mesa 22.3.6`.
    pub version: String,
    /// `MAX_TEXTURE_SIZE`: the largest layer width/height the backend will allocate.
    pub max_texture_size: u32,
    /// `MAX_ARRAY_TEXTURE_LAYERS`, clamped to [`webgl2::ARRAY_LAYERS`].
    pub max_array_layers: u32,
    /// `MAX_TEXTURE_IMAGE_UNITS`, clamped to [`webgl2::TEXTURE_UNITS`].
    pub texture_units: u32,
}

/// An OpenGL ES 3.0 / WebGL2 context with float render targets, checked against WebGL2's
/// minimums.
///
/// Native contexts are current on the thread that created them and must stay there: the type is
/// neither `Send` nor `Sync`.
pub struct GlContext {
    gl: glow::Context,
    caps: Capabilities,
    #[cfg(not(target_arch = "wasm32"))]
    egl: egl::EglContext,
    /// GL contexts are bound to one thread.
    _not_send: std::marker::PhantomData<*const ()>,
}

impl std::fmt::Debug for GlContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GlContext")
            .field("caps", &self.caps)
            .finish_non_exhaustive()
    }
}

impl GlContext {
    /// A headless context: EGL (loaded at run time) on Mesa's surfaceless platform, OpenGL ES 3.0,
    /// current on the calling thread.
    ///
    /// # Errors
    /// [`GlowError::NoContext`] when libEGL, the surfaceless platform or a GLES 3 config is
    /// missing; [`GlowError::MissingExtension`] without `EXT_color_buffer_float`;
    /// [`GlowError::Limit`] below WebGL2's minimums.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn headless() -> Result<Self> {
        let (egl, gl) = egl::EglContext::create()?;
        let caps = check_capabilities(&gl)?;
        Ok(Self {
            gl,
            caps,
            egl,
            _not_send: std::marker::PhantomData,
        })
    }

    /// A WebGL2 context from a canvas.
    ///
    /// # Errors
    /// As [`GlContext::headless`].
    #[cfg(target_arch = "wasm32")]
    pub fn from_canvas(canvas: &web_sys::HtmlCanvasElement) -> Result<Self> {
        Self::from_webgl2(web::from_canvas(canvas)?)
    }

    /// A WebGL2 context from an `OffscreenCanvas`, e.g. in a Web Worker (the viewer bakes there
    /// so that the page stays interactive).
    ///
    /// # Errors
    /// As [`GlContext::headless`].
    #[cfg(target_arch = "wasm32")]
    pub fn from_offscreen_canvas(canvas: &web_sys::OffscreenCanvas) -> Result<Self> {
        Self::from_webgl2(web::from_offscreen_canvas(canvas)?)
    }

    /// A WebGL2 context of the browser's, once its capabilities are checked.
    #[cfg(target_arch = "wasm32")]
    fn from_webgl2(gl: glow::Context) -> Result<Self> {
        let caps = check_capabilities(&gl)?;
        Ok(Self {
            gl,
            caps,
            _not_send: std::marker::PhantomData,
        })
    }

    /// The context's capabilities.
    pub fn capabilities(&self) -> &Capabilities {
        &self.caps
    }

    /// The `glow` context, made current on the calling thread first (native).
    pub(crate) fn gl(&self) -> Result<&glow::Context> {
        #[cfg(not(target_arch = "wasm32"))]
        self.egl.make_current()?;
        Ok(&self.gl)
    }
}

/// Whether RGBA32F textures are colour-renderable: with `EXT_color_buffer_float`, or in core
/// OpenGL ES 3.2 / desktop OpenGL 3.0 and later. WebGL2 always needs the extension (glow
/// enables it at context creation when the browser offers it).
fn float_targets_supported(embedded: bool, version: (u32, u32), has_ext: bool, web: bool) -> bool {
    let core = if embedded {
        version >= (3, 2)
    } else {
        version.0 >= 3
    };
    has_ext || (core && !web)
}

/// Reads the limits, requires `EXT_color_buffer_float` and WebGL2's minimums.
fn check_capabilities(gl: &glow::Context) -> Result<Capabilities> {
    // SAFETY: plain queries on a current context.
    let (renderer, version, tex, layers, units) = unsafe {
        (
            gl.get_parameter_string(glow::RENDERER),
            gl.get_parameter_string(glow::VERSION),
            gl.get_parameter_i32(glow::MAX_TEXTURE_SIZE),
            gl.get_parameter_i32(glow::MAX_ARRAY_TEXTURE_LAYERS),
            gl.get_parameter_i32(glow::MAX_TEXTURE_IMAGE_UNITS),
        )
    };
    let v = gl.version();
    let exts = gl.supported_extensions();
    let has_ext =
        exts.contains("EXT_color_buffer_float") || exts.contains("GL_EXT_color_buffer_float");
    let web = cfg!(target_arch = "wasm32");
    if !float_targets_supported(v.is_embedded, (v.major, v.minor), has_ext, web) {
        return Err(GlowError::MissingExtension {
            name: "EXT_color_buffer_float",
            renderer,
        });
    }
    let at_least = |what: &'static str, have: i32, need: u32| -> Result<u32> {
        let have = u32::try_from(have).unwrap_or(0);
        if have < need {
            return Err(GlowError::Limit {
                what,
                requested: need.into(),
                allowed: have.into(),
            });
        }
        Ok(have)
    };
    let max_texture_size = at_least("MAX_TEXTURE_SIZE", tex, webgl2::TEXTURE_SIZE)?;
    let max_array_layers = at_least("MAX_ARRAY_TEXTURE_LAYERS", layers, webgl2::ARRAY_LAYERS)?
        .min(webgl2::ARRAY_LAYERS);
    let texture_units = at_least("MAX_TEXTURE_IMAGE_UNITS", units, webgl2::TEXTURE_UNITS)?
        .min(webgl2::TEXTURE_UNITS);
    Ok(Capabilities {
        renderer,
        version,
        max_texture_size,
        max_array_layers,
        texture_units,
    })
}

#[cfg(test)]
mod tests {
    use super::float_targets_supported;
    use crate::GlowError;

    #[test]
    fn float_targets_need_the_extension_below_gles_3_2_and_on_the_web() {
        assert!(!float_targets_supported(true, (3, 0), false, false));
        assert!(!float_targets_supported(true, (3, 1), false, false));
        assert!(float_targets_supported(true, (3, 0), true, false));
        assert!(float_targets_supported(true, (3, 2), false, false));
        assert!(float_targets_supported(false, (4, 6), false, false));
        assert!(!float_targets_supported(true, (3, 2), false, true));
        assert!(float_targets_supported(true, (3, 0), true, true));
    }

    #[test]
    fn the_missing_extension_error_names_it() {
        let e = GlowError::MissingExtension {
            name: "EXT_color_buffer_float",
            renderer: "test renderer".into(),
        };
        let msg = e.to_string();
        assert!(
            msg.contains("EXT_color_buffer_float") && msg.contains("test renderer"),
            "{msg}"
        );
    }
}
