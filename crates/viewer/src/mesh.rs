//! The scene's meshes as the display draws them: world-space vertex arrays per object.
//!
//! One vertex is [`FLOATS_PER_VERTEX`] floats: world position (3, metres), world normal (3),
//! light-map UV (2), linear albedo (3: the object's factor × its vertex colour). The display
//! multiplies the light map's illuminance (lux) by this albedo per fragment, so the
//! displayed exitance carries the albedo at vertex resolution rather than light-map
//! resolution.

use luxbake::scene::Scene;

/// Floats per interleaved vertex.
pub const FLOATS_PER_VERTEX: usize = 11;

/// One object ready to upload.
#[derive(Debug, Clone, PartialEq)]
pub struct DisplayMesh {
    /// Object name.
    pub name: String,
    /// Interleaved vertices ([`FLOATS_PER_VERTEX`] each).
    pub vertices: Vec<f32>,
    /// Triangle list, three indices per triangle.
    pub indices: Vec<u32>,
}

/// The display meshes of `scene`, one per object, in object order. Triangles with an index
/// outside the vertex list are dropped (the bake validates scenes; this keeps the display
/// from ever reading out of bounds).
pub fn display_meshes(scene: &Scene) -> Vec<DisplayMesh> {
    scene
        .objects
        .iter()
        .map(|o| {
            let m = &o.mesh;
            let n = m.positions.len();
            let mut vertices = Vec::with_capacity(n * FLOATS_PER_VERTEX);
            for i in 0..n {
                let p = o.transform.point(m.positions[i]);
                let nrm = m
                    .normals
                    .get(i)
                    .map_or([0.0, 1.0, 0.0], |&v| o.transform.normal(v));
                let uv = m.lightmap_uvs.get(i).copied().unwrap_or([0.0; 2]);
                let c = m
                    .colors
                    .as_ref()
                    .and_then(|c| c.get(i))
                    .copied()
                    .unwrap_or([1.0; 3]);
                let a = o.albedo.factor;
                vertices.extend_from_slice(&p);
                vertices.extend_from_slice(&nrm);
                vertices.extend_from_slice(&uv);
                vertices.extend_from_slice(&[a[0] * c[0], a[1] * c[1], a[2] * c[2]]);
            }
            let indices = m
                .indices
                .iter()
                .filter(|t| t.iter().all(|&i| (i as usize) < n))
                .flatten()
                .copied()
                .collect();
            DisplayMesh {
                name: o.name.clone(),
                vertices,
                indices,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meshes_cover_every_object_in_world_space() {
        let scene = Scene::builtin("chairs_01").unwrap();
        let meshes = display_meshes(&scene);
        assert_eq!(meshes.len(), scene.objects.len());
        for (m, o) in meshes.iter().zip(&scene.objects) {
            assert_eq!(m.vertices.len(), o.mesh.positions.len() * FLOATS_PER_VERTEX);
            assert_eq!(m.indices.len(), o.mesh.indices.len() * 3);
            for v in m.vertices.chunks_exact(FLOATS_PER_VERTEX) {
                assert!(v.iter().all(|x| x.is_finite()));
                assert!((0.0..=1.0).contains(&v[6]) && (0.0..=1.0).contains(&v[7]));
                let len = (v[3] * v[3] + v[4] * v[4] + v[5] * v[5]).sqrt();
                assert!((len - 1.0).abs() < 1e-3, "normal length {len}");
            }
        }
        // The chair is placed: its world x differs from its object-space x.
        let chair = &meshes[1];
        let p0 = scene.objects[1].mesh.positions[0];
        assert_ne!(chair.vertices[0], p0[0]);
    }

    #[test]
    fn out_of_range_indices_are_dropped() {
        let mut scene = Scene::builtin("chairs_01").unwrap();
        scene.objects[0].mesh.indices.push([0, 1, u32::MAX]);
        let before = scene.objects[0].mesh.indices.len() - 1;
        assert_eq!(display_meshes(&scene)[0].indices.len(), before * 3);
    }
}
