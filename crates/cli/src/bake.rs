//! `luxbake bake [SCENE_FILE | --scene NAME] [--out DIR] [--backend cpu|glow|wgpu]
//! [--method paper|converged] [--quality draft|default|final] [--rays N] [--bounces K]
//! [--tail true|false] [--tail-tolerance F] [--stride N] [--higher-rays N] [--higher-stride N]
//! [--refine-rays N] [--refine-error F] [--narrow-rays N] [--texels-per-metre D] [--blur SIGMA|none]
//! [--bvh mtbvh|tbvh|none] [--seed S] [--sampler hash|sobol] [--lamp FILE|DIR]...
//! [--lamp-layers]`: bake a scene's light maps into a folder.
//!
//! `--lamp` (repeated, or a folder of `.ies`/`.ldt` files) bakes the room once per
//! photometric file, every lamp of the scene taking that file, into `OUT/<file stem>/`: the
//! room's host work (layout, rasterising, BVH, unocclusion) runs once for all of them.
//! `--lamp-layers` also bakes each lamp's light apart and writes it as a bake folder of its own,
//! `OUT/lamps/<index>_<lamp name>/` (each readable by `luxbake measure`), the maps in `OUT`
//! being their sum ([`luxbake::layers`]).
//!
//! With no arguments it bakes the built-in `chairs_05` with the default lamp into `./out`, with
//! the converged method's `default` preset. The flags are a [`SettingsPatch`] layered over the
//! scene file's `[settings]` before its objects are built (so chart padding follows the final
//! density and blur): preset, then the file's keys, then the flags. `--method`/`--quality`
//! choose the preset (rays, strides, bounces, tail, blur, tail tolerance; the file's density,
//! traversal and seed stay), then the explicit flags override single values; `--bounces`
//! without `--tail true` bakes exactly that many bounces. A progress bar per pass, then a
//! summary table.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};
use luxbake::GpuBackend;
use luxbake::bake::{BakeOutput, Progress, Room, bake, bake_room};
use luxbake::layers::{LampState, bake_layers};
use luxbake::scene::{
    Blur, BvhMode, Lamp, LampModel, Method, Quality, Sampler, Scene, SceneError, SettingError,
    SettingsPatch,
};
use luxbake::sources::scenefile::{from_file_patched, preferred_backend, read_photometry};
use luxbake_backend_cpu::GATHER_HITS_BUDGET;
use luxbake_backends::{AnyBackend, BackendKind};
use luxbake_ies::Photometry;
use luxbake_output::{file_stem, write_bake};

/// Arguments of `luxbake bake` (and `cargo xtask bake`).
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
    /// The settings' flags (`--method` … `--opening-probe-stride`).
    #[command(flatten)]
    pub settings: SettingsArgs,
    /// How every lamp emits, over the scene file's `lamp_model`: auto (its luminous opening
    /// where a receiver is near enough for the point model to be off by more than 1 %),
    /// point or area (the opening everywhere).
    #[arg(long)]
    lamp_model: Option<LampModel>,
    /// A photometric file (IES or EULUMDAT) for every lamp of the scene, or a folder of them:
    /// the room is prepared once and baked per file into `OUT/<file stem>/`. Repeatable.
    #[arg(long = "lamp", value_name = "FILE|DIR")]
    lamp_files: Vec<PathBuf>,
    /// Also write each lamp's light apart, to `OUT/lamps/<index>_<name>/` (a bake folder per
    /// lamp at multiplier 1); the maps in `OUT` are their sum.
    #[arg(long)]
    lamp_layers: bool,
}

