//! The shared test models (`../shared/models`): each loads, bakes on the CPU backend at a
//! small texel density, exports, and re-imports with the same triangles and light-map UVs;
//! generated UVs do not overlap and keep their padding; a room of SheenChairs and a
//! GlamVelvetSofa bakes the same on glow as on the CPU. Skipped with a message when the
//! models are absent.

mod common;

use common::{check_charts, models_dir};

use std::path::{Path, PathBuf};
use std::sync::Arc;

use luxbake::bake::{BakeOutput, bake};
use luxbake::scene::{Albedo, Lamp, Object, Scene, Settings, Transform};
use luxbake::sources::meshes::{self, RoomAlbedo};
use luxbake_assets::uv::{self, UnwrapOptions};
use luxbake_assets::{GltfSource, ImportOptions, Limits, Model, UvSource, export, import};
use luxbake_backend_cpu::CpuBackend;
use luxbake_ies::Photometry;

fn settings() -> Settings {
    Settings {
        texels_per_metre: 24.0,
        rays: 8,
        bounces: 1,
        ..Settings::default()
    }
}

fn options(s: &Settings) -> ImportOptions {
    ImportOptions {
        limits: Limits::default(),
        unwrap: UnwrapOptions {
            texels_per_metre: s.texels_per_metre,
            padding_texels: uv::padding_texels(s.blur),
            scale: [1.0; 3],
        },
    }
}

fn objects(model: &Model, transform: Transform, prefix: &str) -> Vec<Object> {
    model
        .parts
        .iter()
        .map(|p| Object {
            name: format!("{prefix}{}", p.name),
            mesh: p.mesh.clone(),
            transform,
            albedo: p.albedo.clone(),
            receiver: true,
            texel_scale: 1.0,
        })
        .collect()
}

