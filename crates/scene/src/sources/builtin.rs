//! The built-in scenes and lamps.
//!
//! | name        | content                                                                 |
//! |-------------|-------------------------------------------------------------------------|
//! | `chairs_01` | the room ([`ROOM_SIZE`]) with 1 chair under the default downlight        |
//! | `chairs_03` | … 3 chairs                                                              |
//! | `chairs_05` | … 5 chairs (the default scene of `cargo xtask bake`)                    |
//! | `chairs_10` | … 10 chairs                                                             |
//! | `sofa_01`   | the room with one sofa under the default downlight                      |
//! | `floor`     | a [`FLOOR_SIZE`] m square floor, no walls, isotropic lamp at [`FLOOR_LAMP_HEIGHT`] |
//! | `sphere`    | closed inward sphere of [`SPHERE_RADIUS`], isotropic lamp at its centre  |
//!
//! The furnished scenes are the paper's test cases (Table 1, Figure 11): the room has 12
//! triangles, a chair 240 and the sofa 2,024, so the scenes have exactly the paper's 252,
//! 732, 1,212, 2,412 and 2,036 triangles. The paper gave each chair a 256² map, the sofa 512²
//! and the room six 256² maps; here the density is uniform per object, the chairs at
//! [`CHAIR_TEXEL_SCALE`] and the sofa at [`SOFA_TEXEL_SCALE`] × the scene density, which
//! lands the texel counts near Table 1 at the default 64 texels per metre (see the tests of
//! this module for the exact numbers).
//!
//! The lamp of the furnished scenes is [`default_photometry`], a recessed downlight authored
//! for this project as an LM-63-2002 file (`crates/scene/lamps/luxbake_downlight.ies`,
//! embedded in the binary), hanging at the ceiling's centre aimed straight down.

use std::sync::{Arc, OnceLock};

use luxbake_ies::Photometry;

use crate::sources::meshes::{self, RoomAlbedo};
use crate::{
    Albedo, Lamp, Mesh, Object, Scene, SceneError, Settings, Transform, chart_padding_texels,
};

impl Scene {
    /// A built-in scene by name (see [`Scene::builtin_names`] and [`crate::sources::builtin`]),
    /// at the default texel density.
    pub fn builtin(name: &str) -> Result<Scene, SceneError> {
        scene(name, Settings::default())
    }

    /// A built-in scene with the given settings; the procedural meshes' chart padding is
    /// sized for `settings.texels_per_metre` and `settings.blur`
    /// ([`chart_padding_texels`]); use this rather than setting a higher density or a wider
    /// blur on a [`Scene::builtin`] afterwards.
    pub fn builtin_with_settings(name: &str, settings: Settings) -> Result<Scene, SceneError> {
        scene(name, settings)
    }

    /// The names [`Scene::builtin`] accepts.
    pub fn builtin_names() -> &'static [&'static str] {
        NAMES
    }
}

/// The names [`scene`] accepts.
pub const NAMES: &[&str] = &[
    "chairs_01",
    "chairs_03",
    "chairs_05",
    "chairs_10",
    "sofa_01",
    "floor",
    "sphere",
];

/// Room size of the furnished scenes: x, height, z in metres (floor centred on the origin).
pub const ROOM_SIZE: [f32; 3] = [5.0, 2.6, 4.0];
/// Room albedos of the furnished scenes (linear RGB): oak floor, off-white walls, white ceiling.
pub const ROOM_ALBEDO: RoomAlbedo = RoomAlbedo {
    floor: [0.42, 0.30, 0.20],
    walls: [0.75, 0.72, 0.68],
    ceiling: [0.85, 0.85, 0.85],
};
/// Chair albedo (linear RGB, light wood).
pub const CHAIR_ALBEDO: [f32; 3] = [0.55, 0.38, 0.22];
/// Sofa albedo (linear RGB, blue fabric).
pub const SOFA_ALBEDO: [f32; 3] = [0.20, 0.28, 0.50];
/// Texel-density multiplier of the built-in chair: its map is close to the paper's 256².
pub const CHAIR_TEXEL_SCALE: f32 = 2.8;
/// Texel-density multiplier of the built-in sofa: its map is close to the paper's 512².
pub const SOFA_TEXEL_SCALE: f32 = 1.9;
/// Distance of the downlight's photometric centre below the ceiling, metres.
pub const LAMP_BELOW_CEILING: f32 = 0.05;

