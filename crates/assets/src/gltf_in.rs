//! glTF 2.0 import (`.gltf` with external or data-URI buffers, `.glb`).
//!
//! - The default scene (or the first, or every root node when there is none) is walked from
//!   its roots; node matrices or TRS are composed, positions and normals moved into the
//!   file's frame (normals by the inverse transpose; mirroring nodes flip the winding).
//! - Every primitive becomes a [`Part`](crate::Part): `TRIANGLES` as is, `TRIANGLE_STRIP` and
//!   `TRIANGLE_FAN` converted to a list (with a warning), points and lines left out (with a
//!   warning). Primitives whose material is `alphaMode: BLEND` or has
//!   `KHR_materials_transmission` (glass, lamp shades) are left out with a warning: `luxbake`
//!   has no translucent occluders, and a bulb's glass would hide the light inside it.
//! - Albedo: `baseColorFactor` × `COLOR_0` (vertex colours) × `baseColorTexture` (sRGB PNG or
//!   JPEG, decoded to linear); `KHR_texture_transform` is applied to the material UVs and its
//!   `texCoord` override honoured. Sampler wrap modes are not read (textures repeat).
//! - Light-map UVs: `TEXCOORD_1` when present and accepted by [`crate::uv::check`], else
//!   generated ([`UvSource`](crate::UvSource) records which).
//! - `KHR_lights_punctual` point and spot lights become [`Light`]s (intensity in candela, the
//!   node's −Z as the spot direction); directional lights are left out with a warning.
//! - Accessors are read by our own checked reader (every offset, stride and count is
//!   bounds-checked against its buffer view and buffer); sparse accessors are an error.
//!
//! Extensions understood: [`SUPPORTED_EXTENSIONS`]. Others listed in `extensionsUsed` produce a
//! warning; any other in `extensionsRequired` is an [`AssetError::RequiredExtension`].

use std::collections::{HashMap, HashSet};
use std::path::Path;
use std::sync::Arc;

use glam::{DMat3, DMat4, Mat4, Vec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use luxbake::scene::{Albedo, AlbedoTexture};

use crate::model::{self, GltfSource, Light, LightKind, Model, RawPart};
use crate::options::check_limit;
use crate::{AssetError, ImportOptions, Limits};

/// Extensions this reader understands (a file may require them).
pub const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_texture_transform",
    "KHR_lights_punctual",
    "KHR_materials_transmission",
];

/// Deepest node hierarchy walked.
const MAX_DEPTH: usize = 256;

