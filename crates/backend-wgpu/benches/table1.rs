//! The paper's Table 1 on the wgpu backend: bake time per pass of `chairs_01/03/05/10` and
//! `sofa_01`, for both places the BVH can live ([`BvhStorage::Buffers`] and
//! [`BvhStorage::Textures`]), optionally beside the CPU reference. A measured run (median of
//! `RUNS` bakes), not a criterion benchmark: one configuration takes seconds to minutes on
//! lavapipe. Same options and output as the glow backend's `table1` bench, so the two tables
//! line up.
//!
//! ```sh
//! WGPU_BACKEND=vulkan cargo bench -p luxbake-backend-wgpu --bench table1
//! # options (environment): LUXBAKE_BENCH_SCENES=chairs_01,sofa_01 LUXBAKE_BENCH_MODES=mtbvh,tbvh
//! #   LUXBAKE_BENCH_STORAGE=buffers,textures LUXBAKE_BENCH_RAYS=16 LUXBAKE_BENCH_DENSITY=64
//! #   LUXBAKE_BENCH_RUNS=3 LUXBAKE_BENCH_CPU=1
//! ```
//!
//! Pass times are the bake driver's wall time per pass (each tile is waited for), so they
//! include the driver's work, not the asset load, layout, rasterisation or BVH build (the
//! paper's Table 1 also counts only the pre-computation). Prints a Markdown table.

use std::collections::BTreeMap;

use luxbake::backend::GpuBackend;
use luxbake::bake::bake;
use luxbake::scene::{Blur, BvhMode, Scene, Settings};
use luxbake_backend_cpu::CpuBackend;
use luxbake_backend_wgpu::{BvhStorage, WgpuBackend, WgpuOptions};

fn env<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn list(name: &str, default: &str) -> Vec<String> {
    std::env::var(name)
        .unwrap_or_else(|_| default.to_owned())
        .split(',')
        .map(|s| s.trim().to_owned())
        .filter(|s| !s.is_empty())
        .collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        0.0
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Median seconds per pass label (same-label passes summed per run), median total, texels and
/// triangles.
struct Row {
    passes: BTreeMap<&'static str, f64>,
    total: f64,
    texels: u64,
    triangles: usize,
}

fn measure<B: GpuBackend>(backend: &mut B, scene: &Scene, settings: &Settings, runs: usize) -> Row {
    let mut per_pass: BTreeMap<&'static str, Vec<f64>> = BTreeMap::new();
    let mut totals = Vec::new();
    let mut texels = 0;
    let mut triangles = 0;
    for _ in 0..runs {
        let out = match bake(backend, scene, settings, &mut |_| {}) {
            Ok(out) => out,
            Err(e) => {
                eprintln!("bake failed: {e}");
                std::process::exit(1);
            }
        };
        let mut this: BTreeMap<&'static str, f64> = BTreeMap::new();
        for p in &out.report.passes {
            *this.entry(p.label).or_default() += p.seconds;
        }
        totals.push(this.values().sum());
        for (k, v) in this {
            per_pass.entry(k).or_default().push(v);
        }
        texels = out.report.texels;
        triangles = out.report.triangles;
    }
    Row {
        passes: per_pass.into_iter().map(|(k, v)| (k, median(v))).collect(),
        total: median(totals),
        texels,
        triangles,
    }
}

fn ms(s: f64) -> String {
    format!("{:.0}", s * 1000.0)
}

fn main() {
    let scenes = list(
        "LUXBAKE_BENCH_SCENES",
        "chairs_01,chairs_03,chairs_05,chairs_10,sofa_01",
    );
    let modes = list("LUXBAKE_BENCH_MODES", "mtbvh");
    let storages = list("LUXBAKE_BENCH_STORAGE", "buffers");
    let rays: u32 = env("LUXBAKE_BENCH_RAYS", 16);
    let density: f32 = env("LUXBAKE_BENCH_DENSITY", Settings::DEFAULT_TEXELS_PER_METRE);
    let runs: usize = env("LUXBAKE_BENCH_RUNS", 3usize).max(1);
    let with_cpu = env("LUXBAKE_BENCH_CPU", 0u32) != 0;
    println!(
        "| scene | backend | BVH | texels | triangles | direct | blur+copy+albedo | gather | \
         combine | total ms |"
    );
    println!("|---|---|---|---:|---:|---:|---:|---:|---:|---:|");
    for name in &scenes {
        for mode in &modes {
            let bvh = match mode.as_str() {
                "tbvh" => BvhMode::Tbvh,
                "none" => BvhMode::None,
                _ => BvhMode::Mtbvh,
            };
            let settings = Settings {
                rays,
                bounces: 1,
                blur: Blur::Sigma(Settings::PAPER_BLUR_SIGMA),
                texels_per_metre: density,
                bvh,
                seed: 1,
                ..Settings::paper()
            };
            let scene = match Scene::builtin_with_settings(name, settings.clone()) {
                Ok(s) => s,
                Err(e) => {
                    eprintln!("scene {name}: {e}");
                    continue;
                }
            };
            let mut rows = Vec::new();
            for storage in &storages {
                let bvh_storage = if storage == "textures" {
                    BvhStorage::Textures
                } else {
                    BvhStorage::Buffers
                };
                let mut backend = match WgpuBackend::with_options(WgpuOptions {
                    bvh_storage,
                    ..WgpuOptions::default()
                }) {
                    Ok(b) => b,
                    Err(e) => {
                        eprintln!("no wgpu backend: {e}");
                        return;
                    }
                };
                let label = format!("wgpu ({storage})");
                rows.push((label, measure(&mut backend, &scene, &settings, runs)));
            }
            if with_cpu {
                rows.push((
                    "cpu".to_owned(),
                    measure(&mut CpuBackend::new(), &scene, &settings, runs),
                ));
            }
            for (label, r) in rows {
                let get = |k: &str| r.passes.get(k).copied().unwrap_or(0.0);
                let mid: f64 = [
                    "copy_direct",
                    "blur_direct_u",
                    "blur_direct_v",
                    "albedo_direct",
                    "copy_combined",
                    "blur_combined_u",
                    "blur_combined_v",
                    "albedo_combined",
                ]
                .iter()
                .map(|k| get(k))
                .sum();
                println!(
                    "| {name} | {label} | {mode} | {} | {} | {} | {} | {} | {} | {} |",
                    r.texels,
                    r.triangles,
                    ms(get("direct")),
                    ms(mid),
                    ms(get("gather")),
                    ms(get("combine")),
                    ms(r.total)
                );
            }
        }
    }
    println!("\n{rays} gather rays, {density} texels/m, one bounce, blur σ = 2, median of {runs}");
}
