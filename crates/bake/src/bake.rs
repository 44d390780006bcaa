//! The bake driver: layout → G-buffer → BVH build and encode → pass graph → run on a backend.
//!
//! # Modelling only what the scene requires
//! - **Lamps**: before the direct pass, every lamp is evaluated (without shadow rays) at every
//!   valid texel on the CPU: a lamp that faces no texel with a non-zero intensity (it is behind
//!   every receiving surface, turned away, or has a zero multiplier, colour or table) is left out
//!   of the direct pass. A lamp that reaches some receivers but not others is reported per
//!   object.
//! - **Bounces**: after bounce `k` the driver reads back the indirect map and computes the
//!   energy it added, `(ΣE_ind,k − ΣE_ind,k−1) / (ΣE_direct + ΣE_ind,k)` over valid texels
//!   (texels have equal area at a uniform density). Under [`BOUNCE_ENERGY_THRESHOLD`] the
//!   remaining bounces are skipped: each further bounce adds at most about as much again times
//!   the albedo.
//! - **Non-receivers** get no light map (the layout gives them no region); they still cast
//!   shadows and reflect nothing.
//! - **Brute force**: with at most [`BRUTE_FORCE_MAX_TRIANGLES`] triangles a ray tests every
//!   triangle, which costs no more than walking a BVH's boxes; the traversal switches to
//!   [`BvhMode::None`].
//!
//! Everything left out is listed in [`BakeReport::skipped`].

use std::fmt;
// `web_time::Instant` is `std::time::Instant` natively and `performance.now()` on wasm32, where
// std's clock panics (the bake runs in a browser in `luxbake-viewer`).
use web_time::Instant;

use luxbake_bvh::{BuildOptions, Bvh, BvhError, EncodeOptions, WideBvh, encode};
use luxbake_ies::GpuTable;
use rayon::prelude::*;

use crate::backend::{Dispatch, GpuBackend, LampParams, SceneData, ray_epsilon};
use crate::gbuffer::{GBuffer, rasterize};
use crate::graph::{BakeGraph, GraphConfig, GraphError, PassKind, TexId};
use crate::layout::{Layout, LayoutError, Region};
use crate::lightpaths::{self, LampPaths};
use crate::map::MapImage;
use crate::program::{CombineParams, Params, TilePlan};
use crate::scene::{BvhMode, Method, Scene, Settings};
use crate::series::Series;
use crate::validity;

/// Bounces stop once one adds less than this fraction of the total illuminance.
pub const BOUNCE_ENERGY_THRESHOLD: f32 = 1e-3;

/// Scenes with at most this many triangles are traced by brute force.
pub const BRUTE_FORCE_MAX_TRIANGLES: usize = 8;

