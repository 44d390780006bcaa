//! `cargo xtask bench [--quick]`, `cargo xtask bench trade [--quick]` and
//! `cargo xtask bench sampling [--quick]`, `cargo xtask bench grain [--quick]`: measured runs of the bake (not criterion benchmarks:
//! one configuration takes seconds to minutes).
//!
//! - `bench` ([`table1`]): the paper's Table 1 — `chairs_01/03/05/10` and `sofa_01` × every
//!   backend (cpu, glow, wgpu; an unavailable one is reported, not fatal) × traversal (mtbvh,
//!   tbvh, none). Per configuration: texels, triangles, rays cast, the median and min–max of the
//!   pass time over repeated runs (wall and process CPU time), time per pass kind, and the ratio
//!   against CPU + MTBVH of the same scene measured in the same run. Asset load, layout,
//!   rasterisation and BVH build are excluded from the pass time (as in the paper) and reported
//!   separately. Then the scaling runs ([`scaling`]): time vs triangles and vs texels with
//!   log-log slopes.
//! - `bench trade` ([`trade`]): `chairs_05` over rays per texel, texel density, bounces and blur,
//!   each bake compared with the independent Radiance reference (`bench/references/`: mean
//!   |relative error|, bias, p95) and, for continuity, with luxbake's own converged bake (RMSE,
//!   mean relative error, 95th-percentile error in lux); a table, an SVG plot (error against
//!   Radiance vs time, log-log, one curve per knob, Pareto front marked) and the defaults
//!   chosen from the front.
//! - `bench refcheck` ([`refcheck`]): one bake against the independent Radiance reference of
//!   `bench/references/<scene>.csv`: mean |relative error|, bias and p95 per surface kind.
//! - `bench sampling` ([`sampling`]): the gather's error against the ray count for each direction
//!   sampler (hash, Sobol) on a box room, vs a converged reference: relative RMSE, log-log
//!   slopes, hash / Sobol ratios.
//! - `bench grain` ([`grain`]): the grain of the box room's floor, ceiling and walls per preset
//!   against a 4096-ray reference: relative standard deviation and bias of `E / E_ref`.
//! - `bench swap` ([`swap`]): the lamp swap on a prepared room (first bake, swap to the
//!   direct light and to the converged maps, dimming) per backend, as ratios of the first bake.
//! - `bench nearfield` ([`nearfield`]): the direct light of lamps with a size (their luminous
//!   openings) against Radiance's opening model in four rooms, per backend, beside the point
//!   model: mean |relative error|, bias, p95 and max per surface kind, and the cost.
//! - `bench web` ([`web`]): the light-map encodings for the catalogue's web GLB (Radiance
//!   RGBE, RGBE/RGBM/LogLuv PNG, half-float KTX2) on catalogue bakes: size against the EXRs,
//!   relative error against the float maps between 1 lx and the maximum.
//! - `bench rays` ([`rays`]): single-thread rays/s of luxbake's CPU traversals against Embree 3
//!   on the same triangles and rays (built-in scenes and the shared glTF room).
//!
//! Output: Markdown + JSON (+ SVG) named `<what>-<UTC date>-<machine>.*`, where the machine is
//! the CPU model string; the renderer strings of the GPU backends are inside. Full runs write to
//! `bench/results/` (committed); `--quick` (CI) writes to `target/bench-quick/` so CI never
//! dirties the tree. `--out` overrides both.
//!
//! Times are wall-clock seconds of each pass as the bake driver reports them (GPU backends
//! synchronise at the end of every pass), plus the process CPU time (user + system of all
//! threads, the software rasterisers' included) from `/proc/self/stat`, which stays meaningful on
//! a shared machine where wall time does not.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use luxbake::backend::GpuBackend;
use luxbake::bake::{BakeOutput, Progress, bake};
use luxbake::scene::{BvhMode, Scene, Settings};
use luxbake_backends::{AnyBackend, BackendKind};

mod grain;
mod nearfield;
mod rays;
pub(crate) mod refcheck;
mod sampling;
mod scaling;
mod swap;
mod table1;
mod trade;
mod web;

