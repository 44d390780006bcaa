//! Light-map layout: texel density → per-object map size → rectangles in texture-array layers.
//!
//! # Map size
//! An object's light-map UVs span [0, 1]²; the layout measures how many metres of (world,
//! transformed) surface that square spans along u and along v ([`lightmap_extent`]) and sizes
//! the map as `ceil(extent · texels_per_metre · texel_scale)` texels per axis (at least 1), so
//! every receiver is sampled at the same density (times its `texel_scale`) whatever its size.
//!
//! # Limits
//! The density itself is only required to be finite and positive, so a scene modelled at any
//! scale bakes at the same texel count. What is limited is what the bake allocates: the maps
//! may need at most [`Layout::MAX_TEXELS`] texels, and so may the texture array they are
//! packed in (checked before anything of that size is allocated); each map fits the
//! backend's maximum texture size and the layers its maximum layer count.
//!
//! # Texture arrays (paper §3.3)
//! All maps live in one texture array whose layer size is the largest map's width × the
//! largest map's height. Maps are not rescaled to the layer: each map occupies a
//! sub-rectangle ([`Region`]) of a layer, and smaller maps share layers — they are packed
//! with a shelf packer, tallest first, [`REGION_GAP`] texels apart so a blur cannot carry one
//! object's light into another's map. Non-receivers get no region (`None`). A scene with no
//! receiver has zero layers.

use glam::{DVec3, Vec2};

use crate::scene::{Object, Scene};

/// Empty texels between two regions of the same layer.
pub const REGION_GAP: u32 = 4;

/// The chart-padding rule the scene's meshes are built with (the scene crate's).
pub use luxbake_scene::{MIN_CHART_PADDING_TEXELS, chart_padding_texels};

/// Errors of [`Layout::new`].
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LayoutError {
    /// The texel density is not a finite positive number.
    #[error("texels_per_metre must be finite and > 0, got {0}")]
    InvalidDensity(f32),
    /// The light maps, or the texture array they are packed in, need more texels than
    /// [`Layout::MAX_TEXELS`].
    #[error(
        "the light maps need {texels} texels, over the limit of {limit} texels; lower \
         texels_per_metre to at most {suggested_density}"
    )]
    TooManyTexels {
        /// Texels needed: the maps' total, or the texture array's (layers × layer size).
        texels: u64,
        /// The limit, [`Layout::MAX_TEXELS`].
        limit: u64,
        /// A density at which the maps' total would fit.
        suggested_density: f32,
    },
    /// An object's texel scale is not a finite positive number.
    #[error("object `{object}`: texel_scale must be finite and > 0, got {value}")]
    InvalidTexelScale {
        /// The object's name.
        object: String,
        /// Its texel scale.
        value: f32,
    },
    /// A receiver's light-map UVs cover no area (or its surface has none), so it has no size.
    #[error("object `{object}`: its light-map UVs or its surface have no area")]
    NoLightmapArea {
        /// The object's name.
        object: String,
    },
    /// A map does not fit the backend's maximum texture size.
    #[error(
        "object `{object}`: a {}×{} light map exceeds the maximum texture size {max}; lower \
         texels_per_metre to at most {suggested_density:.1}",
        size[0], size[1]
    )]
    MapTooLarge {
        /// The object's name.
        object: String,
        /// The map size it would need, texels.
        size: [u64; 2],
        /// The maximum texture size.
        max: u32,
        /// A density at which it would fit.
        suggested_density: f32,
    },
    /// The maps need more layers than the backend allows.
    #[error("the light maps need {needed} texture-array layers, the backend allows {max}")]
    TooManyLayers {
        /// Layers needed.
        needed: u32,
        /// Layers allowed.
        max: u32,
    },
}

/// Where one object's light map lives: a texel rectangle in one layer of the texture array.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Region {
    /// Layer of the texture array.
    pub layer: u32,
    /// Top-left texel (x = column, y = row) of the rectangle in its layer.
    pub offset: [u32; 2],
    /// Width and height, texels.
    pub size: [u32; 2],
}

