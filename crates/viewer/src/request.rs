//! What the page asks to bake: a built-in scene, settings and one lamp, as JSON.
//!
//! The page (main thread) and the bake worker both turn the same [`BakeRequest`] into the same
//! [`Scene`] with [`build_scene`]: the worker bakes it, the page draws its meshes with the
//! light maps the worker sends back.

use std::sync::Arc;

use luxbake::scene::{Blur, Lamp, LampModel, Method, Quality, Scene, Settings, SettingsPatch};
use luxbake::sources::builtin::{DEFAULT_LAMP_IES, ROOM_SIZE};
use luxbake_ies::Photometry;
use serde::{Deserialize, Serialize};

use crate::error::ViewerError;

/// The lamps the page offers besides a file from disk: `(id, label)`. All are freely licensed:
/// the repository's synthetic downlight, an isotropic point source, and two closed-form
/// distributions generated for luxbake's tests.
pub const BUNDLED_LAMPS: &[(&str, &str)] = &[
    ("downlight", "luxbake downlight (1500 lm, default)"),
    ("isotropic", "isotropic point, 120 cd (1508 lm)"),
    ("synthetic_cosine", "synthetic I = 1000 cd·cos θ"),
    (
        "synthetic_asym",
        "synthetic asymmetric 1000 cd·cos θ·(1 + ½ cos C)",
    ),
];

/// Candela of the bundled isotropic lamp (≈ the downlight's 1500 lm over 4π sr).
pub const ISOTROPIC_CANDELA: f64 = 120.0;

/// The file id [`LampSpec::source`] takes for a photometric file loaded from disk.
pub const FILE_SOURCE: &str = "file";

const SYNTHETIC_COSINE_IES: &str = include_str!("../lamps/synthetic_cosine_typeC.ies");
const SYNTHETIC_ASYM_IES: &str = include_str!("../lamps/synthetic_asym_typeC.ies");

/// Range of the lamp's dimmer ([`LampSpec::multiplier`]). The bake settings' limits are
/// those of every bake, [`Settings::validate`].
pub const MULTIPLIER_RANGE: (f32, f32) = (0.0, 100.0);

/// The lamp of a request: which photometry, where, aimed where, how bright.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LampSpec {
    /// A [`BUNDLED_LAMPS`] id, or [`FILE_SOURCE`] for the bytes given to [`build_scene`].
    pub source: String,
    /// Photometric centre, metres; `None` keeps the scene's lamp position (ceiling centre).
    pub position: Option<[f32; 3]>,
    /// Tilt of the aim away from straight down, degrees (0 = down, 90 = horizontal).
    pub tilt_deg: f32,
    /// Direction of the tilt about +Y, degrees: 0 tilts toward +X, 90 toward +Z.
    pub azimuth_deg: f32,
    /// Turn of the C0 plane about the aim axis, degrees ([`Lamp::rotation_deg`]).
    pub rotation_deg: f32,
    /// Dimmer: scalar on every intensity.
    pub multiplier: f32,
    /// How the lamp emits (`lamp_model`, also `lampModel`): `"auto"`, `"point"` or `"area"`
    /// ([`LampModel`]).
    #[serde(alias = "lampModel")]
    pub lamp_model: String,
}

impl Default for LampSpec {
    fn default() -> Self {
        LampSpec {
            source: "downlight".into(),
            position: None,
            tilt_deg: 0.0,
            azimuth_deg: 0.0,
            rotation_deg: 0.0,
            multiplier: 1.0,
            lamp_model: LampModel::Auto.name().into(),
        }
    }
}

impl LampSpec {
    /// The world aim direction (unit) of the tilt and azimuth.
    pub fn aim(&self) -> [f32; 3] {
        let (st, ct) = self.tilt_deg.to_radians().sin_cos();
        let (sa, ca) = self.azimuth_deg.to_radians().sin_cos();
        [st * ca, -ct, st * sa]
    }
}

/// A bake request: scene, settings, lamp.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BakeRequest {
    /// Built-in scene name ([`Scene::builtin_names`]).
    pub scene: String,
    /// The pipeline: `converged` or `paper` ([`Method`]).
    pub method: String,
    /// The converged method's preset: `draft`, `default` or `final` ([`Quality`]).
    pub quality: String,
    /// Gather rays per texel per bounce (converged: of the first bounce).
    pub rays: u32,
    /// Indirect bounces; 0 = direct light only. Converged: exactly this many, unless `tail`
    /// makes it the most explicit bounces before the tail is added.
    pub bounces: u32,
    /// Converged: after the explicit bounces, add the extrapolated rest of the
    /// inter-reflection series ([`Settings::tail`]; the presets' `true`).
    pub tail: bool,
    /// Blur sigma in texels, 0 = no blur.
    pub blur_sigma: f32,
    /// Light-map texel density, texels per metre.
    pub texels_per_metre: f32,
    /// Seed of the bake's random-number hash.
    pub seed: u32,
    /// The lamp (the scene's only lamp is replaced by it).
    pub lamp: LampSpec,
}

