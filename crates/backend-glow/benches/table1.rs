//! The paper's Table 1 on the glow backend: bake time per pass of `chairs_01/03/05/10` and
//! `sofa_01` with MTBVH, TBVH and no BVH (a measured run, median of `RUNS` bakes; not a
//! criterion benchmark because one configuration takes seconds to minutes on llvmpipe).
//!
//! ```sh
//! cargo bench -p luxbake-backend-glow --bench table1
//! # options (environment): LUXBAKE_BENCH_SCENES=chairs_01,sofa_01 LUXBAKE_BENCH_MODES=mtbvh,tbvh
//! #   LUXBAKE_BENCH_RAYS=16 LUXBAKE_BENCH_DENSITY=64 LUXBAKE_BENCH_RUNS=3 LUXBAKE_BENCH_CPU=1
//! ```
//!
//! Per pass two times are taken: the bake driver's wall time (each glow pass ends with
//! `glFinish`) and the process's CPU time (user + system of all threads, llvmpipe's included,
//! from `/proc/self/stat`), which stays meaningful on a machine shared with other jobs. Neither
//! includes the asset load, layout, rasterisation or BVH build (the paper's Table 1 also counts
//! only the pre-computation). Prints a Markdown table; the columns are summed per pass kind.

use std::collections::BTreeMap;

use luxbake::backend::GpuBackend;
use luxbake::bake::{Progress, bake};
use luxbake::cpu::CpuBackend;
use luxbake::scene::{Blur, BvhMode, Scene, Settings};
use luxbake_backend_glow::GlowBackend;

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

/// Process CPU time (user + system, all threads) in seconds, at clock-tick resolution; 0 where
/// `/proc` is unavailable.
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the parenthesised command name: state is field 3, utime 14, stime 15.
    let after = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let fields: Vec<&str> = after.split_whitespace().collect();
    let ticks = |i: usize| {
        fields
            .get(i)
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    (ticks(11) + ticks(12)) / 100.0
}

/// Median seconds per pass label (passes with the same label summed per run), wall and CPU,
/// the median totals, texels and triangles.
struct Row {
    passes: BTreeMap<&'static str, f64>,
    cpu: BTreeMap<&'static str, f64>,
    total: f64,
    cpu_total: f64,
    texels: u64,
    triangles: usize,
}

