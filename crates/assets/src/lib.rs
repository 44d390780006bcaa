//! # luxbake-assets
//!
//! Real scenes for `luxbake`: glTF 2.0 and OBJ files in, light-map UVs when they are missing,
//! the baked scene back out as glTF. Kept apart from the `luxbake` core so engines that embed
//! the core do not pull in glTF, OBJ or image decoders.
//!
//! - [`import`] reads `.gltf`, `.glb` ([`gltf_in`]) and `.obj` + `.mtl` ([`obj_in`]) files into a
//!   [`Model`]: one [`Part`] per glTF primitive or OBJ material group, each a ready
//!   [`luxbake::scene::Mesh`] with an [`Albedo`] (base colour factor × texture, linear) and
//!   light-map UVs, plus the file's `KHR_lights_punctual` point and spot lights as [`Light`]s.
//! - Light-map UVs ([`uv`]): a glTF `TEXCOORD_1` set is used when [`uv::check`] accepts it (in
//!   [0, 1]², no overlaps, no zero-area charts); otherwise [`uv::unwrap`] generates one with our
//!   own chart unwrapper and packer, its padding sized for the bake's blur radius.
//! - [`SceneLoader`] plugs [`import`] into `luxbake`'s scene files (`mesh = "room.glb"`, see
//!   [`luxbake::scenefile::MeshLoader`]).
//! - [`export`] writes a baked scene as a `.glb` with `TEXCOORD_1`, a PNG light map per object
//!   and a linear EXR (lux) beside it; [`export::export_scene`] writes an unbaked scene (meshes,
//!   albedo, lamps in `extras`) for other tools.
//!
//! ## Conventions
//! Metres, right-handed, +Y up (glTF's frame; OBJ files are read as if they were in it). Part
//! meshes are in the file's frame: glTF node transforms are applied, the object transform of a
//! scene file is not. Albedo is linear RGB in [0, 1] (sRGB textures are decoded). Light-map UVs
//! follow `luxbake`: (0, 0) at the top-left of the map, v down — the same as glTF's UVs, so they
//! are written unchanged. glTF light intensities are candela (as the extension defines them).
//!
//! ## Bad input
//! Every reader checks sizes against [`Limits`] before allocating, validates indices,
//! accessors and numbers, and returns an [`AssetError`] naming the file and the part; no input
//! makes it panic. Unsupported glTF extensions are reported in [`Model::warnings`]; required
//! ones it does not support are an error.

#![warn(missing_docs)]

pub mod export;
pub mod gltf_in;
mod image;
mod loader;
mod model;
pub mod obj_in;
pub mod uv;

use std::path::{Path, PathBuf};

pub use loader::SceneLoader;
pub use luxbake::scene::{Albedo, Mesh};
pub use model::{Light, LightKind, Model, Part, UvSource};

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
    /// A [`Limits`] value was exceeded.
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

/// Upper bounds on what a file may make the importer read or allocate. The defaults suit
/// furnished rooms and reject absurd inputs early.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// Largest model file, and largest external buffer or image file, bytes (default 256 MiB).
    pub max_file_bytes: u64,
    /// Most triangles over the whole model (default 4 000 000).
    pub max_triangles: u64,
    /// Most vertices over the whole model (default 12 000 000).
    pub max_vertices: u64,
    /// Largest image side accepted, texels (default 16384).
    pub max_texture_side: u32,
    /// Largest image accepted, texels (default 64 Mi).
    pub max_texture_texels: u64,
    /// Albedo textures larger than this (per side) are box-filtered down by powers of two
    /// before use (default 1024): finer detail than the light map cannot show is dropped.
    pub albedo_texture_side: u32,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_file_bytes: 256 << 20,
            max_triangles: 4_000_000,
            max_vertices: 12_000_000,
            max_texture_side: 16_384,
            max_texture_texels: 64 << 20,
            albedo_texture_side: 1024,
        }
    }
}

/// Options of [`import`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImportOptions {
    /// Size limits.
    pub limits: Limits,
    /// How light-map UVs are generated when a part has no usable set.
    pub unwrap: uv::UnwrapOptions,
}

impl Default for ImportOptions {
    /// Default limits; padding for `luxbake`'s default blur at its default density, scale 1.
    fn default() -> Self {
        let s = luxbake::scene::Settings::default();
        ImportOptions {
            limits: Limits::default(),
            unwrap: uv::UnwrapOptions {
                texels_per_metre: s.texels_per_metre,
                padding_texels: uv::padding_texels(s.blur),
                scale: [1.0; 3],
            },
        }
    }
}

/// Reads a model file, choosing the reader by extension (`.gltf`, `.glb`, `.obj`).
pub fn import(path: &Path, options: &ImportOptions) -> Result<Model, AssetError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("gltf") | Some("glb") => gltf_in::import(path, options),
        Some("obj") => obj_in::import(path, options),
        _ => Err(AssetError::UnknownFormat {
            path: path.to_path_buf(),
        }),
    }
}

/// Reads a whole file after checking its size against `limit`.
pub(crate) fn read_limited(path: &Path, limit: u64) -> Result<Vec<u8>, AssetError> {
    let io = |source| AssetError::Io {
        path: path.to_path_buf(),
        source,
    };
    let len = std::fs::metadata(path).map_err(io)?.len();
    if len > limit {
        return Err(AssetError::LimitExceeded {
            path: path.to_path_buf(),
            what: "the file size in bytes",
            value: len,
            limit,
        });
    }
    std::fs::read(path).map_err(io)
}
