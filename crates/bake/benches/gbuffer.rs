//! Scene preparation on the CPU: building the built-in scenes (procedural meshes), the
//! light-map layout and the G-buffer rasterisation, per built-in scene at the default density.

use criterion::{Criterion, criterion_group, criterion_main};
use luxbake::gbuffer::rasterize;
use luxbake::layout::Layout;
use luxbake::scene::Scene;

fn prepare(c: &mut Criterion) {
    let mut group = c.benchmark_group("prepare");
    group.sample_size(10);
    for name in ["chairs_05", "sofa_01", "sphere"] {
        group.bench_function(format!("build/{name}"), |b| {
            b.iter(|| Scene::builtin(name).expect("builtin scene"))
        });
        let scene = Scene::builtin(name).expect("builtin scene");
        group.bench_function(format!("layout/{name}"), |b| {
            b.iter(|| Layout::new(&scene, 4096, 256).expect("layout"))
        });
        let layout = Layout::new(&scene, 4096, 256).expect("layout");
        group.bench_function(format!("rasterize/{name}"), |b| {
            b.iter(|| rasterize(&scene, &layout))
        });
    }
    group.finish();
}

criterion_group!(benches, prepare);
criterion_main!(benches);