impl Default for BakeRequest {
    /// `chairs_05` with the bake's default method and preset ([`Settings::default`]), except
    /// the density: 32 texels/m, a quarter of the paper's texels, because a browser's first
    /// bake must fit a tab's memory and finish in seconds (the settings panel goes up to the
    /// paper's density).
    fn default() -> Self {
        BakeRequest::with_preset(Method::Converged, Quality::Default)
    }
}

impl BakeRequest {
    /// The default request with the rays, bounces and blur of `method`'s preset at `quality`
    /// ([`Settings::paper`], [`Settings::preset`]).
    pub fn with_preset(method: Method, quality: Quality) -> BakeRequest {
        let s = Settings::of(method, quality);
        BakeRequest {
            scene: "chairs_05".into(),
            method: method.name().into(),
            quality: quality.name().into(),
            rays: s.rays,
            bounces: s.bounces,
            tail: s.tail,
            blur_sigma: match s.blur {
                Blur::None => 0.0,
                Blur::Sigma(sigma) => sigma,
            },
            texels_per_metre: 32.0,
            seed: 0,
            lamp: LampSpec::default(),
        }
    }

    /// Parses a request from JSON (missing keys take their defaults).
    ///
    /// # Errors
    /// [`ViewerError::Request`] for malformed JSON or unknown keys.
    pub fn from_json(text: &str) -> Result<BakeRequest, ViewerError> {
        serde_json::from_str(text).map_err(|e| ViewerError::Request(e.to_string()))
    }

    /// The settings of this request as a patch: every key is given (`blur_sigma` 0 means no
    /// blur).
    ///
    /// # Errors
    /// [`ViewerError::Setting`] for an unknown `method` or `quality`.
    pub fn patch(&self) -> Result<SettingsPatch, ViewerError> {
        let setting =
            |name: &'static str| move |reason: String| ViewerError::Setting { name, reason };
        Ok(SettingsPatch {
            method: Some(self.method.parse().map_err(setting("method"))?),
            quality: Some(self.quality.parse().map_err(setting("quality"))?),
            rays: Some(self.rays),
            bounces: Some(self.bounces),
            tail: Some(self.tail),
            blur: Some(Blur::sigma(self.blur_sigma)),
            texels_per_metre: Some(self.texels_per_metre),
            seed: Some(self.seed),
            ..SettingsPatch::default()
        })
    }

    /// The bake settings of this request ([`SettingsPatch::settings`]).
    ///
    /// # Errors
    /// [`ViewerError::Setting`] naming the first value out of range by its JSON key.
    pub fn settings(&self) -> Result<Settings, ViewerError> {
        self.patch()?.settings().map_err(|e| ViewerError::Setting {
            name: match e.name {
                "blur" => "blur_sigma",
                name => name,
            },
            reason: e.reason,
        })
    }
}

/// Parses a photometric file (IES LM-63 or EULUMDAT) as the page does for a file from disk.
///
/// # Errors
/// [`ViewerError::Photometry`] with `luxbake-ies`'s message (line and what was expected).
pub fn parse_lamp_file(name: &str, bytes: &[u8]) -> Result<Photometry, ViewerError> {
    Photometry::parse(bytes).map_err(|e| ViewerError::Photometry {
        file: name.to_owned(),
        message: e.to_string(),
    })
}

