//! `cargo xtask bench refcheck [--scene NAME] [--dir BAKE_DIR]`: a bake against the independent
//! references of `bench/references/<scene>.csv`.
//!
//! The references are illuminances that Radiance computed at calculation points of the
//! built-in scenes (`bench/references/make_references.py`; method, conventions and validation
//! in `bench/references/README.md`): luxbake computed none of them. Each point is read from
//! the bake with the look-up of `cargo xtask measure` (closest receiving triangle within
//! [`TOLERANCE`], masked bilinear sample at its light-map UV, Rec. 709 luminance) and compared
//! by relative error `(bake − reference) / reference`: mean |relative error|, bias (mean signed
//! relative error) and the 95th percentile of |relative error|, over all points and per
//! surface kind (floor, wall, ceiling, furniture). The same figures for the direct part (points
//! with at least [`MIN_DIRECT_LUX`] of direct light) and the indirect part (total − direct)
//! separate the lamp model from the inter-reflections.
//!
//! Without `--dir`, the scene is baked in memory with `cargo xtask bake`'s defaults, overridden
//! by `cargo xtask bake`'s own settings flags (`luxbake_cli::bake::SettingsArgs`: `--quality`,
//! `--rays`, `--higher-rays`, `--narrow-rays`, `--bounces` (exactly that many explicit bounces,
//! no tail, as `cargo xtask bake --bounces`), `--texels-per-metre`, `--blur`, …) and
//! `--backend`. `bench trade` calls [`evaluate`] for every bake of its grid.
//!
//! `--seeds N` bakes it N times, seeds 0 .. N − 1 (from `--seed S`: S .. S + N − 1), and
//! separates noise from what every bake
//! shares: the main table gives each figure's mean over the bakes (what one bake is worth),
//! and a second table per surface kind the noise — the mean over points of the standard
//! deviation of a point's relative error across the seeds — beside the mean |relative error|
//! and bias of each point's mean over the seeds (what is left once the noise is averaged
//! down, bias plus noise / √N).
//!
//! `--at-points` reads each point as a lighting-calculation program computes it instead of from
//! its texels (`cargo xtask measure --direct-at-points --indirect-at-points`): the direct light
//! at the point itself (`luxbake::probe::direct_at`, [`measure::POINT_OPENING_SAMPLES`] points
//! of a luminous opening) plus the light gathered there from the bake's exitance maps
//! (`luxbake::probe::indirect_at`, [`measure::POINT_GATHER_RAYS`] rays, the bake's seed).
//!
//! An in-memory check also writes `refcheck-points-<date>-<machine>.csv`: every reference
//! point (line, surface kind, object, position, normal, reference total and direct lux) with
//! each seed's baked total and its relative error, to find where an error sits.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use luxbake::GpuBackend;
use luxbake::bake::BakeOutput;
use luxbake::probe::SurfacePoint;
use luxbake::scene::{Scene, Settings, SettingsPatch};
use luxbake::sources::scenefile::from_file_patched;
use luxbake_backends::BackendKind;
use luxbake_output::picture::luminance;

use super::{machine, open, result_path, timed_bake, utc_now, write};
use luxbake_cli::bake::SettingsArgs;
use luxbake_cli::measure;

/// Largest distance from a reference point to a baked surface, metres (`measure`'s default;
/// the points sit 1 mm off their surface).
pub const TOLERANCE: f64 = 0.01;

/// Points with less direct reference light than this (lux) are left out of the direct-light
/// figures (their relative error is meaningless: the ceiling gets none).
pub const MIN_DIRECT_LUX: f64 = 1.0;

/// Arguments of `cargo xtask bench refcheck`.
#[derive(clap::Args)]
pub struct Args {
    /// Built-in scene with a reference in `bench/references/` (chairs_01, chairs_03,
    /// chairs_05, chairs_10, sofa_01, floor, sphere), or a scene file (`.toml`, e.g.
    /// `bench/scenes/real_office.toml`) whose reference is `bench/references/<file stem>.csv`.
    #[arg(long, default_value = "chairs_05")]
    scene: String,
    /// Compare this folder written by `cargo xtask bake` (of the same scene) instead of baking.
    #[arg(long)]
    dir: Option<PathBuf>,
    /// Reference CSV (default `bench/references/<scene>.csv`).
    #[arg(long)]
    references: Option<PathBuf>,
    /// Backend of the in-memory bake.
    #[arg(long, default_value = "cpu")]
    backend: BackendKind,
    /// The bake's settings: `cargo xtask bake`'s flags (`--quality`, `--rays`, `--bounces`,
    /// `--texels-per-metre`, `--narrow-rays`, …), over its defaults; `--bounces` alone bakes
    /// exactly that many bounces, without the series' tail.
    #[command(flatten)]
    settings: SettingsArgs,
    /// Bakes in memory with seeds 0 .. N − 1 (from `--seed S`: S .. S + N − 1) and reports
    /// their mean figures and their noise (see the module docs).
    #[arg(long, default_value_t = 1)]
    seeds: u32,
    /// Reads each point as computed at the point itself (direct light there, indirect light
    /// gathered there from the maps; see the module docs) instead of from its texels.
    #[arg(long, conflicts_with = "dir")]
    at_points: bool,
}

