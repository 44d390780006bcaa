//! What a page asks to bake: a glTF/GLB scene, options as JSON, the lamps' photometric files;
//! and the scene built from them ([`build_scene`]), natively the same as in the browser.
//!
//! Settings are a [`SettingsPatch`] in camelCase (the CLI's presets, `method` `converged` with
//! `quality` `draft`, `default` or `final`, or `method` `paper`, optionally overridden key by
//! key), checked by [`Settings::validate`]; lamps by [`Lamp::validate`]; the scene is read by
//! [`luxbake_assets::gltf_in::import_bytes`], light-map UVs generated where the file has none
//! usable, padded for the bake's blur at its density (as `cargo xtask bake` does for scene
//! files).

use std::path::Path;
use std::sync::Arc;

use luxbake::scene::{Lamp, LampModel, Object, Scene, Settings, SettingsPatch, Transform};
use luxbake_assets::{GltfSource, ImportOptions, UvSource, uv};
use luxbake_ies::Photometry;
use serde::Deserialize;

use crate::JsBakeError;

/// The bake options a page sends (JSON, camelCase keys; unknown keys are an error).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BakeOptions {
    /// The settings: every key of a [`SettingsPatch`] in camelCase (`blur` is `blurSigma`, a
    /// sigma in texels, 0 = no blur), e.g. `method`, `quality`, `rays`, `bounces`, `tail`,
    /// `texelsPerMetre`, `seed`, `lampPaths`, `denoiseCorrection`, `directAtHits`. Missing ones take the
    /// preset's value.
    pub settings: SettingsPatch,
    /// Largest distance of a `measure` point from a baked surface, metres (default 0.01).
    pub measure_tolerance: Option<f64>,
    /// The lamps; their photometric files are passed beside the options, in the same order.
    pub lamps: Vec<LampOptions>,
    /// `lampModel`: how the lamps without their own `lampModel` emit (`"auto"`, the default,
    /// `"point"` or `"area"`, [`LampModel`]).
    pub lamp_model: Option<String>,
}

/// [`BakeOptions`] as JSON: the settings are the keys besides these.
#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct OptionsJson {
    #[serde(default)]
    measure_tolerance: Option<f64>,
    #[serde(default)]
    lamps: Vec<LampOptions>,
    #[serde(default)]
    lamp_model: Option<String>,
    #[serde(flatten)]
    settings: serde_json::Map<String, serde_json::Value>,
}

/// One lamp of [`BakeOptions`]: where it hangs, where it points, how bright.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct LampOptions {
    /// Name for reports (default `lamp_<index>`).
    #[serde(default)]
    pub name: Option<String>,
    /// Photometric centre, metres, in the glTF file's frame.
    pub position: [f64; 3],
    /// World direction of the photometric nadir (default straight down, `[0, -1, 0]`).
    #[serde(default)]
    pub aim: Option<[f32; 3]>,
    /// Turn of the C0 plane about the aim axis, degrees ([`Lamp::rotation_deg`]).
    #[serde(default)]
    pub rotation: f32,
    /// Dimmer: scalar on every intensity (default 1).
    #[serde(default)]
    pub multiplier: Option<f32>,
    /// Linear RGB tint (default white).
    #[serde(default)]
    pub color: Option<[f32; 3]>,
    /// How it emits: `"auto"` (its file's luminous opening where a receiver is near enough
    /// for the point model to be off by more than 1 %), `"point"` or `"area"` ([`LampModel`]);
    /// default: the options' `lampModel`, else `"auto"`.
    #[serde(default)]
    pub lamp_model: Option<String>,
}