/// The flags of `luxbake bake` (and `cargo xtask bake`) that set the bake's [`luxbake::scene::Settings`]
/// over the scene's: a [`SettingsPatch`] ([`SettingsArgs::patch`]). `cargo xtask bench
/// refcheck` takes the same flags for its in-memory bakes.
#[derive(clap::Args, Debug, Default, Clone)]
pub struct SettingsArgs {
    /// Pipeline: `converged` (every bounce; the default) or `paper` (the paper's fixed bounces
    /// and blur, with its measured defaults).
    #[arg(long)]
    pub method: Option<Method>,
    /// Preset of the converged method: draft, default or final.
    #[arg(long)]
    pub quality: Option<Quality>,
    /// Gather rays per texel per bounce (converged: of the first bounce).
    #[arg(long)]
    pub rays: Option<u32>,
    /// Indirect bounces; 0 = direct light only. Converged: exactly this many, unless
    /// `--tail true` makes it the most explicit bounces before the tail is added.
    #[arg(long)]
    pub bounces: Option<u32>,
    /// Converged: after the explicit bounces, add the extrapolated rest of the
    /// inter-reflection series (the presets: true; `--bounces` alone: false).
    #[arg(long)]
    pub tail: Option<bool>,
    /// Converged: stop explicit bounces when the estimated tail is under this fraction of the
    /// total, or (from bounce 5 on) two successive estimates of the total agree within it.
    #[arg(long)]
    pub tail_tolerance: Option<f32>,
    /// Light-map density, texels per metre.
    #[arg(long)]
    pub texels_per_metre: Option<f32>,
    /// Blur sigma in texels, or `none`.
    #[arg(long)]
    pub blur: Option<Blur>,
    /// Ray traversal: wide (the default; the CPU backend's 8-wide BVH, the MTBVH on GPU
    /// backends), mtbvh, tbvh or none (brute force).
    #[arg(long)]
    pub bvh: Option<BvhMode>,
    /// Seed of the random-number hash.
    #[arg(long)]
    pub seed: Option<u32>,
    /// Gather directions: hash (the paper's independent draws) or sobol (per-texel scrambled
    /// Sobol sequence; the converged presets' default).
    #[arg(long)]
    pub sampler: Option<Sampler>,
    /// Converged: gather the first bounce on every n-th texel per axis and interpolate on each
    /// surface (1 = every texel).
    #[arg(long)]
    pub stride: Option<u32>,
    /// Converged: rays per gathered texel of the bounces after the first.
    #[arg(long)]
    pub higher_rays: Option<u32>,
    /// Converged: --stride of the bounces after the first.
    #[arg(long)]
    pub higher_stride: Option<u32>,
    /// Converged: more first-bounce rays for texels whose estimated relative standard error
    /// exceeds --refine-error (0 = no refinement).
    #[arg(long)]
    pub refine_rays: Option<u32>,
    /// Converged: the relative standard error per texel that refinement aims at.
    #[arg(long)]
    pub refine_error: Option<f32>,
    /// Converged: rays per texel in a narrow gap in the first two bounces, half as many in
    /// each after, whatever its noise (a bounce that gathers fewer there adds the rest; the
    /// `default` preset 64, `final` 256, `draft` 0 = none).
    #[arg(long)]
    pub narrow_rays: Option<u32>,
    /// Converged: the denoiser's bias correction (true or false; the `default` and `final` presets: true):
    /// its residual filtered once more and added back, which cancels its bias where the light
    /// curves within its kernel.
    #[arg(long)]
    pub denoise_correction: Option<bool>,
    /// Converged: the first bounce evaluates the lamps' direct light at each of its gather
    /// rays' hits instead of reading the direct light map there (true or false; the `final`
    /// preset: true): a shadow ray per ray and lamp, without the map's texel interpolation.
    #[arg(long)]
    pub direct_at_hits: Option<bool>,
    /// Converged: lamp paths per texel combined with the first bounce's gather (0 = none).
    #[arg(long)]
    pub lamp_paths: Option<u32>,
    /// Points of a lamp's luminous opening (each with a shadow ray) per texel near a lamp
    /// baked with its opening (see --lamp-model).
    #[arg(long)]
    pub opening_samples: Option<u32>,
    /// Opening samples per visibility probe: a texel first casts the shadow rays of every
    /// Nth of its opening's points and, when all reach the opening, takes the others as seen
    /// (0 or 1: every point casts its ray).
    #[arg(long)]
    pub opening_probe_stride: Option<u32>,
}

impl SettingsArgs {
    /// The flags as a patch.
    pub fn patch(&self) -> SettingsPatch {
        SettingsPatch {
            method: self.method,
            quality: self.quality,
            rays: self.rays,
            bounces: self.bounces,
            tail: self.tail,
            tail_tolerance: self.tail_tolerance,
            texels_per_metre: self.texels_per_metre,
            blur: self.blur,
            bvh: self.bvh,
            seed: self.seed,
            sampler: self.sampler,
            stride: self.stride,
            higher_rays: self.higher_rays,
            higher_stride: self.higher_stride,
            refine_rays: self.refine_rays,
            refine_error: self.refine_error,
            narrow_rays: self.narrow_rays,
            denoise_correction: self.denoise_correction,
            direct_at_hits: self.direct_at_hits,
            lamp_paths: self.lamp_paths,
            opening_samples: self.opening_samples,
            opening_probe_stride: self.opening_probe_stride,
        }
    }
}

