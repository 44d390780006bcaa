//! `luxbake measure DIR --points FILE.csv`: illuminance at calculation points, read back
//! from a bake's light maps.
//!
//! `FILE.csv` has one point per row, `x,y,z` in metres (world), on baked surfaces; blank
//! lines, `#` comments and a non-numeric header row are skipped. The scene is rebuilt from the
//! manifest's `scene.source` (with the baked settings), each point is located on the nearest
//! receiving surface (within `--tolerance`, default 1 cm), and the maps are read bilinearly
//! at its light-map UV (the masked rule of `luxbake::map`). Printed as CSV:
//! `x,y,z,direct_lux,indirect_lux,total_lux` — the Rec. 709 luminance of the RGB illuminance
//! (each channel's value for a white lamp); `indirect = total − direct`, both blurred alike.
//! Lux are printed as the shortest decimal that reads back as the same f32 (the maps'
//! precision), so every magnitude keeps its significant digits: a scene at 1000 × scale
//! (E ≈ 2·10⁻⁵ lx) as well as one in metres. A point on no baked surface is an error naming
//! its row.
//!
//! `--direct-at-points` adds two columns, `direct_at_point_lux` and `total_at_point_lux`: the
//! direct light computed at each point itself (`luxbake::probe::direct_at` on the CPU: the
//! bake's lamps and their models, shadow rays from the located surface point along its
//! normal), and that plus the maps' indirect part. A luminous opening is sampled there with
//! `--opening-samples` points (up to twice as many near it), by default
//! [`POINT_OPENING_SAMPLES`] or the bake's, whichever is more: calculation points are few, so
//! their lattice can converge (the default bake's 48 leave about 1 % of noise at one point
//! near a bright opening, up to 2.7 % in `bench nearfield`; 1024 leave < 0.2 %). A lighting-calculation
//! program computes its points so; a light map holds texel centres and interpolates, which is
//! off where the light bends within a texel (a luminaire's cut-off, the foot of a wall
//! washer). The bake's lamps must be the scene file's (a bake with `--lamp` files is refused:
//! its manifest does not keep the photometric files).
//!
//! `--indirect-at-points` adds `indirect_at_point_lux` (and `total_at_point_lux`): the
//! inter-reflected light gathered at each point itself (`luxbake::probe::indirect_at`: a final
//! gather of `--gather-rays` rays, by default [`POINT_GATHER_RAYS`], from the located surface
//! point, each reading the bake's exitance maps where it meets a surface; cosine-weighted, or
//! drawn uniformly over the hemisphere at a point in a narrow gap, as the bakes' texels
//! there, `luxbake::probe::gathers_uniformly`). The maps' texels
//! then enter only through the light the point sees, averaged over its hemisphere: a point on
//! a strip a few texels wide (a chair's apron, the rim of a seat's underside) is not read from
//! texels half a texel or more away. With both flags `total_at_point_lux` is the sum of the
//! two; with one, that one plus the maps' other part.

use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::path::{Path, PathBuf};

use luxbake::GpuBackend;
use luxbake::bake::Room;
use luxbake::map::MapImage;
use luxbake::probe::{CalcPoint, SurfacePoint, direct_at, indirect_at, locate};
use luxbake::scene::{Scene, SettingsPatch};
use luxbake::sources::scenefile::from_file_patched;
use luxbake_backends::BackendKind;
use luxbake_output::picture::luminance;
use luxbake_output::read_exr;
use serde_json::Value;

