//! What the model tests share: the shared models and the check of an object's charts.

use std::path::PathBuf;

use luxbake::scene::Object;
use luxbake_assets::uv::{self, OVERLAP_TOLERANCE};

/// `../shared/models`, or `None` after `luxbake_testkit::skip_or_fail` (which fails `test` under
/// CI).
pub fn models_dir(test: &str) -> Option<PathBuf> {
    luxbake_testkit::shared_data(test, "models")
}

/// Panics (naming `what` and the object) unless `o`'s light-map UVs pass [`uv::check`] and its
/// charts, in texels of its map at `texels_per_metre`, keep `pad` texels apart.
pub fn check_charts(what: &str, o: &Object, texels_per_metre: f32, pad: f32) {
    let m = &o.mesh;
    uv::check(&m.lightmap_uvs, &m.positions, &m.indices, OVERLAP_TOLERANCE)
        .unwrap_or_else(|e| panic!("{what}{}: {e}", o.name));
    let size = luxbake::layout::map_size(o, texels_per_metre, 16_384).expect("size");
    let texel_uvs: Vec<[f32; 2]> = m
        .lightmap_uvs
        .iter()
        .map(|uv| [uv[0] * size[0] as f32, uv[1] * size[1] as f32])
        .collect();
    let gap = uv::min_chart_gap(&texel_uvs, &m.indices, f64::from(pad) * 0.999);
    assert_eq!(
        gap, None,
        "{what}{}: charts closer than {pad} texels",
        o.name
    );
}
