//! glTF and GLB files (any bytes) through `luxbake-assets`' glTF reader: no panic, and whatever
//! parses gives meshes that pass `Mesh::validate`, with light-map UVs in [0, 1]. External
//! buffers and images resolve against a folder that does not exist (data URIs are read).
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "model_checks.rs"]
mod model_checks;

fuzz_target!(|data: &[u8]| {
    model_checks::assert_import_is_sound(data, "model.gltf", luxbake_assets::gltf_in::import_bytes);
});