impl BakeOptions {
    /// Parses options from JSON.
    ///
    /// # Errors
    /// [`JsBakeError::Options`] for malformed JSON, a wrong type or an unknown key;
    /// [`JsBakeError::Setting`] for a setting of the wrong type or an unknown name (`method`,
    /// `quality`), named by its option key.
    pub fn from_json(text: &str) -> Result<BakeOptions, JsBakeError> {
        let json: OptionsJson =
            serde_json::from_str(text).map_err(|e| JsBakeError::Options(e.to_string()))?;
        let mut entries = Vec::with_capacity(json.settings.len());
        for (key, value) in json.settings {
            let field = setting_field(&key)
                .ok_or_else(|| JsBakeError::Options(format!("unknown option `{key}`")))?;
            entries.push((field, value));
        }
        let settings = SettingsPatch::from_entries(&entries).map_err(|e| JsBakeError::Setting {
            name: option_key(&e.key),
            reason: e.message,
        })?;
        Ok(BakeOptions {
            settings,
            measure_tolerance: json.measure_tolerance,
            lamps: json.lamps,
            lamp_model: json.lamp_model,
        })
    }

    /// The bake settings of [`BakeOptions::settings`] ([`SettingsPatch::settings`]).
    ///
    /// # Errors
    /// [`JsBakeError::Setting`] naming the first value out of range by its option key.
    pub fn settings(&self) -> Result<Settings, JsBakeError> {
        self.settings.settings().map_err(|e| JsBakeError::Setting {
            name: option_key(e.name),
            reason: e.reason,
        })
    }
}

/// The option key of a [`Settings`] field, [`SettingsPatch`] key or [`Lamp`] field: its
/// camelCase name; `blur` is `blurSigma`, `rotation_deg` is `rotation`.
fn option_key(field: &str) -> String {
    match field {
        "blur" => "blurSigma".into(),
        "rotation_deg" => "rotation".into(),
        _ => {
            let mut words = field.split('_');
            let first = words.next().unwrap_or_default().to_owned();
            words.fold(first, |mut key, word| {
                let mut chars = word.chars();
                key.extend(chars.next().map(|c| c.to_ascii_uppercase()));
                key.push_str(chars.as_str());
                key
            })
        }
    }
}

/// The [`SettingsPatch`] key of an option key (the inverse of [`option_key`]); `None` for a
/// key that names no setting.
fn setting_field(key: &str) -> Option<String> {
    let field = match key {
        "blurSigma" => "blur".into(),
        _ => key.chars().fold(String::new(), |mut field, c| {
            if c.is_ascii_uppercase() {
                field.push('_');
            }
            field.push(c.to_ascii_lowercase());
            field
        }),
    };
    (SettingsPatch::KEYS.contains(&field.as_str()) && option_key(&field) == key).then_some(field)
}

/// Where a baked object came from, for the page to find its mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectInfo {
    /// The glTF node, mesh and primitive.
    pub gltf: Option<GltfSource>,
    /// Whether the light-map UVs are the file's own `TEXCOORD_1` (possibly stretched onto the
    /// unit square) or generated.
    pub generated_uvs: bool,
    /// For generated UVs: the file vertex each vertex was copied from.
    pub source_vertex: Option<Vec<u32>>,
}

/// A scene ready to bake, with what the page needs to apply the result.
#[derive(Debug, Clone)]
pub struct Built {
    /// The scene: one receiving object per glTF primitive, the requested lamps, the settings.
    pub scene: Scene,
    /// Per object of `scene` (same order): where it came from.
    pub objects: Vec<ObjectInfo>,
    /// Things that were ignored or converted while reading the file, one sentence each.
    pub warnings: Vec<String>,
}

/// A glTF/GLB file read as a room to bake: its receiving objects (no lamps) and what the page
/// needs to apply a result. Light-map UVs the file lacks are generated for one texel density
/// and chart padding ([`Imported::fits`]).
#[derive(Debug, Clone)]
pub struct Imported {
    /// The scene: one receiving object per glTF primitive, no lamps, the settings it was
    /// imported for.
    pub scene: Scene,
    /// Per object of `scene` (same order): where it came from.
    pub objects: Vec<ObjectInfo>,
    /// Things that were ignored or converted while reading the file, one sentence each.
    pub warnings: Vec<String>,
}

