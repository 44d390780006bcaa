//! `luxbake catalogue run`: bake a row into a temporary folder, list its files in `row.json`,
//! publish it by an atomic rename; verify published rows; record permanent errors.

use std::path::{Component, Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use luxbake::GpuBackend;
use luxbake::bake::{BakeError, Room, bake_room};
use luxbake::scene::{Lamp, Scene};
use luxbake::sources::scenefile::{from_file_patched, read_photometry};
use luxbake_assets::export::{WebReport, export_web};
use luxbake_backend_cpu::GATHER_HITS_BUDGET;
use luxbake_backends::{AnyBackend, BackendKind};
use luxbake_output::write_bake;
use serde_json::{Value, json};

use super::failure::{Failure, PERMANENT, RETRYABLE};
use super::plan::{Input, MISSING, ROW_VERSION, Row, row_patch, scene_inputs, sha256_hex};

/// The prefix of a row's temporary folder (`.tmp-<key>-<pid>-<nanos>`) and of an error
/// record's temporary file: a dot name, which `status` and a front end ignore.
pub(crate) const TEMP_PREFIX: &str = ".tmp-";
/// The file a published row lists its files and their hashes in, written last.
pub(crate) const ROW_FILE: &str = "row.json";
/// The file the bake's timings go to: not listed in `row.json`, so not verified nor compared.
pub(crate) const TIMINGS_FILE: &str = "timings.json";
/// The folder of error records, `OUT/errors/<key>.json`.
pub(crate) const ERRORS_DIR: &str = "errors";
/// A row's web GLB (`luxbake_assets::export::export_web`).
pub(crate) const WEB_GLB: &str = "web.glb";

/// What a run of a row did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowOutcome {
    /// The row was baked and published.
    Baked,
    /// The row was there and verified: nothing was baked.
    Skipped,
}

impl RowOutcome {
    /// The line `catalogue run` prints for `row` (no timing: two runs print the same).
    pub fn line(self, row: &Row) -> String {
        let what = match self {
            RowOutcome::Baked => "baked",
            RowOutcome::Skipped => "skipped (done)",
        };
        format!("row {} {what} {} ({})", row.index, row.key, describe(row))
    }
}

/// `room × lamp × placement × quality`.
pub(crate) fn describe(row: &Row) -> String {
    format!(
        "{} × {} × {} × {}",
        row.room, row.lamp_name, row.placement, row.quality
    )
}

/// The error record of a row: `OUT/errors/<key>.json`.
pub(crate) fn error_record(out: &Path, key: &str) -> PathBuf {
    out.join(ERRORS_DIR).join(format!("{key}.json"))
}

/// Bakes `row` into `out/<key>/` unless it is there and verifies. A permanent input error is
/// recorded in `out/errors/<key>.json` (once: a row with a record fails again without baking).
pub fn run_row(row: &Row, out: &Path) -> Result<RowOutcome, Failure> {
    run_row_keeping(row, out, &mut None, false)
}

/// The gather hits a worker of [`run_all`] keeps at most (`--jobs` workers each keep theirs):
/// a quarter of the CLI's [`GATHER_HITS_BUDGET`], which holds `chairs_05`'s 75 MB at the
/// default preset; the rows of a larger room trace what does not fit, as without it.
const WORKER_HITS_BUDGET: usize = GATHER_HITS_BUDGET / 4;

/// The room a worker of [`run_all`] prepared for its last row and the backend that baked it.
/// The worker's next row of the same room — the same objects at the same texel density, on
/// the same backend — bakes on them without preparing the room again, and on the CPU backend
/// replays the gather's hits and reuses the denoiser's chart tests (`luxbake::cpu`): the
/// same files bit for bit as a row baked alone (`timings.json` aside).
struct Kept {
    kind: BackendKind,
    room: Room,
    backend: AnyBackend,
}

