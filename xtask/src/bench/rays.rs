//! `cargo xtask bench rays`: single-thread ray throughput of luxbake's CPU traversals against
//! Intel Embree 3, same process, same triangles, same rays (issue 15).
//!
//! The measuring happens in `crates/bench-embree` (`luxbake-bench-embree`), a binary of its own
//! so that xtask never links Embree: its build script links Debian's `libembree3` when
//! `libembree-dev` is installed, and otherwise it reports "Embree not available" and measures
//! luxbake alone. This command builds and runs it (release profile), then writes the table:
//! rays/s per thread for each scene × ray set × traversal (the wide BVH, the encoded MTBVH,
//! Embree), and the wide BVH's ratios against Embree and against the MTBVH. Then the bake
//! level (`--bake-gather`): the paper-method bake's first-bounce gather rays/s on one thread
//! against the same rays traced alone with the wide BVH (the bench's `gather` module), their
//! ratio and the overhead `1 − ratio`.

use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

use serde_json::Value;

use super::{load_average, machine, utc_now, write_results};

/// Arguments of `cargo xtask bench rays`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenes, comma separated: built-in names and `room` (three SheenChairs and a
    /// GlamVelvetSofa from `../shared/models`).
    #[arg(long, default_value = "chairs_05,sofa_01,room")]
    scenes: String,
    /// Rays per set (default 400 000; 20 000 with `--quick`).
    #[arg(long)]
    rays: Option<usize>,
    /// The shared glTF models.
    #[arg(long, default_value = "../shared/models")]
    models: String,
    /// Built-in scenes, comma separated, whose paper-method bake measures the gather's overhead
    /// over pure traversal of the same rays (empty: none).
    #[arg(long, default_value = "chairs_05")]
    bake_gather: String,
}

/// Runs the study.
pub fn run(args: &Args, quick: bool, runs: Option<usize>, out: &Path) -> Result<(), String> {
    let rays = args.rays.unwrap_or(if quick { 20_000 } else { 400_000 });
    let runs = runs.unwrap_or(if quick { 1 } else { 5 });
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let output = Command::new(cargo)
        .args([
            "run",
            "--quiet",
            "--release",
            "--package",
            "luxbake-bench-embree",
            "--",
        ])
        .arg(format!("--scenes={}", args.scenes))
        .arg(format!("--rays={rays}"))
        .arg(format!("--runs={runs}"))
        .arg(format!("--models={}", args.models))
        .arg(format!("--bake-gather={}", args.bake_gather))
        .stderr(std::process::Stdio::inherit())
        .output()
        .map_err(|e| format!("running luxbake-bench-embree: {e}"))?;
    if !output.status.success() {
        return Err(format!("luxbake-bench-embree failed: {}", output.status));
    }
    let report: Value = serde_json::from_slice(&output.stdout)
        .map_err(|e| format!("luxbake-bench-embree output: {e}"))?;
    let md = markdown(&report);
    print!("{md}");
    let mut json = report;
    json["machine"] = machine().into();
    json["load_average"] = load_average().into();
    write_results(out, "rays", &md, &json)
}

/// The rate of `tracer` in a set's results.
fn rate(results: &[Value], tracer: &str) -> Option<f64> {
    results
        .iter()
        .find(|r| r["tracer"] == tracer)
        .and_then(|r| r["rays_per_s"].as_f64())
}

fn ratio(a: Option<f64>, b: Option<f64>) -> String {
    match (a, b) {
        (Some(a), Some(b)) if b > 0.0 => format!("{:.2}×", a / b),
        _ => "–".into(),
    }
}

/// The report as Markdown: one row per scene × ray set.
fn markdown(report: &Value) -> String {
    let (date, time) = utc_now();
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# Ray throughput: luxbake vs Embree ({date} {time} UTC)\n"
    );
    let _ = writeln!(
        md,
        "Machine: {}, load average {}. One thread; M rays/s of thread CPU time, median of {} rounds. \
         `agree`: fraction of rays with the same result (hit triangle, or occluded) as the encoded \
         MTBVH traversal; ties between coincident triangles count as disagreements.",
        machine(),
        load_average(),
        report["runs"]
    );
    match report["embree"].as_str() {
        Some(v) => {
            let _ = writeln!(md, "Embree: {v}.\n");
        }
        None => {
            let _ = writeln!(
                md,
                "{}: luxbake alone.\n",
                report["embree_missing"]
                    .as_str()
                    .unwrap_or("Embree not available")
            );
        }
    }
    let tracers = ["luxbake wide", "luxbake mtbvh", "embree"];
    let _ = writeln!(
        md,
        "| scene | triangles | rays | query | wide | mtbvh | embree | wide / embree | wide / mtbvh | agree wide | agree embree |"
    );
    let _ = writeln!(md, "|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|");
    for scene in report["scenes"].as_array().into_iter().flatten() {
        for set in scene["sets"].as_array().into_iter().flatten() {
            let results = set["results"].as_array().map_or(&[][..], Vec::as_slice);
            let rates = tracers.map(|t| rate(results, t));
            let cell = |r: Option<f64>| r.map_or("–".into(), |r| format!("{:.2}", r * 1e-6));
            let agree = |tracer: &str| {
                results
                    .iter()
                    .find(|r| r["tracer"] == tracer)
                    .and_then(|r| r["agree"].as_f64())
                    .map_or("–".into(), |a| format!("{a:.4}"))
            };
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                scene["scene"].as_str().unwrap_or("?"),
                scene["triangles"],
                set["set"].as_str().unwrap_or("?"),
                set["query"].as_str().unwrap_or("?"),
                cell(rates[0]),
                cell(rates[1]),
                cell(rates[2]),
                ratio(rates[0], rates[2]),
                ratio(rates[0], rates[1]),
                agree("luxbake wide"),
                agree("embree"),
            );
        }
    }
    bake_gather(&mut md, report);
    md
}