/// Bounding box of a model's positions.
fn bounds(model: &Model) -> ([f32; 3], [f32; 3]) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in model.parts.iter().flat_map(|p| &p.mesh.positions) {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

fn floor(s: &Settings, y: f32) -> Object {
    Object {
        name: "ground_plane".into(),
        mesh: meshes::plane([6.0, 6.0], 4.0 / s.texels_per_metre),
        transform: Transform::from_trs([0.0, f64::from(y), 0.0], [0.0; 3], [1.0; 3]),
        albedo: Albedo::grey(0.5),
        receiver: true,
        texel_scale: 1.0,
    }
}

fn cpu_bake(scene: &Scene) -> BakeOutput {
    bake(&mut CpuBackend::new(), scene, &scene.settings, &mut |_| {}).expect("CPU bake")
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("luxbake-assets-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

#[test]
fn each_model_loads_bakes_exports_and_reimports() {
    let Some(dir) = models_dir("each_model_loads_bakes_exports_and_reimports") else {
        return;
    };
    let s = settings();
    let cases: [(&str, usize, bool); 4] = [
        ("SheenChair/SheenChair.glb", 39_936, true),
        ("GlamVelvetSofa/GlamVelvetSofa.glb", 4_196, false),
        // Its glass (transmission) and shade (BLEND) primitives are left out.
        ("LightsPunctualLamp/LightsPunctualLamp.gltf", 4_070, false),
        ("CornellBox/CornellBox-Original.obj", 36, false),
    ];
    for (file, triangles, own_uvs) in cases {
        let model = import(&dir.join(file), &options(&s)).unwrap_or_else(|e| panic!("{file}: {e}"));
        assert_eq!(model.triangle_count(), triangles, "{file}");
        for p in &model.parts {
            p.mesh
                .validate()
                .unwrap_or_else(|e| panic!("{file} {}: {e}", p.name));
            assert_eq!(
                matches!(p.uv_source, UvSource::Own),
                own_uvs,
                "{file} {}: {:?}",
                p.name,
                p.uv_source
            );
        }
        let (lo, hi) = bounds(&model);
        let lamps: Vec<Lamp> = if model.lights.is_empty() {
            let top = [
                (lo[0] + hi[0]) / 2.0,
                hi[1] + 1.0,
                (lo[2] + hi[2]) / 2.0 + 0.3,
            ];
            vec![Lamp::new(
                "iso",
                Arc::new(Photometry::isotropic(200.0)),
                top.map(f64::from),
            )]
        } else {
            model.lights.iter().map(|l| l.to_lamp(None)).collect()
        };
        let mut objs = objects(&model, Transform::IDENTITY, "");
        objs.push(floor(&s, lo[1] - 0.01));
        let scene = Scene {
            objects: objs,
            lamps,
            settings: s.clone(),
        };
        let out = cpu_bake(&scene);
        let source = if own_uvs { "own" } else { "generated" };
        let model_texels: u64 = out.layout.regions[..model.parts.len()]
            .iter()
            .flatten()
            .map(|r| r.texel_count())
            .sum();
        println!(
            "{file}: {triangles} triangles, UVs {source}, {model_texels} light-map region texels \
             of the model (scene incl. floor: {} region, {} valid) at {} texels/m, CPU bake {:.2} s",
            out.report.region_texels,
            out.report.texels,
            s.texels_per_metre,
            out.report.total_seconds
        );
        let lit: f64 = out
            .maps
            .iter()
            .flat_map(|m| m.illuminance().valid_rgb())
            .map(|c| f64::from(c[0] + c[1] + c[2]))
            .sum();
        assert!(lit > 0.0 && lit.is_finite(), "{file}: the bake is dark");

        let tmp = temp_dir(&file.replace('/', "_"));
        let glb = tmp.join("baked.glb");
        let report = export::export_baked(&scene, &out, &glb).expect("export");
        assert_eq!(report.exr.len(), out.maps.len());
        for (e, m) in report.exr.iter().zip(&out.maps) {
            let back = luxbake_output::read_exr(e).expect("EXR");
            assert_eq!(
                (back.width, back.height),
                (m.illuminance().width, m.illuminance().height)
            );
        }
        let again = import(&glb, &options(&s)).expect("re-import");
        assert_eq!(again.triangle_count(), scene.triangle_count(), "{file}");
        assert_eq!(again.parts.len(), scene.objects.len());
        for (p, o) in again.parts.iter().zip(&scene.objects) {
            assert_eq!(p.uv_source, UvSource::Own, "{file} {}", o.name);
            assert_eq!(
                p.mesh.lightmap_uvs, o.mesh.lightmap_uvs,
                "{file} {}",
                o.name
            );
            assert_eq!(p.mesh.indices, o.mesh.indices);
            for (a, b) in p.mesh.positions.iter().zip(&o.mesh.positions) {
                let w = o.transform.point(*b);
                assert!((0..3).all(|k| (a[k] - w[k]).abs() < 1e-4), "{a:?} {w:?}");
            }
        }
        std::fs::remove_dir_all(&tmp).ok();
    }
}

#[test]
fn generated_uvs_do_not_overlap_and_keep_the_padding() {
    let Some(dir) = models_dir("generated_uvs_do_not_overlap_and_keep_the_padding") else {
        return;
    };
    let s = settings();
    let pad = uv::padding_texels(s.blur);
    let mut checked = 0;
    for file in [
        "GlamVelvetSofa/GlamVelvetSofa.glb",
        "CornellBox/CornellBox-Original.obj",
        "LightsPunctualLamp/LightsPunctualLamp.gltf",
    ] {
        let model = import(&dir.join(file), &options(&s)).expect("import");
        for o in objects(&model, Transform::IDENTITY, "") {
            check_charts(&format!("{file} "), &o, s.texels_per_metre, pad);
            checked += 1;
        }
    }
    assert!(checked >= 10);
}

#[test]
fn parts_name_their_gltf_origin_and_the_file_vertex_of_each_vertex() {
    let Some(dir) = models_dir("parts_name_their_gltf_origin_and_the_file_vertex_of_each_vertex")
    else {
        return;
    };
    // GlamVelvetSofa: nodes 0..3 each instantiate mesh i (one primitive), no TEXCOORD_1; its
    // POSITION accessors hold 342, 2092 and 684 vertices.
    let model = import(
        &dir.join("GlamVelvetSofa/GlamVelvetSofa.glb"),
        &options(&settings()),
    )
    .expect("import");
    let counts = [342, 2092, 684];
    assert_eq!(model.parts.len(), 3);
    for (i, part) in model.parts.iter().enumerate() {
        assert_eq!(
            part.gltf,
            Some(GltfSource {
                node: i,
                mesh: i,
                primitive: 0
            }),
            "{}",
            part.name
        );
        assert!(matches!(part.uv_source, UvSource::Generated { .. }));
        let sv = part
            .source_vertex
            .as_ref()
            .expect("generated UVs name source vertices");
        assert_eq!(sv.len(), part.mesh.positions.len(), "{}", part.name);
        assert!(
            sv.len() >= counts[i],
            "{}: seams only add vertices",
            part.name
        );
        assert!(
            sv.iter().all(|&v| (v as usize) < counts[i]),
            "{}",
            part.name
        );
    }
    // A file written by the exporter keeps its own UVs and vertices.
    let out = temp_dir("gltf_origin");
    let mut room = Scene::builtin("chairs_01").expect("chairs_01");
    room.lamps.clear();
    let path = out.join("chairs_01.glb");
    export::export_scene(&room, &path).expect("export");
    let model = import(&path, &options(&settings())).expect("reimport");
    for (i, part) in model.parts.iter().enumerate() {
        assert_eq!(part.uv_source, UvSource::Own, "{}", part.name);
        assert_eq!(part.source_vertex, None);
        assert_eq!(part.gltf.map(|g| (g.mesh, g.primitive)), Some((i, 0)));
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// A minimal glTF with one triangle in a data-URI buffer (positions, then u16 indices).
fn triangle_gltf(positions: [[f32; 3]; 3], extra: &str) -> String {
    let mut bytes: Vec<u8> = positions
        .iter()
        .flatten()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    bytes.extend([0u16, 1, 2, 0].iter().flat_map(|i| i.to_le_bytes()));
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut b64 = String::new();
    for c in bytes.chunks(3) {
        let n = (u32::from(c[0]) << 16)
            | (u32::from(*c.get(1).unwrap_or(&0)) << 8)
            | u32::from(*c.get(2).unwrap_or(&0));
        for k in 0..=c.len() {
            b64.push(T[(n >> (18 - 6 * k) & 63) as usize] as char);
        }
    }
    format!(
        r#"{{"asset":{{"version":"2.0"}},{extra}"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,1]}},
                     {{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":6}}],
        "buffers":[{{"byteLength":44,"uri":"data:application/octet-stream;base64,{b64}"}}]}}"#
    )
}

fn import_text(text: &str) -> Result<Model, luxbake_assets::AssetError> {
    import_text_bytes(text.as_bytes())
}

fn import_text_bytes(bytes: &[u8]) -> Result<Model, luxbake_assets::AssetError> {
    luxbake_assets::gltf_in::import_bytes(
        bytes,
        Path::new("/nonexistent/t.gltf"),
        &ImportOptions::default(),
    )
}

#[test]
fn bad_gltf_gives_clear_errors() {
    let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]];
    let ok = import_text(&triangle_gltf(tri, "")).expect("valid triangle");
    assert_eq!(ok.triangle_count(), 1);
    assert!(matches!(ok.parts[0].uv_source, UvSource::Generated { .. }));

    let mut nan = tri;
    nan[1][2] = f32::NAN;
    let e = import_text(&triangle_gltf(nan, ""))
        .expect_err("NaN")
        .to_string();
    assert!(e.contains("POSITION 1 is not finite"), "{e}");

    let required = r#""extensionsUsed":["KHR_draco_mesh_compression","EXT_foo"],"extensionsRequired":["KHR_draco_mesh_compression"],"#;
    let e = import_text(&triangle_gltf(tri, required))
        .expect_err("required")
        .to_string();
    assert!(
        e.contains("requires unsupported") && e.contains("KHR_draco_mesh_compression"),
        "{e}"
    );
    let used = r#""extensionsUsed":["EXT_foo"],"#;
    let m = import_text(&triangle_gltf(tri, used)).expect("used only");
    assert!(
        m.warnings.iter().any(|w| w.contains("EXT_foo")),
        "{:?}",
        m.warnings
    );

    let missing =
        triangle_gltf(tri, "").replace("data:application/octet-stream;base64,", "missing.bin#");
    let e = import_text(&missing)
        .expect_err("missing buffer")
        .to_string();
    assert!(e.contains("buffer 0") && e.contains("missing"), "{e}");

    let short = triangle_gltf(tri, "").replace("\"byteLength\":6}", "\"byteLength\":600}");
    assert!(import_text(&short).is_err());
    let past = triangle_gltf(tri, "").replace(
        "\"count\":3,\"type\":\"SCALAR\"",
        "\"count\":3000,\"type\":\"SCALAR\"",
    );
    assert!(import_text(&past).is_err());

    // Found by the `gltf` fuzz target: a GLB header declaring fewer bytes than itself.
    let mut glb = b"glTF\x02\x00\x00\x00\x04\x00\x00\x00".to_vec();
    let e = import_text_bytes(&glb).expect_err("short GLB").to_string();
    assert!(e.contains("less than the header"), "{e}");
    glb.truncate(9);
    assert!(import_text_bytes(&glb).is_err());
    // Also found by it: a POSITION accessor index past the accessors.
    let e = import_text(&triangle_gltf(tri, "").replace("\"POSITION\":0", "\"POSITION\":11"))
        .expect_err("accessor index")
        .to_string();
    assert!(e.contains("names accessor 11"), "{e}");

    let limits = ImportOptions {
        limits: Limits {
            max_triangles: 0,
            ..Limits::default()
        },
        ..ImportOptions::default()
    };
    let e = luxbake_assets::gltf_in::import_bytes(
        triangle_gltf(tri, "").as_bytes(),
        Path::new("t.gltf"),
        &limits,
    )
    .expect_err("limit")
    .to_string();
    assert!(e.contains("triangle count"), "{e}");
}

#[test]
fn truncated_model_files_never_panic() {
    let Some(dir) = models_dir("truncated_model_files_never_panic") else {
        return;
    };
    for file in [
        "SheenChair/SheenChair.glb",
        "GlamVelvetSofa/GlamVelvetSofa.glb",
        "LightsPunctualLamp/LightsPunctualLamp.gltf",
        "CornellBox/CornellBox-Original.obj",
    ] {
        let path = dir.join(file);
        let bytes = std::fs::read(&path).expect("read");
        let n = bytes.len();
        for cut in [0, 1, 12, 20, 100, n / 7, n / 3, n / 2, n - 1] {
            let prefix = &bytes[..cut];
            let r = if file.ends_with(".obj") {
                luxbake_assets::obj_in::import_bytes(prefix, &path, &ImportOptions::default())
            } else {
                luxbake_assets::gltf_in::import_bytes(prefix, &path, &ImportOptions::default())
            };
            if let Err(e) = r {
                assert!(!e.to_string().is_empty());
            }
        }
    }
    // A .gltf whose buffer file is missing.
    let tmp = temp_dir("missing-bin");
    let text = std::fs::read(dir.join("LightsPunctualLamp/LightsPunctualLamp.gltf")).expect("read");
    std::fs::write(tmp.join("lamp.gltf"), text).expect("write");
    let e = import(&tmp.join("lamp.gltf"), &ImportOptions::default())
        .expect_err("missing buffer")
        .to_string();
    assert!(e.contains("LightsPunctualLamp.data.bin"), "{e}");
    std::fs::remove_dir_all(&tmp).ok();
}

/// A 6 m × 2.6 m × 5 m room with three SheenChairs and a GlamVelvetSofa.
fn furnished_room(dir: &Path, s: &Settings) -> Scene {
    let chair = import(&dir.join("SheenChair/SheenChair.glb"), &options(s)).expect("chair");
    let sofa = import(&dir.join("GlamVelvetSofa/GlamVelvetSofa.glb"), &options(s)).expect("sofa");
    let mut objs = vec![Object {
        name: "room".into(),
        mesh: meshes::room(
            [6.0, 2.6, 5.0],
            RoomAlbedo::uniform([0.7, 0.7, 0.7]),
            uv::padding_texels(s.blur) / s.texels_per_metre,
        ),
        transform: Transform::IDENTITY,
        albedo: Albedo::grey(1.0),
        receiver: true,
        texel_scale: 1.0,
    }];
    for (i, x) in [-1.5f64, 0.0, 1.5].iter().enumerate() {
        let t = Transform::from_trs([*x, 0.0, 1.2], [0.0, 180.0, 0.0], [1.0; 3]);
        objs.extend(objects(&chair, t, &format!("chair{i}_")));
    }
    objs.extend(objects(
        &sofa,
        Transform::from_trs([0.0, 0.0, -1.6], [0.0; 3], [1.0; 3]),
        "sofa_",
    ));
    Scene {
        objects: objs,
        lamps: vec![Lamp::new(
            "iso",
            Arc::new(Photometry::isotropic(300.0)),
            [0.3, 2.4, 0.2],
        )],
        settings: s.clone(),
    }
}

#[test]
fn furnished_room_bakes_the_same_on_glow_and_cpu() {
    let Some(dir) = models_dir("furnished_room_bakes_the_same_on_glow_and_cpu") else {
        return;
    };
    let s = Settings {
        texels_per_metre: 16.0,
        rays: 8,
        ..settings()
    };
    let scene = furnished_room(&dir, &s);
    let Some(mut glow) = luxbake_testkit::or_skip(
        "the glow comparison",
        luxbake_backend_glow::GlowBackend::headless(),
        luxbake_backend_glow::GlowError::is_driver_missing,
    ) else {
        return;
    };
    let cpu = cpu_bake(&scene);
    let gpu = bake(&mut glow, &scene, &scene.settings, &mut |_| {}).expect("glow bake");
    println!(
        "furnished room: {} triangles, {} texels; CPU {:.2} s, glow {:.2} s",
        scene.triangle_count(),
        cpu.report.texels,
        cpu.report.total_seconds,
        gpu.report.total_seconds
    );
    let (mut se, mut sd, mut masks) = (0.0f64, 0.0f64, 0usize);
    assert_eq!(cpu.maps.len(), gpu.maps.len());
    for (c, g) in cpu.maps.iter().zip(&gpu.maps) {
        let (c, g) = (c.illuminance(), g.illuminance());
        assert_eq!((c.width, c.height), (g.width, g.height));
        for (a, b) in c.texels.chunks_exact(4).zip(g.texels.chunks_exact(4)) {
            if (a[3] > 0.5) != (b[3] > 0.5) {
                masks += 1;
                continue;
            }
            if a[3] > 0.5 {
                for k in 0..3 {
                    se += f64::from(a[k]) * f64::from(a[k]);
                    sd += f64::from(a[k] - b[k]).powi(2);
                }
            }
        }
    }
    let rel = (sd / se).sqrt();
    println!("glow vs CPU: relative RMSE {rel:.2e}, {masks} mask mismatches");
    assert_eq!(masks, 0);
    assert!(rel < 1e-2, "glow and CPU differ: relative RMSE {rel}");
}
