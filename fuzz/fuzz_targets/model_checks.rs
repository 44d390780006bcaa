//! What every importer fuzz target asserts of a file that parsed: each mesh passes
//! `Mesh::validate` and every light-map UV lies in [0, 1].

pub fn assert_model_is_sound(model: &luxbake_assets::Model) {
    for part in &model.parts {
        part.mesh.validate().expect("imported meshes are valid");
        assert!(
            part.mesh
                .lightmap_uvs
                .iter()
                .flatten()
                .all(|c| (0.0..=1.0).contains(c))
        );
    }
}
