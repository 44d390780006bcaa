//! What the output crate's integration tests share.
#![allow(dead_code)]

use luxbake::bake::{BakeOutput, bake};
use luxbake::scene::Scene;
use luxbake_backend_cpu::CpuBackend;
pub use luxbake_testkit::temp_dir;

/// `scene` baked on the CPU backend at its own settings.
pub fn run(scene: &Scene) -> BakeOutput {
    bake(&mut CpuBackend::new(), scene, &scene.settings, &mut |_| {}).expect("bake")
}
