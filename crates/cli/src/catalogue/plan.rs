//! `luxbake catalogue plan`: the catalogue file, its expansion into rows, the rows' inputs and
//! content keys, and the manifest (JSON lines).

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use luxbake::scene::SettingsPatch;
use luxbake_backends::BackendKind;
use luxbake_output::file_stem;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value, json};
use sha2::{Digest, Sha256};

use super::failure::Failure;

/// The version of what a published row holds (`row.json`'s `version`). It is part of every
/// content key, so rows published in an older layout are baked again under new keys.
/// 2: the web GLB and `row.json`'s `web`.
pub(crate) const ROW_VERSION: u32 = 2;

/// The `sha256` of an input that was missing when it was hashed: the row fails at run time with
/// a permanent error naming the file.
pub(crate) const MISSING: &str = "missing";

/// One row of a manifest: a room lit by one lamp file at one placement and quality.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Row {
    /// The row's position in the manifest, from 0 (the batch task's index).
    pub index: usize,
    /// The content key (64 hex digits, SHA-256): the name of the row's output folder.
    pub key: String,
    /// The room's name (unique in the catalogue).
    pub room: String,
    /// The room's scene: a scene file's path, or `builtin:<name>`.
    pub scene: String,
    /// The photometric file every lamp of the row takes.
    pub lamp: String,
    /// The lamp file's name in the catalogue (its stem, made unique).
    pub lamp_name: String,
    /// The placement's name (`scene` when the room keeps its scene's own lamps).
    pub placement: String,
    /// The placement's lamp positions (metres, world), or `None`: the scene's own lamps.
    pub positions: Option<Vec<[f64; 3]>>,
    /// The quality preset: `draft`, `default` or `final`.
    pub quality: String,
    /// The backend: `cpu`, `glow` or `wgpu`.
    pub backend: String,
    /// The catalogue's `[settings]` (scene-file keys over the scene's own).
    pub settings: Map<String, Value>,
    /// Every input file, with the SHA-256 of its bytes when planned.
    pub inputs: Vec<Input>,
}

/// An input file of a row.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Input {
    /// What it is: `scene`, `mesh`, `mesh-resource` (a glTF buffer or image, an OBJ material
    /// library or texture), `scene-lamp` (a photometric file the scene names) or `lamp`.
    pub role: String,
    /// Its path.
    pub path: String,
    /// The SHA-256 of its bytes (hex), or `missing`.
    pub sha256: String,
}

