//! TOML scene files (any bytes, read as UTF-8 where valid). Relative paths resolve against a
//! folder that does not exist, so the fuzzer exercises the parser and validation, not the
//! file system. Whatever parses must lay out and (when small) rasterise without panicking,
//! and give finite G-buffer data.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use luxbake::gbuffer::rasterize;
use luxbake::layout::Layout;
use luxbake::scene::Scene;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(scene) = Scene::from_toml_str(text, Path::new("/nonexistent/luxbake-fuzz")) else {
        return;
    };
    scene.validate().expect("parsed scenes are valid");
    let (triangles, attributes) = scene.world_triangles();
    assert_eq!(triangles.len(), attributes.len());
    for lamp in &scene.lamps {
        let m = lamp.world_to_photometric_matrix();
        assert!(m.iter().flatten().all(|v| v.is_finite()));
    }
    if let Ok(layout) = Layout::new(&scene, 1024, 8)
        && layout.allocated_texels() <= 1 << 20
    {
        let g = rasterize(&scene, &layout);
        assert!(g.position.iter().chain(&g.normal).chain(&g.albedo).all(|v| v.is_finite()));
    }
});