/// The photometry of a bundled lamp id.
///
/// # Errors
/// [`ViewerError::Request`] for an unknown id.
pub fn bundled_photometry(id: &str) -> Result<Photometry, ViewerError> {
    let text = match id {
        "isotropic" => return Ok(Photometry::isotropic(ISOTROPIC_CANDELA)),
        "downlight" => DEFAULT_LAMP_IES,
        "synthetic_cosine" => SYNTHETIC_COSINE_IES,
        "synthetic_asym" => SYNTHETIC_ASYM_IES,
        _ => {
            return Err(ViewerError::Request(format!(
                "unknown lamp `{id}` (expected one of {})",
                BUNDLED_LAMPS
                    .iter()
                    .map(|(id, _)| *id)
                    .chain([FILE_SOURCE])
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
    };
    parse_lamp_file(id, text.as_bytes())
}

/// Builds the scene of `request`: the built-in scene at the requested density with its lamp
/// replaced by the requested one. `lamp_file` holds the bytes of a file from disk when
/// `request.lamp.source` is [`FILE_SOURCE`].
///
/// # Errors
/// Unknown scene or lamp, settings out of range, a lamp position outside the room or not
/// finite, a multiplier out of range, a photometric file that does not parse.
pub fn build_scene(request: &BakeRequest, lamp_file: Option<&[u8]>) -> Result<Scene, ViewerError> {
    let settings = request.settings()?;
    if !Scene::builtin_names().contains(&request.scene.as_str()) {
        return Err(ViewerError::Request(format!(
            "unknown scene `{}` (expected one of {})",
            request.scene,
            Scene::builtin_names().join(", ")
        )));
    }
    let mut scene = Scene::builtin_with_settings(&request.scene, settings)
        .map_err(|e| ViewerError::Request(e.to_string()))?;
    let spec = &request.lamp;
    let photometry = if spec.source == FILE_SOURCE {
        let bytes = lamp_file.ok_or_else(|| {
            ViewerError::Request("lamp source `file` but no file was loaded".into())
        })?;
        parse_lamp_file("lamp file", bytes)?
    } else {
        bundled_photometry(&spec.source)?
    };
    let (lo, hi) = MULTIPLIER_RANGE;
    if !(lo..=hi).contains(&spec.multiplier) {
        return Err(ViewerError::Setting {
            name: "multiplier",
            reason: format!("{lo} ..= {hi}, got {}", spec.multiplier),
        });
    }
    for (name, v) in [
        ("tilt_deg", spec.tilt_deg),
        ("azimuth_deg", spec.azimuth_deg),
        ("rotation_deg", spec.rotation_deg),
    ] {
        if !v.is_finite() {
            return Err(ViewerError::Setting {
                name,
                reason: format!("must be finite, got {v}"),
            });
        }
    }
    let default_position = scene
        .lamps
        .first()
        .map_or([0.0, ROOM_SIZE[1] - 0.05, 0.0], |l| {
            l.position.map(|c| c as f32)
        });
    let position = spec.position.unwrap_or(default_position);
    let half = [ROOM_SIZE[0] / 2.0, ROOM_SIZE[1], ROOM_SIZE[2] / 2.0];
    let inside = (0..3).all(|i| {
        let lo = if i == 1 { 0.0 } else { -half[i] };
        position[i].is_finite() && position[i] > lo && position[i] < half[i]
    });
    if !inside {
        return Err(ViewerError::Setting {
            name: "position",
            reason: format!(
                "the lamp must be inside the room (|x| < {}, 0 < y < {}, |z| < {}), got {position:?}",
                half[0], half[1], half[2]
            ),
        });
    }
    let mut lamp = Lamp::new(
        spec.source.clone(),
        Arc::new(photometry),
        position.map(f64::from),
    );
    lamp.aim = spec.aim();
    lamp.rotation_deg = spec.rotation_deg;
    lamp.multiplier = spec.multiplier;
    lamp.model = spec
        .lamp_model
        .parse()
        .map_err(|reason| ViewerError::Setting {
            name: "lamp_model",
            reason,
        })?;
    scene.lamps = vec![lamp];
    Ok(scene)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_request_builds_chairs_05_with_the_downlight() {
        let r = BakeRequest::default();
        let scene = build_scene(&r, None).unwrap();
        assert_eq!(scene.objects.len(), 6, "room + 5 chairs");
        assert_eq!(scene.lamps.len(), 1);
        let lamp = &scene.lamps[0];
        assert_eq!(lamp.aim, [0.0, -1.0, 0.0]);
        assert!((lamp.position[1] - f64::from(ROOM_SIZE[1] - 0.05)).abs() < 1e-6);
        assert_eq!(scene.settings.texels_per_metre, 32.0);
        let preset = Settings::default();
        assert_eq!(
            (
                scene.settings.method,
                scene.settings.rays,
                scene.settings.blur
            ),
            (preset.method, preset.rays, preset.blur)
        );
        assert_eq!(
            scene.settings,
            Settings {
                texels_per_metre: 32.0,
                ..preset
            }
        );
        let paper = BakeRequest::with_preset(Method::Paper, Quality::Default);
        let s = build_scene(&paper, None).unwrap().settings;
        assert_eq!((s.method, s.rays, s.bounces), (Method::Paper, 4, 3));
        assert_eq!(
            s,
            Settings {
                texels_per_metre: 32.0,
                ..Settings::paper()
            }
        );
        // The page's bounces are exact unless the request keeps the tail.
        let r = BakeRequest::from_json(r#"{"bounces":2,"tail":false}"#).unwrap();
        assert_eq!(
            (r.settings().unwrap().bounces, r.settings().unwrap().tail),
            (2, false)
        );
    }

    #[test]
    fn json_round_trips_and_missing_keys_default() {
        let r = BakeRequest::from_json(r#"{"scene":"chairs_01","rays":16}"#).unwrap();
        assert_eq!(r.scene, "chairs_01");
        assert_eq!(r.rays, 16);
        assert_eq!(r.bounces, Settings::default().bounces);
        assert_eq!(
            (r.method.as_str(), r.quality.as_str()),
            ("converged", "default")
        );
        let back = BakeRequest::from_json(&serde_json::to_string(&r).unwrap()).unwrap();
        assert_eq!(back, r);
        let e = BakeRequest::from_json(r#"{"scene":"chairs_01","rayz":16}"#).unwrap_err();
        assert!(e.to_string().contains("rayz"), "{e}");
    }

    #[test]
    fn every_bundled_lamp_parses_and_lights_downward() {
        for (id, _) in BUNDLED_LAMPS {
            let p = bundled_photometry(id).unwrap();
            assert!(p.intensity([0.0, 0.0, -1.0]) > 100.0, "{id}");
        }
        assert!(bundled_photometry("nope").is_err());
    }

    #[test]
    fn lamp_edits_reach_the_scene() {
        let mut r = BakeRequest::default();
        r.lamp.position = Some([1.0, 2.0, -0.5]);
        r.lamp.tilt_deg = 90.0;
        r.lamp.azimuth_deg = 90.0;
        r.lamp.multiplier = 0.25;
        r.lamp.source = "isotropic".into();
        let scene = build_scene(&r, None).unwrap();
        let lamp = &scene.lamps[0];
        assert_eq!(lamp.position, [1.0, 2.0, -0.5]);
        assert_eq!(lamp.multiplier, 0.25);
        assert!((lamp.aim[2] - 1.0).abs() < 1e-6 && lamp.aim[1].abs() < 1e-6);
        assert_eq!(lamp.model, luxbake::scene::LampModel::Auto);
        // `lamp_model`, also spelt `lampModel`.
        for json in [r#"{"lamp_model":"area"}"#, r#"{"lampModel":"area"}"#] {
            let spec: LampSpec = serde_json::from_str(json).unwrap();
            let r = BakeRequest {
                lamp: spec,
                ..BakeRequest::default()
            };
            let scene = build_scene(&r, None).unwrap();
            assert_eq!(scene.lamps[0].model, luxbake::scene::LampModel::Area);
        }
    }

    #[test]
    fn out_of_range_values_name_their_setting() {
        type Edit = Box<dyn Fn(&mut BakeRequest)>;
        let cases: Vec<(&str, Edit)> = vec![
            ("rays", Box::new(|r| r.rays = 0)),
            ("method", Box::new(|r| r.method = "fast".into())),
            ("quality", Box::new(|r| r.quality = "best".into())),
            ("bounces", Box::new(|r| r.bounces = 99)),
            ("blur_sigma", Box::new(|r| r.blur_sigma = f32::NAN)),
            ("texels_per_metre", Box::new(|r| r.texels_per_metre = 0.0)),
            ("multiplier", Box::new(|r| r.lamp.multiplier = -1.0)),
            (
                "position",
                Box::new(|r| r.lamp.position = Some([9.0, 1.0, 0.0])),
            ),
            (
                "position",
                Box::new(|r| r.lamp.position = Some([0.0, f32::NAN, 0.0])),
            ),
            ("tilt_deg", Box::new(|r| r.lamp.tilt_deg = f32::INFINITY)),
            (
                "lamp_model",
                Box::new(|r| r.lamp.lamp_model = "disk".into()),
            ),
        ];
        for (name, edit) in cases {
            let mut r = BakeRequest::default();
            edit(&mut r);
            let e = build_scene(&r, None).unwrap_err();
            assert!(e.to_string().contains(name), "{name}: {e}");
        }
        let r = BakeRequest {
            scene: "kitchen".into(),
            ..BakeRequest::default()
        };
        assert!(
            build_scene(&r, None)
                .unwrap_err()
                .to_string()
                .contains("kitchen")
        );
    }

    #[test]
    fn a_file_lamp_needs_parseable_bytes() {
        let mut r = BakeRequest::default();
        r.lamp.source = FILE_SOURCE.into();
        assert!(build_scene(&r, None).is_err());
        let e =
            build_scene(&r, Some(b"IESNA:LM-63-2002\nTILT=NONE\n1 1000 1 garbage")).unwrap_err();
        assert!(matches!(e, ViewerError::Photometry { .. }), "{e}");
        let ok = build_scene(&r, Some(SYNTHETIC_ASYM_IES.as_bytes())).unwrap();
        assert_eq!(ok.lamps[0].name, FILE_SOURCE);
    }
}