/// Arguments of `cargo xtask bench`.
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    what: Option<What>,
    /// Small sizes and one run per configuration (CI; each command under two minutes).
    #[arg(long, global = true)]
    quick: bool,
    /// Output folder (default `bench/results`, or `target/bench-quick` with `--quick`).
    #[arg(long, global = true)]
    out: Option<PathBuf>,
    /// Repetitions per configuration (Table 1: default 3, 1 with `--quick`; trade: 1).
    #[arg(long, global = true)]
    runs: Option<usize>,
    /// Backends to try, comma separated.
    #[arg(long, value_delimiter = ',', default_value = "cpu,glow,wgpu")]
    backends: Vec<BackendKind>,
    /// Traversal modes for Table 1, comma separated.
    #[arg(long, value_delimiter = ',', default_value = "mtbvh,tbvh,none")]
    bvh: Vec<BvhMode>,
    /// Gather rays per texel for Table 1 (default 4; 2 with `--quick`).
    #[arg(long)]
    rays: Option<u32>,
    /// Texel density for Table 1, texels per metre (default 16, a sixteenth of the paper's
    /// texel counts, so that brute force finishes on a CPU; 8 with `--quick`; 64 gives the
    /// paper's counts).
    #[arg(long)]
    texels_per_metre: Option<f32>,
    /// Stop repeating a configuration once its runs together took this many seconds.
    #[arg(long, default_value_t = 30.0)]
    budget: f64,
    /// Skip the scaling runs.
    #[arg(long)]
    no_scaling: bool,
}

#[derive(clap::Subcommand)]
enum What {
    /// Speed/accuracy trade on chairs_05: rays, texel density, bounces, blur against the
    /// Radiance reference (and luxbake's own converged bake).
    Trade(trade::Args),
    /// A bake (default: `cargo xtask bake`'s defaults, in memory) against the independent
    /// Radiance reference in `bench/references/<scene>.csv`: relative errors per surface kind.
    Refcheck(refcheck::Args),
    /// Gather error vs rays per direction sampler (hash, Sobol) on a box room.
    Sampling(sampling::Args),
    /// Grain of flat, evenly lit surfaces per preset against a 4096-ray reference.
    Grain(grain::Args),
    /// Single-thread ray throughput of luxbake's CPU traversals against Embree 3 (same
    /// triangles, same rays; luxbake alone where Embree is not installed).
    Rays(rays::Args),
    /// The lamp swap: first bake, swap (direct light, converged maps) and dimming on one
    /// prepared room, per backend, as ratios of the first bake.
    Swap(swap::Args),
    /// Direct light of lamps with a size against Radiance's luminous-opening references in
    /// four rooms, per backend, beside the point model.
    Nearfield(nearfield::Args),
    /// Light-map encodings for the web GLB (Radiance RGBE, RGBE/RGBM/LogLuv PNG, half-float
    /// KTX2): size against the EXRs and error against the float maps on catalogue bakes.
    Web(web::Args),
}

/// Runs the command; the error is a message for stderr.
pub fn run(args: &Args) -> Result<(), String> {
    let out = args.out.clone().unwrap_or_else(|| {
        if args.quick {
            PathBuf::from("target/bench-quick")
        } else {
            PathBuf::from("bench/results")
        }
    });
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    match &args.what {
        Some(What::Trade(t)) => trade::run(t, args.quick, args.runs, &out),
        Some(What::Refcheck(r)) => refcheck::run(r, &out),
        Some(What::Sampling(s)) => sampling::run(s, args.quick, &out),
        Some(What::Grain(g)) => grain::run(g, args.quick, &out),
        Some(What::Rays(r)) => rays::run(r, args.quick, args.runs, &out),
        Some(What::Swap(w)) => swap::run(w, args.quick, args.runs, &out),
        Some(What::Nearfield(n)) => nearfield::run(n, args.quick, &out),
        Some(What::Web(w)) => web::run(w, args.quick, &out),
        None => {
            let runs = args.runs.unwrap_or(if args.quick { 1 } else { 3 }).max(1);
            table1::run(args, runs, &out)
        }
    }
}

/// An opened backend and its renderer string, or why it is unavailable.
pub type Opened = Result<(AnyBackend, String), String>;

/// Opens `kind`; the error says why it is unavailable. Also returns the renderer string (the
/// machine's CPU for the CPU backend).
pub fn open(kind: BackendKind) -> Opened {
    let backend = luxbake_backends::open(kind).map_err(|e| e.to_string())?;
    let renderer = backend.device().unwrap_or_else(machine);
    Ok((backend, renderer))
}

/// `bench/scenes/sampling_room.toml`: the box room of the sampling and grain studies.
pub fn sampling_room_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../bench/scenes/sampling_room.toml")
}

/// A study on the sampling room (`bench grain`, `bench sampling`): when, on what and under
/// what load it began, which its report's heading and its JSON state.
pub struct SamplingRoomStudy {
    kind: BackendKind,
    renderer: String,
    quick: bool,
    date: String,
    time: String,
    load_before: String,
}