/// One reference point.
#[derive(Debug, Clone, PartialEq)]
pub struct RefPoint {
    /// Line in the CSV (1-based).
    pub line: usize,
    /// World position, metres (1 mm off the surface along `normal`).
    pub position: [f64; 3],
    /// Surface normal (unit).
    pub normal: [f64; 3],
    /// Surface kind: floor, wall, ceiling, furniture (or the scene's own, e.g. sphere).
    pub surface: String,
    /// Object name, when the file has the column.
    pub object: Option<String>,
    /// Reference illuminance, lux (Rec. 709 luminance of the RGB illuminance).
    pub lux: f64,
    /// Its direct part, lux, when the file has the column.
    pub direct_lux: Option<f64>,
}

/// `bench/references/` of this checkout.
pub fn references_dir() -> PathBuf {
    let xtask = Path::new(env!("CARGO_MANIFEST_DIR"));
    xtask
        .parent()
        .unwrap_or(xtask)
        .join("bench")
        .join("references")
}

/// `path` relative to the checkout when it lies inside it (for reports), else as given.
pub fn shown(path: &Path) -> String {
    let xtask = Path::new(env!("CARGO_MANIFEST_DIR"));
    let root = xtask.parent().unwrap_or(xtask);
    path.strip_prefix(root)
        .unwrap_or(path)
        .display()
        .to_string()
}

/// The committed reference of `name`: a built-in scene's, or a scene file's (`.toml`) by its
/// file stem.
pub fn reference_path(name: &str) -> PathBuf {
    let stem = match Path::new(name).file_stem() {
        Some(stem) if name.ends_with(".toml") => stem.to_string_lossy(),
        _ => name.into(),
    };
    references_dir().join(format!("{stem}.csv"))
}

/// Parses a reference CSV: `#` comments and blank lines skipped, then a header naming the
/// columns (`x,y,z,nx,ny,nz,surface,lux` required; `object`, `direct_lux` and others
/// optional, in any order), then one point per row.
pub fn parse(text: &str) -> Result<Vec<RefPoint>, String> {
    let mut header: Option<Vec<String>> = None;
    let mut col = BTreeMap::new();
    let mut points = Vec::new();
    for (line_no, _, fields) in measure::csv_rows(text) {
        let Some(names) = &header else {
            let names: Vec<String> = fields.iter().map(|f| f.to_ascii_lowercase()).collect();
            for (k, n) in names.iter().enumerate() {
                col.insert(n.clone(), k);
            }
            for need in ["x", "y", "z", "nx", "ny", "nz", "surface", "lux"] {
                if !col.contains_key(need) {
                    return Err(format!("line {line_no}: header lacks the column `{need}`"));
                }
            }
            header = Some(names);
            continue;
        };
        if fields.len() != names.len() {
            return Err(format!(
                "line {line_no}: {} fields, the header has {}",
                fields.len(),
                names.len()
            ));
        }
        let num = |name: &str| -> Result<f64, String> {
            let v = fields[col[name]];
            v.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("line {line_no}: `{name}` is not a finite number: `{v}`"))
        };
        let position = [num("x")?, num("y")?, num("z")?];
        let n = [num("nx")?, num("ny")?, num("nz")?];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        if (len - 1.0).abs() >= 0.01 {
            return Err(format!("line {line_no}: the normal is not a unit vector"));
        }
        let lux = num("lux")?;
        if lux <= 0.0 {
            return Err(format!(
                "line {line_no}: reference lux must be > 0, got {lux}"
            ));
        }
        let direct_lux = match col.get("direct_lux") {
            Some(_) => Some(num("direct_lux")?),
            None => None,
        };
        points.push(RefPoint {
            line: line_no,
            position,
            normal: n.map(|c| c / len),
            surface: fields[col["surface"]].to_owned(),
            object: col.get("object").map(|&k| fields[k].to_owned()),
            lux,
            direct_lux,
        });
    }
    if header.is_none() {
        return Err("no header row".to_owned());
    }
    Ok(points)
}

/// Reads and parses a reference CSV.
pub fn load(path: &Path) -> Result<Vec<RefPoint>, String> {
    let text = measure::read_text(path)?;
    parse(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// Relative-error statistics of values against references.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Stats {
    /// Points compared.
    pub n: usize,
    /// Mean |relative error|.
    pub mean_abs_rel: f64,
    /// Mean signed relative error (negative: the bake is low).
    pub bias: f64,
    /// 95th percentile of |relative error| (nearest rank on the sorted list).
    pub p95_abs_rel: f64,
}

/// `(value − reference) / reference`; `None` for a non-positive reference (such points are
/// left out of every figure).
fn relative_error(value: f64, reference: f64) -> Option<f64> {
    (reference > 0.0).then(|| (value - reference) / reference)
}

impl Stats {
    /// Of `values` against `reference` (pairs with a non-positive reference left out).
    pub fn of(values: &[f64], reference: &[f64]) -> Stats {
        let rel: Vec<f64> = values
            .iter()
            .zip(reference)
            .filter_map(|(&v, &r)| relative_error(v, r))
            .collect();
        let n = rel.len();
        if n == 0 {
            return Stats::default();
        }
        let mut abs: Vec<f64> = rel.iter().map(|r| r.abs()).collect();
        abs.sort_by(f64::total_cmp);
        Stats {
            n,
            mean_abs_rel: abs.iter().sum::<f64>() / n as f64,
            bias: rel.iter().sum::<f64>() / n as f64,
            p95_abs_rel: abs[((n - 1) as f64 * 0.95).round() as usize],
        }
    }

    /// As JSON (fractions, not percent).
    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({ "points": self.n, "mean_abs_rel": self.mean_abs_rel,
            "bias": self.bias, "p95_abs_rel": self.p95_abs_rel })
    }
}