/// Everything that can stop a bake.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BakeError<E: std::error::Error + 'static> {
    /// A setting is out of range.
    #[error("invalid setting `{name}`: {reason}")]
    InvalidSetting {
        /// Setting name (as in the scene file's `[settings]`).
        name: &'static str,
        /// What is allowed.
        reason: String,
    },
    /// The light maps do not fit the backend's textures.
    #[error("light-map layout: {0}")]
    Layout(#[from] LayoutError),
    /// The BVH could not be built or encoded.
    #[error("BVH: {0}")]
    Bvh(#[from] BvhError),
    /// A pass of the graph breaks its program's signature (a bug in the graph builder).
    #[error("pass graph: {0}")]
    Graph(#[from] GraphError),
    /// The backend failed.
    #[error("{backend} backend: {source}")]
    Backend {
        /// Backend name.
        backend: &'static str,
        /// Its error.
        #[source]
        source: E,
    },
}

/// Progress events of a bake, in order.
#[derive(Debug, Clone, PartialEq)]
pub enum Progress<'a> {
    /// A set-up step starts ("layout", "rasterise", "bvh", "unocclude", "lamp paths", "upload",
    /// "read back").
    Setup(&'a str),
    /// Pass `index` of `count` starts.
    PassStart {
        /// Index in the graph.
        index: usize,
        /// Number of passes in the graph.
        count: usize,
        /// Pass label.
        label: &'static str,
        /// Bounce (0 = direct part).
        bounce: u32,
    },
    /// Fraction (0–1) of the running pass done.
    PassProgress {
        /// Index in the graph.
        index: usize,
        /// Fraction done.
        fraction: f32,
    },
    /// Pass `index` finished after `seconds`.
    PassDone {
        /// Index in the graph.
        index: usize,
        /// Wall time, seconds.
        seconds: f64,
    },
}

/// Wall time of one executed pass.
#[derive(Debug, Clone, PartialEq)]
pub struct PassTiming {
    /// Pass label.
    pub label: &'static str,
    /// Pass kind.
    pub kind: PassKind,
    /// Bounce (0 = direct part).
    pub bounce: u32,
    /// Wall time, seconds.
    pub seconds: f64,
}

/// Something the bake left out because the scene does not need it.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Skipped {
    /// A lamp lights no texel (behind or turned away from every receiver, or dark).
    Lamp {
        /// Lamp index.
        lamp: usize,
        /// Lamp name.
        name: String,
    },
    /// A lamp that is used lights no texel of this receiver.
    LampObject {
        /// Lamp index.
        lamp: usize,
        /// Object index.
        object: usize,
        /// Object name.
        name: String,
    },
    /// An object receives no light map.
    NonReceiver {
        /// Object index.
        object: usize,
        /// Object name.
        name: String,
    },
    /// Bounces `from ..= to` were not run: bounce `from − 1` added only `added` of the light.
    Bounces {
        /// First bounce skipped.
        from: u32,
        /// Last bounce skipped.
        to: u32,
        /// Relative energy the last bounce run added.
        added: f32,
    },
    /// [`Settings::lamp_paths`] were asked for but not combined with the first bounce: it is
    /// gathered at reduced resolution or refined (the weights need every texel gathered with
    /// one ray count), or the bake has no bounce or no lamp that lights anything.
    LampPaths {
        /// Why.
        reason: &'static str,
    },
    /// Brute-force traversal replaced the requested BVH.
    Bvh {
        /// The requested traversal.
        requested: BvhMode,
        /// Triangles in the scene.
        triangles: usize,
    },
}

impl fmt::Display for Skipped {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Skipped::Lamp { lamp, name } => {
                write!(f, "lamp {lamp} `{name}`: lights no texel, left out")
            }
            Skipped::LampObject { lamp, name, .. } => {
                write!(f, "lamp {lamp}: lights no texel of `{name}`")
            }
            Skipped::NonReceiver { name, .. } => write!(f, "`{name}`: non-receiver, no map"),
            Skipped::Bounces { from, to, added } => write!(
                f,
                "bounces {from}..={to}: bounce {} added only {:.3} % of the light",
                from - 1,
                added * 100.0
            ),
            Skipped::LampPaths { reason } => write!(f, "lamp paths: not used, {reason}"),
            Skipped::Bvh {
                requested,
                triangles,
            } => write!(
                f,
                "BVH `{}`: {triangles} triangles, brute force is cheaper",
                requested.name()
            ),
        }
    }
}

