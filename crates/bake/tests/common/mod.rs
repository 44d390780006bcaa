//! What the bake's integration tests share. Each test file uses a part of it.
#![allow(dead_code)]

use luxbake::GpuBackend;
use luxbake::bake::{BakeOutput, Room};
use luxbake::scene::{Quality, Scene, Settings};
use luxbake_backend_cpu::CpuBackend;

/// `scene` baked on the CPU backend at its own settings.
pub fn run(scene: &Scene) -> BakeOutput {
    luxbake_backend_cpu::bake(scene).expect("bake")
}

/// `scene` prepared for its own settings and the CPU backend's limits.
pub fn prepare(scene: &Scene) -> Room {
    Room::prepare(
        scene,
        &scene.settings,
        CpuBackend::new().limits(),
        &mut |_| {},
    )
    .expect("room")
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
