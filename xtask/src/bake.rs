//! `cargo xtask bake [SCENE_FILE | --scene NAME] [--out DIR] [--backend cpu|glow|wgpu]
//! [--method paper|converged] [--quality draft|default|final] [--rays N] [--bounces K]
//! [--tail-tolerance F] [--stride N] [--higher-rays N] [--higher-stride N] [--refine-rays N]
//! [--refine-error F] [--texels-per-metre D] [--blur SIGMA|none] [--bvh mtbvh|tbvh|none]
//! [--seed S] [--sampler hash|sobol]`: bake a scene's light maps into a folder.
//!
//! With no arguments it bakes the built-in `chairs_05` with the default lamp into `./out`, with
//! the converged method's `default` preset. Flags override the scene's `[settings]`:
//! `--method`/`--quality` choose the preset (rays, strides, bounces, blur, tail tolerance), then the
//! explicit flags override single values. A progress bar per pass, then a summary table.

use std::path::PathBuf;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};
use luxbake::bake::{BakeOutput, Progress, bake};
use luxbake::output::write_bake;
use luxbake::scene::{Blur, BvhMode, Method, Quality, Sampler, Scene, Settings};
use luxbake::sources::scenefile::preferred_backend;
use luxbake_backends::BackendKind;

/// Arguments of `cargo xtask bake`.
#[derive(clap::Args)]
pub struct Args {
    /// A TOML scene file (see the `luxbake::sources::scenefile` docs).
    #[arg(conflicts_with = "scene")]
    scene_file: Option<PathBuf>,
    /// A built-in scene: chairs_01, chairs_03, chairs_05, chairs_10, sofa_01, floor, sphere.
    #[arg(long)]
    scene: Option<String>,
    /// Output folder.
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// Also write the baked scene as glTF 2.0 binary (light maps on TEXCOORD_1; PNG inside,
    /// linear EXR in lux beside it; see `luxbake_assets::export`).
    #[arg(long)]
    glb: Option<PathBuf>,
    /// Backend: cpu, glow or wgpu (default: the scene file's `settings.backend`, else cpu).
    #[arg(long)]
    backend: Option<BackendKind>,
    /// Pipeline: `converged` (every bounce; the default) or `paper` (the paper's fixed bounces
    /// and blur, with its measured defaults).
    #[arg(long)]
    method: Option<Method>,
    /// Preset of the converged method: draft, default or final.
    #[arg(long)]
    quality: Option<Quality>,
    /// Gather rays per texel per bounce (converged: of the first bounce).
    #[arg(long)]
    rays: Option<u32>,
    /// Indirect bounces (converged: the most explicit bounces; 0 = direct light only).
    #[arg(long)]
    bounces: Option<u32>,
    /// Converged: stop explicit bounces when the estimated tail (or its uncertainty) is under
    /// this fraction of the total.
    #[arg(long)]
    tail_tolerance: Option<f32>,
    /// Light-map density, texels per metre.
    #[arg(long)]
    texels_per_metre: Option<f32>,
    /// Blur sigma in texels, or `none`.
    #[arg(long)]
    blur: Option<Blur>,
    /// Ray traversal: wide (the default; the CPU backend's 8-wide BVH, the MTBVH on GPU
    /// backends), mtbvh, tbvh or none (brute force).
    #[arg(long)]
    bvh: Option<BvhMode>,
    /// Seed of the random-number hash.
    #[arg(long)]
    seed: Option<u32>,
    /// Gather directions: hash (the paper's independent draws) or sobol (per-texel scrambled
    /// Sobol sequence; the converged presets' default).
    #[arg(long)]
    sampler: Option<Sampler>,
    /// Converged: gather the first bounce on every n-th texel per axis and interpolate on each
    /// surface (1 = every texel).
    #[arg(long)]
    stride: Option<u32>,
    /// Converged: rays per gathered texel of the bounces after the first.
    #[arg(long)]
    higher_rays: Option<u32>,
    /// Converged: --stride of the bounces after the first.
    #[arg(long)]
    higher_stride: Option<u32>,
    /// Converged: more first-bounce rays for texels whose estimated relative standard error
    /// exceeds --refine-error (0 = no refinement).
    #[arg(long)]
    refine_rays: Option<u32>,
    /// Converged: the relative standard error per texel that refinement aims at.
    #[arg(long)]
    refine_error: Option<f32>,
    /// Converged: lamp paths per texel combined with the first bounce's gather (0 = none).
    #[arg(long)]
    lamp_paths: Option<u32>,
}