/// Statistics and timings of a bake.
#[derive(Debug, Clone, PartialEq)]
pub struct BakeReport {
    /// Backend name.
    pub backend: &'static str,
    /// Valid (sampled) light-map texels.
    pub texels: u64,
    /// Texels of the receivers' regions (valid or not).
    pub region_texels: u64,
    /// Triangles in the scene.
    pub triangles: usize,
    /// Shadow rays cast (one per valid texel facing a used lamp with non-zero intensity).
    pub shadow_rays: u64,
    /// Gather rays cast (valid texels × rays × bounces run).
    pub gather_rays: u64,
    /// Traversal used.
    pub bvh: BvhMode,
    /// Explicit bounces run.
    pub bounces_run: u32,
    /// [`Method::Converged`]: the estimated tail of the
    /// inter-reflection series that the explicit bounces left out and the bake added, as a
    /// fraction of the total illuminance ([`crate::series`]); 0 for the paper's method and
    /// without [`Settings::tail`].
    pub tail_fraction: f64,
    /// [`Method::Converged`]: the bounce ratio λ of the last two explicit bounces, which the
    /// tail is extrapolated with when [`Settings::tail`] is on (`None` before a second bounce
    /// or for the paper's method).
    pub bounce_ratio: Option<f64>,
    /// Set-up steps and their wall time, seconds.
    pub setup: Vec<(&'static str, f64)>,
    /// Every executed pass.
    pub passes: Vec<PassTiming>,
    /// What was left out.
    pub skipped: Vec<Skipped>,
    /// Whole bake, seconds.
    pub total_seconds: f64,
}

/// One object's maps, cropped to its region: the eight stages of the paper's Figure 5.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectMaps {
    /// Object index.
    pub object: usize,
    /// Object name.
    pub name: String,
    /// Its region in the texture arrays.
    pub region: Region,
    /// Stages (1)–(8) ([`crate::graph::Figure5::NAMES`]); 5–8 are `None` without bounces.
    pub stages: [Option<MapImage>; 8],
}

static EMPTY: MapImage = MapImage {
    width: 0,
    height: 0,
    texels: Vec::new(),
};

impl ObjectMaps {
    fn stage(&self, i: usize) -> &MapImage {
        self.stages
            .get(i)
            .and_then(Option::as_ref)
            .unwrap_or(&EMPTY)
    }

    /// Final illuminance, lux, before albedo: blurred combined (7), or blurred direct (3)
    /// without bounces.
    pub fn illuminance(&self) -> &MapImage {
        if self.stages[6].is_some() {
            self.stage(6)
        } else {
            self.stage(2)
        }
    }

    /// Final exitance, lm/m², after albedo: (8), or (4) without bounces.
    pub fn exitance(&self) -> &MapImage {
        if self.stages[7].is_some() {
            self.stage(7)
        } else {
            self.stage(3)
        }
    }

    /// Blurred direct illuminance (3), lux. `illuminance − direct` is the indirect part,
    /// blurred the same way (the blur is linear).
    pub fn direct(&self) -> &MapImage {
        self.stage(2)
    }

    /// Unblurred direct illuminance (2), lux.
    pub fn direct_unblurred(&self) -> &MapImage {
        self.stage(1)
    }

    /// Indirect illuminance of the last bounce (5), unblurred, if any.
    pub fn indirect(&self) -> Option<&MapImage> {
        self.stages[4].as_ref()
    }
}

/// The result of a bake.
#[derive(Debug, Clone)]
pub struct BakeOutput {
    /// The settings baked with.
    pub settings: Settings,
    /// The light-map layout.
    pub layout: Layout,
    /// The executed graph.
    pub graph: BakeGraph,
    /// Per receiver, its maps.
    pub maps: Vec<ObjectMaps>,
    /// Lamps used by the direct pass.
    pub lamps_used: Vec<usize>,
    /// Statistics and timings.
    pub report: BakeReport,
}

/// Per lamp and object, how many valid texels the lamp lights (no shadows), and the total.
fn lamp_reach(
    gbuffer: &GBuffer,
    lamps: &[LampParams],
    tables: &[GpuTable],
    objects: usize,
) -> Vec<Vec<u64>> {
    let mut reach = vec![vec![0u64; objects]; lamps.len()];
    for (pos, nrm) in gbuffer
        .position
        .chunks_exact(4)
        .zip(gbuffer.normal.chunks_exact(4))
    {
        if pos[3] <= 0.5 {
            continue;
        }
        let object = nrm[3] as usize;
        let n = [nrm[0], nrm[1], nrm[2]];
        for (l, lamp) in lamps.iter().enumerate() {
            if lamp.scale.iter().all(|&c| c.is_nan() || c <= 0.0) {
                continue;
            }
            let to = [0, 1, 2].map(|c| lamp.position[c] - pos[c]);
            let cos = n[0] * to[0] + n[1] * to[1] + n[2] * to[2];
            if cos.is_nan() || cos <= 0.0 {
                continue;
            }
            let m = &lamp.world_to_photometric;
            let d = [0, 1, 2].map(|r| -(m[r][0] * to[0] + m[r][1] * to[1] + m[r][2] * to[2]));
            let lit = tables
                .get(lamp.table as usize)
                .is_some_and(|tab| tab.sample(d) > 0.0);
            if lit && let Some(slot) = reach[l].get_mut(object) {
                *slot += 1;
            }
        }
    }
    reach
}

