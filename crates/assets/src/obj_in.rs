//! Wavefront OBJ + MTL import (`tobj`).
//!
//! Polygons are triangulated (fans), points and lines ignored. Every OBJ object/group (one
//! material each after `tobj`'s split) becomes a [`crate::Part`]; `Kd` is the albedo factor
//! (clamped to [0, 1], 0.5 grey without a material) and `map_Kd` the albedo texture (sRGB PNG
//! or JPEG). OBJ texture coordinates have v up; they are flipped (`1 − v`) into glTF's
//! convention. Meshes without normals get area-weighted vertex normals; light-map UVs are
//! always generated (OBJ has a single UV set, meant for materials). A missing `.mtl` is a
//! warning; a missing `map_Kd` image is an error.

use std::cell::RefCell;
use std::collections::{HashMap, HashSet};
use std::path::Path;
use std::sync::Arc;

use luxbake::scene::Albedo;

use crate::model::{self, Model, RawPart};
use crate::{AssetError, ImportOptions};

/// Parses OBJ bytes; `path` names the file in errors and its folder holds the `.mtl` files.
pub fn import_bytes(
    bytes: &[u8],
    path: &Path,
    options: &ImportOptions,
) -> Result<Model, AssetError> {
    let base = path.parent().unwrap_or(Path::new("."));
    let warnings = RefCell::new(Vec::new());
    let load_options = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let limits = options.limits;
    let mut reader = std::io::Cursor::new(bytes);
    let (models, materials) = tobj::load_obj_buf(&mut reader, &load_options, |mtl| {
        let file = base.join(mtl);
        match crate::options::read_limited(&file, limits.max_file_bytes) {
            Ok(data) => tobj::load_mtl_buf(&mut std::io::Cursor::new(data)),
            Err(e) => {
                warnings
                    .borrow_mut()
                    .push(format!("material library not read ({e}); grey albedo"));
                Err(tobj::LoadError::OpenFileFailed)
            }
        }
    })
    .map_err(|e| AssetError::Obj {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let mut warnings = warnings.into_inner();
    let materials = match materials {
        Ok(m) => m,
        Err(e) => {
            if !matches!(e, tobj::LoadError::OpenFileFailed) {
                warnings.push(format!("material library malformed ({e}); grey albedo"));
            }
            Vec::new()
        }
    };
    let mut triangles = 0u64;
    let mut vertices = 0u64;
    for m in &models {
        triangles = triangles.saturating_add(m.mesh.indices.len() as u64 / 3);
        vertices = vertices.saturating_add(m.mesh.positions.len() as u64 / 3);
    }
    for (what, value, limit) in [
        ("the triangle count", triangles, limits.max_triangles),
        ("the vertex count", vertices, limits.max_vertices),
    ] {
        crate::options::check_limit(path, what, value, limit)?;
    }
    let mut textures: HashMap<String, Arc<luxbake::scene::AlbedoTexture>> = HashMap::new();
    let mut names = HashSet::new();
    let mut parts = Vec::new();
    for (mi, m) in models.iter().enumerate() {
        let mesh = &m.mesh;
        if mesh.indices.len() < 3 {
            continue;
        }
        let label = if m.name.is_empty() {
            format!("object{mi}")
        } else {
            m.name.clone()
        };
        let n = mesh.positions.len() / 3;
        let positions: Vec<[f32; 3]> = mesh
            .positions
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        let normals = (mesh.normals.len() == n * 3).then(|| {
            mesh.normals
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]])
                .collect()
        });
        let material_uvs: Option<Vec<[f32; 2]>> = (mesh.texcoords.len() == n * 2).then(|| {
            mesh.texcoords
                .chunks_exact(2)
                .map(|c| [c[0], 1.0 - c[1]])
                .collect()
        });
        let colors = (mesh.vertex_color.len() == n * 3).then(|| {
            mesh.vertex_color
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]])
                .collect()
        });
        let indices: Vec<[u32; 3]> = mesh
            .indices
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        let mut albedo = Albedo::grey(0.5);
        if let Some(mat) = mesh.material_id.and_then(|i| materials.get(i)) {
            if let Some(kd) = mat.diffuse {
                albedo.factor = kd.map(|c| {
                    if c.is_finite() {
                        c.clamp(0.0, 1.0)
                    } else {
                        0.5
                    }
                });
            }
            if let Some(map) = &mat.diffuse_texture {
                if material_uvs.is_none() {
                    warnings.push(format!(
                        "{label}: map_Kd `{map}` ignored: the mesh has no texture coordinates"
                    ));
                } else {
                    let tex = match textures.get(map) {
                        Some(t) => t.clone(),
                        None => {
                            let file = base.join(map);
                            let err = |message: String| AssetError::Image {
                                path: path.to_path_buf(),
                                image: format!("`{map}` (map_Kd of `{}`)", mat.name),
                                message,
                            };
                            let data = crate::options::read_limited(&file, limits.max_file_bytes)
                                .map_err(|e| err(e.to_string()))?;
                            let t = Arc::new(crate::image::decode(&data, &limits).map_err(err)?);
                            textures.insert(map.clone(), t.clone());
                            t
                        }
                    };
                    albedo.texture = Some(tex);
                }
            }
        }
        let name = model::unique_name(&label, &mut names);
        let raw = RawPart {
            name,
            positions,
            normals,
            material_uvs,
            lightmap_uvs: None,
            colors,
            indices,
            albedo: Some(albedo),
            stretch_lightmap: false,
            gltf: None,
        };
        parts.push(model::finish(raw, path, options, &mut warnings)?);
    }
    if parts.is_empty() {
        return Err(AssetError::Empty {
            path: path.to_path_buf(),
        });
    }
    Ok(Model {
        parts,
        lights: Vec::new(),
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Model, AssetError> {
        import_bytes(
            text.as_bytes(),
            Path::new("/nonexistent/x.obj"),
            &ImportOptions::default(),
        )
    }

    #[test]
    fn quad_without_normals_or_material() {
        let m = parse("v 0 0 0\nv 1 0 0\nv 1 0 -1\nv 0 0 -1\nf 1 2 3 4\n").expect("parses");
        assert_eq!(m.triangle_count(), 2);
        let p = &m.parts[0];
        assert!(
            p.mesh.normals.iter().all(|n| (n[1] - 1.0).abs() < 1e-6),
            "{:?}",
            p.mesh.normals
        );
        assert_eq!(p.albedo.factor, [0.5; 3]);
        assert!(p.mesh.validate().is_ok());
    }

    #[test]
    fn bad_obj_gives_errors_not_panics() {
        for text in [
            "",
            "v 0 0 0\nf 1 2 3\n",
            "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -9\n",
            "f\n",
            "v 1e40 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            "mtllib missing.mtl\nusemtl x\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        ] {
            match parse(text) {
                Ok(m) => assert!(m.parts.iter().all(|p| p.mesh.validate().is_ok())),
                Err(e) => assert!(!e.to_string().is_empty()),
            }
        }
        let e = parse("v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n").expect_err("NaN");
        assert!(e.to_string().contains("position 2"), "{e}");
    }
}
