//! What the bake's integration tests share. Each test file uses a part of it.
#![allow(dead_code)]

use std::path::PathBuf;

use luxbake::bake::{BakeOutput, bake};
use luxbake::cpu::CpuBackend;
use luxbake::scene::Scene;

/// `scene` baked on the CPU backend at its own settings.
pub fn run(scene: &Scene) -> BakeOutput {
    bake(&mut CpuBackend::new(), scene, &scene.settings, &mut |_| {}).expect("bake")
}

/// An empty path in the temporary folder for this process: `luxbake-<prefix>-<pid>-<tag>`
/// (anything left there by an earlier run removed).
pub fn temp_dir(prefix: &str, tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("luxbake-{prefix}-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}