/// The figures of one group of points.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Group {
    /// Total illuminance.
    pub total: Stats,
    /// Direct part, points with at least [`MIN_DIRECT_LUX`] of direct reference light.
    pub direct: Stats,
    /// Indirect part (total − direct), points with a direct column.
    pub indirect: Stats,
}

impl Group {
    /// As JSON.
    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({ "total": self.total.json(), "direct": self.direct.json(),
            "indirect": self.indirect.json() })
    }
}

/// A bake compared with a reference: all points, then per surface kind.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Comparison {
    /// Every point.
    pub all: Group,
    /// Per surface kind, sorted by name.
    pub per_surface: BTreeMap<String, Group>,
}

impl Comparison {
    /// As JSON.
    pub fn json(&self) -> serde_json::Value {
        let per: serde_json::Map<String, serde_json::Value> = self
            .per_surface
            .iter()
            .map(|(k, g)| (k.clone(), g.json()))
            .collect();
        serde_json::json!({ "all": self.all.json(), "per_surface": per })
    }

    /// Markdown table: one row for all points, one per surface kind (percent).
    pub fn markdown(&self) -> String {
        let mut md = String::new();
        let _ = writeln!(
            md,
            "| surface | points | mean \\|rel\\| % | bias % | p95 \\|rel\\| % | direct bias % \
             | indirect bias % | indirect mean \\|rel\\| % |"
        );
        let _ = writeln!(md, "|---|--:|--:|--:|--:|--:|--:|--:|");
        let rows = std::iter::once(("all", &self.all))
            .chain(self.per_surface.iter().map(|(k, g)| (k.as_str(), g)));
        for (name, g) in rows {
            let pct = |s: &Stats, v: f64| {
                if s.n == 0 {
                    "–".to_owned()
                } else {
                    format!("{:+.1}", v * 100.0)
                }
            };
            let _ = writeln!(
                md,
                "| {name} | {} | {:.1} | {:+.1} | {:.1} | {} | {} | {} |",
                g.total.n,
                g.total.mean_abs_rel * 100.0,
                g.total.bias * 100.0,
                g.total.p95_abs_rel * 100.0,
                pct(&g.direct, g.direct.bias),
                pct(&g.indirect, g.indirect.bias),
                if g.indirect.n == 0 {
                    "–".to_owned()
                } else {
                    format!("{:.1}", g.indirect.mean_abs_rel * 100.0)
                },
            );
        }
        md
    }
}

impl Stats {
    /// The field-wise mean of `all` (their point counts should agree; the first's is kept).
    fn mean(all: &[Stats]) -> Stats {
        let n = all.len().max(1) as f64;
        let sum = |f: fn(&Stats) -> f64| all.iter().map(f).sum::<f64>() / n;
        Stats {
            n: all.first().map_or(0, |s| s.n),
            mean_abs_rel: sum(|s| s.mean_abs_rel),
            bias: sum(|s| s.bias),
            p95_abs_rel: sum(|s| s.p95_abs_rel),
        }
    }
}

impl Group {
    fn mean(all: &[&Group]) -> Group {
        let of =
            |f: fn(&Group) -> Stats| Stats::mean(&all.iter().map(|g| f(g)).collect::<Vec<_>>());
        Group {
            total: of(|g| g.total),
            direct: of(|g| g.direct),
            indirect: of(|g| g.indirect),
        }
    }
}

impl Comparison {
    /// Each figure's mean over `all` (comparisons of bakes of one scene, with the same
    /// surface kinds).
    pub fn mean(all: &[Comparison]) -> Comparison {
        let groups = |pick: &dyn Fn(&Comparison) -> Option<&Group>| -> Group {
            Group::mean(&all.iter().filter_map(pick).collect::<Vec<_>>())
        };
        Comparison {
            all: groups(&|c| Some(&c.all)),
            per_surface: all
                .first()
                .map(|c| {
                    c.per_surface
                        .keys()
                        .map(|k| (k.clone(), groups(&|c| c.per_surface.get(k))))
                        .collect()
                })
                .unwrap_or_default(),
        }
    }
}

/// Noise and shared error of several bakes at the same points (`--seeds`), per surface kind.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Noise {
    /// `all`, then each surface kind.
    pub groups: Vec<NoiseGroup>,
}

/// [`Noise`] of one group of points.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct NoiseGroup {
    /// `all` or the surface kind.
    pub name: String,
    /// Points.
    pub points: usize,
    /// The mean over the points of the standard deviation of their relative error across the
    /// bakes.
    pub sd: f64,
    /// The mean |relative error| of each point's mean over the bakes.
    pub mean_abs: f64,
    /// The mean relative error (the bias).
    pub bias: f64,
}