/// Arguments of `luxbake measure` (and `cargo xtask measure`).
#[derive(clap::Args)]
pub struct Args {
    /// A folder written by `luxbake bake` (or `cargo xtask bake`).
    dir: PathBuf,
    /// CSV file of points, one `x,y,z` row each, metres.
    #[arg(long)]
    points: PathBuf,
    /// Largest distance from a point to a baked surface, metres.
    #[arg(long, default_value_t = 0.01)]
    tolerance: f64,
    /// Also compute the direct light at each point itself (columns `direct_at_point_lux`,
    /// `total_at_point_lux`; see the command's docs).
    #[arg(long)]
    direct_at_points: bool,
    /// With `--direct-at-points`: points of a luminous opening per calculation point (up to
    /// twice as many near it); default: 1024 or the bake's, whichever is more.
    #[arg(long, requires = "direct_at_points")]
    opening_samples: Option<u32>,
    /// Also gather the indirect light at each point itself from the bake's exitance maps
    /// (columns `indirect_at_point_lux`, `total_at_point_lux`; see the command's docs).
    #[arg(long)]
    indirect_at_points: bool,
    /// With `--indirect-at-points`: gather rays per calculation point (default 4096).
    #[arg(long, requires = "indirect_at_points")]
    gather_rays: Option<u32>,
}

/// Gather rays per calculation point of `--indirect-at-points` unless told
/// (`--gather-rays`): points are few, so their gather can be fine (the noise of a point's
/// gather of the maps falls as one over the root of the rays; at 4096 it is a small part of
/// the maps' own).
pub const POINT_GATHER_RAYS: u32 = 4096;

/// Opening samples per calculation point of `--direct-at-points` unless the bake's are more
/// ([`at_point_samples`]).
pub const POINT_OPENING_SAMPLES: u32 = 1024;

/// Opening samples of `--direct-at-points`: `asked` (`--opening-samples`, at least 1), else
/// [`POINT_OPENING_SAMPLES`] or the bake's, whichever is more.
pub fn at_point_samples(baked: u32, asked: Option<u32>) -> u32 {
    asked.map_or(POINT_OPENING_SAMPLES.max(baked), |n| n.max(1))
}

/// The rows of a comma-separated text: `(line number, trimmed line, trimmed fields)`, blank
/// lines and `#` comments skipped.
pub fn csv_rows(text: &str) -> impl Iterator<Item = (usize, &str, Vec<&str>)> {
    text.lines().enumerate().filter_map(|(i, line)| {
        let line = line.trim();
        (!line.is_empty() && !line.starts_with('#'))
            .then(|| (i + 1, line, line.split(',').map(str::trim).collect()))
    })
}

/// `path`'s text; the error names the file.
pub fn read_text(path: &Path) -> Result<String, String> {
    std::fs::read_to_string(path).map_err(|e| format!("cannot read {}: {e}", path.display()))
}

/// Parses the points file: `(line number, [x, y, z])` per row.
pub fn parse_points(text: &str) -> Result<Vec<(usize, [f64; 3])>, String> {
    let mut points = Vec::new();
    for (line_no, line, fields) in csv_rows(text) {
        let values: Result<Vec<f64>, _> = fields.iter().map(|f| f.parse::<f64>()).collect();
        match values {
            Ok(v) if v.len() == 3 && v.iter().all(|c| c.is_finite()) => {
                points.push((line_no, [v[0], v[1], v[2]]));
            }
            Ok(v) => {
                return Err(format!(
                    "line {line_no}: expected three finite numbers x,y,z, got {} value(s)",
                    v.len()
                ));
            }
            Err(_) if points.is_empty() && line_no == 1 => {} // header row
            Err(_) => {
                return Err(format!(
                    "line {line_no}: expected three numbers x,y,z, got `{line}`"
                ));
            }
        }
    }
    Ok(points)
}

/// The baked settings: the manifest's `settings` hold every key of a settings patch (the
/// scene file's keys).
fn baked_settings(manifest: &Value) -> Result<SettingsPatch, String> {
    let s = manifest["settings"]
        .as_object()
        .ok_or("manifest: settings missing")?;
    for key in ["rays", "bounces", "texels_per_metre", "seed"] {
        if !s.contains_key(key) {
            return Err(format!("manifest: settings.{key} missing"));
        }
    }
    let mut entries: Vec<(String, Value)> = s.iter().map(|(k, v)| (k.clone(), v.clone())).collect();
    // Manifests before the converged method have no `method`: they were the paper's.
    if !s.contains_key("method") {
        entries.push(("method".into(), Value::from("paper")));
    }
    SettingsPatch::from_entries(&entries)
        .map_err(|e| format!("manifest: settings.{}: {}", e.key, e.message))
}

