//! Native headless context: EGL loaded at run time (`khronos-egl`, `dynamic`), Mesa's surfaceless
//! platform, an OpenGL ES 3.0 context with no surface at all (all rendering goes to framebuffer
//! objects).
//!
//! On a machine without a GPU this runs on Mesa's llvmpipe (`apt-get install libegl1
//! libgl1-mesa-dri`).

use khronos_egl as egl;

use crate::error::{GlowError, Result};

/// `EGL_PLATFORM_SURFACELESS_MESA` (EGL_MESA_platform_surfaceless): a display with no window
/// system, for off-screen rendering.
const PLATFORM_SURFACELESS_MESA: egl::Enum = 0x31DD;

/// The EGL objects behind a headless context. Dropping it destroys the context.
pub(crate) struct EglContext {
    egl: egl::DynamicInstance<egl::EGL1_5>,
    display: egl::Display,
    context: egl::Context,
}

impl std::fmt::Debug for EglContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EglContext").finish_non_exhaustive()
    }
}

fn no_context(step: &str, e: impl std::fmt::Display) -> GlowError {
    GlowError::NoContext {
        reason: format!("{step}: {e}"),
    }
}

impl EglContext {
    /// Loads `libEGL.so.1`, opens the surfaceless display, creates a GLES 3.0 context, makes it
    /// current on this thread and returns it with a `glow` context over it.
    pub(crate) fn create() -> Result<(Self, glow::Context)> {
        // SAFETY: loading the system's libEGL; khronos-egl checks every required symbol.
        let egl = unsafe { egl::DynamicInstance::<egl::EGL1_5>::load_required() }
            .map_err(|e| no_context("loading libEGL.so.1 (EGL 1.5; install libegl1)", e))?;
        let client_exts = egl
            .query_string(None, egl::EXTENSIONS)
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        if !client_exts
            .split_ascii_whitespace()
            .any(|e| e == "EGL_MESA_platform_surfaceless")
        {
            return Err(no_context(
                "EGL client extensions",
                "EGL_MESA_platform_surfaceless is not offered (install Mesa: libgl1-mesa-dri)",
            ));
        }
        // SAFETY: the surfaceless platform takes EGL_DEFAULT_DISPLAY (null) as native display.
        let display = unsafe {
            egl.get_platform_display(
                PLATFORM_SURFACELESS_MESA,
                egl::DEFAULT_DISPLAY,
                &[egl::ATTRIB_NONE],
            )
        }
        .map_err(|e| no_context("eglGetPlatformDisplay(SURFACELESS_MESA)", e))?;
        egl.initialize(display)
            .map_err(|e| no_context("eglInitialize", e))?;
        egl.bind_api(egl::OPENGL_ES_API)
            .map_err(|e| no_context("eglBindAPI(OPENGL_ES)", e))?;
        // SURFACE_TYPE 0: any config, we never create a surface.
        let config = egl
            .choose_first_config(
                display,
                &[
                    egl::RENDERABLE_TYPE,
                    egl::OPENGL_ES3_BIT,
                    egl::SURFACE_TYPE,
                    0,
                    egl::NONE,
                ],
            )
            .map_err(|e| no_context("eglChooseConfig", e))?
            .ok_or_else(|| no_context("eglChooseConfig", "no OpenGL ES 3 config"))?;
        let context = egl
            .create_context(
                display,
                config,
                None,
                &[
                    egl::CONTEXT_MAJOR_VERSION,
                    3,
                    egl::CONTEXT_MINOR_VERSION,
                    0,
                    egl::NONE,
                ],
            )
            .map_err(|e| no_context("eglCreateContext(GLES 3.0)", e))?;
        let this = Self {
            egl,
            display,
            context,
        };
        this.make_current()?;
        // SAFETY: the context is current on this thread; eglGetProcAddress returns core and
        // extension entry points (EGL 1.5 / EGL_KHR_get_all_proc_addresses).
        let gl = unsafe {
            glow::Context::from_loader_function(|name| {
                this.egl
                    .get_proc_address(name)
                    .map_or(std::ptr::null(), |f| f as *const _)
            })
        };
        Ok((this, gl))
    }

    /// Makes the context current on the calling thread (surfaceless: no draw or read surface).
    pub(crate) fn make_current(&self) -> Result<()> {
        self.egl
            .make_current(self.display, None, None, Some(self.context))
            .map_err(|e| no_context("eglMakeCurrent (surfaceless)", e))
    }
}

impl Drop for EglContext {
    fn drop(&mut self) {
        // The display is a per-process singleton shared by every context (tests create several
        // in parallel threads), so it is never terminated; only this context is released.
        // Errors cannot be reported from drop and leave nothing to clean up.
        let _ = self.egl.make_current(self.display, None, None, None);
        let _ = self.egl.destroy_context(self.display, self.context);
    }
}
