//! The package's error type: what the page's promise rejects with.

/// Everything a bake can fail with. [`JsBakeError::kind`] becomes the `kind` of the
/// `LuxbakeError` the JavaScript promise rejects with; the message is the `Display` text.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum JsBakeError {
    /// Malformed bake options (JSON shape, unknown key, a wrong type outside the settings).
    #[error("options: {0}")]
    Options(String),
    /// A bake setting of the wrong type, an unknown name (`method`, `quality`) or out of
    /// range ([`luxbake::scene::Settings::validate`]), named by its option key.
    #[error("setting `{name}`: {reason}")]
    Setting {
        /// The option key (`rays`, `texelsPerMetre`, ...).
        name: String,
        /// The value and what is allowed.
        reason: String,
    },
    /// A lamp that is out of range or whose photometric file does not parse (the parser's
    /// message names the line and what was expected).
    #[error("lamp {index} (`{name}`): {message}")]
    Lamp {
        /// Index in the `lamps` array.
        index: usize,
        /// The lamp's name.
        name: String,
        /// What was wrong.
        message: String,
    },
    /// A glTF/GLB scene that `luxbake-assets` rejects (the message names the accessor, node
    /// or part).
    #[error("scene: {0}")]
    Scene(String),
    /// The GPU (WebGL2) failed, or lacks something the bake needs.
    #[error("WebGL2: {0}")]
    Gpu(String),
    /// The WebGL2 context was lost during the bake; its maps are not trusted.
    #[error("the WebGL2 context was lost during the bake; bake again (a new context is made)")]
    ContextLost,
    /// The measurement points are malformed.
    #[error("measure: {0}")]
    Measure(String),
    /// A room (or result) that was disposed, or that the worker no longer holds.
    #[error("{0}")]
    Disposed(String),
}

impl JsBakeError {
    /// The error's kind as the JavaScript API names it: `options`, `setting`, `lamp`, `scene`,
    /// `webgl`, `contextLost`, `measure` or `disposed`.
    pub fn kind(&self) -> &'static str {
        match self {
            JsBakeError::Options(_) => "options",
            JsBakeError::Setting { .. } => "setting",
            JsBakeError::Lamp { .. } => "lamp",
            JsBakeError::Scene(_) => "scene",
            JsBakeError::Gpu(_) => "webgl",
            JsBakeError::ContextLost => "contextLost",
            JsBakeError::Measure(_) => "measure",
            JsBakeError::Disposed(_) => "disposed",
        }
    }
}