/// The bake-level gather table, if the report has one.
fn bake_gather(md: &mut String, report: &Value) {
    let rows = report["bake_gather"]
        .as_array()
        .map_or(&[][..], Vec::as_slice);
    if rows.is_empty() {
        return;
    }
    let _ = writeln!(
        md,
        "\n## Bake-level gather\n\n\
         The paper-method bake (`cargo xtask bake --method paper`) on one thread: the first \
         bounce's gather rays per second of its dispatches' thread CPU time (G-buffer fetches, \
         directions, closest hits, hit shading, masked look-ups) against the same rays traced \
         alone with the wide BVH's closest hit, in the same order; medians of {} rounds. \
         `reproduced`: texels whose gather the rebuilt rays reproduce bit for bit.\n",
        report["runs"]
    );
    let _ = writeln!(
        md,
        "| scene | rays | bake | traversal | bake / traversal | overhead | reproduced | all bounces, bake |"
    );
    let _ = writeln!(md, "|---|---:|---:|---:|---:|---:|---:|---:|");
    for r in rows {
        let m = |k: &str| {
            r[k].as_f64()
                .map_or("–".into(), |v| format!("{:.2}", v * 1e-6))
        };
        let ratio = r["ratio"].as_f64();
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} of {} | {} |",
            r["scene"].as_str().unwrap_or("?"),
            r["rays"],
            m("bake_rays_per_s"),
            m("traversal_rays_per_s"),
            ratio.map_or("–".into(), |v| format!("{v:.2}×")),
            ratio.map_or("–".into(), |v| format!("{:.0} %", (1.0 - v) * 100.0)),
            r["checked_texels"].as_u64().unwrap_or(0)
                - r["mismatched_texels"].as_u64().unwrap_or(0),
            r["checked_texels"],
            m("all_bounces_rays_per_s"),
        );
    }
    let _ = writeln!(md, "\nRates in M rays/s.");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_has_ratios_and_marks_missing_embree() {
        let report = serde_json::json!({
            "embree": null,
            "embree_missing": "Embree not available",
            "runs": 1,
            "scenes": [{
                "scene": "chairs_05",
                "triangles": 1212,
                "sets": [{
                    "set": "random",
                    "query": "closest hit",
                    "results": [
                        { "tracer": "luxbake mtbvh", "rays_per_s": 2.5e6, "agree": 1.0 },
                        { "tracer": "luxbake wide", "rays_per_s": 5.0e6, "agree": 1.0 },
                    ],
                }],
            }],
        });
        let md = markdown(&report);
        assert!(md.contains("Embree not available: luxbake alone."), "{md}");
        assert!(
            md.contains(
                "| chairs_05 | 1212 | random | closest hit | 5.00 | 2.50 | – | – | 2.00× | 1.0000 | – |"
            ),
            "{md}"
        );
        let with = serde_json::json!({
            "embree": "3.13",
            "runs": 3,
            "scenes": [{ "scene": "s", "triangles": 1, "sets": [{ "set": "shadow", "query": "any hit",
                "results": [
                    { "tracer": "luxbake mtbvh", "rays_per_s": 3.0e6, "agree": 1.0 },
                    { "tracer": "luxbake wide", "rays_per_s": 6.0e6, "agree": 0.9995 },
                    { "tracer": "embree", "rays_per_s": 12.0e6, "agree": 0.999 },
                ] }] }],
        });
        let md = markdown(&with);
        assert!(
            md.contains("| 6.00 | 3.00 | 12.00 | 0.50× | 2.00× | 0.9995 | 0.9990 |"),
            "{md}"
        );
        assert!(!md.contains("Bake-level gather"), "{md}");
        let gather = serde_json::json!({
            "embree": null,
            "runs": 3,
            "scenes": [],
            "bake_gather": [{
                "scene": "chairs_05", "rays": 2335776,
                "bake_rays_per_s": 3.5e6, "traversal_rays_per_s": 7.0e6, "ratio": 0.5,
                "checked_texels": 583944, "mismatched_texels": 0,
                "all_bounces_rays_per_s": 3.6e6,
            }],
        });
        let md = markdown(&gather);
        assert!(
            md.contains(
                "| chairs_05 | 2335776 | 3.50 | 7.00 | 0.50× | 50 % | 583944 of 583944 | 3.60 |"
            ),
            "{md}"
        );
    }
}
