//! glTF 2.0 export: a baked scene with its light maps ([`export_baked`]; for web pages
//! [`export_web`]), or a scene as it goes into a bake ([`export_scene`]), as one binary `.glb`.
//!
//! # What is written
//! - One node per object (its transform as a column-major `matrix`), one mesh with one
//!   triangle primitive: `POSITION`, `NORMAL`, `TEXCOORD_0` (material UVs, when the mesh has
//!   them), **`TEXCOORD_1` (the light-map UVs)**, `COLOR_0` (vertex albedo, when present),
//!   32-bit indices.
//! - One material per object: `baseColorFactor` = the albedo factor, `baseColorTexture` = the
//!   albedo texture (sRGB PNG, on `TEXCOORD_0`), metallic 0, roughness 1 (Lambertian).
//! - Baked scenes: per receiver a light-map PNG embedded in the `.glb` (as an image and a
//!   texture that no core material slot uses) and a linear EXR written beside the `.glb`
//!   (`<stem>_<object>_lux.exr`: RGBA 32-bit float, RGB illuminance in lux before albedo,
//!   alpha 1 on texels that lie on the surface). The material's `extras` say where they are:
//!
//! ```json
//! "extras": { "luxbake": { "lightMap": { "index": 3, "texCoord": 1 },
//!                          "exr": "room_chair_01_lux.exr", "luxPerUnit": 412.5,
//!                          "quantity": "illuminance_lux" } }
//! ```
//!   The PNG stores `E / luxPerUnit` (clamped to 1) sRGB-encoded, the same `luxPerUnit` for
//!   the whole scene (the 99th percentile of the illuminance), with empty texels filled from
//!   their neighbours so bilinear filtering does not darken chart edges.
//! - Lamps: one node per lamp at its position, and `scene.extras.luxbake.lamps`, each with
//!   `name`, `position`, `aim`, `rotationDeg`, `multiplier`, `color` and `peakCandela`
//!   (the node's `extras` hold the same object). Bake settings go to `asset.extras.luxbake`.
//!
//! # The web GLB ([`export_web`])
//! The same nodes, meshes (`TEXCOORD_1` the light-map UVs; `TEXCOORD_0` the material UVs, or
//! the light-map UVs again for a mesh without any: glTF numbers sets without gaps) and
//! materials, with the light maps
//! under Mozilla Hubs' light-map extension and the lamps as `EXT_lights_ies`; three.js reads
//! it with `GLTFLoader` and the `luxbake` npm package's `registerWebGLB` (`docs/catalogue.md`):
//! - per receiver, a material extension `"MOZ_lightmap": { "index": T, "texCoord": 1,
//!   "intensity": 1 }` naming texture `T`, whose `"LUXBAKE_texture_logluv": { "source": I }`
//!   ([`LOGLUV_EXTENSION`]) names a PNG image (a `bufferView`): the object's illuminance in
//!   lux before albedo as 32-bit LogLuv ([`luxbake_output::logluv`]: a texel's lux within
//!   0.14 % plus the 8-bit chromaticity's share), dilated into its chart padding as the EXRs
//!   are. The texture has no core `source` (glTF 2.0 lets an extension supply it): a loader
//!   that does not know the encoding gets no light map rather than a wrong one. Its sampler
//!   is bilinear without mipmaps, clamped (the decoded floats are filtered, never the bytes).
//!   three.js shades a light map `E` as `E · intensity · albedo / π`: with intensity 1 a
//!   texel's value is lux and the shaded value is luminance in cd/m².
//!   The material's `extras.luxbake` holds `quantity` (`illuminance_lux`), the map's `size` and
//!   its `lux` range (least and largest luminance of its texels).
//! - per lamp, a node at its position whose `rotation` turns the `EXT_lights_ies` frame (nadir
//!   −Z, C0 +X, C90 +Y: luxbake's photometric frame) onto its aim and C-plane rotation, with
//!   `"EXT_lights_ies": { "light": L, "multiplier": m, "color": c }`; the profile `L` in
//!   `extensions.EXT_lights_ies.lights` is the lamp's photometry written as IES LM-63-2002
//!   (`luxbake_ies`'s writer: EULUMDAT files are converted, `TILT=<file>` inlined) in a
//!   `bufferView` (`mimeType` `application/x-ies-lm-63`), one per distinct photometry. A colour
//!   component above 1 moves into the multiplier (the extension's colour is in [0, 1]).
//! - `extensionsUsed` lists `MOZ_lightmap`, `LUXBAKE_texture_logluv` and `EXT_lights_ies`
//!   (none is required: without them the room loads unlit).
//!
//! # Using the light maps
//! - **three.js**: `GLTFLoader` puts the extras in `material.userData.luxbake`; load the
//!   texture with `parser.getDependency('texture', userData.luxbake.lightMap.index)`, set
//!   `texture.channel = 1` (it reads `uv1`, i.e. `TEXCOORD_1`), `texture.flipY = false`,
//!   `texture.colorSpace = THREE.SRGBColorSpace`, then `material.lightMap = texture`. three.js
//!   treats a light map as irradiance and shades `lightMap · lightMapIntensity · albedo / π`,
//!   so `lightMapIntensity = π` shows a white PNG texel as the full albedo; for physical
//!   units use `luxPerUnit` times your exposure (display value per cd/m² × π).
//! - **Babylon.js**: the extras arrive in `material.metadata.gltf.extras.luxbake`; use the
//!   texture of that index as `material.lightmapTexture`, with
//!   `lightmapTexture.coordinatesIndex = 1` and `material.useLightmapAsShadowmap = false`.
//! - **Blender** and other tools: `TEXCOORD_1` imports as the second UV map; the lamps'
//!   positions are in the lamp nodes' extras (custom properties).