/// Side of the `floor` scene's square floor, metres.
pub const FLOOR_SIZE: f32 = 20.0;
/// Height of the `floor` scene's lamp above the floor (at x = z = 0), metres.
pub const FLOOR_LAMP_HEIGHT: f32 = 2.0;
/// Intensity of the isotropic lamps of the `floor` and `sphere` scenes, candela.
pub const ISOTROPIC_CANDELA: f64 = 1000.0;
/// Albedo of the `floor` and `sphere` scenes.
pub const ANALYTIC_ALBEDO: f32 = 0.5;
/// Radius of the `sphere` scene, metres (centred on the origin).
pub const SPHERE_RADIUS: f32 = 1.0;

/// Chair placements (x, z, turn about +Y in degrees) of the `chairs_NN` scenes; `chairs_NN`
/// uses the first NN.
pub const CHAIR_PLACEMENTS: [[f32; 3]; 10] = [
    [0.3, -0.5, 15.0],
    [-1.0, 0.6, 200.0],
    [1.4, 0.7, 170.0],
    [-1.6, -0.7, 10.0],
    [1.5, -0.9, -20.0],
    [-0.3, 0.8, 185.0],
    [0.6, 0.9, 175.0],
    [-0.7, -0.6, 5.0],
    [2.0, 0.0, -90.0],
    [-2.0, 0.1, 90.0],
];
/// Sofa placement (x, z, turn about +Y in degrees) of `sofa_01`: against the −Z wall.
pub const SOFA_PLACEMENT: [f32; 3] = [0.0, -1.2, 0.0];

/// The embedded LM-63-2002 file of the default downlight.
pub const DEFAULT_LAMP_IES: &str = include_str!("../../lamps/luxbake_downlight.ies");

/// The default downlight's photometry, parsed once from [`DEFAULT_LAMP_IES`].
pub fn default_photometry() -> Result<Arc<Photometry>, SceneError> {
    static CELL: OnceLock<Result<Arc<Photometry>, String>> = OnceLock::new();
    CELL.get_or_init(|| {
        Photometry::parse(DEFAULT_LAMP_IES.as_bytes())
            .map(Arc::new)
            .map_err(|e| e.to_string())
    })
    .clone()
    .map_err(|e| SceneError::Photometry {
        key: "builtin:downlight".into(),
        file: "crates/scene/lamps/luxbake_downlight.ies".into(),
        source: e.into(),
    })
}

/// The default downlight at `position`, aimed straight down.
pub fn default_lamp(position: [f64; 3]) -> Result<Lamp, SceneError> {
    Ok(Lamp::new("downlight", default_photometry()?, position))
}

/// An isotropic lamp of `candela` in every direction at `position`.
pub fn isotropic_lamp(candela: f64, position: [f64; 3]) -> Lamp {
    Lamp::new(
        format!("isotropic {candela} cd"),
        Arc::new(Photometry::isotropic(candela)),
        position,
    )
}

/// Chart padding in metres for an object at `settings.texels_per_metre × texel_scale`:
/// [`chart_padding_texels`]`(settings.blur)` texels.
pub fn padding_m(settings: &Settings, texel_scale: f32) -> f32 {
    let d = settings.texels_per_metre * texel_scale;
    if d.is_finite() && d > 0.0 {
        chart_padding_texels(settings.blur) / d
    } else {
        0.0
    }
}

fn object(name: impl Into<String>, mesh: Mesh, transform: Transform, albedo: [f32; 3]) -> Object {
    Object {
        name: name.into(),
        mesh,
        transform,
        albedo: Albedo {
            factor: albedo,
            texture: None,
        },
        receiver: true,
        texel_scale: 1.0,
    }
}

/// The room object of the furnished scenes.
fn room(settings: &Settings) -> Object {
    let mesh = meshes::room(ROOM_SIZE, ROOM_ALBEDO, padding_m(settings, 1.0));
    object("room", mesh, Transform::IDENTITY, [1.0; 3])
}