impl SamplingRoomStudy {
    /// Begins a study: the load average and the date first, then the sampling room
    /// ([`sampling_room_path`]) and backend `kind` opened.
    pub fn begin(kind: BackendKind, quick: bool) -> Result<(Self, Scene, AnyBackend), String> {
        let load_before = load_average();
        let (date, time) = utc_now();
        let path = sampling_room_path();
        let scene = Scene::from_toml_file(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let (backend, renderer) = open(kind).map_err(|e| format!("{}: {e}", kind.name()))?;
        let study = SamplingRoomStudy {
            kind,
            renderer,
            quick,
            date,
            time,
            load_before,
        };
        Ok((study, scene, backend))
    }

    /// The report begun: [`report_heading`] with `title` (noting `--quick`), the `lines`, then
    /// the load averages before the study and `load_after`.
    pub fn report(&self, title: &str, lines: &[String], load_after: &str) -> String {
        let quick = if self.quick { "; --quick" } else { "" };
        let when = (self.date.as_str(), self.time.as_str());
        let mut md = report_heading(title, when, self.kind.name(), &self.renderer, quick);
        for line in lines {
            let _ = writeln!(md, "{line}");
        }
        write_load_averages(&mut md, &self.load_before, load_after);
        md
    }

    /// The results' JSON: the study's `fields` (an object) and the run's own: scene, date,
    /// time, machine, backend, renderer, `--quick` and the load averages.
    pub fn json(&self, mut fields: serde_json::Value, load_after: &str) -> serde_json::Value {
        let run = serde_json::json!({
            "scene": "bench/scenes/sampling_room.toml", "date": self.date, "time_utc": self.time,
            "machine": machine(), "backend": self.kind.name(), "renderer": self.renderer,
            "quick": self.quick,
            "load_average_before": self.load_before, "load_average_after": load_after,
        });
        if let (Some(f), serde_json::Value::Object(run)) = (fields.as_object_mut(), run) {
            f.extend(run);
        }
        fields
    }
}

/// One bake and its process CPU time per pass label.
pub struct Run {
    /// The bake's output (maps, report with wall times).
    pub out: BakeOutput,
    /// Process CPU seconds per pass label (passes with the same label summed).
    pub pass_cpu: BTreeMap<&'static str, f64>,
}

impl Run {
    /// Wall seconds of all passes and of the lamp paths' set-up (light transport computed
    /// before the passes, on the CPU for every backend: `luxbake::lightpaths`); asset load,
    /// layout, rasterisation, BVH build and unocclude excluded.
    pub fn wall(&self) -> f64 {
        let paths: f64 = self
            .out
            .report
            .setup
            .iter()
            .filter(|(step, _)| *step == "lamp paths")
            .map(|(_, s)| s)
            .sum();
        self.out
            .report
            .passes
            .iter()
            .map(|p| p.seconds)
            .sum::<f64>()
            + paths
    }

    /// Process CPU seconds of all passes.
    pub fn cpu(&self) -> f64 {
        self.pass_cpu.values().sum()
    }

    /// Rays cast: shadow plus gather.
    pub fn rays(&self) -> u64 {
        self.out.report.shadow_rays + self.out.report.gather_rays
    }
}

/// One timed bake.
pub fn timed_bake<B: GpuBackend>(
    backend: &mut B,
    scene: &Scene,
    settings: &Settings,
) -> Result<Run, String> {
    let mut pass_cpu: BTreeMap<&'static str, f64> = BTreeMap::new();
    let mut started: Option<(&'static str, f64)> = None;
    let out = bake(backend, scene, settings, &mut |p| match p {
        Progress::PassStart { label, .. } => started = Some((label, cpu_seconds())),
        Progress::PassDone { .. } => {
            if let Some((label, t0)) = started.take() {
                *pass_cpu.entry(label).or_default() += cpu_seconds() - t0;
            }
        }
        _ => {}
    })
    .map_err(|e| e.to_string())?;
    Ok(Run { out, pass_cpu })
}

/// Process CPU time (user + system, all threads) in seconds, at clock-tick (10 ms) resolution;
/// 0 where `/proc` is unavailable.
pub fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the parenthesised command name: utime is field 14, stime 15 (1-based).
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

/// Median, minimum and maximum of a sample.
#[derive(Debug, Clone, Copy, Default)]
pub struct Summary {
    /// Median.
    pub median: f64,
    /// Minimum.
    pub min: f64,
    /// Maximum.
    pub max: f64,
}

impl Summary {
    /// Of `v` (all zero when empty).
    pub fn of(v: &[f64]) -> Summary {
        let mut v = v.to_vec();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        if n == 0 {
            return Summary::default();
        }
        let median = if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        };
        Summary {
            median,
            min: v[0],
            max: v[n - 1],
        }
    }

    /// As JSON (seconds).
    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({ "median": self.median, "min": self.min, "max": self.max })
    }
}

/// The CPU model and core count, e.g. `AMD EPYC 7B13 ×2`.
pub fn machine() -> String {
    let model = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_owned())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_owned());
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    format!("{model} ×{cores}")
}

