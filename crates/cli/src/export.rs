//! `luxbake export NAME OUT.glb [--texels-per-metre D]`: writes a built-in scene (or,
//! with a `.toml` path for NAME, a scene file) as glTF 2.0 binary: meshes with light-map UVs
//! (`TEXCOORD_1`), albedo, lamps in `extras` — so other tools (Blender, ...) can bake the very
//! same scene. See `luxbake_assets::export` for the layout of the file.

use std::path::PathBuf;

use luxbake::scene::{Scene, Settings};

/// Arguments of `luxbake export` (and `cargo xtask export-scene`).
#[derive(clap::Args)]
pub struct Args {
    /// A built-in scene (chairs_01, chairs_03, chairs_05, chairs_10, sofa_01, floor, sphere)
    /// or a `.toml` scene file.
    name: String,
    /// The `.glb` to write.
    out: PathBuf,
    /// Light-map density the built-in meshes' chart padding is sized for.
    #[arg(long)]
    texels_per_metre: Option<f32>,
}

/// Runs the export; the error is a message for stderr.
pub fn run(args: &Args) -> Result<(), String> {
    let scene = if args.name.ends_with(".toml") {
        let loader = luxbake_assets::SceneLoader::default();
        Scene::from_toml_file_with(std::path::Path::new(&args.name), &loader)
            .map_err(|e| e.to_string())?
    } else {
        let mut settings = Settings::default();
        if let Some(d) = args.texels_per_metre {
            settings.texels_per_metre = d;
        }
        Scene::builtin_with_settings(&args.name, settings).map_err(|e| e.to_string())?
    };
    luxbake_assets::export::export_scene(&scene, &args.out).map_err(|e| e.to_string())?;
    println!(
        "wrote {} ({} objects, {} triangles, {} lamps)",
        args.out.display(),
        scene.objects.len(),
        scene.triangle_count(),
        scene.lamps.len()
    );
    Ok(())
}