use std::path::{Path, PathBuf};

use glam::{DMat3, DQuat, DVec3};
use luxbake::bake::BakeOutput;
use luxbake::map::MapImage;
use luxbake::scene::{Lamp, Object, Scene};
use luxbake_ies::IesVersion;
use serde_json::{Value, json};

use crate::AssetError;

/// What [`export_baked`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportReport {
    /// The `.glb`.
    pub glb: PathBuf,
    /// The EXR files written beside it.
    pub exr: Vec<PathBuf>,
    /// Illuminance (lux) that a PNG value of 1 stands for.
    pub lux_per_unit: f32,
}

/// Writes `scene` (meshes, albedo, light-map UVs, lamps in `extras`) as a `.glb`, without
/// light maps: the same scene another tool can bake.
pub fn export_scene(scene: &Scene, path: &Path) -> Result<(), AssetError> {
    let glb = encode(scene, Maps::None, path)?;
    write(path, &glb.bytes)
}

/// Writes a baked scene as a `.glb` at `path` with a PNG light map per receiver inside it,
/// and the linear EXR light maps beside it (see the module docs).
pub fn export_baked(
    scene: &Scene,
    output: &BakeOutput,
    path: &Path,
) -> Result<ExportReport, AssetError> {
    let glb = encode(scene, Maps::Extras(output), path)?;
    write(path, &glb.bytes)?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut exr = Vec::new();
    for (name, bytes) in glb.side_files {
        let p = dir.join(name);
        write(&p, &bytes)?;
        exr.push(p);
    }
    Ok(ExportReport {
        glb: path.to_path_buf(),
        exr,
        lux_per_unit: glb.lux_per_unit,
    })
}

/// What [`export_web`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct WebReport {
    /// The `.glb`'s size, bytes.
    pub bytes: u64,
    /// The bytes of its light maps (the LogLuv PNGs inside it).
    pub lightmap_bytes: u64,
    /// The least and the largest illuminance (lux, the Rec. 709 luminance of the RGB) over the
    /// receivers' texels; `[0, 0]` when no texel was baked.
    pub lux: [f32; 2],
}