/// The baked scene, built with the baked settings (a scene file's objects too, so their
/// padding is the bake's when flags overrode the file's density or blur).
fn rebuild_scene(manifest: &Value) -> Result<Scene, String> {
    let source = manifest["scene"]["source"]
        .as_str()
        .ok_or("manifest: scene.source missing")?;
    let settings = baked_settings(manifest)?;
    match source.strip_prefix("builtin:") {
        Some(name) => {
            let settings = settings
                .settings()
                .map_err(|e| format!("manifest: settings.{}: {}", e.name, e.reason))?;
            Scene::builtin_with_settings(name, settings).map_err(|e| e.to_string())
        }
        None => {
            let loader = luxbake_assets::SceneLoader::default();
            from_file_patched(Path::new(source), Some(&loader), &settings)
                .map_err(|e| format!("rebuilding the baked scene: {e}"))
        }
    }
}

/// The manifest of the bake in `dir` and its scene, rebuilt ([`rebuild_scene`]).
fn baked(dir: &Path) -> Result<(Value, Scene), String> {
    let manifest_path = dir.join("manifest.json");
    let text = read_text(&manifest_path)?;
    let manifest: Value =
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", manifest_path.display()))?;
    let scene = rebuild_scene(&manifest)?;
    Ok((manifest, scene))
}

/// One measured point: position and `[direct, indirect, total]` lux.
pub type Row = ([f64; 3], [f64; 3]);

/// Measures the points of `points_file` in the bake in `dir` (see the module docs).
pub fn measure(dir: &Path, points_file: &Path, tolerance: f64) -> Result<Vec<Row>, String> {
    let points_text = read_text(points_file)?;
    let points =
        parse_points(&points_text).map_err(|e| format!("{}: {e}", points_file.display()))?;
    measure_points(dir, &points, &points_file.display().to_string(), tolerance)
}

/// Locates every point on `scene`'s receivers (the rule of the module docs); the error names
/// the first point on no baked surface by `label` (its file) and line.
pub fn locate_points(
    scene: &Scene,
    points: &[(usize, [f64; 3])],
    label: &str,
    tolerance: f64,
) -> Result<Vec<SurfacePoint>, String> {
    points
        .iter()
        .map(|&(line, p)| {
            locate(scene, p, tolerance).ok_or_else(|| {
                format!(
                    "{label} line {line}: point ({}, {}, {}) lies on no baked surface (none within {tolerance} m)",
                    p[0], p[1], p[2],
                )
            })
        })
        .collect()
}

/// Measures `points` (`(line, [x, y, z])`, as [`parse_points`] returns them; `label` names
/// their source in errors) in the bake in `dir`: the look-up of `luxbake measure`.
pub fn measure_points(
    dir: &Path,
    points: &[(usize, [f64; 3])],
    label: &str,
    tolerance: f64,
) -> Result<Vec<Row>, String> {
    let (manifest, scene) = baked(dir)?;
    // Locate every point first, so that a bad row fails before anything is measured.
    let located = locate_points(&scene, points, label, tolerance)?;
    read_rows(dir, &manifest, points, &located)
}

/// [`measure_points`] and, per point, the direct lux computed at the point itself
/// (`--direct-at-points`, see the module docs) with `opening_samples` (`--opening-samples`,
/// [`at_point_samples`]): one reading of the bake, one location of the points.
pub fn measure_points_at(
    dir: &Path,
    points: &[(usize, [f64; 3])],
    label: &str,
    tolerance: f64,
    opening_samples: Option<u32>,
) -> Result<(Vec<Row>, Vec<f64>), String> {
    let (rows, at) =
        measure_points_at_with(dir, points, label, tolerance, Some(opening_samples), None)?;
    Ok((rows, at.direct.unwrap_or_default()))
}