/// The unwrapper's options for `settings`: its texel density and the chart padding its blur
/// needs.
fn unwrap_options(settings: &Settings) -> uv::UnwrapOptions {
    uv::UnwrapOptions {
        texels_per_metre: settings.texels_per_metre,
        padding_texels: uv::padding_texels(settings.blur),
        scale: [1.0; 3],
    }
}

impl Imported {
    /// Whether this import serves a bake with `settings`: the same texel density and chart
    /// padding (the reader checks the file's own light-map UVs at the density, and generates
    /// missing ones for both).
    pub fn fits(&self, settings: &Settings) -> bool {
        let (have, want) = (
            unwrap_options(&self.scene.settings),
            unwrap_options(settings),
        );
        have.texels_per_metre.to_bits() == want.texels_per_metre.to_bits()
            && have.padding_texels.to_bits() == want.padding_texels.to_bits()
    }
}

/// Reads `gltf` (glTF JSON with data-URI buffers, or GLB) as a room baked with `settings`.
///
/// # Errors
/// [`JsBakeError::Scene`] for a file `luxbake-assets` rejects or a scene that fails
/// [`Scene::validate`].
pub fn import_room(gltf: &[u8], settings: &Settings) -> Result<Imported, JsBakeError> {
    let import = ImportOptions {
        unwrap: unwrap_options(settings),
        ..ImportOptions::default()
    };
    let model = luxbake_assets::gltf_in::import_bytes(gltf, Path::new("scene"), &import)
        .map_err(|e| JsBakeError::Scene(e.to_string()))?;
    let mut objects = Vec::with_capacity(model.parts.len());
    let mut infos = Vec::with_capacity(model.parts.len());
    for part in model.parts {
        infos.push(ObjectInfo {
            gltf: part.gltf,
            generated_uvs: matches!(part.uv_source, UvSource::Generated { .. }),
            source_vertex: part.source_vertex,
        });
        objects.push(Object {
            name: part.name,
            mesh: part.mesh,
            transform: Transform::IDENTITY,
            albedo: part.albedo,
            receiver: true,
            texel_scale: 1.0,
        });
    }
    let scene = Scene {
        objects,
        lamps: Vec::new(),
        settings: settings.clone(),
    };
    scene
        .validate()
        .map_err(|e| JsBakeError::Scene(e.to_string()))?;
    Ok(Imported {
        scene,
        objects: infos,
        warnings: model.warnings,
    })
}

/// The lamps of `options` with one photometric file (IES LM-63 or EULUMDAT bytes) each.
///
/// # Errors
/// No lamp, not one file per lamp ([`JsBakeError::Options`]); a photometric file that does
/// not parse (the message names its line) or a lamp out of range ([`JsBakeError::Lamp`]).
pub fn build_lamps(options: &BakeOptions, photometry: &[&[u8]]) -> Result<Vec<Lamp>, JsBakeError> {
    if options.lamps.is_empty() {
        return Err(JsBakeError::Options(
            "`lamps` is empty: a bake needs a lamp".into(),
        ));
    }
    if photometry.len() != options.lamps.len() {
        return Err(JsBakeError::Options(format!(
            "{} lamps but {} photometric files",
            options.lamps.len(),
            photometry.len()
        )));
    }
    let mut lamps = Vec::with_capacity(options.lamps.len());
    for (index, (spec, bytes)) in options.lamps.iter().zip(photometry).enumerate() {
        let name = spec.name.clone().unwrap_or_else(|| format!("lamp_{index}"));
        let lamp_error = |message: String| JsBakeError::Lamp {
            index,
            name: name.clone(),
            message,
        };
        let p = Photometry::parse(bytes).map_err(|e| lamp_error(e.to_string()))?;
        let mut lamp = Lamp::new(name.clone(), Arc::new(p), spec.position);
        lamp.aim = spec.aim.unwrap_or([0.0, -1.0, 0.0]);
        lamp.rotation_deg = spec.rotation;
        lamp.multiplier = spec.multiplier.unwrap_or(1.0);
        lamp.color = spec.color.unwrap_or([1.0; 3]);
        if let Some(model) = spec.lamp_model.as_ref().or(options.lamp_model.as_ref()) {
            lamp.model = model
                .parse::<LampModel>()
                .map_err(|e| lamp_error(format!("`lampModel`: {e}")))?;
        }
        lamp.validate()
            .map_err(|e| lamp_error(format!("`{}`: {}", option_key(e.name), e.reason)))?;
        lamps.push(lamp);
    }
    Ok(lamps)
}

