//! OBJ files (any bytes) through `luxbake-assets`' OBJ reader: no panic, and whatever parses
//! gives meshes that pass `Mesh::validate`, with light-map UVs in [0, 1]. The `.mtl` files it
//! names resolve against a folder that does not exist.
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "model_checks.rs"]
mod model_checks;

fuzz_target!(|data: &[u8]| {
    model_checks::assert_import_is_sound(data, "model.obj", luxbake_assets::obj_in::import_bytes);
});
