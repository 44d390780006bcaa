//! The catalogue end to end, through the built `luxbake` binary: a catalogue of real lamp files
//! planned and run with `--all --jobs 2`, and the fault test (processes killed at random while
//! they bake, retried as a batch engine retries them).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use luxbake_testkit::{SplitMix64, shared_data, temp_dir};

/// The seed of the fault test's kill times.
const FAULT_SEED: u64 = 0x0001_abbe_a728;
/// Attempts of a row the fault test may kill; later attempts run to the end.
const KILLED_ATTEMPTS: u32 = 3;

fn luxbake() -> Command {
    Command::new(env!("CARGO_BIN_EXE_luxbake"))
}

fn output(args: &[&str]) -> Output {
    luxbake().args(args).output().expect("run luxbake")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// The real lamp files `rw_1` … `rw_n`, or `None` (skipped, failing under CI) without the
/// shared data.
fn real_lamps(test: &str, n: usize) -> Option<Vec<PathBuf>> {
    (1..=n)
        .map(|i| shared_data(test, &format!("photometry/real-world/rw_{i}.IES")))
        .collect()
}

/// Writes a catalogue in `dir`: the built-in floor, the built-in chair with its lamp moved to a
/// corner, and a scene file holding a room and the shared `SheenChair` glTF model; the given
/// lamp files; draft quality at 8 texels per metre.
fn write_catalogue(dir: &Path, chair: &Path, lamps: &[PathBuf]) -> PathBuf {
    std::fs::create_dir_all(dir).expect("dir");
    let room = format!(
        "[[lamp]]\nies = \"isotropic:100\"\nposition = [0, 2.4, 0]\n\
         [[object]]\nprimitive = \"room\"\nsize = [4, 2.6, 3]\n\
         [[object]]\nmesh = {:?}\nposition = [0.5, 0, 0]\n",
        chair.display().to_string()
    );
    std::fs::write(dir.join("showroom.toml"), room).expect("scene");
    let lamps: Vec<String> = lamps
        .iter()
        .map(|p| format!("{:?}", p.display().to_string()))
        .collect();
    let catalogue = format!(
        "qualities = [\"draft\"]\nlamps = [{}]\n[settings]\ntexels_per_metre = 8\n\
         [[room]]\nbuiltin = \"floor\"\n\
         [[room]]\nbuiltin = \"chairs_01\"\n\
         [[room.placement]]\nname = \"corner\"\npositions = [[1.2, 2.4, 1.0]]\n\
         [[room]]\nname = \"showroom\"\nscene = \"showroom.toml\"\n",
        lamps.join(", ")
    );
    let path = dir.join("catalogue.toml");
    std::fs::write(&path, catalogue).expect("catalogue");
    path
}

/// Plans `catalogue` into `manifest`; the number of rows.
fn plan(catalogue: &Path, manifest: &Path) -> usize {
    let o = output(&[
        "catalogue",
        "plan",
        &catalogue.display().to_string(),
        "--output",
        &manifest.display().to_string(),
    ]);
    assert!(o.status.success(), "plan: {}", text(&o.stderr));
    std::fs::read_to_string(manifest)
        .expect("manifest")
        .lines()
        .count()
}

fn status_json(manifest: &Path, out: &Path) -> serde_json::Value {
    let o = output(&[
        "catalogue",
        "status",
        &manifest.display().to_string(),
        "--out",
        &out.display().to_string(),
        "--json",
    ]);
    assert!(o.status.success(), "status: {}", text(&o.stderr));
    serde_json::from_slice(&o.stdout).expect("status JSON")
}

/// A catalogue of 3 rooms × 8 real lamp files plans into 24 rows and runs with
/// `--all --jobs 2`; a second run bakes nothing.
#[test]
fn a_catalogue_of_three_rooms_and_eight_real_lamps_runs_on_two_jobs() {
    let test = "a_catalogue_of_three_rooms_and_eight_real_lamps_runs_on_two_jobs";
    let (Some(lamps), Some(chair)) = (
        real_lamps(test, 8),
        shared_data(test, "models/SheenChair/SheenChair.glb"),
    ) else {
        return;
    };
    let dir = temp_dir("cli-catalogue", "all");
    let catalogue = write_catalogue(&dir, &chair, &lamps);
    let manifest = dir.join("manifest.jsonl");
    assert_eq!(plan(&catalogue, &manifest), 24);
    let out = dir.join("out");
    let (m, o) = (manifest.display().to_string(), out.display().to_string());
    let run = [
        "catalogue",
        "run",
        m.as_str(),
        "--all",
        "--jobs",
        "2",
        "--out",
        o.as_str(),
    ];
    let t = Instant::now();
    let first = output(&run);
    let seconds = t.elapsed().as_secs_f64();
    assert!(first.status.success(), "run: {}", text(&first.stderr));
    assert_eq!(text(&first.stdout).matches(" baked ").count(), 24);
    let s = status_json(&manifest, &out);
    assert_eq!(s["done"].as_array().map(Vec::len), Some(24), "{s}");
    eprintln!("{test}: 24 rows baked with --jobs 2 in {seconds:.1} s");
    let index: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("index.json")).expect("index.json"))
            .expect("index JSON");
    assert_eq!(index["listed"].as_u64(), Some(24), "{index}");
    let second = output(&run);
    assert!(second.status.success(), "rerun: {}", text(&second.stderr));
    let lines = text(&second.stdout);
    assert_eq!(
        (
            lines.matches(" baked ").count(),
            lines.matches(" skipped (done) ").count()
        ),
        (0, 24),
        "{lines}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Every file of a published row but `timings.json`, by path.
fn row_files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut files = BTreeMap::new();
    for entry in std::fs::read_dir(dir).expect("row folder").flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if name != "timings.json" {
            files.insert(name, std::fs::read(entry.path()).expect("file"));
        }
    }
    files
}