impl Region {
    /// Number of texels in the rectangle.
    pub fn texel_count(&self) -> u64 {
        u64::from(self.size[0]) * u64::from(self.size[1])
    }

    /// The texel `(x, y)` (column, row, in its layer) holding light-map UV `uv`, clamped to
    /// the rectangle; `None` for non-finite UVs.
    pub fn texel_at(&self, uv: [f32; 2]) -> Option<[u32; 2]> {
        if !uv.iter().all(|c| c.is_finite()) {
            return None;
        }
        Some(std::array::from_fn(|k| {
            let t = (f64::from(uv[k]) * f64::from(self.size[k])).floor();
            let t = t.clamp(0.0, f64::from(self.size[k].saturating_sub(1))) as u32;
            self.offset[k] + t
        }))
    }
}

/// The light-map layout of a scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// Width and height of every layer, texels.
    pub layer_size: [u32; 2],
    /// Number of layers.
    pub layers: u32,
    /// One entry per scene object, in object order; `None` for non-receivers.
    pub regions: Vec<Option<Region>>,
}

impl Layout {
    /// Most texels of all light maps together, and of the texture array holding them
    /// (2²⁶ ≈ 67 million: 1 GiB per RGBA32F texture of the bake graph). The built-in scenes
    /// need about a million at the default density.
    pub const MAX_TEXELS: u64 = 1 << 26;

    /// Lays out the receivers of `scene` at `scene.settings.texels_per_metre`, with maps of at
    /// most `max_texture_size` texels per side in at most `max_layers` layers, and at most
    /// [`Layout::MAX_TEXELS`] texels in all.
    pub fn new(
        scene: &Scene,
        max_texture_size: u32,
        max_layers: u32,
    ) -> Result<Layout, LayoutError> {
        let density = scene.settings.texels_per_metre;
        if !(density.is_finite() && density > 0.0) {
            return Err(LayoutError::InvalidDensity(density));
        }
        // The maps' total first, before any size is trusted.
        let mut wanted = 0.0f64;
        for o in scene.objects.iter().filter(|o| o.receiver) {
            let [w, h] = wanted_size(o, density)?;
            wanted += w * h;
        }
        check_texels(wanted, wanted, density)?;
        let mut sizes = Vec::with_capacity(scene.objects.len());
        for o in &scene.objects {
            sizes.push(if o.receiver {
                Some(map_size(o, density, max_texture_size)?)
            } else {
                None
            });
        }
        let layer_size = sizes
            .iter()
            .flatten()
            .fold([0u32; 2], |acc, s| [acc[0].max(s[0]), acc[1].max(s[1])]);
        let mut order: Vec<usize> = (0..sizes.len()).filter(|&i| sizes[i].is_some()).collect();
        order.sort_by_key(|&i| {
            let s = sizes[i].unwrap_or([0, 0]);
            (std::cmp::Reverse(s[1]), std::cmp::Reverse(s[0]), i)
        });
        let mut layers: Vec<Vec<Shelf>> = Vec::new();
        let mut regions = vec![None; sizes.len()];
        for i in order {
            let Some(size) = sizes[i] else { continue };
            let placed = layers
                .iter_mut()
                .enumerate()
                .find_map(|(l, shelves)| place(shelves, size, layer_size).map(|o| (l, o)));
            let (layer, offset) = match placed {
                Some(p) => p,
                None => {
                    let mut shelves = Vec::new();
                    let offset = place(&mut shelves, size, layer_size).unwrap_or([0, 0]);
                    layers.push(shelves);
                    (layers.len() - 1, offset)
                }
            };
            regions[i] = Some(Region {
                layer: layer as u32,
                offset,
                size,
            });
        }
        let needed = layers.len() as u32;
        if needed > max_layers {
            return Err(LayoutError::TooManyLayers {
                needed,
                max: max_layers,
            });
        }
        let layout = Layout {
            layer_size,
            layers: needed,
            regions,
        };
        // Packing leaves gaps: the array can be larger than the maps.
        check_texels(layout.allocated_texels() as f64, wanted, density)?;
        Ok(layout)
    }

