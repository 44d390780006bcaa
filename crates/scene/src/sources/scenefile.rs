//! The TOML scene-file format.
//!
//! A scene file describes objects, lamps and settings so that people and other tools can
//! write scenes without reading the code. Units are metres, degrees, candela; the world is
//! right-handed with +Y up (as glTF). Relative paths are relative to the scene file's folder.
//! Unknown keys and tables are errors, and every error names the key it is about (for
//! example `object[1].size` or `settings.rays`); type errors carry the line and column.
//! The full reference with an example is `docs/scene-file.md`; a complete example is
//! `crates/bake/examples/room.toml`.
//!
//! ```toml
//! [settings]                  # all optional; the CLI flags override them
//! rays = 256                  # gather rays per texel per bounce, 1..=65536
//! bounces = 1                 # indirect bounces, 0..=64: exactly this many unless tail = true
//! tail = false                # converged: add the extrapolated rest of the series (presets: true)
//! blur = 2.0                  # Gaussian sigma in texels (0 < sigma <= 64), or "none" (or 0)
//! texels_per_metre = 64.0     # light-map density, finite and > 0 (the maps: at most 2^26 texels)
//! bvh = "mtbvh"               # "wide" (default; CPU), "mtbvh", "tbvh" or "none"
//! seed = 0                    # 0..=4294967295
//! backend = "cpu"             # a backend's name, for the tool that bakes (`preferred_backend`)
//!
//! [[lamp]]                    # at least one (or an object with `lights = true`)
//! name = "downlight"          # optional, for reports
//! ies = "lamp.ies"            # .ies/.ldt path (a TILT=<file> beside it is read too),
//!                             # "isotropic:1000" (candela), or
//!                             # "builtin:downlight" (the default when omitted)
//! position = [0.0, 2.25, 0.0] # photometric centre, required
//! aim = [0.0, -1.0, 0.0]      # photometric nadir (default straight down), non-zero
//! rotation_deg = 0.0          # turn of the C0 plane about the aim axis
//! multiplier = 1.0            # >= 0
//! color = [1.0, 1.0, 1.0]     # linear RGB tint, each >= 0
//! lamp_model = "auto"         # "auto", "point" or "area": emission from the file's
//!                             # luminous opening where the scene needs it (LampModel)
//!
//! [[object]]                  # at least one
//! name = "room"               # optional (default: the primitive or builtin name, made
//!                             # unique); letters, digits, '_', '-', '.': it names files
//! primitive = "room"          # "room", "box", "plane" or "sphere" — or instead:
//! # builtin = "chair"         # "chair" or "sofa" — or instead:
//! # mesh = "sofa.glb"         # a file, loaded by a [`MeshLoader`] (luxbake-assets: glTF,
//!                             # OBJ); one object per part, named name_01, name_02, ...
//! size = [4.0, 2.5, 3.0]      # room, box: [x, y, z]; plane: [x, z]; metres, (0, 1e6]
//! # radius = 1.5              # sphere only, (0, 1e6]
//! # inward = false            # sphere and box only (a room is always inward)
//! # segments = 32             # sphere only: grid segments per cube-face edge, 1..=256
//! position = [0.0, 0.0, 0.0]  # room, box, chair, sofa: floor/base centre; plane and
//!                             # sphere: centre
//! rotation_deg = [0.0, 0.0, 0.0] # about world X, then Y, then Z
//! scale = 1.0                 # or [x, y, z]; non-zero
//! albedo = 0.5                # or [r, g, b], each in [0, 1]
//! floor_albedo = 0.3          # room only, override `albedo` per part:
//! walls_albedo = 0.7          #   also accept [r, g, b]
//! ceiling_albedo = 0.8
//! receiver = true             # false: casts shadows, gets no light map
//! texel_scale = 1.0           # multiplier on texels_per_metre for this object, (0, 100]
//! # lights = false            # mesh only: true adds the file's lights (glTF
//!                             # KHR_lights_punctual) as lamps, moved by the object's
//!                             # transform (an error if the file has none)
//! # lights_ies = "x.ies"      # with lights = true: photometry for every imported light
//!                             # instead of the file's (values as [[lamp]].ies)
//! # lights_multiplier = 1.0   # with lights = true: >= 0, on every imported light
//! ```
//!
//! A file's lights are placed by the object's transform: positions by the whole transform,
//! aims by its linear part, renormalised; their C0 rotation is kept (0); their names are
//! `object/light`. Their colour comes from the file, and so does their photometry unless
//! `lights_ies` is given. A file object's `scale` also reaches the [`MeshLoader`]
//! ([`MeshRequest::scale`]) so that generated charts keep their padding in texels.
//!
//! The `[settings]` table is a [`SettingsPatch`] (its keys, its rules for presets and for
//! `bounces` without `tail`), so its ranges are those of every bake: it goes through
//! [`Settings::validate`]. Overrides (the command line's flags) are layered over it with
//! [`from_file_patched`] *before* the objects are built, so that chart padding and the mesh
//! loader's generated UVs follow the final `texels_per_metre` and `blur`: preset, then the
//! file's keys, then the overrides.
//!
//! Defaults: `albedo` 0.5 for primitives, the built-in scenes' colours for the room
//! ([`crate::sources::builtin::ROOM_ALBEDO`]), chair and sofa; `texel_scale` 1 for primitives,
//! [`crate::sources::builtin::CHAIR_TEXEL_SCALE`] and [`crate::sources::builtin::SOFA_TEXEL_SCALE`] for the
//! built-in furniture (as in the built-in scenes).

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use luxbake_ies::{ParseOptions, Photometry};
use serde::Deserialize;
use toml::Value;

use crate::sources::builtin;
use crate::sources::meshes::{self, RoomAlbedo};
use crate::{
    Albedo, Blur, Lamp, Mesh, Object, Scene, SceneError, Settings, SettingsPatch, Transform,
};

/// Largest scene file read, bytes.
pub const MAX_SCENE_FILE_BYTES: u64 = 1 << 20;
/// Largest photometric file read, bytes.
pub const MAX_PHOTOMETRY_FILE_BYTES: u64 = 16 << 20;
/// Most objects a scene file may hold.
pub const MAX_OBJECTS: usize = 10_000;
/// Largest size or radius of a primitive, metres.
pub const MAX_SIZE_M: f64 = 1e6;
/// Most lamps a scene file may hold.
pub const MAX_LAMPS: usize = 1_000;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    /// A [`SettingsPatch`], read key by key (plus `backend`, which is no bake setting).
    settings: Option<toml::Table>,
    #[serde(default)]
    lamp: Vec<RawLamp>,
    #[serde(default)]
    object: Vec<RawObject>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLamp {
    name: Option<String>,
    ies: Option<String>,
    position: [f64; 3],
    aim: Option<[f64; 3]>,
    rotation_deg: Option<f64>,
    multiplier: Option<f64>,
    color: Option<[f64; 3]>,
    lamp_model: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawObject {
    name: Option<String>,
    primitive: Option<String>,
    builtin: Option<String>,
    mesh: Option<String>,
    size: Option<Vec<f64>>,
    radius: Option<f64>,
    inward: Option<bool>,
    segments: Option<u32>,
    position: Option<[f64; 3]>,
    rotation_deg: Option<[f64; 3]>,
    scale: Option<Value>,
    albedo: Option<Value>,
    floor_albedo: Option<Value>,
    walls_albedo: Option<Value>,
    ceiling_albedo: Option<Value>,
    receiver: Option<bool>,
    texel_scale: Option<f64>,
    lights: Option<bool>,
    lights_ies: Option<String>,
    lights_multiplier: Option<f64>,
}

/// Loads the file meshes that scene files name with `mesh = "x.glb"`. The core knows no
/// file formats: a loader is implemented elsewhere (`luxbake-assets` reads glTF and OBJ) and
/// passed to [`from_file_with`] / [`Scene::from_toml_file_with`].
pub trait MeshLoader {
    /// Loads the file of `request`: one [`MeshPart`] per part (glTF primitive, OBJ material
    /// group), each in the file's frame (the object's transform is applied by the scene
    /// file), with valid light-map UVs (generated when the file has none, their chart padding
    /// sized for `request.texels_per_metre` and `request.blur` on the surface scaled by
    /// `request.scale`), and the file's lights as lamps, also in the file's frame (the scene
    /// file adds them only for `lights = true`).
    fn load(
        &self,
        request: &MeshRequest<'_>,
    ) -> Result<LoadedFile, Box<dyn std::error::Error + Send + Sync>>;
}

/// What a [`MeshLoader`] read from one file.
#[derive(Debug, Clone, Default)]
pub struct LoadedFile {
    /// The parts; each becomes one scene object.
    pub parts: Vec<MeshPart>,
    /// The file's lights (glTF `KHR_lights_punctual`) as lamps in the file's frame: position
    /// in the file's metres, `aim` the light's direction, photometry from the file.
    pub lamps: Vec<Lamp>,
}

/// What a [`MeshLoader`] is asked to load.
#[derive(Debug, Clone, Copy)]
pub struct MeshRequest<'a> {
    /// The file, resolved against the scene file's folder (absolute paths are kept).
    pub path: &'a Path,
    /// The object's light-map density: `texels_per_metre × texel_scale`.
    pub texels_per_metre: f32,
    /// The bake's blur (chart padding should exceed its reach).
    pub blur: Blur,
    /// The object's per-axis scale (finite, non-zero): generated charts are measured on the
    /// scaled surface so their padding stays the same in texels.
    pub scale: [f32; 3],
}