/// Reads glTF or GLB bytes; `path` names the file in errors and is the base of relative URIs.
pub fn import_bytes(
    bytes: &[u8],
    path: &Path,
    options: &ImportOptions,
) -> Result<Model, AssetError> {
    let gerr = |message: String| AssetError::Gltf {
        path: path.to_path_buf(),
        message,
    };
    // The `gltf` crate subtracts the 12-byte header from the declared length unchecked.
    if let Some(rest) = bytes.strip_prefix(b"glTF") {
        let declared = rest
            .get(4..8)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .ok_or_else(|| gerr("GLB header truncated (under 12 bytes)".into()))?;
        if declared < 12 {
            return Err(gerr(format!(
                "GLB header declares {declared} bytes, less than the header itself"
            )));
        }
    }
    let mut g =
        gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| gerr(e.to_string()))?;
    let mut warnings = Vec::new();
    let required: Vec<String> = g
        .extensions_required()
        .filter(|e| !SUPPORTED_EXTENSIONS.contains(e))
        .map(str::to_string)
        .collect();
    if !required.is_empty() {
        return Err(AssetError::RequiredExtension {
            path: path.to_path_buf(),
            names: required.join(", "),
        });
    }
    let ignored: Vec<&str> = g
        .extensions_used()
        .filter(|e| !SUPPORTED_EXTENSIONS.contains(e))
        .collect();
    if !ignored.is_empty() {
        warnings.push(format!(
            "ignoring unsupported glTF extension(s): {}",
            ignored.join(", ")
        ));
    }
    // gltf-json's validation indexes the POSITION accessor unchecked: check every primitive's
    // accessor indices first (found by the `gltf` fuzz target).
    let accessors = g.document.as_json().accessors.len();
    for (mi, m) in g.document.as_json().meshes.iter().enumerate() {
        for (pi, p) in m.primitives.iter().enumerate() {
            let named = p
                .attributes
                .values()
                .chain(p.indices.iter())
                .map(|i| i.value());
            if let Some(i) = named.into_iter().find(|&i| i >= accessors) {
                return Err(gerr(format!(
                    "mesh {mi} primitive {pi} names accessor {i}, but there are {accessors}"
                )));
            }
        }
    }
    let blob = g.blob.take();
    let doc = gltf::Document::from_json(g.document.into_json()).map_err(|e| match e {
        gltf::Error::Validation(errs) => gerr(
            errs.iter()
                .take(3)
                .map(|(p, e)| format!("{p}: {e}"))
                .collect::<Vec<_>>()
                .join("; "),
        ),
        other => gerr(other.to_string()),
    })?;
    let base = path.parent().unwrap_or(Path::new("."));
    let limits = &options.limits;

    // Buffers.
    let mut buffers = Vec::new();
    for b in doc.buffers() {
        let what = format!("buffer {}", b.index());
        let want = b.length() as u64;
        check_limit(path, "a buffer's byteLength", want, limits.max_file_bytes)?;
        let data = match b.source() {
            gltf::buffer::Source::Bin => blob.clone().ok_or_else(|| {
                gerr(format!(
                    "{what} refers to the GLB binary chunk, which is missing"
                ))
            })?,
            gltf::buffer::Source::Uri(uri) => {
                load_uri(uri, base, limits, path).map_err(|m| gerr(format!("{what}: {m}")))?
            }
        };
        if (data.len() as u64) < want {
            return Err(gerr(format!(
                "{what} has {} bytes, byteLength says {want} (truncated file?)",
                data.len()
            )));
        }
        buffers.push(data);
    }

    // Nodes to walk.
    let roots: Vec<gltf::Node> = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(s) => s.nodes().collect(),
        None => {
            let children: HashSet<usize> = doc
                .nodes()
                .flat_map(|n| n.children().map(|c| c.index()).collect::<Vec<_>>())
                .collect();
            doc.nodes()
                .filter(|n| !children.contains(&n.index()))
                .collect()
        }
    };
    let mut cx = Cx {
        path,
        base,
        options,
        buffers: &buffers,
        textures: HashMap::new(),
        warnings,
        names: HashSet::new(),
        triangles: 0,
        vertices: 0,
    };
    let mut raws = Vec::new();
    let mut lights = Vec::new();
    let mut stack: Vec<(gltf::Node, DMat4, usize)> = roots
        .into_iter()
        .rev()
        .map(|n| (n, DMat4::IDENTITY, 0))
        .collect();
    let mut visits = 0usize;
    while let Some((node, parent, depth)) = stack.pop() {
        visits += 1;
        if depth > MAX_DEPTH || visits > doc.nodes().len().saturating_mul(4).max(16) {
            return Err(gerr(format!(
                "node hierarchy deeper than {MAX_DEPTH} or cyclic (at node {})",
                node.index()
            )));
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix()).as_dmat4();
        if !local.is_finite() {
            return Err(gerr(format!(
                "node {} has a non-finite transform",
                node.index()
            )));
        }
        let world = parent * local;
        let node_name = node
            .name()
            .map(str::to_string)
            .or_else(|| node.mesh().and_then(|m| m.name().map(str::to_string)))
            .unwrap_or_else(|| format!("node{}", node.index()));
        if let Some(mesh) = node.mesh() {
            let count = mesh.primitives().len();
            for prim in mesh.primitives() {
                let label = if count > 1 {
                    format!("{node_name}.{}", prim.index())
                } else {
                    node_name.clone()
                };
                if let Some(mut raw) = cx.primitive(&prim, &world, &label)? {
                    raw.gltf = Some(GltfSource {
                        node: node.index(),
                        mesh: mesh.index(),
                        primitive: prim.index(),
                    });
                    raws.push(raw);
                }
            }
        }
        if let Some(light) = node.light() {
            cx.light(&light, &world, &node_name, &mut lights);
        }
        for c in node.children().collect::<Vec<_>>().into_iter().rev() {
            stack.push((c, world, depth + 1));
        }
    }
    mark_shared_atlases(&mut raws);
    let mut parts = Vec::with_capacity(raws.len());
    for raw in raws {
        parts.push(model::finish(raw, path, options, &mut cx.warnings)?);
    }
    if parts.is_empty() {
        return Err(AssetError::Empty {
            path: path.to_path_buf(),
        });
    }
    Ok(Model {
        parts,
        lights,
        warnings: cx.warnings,
    })
}