/// The maps' `[direct, indirect, total]` lux at each located point of `points`, read from the
/// bake in `dir` that `manifest` describes.
fn read_rows(
    dir: &Path,
    manifest: &Value,
    points: &[(usize, [f64; 3])],
    located: &[SurfacePoint],
) -> Result<Vec<Row>, String> {
    let objects = manifest["objects"]
        .as_array()
        .ok_or("manifest: objects missing")?;
    let mut cache: HashMap<usize, (MapImage, MapImage)> = HashMap::new();
    let mut rows = Vec::with_capacity(located.len());
    for (&(_, p), sp) in points.iter().zip(located) {
        let (direct, total) = match cache.entry(sp.object) {
            Entry::Occupied(e) => e.into_mut(),
            Entry::Vacant(v) => {
                let entry = objects
                    .iter()
                    .find(|o| o["index"].as_u64() == Some(sp.object as u64))
                    .ok_or_else(|| format!("manifest: object {} missing", sp.object))?;
                let file = |key: &str| -> Result<PathBuf, String> {
                    entry["files"][key]
                        .as_str()
                        .map(|f| dir.join(f))
                        .ok_or_else(|| format!("manifest: object {} has no {key} map", sp.object))
                };
                let total = read_exr(&file("illuminance")?).map_err(|e| e.to_string())?;
                let direct = read_exr(&file("direct")?).map_err(|e| e.to_string())?;
                v.insert((direct, total))
            }
        };
        let d = f64::from(luminance(direct.sample(sp.uv)));
        let t = f64::from(luminance(total.sample(sp.uv)));
        rows.push((p, [d, (t - d).max(0.0), t]));
    }
    Ok(rows)
}

/// Lux as printed: the shortest decimal that reads back as the same f32 (see the module docs).
fn lux(v: f64) -> String {
    (v as f32).to_string()
}

/// The CSV of `rows`: the header, then one line per point (see the module docs).
pub fn csv(rows: &[Row]) -> String {
    let mut out = String::from("x,y,z,direct_lux,indirect_lux,total_lux\n");
    for (p, e) in rows {
        let [d, i, t] = e.map(lux);
        out += &format!("{},{},{},{d},{i},{t}\n", p[0], p[1], p[2]);
    }
    out
}

/// The direct illuminance, lux (Rec. 709 luminance), computed at each of the calculation
/// points `calc` of `scene` (prepared as `room`) on the CPU backend `backend`,
/// `opening_samples` points per luminous opening.
fn direct_at_located(
    backend: &mut luxbake_backends::AnyBackend,
    room: &Room,
    scene: &Scene,
    calc: &[CalcPoint],
    opening_samples: u32,
) -> Result<Vec<f64>, String> {
    let lux = direct_at(
        backend,
        room,
        &scene.lamps,
        &scene.settings,
        opening_samples,
        calc,
    )
    .map_err(|e| e.to_string())?;
    Ok(lux.iter().map(|&e| f64::from(luminance(e))).collect())
}

/// The indirect illuminance, lux (Rec. 709 luminance), gathered with `rays` rays at each of
/// the calculation points `calc` of `scene` (prepared as `room`) from the exitance maps of
/// the bake in `dir` that `manifest` describes (objects without an exitance map reflect
/// nothing).
fn indirect_at_located(
    dir: &Path,
    manifest: &Value,
    scene: &Scene,
    room: &Room,
    calc: &[CalcPoint],
    rays: u32,
) -> Result<Vec<f64>, String> {
    let objects = manifest["objects"]
        .as_array()
        .ok_or("manifest: objects missing")?;
    let mut maps: Vec<Option<MapImage>> = (0..scene.objects.len()).map(|_| None).collect();
    for entry in objects {
        let (Some(index), Some(file)) =
            (entry["index"].as_u64(), entry["files"]["exitance"].as_str())
        else {
            continue;
        };
        if let Some(slot) = maps.get_mut(index as usize) {
            *slot = Some(read_exr(&dir.join(file)).map_err(|e| e.to_string())?);
        }
    }
    let exitance = |object: usize, uv: [f32; 2]| {
        maps.get(object)
            .and_then(Option::as_ref)
            .map_or([0.0; 3], |m| m.sample(uv))
    };
    let lux = indirect_at(room, calc, rays, scene.settings.seed, &exitance);
    Ok(lux.iter().map(|&e| f64::from(luminance(e))).collect())
}