/// The catalogue file (`docs/catalogue.md`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CatalogueFile {
    #[serde(default)]
    backend: Option<String>,
    #[serde(default)]
    qualities: Option<Vec<String>>,
    lamps: Vec<String>,
    #[serde(default)]
    settings: toml::Table,
    #[serde(rename = "room")]
    rooms: Vec<RoomFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RoomFile {
    name: Option<String>,
    scene: Option<String>,
    builtin: Option<String>,
    #[serde(default, rename = "placement")]
    placements: Vec<PlacementFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PlacementFile {
    name: String,
    positions: Vec<[f64; 3]>,
}

/// The SHA-256 of `bytes`, 64 lower-case hex digits.
pub(crate) fn sha256_hex(bytes: &[u8]) -> String {
    format!("{:x}", Sha256::digest(bytes))
}

/// Reads a catalogue file and expands it into its rows, in order: rooms, then lamps, then
/// placements, then qualities. Every error is a [`Failure::Usage`] naming the file and key.
pub fn plan(catalogue: &Path) -> Result<Vec<Row>, Failure> {
    let usage = |m: String| Failure::Usage(format!("{}: {m}", catalogue.display()));
    let text = std::fs::read_to_string(catalogue).map_err(|e| usage(e.to_string()))?;
    let file: CatalogueFile = toml::from_str(&text).map_err(|e| usage(e.to_string()))?;
    let base = catalogue.parent().unwrap_or(Path::new("."));
    let backend: BackendKind = file
        .backend
        .as_deref()
        .unwrap_or("cpu")
        .parse()
        .map_err(|e| usage(format!("backend: {e}")))?;
    let qualities = file.qualities.unwrap_or_else(|| vec!["default".into()]);
    if qualities.is_empty() {
        return Err(usage("qualities: give at least one".into()));
    }
    let settings = settings_json(&file.settings).map_err(&usage)?;
    for q in &qualities {
        row_patch(&settings, q).map_err(|e| usage(format!("qualities/settings: {e}")))?;
    }
    if file.rooms.is_empty() {
        return Err(usage("no [[room]]".into()));
    }
    let lamps = lamp_files(base, &file.lamps).map_err(&usage)?;
    let mut rows = Vec::new();
    let mut room_names = HashSet::new();
    for (r, room) in file.rooms.iter().enumerate() {
        let (scene, name, scene_inputs) = match (&room.scene, &room.builtin) {
            (Some(path), None) => {
                let path =
                    absolute(&base.join(path)).map_err(|e| usage(format!("room {r}: {e}")))?;
                let inputs = scene_inputs(&path).map_err(|e| usage(format!("room {r}: {e}")))?;
                let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned());
                (path.display().to_string(), stem.unwrap_or_default(), inputs)
            }
            (None, Some(name)) => (format!("builtin:{name}"), name.clone(), Vec::new()),
            _ => {
                return Err(usage(format!(
                    "room {r}: give exactly one of `scene` (a scene file) and `builtin`"
                )));
            }
        };
        let name = room.name.clone().unwrap_or(name);
        if !room_names.insert(name.clone()) {
            return Err(usage(format!("room {r}: the name `{name}` is taken")));
        }
        let mut placements: Vec<(String, Option<Vec<[f64; 3]>>)> = Vec::new();
        for p in &room.placements {
            if p.positions.is_empty() || p.positions.iter().flatten().any(|c| !c.is_finite()) {
                return Err(usage(format!(
                    "room `{name}`, placement `{}`: positions: give one or more finite [x, y, z]",
                    p.name
                )));
            }
            if placements.iter().any(|(n, _)| *n == p.name) {
                return Err(usage(format!("room `{name}`: two placements `{}`", p.name)));
            }
            placements.push((p.name.clone(), Some(p.positions.clone())));
        }
        if placements.is_empty() {
            placements.push(("scene".into(), None));
        }
        for (lamp_name, lamp_path) in &lamps {
            for (placement, positions) in &placements {
                for quality in &qualities {
                    let mut inputs = scene_inputs.clone();
                    inputs.push(input("lamp", lamp_path));
                    let mut row = Row {
                        index: rows.len(),
                        key: String::new(),
                        room: name.clone(),
                        scene: scene.clone(),
                        lamp: lamp_path.display().to_string(),
                        lamp_name: lamp_name.clone(),
                        placement: placement.clone(),
                        positions: positions.clone(),
                        quality: quality.clone(),
                        backend: backend.name().into(),
                        settings: settings.clone(),
                        inputs,
                    };
                    row.key = content_key(&row);
                    rows.push(row);
                }
            }
        }
    }
    Ok(rows)
}

/// The catalogue's `[settings]` as JSON, checked to be scene-file settings keys other than
/// `quality` (the `qualities` axis) and `backend` (the catalogue's `backend`).
fn settings_json(table: &toml::Table) -> Result<Map<String, Value>, String> {
    let mut out = Map::new();
    for (k, v) in table {
        if k == "quality" || k == "backend" {
            return Err(format!(
                "settings.{k}: give it as the catalogue's `{}` instead",
                if k == "quality" {
                    "qualities"
                } else {
                    "backend"
                }
            ));
        }
        let v = serde_json::to_value(v).map_err(|e| format!("settings.{k}: {e}"))?;
        out.insert(k.clone(), v);
    }
    Ok(out)
}

/// The settings patch of a row: its quality preset, then the catalogue's `[settings]` (as flags
/// over a scene file's `[settings]`); checked.
pub(crate) fn row_patch(
    settings: &Map<String, Value>,
    quality: &str,
) -> Result<SettingsPatch, String> {
    let mut entries: Vec<(String, Value)> = settings
        .iter()
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    entries.push(("quality".into(), Value::from(quality)));
    let patch = SettingsPatch::from_entries(&entries)
        .map_err(|e| format!("settings.{}: {}", e.key, e.message))?;
    patch
        .settings()
        .map_err(|e| format!("settings.{}: {}", e.name, e.reason))?;
    Ok(patch)
}

