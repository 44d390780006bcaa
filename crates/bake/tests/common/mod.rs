//! What the bake's integration tests share. Each test file uses a part of it.
#![allow(dead_code)]

use luxbake::bake::{BakeOutput, bake};
use luxbake::cpu::CpuBackend;
use luxbake::scene::Scene;

/// `scene` baked on the CPU backend at its own settings.
pub fn run(scene: &Scene) -> BakeOutput {
    bake(&mut CpuBackend::new(), scene, &scene.settings, &mut |_| {}).expect("bake")
}
