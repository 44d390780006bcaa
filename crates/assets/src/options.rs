//! What [`crate::import`] may read and how it fills in missing light-map UVs: [`Limits`],
//! [`ImportOptions`], and the size-checked file read every reader goes through.

use std::path::Path;

use crate::error::AssetError;
use crate::uv;

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

/// Options of [`import`](crate::import).
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

/// Reads a whole file after checking its size against `limit`.
pub(crate) fn read_limited(path: &Path, limit: u64) -> Result<Vec<u8>, AssetError> {
    let io = |source| AssetError::Io {
        path: path.to_path_buf(),
        source,
    };
    let len = std::fs::metadata(path).map_err(io)?.len();
    check_limit(path, "the file size in bytes", len, limit)?;
    std::fs::read(path).map_err(io)
}

/// [`AssetError::LimitExceeded`] for file `path` where `value` (of `what`) is over `limit`.
pub(crate) fn check_limit(
    path: &Path,
    what: &'static str,
    value: u64,
    limit: u64,
) -> Result<(), AssetError> {
    if value > limit {
        return Err(AssetError::LimitExceeded {
            path: path.to_path_buf(),
            what,
            value,
            limit,
        });
    }
    Ok(())
}