/// [`run_row`], on the room and backend in `kept` when they fit the row (else on new ones,
/// left in `kept` when `keep` says more rows may follow).
fn run_row_keeping(
    row: &Row,
    out: &Path,
    kept: &mut Option<Kept>,
    keep: bool,
) -> Result<RowOutcome, Failure> {
    let retry = |what: &str, e: &dyn std::fmt::Display| {
        Failure::Retryable(format!("row {}: {what}: {e}", row.index))
    };
    std::fs::create_dir_all(out).map_err(|e| retry(&out.display().to_string(), &e))?;
    let published = out.join(&row.key);
    if verify(&published, &row.key) {
        return Ok(RowOutcome::Skipped);
    }
    let record = error_record(out, &row.key);
    if let Ok(text) = std::fs::read_to_string(&record) {
        let error = serde_json::from_str::<Value>(&text)
            .ok()
            .and_then(|v| v["error"].as_str().map(str::to_owned))
            .unwrap_or(text);
        return Err(Failure::Permanent(format!(
            "row {} ({}) failed before: {error} (see {})",
            row.index,
            describe(row),
            record.display()
        )));
    }
    remove_temporaries(out, &row.key).map_err(|e| retry("removing stale temporary folders", &e))?;
    let (scene, kind) = match load(row) {
        Ok(loaded) => loaded,
        Err(message) => return Err(record_error(row, out, &message)),
    };
    // The room and backend of the row before when they fit this row, else new ones.
    let start = std::time::Instant::now();
    let reused = kept.take().filter(|k| {
        k.kind == kind
            && k.room.scene.objects == scene.objects
            && k.room.check(&scene.settings, k.backend.limits()).is_ok()
    });
    let fresh = reused.is_none();
    let k = match reused {
        Some(k) => kept.insert(k),
        None => {
            let mut backend = luxbake_backends::open(kind).map_err(|e| retry("backend", &e))?;
            if let (true, AnyBackend::Cpu(cpu)) = (keep, &mut backend) {
                cpu.keep_gather_hits(WORKER_HITS_BUDGET);
            }
            // What the host work refuses (a setting out of range, maps over the backend's
            // limits, a BVH that cannot be built) fails the same way on every try: the row's
            // inputs are at fault, as for a file that does not load.
            let room = match Room::prepare(&scene, &scene.settings, backend.limits(), &mut |_| {}) {
                Ok(room) => room,
                Err(e) => return Err(record_error(row, out, &format!("bake: {e}"))),
            };
            kept.insert(Kept {
                kind,
                room,
                backend,
            })
        }
    };
    let baked = bake_room(
        &mut k.backend,
        &k.room,
        &scene.lamps,
        &scene.settings,
        &mut |_| {},
    );
    let mut output = match baked {
        Ok(output) => output,
        Err(e) => {
            *kept = None;
            return Err(match e {
                BakeError::Prepare(e) => record_error(row, out, &format!("bake: {e}")),
                e => retry("bake", &e),
            });
        }
    };
    output.count_preparation(if fresh { &k.room.timings } else { &[] }, start);
    if !keep {
        *kept = None;
    }
    let temp = out.join(format!(
        "{TEMP_PREFIX}{}-{}-{}",
        row.key,
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos())
    ));
    let written = write_bake(&temp, &scene, &output, &row.scene).map_err(|e| retry("write", &e))?;
    let web = export_web(&scene, &output, &temp.join(WEB_GLB)).map_err(|e| retry("write", &e))?;
    seal(&temp, &row.key, written, &web).map_err(|e| retry("write", &e))?;
    publish(&temp, &published, &row.key).map_err(|e| retry("publish", &e))?;
    Ok(RowOutcome::Baked)
}

/// Runs every row, `jobs` at a time (threads), printing a line per row as it ends; the exit
/// code is the worst outcome's (see the module docs).
pub fn run_all(rows: &[Row], out: &Path, jobs: usize) -> Result<u8, Failure> {
    if jobs == 0 {
        return Err(Failure::Usage("--jobs: give 1 or more".into()));
    }
    let next = AtomicUsize::new(0);
    let worst = Mutex::new(0u8);
    std::thread::scope(|s| {
        for _ in 0..jobs.min(rows.len()) {
            s.spawn(|| {
                let mut kept = None;
                while let Some(row) = rows.get(next.fetch_add(1, Ordering::Relaxed)) {
                    let code = match run_row_keeping(row, out, &mut kept, true) {
                        Ok(outcome) => {
                            println!("{}", outcome.line(row));
                            0
                        }
                        Err(f) => {
                            eprintln!("error: {}", f.message());
                            f.code()
                        }
                    };
                    let mut w = worst.lock().unwrap_or_else(|p| p.into_inner());
                    *w = match (*w, code) {
                        (RETRYABLE, _) | (_, RETRYABLE) => RETRYABLE,
                        (a, b) => a.max(b),
                    };
                }
            });
        }
    });
    Ok(worst.into_inner().unwrap_or_else(|p| p.into_inner()))
}