fn measure<B: GpuBackend>(backend: &mut B, scene: &Scene, settings: &Settings, runs: usize) -> Row {
    let mut per_pass: BTreeMap<&'static str, Vec<f64>> = BTreeMap::new();
    let mut per_pass_cpu: BTreeMap<&'static str, Vec<f64>> = BTreeMap::new();
    let mut totals = Vec::new();
    let mut cpu_totals = Vec::new();
    let mut texels = 0;
    let mut triangles = 0;
    for _ in 0..runs {
        let mut cpu: BTreeMap<&'static str, f64> = BTreeMap::new();
        let mut started: Option<(&'static str, f64)> = None;
        let out = bake(backend, scene, settings, &mut |p| match p {
            Progress::PassStart { label, .. } => started = Some((label, cpu_seconds())),
            Progress::PassDone { .. } => {
                if let Some((label, t0)) = started.take() {
                    *cpu.entry(label).or_default() += cpu_seconds() - t0;
                }
            }
            _ => {}
        })
        .expect("bake");
        let mut this: BTreeMap<&'static str, f64> = BTreeMap::new();
        for p in &out.report.passes {
            *this.entry(p.label).or_default() += p.seconds;
        }
        totals.push(this.values().sum());
        cpu_totals.push(cpu.values().sum());
        for (k, v) in this {
            per_pass.entry(k).or_default().push(v);
        }
        for (k, v) in cpu {
            per_pass_cpu.entry(k).or_default().push(v);
        }
        texels = out.report.texels;
        triangles = out.report.triangles;
    }
    let medians = |m: BTreeMap<&'static str, Vec<f64>>| -> BTreeMap<&'static str, f64> {
        m.into_iter().map(|(k, v)| (k, median(v))).collect()
    };
    Row {
        passes: medians(per_pass),
        cpu: medians(per_pass_cpu),
        total: median(totals),
        cpu_total: median(cpu_totals),
        texels,
        triangles,
    }
}

fn main() {
    // `cargo bench` passes `--bench`; `cargo test --benches` does not: do nothing then.
    if !std::env::args().any(|a| a == "--bench") {
        println!("table1: run with `cargo bench -p luxbake-backend-glow --bench table1`");
        return;
    }
    let scenes = list(
        "LUXBAKE_BENCH_SCENES",
        "chairs_01,chairs_03,chairs_05,chairs_10,sofa_01",
    );
    let modes = list("LUXBAKE_BENCH_MODES", "mtbvh,tbvh,none");
    let rays: u32 = env("LUXBAKE_BENCH_RAYS", 16);
    let density: f32 = env("LUXBAKE_BENCH_DENSITY", Settings::DEFAULT_TEXELS_PER_METRE);
    let runs: usize = env("LUXBAKE_BENCH_RUNS", 3usize).max(1);
    let with_cpu: u32 = env("LUXBAKE_BENCH_CPU", 0);
    let mut glow = match GlowBackend::headless() {
        Ok(b) => b,
        Err(e) => {
            eprintln!("table1: no headless GL context: {e}");
            return;
        }
    };
    println!(
        "renderer: {} ({}); rays {rays}, {density} texels/m, 1 bounce, blur σ 2, median of {runs}",
        glow.capabilities().renderer,
        glow.capabilities().version
    );
    println!(
        "wall ms / CPU ms per pass kind (CPU = user + system time of all threads of the process)"
    );
    println!(
        "| scene | backend | bvh | texels | triangles | direct | gather | blur ×4 | copy+albedo+combine | total |"
    );
    println!("|---|---|---|--:|--:|--:|--:|--:|--:|--:|");
    for name in &scenes {
        for mode in &modes {
            let bvh = match mode.as_str() {
                "mtbvh" => BvhMode::Mtbvh,
                "tbvh" => BvhMode::Tbvh,
                "none" => BvhMode::None,
                other => panic!("unknown mode {other}"),
            };
            let settings = Settings {
                rays,
                bounces: 1,
                blur: Blur::Sigma(2.0),
                texels_per_metre: density,
                bvh,
                ..Settings::default()
            };
            let scene = Scene::builtin_with_settings(name, settings.clone()).expect("scene");
            let mut rows = vec![("glow", measure(&mut glow, &scene, &settings, runs))];
            if with_cpu != 0 && bvh == BvhMode::Mtbvh {
                rows.push((
                    "cpu",
                    measure(&mut CpuBackend::new(), &scene, &settings, runs),
                ));
            }
            for (backend, row) in rows {
                let ms = |labels: &[&str]| -> String {
                    let sum = |m: &BTreeMap<&'static str, f64>| -> f64 {
                        labels.iter().filter_map(|l| m.get(l)).sum::<f64>() * 1e3
                    };
                    format!("{:.0} / {:.0}", sum(&row.passes), sum(&row.cpu))
                };
                println!(
                    "| {name} | {backend} | {mode} | {} | {} | {} | {} | {} | {} | {:.0} / {:.0} |",
                    row.texels,
                    row.triangles,
                    ms(&["direct"]),
                    ms(&["gather"]),
                    ms(&[
                        "blur_direct_u",
                        "blur_direct_v",
                        "blur_combined_u",
                        "blur_combined_v"
                    ]),
                    ms(&[
                        "copy_direct",
                        "albedo_direct",
                        "combine",
                        "copy_combined",
                        "albedo_combined"
                    ]),
                    row.total * 1e3,
                    row.cpu_total * 1e3
                );
            }
        }
    }
}