/// Parts whose `TEXCOORD_1` bounding box meets no other part's box share one atlas with
/// them (a part per material of one unwrapped model): they get `stretch_lightmap`, so each
/// part's own light map is not mostly empty. Parts that each span the whole square (files
/// written by [`crate::export`]) are left as they are.
fn mark_shared_atlases(raws: &mut [RawPart]) {
    let boxes: Vec<Option<[f32; 4]>> = raws
        .iter()
        .map(|r| {
            let uvs = r.lightmap_uvs.as_ref()?;
            let mut b = [
                f32::INFINITY,
                f32::INFINITY,
                f32::NEG_INFINITY,
                f32::NEG_INFINITY,
            ];
            for uv in uvs {
                b = [
                    b[0].min(uv[0]),
                    b[1].min(uv[1]),
                    b[2].max(uv[0]),
                    b[3].max(uv[1]),
                ];
            }
            b.iter().all(|c| c.is_finite()).then_some(b)
        })
        .collect();
    let with_uv = boxes.iter().flatten().count();
    for (i, raw) in raws.iter_mut().enumerate() {
        let Some(a) = boxes[i] else { continue };
        let alone = boxes.iter().enumerate().all(|(j, b)| match b {
            Some(b) if j != i => a[2] <= b[0] || b[2] <= a[0] || a[3] <= b[1] || b[3] <= a[1],
            _ => true,
        });
        raw.stretch_lightmap = with_uv > 1 && alone;
    }
}

/// `p` moved by the affine transform `m`, rounded to `f32`.
fn point(m: &DMat4, p: [f32; 3]) -> [f32; 3] {
    m.transform_point3(Vec3::from(p).as_dvec3())
        .as_vec3()
        .to_array()
}

/// Cofactor matrix of the 3×3 part, i.e. the inverse transpose times the determinant, and the
/// determinant.
fn normal_matrix(m: &DMat4) -> (DMat3, f64) {
    let (a, b, c) = (
        m.x_axis.truncate(),
        m.y_axis.truncate(),
        m.z_axis.truncate(),
    );
    let cof = DMat3::from_cols(b.cross(c), c.cross(a), a.cross(b));
    (cof, a.dot(cof.x_axis))
}

struct Cx<'a> {
    path: &'a Path,
    base: &'a Path,
    options: &'a ImportOptions,
    buffers: &'a [Vec<u8>],
    textures: HashMap<usize, Arc<AlbedoTexture>>,
    warnings: Vec<String>,
    names: HashSet<String>,
    triangles: u64,
    vertices: u64,
}