/// One part of a loaded file; it becomes one scene object.
#[derive(Debug, Clone)]
pub struct MeshPart {
    /// The part's name in the file (for reports; object names come from the scene file).
    pub name: String,
    /// The geometry, in the file's frame.
    pub mesh: Mesh,
    /// Its albedo (an `albedo` key in the scene file replaces the factor, keeps the texture).
    pub albedo: Albedo,
}

impl Scene {
    /// Reads a TOML scene file (format: [`crate::sources::scenefile`]); relative paths inside
    /// it are relative to the file's folder.
    pub fn from_toml_file(path: &Path) -> Result<Scene, SceneError> {
        from_file(path)
    }

    /// [`Scene::from_toml_file`], loading file meshes (`mesh = "x.glb"`) with `loader`.
    pub fn from_toml_file_with(path: &Path, loader: &dyn MeshLoader) -> Result<Scene, SceneError> {
        from_file_with(path, loader)
    }

    /// Parses a TOML scene from text; relative paths inside it are relative to `base_dir`.
    pub fn from_toml_str(text: &str, base_dir: &Path) -> Result<Scene, SceneError> {
        from_str(text, base_dir, None)
    }
}

/// Reads and parses a scene file; `mesh = "..."` objects are an error (no loader).
pub fn from_file(path: &Path) -> Result<Scene, SceneError> {
    from_file_patched(path, None, &SettingsPatch::default())
}

/// Reads and parses a scene file, loading `mesh = "..."` objects with `loader`.
pub fn from_file_with(path: &Path, loader: &dyn MeshLoader) -> Result<Scene, SceneError> {
    from_file_patched(path, Some(loader), &SettingsPatch::default())
}

/// Reads and parses a scene file with `overrides` layered over its `[settings]`
/// ([`SettingsPatch::then`]) *before* the objects are built, so the procedural meshes' chart
/// padding and the mesh loader's UV padding follow the final `texels_per_metre` and `blur`.
/// `mesh = "..."` objects need a `loader`.
///
/// # Errors
/// As [`from_file`]; the file's `[settings]` are checked on their own first
/// ([`SceneError::Invalid`] naming `settings.<key>`), then with the overrides
/// ([`SceneError::Override`] naming the setting, for the caller to name its flag or option).
pub fn from_file_patched(
    path: &Path,
    loader: Option<&dyn MeshLoader>,
    overrides: &SettingsPatch,
) -> Result<Scene, SceneError> {
    let text = read_text(path)?;
    let base = path.parent().unwrap_or(Path::new("."));
    parse(&text, base, Some(path), loader, overrides)
}

/// The text of the scene file `path` (at most [`MAX_SCENE_FILE_BYTES`], UTF-8).
fn read_text(path: &Path) -> Result<String, SceneError> {
    let io = |source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    };
    let bytes = read_limited(path, MAX_SCENE_FILE_BYTES)
        .map_err(io)?
        .ok_or_else(|| SceneError::Toml {
            path: Some(path.to_path_buf()),
            message: format!("longer than {MAX_SCENE_FILE_BYTES} bytes, the limit of scene files"),
        })?;
    String::from_utf8(bytes).map_err(|e| SceneError::Toml {
        path: Some(path.to_path_buf()),
        message: format!("not UTF-8: {e}"),
    })
}

/// The backend the scene file `path` prefers: its `settings.backend` as written, or `None`
/// when it names none. The core knows no backend, so this is no bake [`Settings`] and its value
/// is not checked here: the caller (`cargo xtask bake`, whose `--backend` overrides it; the
/// names are `luxbake_backends::BackendKind`'s) maps the name to a backend and names the key in
/// its error. Parsing the file ([`from_file`]) checks that the key is a string.
///
/// # Errors
/// As [`from_file`] for reading the file and its TOML; `settings.backend` for a value that is
/// not a string.
pub fn preferred_backend(path: &Path) -> Result<Option<String>, SceneError> {
    let cx = Cx {
        path: Some(path.to_path_buf()),
        base_dir: PathBuf::new(),
        loader: None,
    };
    let raw = cx.raw(&read_text(path)?)?;
    raw.settings
        .and_then(|mut s| s.remove("backend"))
        .map(|b| cx.backend(&b))
        .transpose()
}

/// Parses scene-file text; relative paths are relative to `base_dir`; `path` names the file
/// in errors. `mesh = "..."` objects are an error (no loader).
pub fn from_str(text: &str, base_dir: &Path, path: Option<&Path>) -> Result<Scene, SceneError> {
    parse(text, base_dir, path, None, &SettingsPatch::default())
}

/// [`from_str`] with a [`MeshLoader`] for `mesh = "..."` objects.
pub fn from_str_with(
    text: &str,
    base_dir: &Path,
    path: Option<&Path>,
    loader: &dyn MeshLoader,
) -> Result<Scene, SceneError> {
    parse(
        text,
        base_dir,
        path,
        Some(loader),
        &SettingsPatch::default(),
    )
}

fn parse(
    text: &str,
    base_dir: &Path,
    path: Option<&Path>,
    loader: Option<&dyn MeshLoader>,
    overrides: &SettingsPatch,
) -> Result<Scene, SceneError> {
    let cx = Cx {
        path: path.map(Path::to_path_buf),
        base_dir: base_dir.to_path_buf(),
        loader,
    };
    let raw = cx.raw(text)?;
    let file = cx.settings(raw.settings)?;
    let settings = file
        .then(overrides)
        .settings()
        .map_err(SceneError::Override)?;
    let no_lamps = "a scene needs at least one [[lamp]] (or an [[object]] with `lights = true` \
                    whose file has lights)";
    if raw.lamp.is_empty() && !raw.object.iter().any(|o| o.lights == Some(true)) {
        return Err(cx.invalid("lamp", no_lamps));
    }
    if raw.lamp.len() > MAX_LAMPS {
        return Err(cx.invalid(
            "lamp",
            format!("{} lamps; at most {MAX_LAMPS}", raw.lamp.len()),
        ));
    }
    if raw.object.is_empty() {
        return Err(cx.invalid("object", "a scene needs at least one [[object]]"));
    }
    if raw.object.len() > MAX_OBJECTS {
        return Err(cx.invalid(
            "object",
            format!("{} objects; at most {MAX_OBJECTS}", raw.object.len()),
        ));
    }
    let mut lamps = raw
        .lamp
        .into_iter()
        .enumerate()
        .map(|(i, l)| cx.lamp(i, l))
        .collect::<Result<Vec<_>, _>>()?;
    let mut names = HashSet::new();
    let mut objects = Vec::new();
    for (i, o) in raw.object.into_iter().enumerate() {
        let (o, l) = cx.object(i, o, &settings, &mut names)?;
        objects.extend(o);
        if objects.len() > MAX_OBJECTS {
            return Err(cx.invalid(
                format!("object[{i}]"),
                format!("the scene now has more than {MAX_OBJECTS} objects"),
            ));
        }
        lamps.extend(l);
        if lamps.len() > MAX_LAMPS {
            return Err(cx.invalid(
                format!("object[{i}].lights"),
                format!("the scene now has more than {MAX_LAMPS} lamps"),
            ));
        }
    }
    if lamps.is_empty() {
        return Err(cx.invalid("lamp", no_lamps));
    }
    Ok(Scene {
        objects,
        lamps,
        settings,
    })
}

struct Cx<'a> {
    path: Option<PathBuf>,
    base_dir: PathBuf,
    loader: Option<&'a dyn MeshLoader>,
}