    /// Light-map texels the passes compute: the sum of the regions' areas (the paper's
    /// "light-map texels" of Table 1). Texels of a region outside every chart are included;
    /// [`crate::gbuffer::GBuffer::valid_texels`] counts only those on a surface.
    pub fn texel_count(&self) -> u64 {
        self.regions.iter().flatten().map(Region::texel_count).sum()
    }

    /// Texels allocated in the texture array (`layers × layer width × layer height`).
    pub fn allocated_texels(&self) -> u64 {
        u64::from(self.layers) * u64::from(self.layer_size[0]) * u64::from(self.layer_size[1])
    }
}

#[derive(Debug)]
struct Shelf {
    y: u32,
    height: u32,
    next_x: u32,
}

/// Finds a place for a `size` rectangle among the shelves of one layer, opening a new shelf
/// below the last one if needed.
fn place(shelves: &mut Vec<Shelf>, size: [u32; 2], layer: [u32; 2]) -> Option<[u32; 2]> {
    for s in shelves.iter_mut() {
        if size[1] <= s.height && s.next_x.saturating_add(size[0]) <= layer[0] {
            let x = s.next_x;
            s.next_x = x.saturating_add(size[0]).saturating_add(REGION_GAP);
            return Some([x, s.y]);
        }
    }
    let y = shelves.last().map_or(0, |s| {
        s.y.saturating_add(s.height).saturating_add(REGION_GAP)
    });
    (size[0] <= layer[0] && y.saturating_add(size[1]) <= layer[1]).then(|| {
        shelves.push(Shelf {
            y,
            height: size[1],
            next_x: size[0].saturating_add(REGION_GAP),
        });
        [0, y]
    })
}

/// [`LayoutError::TooManyTexels`] when `texels` (of the maps or of the array) exceed
/// [`Layout::MAX_TEXELS`]; the suggested density scales the maps' total `wanted` to fit.
fn check_texels(texels: f64, wanted: f64, density: f32) -> Result<(), LayoutError> {
    let limit = Layout::MAX_TEXELS;
    if texels <= limit as f64 {
        return Ok(());
    }
    let shrink = (limit as f64 / texels.max(wanted)).sqrt();
    Err(LayoutError::TooManyTexels {
        texels: texels.min(u64::MAX as f64) as u64,
        limit,
        suggested_density: (f64::from(density) * shrink * 0.999) as f32,
    })
}

/// The light-map size of one object at `texels_per_metre` (times its `texel_scale`), in
/// texels per axis before any limit: at least 1, possibly huge.
fn wanted_size(object: &Object, texels_per_metre: f32) -> Result<[f64; 2], LayoutError> {
    let scale = object.texel_scale;
    if !(scale.is_finite() && scale > 0.0) {
        return Err(LayoutError::InvalidTexelScale {
            object: object.name.clone(),
            value: scale,
        });
    }
    let extent = lightmap_extent(object).ok_or_else(|| LayoutError::NoLightmapArea {
        object: object.name.clone(),
    })?;
    let d = f64::from(texels_per_metre) * f64::from(scale);
    // 1e-4 texel of slack so f32 noise in the UVs does not add a whole row or column.
    Ok(extent.map(|e| (e * d - 1e-4).ceil().max(1.0)))
}

/// The light-map size of one object at `texels_per_metre` (times its `texel_scale`).
pub fn map_size(
    object: &Object,
    texels_per_metre: f32,
    max_texture_size: u32,
) -> Result<[u32; 2], LayoutError> {
    let want = wanted_size(object, texels_per_metre)?;
    let longest = want[0].max(want[1]);
    if longest > f64::from(max_texture_size) {
        let suggested = f64::from(texels_per_metre) * f64::from(max_texture_size) / longest;
        return Err(LayoutError::MapTooLarge {
            object: object.name.clone(),
            size: want.map(|w| w.min(u64::MAX as f64) as u64),
            max: max_texture_size,
            suggested_density: (suggested * 0.999) as f32,
        });
    }
    Ok(want.map(|w| w as u32))
}