/// Builds the scene of a request: `gltf` (glTF JSON with data-URI buffers, or GLB), `options`,
/// and one photometric file (IES LM-63 or EULUMDAT bytes) per lamp of `options.lamps`
/// ([`build_lamps`], then [`import_room`]).
///
/// # Errors
/// Options or settings out of range, a photometric file that does not parse (the message
/// names its line), a lamp out of range, a glTF file `luxbake-assets` rejects, no lamp.
pub fn build_scene(
    gltf: &[u8],
    options: &BakeOptions,
    photometry: &[&[u8]],
) -> Result<Built, JsBakeError> {
    let settings = options.settings()?;
    let lamps = build_lamps(options, photometry)?;
    let room = import_room(gltf, &settings)?;
    Ok(Built {
        scene: Scene {
            lamps,
            ..room.scene
        },
        objects: room.objects,
        warnings: room.warnings,
    })
}

/// Illuminance (lux, Rec. 709 luminance of the RGB map: each channel's value for a white lamp)
/// at world points `xyz` (`3n` numbers, metres), read from `maps` (per object of `scene`, its
/// total illuminance map) as `cargo xtask measure` reads a bake: the nearest receiving surface
/// within `tolerance` metres, the map looked up bilinearly (masked) at its light-map UV. A
/// point on no baked surface gives NaN.
///
/// # Errors
/// [`JsBakeError::Measure`] when `xyz` is not a whole number of finite points.
pub fn measure(
    scene: &Scene,
    maps: &[(usize, &luxbake::map::MapImage)],
    xyz: &[f64],
    tolerance: f64,
) -> Result<Vec<f64>, JsBakeError> {
    if !xyz.len().is_multiple_of(3) {
        return Err(JsBakeError::Measure(format!(
            "{} numbers are not whole x, y, z points",
            xyz.len()
        )));
    }
    if let Some(i) = xyz.iter().position(|v| !v.is_finite()) {
        return Err(JsBakeError::Measure(format!(
            "point {} has a non-finite coordinate",
            i / 3
        )));
    }
    Ok(xyz
        .chunks_exact(3)
        .map(|p| {
            luxbake::probe::locate(scene, [p[0], p[1], p[2]], tolerance)
                .and_then(|sp| {
                    let map = maps.iter().find(|(o, _)| *o == sp.object)?.1;
                    Some(f64::from(luxbake_output::picture::luminance(
                        map.sample(sp.uv),
                    )))
                })
                .unwrap_or(f64::NAN)
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use luxbake::scene::{Blur, Quality};

    const IES: &[u8] = include_bytes!("../../scene/lamps/luxbake_downlight.ies");

    fn options(json: &str) -> BakeOptions {
        BakeOptions::from_json(json).unwrap()
    }

    fn settings(json: &str) -> Result<Settings, JsBakeError> {
        BakeOptions::from_json(json)?.settings()
    }

    #[test]
    fn presets_are_the_clis_and_overrides_are_checked_by_the_core() {
        let draft = settings(r#"{"quality":"draft"}"#).unwrap();
        assert_eq!(draft, Settings::preset(Quality::Draft));
        let paper = settings(r#"{"method":"paper"}"#).unwrap();
        assert_eq!(paper, Settings::paper());
        let s = settings(r#"{"rays":16,"blurSigma":0,"texelsPerMetre":12}"#).unwrap();
        assert_eq!((s.rays, s.blur, s.texels_per_metre), (16, Blur::None, 12.0));
        let s = settings(r#"{"lampPaths":3,"tailTolerance":0.05}"#).unwrap();
        assert_eq!((s.lamp_paths, s.tail_tolerance), (3, 0.05));
        // The default preset refines the texels in narrow gaps; a page can turn that off.
        assert_eq!(settings("{}").unwrap().narrow_rays, Settings::NARROW_RAYS);
        let s = settings(r#"{"narrowRays":0}"#).unwrap();
        assert_eq!(s.narrow_rays, 0);
        // The default preset corrects its denoiser's bias; a page can turn that off.
        assert!(settings("{}").unwrap().denoise_correction);
        let s = settings(r#"{"denoiseCorrection":false}"#).unwrap();
        assert!(!s.denoise_correction);
        // `bounces` alone is an exact count; with `tail` a cap.
        let s = settings(r#"{"bounces":2}"#).unwrap();
        assert_eq!((s.bounces, s.tail), (2, false));
        let s = settings(r#"{"bounces":2,"tail":true}"#).unwrap();
        assert_eq!((s.bounces, s.tail), (2, true));
        assert!(settings("{}").unwrap().tail);
        for (json, key) in [
            (r#"{"lampPaths":5000}"#, "lampPaths"),
            (r#"{"rays":0}"#, "rays"),
            (r#"{"quality":"best"}"#, "quality"),
            (r#"{"method":"fast"}"#, "method"),
            (r#"{"texelsPerMetre":0}"#, "texelsPerMetre"),
            (r#"{"blurSigma":-1}"#, "blurSigma"),
            (r#"{"bounces":1000}"#, "bounces"),
            (r#"{"tail":"yes"}"#, "tail"),
            (r#"{"higherStride":0}"#, "higherStride"),
            (r#"{"narrowRays":70000}"#, "narrowRays"),
        ] {
            let e = settings(json).unwrap_err();
            assert!(e.to_string().contains(&format!("`{key}`")), "{json}: {e}");
            assert_eq!(e.kind(), "setting");
        }
        for key in ["rayz", "blur", "texels_per_metre"] {
            let e = BakeOptions::from_json(&format!(r#"{{"{key}":4}}"#)).unwrap_err();
            assert!(e.to_string().contains(key), "{e}");
            assert_eq!(e.kind(), "options");
        }
    }

    #[test]
    fn a_malformed_ies_file_names_its_line() {
        let o = options(r#"{"lamps":[{"name":"pendant","position":[0,2,0]}]}"#);
        let bad = b"IESNA:LM-63-2002\n[TEST] malformed\nTILT=NONE\n1 1000 1 3 2 1 2 0 0 0\n1 1 10\n0 45 oops\n";
        let e = build_scene(b"{}", &o, &[bad]).unwrap_err();
        assert_eq!(e.kind(), "lamp");
        assert!(
            e.to_string().contains("pendant") && e.to_string().contains("line 6"),
            "{e}"
        );
    }

    #[test]
    fn lamp_model_is_per_lamp_with_a_default_for_all() {
        use luxbake::scene::LampModel;
        let o = options(
            r#"{"lampModel":"point","openingSamples":64,"openingProbeStride":0,"lamps":[{"position":[0,2,0]},{"position":[1,2,0],"lampModel":"area"}]}"#,
        );
        assert_eq!(o.settings().unwrap().opening_samples, 64);
        assert_eq!(o.settings().unwrap().opening_probe_stride, 0);
        let lamps = build_lamps(&o, &[IES, IES]).unwrap();
        assert_eq!(
            (lamps[0].model, lamps[1].model),
            (LampModel::Point, LampModel::Area)
        );
        let o = options(r#"{"lamps":[{"position":[0,2,0]}]}"#);
        assert_eq!(build_lamps(&o, &[IES]).unwrap()[0].model, LampModel::Auto);
        let o = options(r#"{"lamps":[{"position":[0,2,0],"lampModel":"disk"}]}"#);
        let e = build_lamps(&o, &[IES]).unwrap_err();
        assert!(e.to_string().contains("`lampModel`"), "{e}");
        assert_eq!(e.kind(), "lamp");
    }

    #[test]
    fn lamps_out_of_range_and_bad_gltf_are_named() {
        let o = options(r#"{"lamps":[{"position":[0,2,0],"aim":[0,0,0]}]}"#);
        let e = build_scene(b"{}", &o, &[IES]).unwrap_err();
        assert!(e.to_string().contains("`aim`"), "{e}");
        let o = options(r#"{"lamps":[{"position":[0,2,0],"multiplier":-2}]}"#);
        let e = build_scene(b"{}", &o, &[IES]).unwrap_err();
        assert!(e.to_string().contains("`multiplier`"), "{e}");
        let o = options(r#"{"lamps":[]}"#);
        assert_eq!(build_scene(b"{}", &o, &[]).unwrap_err().kind(), "options");
        let o = options(r#"{"lamps":[{"position":[0,2,0]}]}"#);
        let e = build_scene(b"glTF\x02\0\0\0\x04\0\0\0", &o, &[IES]).unwrap_err();
        assert_eq!(e.kind(), "scene", "{e}");
    }

    #[test]
    fn a_glb_scene_builds_with_its_own_light_map_uvs_and_measures() {
        let dir = std::env::temp_dir().join(format!("luxbake-js-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let glb = dir.join("chairs_01.glb");
        let mut builtin = Scene::builtin("chairs_01").unwrap();
        builtin.lamps.clear();
        luxbake_assets::export::export_scene(&builtin, &glb).unwrap();
        let bytes = std::fs::read(&glb).unwrap();
        let o =
            options(r#"{"quality":"draft","texelsPerMetre":8,"lamps":[{"position":[0,2.5,0]}]}"#);
        let built = build_scene(&bytes, &o, &[IES]).unwrap();
        assert_eq!(built.scene.objects.len(), builtin.objects.len());
        assert!(
            built
                .objects
                .iter()
                .all(|i| i.gltf.is_some() && !i.generated_uvs)
        );
        // The room alone: the same objects, no lamps; it serves bakes at its density and blur.
        let settings = &built.scene.settings;
        let room = import_room(&bytes, settings).unwrap();
        assert!(room.scene.lamps.is_empty());
        assert_eq!(room.scene.objects, built.scene.objects);
        assert!(room.fits(settings));
        let denser = Settings {
            texels_per_metre: 16.0,
            ..settings.clone()
        };
        let blurred = Settings {
            blur: Blur::Sigma(4.0),
            ..settings.clone()
        };
        assert!(!room.fits(&denser) && !room.fits(&blurred));
        let mut backend = luxbake_backend_cpu::CpuBackend::new();
        let out = luxbake::bake(
            &mut backend,
            &built.scene,
            &built.scene.settings,
            &mut |_| {},
        )
        .unwrap();
        let maps: Vec<_> = out
            .maps
            .iter()
            .map(|m| (m.object, m.illuminance()))
            .collect();
        let lux = measure(&built.scene, &maps, &[0.0, 0.0, 0.5, 0.0, 9.0, 0.0], 0.01).unwrap();
        assert!(lux[0] > 10.0, "{lux:?}");
        assert!(lux[1].is_nan(), "{lux:?}");
        assert!(measure(&built.scene, &maps, &[0.0, 1.0], 0.01).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