/// The row's scene with its settings, placement and lamp file, and its backend; the error (a
/// permanent one: the same inputs fail the same way) in words.
fn load(row: &Row) -> Result<(Scene, BackendKind), String> {
    check_inputs(row)?;
    let kind: BackendKind = row.backend.parse()?;
    let patch = row_patch(&row.settings, &row.quality)?;
    let mut scene = match row.scene.strip_prefix("builtin:") {
        Some(name) => {
            let settings = patch
                .settings()
                .map_err(|e| format!("settings.{}: {}", e.name, e.reason))?;
            Scene::builtin_with_settings(name, settings).map_err(|e| e.to_string())?
        }
        None => {
            let loader = luxbake_assets::SceneLoader::default();
            from_file_patched(Path::new(&row.scene), Some(&loader), &patch)
                .map_err(|e| e.to_string())?
        }
    };
    let photometry = read_photometry(Path::new(&row.lamp)).map_err(|e| format!("{e}"))?;
    if let Some(positions) = &row.positions {
        let template = scene
            .lamps
            .first()
            .cloned()
            .ok_or_else(|| format!("{}: the scene has no lamp to place", row.scene))?;
        scene.lamps = positions
            .iter()
            .enumerate()
            .map(|(i, p)| Lamp {
                name: if positions.len() == 1 {
                    template.name.clone()
                } else {
                    format!("{}_{}", template.name, i + 1)
                },
                position: *p,
                ..template.clone()
            })
            .collect();
    }
    if scene.lamps.is_empty() {
        return Err(format!(
            "{}: the scene has no lamp to take the lamp file",
            row.scene
        ));
    }
    for lamp in &mut scene.lamps {
        lamp.photometry = photometry.clone();
    }
    Ok((scene, kind))
}

/// The row's input files are still the planned bytes: a missing or changed one is a permanent
/// error (plan again).
fn check_inputs(row: &Row) -> Result<(), String> {
    let mut now = match row.scene.strip_prefix("builtin:") {
        Some(_) => Vec::new(),
        None => scene_inputs(Path::new(&row.scene))?,
    };
    let lamp = Path::new(&row.lamp);
    now.push(Input {
        role: "lamp".into(),
        path: row.lamp.clone(),
        sha256: std::fs::read(lamp).map_or_else(|_| MISSING.into(), |b| sha256_hex(&b)),
    });
    for input in row.inputs.iter().chain(&now) {
        if input.sha256 == MISSING {
            return Err(format!(
                "{} ({}): the file is missing",
                input.path, input.role
            ));
        }
    }
    if now != row.inputs {
        let changed = now
            .iter()
            .zip(&row.inputs)
            .find(|(a, b)| a != b)
            .map_or_else(|| row.scene.clone(), |(a, _)| a.path.clone());
        return Err(format!(
            "{changed} changed since the manifest was planned: plan the catalogue again"
        ));
    }
    Ok(())
}

/// Writes the error record of a permanent failure (through a temporary file and a rename, so
/// a record is whole or absent) and returns the failure.
fn record_error(row: &Row, out: &Path, message: &str) -> Failure {
    let record = error_record(out, &row.key);
    let text = json!({
        "format": "luxbake-catalogue-error",
        "version": 1,
        "key": row.key,
        "index": row.index,
        "room": row.room,
        "lamp": row.lamp_name,
        "placement": row.placement,
        "quality": row.quality,
        "exit_code": PERMANENT,
        "error": message,
    });
    let dir = out.join(ERRORS_DIR);
    let temp = dir.join(format!(
        "{TEMP_PREFIX}{}-{}.json",
        row.key,
        std::process::id()
    ));
    let written = std::fs::create_dir_all(&dir)
        .and_then(|()| std::fs::write(&temp, format!("{text:#}\n")))
        .and_then(|()| std::fs::rename(&temp, &record));
    match written {
        Ok(()) => Failure::Permanent(format!(
            "row {} ({}): {message} (recorded in {})",
            row.index,
            describe(row),
            record.display()
        )),
        Err(e) => Failure::Retryable(format!(
            "row {}: {message}; writing its error record {}: {e}",
            row.index,
            record.display()
        )),
    }
}

/// Removes the temporary folders (and error-record files) earlier runs of the row `key` left.
fn remove_temporaries(out: &Path, key: &str) -> std::io::Result<()> {
    let prefix = format!("{TEMP_PREFIX}{key}-");
    for dir in [out.to_path_buf(), out.join(ERRORS_DIR)] {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries.flatten() {
            if entry.file_name().to_string_lossy().starts_with(&prefix) {
                let path = entry.path();
                if path.is_dir() {
                    std::fs::remove_dir_all(&path)?;
                } else {
                    std::fs::remove_file(&path)?;
                }
            }
        }
    }
    Ok(())
}

