//! The paper's Table 1 on every available backend (see the parent module).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use luxbake::scene::{Blur, BvhMode, Scene, Settings};
use luxbake_backends::{AnyBackend, BackendKind};

use super::{
    Args, Opened, Summary, load_average, machine, open, timed_bake, utc_now, write_load_averages,
    write_results,
};

/// The scenes of Table 1.
pub const SCENES: [&str; 5] = [
    "chairs_01",
    "chairs_03",
    "chairs_05",
    "chairs_10",
    "sofa_01",
];
/// The traversal modes of Table 1.
pub const MODES: [BvhMode; 3] = [BvhMode::Mtbvh, BvhMode::Tbvh, BvhMode::None];

/// The paper's Table 1 (ms): texels, triangles, GTX 1650 MTBVH/TBVH/none, GTX 1080 Ti
/// MTBVH/TBVH/none.
const PAPER: [(&str, &str, u32, [u32; 6]); 5] = [
    ("chairs_01", "459k", 252, [226, 222, 618, 61, 81, 206]),
    ("chairs_03", "590k", 732, [446, 412, 2810, 154, 168, 760]),
    ("chairs_05", "721k", 1212, [835, 732, 3833, 289, 272, 1553]),
    (
        "chairs_10",
        "1049k",
        2412,
        [2616, 2675, 10708, 644, 662, 4172],
    ),
    ("sofa_01", "655k", 2036, [887, 908, 6617, 263, 279, 2909]),
];

/// The paper's GTX 1650 and GTX 1080 Ti times for `scene` and `mode`, ms.
fn paper_ms(scene: &str, mode: BvhMode) -> Option<(u32, u32)> {
    let i = MODES.iter().position(|m| *m == mode)?;
    PAPER
        .iter()
        .find(|p| p.0 == scene)
        .map(|p| (p.3[i], p.3[i + 3]))
}

/// Pass-kind group of a pass label.
fn group(label: &str) -> &'static str {
    match label {
        "direct" => "direct",
        "gather" => "gather",
        l if l.starts_with("blur") => "blur",
        _ => "other",
    }
}

/// What one configuration measured.
struct Stats {
    texels: u64,
    triangles: usize,
    rays: u64,
    runs: usize,
    wall: Summary,
    cpu: Summary,
    /// Median wall seconds per pass group.
    groups: BTreeMap<&'static str, f64>,
    /// Median seconds per setup step (layout, rasterise, bvh, unocclude).
    setup: BTreeMap<&'static str, f64>,
}

struct Cell {
    scene: &'static str,
    backend: BackendKind,
    bvh: BvhMode,
    result: Result<Stats, String>,
}

fn measure(
    backend: &mut AnyBackend,
    scene: &Scene,
    settings: &Settings,
    runs: usize,
    budget: f64,
) -> Result<Stats, String> {
    let mut walls = Vec::new();
    let mut cpus = Vec::new();
    let mut groups: BTreeMap<&'static str, Vec<f64>> = BTreeMap::new();
    let mut setup: BTreeMap<&'static str, Vec<f64>> = BTreeMap::new();
    let (mut texels, mut triangles, mut rays) = (0, 0, 0);
    let started = std::time::Instant::now();
    for _ in 0..runs {
        let run = timed_bake(backend, scene, settings)?;
        walls.push(run.wall());
        cpus.push(run.cpu());
        let r = &run.out.report;
        let mut g: BTreeMap<&'static str, f64> = BTreeMap::new();
        for p in &r.passes {
            *g.entry(group(p.label)).or_default() += p.seconds;
        }
        for (k, v) in g {
            groups.entry(k).or_default().push(v);
        }
        for (k, v) in &r.setup {
            setup.entry(k).or_default().push(*v);
        }
        texels = r.texels;
        triangles = r.triangles;
        rays = run.rays();
        if started.elapsed().as_secs_f64() > budget {
            break;
        }
    }
    let med = |m: BTreeMap<&'static str, Vec<f64>>| {
        m.into_iter()
            .map(|(k, v)| (k, Summary::of(&v).median))
            .collect()
    };
    Ok(Stats {
        texels,
        triangles,
        rays,
        runs: walls.len(),
        wall: Summary::of(&walls),
        cpu: Summary::of(&cpus),
        groups: med(groups),
        setup: med(setup),
    })
}