impl Args {
    /// Applies the flags to `s` and checks the result ([`Settings::validate`]); the error
    /// names the flag.
    fn apply(&self, s: &mut Settings) -> Result<(), String> {
        if self.method.is_some() || self.quality.is_some() {
            let quality = self.quality.unwrap_or(s.quality);
            let method = match (self.method, self.quality) {
                (Some(m), _) => m,
                (None, Some(_)) => Method::Converged,
                (None, None) => s.method,
            };
            let preset = Settings::of(method, quality);
            *s = Settings {
                texels_per_metre: s.texels_per_metre,
                bvh: s.bvh,
                seed: s.seed,
                ..preset
            };
        }
        if let Some(v) = self.tail_tolerance {
            s.tail_tolerance = v;
        }
        if let Some(v) = self.rays {
            s.rays = v;
        }
        if let Some(v) = self.stride {
            s.stride = v;
        }
        if let Some(v) = self.higher_rays {
            s.higher_rays = v;
        }
        if let Some(v) = self.higher_stride {
            s.higher_stride = v;
        }
        if let Some(v) = self.refine_rays {
            s.refine_rays = v;
        }
        if let Some(v) = self.lamp_paths {
            s.lamp_paths = v;
        }
        if let Some(v) = self.refine_error {
            s.refine_error = v;
        }
        if let Some(v) = self.bounces {
            s.bounces = v;
        }
        if let Some(v) = self.texels_per_metre {
            s.texels_per_metre = v;
        }
        if let Some(v) = self.blur {
            s.blur = v;
        }
        if let Some(v) = self.bvh {
            s.bvh = v;
        }
        if let Some(v) = self.seed {
            s.seed = v;
        }
        if let Some(v) = self.sampler {
            s.sampler = v;
        }
        s.validate()
            .map_err(|e| format!("--{}: {}", e.name.replace('_', "-"), e.reason))
    }
}

/// The scene the arguments name, with the flags applied, the backend to bake it on (the
/// `--backend` flag, else the scene file's `settings.backend`, else cpu) and the scene's source
/// for the manifest.
fn load(args: &Args) -> Result<(Scene, BackendKind, String), String> {
    match &args.scene_file {
        Some(path) => {
            let mut scene =
                Scene::from_toml_file_with(path, &luxbake_assets::SceneLoader::default())
                    .map_err(|e| e.to_string())?;
            args.apply(&mut scene.settings)?;
            let backend = match args.backend {
                Some(b) => b,
                None => match preferred_backend(path).map_err(|e| e.to_string())? {
                    Some(name) => name.parse()?,
                    None => BackendKind::Cpu,
                },
            };
            let abs = std::fs::canonicalize(path).unwrap_or_else(|_| path.clone());
            Ok((scene, backend, abs.display().to_string()))
        }
        None => {
            let name = args.scene.as_deref().unwrap_or("chairs_05");
            let mut settings = Settings::default();
            args.apply(&mut settings)?;
            let scene = Scene::builtin_with_settings(name, settings).map_err(|e| e.to_string())?;
            let backend = args.backend.unwrap_or(BackendKind::Cpu);
            Ok((scene, backend, format!("builtin:{name}")))
        }
    }
}

/// Runs the bake; the error is a message for stderr.
pub fn run(args: &Args) -> Result<(), String> {
    let (scene, backend, source) = load(args)?;
    let settings = scene.settings.clone();
    let mut backend = luxbake_backends::open(backend).map_err(|e| e.to_string())?;
    let output = run_with(&mut backend, &scene, &settings)?;
    write_bake(&args.out, &scene, &output, &source).map_err(|e| e.to_string())?;
    if let Some(glb) = &args.glb {
        luxbake_assets::export::export_baked(&scene, &output, glb).map_err(|e| e.to_string())?;
        println!("wrote {}", glb.display());
    }
    print_summary(&output, &scene);
    println!("wrote {}", args.out.join("manifest.json").display());
    Ok(())
}