/// The located points as calculation points: their surface point and normal.
pub fn calc_points(located: &[SurfacePoint]) -> Vec<CalcPoint> {
    located
        .iter()
        .map(|sp| CalcPoint {
            position: sp.position,
            normal: sp.normal,
        })
        .collect()
}

/// What `--direct-at-points` and `--indirect-at-points` computed at each point, lux.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AtPoints {
    /// The direct light at each point (`--direct-at-points`).
    pub direct: Option<Vec<f64>>,
    /// The indirect light gathered at each point (`--indirect-at-points`).
    pub indirect: Option<Vec<f64>>,
}

/// [`measure_points`] and, per point, the light computed at the point itself: the direct
/// part with `opening_samples` when `direct` (as [`measure_points_at`]), the indirect part
/// gathered with `gather_rays` rays when given. One reading of the bake, one location of the
/// points.
pub fn measure_points_at_with(
    dir: &Path,
    points: &[(usize, [f64; 3])],
    label: &str,
    tolerance: f64,
    direct: Option<Option<u32>>,
    gather_rays: Option<u32>,
) -> Result<(Vec<Row>, AtPoints), String> {
    let (manifest, scene) = baked(dir)?;
    if direct.is_some() {
        same_lamps(&manifest, &scene)?;
    }
    let located = locate_points(&scene, points, label, tolerance)?;
    let rows = read_rows(dir, &manifest, points, &located)?;
    if direct.is_none() && gather_rays.is_none() {
        return Ok((rows, AtPoints::default()));
    }
    // One room for both parts: the scene's geometry prepared once.
    let mut backend = luxbake_backends::open(BackendKind::Cpu).map_err(|e| e.to_string())?;
    let room = Room::prepare(&scene, &scene.settings, backend.limits(), &mut |_| {})
        .map_err(|e| e.to_string())?;
    let calc = calc_points(&located);
    let direct = match direct {
        Some(asked) => {
            let samples = at_point_samples(scene.settings.opening_samples, asked);
            Some(direct_at_located(
                &mut backend,
                &room,
                &scene,
                &calc,
                samples,
            )?)
        }
        None => None,
    };
    let indirect = match gather_rays {
        Some(rays) => Some(indirect_at_located(
            dir,
            &manifest,
            &scene,
            &room,
            &calc,
            rays.max(1),
        )?),
        None => None,
    };
    Ok((rows, AtPoints { direct, indirect }))
}

/// Checks that the rebuilt scene's lamps are the baked ones (names, positions, multipliers
/// and colours as the manifest lists them).
fn same_lamps(manifest: &Value, scene: &Scene) -> Result<(), String> {
    let baked = manifest["lamps"]
        .as_array()
        .ok_or("manifest: lamps missing")?;
    let f = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
    let same = baked.len() == scene.lamps.len()
        && baked.iter().zip(&scene.lamps).all(|(b, l)| {
            b["name"].as_str() == Some(l.name.as_str())
                && (0..3).all(|c| f(&b["position"][c]) == l.position[c])
                && f(&b["multiplier"]) == f64::from(l.multiplier)
                && (0..3).all(|c| f(&b["color"][c]) == f64::from(l.color[c]))
        });
    if same {
        Ok(())
    } else {
        Err(
            "--direct-at-points: the bake's lamps are not its scene's (baked with --lamp files, \
             whose photometry the manifest does not keep); measure it without the flag"
                .to_string(),
        )
    }
}

