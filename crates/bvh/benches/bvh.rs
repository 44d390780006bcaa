//! Build time per triangle and CPU rays/s (closest hit and any hit) for TBVH, MTBVH and brute
//! force over the encoded texels, and obvhs's own builder and traversal on the same rays, on
//! a procedural room with 10 box chairs (2376 triangles), GlamVelvetSofa and SheenChair.
//!
//! `cargo bench -p luxbake-bvh` (the two models are skipped with a message when `../shared`
//! is absent, unless `CI` is set).
//!
//! Times are the benchmark thread's **CPU time** (`CLOCK_THREAD_CPUTIME_ID` on Unix, wall time
//! elsewhere), not wall time, so the figures stay meaningful on a machine shared with other
//! builds; everything is single-threaded.

#[path = "../tests/common/mod.rs"]
mod common;

use std::hint::black_box;
use std::time::Duration;

use criterion::measurement::{Measurement, ValueFormatter};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use luxbake_bvh::{BuildOptions, Bvh, EncodeOptions, Ray, Traversal, encode};

/// CPU time of the calling thread, in nanoseconds.
#[cfg(unix)]
fn thread_cpu_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; the clock id is a constant the C library knows.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    if rc != 0 {
        return 0;
    }
    (ts.tv_sec as u64) * 1_000_000_000 + ts.tv_nsec as u64
}

/// Wall time where no thread CPU clock is available.
#[cfg(not(unix))]
fn thread_cpu_ns() -> u64 {
    use std::sync::OnceLock;
    static START: OnceLock<std::time::Instant> = OnceLock::new();
    START
        .get_or_init(std::time::Instant::now)
        .elapsed()
        .as_nanos() as u64
}

/// Criterion measurement: thread CPU time in nanoseconds.
struct CpuTime;

impl Measurement for CpuTime {
    type Intermediate = u64;
    type Value = u64;
    fn start(&self) -> u64 {
        thread_cpu_ns()
    }
    fn end(&self, start: u64) -> u64 {
        thread_cpu_ns().saturating_sub(start)
    }
    fn add(&self, a: &u64, b: &u64) -> u64 {
        a + b
    }
    fn zero(&self) -> u64 {
        0
    }
    fn to_f64(&self, v: &u64) -> f64 {
        *v as f64
    }
    fn formatter(&self) -> &dyn ValueFormatter {
        &CpuTimeFormatter
    }
}

struct CpuTimeFormatter;

impl ValueFormatter for CpuTimeFormatter {
    fn scale_values(&self, typical: f64, values: &mut [f64]) -> &'static str {
        let (div, unit) = if typical < 1e3 {
            (1.0, "ns (cpu)")
        } else if typical < 1e6 {
            (1e3, "µs (cpu)")
        } else if typical < 1e9 {
            (1e6, "ms (cpu)")
        } else {
            (1e9, "s (cpu)")
        };
        values.iter_mut().for_each(|v| *v /= div);
        unit
    }

    fn scale_throughputs(
        &self,
        typical: f64,
        throughput: &Throughput,
        values: &mut [f64],
    ) -> &'static str {
        let n = match *throughput {
            Throughput::Elements(n)
            | Throughput::Bytes(n)
            | Throughput::BytesDecimal(n)
            | Throughput::Bits(n)
            | Throughput::ElementsAndBytes { elements: n, .. } => n as f64,
        };
        let per_s = n * 1e9 / typical;
        let (div, unit) = if per_s < 1e3 {
            (1.0, "elem/s (cpu)")
        } else if per_s < 1e6 {
            (1e3, "Kelem/s (cpu)")
        } else {
            (1e6, "Melem/s (cpu)")
        };
        values.iter_mut().for_each(|v| *v = n * 1e9 / *v / div);
        unit
    }

    fn scale_for_machines(&self, _values: &mut [f64]) -> &'static str {
        "ns"
    }
}

struct Scene {
    name: &'static str,
    tris: Vec<common::Tri>,
}

fn scenes() -> Vec<Scene> {
    let mut scenes = vec![Scene {
        name: "room_10_chairs",
        tris: common::room_with_chairs(),
    }];
    for name in ["GlamVelvetSofa", "SheenChair"] {
        if let Some(tris) = common::load_model(name) {
            scenes.push(Scene { name, tris });
        }
    }
    scenes
}

/// Bake-like rays: gather rays from points on random triangles into random directions
/// (closest hit, t in (1e-4, ∞)) and shadow rays from the same points to a lamp above the
/// scene's centre (any hit, t in (1e-4, 1)).
fn bake_rays(tris: &[common::Tri], count: usize) -> (Vec<Ray>, Vec<Ray>) {
    let (lo, hi) = common::bounds(tris);
    let lamp = [
        0.5 * (lo[0] + hi[0]),
        hi[1] - 0.05 * (hi[1] - lo[1]),
        0.5 * (lo[2] + hi[2]),
    ];
    let mut rng = common::Rng::new(99);
    let mut gather = Vec::with_capacity(count);
    let mut shadow = Vec::with_capacity(count);
    for _ in 0..count {
        let t = tris[rng.below(tris.len() as u64) as usize];
        let (mut a, mut b) = (rng.f32(), rng.f32());
        if a + b > 1.0 {
            (a, b) = (1.0 - a, 1.0 - b);
        }
        let origin: [f32; 3] =
            std::array::from_fn(|k| t[0][k] + a * (t[1][k] - t[0][k]) + b * (t[2][k] - t[0][k]));
        gather.push(Ray {
            origin,
            dir: rng.direction(),
        });
        shadow.push(Ray {
            origin,
            dir: std::array::from_fn(|k| lamp[k] - origin[k]),
        });
    }
    (gather, shadow)
}