/// Rec. 709 luminance (photometric Y) of a map value's RGB (its first three channels), in f64.
pub fn luminance_f64(rgb: &[f32]) -> f64 {
    0.2126 * f64::from(rgb[0]) + 0.7152 * f64::from(rgb[1]) + 0.0722 * f64::from(rgb[2])
}

/// Writes a report's line of the load averages before and after the measurements.
pub fn write_load_averages(md: &mut String, before: &str, after: &str) {
    let _ = writeln!(
        md,
        "- load average (1/5/15 min) before: {before}, after: {after}\n"
    );
}

/// The 1-, 5- and 15-minute load averages (`/proc/loadavg`), or "unknown".
pub fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|| "unknown".to_owned())
}

/// A bench report's Markdown begun: the heading `# {title}, {date} {time} UTC` and the line
/// naming the machine, the backend and its renderer, then `note`.
pub fn report_heading(
    title: &str,
    (date, time): (&str, &str),
    backend: &str,
    renderer: &str,
    note: &str,
) -> String {
    format!(
        "# {title}, {date} {time} UTC\n\n- machine: {}; backend {backend} ({renderer}){note}\n",
        machine()
    )
}

/// `machine()` as a file-name fragment: lower-case ASCII letters, digits and `-`.
pub fn machine_slug() -> String {
    let mut slug = String::new();
    for c in machine().chars() {
        if c.is_ascii_alphanumeric() {
            slug.push(c.to_ascii_lowercase());
        } else if !slug.ends_with('-') && !slug.is_empty() {
            slug.push('-');
        }
    }
    slug.trim_end_matches('-').to_owned()
}

/// Today's UTC date and time, `YYYY-MM-DD` and `HH:MM`.
pub fn utc_now() -> (String, String) {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let days = (secs / 86_400) as i64;
    let rem = secs % 86_400;
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    (
        format!("{y:04}-{m:02}-{d:02}"),
        format!("{:02}:{:02}", rem / 3600, (rem % 3600) / 60),
    )
}

/// `<dir>/<what>-<date>-<machine>.<ext>`.
pub fn result_path(dir: &Path, what: &str, ext: &str) -> PathBuf {
    let (date, _) = utc_now();
    dir.join(format!("{what}-{date}-{}.{ext}", machine_slug()))
}

/// Writes `text` to `path`, reporting it on stdout.
pub fn write(path: &Path, text: &str) -> Result<(), String> {
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))?;
    println!("wrote {}", path.display());
    Ok(())
}

/// Writes a study's results: `md` and `json` (pretty) as `<dir>/<what>-<date>-<machine>.md` and
/// `.json`.
pub fn write_results(
    dir: &Path,
    what: &str,
    md: &str,
    json: &serde_json::Value,
) -> Result<(), String> {
    write(&result_path(dir, what, "md"), md)?;
    write(
        &result_path(dir, what, "json"),
        &serde_json::to_string_pretty(json).map_err(|e| e.to_string())?,
    )
}

/// Least-squares slope of `ln y` against `ln x` (points with non-positive values left out);
/// `None` with fewer than two usable points.
pub fn log_log_slope(points: &[(f64, f64)]) -> Option<f64> {
    let p: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    if p.len() < 2 {
        return None;
    }
    let n = p.len() as f64;
    let mx = p.iter().map(|q| q.0).sum::<f64>() / n;
    let my = p.iter().map(|q| q.1).sum::<f64>() / n;
    let sxx: f64 = p.iter().map(|q| (q.0 - mx).powi(2)).sum();
    let sxy: f64 = p.iter().map(|q| (q.0 - mx) * (q.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_median_min_max() {
        let s = Summary::of(&[3.0, 1.0, 2.0, 10.0]);
        assert_eq!((s.median, s.min, s.max), (2.5, 1.0, 10.0));
        assert_eq!(Summary::of(&[4.0, 1.0, 2.0]).median, 2.0);
        assert_eq!(Summary::of(&[]).median, 0.0);
    }

    #[test]
    fn slope_of_power_law() {
        let pts: Vec<(f64, f64)> = [1.0, 2.0, 4.0, 8.0]
            .iter()
            .map(|&x: &f64| (x, 3.0 * x.powf(1.5)))
            .collect();
        let s = log_log_slope(&pts).expect("slope");
        assert!((s - 1.5).abs() < 1e-9, "{s}");
        assert_eq!(log_log_slope(&[(1.0, 1.0)]), None);
    }

    #[test]
    fn utc_date_is_well_formed() {
        let (date, time) = utc_now();
        assert_eq!(date.len(), 10, "{date}");
        assert!(date.starts_with("20"), "{date}");
        assert_eq!(time.len(), 5, "{time}");
        assert!(
            machine_slug()
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-')
        );
    }
}