/// A setting out of range, named by its flag.
fn flag_error(e: &SettingError) -> String {
    format!("--{}: {}", e.name.replace('_', "-"), e.reason)
}

/// The scene the arguments name, with the flags applied, the backend to bake it on (the
/// `--backend` flag, else the scene file's `settings.backend`, else cpu) and the scene's source
/// for the manifest.
fn load(args: &Args) -> Result<(Scene, BackendKind, String), String> {
    match &args.scene_file {
        Some(path) => {
            let loader = luxbake_assets::SceneLoader::default();
            let scene = from_file_patched(path, Some(&loader), &args.settings.patch()).map_err(
                |e| match e {
                    SceneError::Override(e) => flag_error(&e),
                    e => e.to_string(),
                },
            )?;
            // The file's backend is checked even when `--backend` overrides it.
            let preferred = match preferred_backend(path).map_err(|e| e.to_string())? {
                Some(name) => Some(
                    name.parse::<BackendKind>()
                        .map_err(|e| format!("{}: settings.backend: {e}", path.display()))?,
                ),
                None => None,
            };
            let backend = args.backend.or(preferred).unwrap_or(BackendKind::Cpu);
            let abs = std::fs::canonicalize(path).unwrap_or_else(|_| path.clone());
            Ok((scene, backend, abs.display().to_string()))
        }
        None => {
            let name = args.scene.as_deref().unwrap_or("chairs_05");
            let settings = args
                .settings
                .patch()
                .settings()
                .map_err(|e| flag_error(&e))?;
            let scene = Scene::builtin_with_settings(name, settings).map_err(|e| e.to_string())?;
            let backend = args.backend.unwrap_or(BackendKind::Cpu);
            Ok((scene, backend, format!("builtin:{name}")))
        }
    }
}

/// Runs the bake; the error is a message for stderr.
pub fn run(args: &Args) -> Result<(), String> {
    let (mut scene, backend, source) = load(args)?;
    if let Some(model) = args.lamp_model {
        for lamp in &mut scene.lamps {
            lamp.model = model;
        }
    }
    let files = lamp_files(&args.lamp_files)?;
    if files.len() > 1 && args.glb.is_some() {
        return Err("--glb writes one file: give it with one --lamp file at a time".into());
    }
    if !files.is_empty() && scene.lamps.is_empty() {
        return Err("--lamp: the scene has no lamp to take the photometric file".into());
    }
    let settings = scene.settings.clone();
    let mut backend = luxbake_backends::open(backend).map_err(|e| e.to_string())?;
    let mut progress = progress_bars()?;
    if files.is_empty() && !args.lamp_layers {
        let output =
            bake(&mut backend, &scene, &settings, &mut progress).map_err(|e| e.to_string())?;
        return finish(args, &args.out, &scene, &output, &source);
    }
    // The room once, then each lamp file (or the scene's own lamps) on it.
    let room = Room::prepare(&scene, &settings, backend.limits(), &mut progress)
        .map_err(|e| e.to_string())?;
    let room_seconds: f64 = room.timings.iter().map(|(_, s)| s).sum();
    let bakes = files.len().max(1)
        * if args.lamp_layers {
            scene.lamps.len()
        } else {
            1
        };
    // A room baked more than once: the backend keeps the gather rays' hits from the first
    // bake for the others (`luxbake::cpu::hits`, `luxbake::kept`; the same maps, fewer
    // traversals).
    if bakes > 1 {
        backend.keep_gather_hits(GATHER_HITS_BUDGET)?;
    }
    let jobs: Vec<(PathBuf, Scene)> = if files.is_empty() {
        vec![(args.out.clone(), scene.clone())]
    } else {
        files
            .iter()
            .map(|(stem, photometry)| {
                let mut lit = scene.clone();
                for lamp in &mut lit.lamps {
                    lamp.photometry = photometry.clone();
                }
                (args.out.join(stem), lit)
            })
            .collect()
    };
    let mut lamp_seconds = Vec::new();
    for (dir, lit) in &jobs {
        let t = Instant::now();
        let output = if args.lamp_layers {
            let layers = bake_layers(&mut backend, &room, &lit.lamps, &settings, &mut progress)
                .map_err(|e| e.to_string())?;
            for (i, (layer, color)) in layers.layers.iter().zip(&layers.colors).enumerate() {
                let lamp = Lamp {
                    multiplier: 1.0,
                    color: *color,
                    ..lit.lamps[i].clone()
                };
                let alone = Scene {
                    lamps: vec![lamp],
                    ..lit.clone()
                };
                let folder = dir
                    .join("lamps")
                    .join(format!("{i}_{}", file_stem(&lit.lamps[i].name)));
                write_bake(&folder, &alone, layer, &source).map_err(|e| e.to_string())?;
            }
            let states: Vec<LampState> = lit.lamps.iter().map(LampState::of).collect();
            layers.combine(&states).map_err(|e| e.to_string())?
        } else {
            bake_room(&mut backend, &room, &lit.lamps, &settings, &mut progress)
                .map_err(|e| e.to_string())?
        };
        lamp_seconds.push((dir.clone(), t.elapsed().as_secs_f64()));
        finish(args, dir, lit, &output, &source)?;
    }
    println!(
        "\nroom prepared once: {:.1} ms (layout, rasterise, bvh, unocclude)",
        room_seconds * 1e3
    );
    for (dir, seconds) in lamp_seconds {
        println!(
            "lamps baked on it:  {:>8.1} ms  {}",
            seconds * 1e3,
            dir.display()
        );
    }
    if let AnyBackend::Cpu(cpu) = &backend
        && let Some(h) = cpu.gather_hit_stats()
    {
        println!(
            "gather hits kept:   {:.1} MB; rays replayed {}, traced {}",
            h.bytes as f64 / 1e6,
            h.replayed,
            h.traced
        );
    }
    Ok(())
}