/// The entries of `out` a reader sees as results: every name not starting with `.`.
fn visible(out: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(out)
        .map(|d| {
            d.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| !n.starts_with('.'))
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
}

/// Entries of `out` and `out/errors` whose names start with `.`.
fn hidden(out: &Path) -> Vec<String> {
    [out.to_path_buf(), out.join("errors")]
        .iter()
        .flat_map(|d| std::fs::read_dir(d).into_iter().flatten().flatten())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect()
}

/// The fault test. Every row runs as its own process (`catalogue run --index I`, as a batch
/// engine runs an array task); each of its first [`KILLED_ATTEMPTS`] attempts is killed with
/// SIGKILL at a random time (seeded by [`FAULT_SEED`]) between its start and 1.5 × the row's
/// time in a clean serial run, and it is retried until it exits 0 — or 3, the permanent error,
/// which is never retried. After every kill no visible entry of OUT is anything but a complete,
/// verified row or the error records; afterwards every row is byte-identical to the serial run
/// (`timings.json` aside), no temporary folder is left (also none planted as a killed writer
/// would leave it), the rows of the malformed lamp file
/// failed once each with their record, and a second full run bakes nothing (its lines say
/// `skipped`, never `baked`).
#[test]
fn rows_killed_at_random_and_retried_end_as_a_clean_serial_run() {
    let test = "rows_killed_at_random_and_retried_end_as_a_clean_serial_run";
    let (Some(lamps), Some(chair)) = (
        real_lamps(test, 2),
        shared_data(test, "models/SheenChair/SheenChair.glb"),
    ) else {
        return;
    };
    let dir = temp_dir("cli-catalogue", "fault");
    std::fs::create_dir_all(&dir).expect("dir");
    let broken = dir.join("broken.ies");
    // A real file cut short: the header and tilt line, then too few numbers.
    let real = std::fs::read_to_string(&lamps[0]).expect("lamp");
    let cut: String = real
        .lines()
        .take_while(|l| !l.starts_with("TILT"))
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(
        &broken,
        format!("{cut}\nTILT=NONE\n1 1000 1 3 1 1 2 0.1 0.1 0\n1 1 30\n0 45\n"),
    )
    .expect("broken");
    let mut lamp_files = lamps.clone();
    lamp_files.push(broken.clone());
    let catalogue = write_catalogue(&dir, &chair, &lamp_files);
    let manifest = dir.join("manifest.jsonl");
    let rows = plan(&catalogue, &manifest);
    assert_eq!(rows, 9);
    let broken_rows: Vec<usize> = (0..rows).filter(|i| i % 3 == 2).collect();
    let m = manifest.display().to_string();
    let run_index = |out: &Path, i: usize| {
        luxbake()
            .args(["catalogue", "run", &m, "--index", &i.to_string(), "--out"])
            .arg(out)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn luxbake")
    };

    // The clean serial run, and each row's time.
    let serial = dir.join("serial");
    let mut row_seconds = Vec::new();
    let t = Instant::now();
    for i in 0..rows {
        let t = Instant::now();
        let o = run_index(&serial, i)
            .wait_with_output()
            .expect("serial row");
        row_seconds.push(t.elapsed().as_secs_f64());
        let expected = if broken_rows.contains(&i) { 3 } else { 0 };
        assert_eq!(
            o.status.code(),
            Some(expected),
            "row {i}: {}",
            text(&o.stderr)
        );
    }
    let serial_seconds = t.elapsed().as_secs_f64();

    // Every row as its own process, killed at random, retried.
    let faulty = dir.join("faulty");
    let mut rng = SplitMix64::new(FAULT_SEED);
    let (mut kills, mut attempts, mut left_temporary) = (0, 0, 0);
    let mut permanent = vec![0; rows];
    let keys: Vec<String> = std::fs::read_to_string(&manifest)
        .expect("manifest")
        .lines()
        .map(|l| {
            serde_json::from_str::<serde_json::Value>(l).expect("row")["key"]
                .as_str()
                .expect("key")
                .to_owned()
        })
        .collect();
    // What a run killed while writing leaves (a killed kill may land anywhere, so leave it
    // for sure too): a temporary row folder and a temporary error record, which `status`
    // lists and the rows' next runs remove.
    let stale = faulty.join(format!(".tmp-{}-999999-0", keys[0]));
    std::fs::create_dir_all(&stale).expect("stale folder");
    std::fs::write(stale.join("floor_illuminance.exr"), b"partial").expect("stale file");
    std::fs::create_dir_all(faulty.join("errors")).expect("errors");
    std::fs::write(
        faulty
            .join("errors")
            .join(format!(".tmp-{}-999999.json", keys[2])),
        b"{",
    )
    .expect("stale record");
    let s = status_json(&manifest, &faulty);
    assert_eq!(
        (
            s["temporary"].as_array().map(Vec::len),
            s["missing"].as_array().map(Vec::len)
        ),
        (Some(2), Some(rows)),
        "{s}"
    );
    let t = Instant::now();
    for (i, seconds) in row_seconds.iter().enumerate() {
        for attempt in 0.. {
            attempts += 1;
            let mut child = run_index(&faulty, i);
            let status = if attempt < KILLED_ATTEMPTS {
                let deadline = Instant::now() + Duration::from_secs_f64(rng.f64() * 1.5 * seconds);
                loop {
                    if let Some(status) = child.try_wait().expect("wait") {
                        break Some(status);
                    }
                    if Instant::now() >= deadline {
                        child.kill().expect("SIGKILL");
                        child.wait().expect("reap");
                        kills += 1;
                        left_temporary += usize::from(
                            hidden(&faulty)
                                .iter()
                                .any(|n| n.contains(&keys[i]) && !n.contains("-999999")),
                        );
                        break None;
                    }
                    std::thread::sleep(Duration::from_millis(2));
                }
            } else {
                Some(child.wait().expect("wait"))
            };
            // Whatever was killed where: a visible entry is a whole row or the error records.
            for name in visible(&faulty) {
                let ok = name == "errors"
                    || (keys.contains(&name)
                        && std::fs::read(faulty.join(&name).join("row.json")).is_ok());
                assert!(ok, "row {i}, attempt {attempt}: `{name}` is visible in OUT");
            }
            match status.map(|s| s.code()) {
                None => continue,
                Some(Some(0)) => break,
                Some(Some(3)) => {
                    permanent[i] += 1;
                    break;
                }
                Some(code) => panic!("row {i}, attempt {attempt}: exit {code:?}"),
            }
        }
    }
    let faulty_seconds = t.elapsed().as_secs_f64();
    eprintln!(
        "{test}: seed {FAULT_SEED:#x}: {rows} rows, {attempts} processes, {kills} killed \
         ({left_temporary} leaving a temporary folder or file); \
         serial run {serial_seconds:.1} s, faulty run {faulty_seconds:.1} s"
    );
    assert!(kills > 0, "no process was killed");

    // Every row as the serial run's; the malformed lamp's rows failed once each, with a record.
    for (i, key) in keys.iter().enumerate() {
        if broken_rows.contains(&i) {
            assert_eq!(permanent[i], 1, "row {i}");
            let record = std::fs::read_to_string(faulty.join("errors").join(format!("{key}.json")))
                .expect("error record");
            assert!(
                record.contains("broken.ies") && record.contains("\"exit_code\": 3"),
                "{record}"
            );
            assert!(!faulty.join(key).exists(), "row {i} has no result");
        } else {
            assert_eq!(permanent[i], 0, "row {i}");
            assert_eq!(
                row_files(&faulty.join(key)),
                row_files(&serial.join(key)),
                "row {i}"
            );
        }
    }
    assert_eq!(
        hidden(&faulty),
        Vec::<String>::new(),
        "temporary folders left"
    );
    let s = status_json(&manifest, &faulty);
    assert_eq!(s["missing"], serde_json::json!([]), "{s}");
    assert_eq!(
        s["done"].as_array().map(Vec::len),
        Some(rows - broken_rows.len()),
        "{s}"
    );
    let failed: Vec<u64> = s["failed"]
        .as_array()
        .expect("failed")
        .iter()
        .filter_map(|f| f["index"].as_u64())
        .collect();
    assert_eq!(
        failed,
        broken_rows.iter().map(|&i| i as u64).collect::<Vec<_>>()
    );

    // A second full run bakes nothing and leaves the records as they were.
    let records = |out: &Path| row_files(&out.join("errors"));
    let before = records(&faulty);
    let run_all = |jobs: &str, out: &Path| {
        output(&[
            "catalogue",
            "run",
            &m,
            "--all",
            "--jobs",
            jobs,
            "--out",
            &out.display().to_string(),
        ])
    };
    let o = run_all("2", &faulty);
    assert_eq!(o.status.code(), Some(3), "{}", text(&o.stderr));
    let lines = text(&o.stdout);
    assert_eq!(
        (
            lines.matches(" baked ").count(),
            lines.matches(" skipped (done) ").count()
        ),
        (0, rows - broken_rows.len()),
        "{lines}"
    );
    assert_eq!(
        text(&o.stderr).matches("failed before").count(),
        broken_rows.len()
    );
    assert_eq!(records(&faulty), before);
    assert_eq!(records(&faulty), records(&serial));

    // One worker through every row (`--all --jobs 1`): a room's later rows bake on the room
    // and backend of the row before (the CPU backend replaying its gather hits and chart
    // tests), and every row is byte-identical to the serial run's, whose rows each prepared
    // their own room on a new backend.
    let kept = dir.join("kept");
    let o = run_all("1", &kept);
    assert_eq!(o.status.code(), Some(3), "{}", text(&o.stderr));
    let mut reused = 0;
    for (i, key) in keys.iter().enumerate() {
        if broken_rows.contains(&i) {
            continue;
        }
        assert_eq!(
            row_files(&kept.join(key)),
            row_files(&serial.join(key)),
            "row {i}, its room kept"
        );
        // The row's host steps: a kept room's bake has no rasterisation of its own.
        let timings =
            std::fs::read_to_string(kept.join(key).join("timings.json")).expect("timings");
        if !timings.contains("rasterise") {
            reused += 1;
        }
    }
    assert_eq!(
        reused, 3,
        "one row of each room baked on the room kept from the row before"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A broken glTF, a scene whose mesh is missing and a scene file that is not TOML are
/// permanent errors of their rows only: each gets its record and exit 3, the other row bakes.
#[test]
fn broken_rooms_fail_alone_with_their_records() {
    let test = "broken_rooms_fail_alone_with_their_records";
    let Some(lamps) = real_lamps(test, 1) else {
        return;
    };
    let dir = temp_dir("cli-catalogue", "broken");
    std::fs::create_dir_all(&dir).expect("dir");
    std::fs::write(dir.join("broken.glb"), b"glTF\x02\x00\x00\x00 not a glb").expect("glb");
    let scene = |mesh: &str| {
        format!(
            "[[lamp]]\nies = \"isotropic:100\"\nposition = [0, 2, 0]\n\
             [[object]]\nprimitive = \"plane\"\nsize = [2, 2]\n\
             [[object]]\nmesh = \"{mesh}\"\n"
        )
    };
    std::fs::write(dir.join("gltf.toml"), scene("broken.glb")).expect("scene");
    std::fs::write(dir.join("missing.toml"), scene("gone.glb")).expect("scene");
    std::fs::write(dir.join("toml.toml"), "[[lamp]\nies = ").expect("scene");
    // Loads, but its maps cannot fit any backend's textures: the bake refuses it every time.
    let huge = "[[lamp]]\nies = \"isotropic:100\"\nposition = [0, 2, 0]\n\
                [[object]]\nprimitive = \"plane\"\nsize = [5000, 5000]\n";
    std::fs::write(dir.join("huge.toml"), huge).expect("scene");
    let catalogue = format!(
        "qualities = [\"draft\"]\nlamps = [{:?}]\n[settings]\ntexels_per_metre = 8\n\
         [[room]]\nscene = \"gltf.toml\"\n[[room]]\nscene = \"missing.toml\"\n\
         [[room]]\nscene = \"toml.toml\"\n[[room]]\nscene = \"huge.toml\"\n\
         [[room]]\nbuiltin = \"floor\"\n",
        lamps[0].display().to_string()
    );
    std::fs::write(dir.join("catalogue.toml"), catalogue).expect("catalogue");
    let manifest = dir.join("manifest.jsonl");
    assert_eq!(plan(&dir.join("catalogue.toml"), &manifest), 5);
    let out = dir.join("out");
    for (i, needle) in [
        (0, "broken.glb"),
        (1, "gone.glb"),
        (2, "toml.toml"),
        (3, "bake: "),
    ] {
        let o = output(&[
            "catalogue",
            "run",
            &manifest.display().to_string(),
            "--index",
            &i.to_string(),
            "--out",
            &out.display().to_string(),
        ]);
        let stderr = text(&o.stderr);
        assert_eq!(o.status.code(), Some(3), "row {i}: {stderr}");
        assert!(
            stderr.contains(needle) && stderr.contains("recorded in"),
            "row {i}: {stderr}"
        );
    }
    let o = luxbake()
        .args(["catalogue", "run", &manifest.display().to_string(), "--out"])
        .arg(&out)
        .env("SLURM_ARRAY_TASK_ID", "4")
        .output()
        .expect("run");
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        text(&o.stdout).starts_with("row 4 baked "),
        "{}",
        text(&o.stdout)
    );
    let s = status_json(&manifest, &out);
    assert_eq!(
        (s["done"].clone(), s["missing"].clone()),
        (serde_json::json!([4]), serde_json::json!([]))
    );
    assert_eq!(s["failed"].as_array().map(Vec::len), Some(4), "{s}");
    std::fs::remove_dir_all(&dir).ok();
}
