//! What the scene crate builds meets the bake's layout and rasteriser: scene-file overrides lay
//! out as the same keys in the file, scaled scenes keep their maps, chart padding follows the
//! density, and the meshes of every built-in and closed-form scene keep their charts apart and
//! at uniform texel density where the layout sizes and the G-buffer rasterises them.

use std::collections::HashMap;
use std::path::Path;

use glam::{DVec2, DVec3, Vec3};
use luxbake::gbuffer::overlaps;
use luxbake::layout::{Layout, lightmap_extent, map_size};
use luxbake::scene::{Mesh, Object, Scene, Settings, SettingsPatch};
use luxbake::sources::{closed_forms, scenefile};

fn layout(s: &Scene) -> Layout {
    Layout::new(s, 4096, 64).expect("layout")
}

fn example() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../crates/scene/scenes/living_room.toml")
}

/// `--texels-per-metre 32` over a scene file (the one overlay, applied before the objects are
/// built) gives the layout and padding of `texels_per_metre = 32` in the file.
#[test]
fn a_density_override_lays_out_as_the_file_key() {
    let path = example();
    let text = std::fs::read_to_string(&path).expect("example");
    let key = "texels_per_metre = 48.0";
    assert!(text.contains(key), "the example names {key}");
    let written = text.replacen(key, "texels_per_metre = 32", 1);
    let in_file = scenefile::from_str(&written, path.parent().expect("dir"), None).expect("file");
    let patch = SettingsPatch {
        texels_per_metre: Some(32.0),
        ..SettingsPatch::default()
    };
    let overridden = scenefile::from_file_patched(&path, None, &patch).expect("override");
    let plain = Scene::from_toml_file(&path).expect("plain");
    assert_eq!(overridden.settings, in_file.settings);
    assert_eq!(overridden.objects, in_file.objects);
    let (a, b) = (layout(&overridden), layout(&in_file));
    assert_eq!(a, b);
    assert_ne!(a, layout(&plain), "the density changes the layout");
    assert!(layout(&plain).texel_count() > 100_000);
}

#[test]
fn scaling_a_scene_keeps_its_maps() {
    let s = Scene::builtin("chairs_01").expect("builtin");
    for f in [1e-3f32, 1e3] {
        let t = s.scaled(f);
        // At 1/1000 scale: 64 000 texels per metre, as valid as 64.
        assert_eq!(t.settings.texels_per_metre, 64.0 / f);
        assert_eq!(t.settings.validate(), Ok(()), "scale {f}");
        assert_eq!(layout(&s), layout(&t), "scale {f}");
        let p = s.objects[1].transform.point([0.1, 0.2, 0.3]);
        let q = t.objects[1].transform.point([0.1, 0.2, 0.3]);
        for k in 0..3 {
            assert!((q[k] - p[k] * f).abs() <= 1e-5 * f.max(1.0), "{p:?} {q:?}");
        }
        assert_eq!(
            t.lamps[0].position,
            s.lamps[0].position.map(|v| v * f64::from(f))
        );
    }
}

/// A quarter of the density keeps 5 texels of padding: the chair's region is more than a
/// quarter of its size at the default density.
#[test]
fn padding_follows_the_density() {
    let coarse = Settings {
        texels_per_metre: 16.0,
        ..Settings::default()
    };
    let s = Scene::builtin_with_settings("chairs_01", coarse).expect("builtin");
    let d = Scene::builtin("chairs_01").expect("builtin");
    let chair = |s: &Scene| Layout::new(s, 4096, 8).expect("layout").regions[1].expect("chair");
    let (r, rd) = (chair(&s), chair(&d));
    assert!(
        r.size[0] * 4 > rd.size[0] && r.size[0] * 3 < rd.size[0],
        "{r:?} vs {rd:?}"
    );
}