fn run_with<B: luxbake::GpuBackend>(
    backend: &mut B,
    scene: &Scene,
    settings: &Settings,
) -> Result<BakeOutput, String> {
    let style = ProgressStyle::with_template(
        "{prefix:>16} [{bar:40.cyan/blue}] {percent:>3}% {elapsed_precise}",
    )
    .map_err(|e| e.to_string())?
    .progress_chars("=> ");
    let mut bar: Option<ProgressBar> = None;
    let mut on_progress = |p: &Progress<'_>| match p {
        Progress::Setup(step) => eprintln!("{step} …"),
        Progress::PassStart {
            index,
            count,
            label,
            bounce,
        } => {
            let b = ProgressBar::new(1000).with_style(style.clone());
            let prefix = if *bounce > 0 {
                format!("{}/{} {label} #{bounce}", index + 1, count)
            } else {
                format!("{}/{} {label}", index + 1, count)
            };
            b.set_prefix(prefix);
            b.enable_steady_tick(Duration::from_millis(200));
            bar = Some(b);
        }
        Progress::PassProgress { fraction, .. } => {
            if let Some(b) = &bar {
                b.set_position((fraction.clamp(0.0, 1.0) * 1000.0) as u64);
            }
        }
        Progress::PassDone { .. } => {
            if let Some(b) = bar.take() {
                b.finish();
            }
        }
    };
    bake(backend, scene, settings, &mut on_progress).map_err(|e| e.to_string())
}

fn print_summary(out: &BakeOutput, scene: &Scene) {
    let r = &out.report;
    let s = &out.settings;
    println!();
    println!("backend            {}", r.backend);
    println!(
        "objects            {} ({} with light maps), lamps {} ({} used)",
        scene.objects.len(),
        out.maps.len(),
        scene.lamps.len(),
        out.lamps_used.len()
    );
    println!(
        "texels             {} sampled of {} in regions; layout {}×{} × {} layers",
        r.texels,
        r.region_texels,
        out.layout.layer_size[0],
        out.layout.layer_size[1],
        out.layout.layers
    );
    println!(
        "triangles          {} (traversal: {})",
        r.triangles,
        r.bvh.name()
    );
    println!(
        "rays               {} shadow, {} gather ({} per texel, {} of {} bounces run)",
        r.shadow_rays, r.gather_rays, s.rays, r.bounces_run, s.bounces
    );
    println!();
    println!("{:<20} {:>6} {:>12}", "pass", "bounce", "time [ms]");
    for (label, t) in &r.setup {
        println!("{:<20} {:>6} {:>12.1}", format!("({label})"), "", t * 1e3);
    }
    for p in &r.passes {
        println!("{:<20} {:>6} {:>12.1}", p.label, p.bounce, p.seconds * 1e3);
    }
    let pass_total: f64 = r.passes.iter().map(|p| p.seconds).sum();
    println!(
        "{:<20} {:>6} {:>12.1}",
        "passes total",
        "",
        pass_total * 1e3
    );
    println!(
        "{:<20} {:>6} {:>12.1}",
        "bake total",
        "",
        r.total_seconds * 1e3
    );
    if r.skipped.is_empty() {
        println!("\nskipped: nothing");
    } else {
        println!("\nskipped:");
        for k in &r.skipped {
            println!("  - {k}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: Args,
    }

    fn load_with(flags: &[&str]) -> Result<(Scene, BackendKind, String), String> {
        let cli = Cli::try_parse_from([&["bake", "--scene", "floor"], flags].concat())
            .map_err(|e| e.to_string())?;
        load(&cli.args)
    }

    #[test]
    fn flags_out_of_range_are_named() {
        for (flags, name) in [
            (&["--rays", "0"][..], "--rays"),
            (&["--bounces", "65"], "--bounces"),
            (&["--blur", "100"], "--blur"),
            (&["--texels-per-metre", "0"], "--texels-per-metre"),
        ] {
            let e = load_with(flags).expect_err("out of range");
            assert!(e.starts_with(name), "{flags:?}: {e}");
        }
        let (scene, backend, source) =
            load_with(&["--rays", "2", "--texels-per-metre", "4"]).expect("ok");
        assert_eq!(
            (scene.settings.rays, backend, source.as_str()),
            (2, BackendKind::Cpu, "builtin:floor")
        );
    }
}