/// Writes one bake's folder (and `--glb`), prints its summary.
fn finish(
    args: &Args,
    dir: &Path,
    scene: &Scene,
    output: &BakeOutput,
    source: &str,
) -> Result<(), String> {
    write_bake(dir, scene, output, source).map_err(|e| e.to_string())?;
    if let Some(glb) = &args.glb {
        luxbake_assets::export::export_baked(scene, output, glb).map_err(|e| e.to_string())?;
        println!("wrote {}", glb.display());
    }
    print_summary(output, scene);
    println!("wrote {}", dir.join("manifest.json").display());
    Ok(())
}

/// The `.ies` and `.ldt` files of folder `dir` (any case), in name order.
pub(crate) fn photometric_files_in(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut found: Vec<PathBuf> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.is_file()
                && p.extension()
                    .is_some_and(|x| x.eq_ignore_ascii_case("ies") || x.eq_ignore_ascii_case("ldt"))
        })
        .collect();
    found.sort();
    Ok(found)
}

/// The photometric files `--lamp` names, each with its output folder's name (the file stem,
/// made unique), read and parsed; a folder gives its `.ies` and `.ldt` files in name order.
fn lamp_files(paths: &[PathBuf]) -> Result<Vec<(String, Arc<Photometry>)>, String> {
    let mut files = Vec::new();
    for path in paths {
        if path.is_dir() {
            let found = photometric_files_in(path)
                .map_err(|e| format!("--lamp {}: {e}", path.display()))?;
            if found.is_empty() {
                return Err(format!(
                    "--lamp {}: the folder holds no .ies or .ldt file",
                    path.display()
                ));
            }
            files.extend(found);
        } else {
            files.push(path.clone());
        }
    }
    let mut stems = std::collections::HashSet::new();
    files
        .iter()
        .map(|file| {
            let photometry =
                read_photometry(file).map_err(|e| format!("--lamp {}: {e}", file.display()))?;
            let base = file_stem(
                &file
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default(),
            );
            let mut stem = base.clone();
            let mut n = 2;
            while !stems.insert(stem.clone()) {
                stem = format!("{base}_{n}");
                n += 1;
            }
            Ok((stem, photometry))
        })
        .collect()
}

