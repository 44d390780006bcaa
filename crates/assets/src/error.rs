//! [`AssetError`]: what import and export report.

use std::path::PathBuf;

/// Errors of import and export.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AssetError {
    /// A file could not be read or written.
    #[error("`{path}`: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The file name has no extension this crate reads.
    #[error("`{path}`: unknown model format (expected .gltf, .glb or .obj)")]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
    /// The glTF document is malformed or inconsistent.
    #[error("`{path}`: invalid glTF: {message}")]
    Gltf {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The glTF file requires extensions this crate does not support.
    #[error("`{path}`: requires unsupported glTF extension(s): {names}")]
    RequiredExtension {
        /// The file.
        path: PathBuf,
        /// Comma-separated extension names.
        names: String,
    },
    /// The OBJ or MTL file is malformed.
    #[error("`{path}`: invalid OBJ: {message}")]
    Obj {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A part of the model has invalid data (NaN positions, indices out of range, ...).
    #[error("`{path}`: {part}: {message}")]
    InvalidData {
        /// The file.
        path: PathBuf,
        /// Which part, e.g. `mesh "chair" primitive 0`.
        part: String,
        /// What is wrong.
        message: String,
    },
    /// An image could not be found or decoded.
    #[error("`{path}`: image {image}: {message}")]
    Image {
        /// The model file.
        path: PathBuf,
        /// Which image (index and URI or name).
        image: String,
        /// What is wrong.
        message: String,
    },
    /// A [`Limits`](crate::Limits) value was exceeded.
    #[error("`{path}`: {what} is {value}, over the limit of {limit} (see luxbake_assets::Limits)")]
    LimitExceeded {
        /// The file.
        path: PathBuf,
        /// What was measured.
        what: &'static str,
        /// Its value.
        value: u64,
        /// The limit.
        limit: u64,
    },
    /// The file holds no triangles.
    #[error("`{path}`: no triangles to bake")]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// Export failed (encoding or an inconsistent bake).
    #[error("export `{path}`: {message}")]
    Export {
        /// The output file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}