impl Noise {
    /// Of `bakes` (each a bake's `[direct, total]` at the points of `refs`, at least two);
    /// points with a non-positive reference are left out, as in [`Stats::of`].
    pub fn of(refs: &[RefPoint], bakes: &[Vec<Measured>]) -> Noise {
        let n = bakes.len() as f64;
        // Per point with a relative error: the standard deviation and mean of it over bakes.
        let per_point: Vec<Option<(f64, f64)>> = refs
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let rel: Vec<f64> = bakes
                    .iter()
                    .map(|b| relative_error(b[i][1], r.lux))
                    .collect::<Option<_>>()?;
                let mean = rel.iter().sum::<f64>() / n;
                let var = rel.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
                Some((var.sqrt(), mean))
            })
            .collect();
        let all: Vec<usize> = (0..refs.len()).collect();
        let groups = std::iter::once(("all".to_owned(), all))
            .chain(surface_kinds(refs))
            .map(|(name, idx)| {
                let points: Vec<(f64, f64)> = idx.iter().filter_map(|&i| per_point[i]).collect();
                let m = points.len().max(1) as f64;
                let avg = |f: &dyn Fn(&(f64, f64)) -> f64| points.iter().map(f).sum::<f64>() / m;
                NoiseGroup {
                    points: points.len(),
                    sd: avg(&|p| p.0),
                    mean_abs: avg(&|p| p.1.abs()),
                    bias: avg(&|p| p.1),
                    name,
                }
            })
            .collect();
        Noise { groups }
    }

    /// As JSON (fractions).
    pub fn json(&self) -> serde_json::Value {
        self.groups
            .iter()
            .map(|g| {
                serde_json::json!({ "surface": g.name, "points": g.points, "noise_sd": g.sd,
                    "mean_abs_rel_of_mean": g.mean_abs, "bias": g.bias })
            })
            .collect()
    }

    /// Markdown table (percent).
    pub fn markdown(&self) -> String {
        let mut md = String::from(
            "| surface | points | noise sd % | mean \\|rel\\| of the mean % | bias % |\n\
             |---|--:|--:|--:|--:|\n",
        );
        for g in &self.groups {
            let _ = writeln!(
                md,
                "| {} | {} | {:.2} | {:.2} | {:+.2} |",
                g.name,
                g.points,
                g.sd * 100.0,
                g.mean_abs * 100.0,
                g.bias * 100.0
            );
        }
        md
    }
}

/// A bake's `[direct, total]` lux at each point.
pub type Measured = [f64; 2];

/// Compares `measured` (same order as `refs`) with the references.
pub fn compare(refs: &[RefPoint], measured: &[Measured]) -> Comparison {
    let group = |idx: &[usize]| -> Group {
        let pick = |f: &dyn Fn(usize) -> Option<(f64, f64)>| -> (Vec<f64>, Vec<f64>) {
            idx.iter().filter_map(|&i| f(i)).unzip()
        };
        let (v, r) = pick(&|i| Some((measured[i][1], refs[i].lux)));
        let (dv, dr) = pick(&|i| {
            refs[i]
                .direct_lux
                .filter(|d| *d >= MIN_DIRECT_LUX)
                .map(|d| (measured[i][0], d))
        });
        let (iv, ir) = pick(&|i| {
            refs[i]
                .direct_lux
                .map(|d| (measured[i][1] - measured[i][0], refs[i].lux - d))
        });
        Group {
            total: Stats::of(&v, &r),
            direct: Stats::of(&dv, &dr),
            indirect: Stats::of(&iv, &ir),
        }
    };
    let n = refs.len().min(measured.len());
    let all: Vec<usize> = (0..n).collect();
    Comparison {
        all: group(&all),
        per_surface: surface_kinds(&refs[..n])
            .into_iter()
            .map(|(k, idx)| (k, group(&idx)))
            .collect(),
    }
}

/// The indices of `refs` per surface kind, sorted by name.
fn surface_kinds(refs: &[RefPoint]) -> BTreeMap<String, Vec<usize>> {
    let mut kinds: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for (i, r) in refs.iter().enumerate() {
        kinds.entry(r.surface.clone()).or_default().push(i);
    }
    kinds
}

/// Locates the reference points on `scene`'s receivers (`measure`'s rule and tolerance);
/// `label` names the file in errors.
pub fn locate(scene: &Scene, refs: &[RefPoint], label: &str) -> Result<Vec<SurfacePoint>, String> {
    let points: Vec<(usize, [f64; 3])> = refs.iter().map(|r| (r.line, r.position)).collect();
    measure::locate_points(scene, &points, label, TOLERANCE)
}

/// `[direct, total]` lux of an in-memory bake at located points: the masked bilinear look-up
/// and Rec. 709 luminance of `cargo xtask measure` (which reads the same maps from EXR).
pub fn sample(out: &BakeOutput, located: &[SurfacePoint]) -> Result<Vec<Measured>, String> {
    located
        .iter()
        .map(|sp| {
            let maps = out
                .maps
                .iter()
                .find(|m| m.object == sp.object)
                .ok_or_else(|| format!("object {} has no light map", sp.object))?;
            Ok([
                f64::from(luminance(maps.direct().sample(sp.uv))),
                f64::from(luminance(maps.illuminance().sample(sp.uv))),
            ])
        })
        .collect()
}

