//! Scaling on the CPU backend with MTBVH: pass time vs triangles (replicated chairs as
//! non-receiving occluders, so the texel count stays fixed) and vs texels (texel density of
//! `chairs_01`), with least-squares log-log slopes.

use std::fmt::Write as _;

use luxbake::scene::{Blur, BvhMode, Object, Scene, Settings, Transform};
use luxbake_backend_cpu::CpuBackend;

use super::{log_log_slope, timed_bake};

/// Gather rays per texel of the scaling runs.
const RAYS: u32 = 4;

/// `base` with extra non-receiving copies of its first chair, shrunk to 1/10 and spread on a
/// grid inside the room, until it has at least `target` triangles.
fn with_triangles(base: &Scene, target: usize) -> Scene {
    let mut scene = base.clone();
    let Some(chair) = base.objects.iter().find(|o| o.name.starts_with("chair")) else {
        return scene;
    };
    let per = chair.mesh.triangle_count().max(1);
    let copies = target.saturating_sub(base.triangle_count()).div_ceil(per);
    // A grid of side n³ ≥ copies over x ∈ [-2, 2], y ∈ [0.3, 2.2], z ∈ [-1.6, 1.6].
    let n = (copies as f64).cbrt().ceil().max(1.0) as usize;
    for i in 0..copies {
        let (a, b, c) = (i % n, (i / n) % n, i / (n * n));
        let f = |k: usize, lo: f32, hi: f32| lo + (hi - lo) * (k as f32 + 0.5) / n as f32;
        let linear = chair.transform.linear.map(|col| col.map(|v| v * 0.1));
        scene.objects.push(Object {
            name: format!("occluder_{i}"),
            transform: Transform {
                linear,
                translation: [f(a, -2.0, 2.0), f(c, 0.3, 2.2), f(b, -1.6, 1.6)].map(f64::from),
            },
            receiver: false,
            ..chair.clone()
        });
    }
    scene
}

/// Runs both sweeps; returns the Markdown section and the JSON.
pub fn run(quick: bool) -> Result<(String, serde_json::Value), String> {
    let mut cpu = CpuBackend::new();
    let base_settings = Settings {
        rays: RAYS,
        bounces: 1,
        blur: Blur::Sigma(Settings::PAPER_BLUR_SIGMA),
        texels_per_metre: if quick { 4.0 } else { 12.0 },
        bvh: BvhMode::Mtbvh,
        ..Settings::paper()
    };
    let mut md = String::new();
    let _ = writeln!(
        md,
        "## Scaling (CPU backend, MTBVH, {RAYS} rays/texel, 1 bounce, one run per point)\n"
    );

    // Triangles.
    let base = Scene::builtin_with_settings("chairs_01", base_settings.clone())
        .map_err(|e| e.to_string())?;
    let targets: &[usize] = if quick {
        &[1_000, 4_000]
    } else {
        &[1_000, 4_000, 16_000, 64_000, 256_000, 1_000_000]
    };
    let _ = writeln!(
        md,
        "Time vs triangles (chairs_01 at {} texels/m plus shrunken non-receiving chair copies):\n",
        base_settings.texels_per_metre
    );
    let _ = writeln!(
        md,
        "| triangles | texels | pass wall ms | pass CPU ms | BVH build ms |"
    );
    let _ = writeln!(md, "|--:|--:|--:|--:|--:|");
    let mut tri_points = Vec::new();
    let mut tri_json = Vec::new();
    for &t in targets {
        let scene = with_triangles(&base, t);
        let run = timed_bake(&mut cpu, &scene, &base_settings)?;
        let r = &run.out.report;
        let bvh = r.setup.iter().find(|s| s.0 == "bvh").map_or(0.0, |s| s.1);
        eprintln!(
            "scaling: {} triangles {:.0} ms",
            r.triangles,
            run.wall() * 1e3
        );
        let _ = writeln!(
            md,
            "| {} | {} | {:.0} | {:.0} | {:.0} |",
            r.triangles,
            r.texels,
            run.wall() * 1e3,
            run.cpu() * 1e3,
            bvh * 1e3
        );
        tri_points.push((r.triangles as f64, run.wall()));
        tri_json.push(serde_json::json!({
            "triangles": r.triangles, "texels": r.texels, "wall_s": run.wall(),
            "cpu_s": run.cpu(), "bvh_build_s": bvh,
        }));
    }
    let tri_slope = log_log_slope(&tri_points);
    let _ = writeln!(
        md,
        "\nlog-log slope (time ∝ triangles^s): s = {}\n",
        tri_slope.map_or("–".to_owned(), |s| format!("{s:.2}"))
    );

    // Texels: calibrate the density from a first bake (texels ∝ density²).
    let targets: &[f64] = if quick {
        &[16e3, 64e3]
    } else {
        &[64e3, 256e3, 1024e3, 4096e3, 16384e3]
    };
    let probe = timed_bake(&mut cpu, &base, &base_settings)?;
    let texels0 = probe.out.report.texels.max(1) as f64;
    let _ = writeln!(
        md,
        "Time vs texels (chairs_01, texel density varied):\n\n\
         | texels/m | texels | pass wall ms | pass CPU ms |\n|--:|--:|--:|--:|"
    );
    let mut tex_points = Vec::new();
    let mut tex_json = Vec::new();
    for &t in targets {
        let density = base_settings.texels_per_metre * (t / texels0).sqrt() as f32;
        let s = Settings {
            texels_per_metre: density,
            ..base_settings.clone()
        };
        let scene =
            Scene::builtin_with_settings("chairs_01", s.clone()).map_err(|e| e.to_string())?;
        let run = timed_bake(&mut cpu, &scene, &s)?;
        let r = &run.out.report;
        eprintln!("scaling: {} texels {:.0} ms", r.texels, run.wall() * 1e3);
        let _ = writeln!(
            md,
            "| {density:.1} | {} | {:.0} | {:.0} |",
            r.texels,
            run.wall() * 1e3,
            run.cpu() * 1e3
        );
        tex_points.push((r.texels as f64, run.wall()));
        tex_json.push(serde_json::json!({
            "texels_per_metre": density, "texels": r.texels, "wall_s": run.wall(),
            "cpu_s": run.cpu(),
        }));
    }
    let tex_slope = log_log_slope(&tex_points);
    let _ = writeln!(
        md,
        "\nlog-log slope (time ∝ texels^s): s = {}",
        tex_slope.map_or("–".to_owned(), |s| format!("{s:.2}"))
    );
    let json = serde_json::json!({
        "backend": "cpu", "bvh": "mtbvh", "rays": RAYS,
        "triangles": tri_json, "triangles_slope": tri_slope,
        "texels": tex_json, "texels_slope": tex_slope,
    });
    Ok((md, json))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replicated_scene_reaches_the_target_without_new_texels() {
        let base = Scene::builtin("chairs_01").expect("scene");
        let s = with_triangles(&base, 5_000);
        assert!(s.triangle_count() >= 5_000, "{}", s.triangle_count());
        assert_eq!(
            s.objects.iter().filter(|o| o.receiver).count(),
            base.objects.iter().filter(|o| o.receiver).count()
        );
        s.validate().expect("valid");
    }
}
