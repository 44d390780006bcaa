//! What every importer fuzz target asserts of a file that parsed: each mesh passes
//! `Mesh::validate` and every light-map UV lies in [0, 1].

use std::path::Path;

use luxbake_assets::{AssetError, ImportOptions, Model};

/// An importer's `import_bytes` (`gltf_in`, `obj_in`).
pub type ImportBytes = fn(&[u8], &Path, &ImportOptions) -> Result<Model, AssetError>;

/// `data` through `import` as the file `name` in a folder that does not exist (so whatever
/// it names outside itself does not resolve), with the default options: no panic, and
/// whatever parses is sound ([`assert_model_is_sound`]).
pub fn assert_import_is_sound(data: &[u8], name: &str, import: ImportBytes) {
    let path = Path::new("/nonexistent/luxbake-fuzz").join(name);
    if let Ok(model) = import(data, &path, &ImportOptions::default()) {
        assert_model_is_sound(&model);
    }
}

pub fn assert_model_is_sound(model: &Model) {
    for part in &model.parts {
        part.mesh.validate().expect("imported meshes are valid");
        assert!(
            part.mesh
                .lightmap_uvs
                .iter()
                .flatten()
                .all(|c| (0.0..=1.0).contains(c))
        );
    }
}
