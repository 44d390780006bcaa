//! glTF and GLB files (any bytes) through `luxbake-assets`' glTF reader: no panic, and whatever
//! parses gives meshes that pass `Mesh::validate`, with light-map UVs in [0, 1]. External
//! buffers and images resolve against a folder that does not exist (data URIs are read).
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use luxbake_assets::ImportOptions;

#[path = "model_checks.rs"]
mod model_checks;

fuzz_target!(|data: &[u8]| {
    let options = ImportOptions::default();
    let path = Path::new("/nonexistent/luxbake-fuzz/model.gltf");
    let Ok(model) = luxbake_assets::gltf_in::import_bytes(data, path, &options) else {
        return;
    };
    model_checks::assert_model_is_sound(&model);
});