/// Writes a baked scene as the web `.glb` at `path` (see the module docs, *The web GLB*): the
/// light maps under `MOZ_lightmap` as LogLuv PNGs on `TEXCOORD_1`, the
/// lamps as `EXT_lights_ies` with their profiles. The bytes depend on the scene and the bake
/// only (no time, no path).
pub fn export_web(
    scene: &Scene,
    output: &BakeOutput,
    path: &Path,
) -> Result<WebReport, AssetError> {
    let glb = encode(scene, Maps::Web(output), path)?;
    write(path, &glb.bytes)?;
    Ok(WebReport {
        bytes: glb.bytes.len() as u64,
        lightmap_bytes: glb.lightmap_bytes,
        lux: glb.lux,
    })
}

fn write(path: &Path, bytes: &[u8]) -> Result<(), AssetError> {
    std::fs::write(path, bytes).map_err(|source| AssetError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Which light maps a `.glb` carries.
#[derive(Clone, Copy)]
enum Maps<'a> {
    /// None: the scene as it goes into a bake.
    None,
    /// sRGB PNGs named by `extras`, EXRs beside the file ([`export_baked`]).
    Extras(&'a BakeOutput),
    /// LogLuv PNGs under `MOZ_lightmap`, lamps as `EXT_lights_ies` ([`export_web`]).
    Web(&'a BakeOutput),
}

impl<'a> Maps<'a> {
    fn output(self) -> Option<&'a BakeOutput> {
        match self {
            Maps::None => None,
            Maps::Extras(o) | Maps::Web(o) => Some(o),
        }
    }
}

/// An encoded `.glb` and the files that go beside it.
struct Encoded {
    bytes: Vec<u8>,
    side_files: Vec<(String, Vec<u8>)>,
    lux_per_unit: f32,
    lightmap_bytes: u64,
    lux: [f32; 2],
}

/// The binary chunk under construction.
#[derive(Default)]
struct Bin {
    data: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.data.len().is_multiple_of(4) {
            self.data.push(0);
        }
        let mut v =
            json!({ "buffer": 0, "byteOffset": self.data.len(), "byteLength": bytes.len() });
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.data.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    fn floats<const N: usize>(&mut self, items: &[[f32; N]], kind: &str, min_max: bool) -> usize {
        let view = self.view(&le_bytes(items, f32::to_le_bytes), Some(34962));
        let mut a = json!({ "bufferView": view, "componentType": 5126, "count": items.len(), "type": kind });
        if min_max {
            let mut lo = [f32::INFINITY; N];
            let mut hi = [f32::NEG_INFINITY; N];
            for it in items {
                for k in 0..N {
                    lo[k] = lo[k].min(it[k]);
                    hi[k] = hi[k].max(it[k]);
                }
            }
            a["min"] = json!(lo.to_vec());
            a["max"] = json!(hi.to_vec());
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    fn indices(&mut self, tris: &[[u32; 3]]) -> usize {
        let view = self.view(&le_bytes(tris, u32::to_le_bytes), Some(34963));
        self.accessors.push(json!({ "bufferView": view, "componentType": 5125, "count": tris.len() * 3, "type": "SCALAR" }));
        self.accessors.len() - 1
    }
}

/// The components of `items` in order, each as its little-endian bytes (`to_le`).
fn le_bytes<T: Copy, const N: usize>(items: &[[T; N]], to_le: fn(T) -> [u8; 4]) -> Vec<u8> {
    items.iter().flatten().flat_map(|&x| to_le(x)).collect()
}

/// The scene-wide PNG scale: the 99th percentile of valid illuminance channels (≥ 1e-6).
fn lux_per_unit(output: &BakeOutput) -> f32 {
    let mut v: Vec<f32> = output
        .maps
        .iter()
        .flat_map(|m| m.illuminance().valid_rgb())
        .flat_map(|c| c.into_iter())
        .filter(|x| x.is_finite())
        .collect();
    if v.is_empty() {
        return 1.0;
    }
    let k = ((v.len() - 1) as f64 * 0.99) as usize;
    let (_, p, _) = v.select_nth_unstable_by(k, f32::total_cmp);
    p.max(1e-6)
}

/// Least rounds of dilation of the exported light maps (more where the chart padding is wider).
const MIN_DILATION_PASSES: u32 = 16;

/// The light map as an sRGB PNG, dilated into its padding as the bake's own maps are
/// ([`MapImage::dilated`]).
fn lightmap_png(
    map: &MapImage,
    scale: f32,
    passes: u32,
    path: &Path,
) -> Result<Vec<u8>, AssetError> {
    let filled = map.dilated(passes.max(MIN_DILATION_PASSES));
    let mut rgb = Vec::with_capacity(3 * filled.width as usize * filled.height as usize);
    for y in 0..filled.height {
        for x in 0..filled.width {
            let t = filled.texel(x, y);
            for c in &t[..3] {
                rgb.push(crate::image::linear_to_srgb(c / scale));
            }
        }
    }
    crate::image::encode_rgb_png(filled.width.max(1), filled.height.max(1), &rgb).map_err(
        |message| AssetError::Export {
            path: path.to_path_buf(),
            message,
        },
    )
}

fn stem(path: &Path) -> String {
    path.file_stem()
        .map(|s| luxbake_output::file_stem(&s.to_string_lossy()))
        .unwrap_or_else(|| "scene".into())
}

/// The node's column-major matrix: the linear part's f32 values, and the f64 translation so
/// that a room kilometres out keeps its millimetres in the JSON.
fn matrix(o: &Object) -> Vec<serde_json::Value> {
    let l = &o.transform.linear;
    let t = o.transform.translation;
    let mut m: Vec<serde_json::Value> = Vec::with_capacity(16);
    for col in l {
        m.extend(col.iter().map(|&v| json!(v)));
        m.push(json!(0.0));
    }
    m.extend(t.iter().map(|&v| json!(v)));
    m.push(json!(1.0));
    m
}

/// The texture extension naming a light map's LogLuv PNG ([`luxbake_output::logluv`]).
pub const LOGLUV_EXTENSION: &str = "LUXBAKE_texture_logluv";

/// The media type of an IES LM-63 profile in `EXT_lights_ies`.
const IES_MIME_TYPE: &str = "application/x-ies-lm-63";

/// The light maps' sampler: bilinear without mipmaps (the maps are dilated into their chart
/// padding for bilinear look-ups only), clamped at the edges.
const LIGHTMAP_SAMPLER: &str =
    r#"{"magFilter": 9729, "minFilter": 9729, "wrapS": 33071, "wrapT": 33071}"#;

/// The least and largest Rec. 709 luminance over the valid texels of `map`, or `None`.
fn lux_range(map: &MapImage) -> Option<[f32; 2]> {
    map.valid_rgb()
        .map(luxbake_output::picture::luminance)
        .filter(|v| v.is_finite())
        .fold(None, |r, v| match r {
            None => Some([v, v]),
            Some([lo, hi]) => Some([lo.min(v), hi.max(v)]),
        })
}

/// The node rotation (quaternion `[x, y, z, w]`) that turns the `EXT_lights_ies` frame (nadir
/// −Z, C0 +X, C90 +Y — luxbake's photometric frame) into the lamp's world orientation.
fn lamp_rotation(lamp: &Lamp) -> [f64; 4] {
    // The rows of the world-to-photometric matrix are the world directions of the photometric
    // axes: the columns of the node's rotation.
    let [x, y, z] = lamp.frame_f64().map(DVec3::from);
    let q = DQuat::from_mat3(&DMat3::from_cols(x, y, z)).normalize();
    [q.x, q.y, q.z, q.w]
}

/// `EXT_lights_ies`'s `multiplier` and `color` (linear, in [0, 1]) for a lamp: a colour
/// component above 1 moves into the multiplier.
fn ies_multiplier_color(lamp: &Lamp) -> (f32, [f32; 3]) {
    let top = lamp.color.iter().copied().fold(0.0f32, f32::max);
    if top > 1.0 {
        (lamp.multiplier * top, lamp.color.map(|c| c / top))
    } else {
        (lamp.multiplier, lamp.color)
    }
}

fn encode(scene: &Scene, maps_of: Maps, path: &Path) -> Result<Encoded, AssetError> {
    let output = maps_of.output();
    let web = matches!(maps_of, Maps::Web(_));
    scene.validate().map_err(|e| AssetError::Export {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let mut bin = Bin::default();
    let (mut nodes, mut meshes, mut materials, mut images, mut textures) = (
        Vec::new(),
        Vec::new(),
        Vec::new(),
        Vec::new(),
        Vec::<Value>::new(),
    );
    let mut side_files = Vec::new();
    let scale = output.map_or(1.0, lux_per_unit);
    let (mut lightmap_bytes, mut lux) = (0u64, None::<[f32; 2]>);
    let mut used = std::collections::BTreeSet::new();
    // EXT_lights_ies profiles (IES LM-63-2002 text), one per distinct photometry.
    let mut profiles: Vec<(String, Value)> = Vec::new();
    let file_stem = stem(path);
    let mut albedo_textures: Vec<(*const luxbake::scene::AlbedoTexture, usize)> = Vec::new();
    for (oi, o) in scene.objects.iter().enumerate() {
        let m = &o.mesh;
        let mut attributes = serde_json::Map::new();
        attributes.insert(
            "POSITION".into(),
            json!(bin.floats(&m.positions, "VEC3", true)),
        );
        attributes.insert(
            "NORMAL".into(),
            json!(bin.floats(&m.normals, "VEC3", false)),
        );
        if let Some(uv0) = &m.material_uvs {
            attributes.insert("TEXCOORD_0".into(), json!(bin.floats(uv0, "VEC2", false)));
        } else if web {
            // glTF numbers a semantic's sets from 0 without gaps: TEXCOORD_1 needs a
            // TEXCOORD_0 (the Khronos validator's MESH_PRIMITIVE_INDEXED_SEMANTIC_CONTINUITY);
            // without material UVs it is the light-map UVs again.
            attributes.insert(
                "TEXCOORD_0".into(),
                json!(bin.floats(&m.lightmap_uvs, "VEC2", false)),
            );
        }
        attributes.insert(
            "TEXCOORD_1".into(),
            json!(bin.floats(&m.lightmap_uvs, "VEC2", false)),
        );
        if let Some(c) = &m.colors {
            attributes.insert("COLOR_0".into(), json!(bin.floats(c, "VEC3", false)));
        }
        let indices = bin.indices(&m.indices);
        let f = o.albedo.factor;
        let mut pbr = json!({ "baseColorFactor": [f[0], f[1], f[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0 });
        if let Some(t) = &o.albedo.texture
            && m.material_uvs.is_some()
        {
            let key = std::sync::Arc::as_ptr(t);
            let tex = match albedo_textures.iter().find(|(k, _)| *k == key) {
                Some(&(_, i)) => i,
                None => {
                    let png = crate::image::encode_albedo_png(t).map_err(|message| {
                        AssetError::Export {
                            path: path.to_path_buf(),
                            message,
                        }
                    })?;
                    let view = bin.view(&png, None);
                    images.push(json!({ "bufferView": view, "mimeType": "image/png", "name": format!("{}_albedo", o.name) }));
                    textures.push(json!({ "source": images.len() - 1 }));
                    albedo_textures.push((key, textures.len() - 1));
                    textures.len() - 1
                }
            };
            pbr["baseColorTexture"] = json!({ "index": tex, "texCoord": 0 });
        }
        let mut material = json!({ "name": o.name, "pbrMetallicRoughness": pbr });
        if let Maps::Web(out) = maps_of
            && let Some(maps) = out.maps.iter().find(|mp| mp.object == oi)
        {
            let lm = maps.illuminance();
            let range = lux_range(lm);
            if let Some([lo, hi]) = range {
                lux = Some(lux.map_or([lo, hi], |[a, b]: [f32; 2]| [a.min(lo), b.max(hi)]));
            }
            let passes = luxbake_output::dilation_passes(&out.settings);
            let png =
                luxbake_output::logluv::encode_logluv_png(&lm.dilated(passes)).map_err(|e| {
                    AssetError::Export {
                        path: path.to_path_buf(),
                        message: e.to_string(),
                    }
                })?;
            lightmap_bytes += png.len() as u64;
            let view = bin.view(&png, None);
            images.push(json!({ "bufferView": view, "mimeType": "image/png", "name": format!("{}_lightmap", o.name) }));
            textures.push(
                json!({ "name": format!("{}_lightmap", o.name), "sampler": 0,
                "extensions": { LOGLUV_EXTENSION: { "source": images.len() - 1 } } }),
            );
            material["extensions"] = json!({ "MOZ_lightmap": { "index": textures.len() - 1, "texCoord": 1, "intensity": 1.0 } });
            material["extras"] = json!({ "luxbake": {
                "quantity": "illuminance_lux",
                "size": [lm.width, lm.height],
                "lux": range,
            }});
            used.extend(["MOZ_lightmap", LOGLUV_EXTENSION]);
        }
        if let Maps::Extras(out) = maps_of
            && let Some(maps) = out.maps.iter().find(|mp| mp.object == oi)
        {
            let lm = maps.illuminance();
            let passes = luxbake_output::dilation_passes(&out.settings);
            let png = lightmap_png(lm, scale, passes, path)?;
            let view = bin.view(&png, None);
            images.push(json!({ "bufferView": view, "mimeType": "image/png", "name": format!("{}_lightmap", o.name) }));
            textures.push(
                json!({ "source": images.len() - 1, "name": format!("{}_lightmap", o.name) }),
            );
            let exr_name = format!("{file_stem}_{}_lux.exr", luxbake_output::file_stem(&o.name));
            let exr = luxbake_output::encode_exr(lm).map_err(|e| AssetError::Export {
                path: path.to_path_buf(),
                message: e.to_string(),
            })?;
            side_files.push((exr_name.clone(), exr));
            material["extras"] = json!({ "luxbake": {
                "lightMap": { "index": textures.len() - 1, "texCoord": 1 },
                "exr": exr_name,
                "luxPerUnit": scale,
                "quantity": "illuminance_lux",
                "size": [lm.width, lm.height],
            }});
        }
        materials.push(material);
        meshes.push(json!({ "name": o.name, "primitives": [{ "attributes": attributes, "indices": indices, "material": materials.len() - 1, "mode": 4 }] }));
        nodes.push(
            json!({ "name": o.name, "mesh": meshes.len() - 1, "matrix": matrix(o),
            "extras": { "luxbake": { "receiver": o.receiver, "texelScale": o.texel_scale } } }),
        );
    }
    let mut lamps = Vec::new();
    for l in &scene.lamps {
        let peak = l
            .photometry
            .vertical_angles()
            .iter()
            .flat_map(|&v| {
                l.photometry
                    .horizontal_angles()
                    .iter()
                    .map(move |&h| (v, h))
                    .collect::<Vec<_>>()
            })
            .map(|(v, h)| l.photometry.intensity_at(v, h))
            .fold(0.0f64, f64::max);
        let info = json!({
            "name": l.name, "position": l.position, "aim": l.aim, "rotationDeg": l.rotation_deg,
            "multiplier": l.multiplier, "color": l.color, "peakCandela": peak,
        });
        let mut node = json!({ "name": format!("lamp_{}", l.name), "translation": l.position, "extras": { "luxbake": { "lamp": info.clone() } } });
        if web {
            let text = l.photometry.to_ies(IesVersion::Lm63_2002);
            let light = match profiles.iter().position(|(t, _)| *t == text) {
                Some(i) => i,
                None => {
                    let view = bin.view(text.as_bytes(), None);
                    let profile =
                        json!({ "name": l.name, "bufferView": view, "mimeType": IES_MIME_TYPE });
                    profiles.push((text, profile));
                    profiles.len() - 1
                }
            };
            let (multiplier, color) = ies_multiplier_color(l);
            node["rotation"] = json!(lamp_rotation(l));
            node["extensions"] = json!({ "EXT_lights_ies": { "light": light, "multiplier": multiplier, "color": color } });
            used.insert("EXT_lights_ies");
        }
        nodes.push(node);
        lamps.push(info);
    }
    let s = &scene.settings;
    let mut root = json!({
        "asset": { "version": "2.0", "generator": concat!("luxbake-assets ", env!("CARGO_PKG_VERSION")),
            "extras": { "luxbake": { "texelsPerMetre": s.texels_per_metre, "rays": s.rays, "bounces": s.bounces,
                "baked": output.is_some() } } },
        "scene": 0,
        "scenes": [{ "nodes": (0..nodes.len()).collect::<Vec<_>>(), "extras": { "luxbake": { "lamps": lamps } } }],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "accessors": bin.accessors,
        "bufferViews": bin.views,
        "buffers": [{ "byteLength": bin.data.len() }],
    });
    if !images.is_empty() {
        root["images"] = json!(images);
        root["textures"] = json!(textures);
    }
    if web && textures.iter().any(|t| t.get("sampler").is_some()) {
        let sampler: Value =
            serde_json::from_str(LIGHTMAP_SAMPLER).map_err(|e| AssetError::Export {
                path: path.to_path_buf(),
                message: e.to_string(),
            })?;
        root["samplers"] = json!([sampler]);
    }
    if !profiles.is_empty() {
        root["extensions"] = json!({ "EXT_lights_ies": { "lights": profiles.into_iter().map(|(_, p)| p).collect::<Vec<_>>() } });
    }
    if !used.is_empty() {
        root["extensionsUsed"] = json!(used);
    }
    let mut json_bytes = serde_json::to_vec(&root).map_err(|e| AssetError::Export {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    while !json_bytes.len().is_multiple_of(4) {
        json_bytes.push(b' ');
    }
    let mut data = bin.data;
    while !data.len().is_multiple_of(4) {
        data.push(0);
    }
    let total = 12 + 8 + json_bytes.len() + 8 + data.len();
    let too_big = |_| AssetError::Export {
        path: path.to_path_buf(),
        message: format!("{total} bytes: a .glb is limited to 4 GiB"),
    };
    let mut bytes = Vec::with_capacity(total);
    bytes.extend_from_slice(b"glTF");
    bytes.extend_from_slice(&2u32.to_le_bytes());
    bytes.extend_from_slice(&u32::try_from(total).map_err(too_big)?.to_le_bytes());
    bytes.extend_from_slice(
        &u32::try_from(json_bytes.len())
            .map_err(too_big)?
            .to_le_bytes(),
    );
    bytes.extend_from_slice(b"JSON");
    bytes.extend_from_slice(&json_bytes);
    bytes.extend_from_slice(&u32::try_from(data.len()).map_err(too_big)?.to_le_bytes());
    bytes.extend_from_slice(b"BIN\0");
    bytes.extend_from_slice(&data);
    Ok(Encoded {
        bytes,
        side_files,
        lux_per_unit: scale,
        lightmap_bytes,
        lux: lux.unwrap_or([0.0; 2]),
    })
}