fn placed(placement: [f32; 3]) -> Transform {
    Transform::from_trs(
        [f64::from(placement[0]), 0.0, f64::from(placement[1])],
        [0.0, placement[2], 0.0],
        [1.0; 3],
    )
}

/// Builds the built-in scene `name` with `settings`.
pub fn scene(name: &str, settings: Settings) -> Result<Scene, SceneError> {
    let ceiling_lamp = [0.0, f64::from(ROOM_SIZE[1] - LAMP_BELOW_CEILING), 0.0];
    let (objects, lamps) = match name {
        "chairs_01" | "chairs_03" | "chairs_05" | "chairs_10" => {
            let count: usize = name[7..].parse().unwrap_or(1);
            let chair = meshes::chair(padding_m(&settings, CHAIR_TEXEL_SCALE));
            let mut objects = vec![room(&settings)];
            for (i, p) in CHAIR_PLACEMENTS.iter().take(count).enumerate() {
                let mut o = object(
                    format!("chair_{:02}", i + 1),
                    chair.clone(),
                    placed(*p),
                    CHAIR_ALBEDO,
                );
                o.texel_scale = CHAIR_TEXEL_SCALE;
                objects.push(o);
            }
            (objects, vec![default_lamp(ceiling_lamp)?])
        }
        "sofa_01" => {
            let mut sofa = object(
                "sofa",
                meshes::sofa(padding_m(&settings, SOFA_TEXEL_SCALE)),
                placed(SOFA_PLACEMENT),
                SOFA_ALBEDO,
            );
            sofa.texel_scale = SOFA_TEXEL_SCALE;
            (
                vec![room(&settings), sofa],
                vec![default_lamp(ceiling_lamp)?],
            )
        }
        "floor" => {
            let mesh = meshes::plane([FLOOR_SIZE; 2], padding_m(&settings, 1.0));
            (
                vec![object(
                    "floor",
                    mesh,
                    Transform::IDENTITY,
                    [ANALYTIC_ALBEDO; 3],
                )],
                vec![isotropic_lamp(
                    ISOTROPIC_CANDELA,
                    [0.0, f64::from(FLOOR_LAMP_HEIGHT), 0.0],
                )],
            )
        }
        "sphere" => {
            let mesh = meshes::sphere(
                SPHERE_RADIUS,
                meshes::SPHERE_SEGMENTS,
                true,
                padding_m(&settings, 1.0),
            );
            (
                vec![object(
                    "sphere",
                    mesh,
                    Transform::IDENTITY,
                    [ANALYTIC_ALBEDO; 3],
                )],
                vec![isotropic_lamp(ISOTROPIC_CANDELA, [0.0; 3])],
            )
        }
        _ => {
            return Err(SceneError::UnknownBuiltin {
                name: name.to_string(),
                known: NAMES.join(", "),
            });
        }
    };
    Ok(Scene {
        objects,
        lamps,
        settings,
    })
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    /// World bounding box of an object.
    fn bounds(o: &Object) -> [[f32; 3]; 2] {
        let mut b = [[f32::INFINITY; 3], [f32::NEG_INFINITY; 3]];
        for &p in &o.mesh.positions {
            let w = o.transform.point(p);
            for k in 0..3 {
                b[0][k] = b[0][k].min(w[k]);
                b[1][k] = b[1][k].max(w[k]);
            }
        }
        b
    }

    #[test]
    fn every_name_builds() {
        assert_eq!(Scene::builtin_names(), NAMES);
        for name in NAMES {
            let s = Scene::builtin(name).unwrap_or_else(|e| panic!("{name}: {e}"));
            s.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(s.lamps.len(), 1, "{name}");
            assert!(s.objects.iter().all(|o| o.receiver));
        }
        match Scene::builtin("chairs_02") {
            Err(SceneError::UnknownBuiltin { name, known }) => {
                assert_eq!(name, "chairs_02");
                assert!(known.contains("chairs_05") && known.contains("sphere"));
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn default_lamp_is_a_downlight() {
        let p = default_photometry().expect("embedded IES file parses");
        let down = p.intensity([0.0, 0.0, -1.0]);
        let up = p.intensity([0.0, 0.0, 1.0]);
        assert!(down > 100.0 && up == 0.0, "down {down} cd, up {up} cd");
        let l = default_lamp([0.0, 2.0, 0.0]).expect("lamp");
        assert_eq!(
            (l.aim, l.rotation_deg, l.multiplier),
            ([0.0, -1.0, 0.0], 0.0, 1.0)
        );
        let iso = isotropic_lamp(250.0, [0.0; 3]);
        assert_eq!(iso.photometry.intensity([0.6, 0.0, 0.8]), 250.0);
    }

    #[test]
    fn furniture_stands_in_the_room_without_overlap() {
        for name in ["chairs_10", "sofa_01"] {
            let s = Scene::builtin(name).expect("builtin");
            let room = bounds(&s.objects[0]);
            let lamp = s.lamps[0].position.map(|c| c as f32);
            let furniture: Vec<_> = s.objects[1..].iter().map(bounds).collect();
            for (i, b) in furniture.iter().enumerate() {
                for k in 0..3 {
                    assert!(
                        b[0][k] >= room[0][k] - 1e-6 && b[1][k] <= room[1][k],
                        "{name}: object {i} leaves the room"
                    );
                }
                assert!(
                    b[0][1].abs() < 1e-6,
                    "{name}: object {i} stands on the floor"
                );
                assert!(b[1][1] < lamp[1] - 1.0, "{name}: lamp above the furniture");
                for (j, c) in furniture.iter().enumerate().skip(i + 1) {
                    let apart = (0..3).any(|k| b[1][k] <= c[0][k] || c[1][k] <= b[0][k]);
                    assert!(apart, "{name}: objects {i} and {j} overlap");
                }
            }
            assert!(lamp[1] < room[1][1] && lamp[1] > room[1][1] - 0.1);
        }
        let s = Scene::builtin("chairs_05").expect("builtin");
        let names: Vec<&str> = s.objects.iter().map(|o| o.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "room", "chair_01", "chair_02", "chair_03", "chair_04", "chair_05"
            ]
        );
    }

    #[test]
    fn analytic_scenes() {
        let s = Scene::builtin("floor").expect("floor");
        let b = bounds(&s.objects[0]);
        assert_eq!(b, [[-10.0, 0.0, -10.0], [10.0, 0.0, 10.0]]);
        assert_eq!(
            s.lamps[0].position,
            [0.0, f64::from(FLOOR_LAMP_HEIGHT), 0.0]
        );
        assert_eq!(
            s.lamps[0].photometry.intensity([0.3, 0.4, -0.5]),
            ISOTROPIC_CANDELA
        );
        assert_eq!(s.objects[0].albedo.factor, [ANALYTIC_ALBEDO; 3]);
        let s = Scene::builtin("sphere").expect("sphere");
        assert_eq!(s.lamps[0].position, [0.0; 3]);
        let m = &s.objects[0].mesh;
        for (p, n) in m.positions.iter().zip(&m.normals) {
            let (p, n) = (Vec3::from(*p).as_dvec3(), Vec3::from(*n).as_dvec3());
            assert!((p.length() - f64::from(SPHERE_RADIUS)).abs() < 1e-6);
            assert!(p.dot(n) < 0.0, "inward");
        }
    }

    /// Chart padding follows the density the scene is built for (what it does to the layout:
    /// the workspace's `tests/tests/scene_layout.rs`).
    #[test]
    fn padding_follows_the_density() {
        let coarse = Settings {
            texels_per_metre: 16.0,
            ..Settings::default()
        };
        assert_eq!(Settings::default().blur, crate::Blur::Sigma(1.0));
        assert_eq!(padding_m(&coarse, 2.0), 5.0 / 32.0);
        let paper = Settings {
            texels_per_metre: 16.0,
            ..Settings::paper()
        };
        assert_eq!(padding_m(&paper, 2.0), 8.0 / 32.0);
        let none = Settings {
            texels_per_metre: 0.0,
            ..Settings::default()
        };
        assert_eq!(padding_m(&none, 1.0), 0.0);
    }
}