/// The files under `dir`, relative, `/`-separated, sorted.
fn files_under(dir: &Path) -> std::io::Result<Vec<String>> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d)? {
            let path = entry?.path();
            if path.is_dir() {
                stack.push(path);
            } else if let Ok(rel) = path.strip_prefix(dir) {
                let parts: Vec<String> = rel
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect();
                out.push(parts.join("/"));
            }
        }
    }
    out.sort();
    Ok(out)
}

/// Finishes a baked folder: the timings move from `manifest.json` to `timings.json`, every
/// other file is listed with its size and SHA-256 in `row.json` (written last, with the web
/// GLB's name and lux range), and all of it is synced to disk.
fn seal(dir: &Path, key: &str, mut manifest: Value, web: &WebReport) -> std::io::Result<()> {
    let timings = manifest
        .as_object_mut()
        .and_then(|m| m.remove("timings"))
        .unwrap_or(Value::Null);
    let pretty = |v: &Value| serde_json::to_string_pretty(v).map_err(std::io::Error::other);
    std::fs::write(dir.join("manifest.json"), pretty(&manifest)?)?;
    std::fs::write(dir.join(TIMINGS_FILE), pretty(&timings)?)?;
    let mut files = Vec::new();
    for rel in files_under(dir)? {
        if rel == TIMINGS_FILE || rel == ROW_FILE {
            continue;
        }
        let bytes = std::fs::read(dir.join(&rel))?;
        files.push(json!({"path": rel, "bytes": bytes.len(), "sha256": sha256_hex(&bytes)}));
    }
    let row = json!({
        "format": "luxbake-catalogue-row",
        "version": ROW_VERSION,
        "key": key,
        "files": files,
        "web": {"glb": WEB_GLB, "lux": {"min": web.lux[0], "max": web.lux[1]}},
    });
    std::fs::write(dir.join(ROW_FILE), pretty(&row)?)?;
    for rel in files_under(dir)? {
        std::fs::File::open(dir.join(rel))?.sync_all()?;
    }
    sync_dir(dir)
}

/// Syncs a folder's entries (a no-op where folders cannot be opened as files).
fn sync_dir(dir: &Path) -> std::io::Result<()> {
    match std::fs::File::open(dir) {
        Ok(f) => f.sync_all().or(Ok(())),
        Err(_) => Ok(()),
    }
}

/// Renames the sealed `temp` to `published`. When `published` exists (another run published
/// the row first, or a damaged copy is there): a copy that verifies wins and `temp` goes; a
/// damaged one is moved aside and removed, then `temp` takes its place.
fn publish(temp: &Path, published: &Path, key: &str) -> std::io::Result<()> {
    if std::fs::rename(temp, published).is_ok() {
        return published.parent().map_or(Ok(()), sync_dir);
    }
    if verify(published, key) {
        return std::fs::remove_dir_all(temp);
    }
    if published.exists() {
        let aside = temp.with_file_name(format!(
            "{}-damaged",
            temp.file_name().unwrap_or_default().to_string_lossy()
        ));
        std::fs::rename(published, &aside)?;
        std::fs::remove_dir_all(&aside)?;
    }
    std::fs::rename(temp, published)?;
    published.parent().map_or(Ok(()), sync_dir)
}

/// Whether `dir` is a published row `key`: its `row.json` names the key, and every file it
/// lists is there with its size and SHA-256.
pub(crate) fn verify(dir: &Path, key: &str) -> bool {
    let Ok(text) = std::fs::read_to_string(dir.join(ROW_FILE)) else {
        return false;
    };
    let Ok(row) = serde_json::from_str::<Value>(&text) else {
        return false;
    };
    let (Some(files), Some(true)) = (
        row["files"].as_array(),
        row["key"].as_str().map(|k| k == key),
    ) else {
        return false;
    };
    !files.is_empty()
        && files.iter().all(|f| {
            let (Some(rel), Some(size), Some(hash)) = (
                f["path"].as_str(),
                f["bytes"].as_u64(),
                f["sha256"].as_str(),
            ) else {
                return false;
            };
            let path = Path::new(rel);
            path.components().all(|c| matches!(c, Component::Normal(_)))
                && std::fs::read(dir.join(path))
                    .is_ok_and(|b| b.len() as u64 == size && sha256_hex(&b) == hash)
        })
}