impl Cx<'_> {
    fn primitive(
        &mut self,
        prim: &gltf::Primitive,
        world: &DMat4,
        label: &str,
    ) -> Result<Option<RawPart>, AssetError> {
        let mode = prim.mode();
        match mode {
            Mode::Triangles => {}
            Mode::TriangleStrip | Mode::TriangleFan => self
                .warnings
                .push(format!("{label}: {mode:?} converted to a triangle list")),
            _ => {
                self.warnings.push(format!(
                    "{label}: {mode:?} primitive left out (only triangles are baked)"
                ));
                return Ok(None);
            }
        }
        let material = prim.material();
        let transmissive = material
            .transmission()
            .is_some_and(|t| t.transmission_factor() > 0.0);
        if material.alpha_mode() == gltf::material::AlphaMode::Blend || transmissive {
            self.warnings.push(format!(
                "{label}: transparent material ({}) left out: luxbake has no translucent occluders",
                if transmissive {
                    "KHR_materials_transmission"
                } else {
                    "alphaMode BLEND"
                }
            ));
            return Ok(None);
        }
        let part = format!("primitive `{label}`");
        let (path, buffers) = (self.path, self.buffers);
        let bad = |message: String| AssetError::InvalidData {
            path: path.to_path_buf(),
            part: part.clone(),
            message,
        };
        let positions_acc = prim
            .get(&gltf::Semantic::Positions)
            .ok_or_else(|| bad("no POSITION attribute".into()))?;
        let n = positions_acc.count();
        self.vertices = self.vertices.saturating_add(n as u64);
        let limits = &self.options.limits;
        check_limit(
            self.path,
            "the vertex count",
            self.vertices,
            limits.max_vertices,
        )?;
        let read3 = |acc: &gltf::Accessor, what: &str| -> Result<Vec<[f32; 3]>, AssetError> {
            let v = read_floats(acc, buffers, &[3], n).map_err(|m| bad(format!("{what}: {m}")))?;
            Ok(v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
        };
        let read2 = |acc: &gltf::Accessor, what: &str| -> Result<Vec<[f32; 2]>, AssetError> {
            let v = read_floats(acc, buffers, &[2], n).map_err(|m| bad(format!("{what}: {m}")))?;
            Ok(v.chunks_exact(2).map(|c| [c[0], c[1]]).collect())
        };
        let local_pos = read3(&positions_acc, "POSITION")?;
        if let Some(i) = local_pos
            .iter()
            .position(|p| !p.iter().all(|c| c.is_finite()))
        {
            return Err(bad(format!(
                "POSITION {i} is not finite ({:?})",
                local_pos[i]
            )));
        }
        let positions: Vec<[f32; 3]> = local_pos.iter().map(|&p| point(world, p)).collect();
        let (cof, det) = normal_matrix(world);
        let normals = match prim.get(&gltf::Semantic::Normals) {
            Some(acc) => Some(
                read3(&acc, "NORMAL")?
                    .into_iter()
                    .map(|v| {
                        let w = cof * Vec3::from(v).as_dvec3() * det.signum();
                        w.as_vec3().to_array()
                    })
                    .collect(),
            ),
            None => None,
        };
        let lightmap_uvs = match prim.get(&gltf::Semantic::TexCoords(1)) {
            Some(acc) => Some(read2(&acc, "TEXCOORD_1")?),
            None => None,
        };
        let colors = match prim.get(&gltf::Semantic::Colors(0)) {
            Some(acc) => {
                let comps = acc.dimensions().multiplicity();
                let v = read_floats(&acc, self.buffers, &[3, 4], n)
                    .map_err(|m| bad(format!("COLOR_0: {m}")))?;
                Some(v.chunks_exact(comps).map(|c| [c[0], c[1], c[2]]).collect())
            }
            None => None,
        };
        // Indices.
        let mut flat: Vec<u32> = match prim.indices() {
            Some(acc) => {
                read_indices(&acc, self.buffers).map_err(|m| bad(format!("indices: {m}")))?
            }
            None => (0..n as u32).collect(),
        };
        if let Some(&over) = flat.iter().find(|&&i| i as usize >= n) {
            return Err(bad(format!("index {over} is past the {n} vertices")));
        }
        let mut indices: Vec<[u32; 3]> = match mode {
            Mode::TriangleStrip => (2..flat.len())
                .map(|i| {
                    if i % 2 == 0 {
                        [flat[i - 2], flat[i - 1], flat[i]]
                    } else {
                        [flat[i - 1], flat[i - 2], flat[i]]
                    }
                })
                .collect(),
            Mode::TriangleFan => (2..flat.len())
                .map(|i| [flat[0], flat[i - 1], flat[i]])
                .collect(),
            _ => {
                if !flat.len().is_multiple_of(3) {
                    self.warnings.push(format!(
                        "{label}: {} indices is not a multiple of 3; the rest is ignored",
                        flat.len()
                    ));
                }
                flat.truncate(flat.len() / 3 * 3);
                flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
            }
        };
        if det < 0.0 {
            for t in &mut indices {
                t.swap(1, 2);
            }
        }
        self.triangles = self.triangles.saturating_add(indices.len() as u64);
        let limits = &self.options.limits;
        check_limit(
            self.path,
            "the triangle count",
            self.triangles,
            limits.max_triangles,
        )?;
        // Albedo.
        let pbr = material.pbr_metallic_roughness();
        let f = pbr.base_color_factor();
        let factor = [f[0], f[1], f[2]].map(|c| {
            if c.is_finite() {
                c.clamp(0.0, 1.0)
            } else {
                1.0
            }
        });
        let mut texture = None;
        let mut material_uvs = None;
        if let Some(info) = pbr.base_color_texture() {
            let transform = info.texture_transform();
            let set = transform
                .as_ref()
                .and_then(|t| t.tex_coord())
                .unwrap_or_else(|| info.tex_coord());
            match prim.get(&gltf::Semantic::TexCoords(set)) {
                None => self.warnings.push(format!(
                    "{label}: base colour texture uses TEXCOORD_{set}, which is missing; texture ignored"
                )),
                Some(acc) => {
                    let mut uvs = read2(&acc, &format!("TEXCOORD_{set}"))?;
                    if let Some(t) = transform {
                        let [ox, oy] = t.offset();
                        let [sx, sy] = t.scale();
                        let (s, c) = t.rotation().sin_cos();
                        for uv in &mut uvs {
                            let [u, v] = *uv;
                            *uv = [ox + c * sx * u + s * sy * v, oy - s * sx * u + c * sy * v];
                        }
                    }
                    let image = info.texture().source();
                    texture = Some(self.texture(&image)?);
                    material_uvs = Some(uvs);
                }
            }
        }
        if material_uvs.is_none()
            && let Some(acc) = prim.get(&gltf::Semantic::TexCoords(0))
        {
            material_uvs = Some(read2(&acc, "TEXCOORD_0")?);
        }
        let name = model::unique_name(label, &mut self.names);
        Ok(Some(RawPart {
            name,
            positions,
            normals,
            material_uvs,
            lightmap_uvs,
            colors,
            indices,
            albedo: Some(Albedo { factor, texture }),
            stretch_lightmap: false,
            gltf: None,
        }))
    }

    fn texture(&mut self, image: &gltf::Image) -> Result<Arc<AlbedoTexture>, AssetError> {
        if let Some(t) = self.textures.get(&image.index()) {
            return Ok(t.clone());
        }
        let (label, bytes) = match image.source() {
            gltf::image::Source::View { view, .. } => {
                let start = view.offset();
                let data = self
                    .buffers
                    .get(view.buffer().index())
                    .and_then(|b| b.get(start..start.checked_add(view.length())?));
                (
                    format!("{} (buffer view {})", image.index(), view.index()),
                    data.map(<[u8]>::to_vec),
                )
            }
            gltf::image::Source::Uri { uri, .. } => {
                let label = format!("{} `{uri}`", image.index());
                let data = load_uri(uri, self.base, &self.options.limits, self.path).map_err(
                    |message| AssetError::Image {
                        path: self.path.to_path_buf(),
                        image: label.clone(),
                        message,
                    },
                )?;
                (label, Some(data))
            }
        };
        let err = |message: String| AssetError::Image {
            path: self.path.to_path_buf(),
            image: label.clone(),
            message,
        };
        let bytes = bytes.ok_or_else(|| err("its buffer view lies outside its buffer".into()))?;
        let tex = Arc::new(crate::image::decode(&bytes, &self.options.limits).map_err(err)?);
        self.textures.insert(image.index(), tex.clone());
        Ok(tex)
    }

    fn light(
        &mut self,
        light: &gltf::khr_lights_punctual::Light,
        world: &DMat4,
        node_name: &str,
        out: &mut Vec<Light>,
    ) {
        use gltf::khr_lights_punctual::Kind;
        let name = light
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| format!("light_{}", light.index()));
        let kind = match light.kind() {
            Kind::Point => LightKind::Point,
            Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => LightKind::Spot {
                inner_cone_rad: inner_cone_angle,
                outer_cone_rad: outer_cone_angle,
            },
            Kind::Directional => {
                self.warnings.push(format!(
                    "light `{name}` (node `{node_name}`): directional lights are not baked; left out"
                ));
                return;
            }
        };
        let position = point(world, [0.0; 3]);
        let d = -world.z_axis.truncate();
        let l = d.length();
        let direction = if l > 0.0 && l.is_finite() {
            (d / l).as_vec3().to_array()
        } else {
            [0.0, -1.0, 0.0]
        };
        let intensity = light.intensity();
        let color = light.color();
        let valid = intensity.is_finite()
            && intensity >= 0.0
            && color.iter().all(|c| c.is_finite() && *c >= 0.0)
            && position.iter().all(|c| c.is_finite());
        if !valid {
            self.warnings.push(format!(
                "light `{name}`: non-finite or negative values; left out"
            ));
            return;
        }
        out.push(Light {
            name,
            kind,
            position,
            direction,
            color,
            intensity_cd: intensity,
        });
    }
}