/// The CSV of `rows` with the columns of `--direct-at-points`: `at_point[i]` the direct lux
/// computed at row `i`'s point.
pub fn csv_at_points(rows: &[Row], at_point: &[f64]) -> String {
    csv_with(
        rows,
        &AtPoints {
            direct: Some(at_point.to_vec()),
            indirect: None,
        },
    )
}

/// The CSV of `rows` with the columns of what was computed at the points: after the maps'
/// three, `direct_at_point_lux` and/or `indirect_at_point_lux`, then `total_at_point_lux`
/// (each part at the point where computed, else the maps').
pub fn csv_with(rows: &[Row], at: &AtPoints) -> String {
    let mut out = String::from("x,y,z,direct_lux,indirect_lux,total_lux");
    if at.direct.is_some() {
        out += ",direct_at_point_lux";
    }
    if at.indirect.is_some() {
        out += ",indirect_at_point_lux";
    }
    if at.direct.is_some() || at.indirect.is_some() {
        out += ",total_at_point_lux";
    }
    out += "\n";
    for (k, (p, e)) in rows.iter().enumerate() {
        let [dm, i, t] = e.map(lux);
        out += &format!("{},{},{},{dm},{i},{t}", p[0], p[1], p[2]);
        let d = at.direct.as_ref().and_then(|v| v.get(k).copied());
        let ind = at.indirect.as_ref().and_then(|v| v.get(k).copied());
        if let Some(d) = d {
            out += &format!(",{}", lux(d));
        }
        if let Some(ind) = ind {
            out += &format!(",{}", lux(ind));
        }
        if d.is_some() || ind.is_some() {
            out += &format!(",{}", lux(d.unwrap_or(e[0]) + ind.unwrap_or(e[1])));
        }
        out += "\n";
    }
    out
}

