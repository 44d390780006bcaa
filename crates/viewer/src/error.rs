//! The viewer's error type.

/// Everything the viewer reports to the page (shown as an error line; the previous bake stays).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ViewerError {
    /// A malformed bake request (JSON, unknown scene or lamp).
    #[error("request: {0}")]
    Request(String),
    /// A setting out of range.
    #[error("setting `{name}`: {reason}")]
    Setting {
        /// Setting name as in the request JSON.
        name: &'static str,
        /// What is allowed, and what was given.
        reason: String,
    },
    /// A photometric file that `luxbake-ies` rejects.
    #[error("{file}: {message}")]
    Photometry {
        /// File name.
        file: String,
        /// The parser's message (line and what was expected).
        message: String,
    },
    /// A light-map set that does not match the scene on display.
    #[error("light maps: {0}")]
    Maps(String),
    /// The GPU (WebGL2) failed or is missing something.
    #[error("{0}")]
    Gpu(String),
}
