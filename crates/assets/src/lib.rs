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
//!   [`luxbake::sources::scenefile::MeshLoader`]).
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

mod error;
pub mod export;
pub mod gltf_in;
mod image;
mod loader;
mod model;
pub mod obj_in;
mod options;
pub mod uv;

use std::path::Path;

pub use error::AssetError;
pub use loader::SceneLoader;
pub use luxbake::scene::{Albedo, Mesh};
pub use model::{GltfSource, Light, LightKind, Model, Part, UvSource};
pub use options::{ImportOptions, Limits};

/// Reads a model file (its size checked against [`Limits::max_file_bytes`]), choosing the
/// reader by extension (`.gltf`, `.glb`: [`gltf_in::import_bytes`]; `.obj`:
/// [`obj_in::import_bytes`]).
pub fn import(path: &Path, options: &ImportOptions) -> Result<Model, AssetError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let import_bytes = match ext.as_deref() {
        Some("gltf") | Some("glb") => gltf_in::import_bytes,
        Some("obj") => obj_in::import_bytes,
        _ => {
            return Err(AssetError::UnknownFormat {
                path: path.to_path_buf(),
            });
        }
    };
    let bytes = options::read_limited(path, options.limits.max_file_bytes)?;
    import_bytes(&bytes, path, options)
}