/// A progress bar per pass on stderr.
fn progress_bars() -> Result<impl FnMut(&Progress<'_>), String> {
    let style = ProgressStyle::with_template(
        "{prefix:>16} [{bar:40.cyan/blue}] {percent:>3}% {elapsed_precise}",
    )
    .map_err(|e| e.to_string())?
    .progress_chars("=> ");
    let mut bar: Option<ProgressBar> = None;
    Ok(move |p: &Progress<'_>| match p {
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
        Progress::Work(_) => {}
    })
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
    if !r.lamp_models.is_empty() {
        println!("\nlamp models:");
        for m in &r.lamp_models {
            println!("  - {m}");
        }
    }
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

    #[test]
    fn a_scene_files_backend_is_named_by_the_backends_crate() {
        let dir = std::env::temp_dir().join(format!("luxbake-xtask-be-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("s.toml");
        let load_file = |backend: &str, flags: &[&str]| {
            let text = format!(
                "[settings]\nbackend = \"{backend}\"\n[[lamp]]\nies = \"isotropic:100\"\n\
                 position = [0, 2, 0]\n[[object]]\nprimitive = \"plane\"\nsize = [2, 2]\n"
            );
            std::fs::write(&path, text).expect("write scene");
            let p = path.display().to_string();
            let cli = Cli::try_parse_from([&["bake", p.as_str()], flags].concat())
                .map_err(|e| e.to_string())?;
            load(&cli.args).map(|(_, backend, _)| backend)
        };
        assert_eq!(load_file(" Glow ", &[]), Ok(BackendKind::Glow));
        assert_eq!(
            load_file("glow", &["--backend", "cpu"]),
            Ok(BackendKind::Cpu)
        );
        // An unknown name is an error naming the key, also under a `--backend` override.
        for flags in [&[][..], &["--backend", "cpu"]] {
            let e = load_file("vulkan", flags).expect_err("vulkan");
            assert!(
                e.contains("settings.backend")
                    && e.contains("expected \"cpu\", \"glow\" or \"wgpu\", got `vulkan`"),
                "{e}"
            );
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    /// A unit cube without UVs: the mesh loader generates its light-map UVs, padded for the
    /// density.
    const CUBE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
        f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

    /// `luxbake bake scene.toml --texels-per-metre 32` builds the objects as
    /// `texels_per_metre = 32` in the file does: chart padding (procedural and the mesh
    /// loader's) follows the flag.
    #[test]
    fn a_density_flag_pads_as_the_file_key_does() {
        let dir = std::env::temp_dir().join(format!("luxbake-xtask-flags-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        std::fs::write(dir.join("cube.obj"), CUBE_OBJ).expect("write mesh");
        let file = |name: &str, density: u32| {
            let path = dir.join(name);
            let text = format!(
                "[settings]\ntexels_per_metre = {density}\nbounces = 1\n\
                 [[lamp]]\nies = \"isotropic:100\"\nposition = [0, 2, 0]\n\
                 [[object]]\nprimitive = \"room\"\nsize = [4, 2.5, 3]\n\
                 [[object]]\nbuiltin = \"chair\"\n\
                 [[object]]\nmesh = \"cube.obj\"\nposition = [1, 0, 0]\n"
            );
            std::fs::write(&path, text).expect("write scene");
            path.display().to_string()
        };
        let (coarse, fine) = (file("coarse.toml", 48), file("fine.toml", 32));
        let load_file = |path: &str, flags: &[&str]| {
            let cli = Cli::try_parse_from([&["bake", path], flags].concat())
                .map_err(|e| e.to_string())?;
            load(&cli.args).map(|(scene, ..)| scene)
        };
        let flagged = load_file(&coarse, &["--texels-per-metre", "32"]).expect("flagged");
        let written = load_file(&fine, &[]).expect("written");
        assert_eq!(flagged.settings, written.settings);
        assert_eq!(flagged.objects, written.objects);
        let layout = |s: &Scene| luxbake::layout::Layout::new(s, 4096, 64).expect("layout");
        assert_eq!(layout(&flagged), layout(&written));
        let plain = load_file(&coarse, &[]).expect("plain");
        for o in [0, 2] {
            assert_ne!(
                plain.objects[o].mesh.lightmap_uvs, flagged.objects[o].mesh.lightmap_uvs,
                "object {o} is padded for the flag's density"
            );
        }
        // Over a file, a flag out of range is named by its flag; `--bounces` alone is exact.
        let e = load_file(&coarse, &["--rays", "0"]).expect_err("rays 0");
        assert!(e.starts_with("--rays"), "{e}");
        let s = load_file(&coarse, &["--bounces", "2"])
            .expect("bounces")
            .settings;
        assert_eq!((s.bounces, s.tail), (2, false));
        let s = load_file(&coarse, &["--bounces", "2", "--tail", "true"])
            .expect("tail")
            .settings;
        assert_eq!((s.bounces, s.tail), (2, true));
        std::fs::remove_dir_all(&dir).ok();
    }

    /// `--lamp A --lamp B --lamp-layers` prepares the room once and writes one folder per file,
    /// each with the maps a whole bake of the scene with that file gives, and the per-lamp
    /// folder beside them.
    #[test]
    fn lamp_files_bake_one_room_per_file_into_their_folders() {
        let (Some(a), Some(b)) = (
            luxbake_testkit::shared_data("lamp_files", "photometry/real-world/rw_7.IES"),
            luxbake_testkit::shared_data("lamp_files", "photometry/real-world/rw_5.IES"),
        ) else {
            return;
        };
        let out = luxbake_testkit::temp_dir("xtask-lamps", "out");
        let (a, b, o) = (
            a.display().to_string(),
            b.display().to_string(),
            out.display().to_string(),
        );
        let flags = [
            "bake",
            "--scene",
            "floor",
            "--quality",
            "draft",
            "--texels-per-metre",
            "8",
            "--out",
            &o,
            "--lamp",
            &a,
            "--lamp",
            &b,
            "--lamp-layers",
        ];
        let cli = Cli::try_parse_from(flags).expect("flags");
        run(&cli.args).expect("bake");
        let (scene, ..) = load(&cli.args).expect("scene");
        for (stem, file) in [("rw_7", &a), ("rw_5", &b)] {
            let mut lit = scene.clone();
            lit.lamps[0].photometry = read_photometry(Path::new(file)).expect("photometry");
            let whole = bake(
                &mut luxbake_backend_cpu::CpuBackend::new(),
                &lit,
                &lit.settings,
                &mut |_| {},
            )
            .expect("whole bake");
            let folder = out.join(stem);
            let written = luxbake_output::read_exr(&folder.join(format!(
                "{}_illuminance.exr",
                file_stem(&lit.objects[0].name)
            )))
            .expect("illuminance");
            // The EXR is dilated into the padding: compare the baked texels.
            let baked = whole.maps[0].illuminance();
            let mut compared = 0;
            for (w, t) in written
                .texels
                .chunks_exact(4)
                .zip(baked.texels.chunks_exact(4))
            {
                if t[3] > 0.5 {
                    for c in 0..3 {
                        assert!((w[c] - t[c]).abs() <= 1e-5 * t[c].abs().max(1e-3), "{stem}");
                    }
                    compared += 1;
                }
            }
            assert!(compared > 100, "{stem}: {compared} texels");
            let layer = folder
                .join("lamps")
                .join(format!("0_{}", file_stem(&lit.lamps[0].name)));
            assert!(layer.join("manifest.json").is_file(), "{}", layer.display());
        }
        // A folder gives its files in name order; one without any is refused.
        let dir = Path::new(&a).parent().expect("folder");
        let stems: Vec<String> = lamp_files(&[dir.to_path_buf()])
            .expect("folder")
            .into_iter()
            .map(|(s, _)| s)
            .collect();
        assert!(
            stems.len() >= 2 && stems.windows(2).all(|w| w[0] < w[1]),
            "{stems:?}"
        );
        std::fs::create_dir_all(out.join("empty")).expect("empty");
        let e = lamp_files(&[out.join("empty")]).expect_err("empty folder");
        assert!(e.contains("no .ies or .ldt file"), "{e}");
        // The same file twice gets two folders.
        let twice: Vec<String> = lamp_files(&[a.clone().into(), a.clone().into()])
            .expect("twice")
            .into_iter()
            .map(|(s, _)| s)
            .collect();
        assert_eq!(twice, ["rw_7", "rw_7_2"]);
        std::fs::remove_dir_all(&out).ok();
    }
}
