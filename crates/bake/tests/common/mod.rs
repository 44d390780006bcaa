//! What the bake's integration tests share. Each test file uses a part of it.
#![allow(dead_code)]

use luxbake::bake::BakeOutput;
use luxbake::scene::{Quality, Scene, Settings};

/// `scene` baked on the CPU backend at its own settings.
pub fn run(scene: &Scene) -> BakeOutput {
    luxbake_backend_cpu::bake(scene).expect("bake")
}

/// `chairs_01` at the default preset with 4 rays at 8 texels/m: a small room whose bakes take
/// a fraction of a second, for tests that bake it many times.
pub fn small_room() -> Scene {
    let settings = Settings {
        rays: 4,
        texels_per_metre: 8.0,
        ..Settings::preset(Quality::Default)
    };
    Scene::builtin_with_settings("chairs_01", settings).expect("chairs_01")
}

/// Every texel of every stage of every map of `out` is finite and non-negative.
pub fn assert_finite(out: &BakeOutput) {
    assert_eq!(out.first_invalid_texel(), None);
}
