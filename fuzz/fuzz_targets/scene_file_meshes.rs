//! TOML scene files (any bytes, read as UTF-8 where valid) parsed with `luxbake-assets`'
//! `SceneLoader`, so `mesh = "..."` objects go through the loader's error paths (the files
//! resolve against a folder that does not exist). Whatever parses must validate.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use luxbake::sources::scenefile::from_str_with;
use luxbake_assets::SceneLoader;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let loader = SceneLoader {
        on_warning: Box::new(|_| {}),
        ..SceneLoader::default()
    };
    let base = Path::new("/nonexistent/luxbake-fuzz");
    if let Ok(scene) = from_str_with(text, base, None, &loader) {
        scene.validate().expect("parsed scenes are valid");
    }
});
