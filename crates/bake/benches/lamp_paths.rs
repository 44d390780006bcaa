//! The lamp paths' pool on the host (`LampPaths::trace`): the part of a lamp swap that no GPU
//! speeds up. `chairs_05` at the browser's 24 texels/m, its lamp once a point (`rw_7.IES`)
//! and once a linear pendant whose opening the pool samples (`rw_5.IES`), on one thread as in
//! the browser's worker.

use std::sync::Arc;

use criterion::{Criterion, criterion_group, criterion_main};
use luxbake::backend::Limits;
use luxbake::prepare::{Lamps, Room};
use luxbake::scene::{LampModel, Scene, Settings};
use luxbake_ies::Photometry;
use luxbake_testkit::shared_data;

fn pool(c: &mut Criterion) {
    let threads = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("one thread");
    let mut group = c.benchmark_group("lamp_paths");
    group.sample_size(10);
    let scene = Scene::builtin("chairs_05").expect("builtin scene");
    let settings = Settings {
        texels_per_metre: 24.0,
        ..scene.settings.clone()
    };
    let limits = Limits {
        max_texture_size: 4096,
        max_array_layers: 256,
        max_texture_units: 16,
        loop_iterations: None,
    };
    let room = Room::prepare(&scene, &settings, limits, &mut |_| {}).expect("room");
    for (name, file) in [("point", "rw_7.IES"), ("opening", "rw_5.IES")] {
        let Some(path) = shared_data("lamp_paths", &format!("photometry/real-world/{file}")) else {
            continue;
        };
        let bytes = std::fs::read(path).expect("read");
        let photometry = Arc::new(Photometry::parse(&bytes).expect("parse"));
        let mut lamps = scene.lamps.clone();
        for l in &mut lamps {
            l.photometry = Arc::clone(&photometry);
            l.position = [0.0, 2.0, 0.0];
            l.model = LampModel::Auto;
        }
        group.bench_function(format!("chairs_05_24/{name}"), |b| {
            b.iter(|| {
                threads.install(|| {
                    let mut lamps = Lamps::prepare(&room, &lamps, &settings);
                    assert!(lamps.trace_paths(&room, &settings, &mut |_| {}, &mut |_| {}));
                    lamps.pool()
                })
            })
        });
    }
    group.finish();
}

criterion_group!(benches, pool);
criterion_main!(benches);