/// Every object of every built-in scene, the closed box and the closed sphere, at the density
/// its scene is built for.
fn all_objects() -> Vec<(String, Object, f32)> {
    let mut scenes: Vec<(String, Scene)> = Scene::builtin_names()
        .iter()
        .map(|&n| (n.to_string(), Scene::builtin(n).expect("builtin")))
        .collect();
    let settings = Settings::default();
    scenes.push((
        "cie_171_5_8".into(),
        closed_forms::cie_171_5_8(0.5, settings.clone()).0,
    ));
    scenes.push((
        "closed_sphere".into(),
        closed_forms::closed_sphere(1.0, 0.5, 10.0, settings).0,
    ));
    let mut out = Vec::new();
    for (name, s) in scenes {
        for o in s.objects {
            if o.receiver {
                out.push((format!("{name}/{}", o.name), o, s.settings.texels_per_metre));
            }
        }
    }
    assert!(out.len() >= 10, "{} objects", out.len());
    out
}

/// Chart id per triangle: triangles sharing a light-map UV point are in the same chart.
fn charts(m: &Mesh) -> Vec<u32> {
    let mut parent: Vec<usize> = (0..m.indices.len()).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let mut first: HashMap<[u32; 2], usize> = HashMap::new();
    for (ti, t) in m.indices.iter().enumerate() {
        for &i in t {
            let k = m.lightmap_uvs[i as usize].map(f32::to_bits);
            let other = *first.entry(k).or_insert(ti);
            let (a, b) = (find(&mut parent, ti), find(&mut parent, other));
            parent[a] = b;
        }
    }
    (0..m.indices.len())
        .map(|i| find(&mut parent, i) as u32)
        .collect()
}

/// Conservatively rasterises every triangle at the map size the layout gives, labelling
/// texels with the triangle's chart. No texel may belong to two charts, and no two charts may
/// touch, even diagonally: the padding leaves empty texels between them.
#[test]
fn charts_do_not_overlap_and_are_padded() {
    for (name, o, density) in all_objects() {
        let m = &o.mesh;
        let size = map_size(&o, density, 8192).expect("size");
        let chart = charts(m);
        let (w, h) = (size[0] as usize, size[1] as usize);
        let mut label = vec![u32::MAX; w * h];
        for (ti, t) in m.indices.iter().enumerate() {
            let p = t.map(|i| {
                let uv = m.lightmap_uvs[i as usize];
                [f64::from(uv[0]) * w as f64, f64::from(uv[1]) * h as f64]
            });
            for y in 0..h {
                for x in 0..w {
                    if overlaps(&p, [x as f64, y as f64]) {
                        let l = &mut label[y * w + x];
                        assert!(
                            *l == u32::MAX || *l == chart[ti],
                            "{name}: texel ({x}, {y}) in charts {} and {}",
                            *l,
                            chart[ti]
                        );
                        *l = chart[ti];
                    }
                }
            }
        }
        for y in 0..h {
            for x in 0..w {
                let l = label[y * w + x];
                if l == u32::MAX {
                    continue;
                }
                for (dx, dy) in [(1, 0), (0, 1), (1, 1), (-1, 1)] {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                        continue;
                    }
                    let n = label[ny as usize * w + nx as usize];
                    assert!(
                        n == u32::MAX || n == l,
                        "{name}: charts {l} and {n} touch at ({x}, {y})"
                    );
                }
            }
        }
    }
}

/// Boxes are charted at exactly uniform metric scale; spheres and the rounded parts of the
/// sofa within modest distortion.
#[test]
fn charts_have_uniform_texel_density() {
    for (name, o, _) in all_objects() {
        let m = &o.mesh;
        let e = lightmap_extent(&o).expect("extent");
        let tol = if name.contains("sphere") {
            0.35
        } else if name.contains("sofa") {
            0.6
        } else {
            1e-3
        };
        for t in &m.indices {
            let p = t.map(|i| Vec3::from(m.positions[i as usize]).as_dvec3());
            let uv = t.map(|i| DVec2::from(m.lightmap_uvs[i as usize].map(f64::from)));
            let (e1, e2): (DVec3, DVec3) = (p[1] - p[0], p[2] - p[0]);
            let (d1, d2) = (uv[1] - uv[0], uv[2] - uv[0]);
            let det = d1.perp_dot(d2);
            let dpdu = (d2.y * e1 - d1.y * e2) / det;
            let dpdv = (-d2.x * e1 + d1.x * e2) / det;
            let su = dpdu.length() / e[0];
            let sv = dpdv.length() / e[1];
            assert!(
                (su - 1.0).abs() < tol && (sv - 1.0).abs() < tol,
                "{name}: stretch {su} {sv}"
            );
        }
    }
}