/// Loads a buffer or image URI: `data:` (base64) or a path relative to `base`.
fn load_uri(uri: &str, base: &Path, limits: &Limits, model: &Path) -> Result<Vec<u8>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, payload) = rest
            .split_once(";base64,")
            .ok_or("only base64 data URIs are supported")?;
        if payload.len() as u64 / 4 * 3 > limits.max_file_bytes {
            return Err(format!(
                "data URI over the limit of {} bytes",
                limits.max_file_bytes
            ));
        }
        return base64_decode(payload).ok_or_else(|| "malformed base64 in data URI".to_string());
    }
    if uri.contains("://") {
        return Err(format!(
            "`{uri}`: only relative file paths and data URIs are read"
        ));
    }
    let decoded = percent_decode(uri);
    let file = base.join(&decoded);
    crate::options::read_limited(&file, limits.max_file_bytes).map_err(|e| match e {
        AssetError::Io { source, .. } => {
            format!("missing or unreadable `{}`: {source}", file.display())
        }
        other => format!("{other} (referenced by `{}`)", model.display()),
    })
}

fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%'
            && i + 2 < b.len()
            && let Some(v) = std::str::from_utf8(&b[i + 1..i + 3])
                .ok()
                .and_then(|h| u8::from_str_radix(h, 16).ok())
        {
            out.push(v);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

fn base64_decode(s: &str) -> Option<Vec<u8>> {
    let val = |c: u8| -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => u32::from(c - b'A'),
            b'a'..=b'z' => u32::from(c - b'a') + 26,
            b'0'..=b'9' => u32::from(c - b'0') + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            _ => return None,
        })
    };
    let data: Vec<u8> = s
        .bytes()
        .filter(|c| !c.is_ascii_whitespace() && *c != b'=')
        .collect();
    let mut out = Vec::with_capacity(data.len() * 3 / 4);
    for chunk in data.chunks(4) {
        let mut acc = 0u32;
        for (i, &c) in chunk.iter().enumerate() {
            acc |= val(c)? << (18 - 6 * i);
        }
        let bytes = acc.to_be_bytes();
        match chunk.len() {
            4 => out.extend_from_slice(&bytes[1..4]),
            3 => out.extend_from_slice(&bytes[1..3]),
            2 => out.push(bytes[1]),
            _ => return None,
        }
    }
    Some(out)
}