impl Cx<'_> {
    fn invalid(&self, key: impl Into<String>, message: impl Into<String>) -> SceneError {
        SceneError::Invalid {
            path: self.path.clone(),
            key: key.into(),
            message: message.into(),
        }
    }

    fn raw(&self, text: &str) -> Result<RawScene, SceneError> {
        toml::from_str(text).map_err(|e| SceneError::Toml {
            path: self.path.clone(),
            message: e.to_string(),
        })
    }

    fn backend(&self, value: &Value) -> Result<String, SceneError> {
        value.as_str().map(str::to_owned).ok_or_else(|| {
            self.invalid(
                "settings.backend",
                format!("{value}; expected a backend's name (a string)"),
            )
        })
    }

    /// The `[settings]` table as a patch (`backend` checked and left out), checked on its own
    /// by [`Settings::validate`]; errors name `settings.<key>`.
    fn settings(&self, raw: Option<toml::Table>) -> Result<SettingsPatch, SceneError> {
        let mut table = raw.unwrap_or_default();
        // Not a bake setting: checked here, read by `preferred_backend`.
        if let Some(b) = table.remove("backend") {
            self.backend(&b)?;
        }
        let entries: Vec<(String, Value)> = table.into_iter().collect();
        let invalid = |key: &str, message| match key {
            "" => self.invalid("settings", message),
            key => self.invalid(format!("settings.{key}"), message),
        };
        let patch =
            SettingsPatch::from_entries(&entries).map_err(|e| invalid(&e.key, e.message))?;
        patch.settings().map_err(|e| invalid(e.name, e.reason))?;
        Ok(patch)
    }

    fn lamp(&self, i: usize, raw: RawLamp) -> Result<Lamp, SceneError> {
        let key = |k: &str| format!("lamp[{i}].{k}");
        let ies = raw.ies.as_deref().unwrap_or("builtin:downlight");
        let photometry = self.photometry(&key("ies"), ies)?;
        let position = self.finite3_f64(&key("position"), raw.position)?;
        let mut lamp = Lamp::new(
            raw.name.unwrap_or_else(|| format!("lamp_{i}")),
            photometry,
            position,
        );
        if let Some(aim) = raw.aim {
            lamp.aim = self.finite3(&key("aim"), aim)?;
        }
        if let Some(r) = raw.rotation_deg {
            lamp.rotation_deg = self.finite(&key("rotation_deg"), r)?;
        }
        if let Some(m) = raw.multiplier {
            lamp.multiplier = m as f32;
        }
        if let Some(c) = raw.color {
            lamp.color = c.map(|v| v as f32);
        }
        if let Some(m) = raw.lamp_model {
            lamp.model = m
                .parse()
                .map_err(|e: String| self.invalid(key("lamp_model"), e))?;
        }
        // The ranges every bake input shares (a zero aim, a negative multiplier or colour).
        lamp.validate()
            .map_err(|e| self.invalid(key(e.name), e.reason))?;
        Ok(lamp)
    }

    fn photometry(&self, key: &str, ies: &str) -> Result<Arc<Photometry>, SceneError> {
        if let Some(cd) = ies.strip_prefix("isotropic:") {
            let cd: f64 = cd.trim().parse().map_err(|_| {
                self.invalid(
                    key,
                    format!("`{ies}`: expected \"isotropic:<candela>\", e.g. \"isotropic:1000\""),
                )
            })?;
            if !(cd >= 0.0 && cd.is_finite()) {
                return Err(self.invalid(
                    key,
                    format!("`{ies}`: the intensity must be finite and >= 0"),
                ));
            }
            return Ok(Arc::new(Photometry::isotropic(cd)));
        }
        if let Some(name) = ies.strip_prefix("builtin:") {
            return match name {
                "downlight" => builtin::default_photometry(),
                _ => Err(self.invalid(
                    key,
                    format!("`{ies}`: the only built-in lamp is \"builtin:downlight\""),
                )),
            };
        }
        let file = self.base_dir.join(ies);
        read_photometry(&file).map_err(|e| match e {
            PhotometryFileError::Parse { file, source } => SceneError::Photometry {
                key: key.to_string(),
                file,
                source,
            },
            e => self.invalid(key, e.to_string()),
        })
    }

    fn object(
        &self,
        i: usize,
        raw: RawObject,
        settings: &Settings,
        names: &mut HashSet<String>,
    ) -> Result<(Vec<Object>, Vec<Lamp>), SceneError> {
        let key = |k: &str| format!("object[{i}].{k}");
        let given = [&raw.primitive, &raw.builtin, &raw.mesh]
            .iter()
            .filter(|v| v.is_some())
            .count();
        if given > 1 {
            return Err(self.invalid(
                format!("object[{i}]"),
                "give exactly one of `primitive`, `builtin` and `mesh`",
            ));
        }
        let kind = match (&raw.primitive, &raw.builtin) {
            (None, None) if raw.mesh.is_some() => "mesh".to_string(),
            (Some(p), None) => match p.as_str() {
                "room" | "box" | "plane" | "sphere" => p.clone(),
                _ => {
                    return Err(self.invalid(
                        key("primitive"),
                        format!("`{p}`; expected \"room\", \"box\", \"plane\" or \"sphere\""),
                    ));
                }
            },
            (None, Some(b)) => match b.as_str() {
                "chair" | "sofa" => b.clone(),
                _ => {
                    return Err(self.invalid(
                        key("builtin"),
                        format!(
                            "`{b}`; expected \"chair\" or \"sofa\" (files: `mesh = \"x.glb\"`)"
                        ),
                    ));
                }
            },
            _ => {
                return Err(self.invalid(
                    format!("object[{i}]"),
                    "missing `primitive` (\"room\", \"box\", \"plane\", \"sphere\"), `builtin` (\"chair\", \"sofa\") or `mesh` (a file)",
                ));
            }
        };
        // Keys that only some kinds accept.
        let only = |present: bool, k: &str, kinds: &[&str], what: &str| {
            if present && !kinds.contains(&kind.as_str()) {
                Err(self.invalid(
                    key(k),
                    format!("a {kind} has no {what} (only {})", kinds.join(", ")),
                ))
            } else {
                Ok(())
            }
        };
        only(
            raw.size.is_some(),
            "size",
            &["room", "box", "plane"],
            "`size`",
        )?;
        only(raw.radius.is_some(), "radius", &["sphere"], "`radius`")?;
        only(
            raw.inward.is_some(),
            "inward",
            &["sphere", "box"],
            "`inward`",
        )?;
        only(
            raw.segments.is_some(),
            "segments",
            &["sphere"],
            "`segments`",
        )?;
        for (present, k) in [
            (raw.floor_albedo.is_some(), "floor_albedo"),
            (raw.walls_albedo.is_some(), "walls_albedo"),
            (raw.ceiling_albedo.is_some(), "ceiling_albedo"),
        ] {
            only(present, k, &["room"], &format!("`{k}`"))?;
        }
        for (present, k) in [
            (raw.lights.is_some(), "lights"),
            (raw.lights_ies.is_some(), "lights_ies"),
            (raw.lights_multiplier.is_some(), "lights_multiplier"),
        ] {
            only(present, k, &["mesh"], &format!("`{k}`"))?;
        }
        let lights = raw.lights.unwrap_or(false);
        for (present, k) in [
            (raw.lights_ies.is_some(), "lights_ies"),
            (raw.lights_multiplier.is_some(), "lights_multiplier"),
        ] {
            if present && !lights {
                return Err(self.invalid(key(k), "only with `lights = true`"));
            }
        }
        let lights_photometry = raw
            .lights_ies
            .as_deref()
            .map(|ies| self.photometry(&key("lights_ies"), ies))
            .transpose()?;
        let lights_multiplier = match raw.lights_multiplier {
            None => 1.0,
            Some(m) if m >= 0.0 && m.is_finite() => m as f32,
            Some(m) => {
                return Err(self.invalid(
                    key("lights_multiplier"),
                    format!("{m}; expected a finite number >= 0"),
                ));
            }
        };

        let texel_scale = match raw.texel_scale {
            Some(t) if t > 0.0 && t <= 100.0 => t as f32,
            Some(t) => {
                return Err(self.invalid(
                    key("texel_scale"),
                    format!("{t}; expected 0 < texel_scale <= 100"),
                ));
            }
            None => match kind.as_str() {
                "chair" => builtin::CHAIR_TEXEL_SCALE,
                "sofa" => builtin::SOFA_TEXEL_SCALE,
                _ => 1.0,
            },
        };
        let padding = builtin::padding_m(settings, texel_scale);
        let albedo = raw
            .albedo
            .as_ref()
            .map(|v| self.rgb(&key("albedo"), v))
            .transpose()?;
        let default_albedo = match kind.as_str() {
            "chair" => builtin::CHAIR_ALBEDO,
            "sofa" => builtin::SOFA_ALBEDO,
            _ => [0.5; 3],
        };
        let mut factor = albedo.unwrap_or(default_albedo);
        let size3 = |n: usize| -> Result<Vec<f32>, SceneError> {
            let Some(s) = &raw.size else {
                return Err(self.invalid(
                    key("size"),
                    format!("a {kind} needs `size` ({n} numbers, metres)"),
                ));
            };
            if s.len() != n || !s.iter().all(|&v| v > 0.0 && v <= MAX_SIZE_M) {
                return Err(self.invalid(
                    key("size"),
                    format!("{s:?}; expected {n} numbers in (0, 1e6] (metres)"),
                ));
            }
            Ok(s.iter().map(|&v| v as f32).collect())
        };
        let mesh = match kind.as_str() {
            "mesh" => None,
            "room" => Some({
                let s = size3(3)?;
                let base = albedo.map_or(builtin::ROOM_ALBEDO, RoomAlbedo::uniform);
                let part = |v: &Option<Value>, k: &str, d: [f32; 3]| match v {
                    Some(v) => self.rgb(&key(k), v),
                    None => Ok(d),
                };
                let parts = RoomAlbedo {
                    floor: part(&raw.floor_albedo, "floor_albedo", base.floor)?,
                    walls: part(&raw.walls_albedo, "walls_albedo", base.walls)?,
                    ceiling: part(&raw.ceiling_albedo, "ceiling_albedo", base.ceiling)?,
                };
                factor = [1.0; 3];
                meshes::room([s[0], s[1], s[2]], parts, padding)
            }),
            "box" => {
                let s = size3(3)?;
                Some(meshes::cuboid(
                    [s[0], s[1], s[2]],
                    raw.inward.unwrap_or(false),
                    padding,
                ))
            }
            "plane" => {
                let s = size3(2)?;
                Some(meshes::plane([s[0], s[1]], padding))
            }
            "sphere" => {
                let r = match raw.radius {
                    Some(r) if r > 0.0 && r <= MAX_SIZE_M => r as f32,
                    Some(r) => {
                        return Err(self.invalid(
                            key("radius"),
                            format!("{r}; expected a number in (0, 1e6] (metres)"),
                        ));
                    }
                    None => {
                        return Err(self.invalid(key("radius"), "a sphere needs `radius` (metres)"));
                    }
                };
                let segments = match raw.segments {
                    Some(n) if (1..=256).contains(&n) => n,
                    Some(n) => {
                        return Err(self.invalid(key("segments"), format!("{n}; expected 1..=256")));
                    }
                    None => meshes::SPHERE_SEGMENTS,
                };
                Some(meshes::sphere(
                    r,
                    segments,
                    raw.inward.unwrap_or(false),
                    padding,
                ))
            }
            "chair" => Some(meshes::chair(padding)),
            _ => Some(meshes::sofa(padding)),
        };
        let scale = match &raw.scale {
            None => [1.0; 3],
            Some(v) => {
                let s = match v {
                    Value::Array(_) => self.vec3(&key("scale"), v)?,
                    _ => {
                        [number(v).ok_or_else(|| {
                            self.invalid(
                                key("scale"),
                                format!("{v}; expected a number or [x, y, z]"),
                            )
                        })?; 3]
                    }
                };
                if !s
                    .iter()
                    .all(|&c| c.is_finite() && c != 0.0 && c.abs() <= 1e6)
                {
                    return Err(self.invalid(
                        key("scale"),
                        format!("{s:?}; expected finite, non-zero factors"),
                    ));
                }
                s.map(|c| c as f32)
            }
        };
        let mut file_lamps = Vec::new();
        let parts: Vec<(Mesh, Albedo)> = match (mesh, &raw.mesh) {
            (Some(m), _) => vec![(
                m,
                Albedo {
                    factor,
                    texture: None,
                },
            )],
            (None, Some(file)) => {
                let Some(loader) = self.loader else {
                    return Err(self.invalid(
                        key("mesh"),
                        "file meshes need a mesh loader: bake with `cargo xtask bake`, or pass \
                         luxbake-assets' loader to `Scene::from_toml_file_with`",
                    ));
                };
                let file = self.base_dir.join(file);
                let request = MeshRequest {
                    path: &file,
                    texels_per_metre: settings.texels_per_metre * texel_scale,
                    blur: settings.blur,
                    scale,
                };
                let loaded = loader
                    .load(&request)
                    .map_err(|source| SceneError::MeshFile {
                        key: key("mesh"),
                        file: file.clone(),
                        source,
                    })?;
                if loaded.parts.is_empty() {
                    return Err(self.invalid(
                        key("mesh"),
                        format!("`{}` holds no triangle mesh", file.display()),
                    ));
                }
                if lights {
                    if loaded.lamps.is_empty() {
                        return Err(self.invalid(
                            key("lights"),
                            format!("`{}` holds no lights", file.display()),
                        ));
                    }
                    file_lamps = loaded.lamps;
                }
                loaded
                    .parts
                    .into_iter()
                    .map(|p| {
                        let mut a = p.albedo;
                        if let Some(f) = albedo {
                            a.factor = f;
                        }
                        (p.mesh, a)
                    })
                    .collect()
            }
            (None, None) => Vec::new(),
        };

        let position = match raw.position {
            Some(p) => self.finite3_f64(&key("position"), p)?,
            None => [0.0; 3],
        };
        let rotation = match raw.rotation_deg {
            Some(r) => self.finite3(&key("rotation_deg"), r)?,
            None => [0.0; 3],
        };
        let name = match raw.name {
            Some(n) => {
                let ok = !n.is_empty()
                    && n.len() <= 100
                    && !n.starts_with('.')
                    && n.chars()
                        .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'));
                if !ok {
                    return Err(self.invalid(
                        key("name"),
                        format!("`{n}`: use 1 to 100 letters, digits, '_', '-', '.' (not first): it names output files"),
                    ));
                }
                if names.contains(&n) {
                    return Err(self.invalid(
                        key("name"),
                        format!("`{n}` is already the name of another object"),
                    ));
                }
                n
            }
            None => {
                let stem = raw
                    .mesh
                    .as_deref()
                    .and_then(|f| Path::new(f).file_stem())
                    .map(|s| {
                        s.to_string_lossy()
                            .chars()
                            .filter(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-'))
                            .take(60)
                            .collect::<String>()
                    })
                    .filter(|s| !s.is_empty());
                let base = stem.unwrap_or_else(|| kind.clone());
                let mut n = base.clone();
                let mut k = 2;
                while names.contains(&n) {
                    n = format!("{base}_{k}");
                    k += 1;
                }
                n
            }
        };
        let transform = Transform::from_trs(position, rotation, scale);
        // The file's lights, in world space: positions by the full transform, aims by its
        // linear part, renormalised.
        let lamps = file_lamps
            .into_iter()
            .map(|mut l| {
                l.name = format!("{name}/{}", l.name);
                l.position = transform.point_f64(l.position);
                let m = &transform.linear;
                let a = l.aim;
                let aim: [f32; 3] =
                    std::array::from_fn(|r| m[0][r] * a[0] + m[1][r] * a[1] + m[2][r] * a[2]);
                let len = aim.iter().map(|c| c * c).sum::<f32>().sqrt();
                if len > 0.0 && len.is_finite() {
                    l.aim = aim.map(|c| c / len);
                }
                if let Some(p) = &lights_photometry {
                    l.photometry = Arc::clone(p);
                }
                l.multiplier *= lights_multiplier;
                l
            })
            .collect();
        let receiver = raw.receiver.unwrap_or(true);
        let count = parts.len();
        let mut objects = Vec::with_capacity(count);
        for (k, (mesh, albedo)) in parts.into_iter().enumerate() {
            // Several parts of one file: name_01, name_02, ...
            let mut n = if count == 1 {
                name.clone()
            } else {
                format!("{name}_{:02}", k + 1)
            };
            let mut extra = 2;
            while names.contains(&n) {
                n = format!("{name}_{:02}_{extra}", k + 1);
                extra += 1;
            }
            names.insert(n.clone());
            objects.push(Object {
                name: n,
                mesh,
                transform,
                albedo,
                receiver,
                texel_scale,
            });
        }
        Ok((objects, lamps))
    }

    fn finite(&self, key: &str, v: f64) -> Result<f32, SceneError> {
        if v.is_finite() && v.abs() <= 1e9 {
            Ok(v as f32)
        } else {
            Err(self.invalid(key, format!("{v}; expected a finite number")))
        }
    }

    fn finite3(&self, key: &str, v: [f64; 3]) -> Result<[f32; 3], SceneError> {
        Ok(self.finite3_f64(key, v)?.map(|c| c as f32))
    }

    /// [`Self::finite3`] kept in double precision (world placements).
    fn finite3_f64(&self, key: &str, v: [f64; 3]) -> Result<[f64; 3], SceneError> {
        if v.iter().all(|c| c.is_finite() && c.abs() <= 1e9) {
            Ok(v)
        } else {
            Err(self.invalid(key, format!("{v:?}; expected three finite numbers")))
        }
    }

    fn vec3(&self, key: &str, v: &Value) -> Result<[f64; 3], SceneError> {
        let bad = || self.invalid(key, format!("{v}; expected an array of three numbers"));
        let Value::Array(a) = v else {
            return Err(bad());
        };
        if a.len() != 3 {
            return Err(bad());
        }
        let n: Vec<f64> = a
            .iter()
            .map(number)
            .collect::<Option<_>>()
            .ok_or_else(bad)?;
        Ok([n[0], n[1], n[2]])
    }

    /// An albedo: a number or [r, g, b], each in [0, 1].
    fn rgb(&self, key: &str, v: &Value) -> Result<[f32; 3], SceneError> {
        let c = match v {
            Value::Array(_) => self.vec3(key, v)?,
            _ => {
                [number(v).ok_or_else(|| {
                    self.invalid(key, format!("{v}; expected a number or [r, g, b]"))
                })?; 3]
            }
        };
        if c.iter().all(|&x| (0.0..=1.0).contains(&x)) {
            Ok(c.map(|x| x as f32))
        } else {
            Err(self.invalid(key, format!("{v}; albedo components must lie in [0, 1]")))
        }
    }
}