/// The lamp files the catalogue's `lamps` names, each with its unique name (its stem); a
/// folder gives its `.ies` and `.ldt` files in name order.
fn lamp_files(base: &Path, entries: &[String]) -> Result<Vec<(String, PathBuf)>, String> {
    let mut files = Vec::new();
    for entry in entries {
        let path = absolute(&base.join(entry)).map_err(|e| format!("lamps: {e}"))?;
        if path.is_dir() {
            let found = crate::bake::photometric_files_in(&path)
                .map_err(|e| format!("lamps: {}: {e}", path.display()))?;
            if found.is_empty() {
                return Err(format!(
                    "lamps: {} holds no .ies or .ldt file",
                    path.display()
                ));
            }
            files.extend(found);
        } else {
            files.push(path);
        }
    }
    if files.is_empty() {
        return Err("lamps: give one or more files or folders".into());
    }
    let mut stems = HashSet::new();
    Ok(files
        .into_iter()
        .map(|file| {
            let base = file_stem(&file.file_stem().unwrap_or_default().to_string_lossy());
            let mut stem = base.clone();
            let mut n = 2;
            while !stems.insert(stem.clone()) {
                stem = format!("{base}_{n}");
                n += 1;
            }
            (stem, file)
        })
        .collect())
}

/// `path` made absolute (so the manifest does not depend on the working folder) and checked
/// to exist.
fn absolute(path: &Path) -> Result<PathBuf, String> {
    std::fs::canonicalize(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// An input with the hash of its bytes (or [`MISSING`]).
fn input(role: &str, path: &Path) -> Input {
    Input {
        role: role.into(),
        path: path.display().to_string(),
        sha256: std::fs::read(path).map_or_else(|_| MISSING.into(), |b| sha256_hex(&b)),
    }
}

/// A scene file and every file it references, hashed: the `ies`, `mesh` and `lights_ies` keys
/// (relative to the scene file), a glTF's external buffers and images, an OBJ's material
/// libraries and their textures. A referenced file that is missing is listed as [`MISSING`]; a
/// scene file that is not TOML is listed alone (its bake fails with the parse error).
pub(crate) fn scene_inputs(scene: &Path) -> Result<Vec<Input>, String> {
    let text = std::fs::read(scene).map_err(|e| format!("{}: {e}", scene.display()))?;
    let mut inputs = vec![Input {
        role: "scene".into(),
        path: scene.display().to_string(),
        sha256: sha256_hex(&text),
    }];
    let base = scene.parent().unwrap_or(Path::new("."));
    let Ok(table) = std::str::from_utf8(&text)
        .map_err(|e| e.to_string())
        .and_then(|t| t.parse::<toml::Table>().map_err(|e| e.to_string()))
    else {
        return Ok(inputs);
    };
    let entries = |key: &str| -> Vec<toml::Table> {
        match table.get(key) {
            Some(toml::Value::Array(a)) => a.iter().filter_map(|v| v.as_table().cloned()).collect(),
            _ => Vec::new(),
        }
    };
    let photometry = |v: Option<&toml::Value>| {
        v.and_then(toml::Value::as_str)
            .filter(|s| !s.starts_with("isotropic:"))
            .map(|s| base.join(s))
    };
    for lamp in entries("lamp") {
        if let Some(p) = photometry(lamp.get("ies")) {
            inputs.push(input("scene-lamp", &p));
        }
    }
    for object in entries("object") {
        if let Some(mesh) = object.get("mesh").and_then(toml::Value::as_str) {
            let mesh = base.join(mesh);
            inputs.push(input("mesh", &mesh));
            for resource in mesh_resources(&mesh) {
                inputs.push(input("mesh-resource", &resource));
            }
        }
        if let Some(p) = photometry(object.get("lights_ies")) {
            inputs.push(input("scene-lamp", &p));
        }
    }
    Ok(inputs)
}

/// The files a mesh file reads besides itself: a `.gltf`'s buffers and images given by a
/// relative URI, an `.obj`'s `mtllib` files and the `map_*` textures they name.
fn mesh_resources(mesh: &Path) -> Vec<PathBuf> {
    let base = mesh.parent().unwrap_or(Path::new("."));
    let ext = mesh
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let Ok(text) = std::fs::read_to_string(mesh) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    if ext == "gltf" {
        let Ok(json) = serde_json::from_str::<Value>(&text) else {
            return out;
        };
        for list in ["buffers", "images"] {
            for item in json[list].as_array().into_iter().flatten() {
                if let Some(uri) = item["uri"].as_str()
                    && !uri.starts_with("data:")
                    && !uri.contains("://")
                {
                    out.push(base.join(percent_decode(uri)));
                }
            }
        }
    } else if ext == "obj" {
        for lib in text
            .lines()
            .filter_map(|l| l.trim().strip_prefix("mtllib "))
        {
            for name in lib.split_whitespace() {
                let mtl = base.join(name);
                if let Ok(mtl_text) = std::fs::read_to_string(&mtl) {
                    for line in mtl_text.lines().map(str::trim) {
                        if line.starts_with("map_")
                            && let Some(texture) = line.split_whitespace().last()
                        {
                            out.push(base.join(texture));
                        }
                    }
                }
                out.push(mtl);
            }
        }
    }
    out
}

/// `%XX` escapes of a URI decoded (glTF URIs are percent-encoded).
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        if bytes[i] == b'%'
            && i + 2 < bytes.len()
            && let (Some(h), Some(l)) = (hex(bytes[i + 1]), hex(bytes[i + 2]))
        {
            out.push((h * 16 + l) as u8);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// The content key of a row: the SHA-256 of luxbake's version, the layout of a published row
/// ([`ROW_VERSION`]), its inputs' hashes (by role, not by path: a catalogue moved elsewhere
/// keeps its keys), the built-in scene's name, the placement's positions, the quality, the
/// backend and the settings.
pub(crate) fn content_key(row: &Row) -> String {
    let doc = json!({
        "format": "luxbake-catalogue-key",
        "version": 1,
        "luxbake": env!("CARGO_PKG_VERSION"),
        "row": ROW_VERSION,
        "builtin": row.scene.strip_prefix("builtin:"),
        "inputs": row.inputs.iter().map(|i| [&i.role, &i.sha256]).collect::<Vec<_>>(),
        "positions": row.positions,
        "quality": row.quality,
        "backend": row.backend,
        "settings": row.settings,
    });
    sha256_hex(doc.to_string().as_bytes())
}

/// Writes the manifest: one JSON line per row.
pub(crate) fn write_manifest(path: &Path, rows: &[Row]) -> Result<(), Failure> {
    let mut text = String::new();
    for row in rows {
        let line = serde_json::to_string(row)
            .map_err(|e| Failure::Usage(format!("{}: {e}", path.display())))?;
        text.push_str(&line);
        text.push('\n');
    }
    std::fs::write(path, text).map_err(|e| Failure::Usage(format!("{}: {e}", path.display())))
}

/// Reads a manifest; an unreadable one, a malformed line or a row out of order is a
/// [`Failure::Usage`] naming the line.
pub fn read_manifest(path: &Path) -> Result<Vec<Row>, Failure> {
    let usage = |m: String| Failure::Usage(format!("{}: {m}", path.display()));
    let text = std::fs::read_to_string(path).map_err(|e| usage(e.to_string()))?;
    let mut rows = Vec::new();
    for (n, line) in text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
    {
        let row: Row =
            serde_json::from_str(line).map_err(|e| usage(format!("line {}: {e}", n + 1)))?;
        if row.index != rows.len() {
            return Err(usage(format!(
                "line {}: row index {} where {} was expected",
                n + 1,
                row.index,
                rows.len()
            )));
        }
        if row.key.len() != 64 || !row.key.bytes().all(|b| b.is_ascii_hexdigit()) {
            return Err(usage(format!(
                "line {}: the key is not 64 hex digits",
                n + 1
            )));
        }
        rows.push(row);
    }
    if rows.is_empty() {
        return Err(usage("no rows".into()));
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_escapes_decode() {
        assert_eq!(percent_decode("a%20b%2x.bin"), "a b%2x.bin");
        assert_eq!(percent_decode("x%4"), "x%4");
    }

    /// A scene's referenced files are its inputs; a missing one is listed as missing; the key
    /// changes with any input byte and any setting, not with where the files are.
    #[test]
    fn keys_follow_the_inputs_bytes_and_settings() {
        let dir = luxbake_testkit::temp_dir("cli-plan", "keys");
        std::fs::create_dir_all(dir.join("lamps")).expect("dir");
        std::fs::write(dir.join("lamps/a.ies"), "not an IES file").expect("lamp");
        std::fs::write(dir.join("lamps/b.ldt"), "not a LDT file").expect("lamp");
        let scene = "[[lamp]]\nies = \"isotropic:100\"\nposition = [0, 2, 0]\n\
                     [[object]]\nmesh = \"gone.obj\"\n";
        std::fs::write(dir.join("room.toml"), scene).expect("scene");
        let catalogue = "qualities = [\"draft\", \"default\"]\nlamps = [\"lamps\"]\n\
                         [settings]\ntexels_per_metre = 8\n\
                         [[room]]\nscene = \"room.toml\"\n\
                         [[room]]\nbuiltin = \"floor\"\n\
                         [[room.placement]]\nname = \"two\"\npositions = [[0, 2, 0], [1, 2, 0]]\n";
        std::fs::write(dir.join("c.toml"), catalogue).expect("catalogue");
        let rows = plan(&dir.join("c.toml")).expect("plan");
        assert_eq!(rows.len(), 2 * 2 * 2);
        assert_eq!(
            (
                rows[0].room.as_str(),
                rows[0].lamp_name.as_str(),
                rows[0].quality.as_str()
            ),
            ("room", "a", "draft")
        );
        assert_eq!(rows[4].placement, "two");
        let roles: Vec<_> = rows[0]
            .inputs
            .iter()
            .map(|i| (i.role.as_str(), i.sha256 == MISSING))
            .collect();
        assert_eq!(roles, [("scene", false), ("mesh", true), ("lamp", false)]);
        let keys: HashSet<_> = rows.iter().map(|r| r.key.clone()).collect();
        assert_eq!(keys.len(), rows.len());
        // The manifest round-trips.
        write_manifest(&dir.join("m.jsonl"), &rows).expect("write");
        assert_eq!(read_manifest(&dir.join("m.jsonl")).expect("read"), rows);
        // A changed lamp byte changes its rows' keys only; the same files elsewhere keep them.
        std::fs::write(dir.join("lamps/b.ldt"), "not a LDT file!").expect("lamp");
        let changed = plan(&dir.join("c.toml")).expect("plan");
        for (a, b) in rows.iter().zip(&changed) {
            assert_eq!(a.key == b.key, a.lamp_name == "a", "row {}", a.index);
        }
        let moved = luxbake_testkit::temp_dir("cli-plan", "moved");
        std::fs::rename(&dir, &moved).expect("move");
        let again = plan(&moved.join("c.toml")).expect("plan");
        assert!(again.iter().zip(&changed).all(|(a, b)| a.key == b.key));
        // Errors name the key.
        for (text, needle) in [
            (
                "lamps = [\"lamps\"]\n[settings]\nrays = 0\n[[room]]\nbuiltin = \"floor\"\n",
                "settings.rays",
            ),
            (
                "lamps = [\"lamps\"]\n[settings]\nquality = \"draft\"\n[[room]]\nbuiltin = \"floor\"\n",
                "qualities",
            ),
            (
                "lamps = [\"nope.ies\"]\n[[room]]\nbuiltin = \"floor\"\n",
                "nope.ies",
            ),
            (
                "lamps = [\"lamps\"]\n[[room]]\nbuiltin = \"floor\"\nscene = \"room.toml\"\n",
                "exactly one",
            ),
            ("lamps = [\"lamps\"]\nrooms = 1\n", "unknown field"),
        ] {
            std::fs::write(moved.join("bad.toml"), text).expect("catalogue");
            let e = plan(&moved.join("bad.toml")).expect_err(needle);
            assert!(
                e.code() == crate::catalogue::USAGE && e.message().contains(needle),
                "{e:?}"
            );
        }
        std::fs::remove_dir_all(&moved).ok();
    }
}
