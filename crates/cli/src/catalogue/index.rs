//! `luxbake catalogue index`: `OUT/index.json`, what a shop's front end reads — one entry per
//! published and verified row (room, lamp, placement, quality, key, the web GLB, every file
//! with its size, the lux range), written atomically.

use std::path::Path;

use serde_json::{Value, json};

use super::failure::Failure;
use super::plan::Row;
use super::run::{ROW_FILE, TEMP_PREFIX, verify};

/// The index's file name in the output folder.
pub const INDEX_FILE: &str = "index.json";

/// Writes `out/index.json` for the manifest's `rows`: every row whose folder verifies (every
/// file of its `row.json` there with its size and SHA-256) is listed, in manifest order; rows
/// missing, failed or being baked are not. The file is written under a temporary dot name and
/// renamed into place, so a reader (or a concurrent writer) sees one whole index or the one
/// before. Returns the number of rows listed.
pub fn write_index(rows: &[Row], out: &Path) -> Result<usize, Failure> {
    let retry = |what: &Path, e: &dyn std::fmt::Display| {
        Failure::Retryable(format!("index {}: {e}", what.display()))
    };
    let mut entries = Vec::new();
    for row in rows {
        let dir = out.join(&row.key);
        if !verify(&dir, &row.key) {
            continue;
        }
        let text = std::fs::read_to_string(dir.join(ROW_FILE)).map_err(|e| retry(&dir, &e))?;
        let record: Value = serde_json::from_str(&text).map_err(|e| retry(&dir, &e))?;
        entries.push(entry(row, &record));
    }
    let index = json!({
        "format": "luxbake-catalogue-index",
        "version": 1,
        "rows": rows.len(),
        "listed": entries.len(),
        "entries": entries,
    });
    let text = serde_json::to_string_pretty(&index).map_err(|e| retry(out, &e))? + "\n";
    std::fs::create_dir_all(out).map_err(|e| retry(out, &e))?;
    let temp = out.join(format!(
        "{TEMP_PREFIX}index-{}-{}.json",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos())
    ));
    let written = std::fs::write(&temp, &text)
        .and_then(|()| std::fs::File::open(&temp)?.sync_all())
        .and_then(|()| std::fs::rename(&temp, out.join(INDEX_FILE)));
    if let Err(e) = written {
        let _ = std::fs::remove_file(&temp);
        return Err(retry(&out.join(INDEX_FILE), &e));
    }
    Ok(entries.len())
}

/// A row's entry: what the manifest says of it, and what its `row.json` lists.
fn entry(row: &Row, record: &Value) -> Value {
    let files: Vec<Value> = record["files"]
        .as_array()
        .map(|files| {
            files
                .iter()
                .map(|f| {
                    json!({
                        "path": format!("{}/{}", row.key, f["path"].as_str().unwrap_or("")),
                        "bytes": f["bytes"],
                    })
                })
                .collect()
        })
        .unwrap_or_default();
    let web = &record["web"];
    json!({
        "index": row.index,
        "key": row.key,
        "room": row.room,
        "lamp": row.lamp_name,
        "placement": row.placement,
        "positions": row.positions,
        "quality": row.quality,
        "glb": web["glb"].as_str().map(|g| format!("{}/{g}", row.key)),
        "lux": web["lux"],
        "files": files,
    })
}
