//! `luxbake catalogue status`: which rows of a manifest are done, failed and missing.

use std::fmt::Write as _;
use std::path::Path;

use serde_json::{Value, json};

use super::failure::Failure;
use super::plan::Row;
use super::run::{TEMP_PREFIX, describe, error_record, verify};

/// The state of a manifest's rows in an output folder.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Status {
    /// Rows published and verified (indices).
    pub done: Vec<usize>,
    /// Rows with an error record: index and the recorded error.
    pub failed: Vec<(usize, String)>,
    /// Rows neither done nor failed (never run, running, or killed before publishing).
    pub missing: Vec<usize>,
    /// Temporary folders and files left in the output folder (by runs in progress or killed);
    /// the next run of their row removes them.
    pub temporary: Vec<String>,
}

/// Checks every row of `rows` in `out` (reading and hashing every published file).
pub fn status(rows: &[Row], out: &Path) -> Result<Status, Failure> {
    let mut s = Status::default();
    for row in rows {
        if verify(&out.join(&row.key), &row.key) {
            s.done.push(row.index);
        } else if let Ok(text) = std::fs::read_to_string(error_record(out, &row.key)) {
            let error = serde_json::from_str::<Value>(&text)
                .ok()
                .and_then(|v| v["error"].as_str().map(str::to_owned))
                .unwrap_or_else(|| "an unreadable error record".into());
            s.failed.push((row.index, error));
        } else {
            s.missing.push(row.index);
        }
    }
    for dir in [out.to_path_buf(), out.join(super::run::ERRORS_DIR)] {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            if name.starts_with(TEMP_PREFIX) {
                s.temporary.push(entry.path().display().to_string());
            }
        }
    }
    s.temporary.sort();
    Ok(s)
}

impl Status {
    /// The report as text: a summary line, then a line per failed and per missing row.
    pub fn text(&self, rows: &[Row]) -> String {
        let mut o = String::new();
        let _ = writeln!(
            o,
            "{} rows: {} done, {} failed, {} missing",
            rows.len(),
            self.done.len(),
            self.failed.len(),
            self.missing.len()
        );
        for (i, error) in &self.failed {
            let row = &rows[*i];
            let _ = writeln!(o, "failed  {i:>5} {} ({}): {error}", row.key, describe(row));
        }
        for i in &self.missing {
            let row = &rows[*i];
            let _ = writeln!(o, "missing {i:>5} {} ({})", row.key, describe(row));
        }
        if !self.temporary.is_empty() {
            let _ = writeln!(
                o,
                "{} temporary folder(s) or file(s) of unfinished runs (removed by their row's next run)",
                self.temporary.len()
            );
        }
        o
    }

    /// The report as one JSON object: `rows`, `done` (indices), `failed` (`index`, `key`,
    /// `error`), `missing` (indices), `temporary` (paths).
    pub fn json(&self, rows: &[Row]) -> Value {
        json!({
            "rows": rows.len(),
            "done": self.done,
            "failed": self.failed.iter().map(|(i, e)| json!({
                "index": i, "key": rows[*i].key, "error": e,
            })).collect::<Vec<_>>(),
            "missing": self.missing,
            "temporary": self.temporary,
        })
    }
}