fn ms(s: f64) -> String {
    format!("{:.0}", s * 1e3)
}

/// Runs Table 1 (and the scaling runs unless disabled), prints and writes the results.
pub fn run(args: &Args, runs: usize, out: &Path) -> Result<(), String> {
    let quick = args.quick;
    let settings = Settings {
        rays: args.rays.unwrap_or(if quick { 2 } else { 4 }),
        bounces: 1,
        blur: Blur::Sigma(Settings::PAPER_BLUR_SIGMA),
        texels_per_metre: args
            .texels_per_metre
            .unwrap_or(if quick { 8.0 } else { 16.0 }),
        ..Settings::paper()
    };
    let load_before = load_average();
    let (date, time) = utc_now();
    let mut backends: Vec<(BackendKind, Opened)> =
        args.backends.iter().map(|&k| (k, open(k))).collect();
    let mut renderers = BTreeMap::new();
    for (k, b) in &backends {
        let r = match b {
            Ok((_, r)) => r.clone(),
            Err(e) => format!("unavailable: {e}"),
        };
        eprintln!("{}: {r}", k.name());
        renderers.insert(k.name(), r);
    }
    let mut cells = Vec::new();
    for scene_name in SCENES {
        for &bvh in &args.bvh {
            let s = Settings {
                bvh,
                ..settings.clone()
            };
            let scene =
                Scene::builtin_with_settings(scene_name, s.clone()).map_err(|e| e.to_string())?;
            for (kind, b) in &mut backends {
                let result = match b {
                    Ok((backend, _)) => measure(backend, &scene, &s, runs, args.budget),
                    Err(e) => Err(format!("unavailable: {e}")),
                };
                match &result {
                    Ok(st) => eprintln!(
                        "{scene_name} {} {}: {} ms (median of {})",
                        kind.name(),
                        bvh.name(),
                        ms(st.wall.median),
                        st.runs
                    ),
                    Err(e) => eprintln!("{scene_name} {} {}: {e}", kind.name(), bvh.name()),
                }
                cells.push(Cell {
                    scene: scene_name,
                    backend: *kind,
                    bvh,
                    result,
                });
            }
        }
    }
    let load_after = load_average();

    let mut md = String::new();
    let _ = writeln!(md, "# Table 1 — {date} {time} UTC\n");
    let _ = writeln!(md, "- machine: {}", machine());
    for (k, r) in &renderers {
        let _ = writeln!(md, "- {k}: {r}");
    }
    let _ = writeln!(
        md,
        "- settings: {} gather rays/texel, 1 bounce, blur σ {}, {} texels/m; {} run(s) per \
         configuration (fewer where the runs exceeded {} s){}",
        settings.rays,
        Settings::PAPER_BLUR_SIGMA,
        settings.texels_per_metre,
        runs,
        args.budget,
        if quick { "; --quick" } else { "" }
    );
    write_load_averages(&mut md, &load_before, &load_after);
    let _ = writeln!(
        md,
        "Pass time = sum of the bake's passes (no asset load, layout, rasterisation or BVH \
         build: those are the `setup` columns). wall: median [min–max] ms; CPU: median process \
         CPU ms (all threads). ×ref = wall median / CPU backend + MTBVH of the same scene, same \
         run. Paper: GTX 1650 / GTX 1080 Ti ms.\n"
    );
    let _ = writeln!(
        md,
        "| scene | backend | bvh | texels | triangles | rays cast | runs | wall ms | CPU ms | M rays/s | \
         direct | gather | blur | other | ×ref | setup: layout+raster+unocclude ms | BVH build ms | paper ms |"
    );
    let _ = writeln!(
        md,
        "|---|---|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|"
    );
    let mut json_cells = Vec::new();
    for c in &cells {
        let reference = cells
            .iter()
            .find(|r| {
                r.scene == c.scene && r.backend == BackendKind::Cpu && r.bvh == BvhMode::Mtbvh
            })
            .and_then(|r| r.result.as_ref().ok())
            .map(|r| r.wall.median);
        let paper = paper_ms(c.scene, c.bvh)
            .map(|(a, b)| format!("{a} / {b}"))
            .unwrap_or_default();
        match &c.result {
            Ok(s) => {
                let g = |k: &str| ms(s.groups.get(k).copied().unwrap_or(0.0));
                let st = |k: &str| s.setup.get(k).copied().unwrap_or(0.0);
                let ratio = reference
                    .filter(|r| *r > 0.0)
                    .map(|r| format!("{:.2}", s.wall.median / r))
                    .unwrap_or_else(|| "–".to_owned());
                let _ = writeln!(
                    md,
                    "| {} | {} | {} | {} | {} | {} | {} | {} [{}–{}] | {} | {:.2} | {} | {} | {} | {} | {} \
                     | {} | {} | {} |",
                    c.scene,
                    c.backend.name(),
                    c.bvh.name(),
                    s.texels,
                    s.triangles,
                    s.rays,
                    s.runs,
                    ms(s.wall.median),
                    ms(s.wall.min),
                    ms(s.wall.max),
                    ms(s.cpu.median),
                    if s.wall.median > 0.0 {
                        s.rays as f64 / s.wall.median / 1e6
                    } else {
                        0.0
                    },
                    g("direct"),
                    g("gather"),
                    g("blur"),
                    g("other"),
                    ratio,
                    ms(st("layout") + st("rasterise") + st("unocclude")),
                    ms(st("bvh")),
                    paper
                );
                json_cells.push(serde_json::json!({
                    "scene": c.scene, "backend": c.backend.name(), "bvh": c.bvh.name(),
                    "texels": s.texels, "triangles": s.triangles, "rays_cast": s.rays,
                    "runs": s.runs, "wall_s": s.wall.json(), "cpu_s": s.cpu.json(),
                    "pass_groups_wall_s": s.groups, "setup_s": s.setup,
                    "ratio_vs_cpu_mtbvh": reference.filter(|r| *r > 0.0).map(|r| s.wall.median / r),
                }));
            }
            Err(e) => {
                let _ = writeln!(
                    md,
                    "| {} | {} | {} | {e} | | | | | | | | | | | | | | {paper} |",
                    c.scene,
                    c.backend.name(),
                    c.bvh.name()
                );
                json_cells.push(serde_json::json!({
                    "scene": c.scene, "backend": c.backend.name(), "bvh": c.bvh.name(),
                    "error": e,
                }));
            }
        }
    }
    print!("{md}");

    let scaling = if args.no_scaling {
        None
    } else {
        Some(super::scaling::run(quick)?)
    };
    if let Some((smd, _)) = &scaling {
        print!("\n{smd}");
        md.push('\n');
        md.push_str(smd);
    }
    let json = serde_json::json!({
        "date": date, "time_utc": time, "machine": machine(), "renderers": renderers,
        "quick": quick, "runs": runs, "budget_s": args.budget,
        "settings": { "rays": settings.rays, "bounces": 1,
                      "blur_sigma": Settings::PAPER_BLUR_SIGMA,
                      "texels_per_metre": settings.texels_per_metre },
        "load_average_before": load_before, "load_average_after": load_after,
        "table1": json_cells,
        "scaling": scaling.map(|s| s.1),
    });
    write_results(out, "table1", &md, &json)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_lookup_and_groups() {
        assert_eq!(paper_ms("chairs_05", BvhMode::Tbvh), Some((732, 272)));
        assert_eq!(paper_ms("sofa_01", BvhMode::None), Some((6617, 2909)));
        assert_eq!(paper_ms("floor", BvhMode::None), None);
        assert_eq!(group("blur_direct_u"), "blur");
        assert_eq!(group("gather"), "gather");
        assert_eq!(group("combine"), "other");
        for s in SCENES {
            assert!(Scene::builtin_names().contains(&s), "{s}");
        }
    }
}