/// The bytes of an accessor's elements: (data, stride, element size), bounds-checked.
fn accessor_bytes<'b>(
    acc: &gltf::Accessor,
    buffers: &'b [Vec<u8>],
    elem: usize,
) -> Result<Option<(&'b [u8], usize)>, String> {
    if acc.sparse().is_some() {
        return Err("sparse accessors are not supported".into());
    }
    let Some(view) = acc.view() else {
        return Ok(None);
    };
    let stride = view.stride().unwrap_or(elem);
    if stride < elem {
        return Err(format!(
            "byteStride {stride} is smaller than an element ({elem} bytes)"
        ));
    }
    let buffer = buffers
        .get(view.buffer().index())
        .ok_or("buffer view names a missing buffer")?;
    let view_end = view
        .offset()
        .checked_add(view.length())
        .filter(|&e| e <= buffer.len())
        .ok_or("buffer view lies outside its buffer")?;
    let count = acc.count();
    if count == 0 {
        return Ok(Some((&[], stride)));
    }
    let start = view
        .offset()
        .checked_add(acc.offset())
        .ok_or("accessor offset overflows")?;
    let end = (count - 1)
        .checked_mul(stride)
        .and_then(|x| x.checked_add(elem))
        .and_then(|x| x.checked_add(start))
        .filter(|&e| e <= view_end)
        .ok_or_else(|| format!("{count} elements do not fit in their buffer view"))?;
    Ok(Some((&buffer[start..end], stride)))
}