/// `[direct, total]` lux at located points computed at the points themselves (`--at-points`,
/// see the module docs) from the in-memory bake `out` of `room` with `settings`.
fn at_points(
    room: &luxbake::bake::Room,
    out: &BakeOutput,
    settings: &Settings,
    located: &[SurfacePoint],
) -> Result<Vec<Measured>, String> {
    use luxbake::probe::{direct_at, indirect_at};
    let calc = measure::calc_points(located);
    let mut cpu = luxbake_backends::open(BackendKind::Cpu).map_err(|e| e.to_string())?;
    let samples = measure::at_point_samples(settings.opening_samples, None);
    let direct = direct_at(&mut cpu, room, &room.scene.lamps, settings, samples, &calc)
        .map_err(|e| e.to_string())?;
    // Each object's maps, looked up once rather than on every ray.
    let by_object: Vec<_> = (0..room.scene.objects.len())
        .map(|k| out.maps.iter().find(|m| m.object == k))
        .collect();
    let exitance = |object: usize, uv: [f32; 2]| {
        by_object
            .get(object)
            .copied()
            .flatten()
            .map_or([0.0; 3], |m| m.exitance().sample(uv))
    };
    let indirect = indirect_at(
        room,
        &calc,
        measure::POINT_GATHER_RAYS,
        settings.seed,
        &exitance,
    );
    Ok(direct
        .iter()
        .zip(&indirect)
        .map(|(&d, &i)| {
            let d = f64::from(luminance(d));
            [d, d + f64::from(luminance(i))]
        })
        .collect())
}

/// Compares the in-memory bake `out` of `scene` with `refs` (`label`: their file, for errors).
pub fn evaluate(
    scene: &Scene,
    out: &BakeOutput,
    refs: &[RefPoint],
    label: &str,
) -> Result<Comparison, String> {
    let located = locate(scene, refs, label)?;
    Ok(compare(refs, &sample(out, &located)?))
}

fn settings_label(s: &Settings) -> String {
    format!(
        "{} rays, {} texels/m, {} bounces, blur {}",
        s.rays, s.texels_per_metre, s.bounces, s.blur
    )
}

/// The seeds of `--seeds N`: N of them from `--seed` (default 0), `first .. first + N − 1`
/// (at least one, and none past `u32::MAX`).
fn seed_range(first: Option<u32>, n: u32) -> std::ops::RangeInclusive<u32> {
    let first = first.unwrap_or(0);
    first..=first.saturating_add(n.max(1) - 1)
}

/// Every reference point with what each bake measured there, one row a point: its line in the
/// reference file, surface kind, object, the reference's total and direct lux, then per bake
/// (its seed from `seeds`) `total_lux_<seed>` and `rel_<seed>` (relative error of the total;
/// empty where the reference is not positive).
fn points_table(
    refs: &[RefPoint],
    seeds: std::ops::RangeInclusive<u32>,
    bakes: &[Vec<Measured>],
) -> String {
    let mut csv = String::from("line,surface,object,x,y,z,nx,ny,nz,lux,direct_lux");
    for seed in seeds.take(bakes.len()) {
        let _ = write!(csv, ",total_lux_{seed},rel_{seed}");
    }
    csv.push('\n');
    for (i, r) in refs.iter().enumerate() {
        let [x, y, z] = r.position;
        let [nx, ny, nz] = r.normal;
        let _ = write!(
            csv,
            "{},{},{},{x},{y},{z},{nx},{ny},{nz},{},{}",
            r.line,
            r.surface,
            r.object.as_deref().unwrap_or(""),
            r.lux,
            r.direct_lux.map(|d| d.to_string()).unwrap_or_default()
        );
        for bake in bakes {
            let total = bake[i][1];
            let rel = relative_error(total, r.lux).map_or_else(String::new, |e| e.to_string());
            let _ = write!(csv, ",{total},{rel}");
        }
        csv.push('\n');
    }
    csv
}

/// The scene `name` names: a built-in, or a scene file (a path ending in `.toml`, its meshes
/// loaded), with `patch` over its settings.
fn scene_of(name: &str, patch: &SettingsPatch) -> Result<Scene, String> {
    if name.ends_with(".toml") {
        let loader = luxbake_assets::SceneLoader::default();
        return from_file_patched(Path::new(name), Some(&loader), patch)
            .map_err(|e| format!("{name}: {e}"));
    }
    let settings = patch.settings().map_err(|e| e.to_string())?;
    Scene::builtin_with_settings(name, settings).map_err(|e| e.to_string())
}

