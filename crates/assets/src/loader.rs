//! [`SceneLoader`]: `luxbake` scene files' `mesh = "x.glb"` objects, read by [`crate::import`].

use luxbake::sources::scenefile::{LoadedFile, MeshLoader, MeshPart, MeshRequest};

use crate::{ImportOptions, Limits, uv};

/// A [`MeshLoader`] for `luxbake` scene files that reads glTF and OBJ files with
/// [`crate::import`]: one [`MeshPart`] per model part, light-map UVs generated when missing
/// with padding [`uv::padding_texels`] of the request's blur at the request's density,
/// measured on the surface scaled by the request's `scale` (so the padding stays the same in
/// texels for scaled objects).
///
/// The file's `KHR_lights_punctual` point and spot lights come back as lamps in the file's
/// frame ([`crate::Light::to_lamp`] with the file's photometry); a scene file adds them for
/// `lights = true`, optionally with `lights_ies` replacing their photometry.
///
/// Warnings (ignored extensions, rejected UV sets, left-out primitives) go to `on_warning`
/// (default: standard error).
pub struct SceneLoader {
    /// Size limits for every file read.
    pub limits: Limits,
    /// Receives each warning, prefixed with the file name.
    pub on_warning: Box<dyn Fn(&str) + Send + Sync>,
}

impl Default for SceneLoader {
    fn default() -> Self {
        SceneLoader {
            limits: Limits::default(),
            on_warning: Box::new(|w| eprintln!("warning: {w}")),
        }
    }
}

impl std::fmt::Debug for SceneLoader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SceneLoader")
            .field("limits", &self.limits)
            .finish_non_exhaustive()
    }
}

impl MeshLoader for SceneLoader {
    fn load(
        &self,
        request: &MeshRequest<'_>,
    ) -> Result<LoadedFile, Box<dyn std::error::Error + Send + Sync>> {
        let options = ImportOptions {
            limits: self.limits,
            unwrap: uv::UnwrapOptions {
                texels_per_metre: request.texels_per_metre,
                padding_texels: uv::padding_texels(request.blur),
                scale: request.scale,
            },
        };
        let model = crate::import(request.path, &options)?;
        for w in &model.warnings {
            (self.on_warning)(&format!("{}: {w}", request.path.display()));
        }
        Ok(LoadedFile {
            lamps: model.lights.iter().map(|l| l.to_lamp(None)).collect(),
            parts: model
                .parts
                .into_iter()
                .map(|p| MeshPart {
                    name: p.name,
                    mesh: p.mesh,
                    albedo: p.albedo,
                })
                .collect(),
        })
    }
}
