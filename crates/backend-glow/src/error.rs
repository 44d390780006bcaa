//! The crate's one error type.

/// Everything that can go wrong in the glow backend.
///
/// Messages name the pass (the [`crate`]'s shader program label) and carry the driver's own log
/// where the driver gives one, so that a failure on a user's GPU can be diagnosed from the message
/// alone.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GlowError {
    /// No usable OpenGL ES 3.0 / WebGL2 context could be created (no EGL library, no Mesa
    /// surfaceless platform, no GLES 3 config, a canvas without WebGL2, ...).
    #[error("no OpenGL ES 3.0 / WebGL2 context: {reason}")]
    NoContext {
        /// What failed, with the platform's error.
        reason: String,
    },
    /// A required extension is missing from the context.
    #[error(
        "the context lacks the required extension {name} (needed to render into RGBA32F texture \
         array layers); renderer: {renderer}"
    )]
    MissingExtension {
        /// The extension's name, e.g. `EXT_color_buffer_float`.
        name: &'static str,
        /// The driver's `GL_RENDERER` string.
        renderer: String,
    },
    /// A device limit is below what the backend needs, or a request exceeds the limit the
    /// backend allows itself (the WebGL2 guaranteed minimum or the context's own limit).
    #[error("{what}: {requested} requested, {allowed} allowed")]
    Limit {
        /// The limited quantity, e.g. `"texture units per pass"`.
        what: &'static str,
        /// The amount asked for.
        requested: u64,
        /// The most that is allowed.
        allowed: u64,
    },
    /// A shader failed to compile.
    #[error("pass `{pass}`: the {stage} shader failed to compile:\n{log}")]
    Compile {
        /// The pass (program) label.
        pass: String,
        /// `"vertex"` or `"fragment"`.
        stage: &'static str,
        /// The driver's info log.
        log: String,
    },
    /// A program failed to link.
    #[error("pass `{pass}`: the program failed to link:\n{log}")]
    Link {
        /// The pass (program) label.
        pass: String,
        /// The driver's info log.
        log: String,
    },
    /// `glGetError` reported an error after an operation.
    #[error("pass `{pass}`: GL error 0x{code:04X} ({name}) after {operation}")]
    Gl {
        /// The pass or operation label.
        pass: String,
        /// What the backend was doing.
        operation: &'static str,
        /// The raw GL error code.
        code: u32,
        /// The GL error name, e.g. `GL_INVALID_OPERATION`.
        name: &'static str,
    },
    /// A framebuffer was incomplete.
    #[error("pass `{pass}`: framebuffer incomplete (status 0x{status:04X})")]
    Framebuffer {
        /// The pass label.
        pass: String,
        /// The `glCheckFramebufferStatus` value.
        status: u32,
    },
    /// The caller passed data of the wrong shape (length, layer, rectangle).
    #[error("invalid input: {0}")]
    InvalidInput(String),
}

impl GlowError {
    /// Whether the machine has no OpenGL ES 3.0 driver to run on ([`GlowError::NoContext`]):
    /// a test that needs one skips or fails by the workspace's rule (`luxbake_testkit::or_skip`). Every other error,
    /// opening included, is a failure of a driver that is there.
    pub fn is_driver_missing(&self) -> bool {
        matches!(self, GlowError::NoContext { .. })
    }
}

/// Short alias used throughout the crate.
pub type Result<T, E = GlowError> = std::result::Result<T, E>;

/// The symbolic name of a `glGetError` code.
pub(crate) fn gl_error_name(code: u32) -> &'static str {
    match code {
        glow::INVALID_ENUM => "GL_INVALID_ENUM",
        glow::INVALID_VALUE => "GL_INVALID_VALUE",
        glow::INVALID_OPERATION => "GL_INVALID_OPERATION",
        glow::INVALID_FRAMEBUFFER_OPERATION => "GL_INVALID_FRAMEBUFFER_OPERATION",
        glow::OUT_OF_MEMORY => "GL_OUT_OF_MEMORY",
        glow::CONTEXT_LOST => "GL_CONTEXT_LOST",
        _ => "unknown GL error",
    }
}