/// Metres of world surface spanned by the object's light-map square along u and along v:
/// `sqrt(A_world / A_uv)` split by the area-weighted ratio of the surface's stretch along u
/// and v (exact for charts laid out at a uniform metric scale, as [`crate::sources::meshes`] does).
/// `None` when the UVs or the surface have no area, or the data is not finite.
pub fn lightmap_extent(object: &Object) -> Option<[f64; 2]> {
    let m = &object.mesh;
    let (mut area_world, mut area_uv, mut stretch_u, mut stretch_v) =
        (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for tri in &m.indices {
        let Some(idx) = crate::scene::tri_indices(tri, m) else {
            continue;
        };
        let p = idx.map(|i| DVec3::from(object.transform.point_f64(m.positions[i].map(f64::from))));
        let t = idx.map(|i| Vec2::from(m.lightmap_uvs[i]).as_dvec2());
        let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
        let (d1, d2) = (t[1] - t[0], t[2] - t[0]);
        let det = d1.perp_dot(d2);
        let aw = e1.cross(e2).length() / 2.0;
        let auv = det.abs() / 2.0;
        if !(aw.is_finite() && auv.is_finite()) || auv == 0.0 {
            continue;
        }
        // dP/du and dP/dv of the affine map from UV to the surface.
        let dpdu = (e1 * d2.y - e2 * d1.y) / det;
        let dpdv = (e1 * -d2.x + e2 * d1.x) / det;
        area_world += aw;
        area_uv += auv;
        stretch_u += auv * dpdu.length();
        stretch_v += auv * dpdv.length();
    }
    if !(area_world > 0.0 && area_uv > 0.0 && stretch_u > 0.0 && stretch_v > 0.0) {
        return None;
    }
    let side2 = area_world / area_uv; // extent_u · extent_v
    let aspect = stretch_u / stretch_v; // extent_u / extent_v
    let e = [(side2 * aspect).sqrt(), (side2 / aspect).sqrt()];
    e.iter().all(|x| x.is_finite() && *x > 0.0).then_some(e)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Albedo, Settings, Transform};
    use crate::sources::meshes;

    fn plane_object(name: &str, size: [f32; 2], padding: f32) -> Object {
        Object {
            name: name.into(),
            mesh: meshes::plane(size, padding),
            transform: Transform::IDENTITY,
            albedo: Albedo::grey(0.5),
            receiver: true,
            texel_scale: 1.0,
        }
    }

    fn scene(objects: Vec<Object>, density: f32) -> Scene {
        Scene {
            objects,
            lamps: Vec::new(),
            settings: Settings {
                texels_per_metre: density,
                ..Settings::default()
            },
        }
    }

    #[test]
    fn density_gives_map_size() {
        // A 2 m × 1 m plane with 1/16 m padding: the UV square spans 2.0625 m × 1.0625 m.
        let pad = 1.0 / 16.0;
        let o = plane_object("p", [2.0, 1.0], pad);
        let e = lightmap_extent(&o).expect("extent");
        assert!(
            (e[0] - 2.0625).abs() < 1e-5 && (e[1] - 1.0625).abs() < 1e-5,
            "{e:?}"
        );
        assert_eq!(map_size(&o, 64.0, 4096).expect("size"), [132, 68]);
        assert_eq!(map_size(&o, 10.0, 4096).expect("size"), [21, 11]);
        // texel_scale and the object's transform scale the map.
        let mut big = o.clone();
        big.texel_scale = 2.0;
        assert_eq!(map_size(&big, 64.0, 4096).expect("size"), [264, 136]);
        let mut scaled = o.clone();
        scaled.transform = Transform::from_trs([3.0, 0.0, 0.0], [0.0, 90.0, 0.0], [2.0, 1.0, 2.0]);
        assert_eq!(map_size(&scaled, 64.0, 4096).expect("size"), [264, 136]);
        let mut stretched = o;
        stretched.transform = Transform::from_trs([0.0; 3], [0.0; 3], [1.0, 1.0, 3.0]);
        assert_eq!(map_size(&stretched, 64.0, 4096).expect("size"), [132, 204]);
    }

    #[test]
    fn regions_are_disjoint_sub_rectangles() {
        let objects = vec![
            plane_object("a", [4.0, 3.0], 0.05),
            plane_object("b", [1.0, 1.0], 0.05),
            plane_object("c", [2.0, 1.0], 0.05),
            plane_object("d", [1.0, 2.0], 0.05),
            plane_object("e", [0.5, 0.5], 0.05),
        ];
        let mut objects = objects;
        objects.push(Object {
            receiver: false,
            ..plane_object("occluder", [1.0, 1.0], 0.05)
        });
        let s = scene(objects, 50.0);
        let l = Layout::new(&s, 4096, 16).expect("layout");
        assert_eq!(l.regions.len(), 6);
        assert!(l.regions[5].is_none(), "non-receivers get no map");
        let sizes: Vec<[u32; 2]> = s.objects[..5]
            .iter()
            .map(|o| map_size(o, 50.0, 4096).expect("size"))
            .collect();
        assert_eq!(l.layer_size, [sizes[0][0], sizes[0][1]]);
        let regions: Vec<Region> = l.regions.iter().flatten().copied().collect();
        for (r, s) in regions.iter().zip(&sizes) {
            assert_eq!(r.size, *s);
            assert!(r.layer < l.layers);
            assert!(r.offset[0] + r.size[0] <= l.layer_size[0]);
            assert!(r.offset[1] + r.size[1] <= l.layer_size[1]);
        }
        for (i, a) in regions.iter().enumerate() {
            for b in &regions[i + 1..] {
                if a.layer != b.layer {
                    continue;
                }
                let apart = (0..2).any(|k| {
                    a.offset[k] + a.size[k] + REGION_GAP <= b.offset[k]
                        || b.offset[k] + b.size[k] + REGION_GAP <= a.offset[k]
                });
                assert!(apart, "{a:?} and {b:?} overlap or are closer than the gap");
            }
        }
        assert_eq!(
            l.texel_count(),
            sizes.iter().map(|s| u64::from(s[0] * s[1])).sum::<u64>()
        );
        assert!(l.allocated_texels() >= l.texel_count());
        // The four small maps share the second layer.
        assert_eq!(l.layers, 2);
    }

    #[test]
    fn limits_are_reported() {
        let s = scene(vec![plane_object("wide", [10.0, 1.0], 0.0)], 100.0);
        match Layout::new(&s, 512, 4) {
            Err(LayoutError::MapTooLarge {
                object,
                size,
                max,
                suggested_density,
            }) => {
                assert_eq!((object.as_str(), size, max), ("wide", [1000, 100], 512));
                let mut fixed = s.clone();
                fixed.settings.texels_per_metre = suggested_density;
                assert!(
                    Layout::new(&fixed, 512, 4).is_ok(),
                    "the suggested density fits"
                );
            }
            other => panic!("{other:?}"),
        }
        let many = scene(
            (0..5)
                .map(|i| plane_object(&format!("p{i}"), [1.0, 1.0], 0.0))
                .collect(),
            64.0,
        );
        assert!(matches!(
            Layout::new(&many, 64, 3),
            Err(LayoutError::TooManyLayers { needed: 5, max: 3 })
        ));
        assert!(Layout::new(&many, 4096, 16).is_ok());
        for d in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            let mut bad = many.clone();
            bad.settings.texels_per_metre = d;
            assert!(matches!(
                Layout::new(&bad, 4096, 16),
                Err(LayoutError::InvalidDensity(_))
            ));
        }
        let mut bad = many.clone();
        bad.objects[1].texel_scale = 0.0;
        assert!(matches!(
            Layout::new(&bad, 4096, 16),
            Err(LayoutError::InvalidTexelScale { .. })
        ));
        let mut flat = many;
        flat.objects[0]
            .mesh
            .lightmap_uvs
            .iter_mut()
            .for_each(|uv| *uv = [0.5, 0.5]);
        assert!(matches!(
            Layout::new(&flat, 4096, 16),
            Err(LayoutError::NoLightmapArea { object }) if object == "p0"
        ));
        let none = scene(Vec::new(), 64.0);
        let l = Layout::new(&none, 4096, 16).expect("empty");
        assert_eq!((l.layers, l.texel_count()), (0, 0));
    }

    #[test]
    fn the_texel_count_is_limited_not_the_density() {
        let plane = |size| vec![plane_object("p", size, 0.0)];
        // A square metre at 1 mm texels: a million texels.
        let fine = Layout::new(&scene(plane([1.0, 1.0]), 1000.0), 16_384, 16).expect("fine");
        assert_eq!(fine.texel_count(), 1_000_000);
        // An absurd density is refused before any map is sized, naming the texel count and
        // the limit; the density it suggests fits.
        for d in [1e5f32, 1e12, f32::MAX] {
            let s = scene(plane([1.0, 1.0]), d);
            match Layout::new(&s, 16_384, 16) {
                Err(
                    e @ LayoutError::TooManyTexels {
                        texels,
                        limit,
                        suggested_density,
                    },
                ) => {
                    assert_eq!(limit, Layout::MAX_TEXELS);
                    assert!(texels > limit, "{d}: {texels}");
                    let m = e.to_string();
                    assert!(m.contains(&format!("{texels} texels")), "{m}");
                    assert!(m.contains(&format!("limit of {limit} texels")), "{m}");
                    let mut fixed = s.clone();
                    fixed.settings.texels_per_metre = suggested_density;
                    let l = Layout::new(&fixed, 16_384, 16).expect("the suggestion fits");
                    assert!(l.allocated_texels() <= limit, "{d}");
                }
                other => panic!("{d}: {other:?}"),
            }
        }
        // Few texels in thin maps, a 16384 × 1 and a 1 × 16384 (the plane stretched along u,
        // along v), but a texture array of two 16384² layers.
        let stretched = |name, scale| Object {
            transform: Transform::from_trs([0.0; 3], [0.0; 3], scale),
            ..plane_object(name, [1.0, 1.0], 0.0)
        };
        let thin = scene(
            vec![
                stretched("wide", [16_384.0, 1.0, 1.0]),
                stretched("tall", [1.0, 1.0, 16_384.0]),
            ],
            1.0,
        );
        assert!(matches!(
            Layout::new(&thin, 16_384, 16),
            Err(LayoutError::TooManyTexels { texels, .. }) if texels == 2 * 16_384 * 16_384
        ));
    }

    #[test]
    fn texel_at_follows_the_uv_convention() {
        let r = Region {
            layer: 1,
            offset: [10, 20],
            size: [100, 50],
        };
        assert_eq!(r.texel_at([0.0, 0.0]), Some([10, 20]));
        assert_eq!(r.texel_at([0.999, 0.999]), Some([109, 69]));
        assert_eq!(r.texel_at([1.0, 1.0]), Some([109, 69]), "clamped");
        assert_eq!(r.texel_at([0.5, 0.01]), Some([60, 20]));
        assert_eq!(r.texel_at([f32::NAN, 0.0]), None);
    }

    /// The built-in scenes at the default density, against the paper's Table 1.
    #[test]
    fn builtin_texel_counts_near_table_1() {
        let table = [
            ("chairs_01", 459_000, 252),
            ("chairs_03", 590_000, 732),
            ("chairs_05", 721_000, 1212),
            ("chairs_10", 1_049_000, 2412),
            ("sofa_01", 655_000, 2036),
        ];
        for (name, texels, triangles) in table {
            let s = Scene::builtin(name).expect("builtin");
            let l = Layout::new(&s, 4096, 64).expect("layout");
            let n = l.texel_count();
            println!(
                "{name}: {n} texels (paper {texels}), {} triangles, {} layers of {:?}",
                s.triangle_count(),
                l.layers,
                l.layer_size
            );
            assert_eq!(s.triangle_count(), triangles, "{name}");
            let rel = n as f64 / texels as f64 - 1.0;
            assert!(rel.abs() < 0.05, "{name}: {n} texels vs {texels}");
        }
    }
}