/// Runs the measurement and prints the CSV; the error is a message for stderr.
pub fn run(args: &Args) -> Result<(), String> {
    if args.direct_at_points || args.indirect_at_points {
        let text = read_text(&args.points)?;
        let points = parse_points(&text).map_err(|e| format!("{}: {e}", args.points.display()))?;
        let label = args.points.display().to_string();
        let (rows, at) = measure_points_at_with(
            &args.dir,
            &points,
            &label,
            args.tolerance,
            args.direct_at_points.then_some(args.opening_samples),
            args.indirect_at_points
                .then(|| args.gather_rays.unwrap_or(POINT_GATHER_RAYS)),
        )?;
        print!("{}", csv_with(&rows, &at));
    } else {
        print!(
            "{}",
            csv(&measure(&args.dir, &args.points, args.tolerance)?)
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use luxbake::scene::{Blur, Settings};

    #[test]
    fn points_file_rules() {
        let p = parse_points("x,y,z\n1,2,3\n\n# note\n 4 , 5.5 , -6\n").expect("parse");
        assert_eq!(p, vec![(2, [1.0, 2.0, 3.0]), (5, [4.0, 5.5, -6.0])]);
        assert!(parse_points("1,2\n").unwrap_err().contains("line 1"));
        assert!(
            parse_points("1,2,3\nx,y,z\n")
                .unwrap_err()
                .contains("line 2")
        );
        assert!(parse_points("1,2,nan\n").is_err());
        assert!(parse_points("").expect("empty").is_empty());
    }

    #[test]
    fn lux_keep_their_significant_digits_at_every_magnitude() {
        // The floor's closed form at 1000 × scale (E ≈ 2·10⁻⁵ lx), in metres, and extremes.
        let values = [2.345_678e-5f32, 1.5e-9, 0.0, 0.123_456_7, 12_345.67, 3.0e7];
        let rows: Vec<Row> = values
            .iter()
            .map(|&v| ([1.5, 0.0, -2.0], [f64::from(v); 3]))
            .collect();
        let text = csv(&rows);
        let mut lines = text.lines();
        assert_eq!(
            lines.next(),
            Some("x,y,z,direct_lux,indirect_lux,total_lux")
        );
        for (line, v) in lines.zip(values) {
            let fields: Vec<&str> = line.split(',').collect();
            assert_eq!(fields[..3], ["1.5", "0", "-2"]);
            for f in &fields[3..] {
                assert_eq!(f.parse::<f32>(), Ok(v), "{line}");
                assert!(!f.contains('e'), "{line}");
            }
        }
        assert_eq!(lux(2.345_678e-5), "0.00002345678");
    }

    /// A scene file baked with overrides is rebuilt with them: the same objects (padding).
    #[test]
    fn a_scene_file_is_rebuilt_with_the_baked_settings() {
        use luxbake::bake::bake;
        use luxbake_backend_cpu::CpuBackend;
        use luxbake_output::write_bake;
        let dir = std::env::temp_dir().join(format!("luxbake-rebuild-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("room.toml");
        let text = "[settings]\ntexels_per_metre = 48\n[[lamp]]\nies = \"isotropic:100\"\n\
                    position = [0, 2, 0]\n[[object]]\nprimitive = \"room\"\nsize = [2, 2.5, 2]\n";
        std::fs::write(&path, text).expect("write scene");
        let overrides = SettingsPatch {
            texels_per_metre: Some(8.0),
            rays: Some(1),
            bounces: Some(0),
            ..SettingsPatch::default()
        };
        let scene = from_file_patched(&path, None, &overrides).expect("scene");
        let out = bake(&mut CpuBackend::new(), &scene, &scene.settings, &mut |_| {}).expect("bake");
        let source = path.display().to_string();
        let manifest = write_bake(&dir.join("out"), &scene, &out, &source).expect("write");
        let rebuilt = rebuild_scene(&manifest).expect("rebuild");
        assert_eq!(rebuilt.settings, scene.settings);
        assert_eq!(rebuilt.objects, scene.objects);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn calculation_points_take_converged_opening_samples_unless_told() {
        assert_eq!(at_point_samples(48, None), POINT_OPENING_SAMPLES);
        assert_eq!(
            at_point_samples(4096, None),
            4096,
            "never fewer than the bake's"
        );
        assert_eq!(at_point_samples(48, Some(12)), 12);
        assert_eq!(at_point_samples(48, Some(0)), 1);
    }

    /// The closed diffuse sphere (albedo ρ, an isotropic lamp at its centre): the light
    /// inter-reflected onto every point is `ρ/(1 − ρ)` times the direct light. Gathered at the
    /// points from a coarse bake's exitance maps (16 rays, 8 texels/m) it meets that within
    /// 1.5 % at every point.
    #[test]
    fn the_light_at_points_in_a_closed_sphere_meets_the_closed_form() {
        use luxbake::bake::bake;
        use luxbake::sources::builtin::ANALYTIC_ALBEDO;
        use luxbake_backend_cpu::CpuBackend;
        use luxbake_output::write_bake;
        let settings = Settings {
            rays: 16,
            texels_per_metre: 8.0,
            ..Settings::preset(luxbake::scene::Quality::Default)
        };
        let scene = Scene::builtin_with_settings("sphere", settings).expect("sphere");
        let out = bake(&mut CpuBackend::new(), &scene, &scene.settings, &mut |_| {}).expect("bake");
        let dir =
            std::env::temp_dir().join(format!("luxbake-measure-sphere-{}", std::process::id()));
        write_bake(&dir, &scene, &out, "builtin:sphere").expect("write");
        let parsed = parse_points("0,-1,0\n0.6,0.8,0\n0,0.28,-0.96\n-0.8,0,0.6\n").expect("parse");
        let (rows, at) =
            measure_points_at_with(&dir, &parsed, "points", 0.01, Some(None), Some(4096))
                .expect("at points");
        let (direct, indirect) = (
            at.direct.clone().expect("direct"),
            at.indirect.clone().expect("indirect"),
        );
        let rho = f64::from(ANALYTIC_ALBEDO);
        for (k, (p, _)) in rows.iter().enumerate() {
            let want = direct[k] * rho / (1.0 - rho);
            let rel = indirect[k] / want - 1.0;
            assert!(
                rel.abs() < 0.015,
                "{p:?}: gathered {} vs closed form {want}",
                indirect[k]
            );
        }
        let text = csv_with(&rows, &at);
        assert!(text.starts_with(
            "x,y,z,direct_lux,indirect_lux,total_lux,direct_at_point_lux,indirect_at_point_lux,total_at_point_lux\n"
        ));
        assert_eq!(text.lines().count(), 5);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn measures_a_bake_against_the_closed_form() {
        use luxbake::bake::bake;
        use luxbake_backend_cpu::CpuBackend;
        use luxbake_output::write_bake;
        let settings = Settings {
            rays: 4,
            bounces: 0,
            blur: Blur::None,
            texels_per_metre: 8.0,
            ..Settings::default()
        };
        let scene = Scene::builtin_with_settings("floor", settings).expect("floor");
        let out = bake(&mut CpuBackend::new(), &scene, &scene.settings, &mut |_| {}).expect("bake");
        let dir = std::env::temp_dir().join(format!("luxbake-measure-{}", std::process::id()));
        write_bake(&dir, &scene, &out, "builtin:floor").expect("write");
        let points = dir.join("points.csv");
        std::fs::write(&points, "x,y,z\n3,0,4\n-5,0,2.5\n").expect("points");
        let rows = measure(&dir, &points, 0.01).expect("measure");
        assert_eq!(rows.len(), 2);
        for (p, [d, i, t]) in rows {
            // Floor scene: 1000 cd isotropic lamp 2 m above the origin.
            let r2 = p[0] * p[0] + p[2] * p[2];
            let want = 1000.0 * 2.0 / (4.0 + r2).powf(1.5);
            assert!((t - want).abs() / want < 0.005, "{p:?}: {t} vs {want}");
            assert_eq!((d, i), (t, 0.0));
        }
        // At the points themselves (between texels): the closed form to f32's precision.
        let parsed = parse_points("3,0,4\n-5,0,2.5\n").expect("parse");
        let (rows, at) = measure_points_at(&dir, &parsed, "points", 0.01, None).expect("at points");
        assert_eq!(rows, measure(&dir, &points, 0.01).expect("measure"));
        for ((_, p), e) in parsed.iter().zip(&at) {
            let want = 1000.0 * 2.0 / (4.0 + p[0] * p[0] + p[2] * p[2]).powf(1.5);
            assert!((e - want).abs() / want < 1e-5, "{p:?}: {e} vs {want}");
        }
        let text = csv_at_points(&rows, &at);
        assert!(text.starts_with(
            "x,y,z,direct_lux,indirect_lux,total_lux,direct_at_point_lux,total_at_point_lux\n"
        ));
        assert_eq!(text.lines().count(), 3);
        // A bake whose lamps are not its scene's is refused.
        let manifest_path = dir.join("manifest.json");
        let original = std::fs::read_to_string(&manifest_path).expect("manifest");
        let mut m: Value = serde_json::from_str(&original).expect("json");
        m["lamps"][0]["position"][1] = Value::from(2.5);
        std::fs::write(&manifest_path, m.to_string()).expect("write");
        let err = measure_points_at(&dir, &parsed, "points", 0.01, None).unwrap_err();
        assert!(err.contains("--lamp"), "{err}");
        // Gathered at the points on the open floor: nothing above them, no indirect light,
        // and the lamps need not be the scene's for it.
        let (rows, at) =
            measure_points_at_with(&dir, &parsed, "points", 0.01, None, Some(64)).expect("gather");
        assert_eq!(at.indirect, Some(vec![0.0, 0.0]));
        let text = csv_with(&rows, &at);
        assert!(text.starts_with(
            "x,y,z,direct_lux,indirect_lux,total_lux,indirect_at_point_lux,total_at_point_lux\n"
        ));
        std::fs::write(&manifest_path, original).expect("restore");
        std::fs::write(&points, "0,1,0\n").expect("points");
        let err = measure(&dir, &points, 0.01).unwrap_err();
        assert!(
            err.contains("line 1") && err.contains("no baked surface"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