/// Runs the check; prints and writes `refcheck-<date>-<machine>.{md,json}` into `out`.
pub fn run(args: &Args, out: &Path) -> Result<(), String> {
    let ref_path = args
        .references
        .clone()
        .unwrap_or_else(|| reference_path(&args.scene));
    let refs = load(&ref_path)?;
    let label = shown(&ref_path);
    let mut noise_md = String::new();
    let mut points_csv = None;
    let (what, comparison, extra) = match &args.dir {
        Some(dir) => {
            let points: Vec<(usize, [f64; 3])> =
                refs.iter().map(|r| (r.line, r.position)).collect();
            let rows = measure::measure_points(dir, &points, &label, TOLERANCE)?;
            let measured: Vec<Measured> = rows.iter().map(|(_, [d, _, t])| [*d, *t]).collect();
            let what = format!("bake folder {}", dir.display());
            (
                what,
                compare(&refs, &measured),
                serde_json::json!({ "dir": dir.display().to_string() }),
            )
        }
        None => {
            // The flags as `cargo xtask bake`'s: a patch over the default (`--bounces` alone
            // then bakes exactly that many bounces, without the tail).
            let patch = args.settings.patch();
            let scene = scene_of(&args.scene, &patch)?;
            let s = scene.settings.clone();
            let (mut backend, renderer) =
                open(args.backend).map_err(|e| format!("{}: {e}", args.backend.name()))?;
            let located = locate(&scene, &refs, &label)?;
            let room = if args.at_points {
                let limits = luxbake_backends::open(BackendKind::Cpu)
                    .map_err(|e| e.to_string())?
                    .limits();
                Some(
                    luxbake::bake::Room::prepare(&scene, &s, limits, &mut |_| {})
                        .map_err(|e| e.to_string())?,
                )
            } else {
                None
            };
            let (mut comparisons, mut bakes, mut walls) = (Vec::new(), Vec::new(), Vec::new());
            let seeds = seed_range(args.settings.seed, args.seeds);
            for seed in seeds.clone() {
                let s = Settings { seed, ..s.clone() };
                eprintln!("refcheck: baking {} ({})", args.scene, settings_label(&s));
                let run = timed_bake(&mut backend, &scene, &s)?;
                walls.push(run.wall());
                let measured = match &room {
                    Some(room) => at_points(room, &run.out, &s, &located)?,
                    None => sample(&run.out, &located)?,
                };
                comparisons.push(compare(&refs, &measured));
                bakes.push(measured);
            }
            let wall = walls.iter().sum::<f64>() / walls.len() as f64;
            points_csv = Some(points_table(&refs, seeds.clone(), &bakes));
            let what = format!(
                "in-memory bake of `{}`: {} on {} ({renderer}), passes {:.1} s{}{}",
                args.scene,
                settings_label(&s),
                args.backend.name(),
                wall,
                if args.seeds > 1 {
                    format!(
                        " (mean of {} bakes, seeds {} .. {})",
                        bakes.len(),
                        seeds.start(),
                        seeds.end()
                    )
                } else {
                    String::new()
                },
                if args.at_points {
                    "; read at the points themselves (--at-points)"
                } else {
                    ""
                }
            );
            // Every setting, as a bake's manifest records them: refcheck takes all the bake's
            // settings flags.
            let mut extra = serde_json::json!({ "at_points": args.at_points,
                "settings": luxbake_output::settings_json(&s), "backend": args.backend.name(),
                "renderer": renderer, "pass_wall_s": wall });
            if args.seeds > 1 {
                let noise = Noise::of(&refs, &bakes);
                extra["seeds"] = serde_json::json!(args.seeds);
                extra["per_seed"] = comparisons.iter().map(Comparison::json).collect();
                extra["noise"] = noise.json();
                noise_md = noise.markdown();
            }
            (what, Comparison::mean(&comparisons), extra)
        }
    };
    let (date, time) = utc_now();
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# Reference check — {} against Radiance, {date} {time} UTC\n",
        args.scene
    );
    let _ = writeln!(md, "- bake: {what}");
    let _ = writeln!(
        md,
        "- reference: `{}` ({} points; Radiance `rtrace -I`, see bench/references/README.md)",
        label,
        refs.len()
    );
    let _ = writeln!(
        md,
        "- relative error = (bake − reference) / reference; bias = its mean; direct: points \
         with ≥ {MIN_DIRECT_LUX} lx of direct light; indirect = total − direct\n"
    );
    md.push_str(&comparison.markdown());
    if !noise_md.is_empty() {
        let _ = writeln!(
            md,
            "\nNoise and shared error over the {} seeds (percent):\n",
            args.seeds
        );
        md.push_str(&noise_md);
    }
    print!("{md}");
    let json = serde_json::json!({
        "scene": args.scene, "date": date, "time_utc": time, "machine": machine(),
        "reference": label, "points": refs.len(),
        "bake": extra, "comparison": comparison.json(),
    });
    write(&result_path(out, "refcheck", "md"), &md)?;
    if let Some(csv) = points_csv {
        write(&result_path(out, "refcheck-points", "csv"), &csv)?;
    }
    write(
        &result_path(out, "refcheck", "json"),
        &serde_json::to_string_pretty(&json).map_err(|e| e.to_string())?,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use luxbake::scene::Blur;

    #[test]
    fn a_scene_file_reads_the_reference_named_by_its_stem() {
        assert_eq!(
            reference_path("chairs_05"),
            references_dir().join("chairs_05.csv")
        );
        assert_eq!(
            reference_path("bench/scenes/real_office.toml"),
            references_dir().join("real_office.csv")
        );
        let patch = SettingsPatch::default();
        let scene = scene_of(
            &format!(
                "{}/../bench/scenes/real_office.toml",
                env!("CARGO_MANIFEST_DIR")
            ),
            &patch,
        )
        .expect("the scene file");
        assert_eq!(scene.lamps.len(), 2);
        assert!(scene_of("no_such_room", &patch).is_err());
    }

    #[test]
    fn parses_by_header_names() {
        let text = "# comment\n\nx,y,z,nx,ny,nz,surface,object,lux,direct_lux,lux_r\n\
                    1,0.001,2,0,1,0,floor,room,50,30,51\n\
                    0,1,1.999,0,0,-1,wall,room,20.5,0,20\n";
        let p = parse(text).expect("parse");
        assert_eq!(p.len(), 2);
        assert_eq!(p[0].line, 4);
        assert_eq!(p[0].position, [1.0, 0.001, 2.0]);
        assert_eq!(p[0].surface, "floor");
        assert_eq!(p[0].object.as_deref(), Some("room"));
        assert_eq!((p[0].lux, p[0].direct_lux), (50.0, Some(30.0)));
        assert_eq!(p[1].normal, [0.0, 0.0, -1.0]);
        // Columns in another order, no optional ones.
        let q = parse("lux,surface,x,y,z,nx,ny,nz\n7,ceiling,0,2.599,0,0,-1,0\n").expect("parse");
        assert_eq!(
            (q[0].lux, q[0].direct_lux, q[0].object.clone()),
            (7.0, None, None)
        );
        assert!(parse("x,y,z\n1,2,3\n").unwrap_err().contains("`nx`"));
        let bad = "x,y,z,nx,ny,nz,surface,lux\n1,2,3,0,1,0,floor\n";
        assert!(parse(bad).unwrap_err().contains("line 2"));
        let flat = "x,y,z,nx,ny,nz,surface,lux\n1,2,3,0,0,0,floor,4\n";
        assert!(parse(flat).unwrap_err().contains("unit vector"));
        let zero = "x,y,z,nx,ny,nz,surface,lux\n1,2,3,0,1,0,floor,0\n";
        assert!(parse(zero).unwrap_err().contains("> 0"));
        assert!(parse("# only a comment\n").is_err());
    }

    #[test]
    fn stats_of_known_errors() {
        let r = [10.0, 10.0, 20.0, 40.0];
        let v = [9.0, 11.0, 10.0, 40.0];
        let s = Stats::of(&v, &r);
        assert_eq!(s.n, 4);
        assert!((s.mean_abs_rel - 0.175).abs() < 1e-12, "{s:?}");
        assert!((s.bias + 0.125).abs() < 1e-12, "{s:?}");
        assert!((s.p95_abs_rel - 0.5).abs() < 1e-12, "{s:?}");
        assert_eq!(Stats::of(&[], &[]), Stats::default());
        assert_eq!(Stats::of(&[1.0], &[0.0]).n, 0);
    }

    /// A reference point on `surface` with `lux` (and its direct part).
    fn point(surface: &str, lux: f64, direct_lux: Option<f64>) -> RefPoint {
        RefPoint {
            line: 1,
            position: [0.0; 3],
            normal: [0.0, 1.0, 0.0],
            surface: surface.to_owned(),
            object: None,
            lux,
            direct_lux,
        }
    }

    #[test]
    fn noise_separates_spread_from_shared_error() {
        let refs = [
            point("floor", 100.0, None),
            point("wall", 10.0, None),
            point("wall", 0.0, None),
        ];
        // The floor point: +2 % and −2 % (noise, no shared error); the first wall point: +10 %
        // twice; the second, dark in the reference, has no relative error and is left out.
        let bakes = vec![
            vec![[0.0, 102.0], [0.0, 11.0], [0.0, 1.0]],
            vec![[0.0, 98.0], [0.0, 11.0], [0.0, 2.0]],
        ];
        let noise = Noise::of(&refs, &bakes);
        let floor = &noise.groups[1];
        assert_eq!((floor.name.as_str(), floor.points), ("floor", 1));
        assert!((floor.sd - 0.02 * 2f64.sqrt()).abs() < 1e-12, "{floor:?}");
        assert!(
            floor.mean_abs.abs() < 1e-12 && floor.bias.abs() < 1e-12,
            "{floor:?}"
        );
        let wall = &noise.groups[2];
        assert!(
            wall.sd.abs() < 1e-12 && (wall.mean_abs - 0.1).abs() < 1e-12,
            "{wall:?}"
        );
        assert!((wall.bias - 0.1).abs() < 1e-12, "{wall:?}");
        assert_eq!(wall.points, 1);
        assert_eq!(noise.groups[0].points, 2);
        assert!(
            noise
                .groups
                .iter()
                .all(|g| g.sd.is_finite() && g.bias.is_finite())
        );
        assert!(
            noise
                .markdown()
                .contains("| wall | 1 | 0.00 | 10.00 | +10.00 |")
        );
        // The mean of two comparisons: each figure averaged.
        let c = [compare(&refs, &bakes[0]), compare(&refs, &bakes[1])];
        let m = Comparison::mean(&c);
        assert!((m.per_surface["floor"].total.mean_abs_rel - 0.02).abs() < 1e-12);
        assert!(m.per_surface["floor"].total.bias.abs() < 1e-12);
        assert!((m.all.total.bias - 0.05).abs() < 1e-12, "{:?}", m.all.total);
    }

    #[test]
    fn the_points_table_lists_every_point_with_every_seed() {
        let refs = [
            RefPoint {
                line: 7,
                object: Some("chair_01".into()),
                ..point("furniture", 16.0, Some(0.0))
            },
            point("floor", 0.0, None),
        ];
        let bakes = vec![vec![[0.0, 12.0], [0.0, 1.0]], vec![[0.0, 20.0], [0.0, 2.0]]];
        let csv = points_table(&refs, seed_range(None, 2), &bakes);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(
            lines,
            [
                "line,surface,object,x,y,z,nx,ny,nz,lux,direct_lux,total_lux_0,rel_0,total_lux_1,rel_1",
                "7,furniture,chair_01,0,0,0,0,1,0,16,0,12,-0.25,20,0.25",
                // No relative error against a reference of 0, no direct part where the file
                // has none.
                "1,floor,,0,0,0,0,1,0,0,,1,,2,",
            ]
        );
        // From `--seed 5` the columns name seeds 5 and 6.
        let from_five = points_table(&refs, seed_range(Some(5), 2), &bakes);
        assert!(
            from_five
                .lines()
                .next()
                .is_some_and(|h| h.ends_with(",total_lux_5,rel_5,total_lux_6,rel_6")),
            "{from_five}"
        );
    }

    #[test]
    fn seeds_run_from_the_seed_flag() {
        assert_eq!(seed_range(None, 3), 0..=2);
        assert_eq!(seed_range(Some(7), 1), 7..=7);
        // `--seeds 0` bakes once; no seed past u32::MAX.
        assert_eq!(seed_range(Some(4), 0), 4..=4);
        assert_eq!(seed_range(Some(u32::MAX - 1), 4), u32::MAX - 1..=u32::MAX);
    }

    #[test]
    fn refcheck_takes_the_bakes_settings_flags() {
        use clap::Parser;
        #[derive(Parser)]
        struct Cli {
            #[command(flatten)]
            args: Args,
        }
        let cli = Cli::try_parse_from([
            "refcheck",
            "--quality",
            "final",
            "--narrow-rays",
            "1024",
            "--texels-per-metre",
            "128",
            "--opening-samples",
            "96",
            "--seed",
            "3",
            "--seeds",
            "2",
        ])
        .expect("the bake's flags parse");
        let patch = cli.args.settings.patch();
        assert_eq!(patch.quality, Some(luxbake::scene::Quality::Final));
        assert_eq!(patch.narrow_rays, Some(1024));
        assert_eq!(patch.texels_per_metre, Some(128.0));
        assert_eq!(patch.opening_samples, Some(96));
        assert_eq!(seed_range(patch.seed, cli.args.seeds), 3..=4);
    }

    #[test]
    fn compare_groups_by_surface() {
        let p = |surface: &str, lux: f64, direct: f64| point(surface, lux, Some(direct));
        let refs = [
            p("floor", 100.0, 60.0),
            p("wall", 40.0, 0.5),
            p("wall", 20.0, 10.0),
        ];
        let measured = [[60.0, 90.0], [0.5, 30.0], [10.0, 20.0]];
        let c = compare(&refs, &measured);
        assert_eq!(c.all.total.n, 3);
        assert_eq!(c.per_surface["wall"].total.n, 2);
        assert!((c.per_surface["floor"].total.bias + 0.1).abs() < 1e-12);
        assert!((c.per_surface["floor"].indirect.bias + 0.25).abs() < 1e-12);
        // The wall point with 0.5 lx direct is left out of the direct figures only.
        assert_eq!(c.per_surface["wall"].direct.n, 1);
        assert_eq!(c.per_surface["wall"].indirect.n, 2);
        let md = c.markdown();
        assert!(
            md.contains("| all | 3 |") && md.contains("| wall | 2 |"),
            "{md}"
        );
    }

    /// Every committed reference parses and its points lie on the scene's receivers.
    #[test]
    fn committed_references_locate_on_their_scenes() {
        for name in ["chairs_01", "chairs_05", "sofa_01", "floor", "sphere"] {
            let path = reference_path(name);
            let refs = load(&path).unwrap_or_else(|e| panic!("{e}"));
            assert!(refs.len() >= 100, "{name}: {} points", refs.len());
            let scene = Scene::builtin(name).expect("builtin");
            let located = locate(&scene, &refs, name).unwrap_or_else(|e| panic!("{e}"));
            for (r, sp) in refs.iter().zip(&located) {
                assert!(
                    (sp.distance - 0.001).abs() < 2e-4,
                    "{name} line {}: {} m off the surface",
                    r.line,
                    sp.distance
                );
            }
        }
    }

    /// The `floor` reference is direct light only (one plane: nothing to inter-reflect), so a
    /// coarse bake must meet it closely: a check of the whole chain (file, look-up, units).
    #[test]
    fn a_floor_bake_meets_the_floor_reference() {
        use luxbake::bake::bake;
        use luxbake_backend_cpu::CpuBackend;
        let refs = load(&reference_path("floor")).expect("floor reference");
        let settings = Settings {
            rays: 1,
            bounces: 0,
            blur: Blur::None,
            texels_per_metre: 4.0,
            ..Settings::default()
        };
        let scene = Scene::builtin_with_settings("floor", settings.clone()).expect("floor");
        let out = bake(&mut CpuBackend::new(), &scene, &settings, &mut |_| {}).expect("bake");
        let c = evaluate(&scene, &out, &refs, "floor.csv").expect("evaluate");
        assert_eq!(c.all.total.n, refs.len());
        assert!(c.all.total.mean_abs_rel < 0.01, "{:?}", c.all.total);
        assert!(c.all.total.bias.abs() < 0.01, "{:?}", c.all.total);
    }
}