fn bench(c: &mut Criterion<CpuTime>) {
    let options = BuildOptions::default();
    for scene in scenes() {
        let tris = &scene.tris;
        let (bvh, encoded) = common::build_and_encode_objects(tris, 11);
        let otris = common::obvhs_triangles(tris);
        let obvh = common::obvhs_build(&otris, common::obvhs_params(false, options.max_leaf_size));
        println!(
            "{}: {} triangles, {} nodes; SAH cost (C_t = C_i = 1) ours {:.2}, obvhs medium {:.2}",
            scene.name,
            tris.len(),
            bvh.nodes().len(),
            bvh.sah_cost(),
            common::obvhs_sah(&obvh, 1.0, 1.0)
        );

        let mut group = c.benchmark_group(format!("build/{}", scene.name));
        group
            .sample_size(10)
            .measurement_time(Duration::from_secs(1))
            .warm_up_time(Duration::from_millis(500));
        group.throughput(Throughput::Elements(tris.len() as u64));
        group.bench_function("luxbake_binned_sah", |b| {
            b.iter(|| Bvh::build(black_box(tris), &options).expect("build"))
        });
        group.bench_function("luxbake_build_and_encode", |b| {
            let attrs = common::attributes(tris, 11);
            b.iter(|| {
                let bvh = Bvh::build(black_box(tris), &options).expect("build");
                encode(&bvh, tris, &attrs, &EncodeOptions::default()).expect("encode")
            })
        });
        group.bench_function("obvhs_medium", |b| {
            let params = common::obvhs_params(false, options.max_leaf_size);
            b.iter(|| common::obvhs_build(black_box(&otris), params))
        });
        group.finish();

        let (gather, shadow) = bake_rays(tris, 4096);
        for traversal in [Traversal::Mtbvh, Traversal::Tbvh, Traversal::BruteForce] {
            let per_ray = |rays: &[Ray], t_max: f32, any: bool| {
                let (mut nodes, mut tests) = (0u64, 0u64);
                for r in rays {
                    let s = encoded.traversal_stats(r, 1e-4, t_max, traversal, any);
                    nodes += u64::from(s.nodes);
                    tests += u64::from(s.triangle_tests);
                }
                let n = rays.len() as f64;
                (nodes as f64 / n, tests as f64 / n)
            };
            let n = if traversal == Traversal::BruteForce {
                128
            } else {
                gather.len()
            };
            let (gn, gt) = per_ray(&gather[..n], f32::INFINITY, false);
            let (sn, st) = per_ray(&shadow[..n], 1.0, true);
            println!(
                "{} {traversal:?}: per ray, closest hit {gn:.1} nodes {gt:.1} triangle tests; any hit {sn:.1} nodes {st:.1} tests",
                scene.name
            );
        }
        for (query, rays) in [("closest_hit", &gather), ("any_hit", &shadow)] {
            let mut group = c.benchmark_group(format!("{query}/{}", scene.name));
            group
                .sample_size(10)
                .measurement_time(Duration::from_secs(1))
                .warm_up_time(Duration::from_millis(500));
            let t_max = if query == "any_hit" {
                1.0
            } else {
                f32::INFINITY
            };
            for (label, traversal) in [
                ("mtbvh", Traversal::Mtbvh),
                ("tbvh", Traversal::Tbvh),
                ("brute_force", Traversal::BruteForce),
            ] {
                // Brute force on 40k triangles is slow: fewer rays, same rays/s figure.
                let n = if traversal == Traversal::BruteForce {
                    128
                } else {
                    rays.len()
                };
                let rays = &rays[..n];
                group.throughput(Throughput::Elements(n as u64));
                group.bench_with_input(BenchmarkId::new(label, n), rays, |b, rays| {
                    b.iter(|| {
                        let mut hits = 0u32;
                        for r in rays {
                            if query == "any_hit" {
                                hits += u32::from(encoded.any_hit(r, 1e-4, t_max, traversal));
                            } else {
                                hits += u32::from(
                                    encoded.closest_hit(r, 1e-4, t_max, traversal).is_some(),
                                );
                            }
                        }
                        hits
                    })
                });
            }
            group.throughput(Throughput::Elements(rays.len() as u64));
            group.bench_with_input(BenchmarkId::new("obvhs", rays.len()), rays, |b, rays| {
                b.iter(|| {
                    let mut hits = 0u32;
                    for r in rays.iter() {
                        if query == "any_hit" {
                            hits += u32::from(common::obvhs_any(&obvh, &otris, r, 1e-4, t_max));
                        } else {
                            hits += u32::from(
                                common::obvhs_closest(&obvh, &otris, r, 1e-4, t_max).is_some(),
                            );
                        }
                    }
                    hits
                })
            });
            group.finish();
        }
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().with_measurement(CpuTime);
    targets = bench
}
criterion_main!(benches);