/// Reads at most `limit` bytes of `path`: `Ok(None)` when the file is longer. Reads through
/// the handle rather than trusting the file's reported size (devices and pipes report 0).
/// A photometric file that [`read_photometry`] could not read.
#[derive(Debug, thiserror::Error)]
pub enum PhotometryFileError {
    /// The file could not be opened or read.
    #[error("cannot read `{}`: {source}", file.display())]
    Read {
        /// The file.
        file: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The file is longer than [`MAX_PHOTOMETRY_FILE_BYTES`].
    #[error("`{}` is longer than {MAX_PHOTOMETRY_FILE_BYTES} bytes", file.display())]
    TooLong {
        /// The file.
        file: PathBuf,
    },
    /// The file is neither valid IES LM-63 nor valid EULUMDAT.
    #[error("cannot parse photometric file `{}`: {source}", file.display())]
    Parse {
        /// The file.
        file: PathBuf,
        /// The parser's error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
}

/// Reads an IES LM-63 or EULUMDAT file as a scene file's `ies` key does: at most
/// [`MAX_PHOTOMETRY_FILE_BYTES`], a `TILT=<file>` naming a plain file beside it.
///
/// # Errors
/// [`PhotometryFileError`] naming the file.
pub fn read_photometry(file: &Path) -> Result<Arc<Photometry>, PhotometryFileError> {
    let bytes = read_limited(file, MAX_PHOTOMETRY_FILE_BYTES)
        .map_err(|source| PhotometryFileError::Read {
            file: file.to_path_buf(),
            source,
        })?
        .ok_or_else(|| PhotometryFileError::TooLong {
            file: file.to_path_buf(),
        })?;
    // `TILT=<file>` names a file beside the photometric file (a plain file name only).
    let folder = file.parent().map(Path::to_path_buf).unwrap_or_default();
    let resolve = |name: &str| -> Option<Vec<u8>> {
        let name = name.trim();
        let plain = Path::new(name).file_name().is_some_and(|f| f == name);
        if !plain {
            return None;
        }
        read_limited(&folder.join(name), MAX_PHOTOMETRY_FILE_BYTES).ok()?
    };
    let options = ParseOptions {
        tilt_resolver: Some(&resolve),
        ..ParseOptions::default()
    };
    Photometry::parse_with(&bytes, &options)
        .map(Arc::new)
        .map_err(|e| PhotometryFileError::Parse {
            file: file.to_path_buf(),
            source: Box::new(e),
        })
}

fn read_limited(path: &Path, limit: u64) -> std::io::Result<Option<Vec<u8>>> {
    use std::io::Read;
    let mut bytes = Vec::new();
    std::fs::File::open(path)?
        .take(limit + 1)
        .read_to_end(&mut bytes)?;
    Ok((bytes.len() as u64 <= limit).then_some(bytes))
}

fn number(v: &Value) -> Option<f64> {
    match v {
        Value::Float(f) => Some(*f),
        Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Blur, BvhMode};

    const LAMP: &str = "position = [0.0, 2.0, 0.0]\nies = \"isotropic:100\"";
    const OBJECT: &str = "primitive = \"plane\"\nsize = [1.0, 1.0]";

    fn text(settings: &str, lamp: &str, object: &str) -> String {
        format!("[settings]\n{settings}\n[[lamp]]\n{lamp}\n[[object]]\n{object}\n")
    }

    fn parse(t: &str) -> Result<Scene, SceneError> {
        from_str(t, Path::new(env!("CARGO_MANIFEST_DIR")), None)
    }

    fn err(t: &str) -> String {
        match parse(t) {
            Ok(_) => panic!("accepted:\n{t}"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn lamp_paths_are_a_setting_with_its_limit() {
        let s = parse(&text("lamp_paths = 5", LAMP, OBJECT)).expect("parses");
        assert_eq!(s.settings.lamp_paths, 5);
        let s = parse(&text("lamp_paths = 0", LAMP, OBJECT)).expect("parses");
        assert_eq!(s.settings.lamp_paths, 0);
        let e = err(&text("lamp_paths = 5000", LAMP, OBJECT));
        assert!(
            e.contains("settings.lamp_paths") && e.contains("5000"),
            "{e}"
        );
    }

    #[test]
    fn minimal_scene_and_defaults() {
        let s = parse(&text("", LAMP, OBJECT)).expect("parses");
        assert_eq!(s.settings, Settings::default());
        assert_eq!(s.lamps.len(), 1);
        assert_eq!(s.lamps[0].aim, [0.0, -1.0, 0.0]);
        assert_eq!((s.lamps[0].rotation_deg, s.lamps[0].multiplier), (0.0, 1.0));
        let i = s.lamps[0].photometry.intensity([0.3, 0.2, -0.9]);
        assert!((i - 100.0).abs() < 1e-9, "isotropic:100 gives 100 cd: {i}");
        let o = &s.objects[0];
        assert_eq!(
            (o.name.as_str(), o.receiver, o.texel_scale),
            ("plane", true, 1.0)
        );
        assert_eq!(o.albedo.factor, [0.5; 3]);
        assert_eq!(o.transform, Transform::IDENTITY);
        // The default lamp is the embedded downlight.
        let s = parse(&text("", "position = [0.0, 2.0, 0.0]", OBJECT)).expect("parses");
        assert!(Arc::ptr_eq(
            &s.lamps[0].photometry,
            &builtin::default_photometry().expect("lamp")
        ));
    }

    #[test]
    fn every_key_is_read() {
        let settings = "rays = 64\nbounces = 3\nblur = \"none\"\ntexels_per_metre = 32\nbvh = \"tbvh\"\nseed = 9\nbackend = \"wgpu\"";
        let lamp = "name = \"l\"\nies = \"builtin:downlight\"\nposition = [1, 2, 3]\naim = [1.0, 0.0, 0.0]\nrotation_deg = 45\nmultiplier = 2.5\ncolor = [1.0, 0.5, 0.25]";
        let objects = "name = \"r\"\nprimitive = \"room\"\nsize = [4, 2.5, 3]\nposition = [1, 0, 0]\nalbedo = 0.6\nfloor_albedo = [0.1, 0.2, 0.3]\nwalls_albedo = 0.4\nceiling_albedo = 0.9\nreceiver = false\ntexel_scale = 0.5\n\
            [[object]]\nprimitive = \"sphere\"\nradius = 0.5\ninward = true\nsegments = 4\nrotation_deg = [0, 90, 0]\nscale = [1, 2, 1]\n\
            [[object]]\nprimitive = \"box\"\nsize = [1, 1, 1]\ninward = true\nscale = 2\n\
            [[object]]\nbuiltin = \"chair\"\n[[object]]\nbuiltin = \"chair\"\n[[object]]\nbuiltin = \"sofa\"\nalbedo = [0.1, 0.1, 0.1]";
        let s = parse(&text(settings, lamp, objects)).expect("parses");
        let st = &s.settings;
        assert_eq!((st.rays, st.bounces, st.seed), (64, 3, 9));
        assert_eq!(
            (st.blur, st.texels_per_metre, st.bvh),
            (Blur::None, 32.0, BvhMode::Tbvh)
        );
        let l = &s.lamps[0];
        assert_eq!(
            (l.name.as_str(), l.position, l.aim),
            ("l", [1.0, 2.0, 3.0], [1.0, 0.0, 0.0])
        );
        assert_eq!(
            (l.rotation_deg, l.multiplier, l.color),
            (45.0, 2.5, [1.0, 0.5, 0.25])
        );
        let names: Vec<&str> = s.objects.iter().map(|o| o.name.as_str()).collect();
        assert_eq!(names, ["r", "sphere", "box", "chair", "chair_2", "sofa"]);
        let room = &s.objects[0];
        assert_eq!(
            (room.receiver, room.texel_scale, room.albedo.factor),
            (false, 0.5, [1.0; 3])
        );
        let colors = room.mesh.colors.as_ref().expect("room colours");
        assert!(
            colors.contains(&[0.1, 0.2, 0.3])
                && colors.contains(&[0.4; 3])
                && colors.contains(&[0.9; 3])
        );
        assert!(!colors.contains(&[0.6; 3]), "all three parts overridden");
        assert_eq!(room.transform.point([0.0; 3]), [1.0, 0.0, 0.0]);
        let sphere = &s.objects[1];
        assert_eq!(sphere.mesh.triangle_count(), 6 * 2 * 16);
        assert!(
            sphere.mesh.normals[0]
                .iter()
                .zip(&sphere.mesh.positions[0])
                .map(|(n, p)| n * p)
                .sum::<f32>()
                < 0.0
        );
        let p = sphere.transform.point([1.0, 1.0, 0.0]);
        assert!(
            (p[0] - 0.0).abs() < 1e-6 && (p[1] - 2.0).abs() < 1e-6 && (p[2] + 1.0).abs() < 1e-6,
            "{p:?}"
        );
        assert_eq!(
            s.objects[2].transform.point([1.0, 1.0, 1.0]),
            [2.0, 2.0, 2.0]
        );
        assert_eq!(s.objects[3].texel_scale, builtin::CHAIR_TEXEL_SCALE);
        assert_eq!(s.objects[3].albedo.factor, builtin::CHAIR_ALBEDO);
        assert_eq!(s.objects[5].mesh.triangle_count(), meshes::SOFA_TRIANGLES);
        assert_eq!(s.objects[5].albedo.factor, [0.1; 3]);
        // Blur as a number; integers where floats are expected.
        let s = parse(&text("blur = 3", LAMP, OBJECT)).expect("parses");
        assert_eq!(s.settings.blur, Blur::Sigma(3.0));
    }

    #[test]
    fn every_bad_value_names_its_key() {
        let cases: &[(&str, &str, &str, &str)] = &[
            // (settings, lamp, object, key the message must contain)
            ("rays = 0", LAMP, OBJECT, "settings.rays"),
            ("rays = -1", LAMP, OBJECT, "rays"),
            ("rays = \"many\"", LAMP, OBJECT, "rays"),
            ("bounces = 65", LAMP, OBJECT, "settings.bounces"),
            ("blur = -1.0", LAMP, OBJECT, "settings.blur"),
            ("blur = \"soft\"", LAMP, OBJECT, "settings.blur"),
            ("blur = true", LAMP, OBJECT, "settings.blur"),
            (
                "texels_per_metre = 0",
                LAMP,
                OBJECT,
                "settings.texels_per_metre",
            ),
            (
                "texels_per_metre = nan",
                LAMP,
                OBJECT,
                "settings.texels_per_metre",
            ),
            ("bvh = \"kd\"", LAMP, OBJECT, "settings.bvh"),
            ("seed = -3", LAMP, OBJECT, "seed"),
            ("backend = 3", LAMP, OBJECT, "settings.backend"),
            ("raus = 3", LAMP, OBJECT, "raus"),
            ("", "ies = \"isotropic:1\"", OBJECT, "position"),
            ("", "position = [0.0, 1.0]", OBJECT, "position"),
            ("", "position = [nan, 1.0, 0.0]", OBJECT, "lamp[0].position"),
            (
                "",
                "position = [0, 1, 0]\naim = [0, 0, 0]",
                OBJECT,
                "lamp[0].aim",
            ),
            (
                "",
                "position = [0, 1, 0]\naim = [inf, 0, 0]",
                OBJECT,
                "lamp[0].aim",
            ),
            (
                "",
                "position = [0, 1, 0]\nrotation_deg = \"x\"",
                OBJECT,
                "rotation_deg",
            ),
            (
                "",
                "position = [0, 1, 0]\nrotation_deg = inf",
                OBJECT,
                "lamp[0].rotation_deg",
            ),
            (
                "",
                "position = [0, 1, 0]\nmultiplier = -1",
                OBJECT,
                "lamp[0].multiplier",
            ),
            (
                "",
                "position = [0, 1, 0]\ncolor = [-1, 0, 0]",
                OBJECT,
                "lamp[0].color",
            ),
            (
                "",
                "position = [0, 1, 0]\nies = \"isotropic:abc\"",
                OBJECT,
                "lamp[0].ies",
            ),
            (
                "",
                "position = [0, 1, 0]\nies = \"isotropic:-5\"",
                OBJECT,
                "lamp[0].ies",
            ),
            (
                "",
                "position = [0, 1, 0]\nies = \"builtin:spot\"",
                OBJECT,
                "lamp[0].ies",
            ),
            (
                "",
                "position = [0, 1, 0]\nies = \"no/such/file.ies\"",
                OBJECT,
                "lamp[0].ies",
            ),
            (
                "",
                "position = [0, 1, 0]\nies = \"Cargo.toml\"",
                OBJECT,
                "lamp[0].ies",
            ),
            ("", "position = [0, 1, 0]\nwatts = 3", OBJECT, "watts"),
            ("", LAMP, "primitive = \"cone\"", "object[0].primitive"),
            ("", LAMP, "builtin = \"table\"", "object[0].builtin"),
            (
                "",
                LAMP,
                "builtin = \"chair\"\nprimitive = \"box\"",
                "`object[0]`: give exactly one",
            ),
            ("", LAMP, "name = \"x\"", "object[0]"),
            ("", LAMP, "primitive = \"plane\"", "object[0].size"),
            (
                "",
                LAMP,
                "primitive = \"plane\"\nsize = [1.0]",
                "object[0].size",
            ),
            (
                "",
                LAMP,
                "primitive = \"box\"\nsize = [1.0, 1.0]",
                "object[0].size",
            ),
            (
                "",
                LAMP,
                "primitive = \"plane\"\nsize = [1.0, -1.0]",
                "object[0].size",
            ),
            ("", LAMP, "primitive = \"plane\"\nsize = \"big\"", "size"),
            ("", LAMP, "primitive = \"sphere\"", "object[0].radius"),
            (
                "",
                LAMP,
                "primitive = \"sphere\"\nradius = 0",
                "object[0].radius",
            ),
            (
                "",
                LAMP,
                "primitive = \"sphere\"\nradius = 1\nsegments = 0",
                "object[0].segments",
            ),
            (
                "",
                LAMP,
                "primitive = \"sphere\"\nradius = 1\nsegments = 257",
                "object[0].segments",
            ),
            (
                "",
                LAMP,
                "primitive = \"sphere\"\nradius = 1\nsize = [1, 1, 1]",
                "object[0].size",
            ),
            (
                "",
                LAMP,
                "primitive = \"plane\"\nsize = [1, 1]\nradius = 1",
                "object[0].radius",
            ),
            (
                "",
                LAMP,
                "primitive = \"plane\"\nsize = [1, 1]\nsegments = 4",
                "object[0].segments",
            ),
            (
                "",
                LAMP,
                "primitive = \"room\"\nsize = [1, 1, 1]\ninward = false",
                "object[0].inward",
            ),
            (
                "",
                LAMP,
                "primitive = \"box\"\nsize = [1, 1, 1]\nfloor_albedo = 0.5",
                "object[0].floor_albedo",
            ),
            (
                "",
                LAMP,
                "builtin = \"sofa\"\nwalls_albedo = 0.5",
                "object[0].walls_albedo",
            ),
            (
                "",
                LAMP,
                "builtin = \"sofa\"\nceiling_albedo = 0.5",
                "object[0].ceiling_albedo",
            ),
            (
                "",
                LAMP,
                "builtin = \"sofa\"\nsize = [1, 1, 1]",
                "object[0].size",
            ),
            (
                "",
                LAMP,
                "builtin = \"chair\"\nalbedo = 1.5",
                "object[0].albedo",
            ),
            (
                "",
                LAMP,
                "builtin = \"chair\"\nalbedo = [1, 1]",
                "object[0].albedo",
            ),
            (
                "",
                LAMP,
                "builtin = \"chair\"\nalbedo = \"red\"",
                "object[0].albedo",
            ),
            (
                "",
                LAMP,
                "primitive = \"room\"\nsize = [1, 1, 1]\nfloor_albedo = -0.1",
                "object[0].floor_albedo",
            ),
            (
                "",
                LAMP,
                "builtin = \"chair\"\nscale = 0",
                "object[0].scale",
            ),
            (
                "",
                LAMP,
                "builtin = \"chair\"\nscale = [1, 0, 1]",
                "object[0].scale",
            ),
            (
                "",
                LAMP,
                "builtin = \"chair\"\nscale = \"big\"",
                "object[0].scale",
            ),
            (
                "",
                LAMP,
                "builtin = \"chair\"\nposition = [1, 2]",
                "position",
            ),
            (
                "",
                LAMP,
                "builtin = \"chair\"\nposition = [1, 2, inf]",
                "object[0].position",
            ),
            (
                "",
                LAMP,
                "builtin = \"chair\"\nrotation_deg = [0, \"x\", 0]",
                "rotation_deg",
            ),
            (
                "",
                LAMP,
                "builtin = \"chair\"\nrotation_deg = [0, nan, 0]",
                "object[0].rotation_deg",
            ),
            ("", LAMP, "builtin = \"chair\"\nreceiver = 3", "receiver"),
            (
                "",
                LAMP,
                "builtin = \"chair\"\ntexel_scale = 0",
                "object[0].texel_scale",
            ),
            (
                "",
                LAMP,
                "builtin = \"chair\"\ntexel_scale = 1000",
                "object[0].texel_scale",
            ),
            (
                "",
                LAMP,
                "builtin = \"chair\"\nname = \"../evil\"",
                "object[0].name",
            ),
            (
                "",
                LAMP,
                "builtin = \"chair\"\nname = \"\"",
                "object[0].name",
            ),
            (
                "",
                LAMP,
                "builtin = \"chair\"\nname = \"a\"\n[[object]]\nbuiltin = \"sofa\"\nname = \"a\"",
                "object[1].name",
            ),
            ("", LAMP, "builtin = \"chair\"\ncolour = 1", "colour"),
        ];
        for (settings, lamp, object, key) in cases {
            let t = text(settings, lamp, object);
            let e = err(&t);
            assert!(
                e.contains(key),
                "error for\n{t}\ndoes not name `{key}`: {e}"
            );
        }
        // Whole-file problems.
        assert!(err("[camera]\nfov = 60\n").contains("camera"));
        assert!(err(&format!("[[object]]\n{OBJECT}\n")).contains("`lamp`"));
        assert!(err(&format!("[[lamp]]\n{LAMP}\n")).contains("`object`"));
        assert!(err("[[lamp]\n").contains("line 1"));
    }

    #[test]
    fn files_and_relative_paths() {
        let dir = std::env::temp_dir().join(format!("luxbake-scenefile-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("lamps")).expect("temp dir");
        std::fs::write(dir.join("lamps/l.ies"), builtin::DEFAULT_LAMP_IES).expect("write lamp");
        let scene = dir.join("s.toml");
        std::fs::write(
            &scene,
            format!(
                "[[lamp]]\nies = \"lamps/l.ies\"\nposition = [0, 2, 0]\n[[object]]\n{OBJECT}\n"
            ),
        )
        .expect("write scene");
        let s = Scene::from_toml_file(&scene).expect("parses");
        let here = builtin::default_photometry().expect("lamp");
        let dir_down = [0.0, 0.0, -1.0];
        assert_eq!(
            s.lamps[0].photometry.intensity(dir_down),
            here.intensity(dir_down)
        );
        // Errors name the file.
        std::fs::write(&scene, "[[lamp]]\nposition = [0, 2, 0]\nies = \"lamps/missing.ies\"\n[[object]]\nbuiltin = \"chair\"\n")
            .expect("write scene");
        let e = Scene::from_toml_file(&scene)
            .expect_err("missing lamp")
            .to_string();
        assert!(
            e.contains("s.toml") && e.contains("lamp[0].ies") && e.contains("missing.ies"),
            "{e}"
        );
        let e = Scene::from_toml_file(&dir.join("nope.toml"))
            .expect_err("missing file")
            .to_string();
        assert!(e.contains("nope.toml"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn the_preferred_backend_stays_outside_the_settings() {
        let dir = std::env::temp_dir().join(format!("luxbake-backend-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("s.toml");
        // The core passes the name on as written: the backends' crate knows the names.
        for (settings, want) in [
            ("", None),
            ("backend = \"WGPU\"", Some("WGPU")),
            ("backend = \" glow \"", Some(" glow ")),
            ("backend = \"vulkan\"", Some("vulkan")),
        ] {
            std::fs::write(&path, text(settings, LAMP, OBJECT)).expect("write scene");
            let got = preferred_backend(&path).expect("reads");
            assert_eq!(got.as_deref(), want, "{settings}");
            let s = from_file(&path).expect("parses");
            assert_eq!(s.settings, Settings::default());
        }
        std::fs::write(&path, text("backend = 3", LAMP, OBJECT)).expect("write scene");
        let e = preferred_backend(&path).expect_err("a number").to_string();
        assert!(
            e.contains("settings.backend") && e.contains("expected a backend's name"),
            "{e}"
        );
        assert!(from_file(&path).is_err());
        assert!(preferred_backend(&dir.join("nope.toml")).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn tilt_files_resolve_beside_the_photometric_file() {
        let dir = std::env::temp_dir().join(format!("luxbake-tilt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let ies = builtin::DEFAULT_LAMP_IES.replacen("TILT=NONE", "TILT=tilt.dat", 1);
        assert_ne!(
            ies,
            builtin::DEFAULT_LAMP_IES,
            "the default lamp has a TILT line"
        );
        std::fs::write(dir.join("l.ies"), &ies).expect("write lamp");
        let scene =
            format!("[[lamp]]\nies = \"l.ies\"\nposition = [0, 2, 0]\n[[object]]\n{OBJECT}\n");
        let e = from_str(&scene, &dir, None)
            .expect_err("tilt file missing")
            .to_string();
        assert!(e.contains("lamp[0].ies"), "{e}");
        std::fs::write(dir.join("tilt.dat"), "1\n3\n0 45 90\n1.0 0.9 0.8\n").expect("write tilt");
        let s = from_str(&scene, &dir, None).expect("tilt file beside the lamp");
        assert!(s.lamps[0].photometry.intensity([0.0, 0.0, -1.0]) > 0.0);
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Devices report a size of 0: reads stop at the limit anyway.
    #[cfg(unix)]
    #[test]
    fn endless_files_are_cut_at_the_limit() {
        let t = text("", "position = [0, 1, 0]\nies = \"/dev/zero\"", OBJECT);
        let e = err(&t);
        assert!(
            e.contains("lamp[0].ies") && e.contains("longer than"),
            "{e}"
        );
        let big = text("", LAMP, "primitive = \"box\"\nsize = [1, 1e7, 1]");
        assert!(err(&big).contains("object[0].size"));
    }

    /// A loader that returns `n` unit-square parts and one 10 cd light at (0, 1, 0) aimed
    /// along −Z, or fails for files named `bad.*`.
    struct FakeLoader(usize);

    impl MeshLoader for FakeLoader {
        fn load(
            &self,
            request: &MeshRequest<'_>,
        ) -> Result<LoadedFile, Box<dyn std::error::Error + Send + Sync>> {
            if request.path.file_stem().is_some_and(|s| s == "bad") {
                return Err("truncated file".into());
            }
            assert!(request.path.is_absolute() || request.path.starts_with("/base"));
            let mut lamp = Lamp::new(
                "bulb",
                Arc::new(Photometry::isotropic(10.0)),
                [0.0, 1.0, 0.0],
            );
            lamp.aim = [0.0, 0.0, -1.0];
            Ok(LoadedFile {
                parts: (0..self.0)
                    .map(|k| MeshPart {
                        name: format!("part{k}"),
                        mesh: meshes::plane([1.0, 1.0], 4.0 / request.texels_per_metre),
                        albedo: Albedo::grey(0.25),
                    })
                    .collect(),
                lamps: vec![lamp],
            })
        }
    }

    #[test]
    fn file_lights_follow_the_object_transform() {
        let obj = "mesh = \"lamp.glb\"\nposition = [1, 0, 2]\nrotation_deg = [0, 90, 0]\n\
                   scale = 2\nlights = true\nlights_multiplier = 3";
        let t = format!("[[object]]\n{obj}\n");
        let base = Path::new("/base");
        let s = from_str_with(&t, base, None, &FakeLoader(1)).expect("loads");
        assert_eq!(s.lamps.len(), 1, "no [[lamp]]: the file's light alone");
        let l = &s.lamps[0];
        let near = |a: [f32; 3], b: [f32; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-5);
        assert!(
            near(l.position.map(|c| c as f32), [1.0, 2.0, 2.0]),
            "{:?}",
            l.position
        );
        // −Z turned 90° about +Y is −X; unit length despite the scale.
        assert!(near(l.aim, [-1.0, 0.0, 0.0]), "{:?}", l.aim);
        assert_eq!((l.multiplier, l.name.as_str()), (3.0, "lamp/bulb"));
        assert_eq!(l.photometry.max_intensity().0, 10.0);
        let iso = format!("{obj}\nlights_ies = \"isotropic:50\"");
        let s = from_str_with(&text("", LAMP, &iso), base, None, &FakeLoader(1)).expect("loads");
        assert_eq!(s.lamps.len(), 2);
        assert_eq!(s.lamps[1].photometry.max_intensity().0, 50.0);
        let without = from_str_with(
            &text("", LAMP, "mesh = \"a.glb\""),
            base,
            None,
            &FakeLoader(1),
        );
        assert_eq!(
            without.expect("loads").lamps.len(),
            1,
            "lights default to off"
        );
        for (extra, k) in [
            ("mesh = \"a.glb\"\nlights = 3", "lights"),
            (
                "mesh = \"a.glb\"\nlights = true\nlights_ies = \"nope.ies\"",
                "object[0].lights_ies",
            ),
            (
                "mesh = \"a.glb\"\nlights = true\nlights_ies = \"isotropic:-1\"",
                "object[0].lights_ies",
            ),
            (
                "mesh = \"a.glb\"\nlights = true\nlights_multiplier = -1",
                "object[0].lights_multiplier",
            ),
            (
                "mesh = \"a.glb\"\nlights_multiplier = 2",
                "object[0].lights_multiplier",
            ),
            (
                "primitive = \"plane\"\nsize = [1, 1]\nlights = true",
                "object[0].lights",
            ),
            (
                "mesh = \"a.glb\"\nlights_ies = \"isotropic:1\"",
                "object[0].lights_ies",
            ),
            ("mesh = \"a.glb\"\nlights_colour = true", "lights_colour"),
        ] {
            let r = from_str_with(&text("", LAMP, extra), base, None, &FakeLoader(1));
            let e = r.expect_err(extra).to_string();
            assert!(e.contains(k), "{extra}: {e}");
        }
        let r = from_str_with("[[object]]\nmesh = \"a.glb\"", base, None, &FakeLoader(1));
        assert!(r.expect_err("no lamps").to_string().contains("lamp"));
    }

    #[test]
    fn file_meshes_go_through_the_loader() {
        let obj = "mesh = \"models/Glam Sofa.glb\"\nposition = [1, 0, 0]\ntexel_scale = 2\nreceiver = false";
        let t = text("texels_per_metre = 10", LAMP, obj);
        let base = Path::new("/base");
        let s = from_str_with(&t, base, None, &FakeLoader(2)).expect("loads");
        let names: Vec<&str> = s.objects.iter().map(|o| o.name.as_str()).collect();
        assert_eq!(names, ["GlamSofa_01", "GlamSofa_02"]);
        for o in &s.objects {
            assert_eq!(
                (o.receiver, o.texel_scale, o.albedo.factor),
                (false, 2.0, [0.25; 3])
            );
            assert_eq!(o.transform.point([0.0; 3]), [1.0, 0.0, 0.0]);
        }
        let one = text(
            "",
            LAMP,
            "mesh = \"chair.obj\"\nname = \"seat\"\nalbedo = 0.75",
        );
        let s = from_str_with(&one, base, None, &FakeLoader(1)).expect("loads");
        assert_eq!(
            (s.objects[0].name.as_str(), s.objects[0].albedo.factor),
            ("seat", [0.75; 3])
        );
        // Errors name the key.
        let e = from_str(&one, base, None)
            .expect_err("no loader")
            .to_string();
        assert!(e.contains("object[0].mesh") && e.contains("loader"), "{e}");
        let bad = text("", LAMP, "mesh = \"bad.glb\"");
        let e = from_str_with(&bad, base, None, &FakeLoader(1))
            .expect_err("fails")
            .to_string();
        assert!(
            e.contains("object[0].mesh") && e.contains("truncated file"),
            "{e}"
        );
        let e = from_str_with(&one, base, None, &FakeLoader(0))
            .expect_err("empty")
            .to_string();
        assert!(e.contains("object[0].mesh"), "{e}");
        let both = text("", LAMP, "mesh = \"a.glb\"\nbuiltin = \"chair\"");
        let e = from_str_with(&both, base, None, &FakeLoader(1))
            .expect_err("both")
            .to_string();
        assert!(e.contains("`object[0]`: give exactly one"), "{e}");
        let sized = text("", LAMP, "mesh = \"a.glb\"\nsize = [1, 1, 1]");
        let e = from_str_with(&sized, base, None, &FakeLoader(1))
            .expect_err("size")
            .to_string();
        assert!(e.contains("object[0].size"), "{e}");
    }

    /// A density or blur given as an override builds the objects as the same key written in
    /// the file does: the same meshes and light-map UVs (procedural charts and the loader's),
    /// the same layout.
    #[test]
    fn overrides_size_the_padding_as_the_file_does() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/living_room.toml");
        let text = std::fs::read_to_string(&path).expect("example");
        let base = path.parent().expect("folder");
        let with_loader = format!("{text}\n[[object]]\nmesh = \"part.glb\"\n");
        // (the key in the file, its new value, the same as an override, objects it re-pads: the
        // room, and for the density the loader's part, which pads for the density alone)
        for (key, value, patch, changed) in [
            (
                "texels_per_metre = 48.0",
                "texels_per_metre = 32",
                SettingsPatch {
                    texels_per_metre: Some(32.0),
                    ..SettingsPatch::default()
                },
                &[0, 7][..],
            ),
            (
                "blur = 2.0",
                "blur = 9",
                SettingsPatch {
                    blur: Some(Blur::Sigma(9.0)),
                    ..SettingsPatch::default()
                },
                &[0],
            ),
        ] {
            assert!(text.contains(key), "{key}");
            let written = with_loader.replacen(key, value, 1);
            let build = |text: &str, overrides: &SettingsPatch| {
                super::parse(text, base, None, Some(&FakeLoader(1)), overrides).expect("parses")
            };
            let plain = build(&with_loader, &SettingsPatch::default());
            let overridden = build(&with_loader, &patch);
            let in_file = build(&written, &SettingsPatch::default());
            assert_eq!(overridden.settings, in_file.settings, "{value}");
            assert_eq!(overridden.objects, in_file.objects, "{value}");
            for &o in changed {
                assert_ne!(
                    plain.objects[o].mesh.lightmap_uvs, overridden.objects[o].mesh.lightmap_uvs,
                    "{value}: object {o}"
                );
            }
        }
        // From a file, through the public loader.
        let overrides = SettingsPatch {
            texels_per_metre: Some(12.0),
            ..SettingsPatch::default()
        };
        let coarse = from_file_patched(&path, None, &overrides).expect("example");
        assert_eq!(coarse.settings.texels_per_metre, 12.0);
    }

    #[test]
    fn overrides_out_of_range_are_theirs() {
        let t = text("rays = 8", LAMP, OBJECT);
        let over = |patch: SettingsPatch| super::parse(&t, Path::new("."), None, None, &patch);
        let bad = over(SettingsPatch {
            rays: Some(0),
            ..SettingsPatch::default()
        });
        assert!(
            matches!(&bad, Err(SceneError::Override(e)) if e.name == "rays"),
            "{bad:?}"
        );
        // The file is checked on its own first.
        let t = text("rays = 0", LAMP, OBJECT);
        let fixed = SettingsPatch {
            rays: Some(4),
            ..SettingsPatch::default()
        };
        let e = super::parse(&t, Path::new("."), None, None, &fixed).expect_err("file");
        assert!(e.to_string().contains("settings.rays"), "{e}");
        // `bounces` in the file is exact unless it turns the tail on.
        let s = parse(&text("bounces = 2", LAMP, OBJECT))
            .expect("parses")
            .settings;
        assert_eq!((s.bounces, s.tail), (2, false));
        let s = parse(&text("bounces = 2\ntail = true", LAMP, OBJECT))
            .expect("parses")
            .settings;
        assert_eq!((s.bounces, s.tail), (2, true));
    }

    /// The example scene of the repository parses, and its relative lamp path resolves.
    #[test]
    fn example_scene_parses() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/living_room.toml");
        let s = Scene::from_toml_file(&path).expect("example scene");
        assert_eq!(s.lamps.len(), 2);
        assert_eq!(s.objects.len(), 7);
        assert!(!s.objects[6].receiver);
        s.validate().expect("valid");
    }

    /// A real photometric file from `../shared` (GPL data: read in tests, never vendored).
    #[test]
    fn shared_ldt_file_parses_when_present() {
        let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/photometry");
        if !shared.join("acrux_452lm.ldt").is_file() {
            let reason = format!("{} not found", shared.join("acrux_452lm.ldt").display());
            luxbake_testkit::skip_or_fail("shared_ldt_file_parses_when_present", &reason);
            return;
        }
        let t = format!(
            "[[lamp]]\nies = \"acrux_452lm.ldt\"\nposition = [0, 2, 0]\n[[object]]\n{OBJECT}\n"
        );
        let s = from_str(&t, &shared, None).expect("parses");
        assert!(s.lamps[0].photometry.intensity([0.0, 0.0, -1.0]) > 0.0);
    }

    #[test]
    fn truncated_prefixes_never_panic() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/living_room.toml");
        let text = std::fs::read_to_string(&path).expect("example");
        let base = path.parent().expect("dir");
        for end in (0..text.len())
            .filter(|&i| text.is_char_boundary(i))
            .step_by(7)
        {
            let _ = from_str(&text[..end], base, None);
        }
    }
}