/// Reads a float attribute with one of the allowed component counts, converting normalised
/// integer components; `expect` is the vertex count the accessor must have.
fn read_floats(
    acc: &gltf::Accessor,
    buffers: &[Vec<u8>],
    comps: &[usize],
    expect: usize,
) -> Result<Vec<f32>, String> {
    let n = match acc.dimensions() {
        Dimensions::Scalar => 1,
        Dimensions::Vec2 => 2,
        Dimensions::Vec3 => 3,
        Dimensions::Vec4 => 4,
        _ => 0,
    };
    if !comps.contains(&n) {
        return Err(format!(
            "{:?} accessor, expected {comps:?} components",
            acc.dimensions()
        ));
    }
    if acc.count() != expect {
        return Err(format!("{} elements for {expect} vertices", acc.count()));
    }
    let dt = acc.data_type();
    let size = dt.size();
    if dt != DataType::F32 && !acc.normalized() && !matches!(dt, DataType::U8 | DataType::U16) {
        return Err(format!("{dt:?} components that are not normalized"));
    }
    let Some((bytes, stride)) = accessor_bytes(acc, buffers, n * size)? else {
        return Ok(vec![0.0; expect * n]);
    };
    let mut out = Vec::with_capacity(expect * n);
    for e in 0..expect {
        for k in 0..n {
            let o = e * stride + k * size;
            let b = bytes
                .get(o..o + size)
                .ok_or("element outside its buffer view")?;
            out.push(match dt {
                DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                DataType::U8 => f32::from(b[0]) / 255.0,
                DataType::U16 => f32::from(u16::from_le_bytes([b[0], b[1]])) / 65535.0,
                DataType::I8 => (f32::from(b[0] as i8) / 127.0).max(-1.0),
                DataType::I16 => (f32::from(i16::from_le_bytes([b[0], b[1]])) / 32767.0).max(-1.0),
                DataType::U32 => return Err("U32 components in a float attribute".into()),
            });
        }
    }
    Ok(out)
}

/// Reads a scalar unsigned index accessor.
fn read_indices(acc: &gltf::Accessor, buffers: &[Vec<u8>]) -> Result<Vec<u32>, String> {
    if acc.dimensions() != Dimensions::Scalar {
        return Err(format!(
            "{:?} index accessor, expected SCALAR",
            acc.dimensions()
        ));
    }
    let dt = acc.data_type();
    let size = match dt {
        DataType::U8 => 1,
        DataType::U16 => 2,
        DataType::U32 => 4,
        other => return Err(format!("{other:?} indices, expected unsigned")),
    };
    let Some((bytes, stride)) = accessor_bytes(acc, buffers, size)? else {
        return Err("index accessor without a buffer view".into());
    };
    (0..acc.count())
        .map(|e| {
            let o = e * stride;
            let b = bytes
                .get(o..o + size)
                .ok_or("index outside its buffer view")?;
            Ok(match size {
                1 => u32::from(b[0]),
                2 => u32::from(u16::from_le_bytes([b[0], b[1]])),
                _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_and_percent_decoding() {
        assert_eq!(base64_decode("aGVsbG8=").as_deref(), Some(&b"hello"[..]));
        assert_eq!(base64_decode("aGk").as_deref(), Some(&b"hi"[..]));
        assert!(base64_decode("a$==").is_none());
        assert!(base64_decode("a").is_none());
        assert_eq!(percent_decode("a%20b%zz"), "a b%zz");
        assert_eq!(percent_decode("%2"), "%2");
    }

    #[test]
    fn matrices_compose_column_major() {
        let t = DMat4::from_translation(glam::DVec3::new(1.0, 2.0, 3.0));
        let s = DMat4::from_scale(glam::DVec3::splat(2.0));
        assert_eq!(point(&(t * s), [1.0, 1.0, 1.0]), [3.0, 4.0, 5.0]);
        assert_eq!(point(&(s * t), [0.0; 3]), [2.0, 4.0, 6.0]);
        let (_, det) = normal_matrix(&s);
        assert_eq!(det, 8.0);
    }
}