/// World size of a light-map texel, `[smallest, largest]` over the receivers, metres.
fn receiver_texel_sizes(scene: &Scene, texels_per_metre: f32) -> [f32; 2] {
    let scales = scene
        .objects
        .iter()
        .filter(|o| o.receiver)
        .map(|o| o.texel_scale)
        .filter(|s| s.is_finite() && *s > 0.0);
    let (lo, hi) = scales.fold((f32::INFINITY, 0.0f32), |(lo, hi), s| {
        (lo.min(s), hi.max(s))
    });
    if hi > 0.0 {
        [1.0 / (texels_per_metre * hi), 1.0 / (texels_per_metre * lo)]
    } else {
        [1.0 / texels_per_metre; 2]
    }
}

/// Sum of RGB over valid texels of `layers` (read-back layers), f64.
fn energy(layers: &[Vec<f32>]) -> f64 {
    layers
        .iter()
        .flat_map(|l| l.chunks_exact(4))
        .filter(|t| t[3] > 0.5)
        .map(|t| f64::from(t[0]) + f64::from(t[1]) + f64::from(t[2]))
        .sum()
}

/// The shift that moves a scene lying far from the world origin next to it, or `None` for a
/// scene around the origin. A light map does not depend on where the room stands, but f32
/// coordinates far out are coarse (1 mm at 10 km), so [`bake`] bakes the scene moved by
/// `−shift`: the centre of the objects' world bounding box (lamps are not geometry), rounded
/// to a multiple of the power of two `g ≥` the box's half-extent, so that moving an f32
/// translation or lamp position by it is exact where the result is near the origin. `None`
/// when no centre coordinate is beyond the half-extent (the box holds the origin, or nearly):
/// such scenes bake exactly as given.
pub fn recentring_shift(scene: &Scene) -> Option<[f64; 3]> {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for o in &scene.objects {
        for p in &o.mesh.positions {
            let w = o.transform.point_f64(p.map(f64::from));
            for c in 0..3 {
                if w[c].is_finite() {
                    lo[c] = lo[c].min(w[c]);
                    hi[c] = hi[c].max(w[c]);
                }
            }
        }
    }
    let half = (0..3).map(|c| 0.5 * (hi[c] - lo[c])).fold(0.0f64, f64::max);
    let centre: [f64; 3] = std::array::from_fn(|c| 0.5 * (hi[c] + lo[c]));
    if !(half.is_finite() && centre.iter().all(|c| c.is_finite()))
        || centre.iter().all(|c| c.abs() <= half)
    {
        return None;
    }
    let g = 2f64.powi(half.max(1e-30).log2().ceil() as i32);
    Some(centre.map(|c| (c / g).round() * g))
}

/// Bakes `scene` with `settings` on `backend` (see the module docs). `settings` replaces
/// `scene.settings` (texel density, rays, bounces, blur, traversal, seed).
pub fn bake<B: GpuBackend>(
    backend: &mut B,
    scene: &Scene,
    settings: &Settings,
    progress: &mut dyn FnMut(&Progress<'_>),
) -> Result<BakeOutput, BakeError<B::Error>> {
    let start = Instant::now();
    settings.validate().map_err(|e| BakeError::InvalidSetting {
        name: e.name,
        reason: e.reason,
    })?;
    let name = backend.name();
    let be = |source| BakeError::Backend {
        backend: name,
        source,
    };
    let local;
    let scene = if &scene.settings == settings {
        scene
    } else {
        local = Scene {
            settings: settings.clone(),
            ..scene.clone()
        };
        &local
    };
    let recentred;
    let scene = match recentring_shift(scene) {
        Some(shift) => {
            recentred = scene.translated(shift.map(|c| -c));
            &recentred
        }
        None => scene,
    };
    let mut setup = Vec::new();
    let mut skipped = Vec::new();
    let limits = backend.limits();

    progress(&Progress::Setup("layout"));
    let t = Instant::now();
    let layout = Layout::new(scene, limits.max_texture_size, limits.max_array_layers)?;
    setup.push(("layout", t.elapsed().as_secs_f64()));
    for (i, o) in scene.objects.iter().enumerate() {
        if layout.regions.get(i).is_none_or(Option::is_none) {
            skipped.push(Skipped::NonReceiver {
                object: i,
                name: o.name.clone(),
            });
        }
    }

    progress(&Progress::Setup("rasterise"));
    let t = Instant::now();
    let mut gbuffer = rasterize(scene, &layout);
    setup.push(("rasterise", t.elapsed().as_secs_f64()));

    progress(&Progress::Setup("bvh"));
    let t = Instant::now();
    let (triangles, attributes) = scene.world_triangles();
    let bvh = Bvh::build(&triangles, &BuildOptions::default())?;
    let encoded = encode(
        &bvh,
        &triangles,
        &attributes,
        &EncodeOptions {
            max_texture_size: limits.max_texture_size,
        },
    )?;
    setup.push(("bvh", t.elapsed().as_secs_f64()));
    let mut bvh_mode = settings.bvh;
    if triangles.len() <= BRUTE_FORCE_MAX_TRIANGLES && bvh_mode != BvhMode::None {
        skipped.push(Skipped::Bvh {
            requested: bvh_mode,
            triangles: triangles.len(),
        });
        bvh_mode = BvhMode::None;
    }

    // The ray offset's size term from the extent of the scene's geometry (not from where the
    // scene or its lamps lie: backend::offset_origin adds the position's own ULPs).
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for v in triangles.iter().flatten() {
        for c in 0..3 {
            if v[c].is_finite() {
                lo[c] = lo[c].min(v[c]);
                hi[c] = hi[c].max(v[c]);
            }
        }
    }
    let half_extent = (0..3)
        .map(|c| 0.5 * (hi[c] - lo[c]))
        .fold(0.0f32, |m, e| if e.is_finite() { m.max(e) } else { m });

    // Texels inside geometry: moved out or made empty, for every backend (crate::validity).
    progress(&Progress::Setup("unocclude"));
    let t = Instant::now();
    validity::unocclude(&mut gbuffer, scene, &encoded, ray_epsilon(half_extent));
    setup.push(("unocclude", t.elapsed().as_secs_f64()));

    // Lamps, their tables, and which of them reach anything.
    let tables: Vec<GpuTable> = scene
        .lamps
        .iter()
        .map(|l| l.photometry.gpu_table_tilted(l.tilt_deg()))
        .collect();
    let lamps: Vec<LampParams> = scene
        .lamps
        .iter()
        .enumerate()
        .map(|(i, l)| LampParams {
            position: l.position.map(|c| c as f32),
            world_to_photometric: l.world_to_photometric_matrix(),
            scale: l.color.map(|c| c * l.multiplier),
            table: i as u32,
        })
        .collect();
    let reach = lamp_reach(&gbuffer, &lamps, &tables, scene.objects.len());
    let mut lamps_used = Vec::new();
    let mut shadow_rays = 0u64;
    for (l, per_object) in reach.iter().enumerate() {
        let total: u64 = per_object.iter().sum();
        if total == 0 {
            skipped.push(Skipped::Lamp {
                lamp: l,
                name: scene.lamps[l].name.clone(),
            });
            continue;
        }
        lamps_used.push(l);
        shadow_rays += total;
        for (o, &count) in per_object.iter().enumerate() {
            if count == 0 && layout.regions.get(o).is_some_and(Option::is_some) {
                skipped.push(Skipped::LampObject {
                    lamp: l,
                    object: o,
                    name: scene.objects[o].name.clone(),
                });
            }
        }
    }

    // The direct pass evaluates the uploaded lamps: only those that light something.
    let used_lamps: Vec<LampParams> = lamps_used.iter().map(|&l| lamps[l]).collect();

    // First-bounce lamp paths, for every backend (crate::lightpaths).
    let paths_off = if settings.method != Method::Converged || settings.lamp_paths == 0 {
        None
    } else if settings.bounces == 0 {
        Some("no bounce")
    } else if settings.stride > 1 {
        Some("the first bounce is gathered at reduced resolution (stride > 1)")
    } else if settings.refine_rays > 0 {
        Some("the first bounce is refined (refine_rays > 0)")
    } else if used_lamps.is_empty() {
        Some("no lamp lights anything")
    } else {
        None
    };
    let with_paths =
        settings.method == Method::Converged && settings.lamp_paths > 0 && paths_off.is_none();
    if let Some(reason) = paths_off {
        skipped.push(Skipped::LampPaths { reason });
    }
    let mut connected = None;
    let mut density_scale = 0.0;
    if with_paths {
        progress(&Progress::Setup("lamp paths"));
        let t = Instant::now();
        let wide = WideBvh::from_encoded(&encoded);
        let geometry = lightpaths::Geometry {
            encoded: &encoded,
            wide: &wide,
            regions: &layout.regions,
            gbuffer: &gbuffer,
            eps: ray_epsilon(half_extent),
        };
        let size = lightpaths::pool_size(gbuffer.valid_texels(), settings.lamp_paths);
        let pool = LampPaths::trace(&geometry, &used_lamps, &tables, size, settings.seed);
        density_scale = pool.density_scale;
        connected =
            Some(pool.connect(&geometry, settings.rays, settings.lamp_paths, settings.seed));
        setup.push(("lamp paths", t.elapsed().as_secs_f64()));
    }

    let mut graph = BakeGraph::build(&GraphConfig {
        layer_size: layout.layer_size,
        layers: layout.layers,
        lamp_count: u32::try_from(lamps_used.len()).unwrap_or(u32::MAX),
        rays: settings.rays,
        bounces: settings.bounces,
        blur: settings.blur,
        seed: settings.seed,
        sampler: settings.sampler,
        bvh: bvh_mode,
        method: settings.method,
        higher_rays: settings.higher_rays,
        stride: settings.stride,
        higher_stride: settings.higher_stride,
        refine: Some((settings.refine_rays, settings.refine_error)),
        texel_size: receiver_texel_sizes(scene, settings.texels_per_metre),
        lamp_paths: if with_paths {
            (settings.lamp_paths, density_scale)
        } else {
            (0, 0.0)
        },
    });
    graph.validate()?;

    progress(&Progress::Setup("upload"));
    let t = Instant::now();
    let textures = graph
        .textures
        .iter()
        .map(|d| backend.create_texture(d))
        .collect::<Result<Vec<_>, _>>()
        .map_err(be)?;
    let gpu_scene = backend
        .upload_scene(&SceneData {
            bvh: &encoded,
            lamps: &used_lamps,
            ies_tables: &tables,
            regions: &layout.regions,
            layer_size: layout.layer_size,
            layers: layout.layers,
            ray_epsilon: ray_epsilon(half_extent),
        })
        .map_err(be)?;
    setup.push(("upload", t.elapsed().as_secs_f64()));

    let layer_floats = 4 * layout.layer_size[0] as usize * layout.layer_size[1] as usize;
    let valid_texels = gbuffer
        .position
        .chunks_exact(4)
        .filter(|p| p[3] > 0.5)
        .count() as u64;
    let read_all = |backend: &mut B, tex: TexId| -> Result<Vec<Vec<f32>>, B::Error> {
        (0..layout.layers)
            .map(|l| backend.read_back(&textures[tex.index()], l))
            .collect()
    };

    let mut passes = Vec::new();
    let mut bounces_run = 0;
    let mut direct_energy = 0.0f64;
    let mut previous_indirect = 0.0f64;
    let mut series = Series::default();
    let count = graph.passes.len();
    let mut index = 0;
    while index < count {
        let pass = &graph.passes[index];
        progress(&Progress::PassStart {
            index,
            count,
            label: pass.label,
            bounce: pass.bounce,
        });
        let t = Instant::now();
        if pass.kind == PassKind::GBuffer {
            let empty = Vec::new();
            let sources = [
                &gbuffer.position,
                &gbuffer.normal,
                &gbuffer.albedo,
                connected.as_ref().unwrap_or(&empty),
            ];
            for (w, src) in pass.writes.iter().zip(sources) {
                for l in 0..layout.layers as usize {
                    let slice = src
                        .get(l * layer_floats..(l + 1) * layer_floats)
                        .unwrap_or(&[]);
                    backend
                        .upload(&textures[w.index()], l as u32, slice)
                        .map_err(be)?;
                }
            }
            progress(&Progress::PassProgress {
                index,
                fraction: 1.0,
            });
        } else if let (Some(program), Some(write)) = (pass.kind.program(), pass.writes.first()) {
            // `graph.validate()` checked the slots, the parameter block and the sizes.
            let reads: Vec<&B::Texture> = pass.reads.iter().map(|r| &textures[r.index()]).collect();
            let params = pass.params.words();
            let plan = TilePlan::new(
                layout.layer_size,
                layout.layers,
                pass.params.work_per_texel(),
                backend.tile_work(),
            );
            let tiles = plan.len();
            for (done, tile) in plan.tiles().enumerate() {
                backend
                    .dispatch(&Dispatch {
                        label: pass.label,
                        program,
                        bvh: pass.bvh,
                        reads: &reads,
                        write: &textures[write.index()],
                        scene: &gpu_scene,
                        params: &params,
                        tile,
                    })
                    .map_err(be)?;
                progress(&Progress::PassProgress {
                    index,
                    fraction: (done as u64 + 1) as f32 / tiles as f32,
                });
            }
            if tiles == 0 {
                progress(&Progress::PassProgress {
                    index,
                    fraction: 1.0,
                });
            }
        }
        let seconds = t.elapsed().as_secs_f64();
        progress(&Progress::PassDone { index, seconds });
        passes.push(PassTiming {
            label: pass.label,
            kind: pass.kind,
            bounce: pass.bounce,
            seconds,
        });
        index += 1;
        if pass.kind == PassKind::Direct && settings.bounces > 0 {
            direct_energy = energy(&read_all(backend, graph.direct).map_err(be)?);
            series.direct = direct_energy;
        }
        let bounce_end = graph
            .bounce_passes
            .iter()
            .position(|&(_, end)| end == index);
        // Converged method: after each bounce, the increment's energy decides whether to stop;
        // then the tail factor is set and the finishing passes run.
        if let (Some(k), Some(delta)) = (bounce_end, graph.delta) {
            let k = k as u32 + 1;
            bounces_run = k;
            series
                .increments
                .push(energy(&read_all(backend, delta).map_err(be)?));
            let last = k as usize == graph.bounce_passes.len();
            if last || (settings.tail && series.converged(f64::from(settings.tail_tolerance))) {
                if !last {
                    skipped.push(Skipped::Bounces {
                        from: k + 1,
                        to: settings.bounces,
                        added: series.tail_fraction() as f32,
                    });
                }
                if let Some(tail) = graph.tail_pass {
                    graph.passes[tail].params = Params::Combine(CombineParams {
                        b_weight: if settings.tail {
                            series.tail_factor() as f32
                        } else {
                            0.0
                        },
                        ..CombineParams::SUM
                    });
                    // The running sum of the last bounce run (two textures alternate).
                    if let Some(&sum) = graph.sum_after.get(k as usize - 1) {
                        graph.passes[tail].reads[0] = sum;
                    }
                }
                index = graph.finish_passes.0;
            }
            continue;
        }
        // Paper method: end of a bounce: measure what it added and stop when it is negligible.
        if let Some(k) = bounce_end {
            let k = k as u32 + 1;
            bounces_run = k;
            let indirect_tex = graph.figure5.stages[4].unwrap_or(graph.direct);
            let e = energy(&read_all(backend, indirect_tex).map_err(be)?);
            let total = direct_energy + e;
            let added = if total > 0.0 {
                ((e - previous_indirect) / total) as f32
            } else {
                0.0
            };
            previous_indirect = e;
            if k < settings.bounces && added.abs() < BOUNCE_ENERGY_THRESHOLD {
                skipped.push(Skipped::Bounces {
                    from: k + 1,
                    to: settings.bounces,
                    added,
                });
                break;
            }
        }
    }

    progress(&Progress::Setup("read back"));
    let t = Instant::now();
    // One stage at a time: its layers read back, every object's region cropped (in
    // parallel), the layers dropped before the next stage's are read.
    let mut stages: Vec<[Option<MapImage>; 8]> = vec![Default::default(); layout.regions.len()];
    for (i, stage) in graph.figure5.stages.iter().enumerate() {
        let Some(tex) = stage else { continue };
        let layers = read_all(backend, *tex).map_err(be)?;
        let crops: Vec<Option<MapImage>> = layout
            .regions
            .par_iter()
            .map(|r| r.as_ref().map(|r| crop(&layers, layout.layer_size, r)))
            .collect();
        for (object, map) in stages.iter_mut().zip(crops) {
            object[i] = map;
        }
    }
    let mut maps = Vec::new();
    for ((o, region), stages) in layout.regions.iter().enumerate().zip(stages) {
        let Some(region) = region else { continue };
        maps.push(ObjectMaps {
            object: o,
            name: scene
                .objects
                .get(o)
                .map(|ob| ob.name.clone())
                .unwrap_or_default(),
            region: *region,
            stages,
        });
    }
    setup.push(("read back", t.elapsed().as_secs_f64()));

    let report = BakeReport {
        backend: name,
        texels: valid_texels,
        region_texels: layout.texel_count(),
        triangles: triangles.len(),
        shadow_rays,
        gather_rays: valid_texels
            * match (settings.method, bounces_run) {
                (Method::Paper, k) => u64::from(settings.rays) * u64::from(k),
                (Method::Converged, 0) => 0,
                // Nominal: grid texels × rays (orphans and refinement rays not counted).
                (Method::Converged, k) => {
                    let per =
                        |rays: u32, stride: u32| u64::from(rays) / u64::from(stride.max(1)).pow(2);
                    per(settings.rays, settings.stride)
                        + per(settings.higher_rays, settings.higher_stride) * u64::from(k - 1)
                }
            },
        tail_fraction: if graph.delta.is_some() && settings.tail {
            series.tail_fraction()
        } else {
            0.0
        },
        bounce_ratio: graph.delta.and(series.ratio()),
        bvh: bvh_mode,
        bounces_run,
        setup,
        passes,
        skipped,
        total_seconds: start.elapsed().as_secs_f64(),
    };
    Ok(BakeOutput {
        settings: settings.clone(),
        layout,
        graph,
        maps,
        lamps_used,
        report,
    })
}

/// Copies `region` out of read-back layers.
fn crop(layers: &[Vec<f32>], layer_size: [u32; 2], region: &Region) -> MapImage {
    let mut m = MapImage::zeros(region.size[0], region.size[1]);
    let Some(layer) = layers.get(region.layer as usize) else {
        return m;
    };
    let w = region.size[0] as usize;
    for y in 0..region.size[1] as usize {
        let src = 4
            * ((region.offset[1] as usize + y) * layer_size[0] as usize
                + region.offset[0] as usize);
        let dst = 4 * y * w;
        if let (Some(s), Some(d)) = (
            layer.get(src..src + 4 * w),
            m.texels.get_mut(dst..dst + 4 * w),
        ) {
            d.copy_from_slice(s);
        }
    }
    m
}
