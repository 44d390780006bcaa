//! The host work of a bake, as typed nodes: what runs on the CPU for every backend before the
//! first pass, and what each step depends on.
//!
//! A bake is *prepare → build → execute → collect* ([`crate::bake()`]). Preparing has two
//! parts, split by what they depend on ([`HostNode::depends`]):
//!
//! ```text
//!   Room::prepare (the scene and its texel density; not the lamps)
//!     recentre → layout → rasterise → BVH build (once) → unocclude
//!   Lamps::prepare (the room and the lamps)
//!     lamp tables → lamp reach
//!   Lamps::trace_paths, once the direct pass has run (the direct light comes first)
//!     lamp paths (the pool traced once; the backend connects every texel to it, pass
//!     `connect`)
//! ```
//!
//! A [`Room`] holds everything that does not depend on the lamps: the layout, the G-buffer
//! after unocclusion and the BVH, built once and shared by the host steps and the CPU backend
//! ([`SceneBvh`]). A lamp change needs only [`Lamps::prepare`] and the passes that depend on
//! the lamps ([`crate::graph::PassDesc::lamps`]): [`crate::bake_room`] takes the lamps apart from
//! the room.

use luxbake_bvh::{BuildOptions, Bvh, BvhError, EncodeOptions, encode};
use luxbake_ies::GpuTable;
use rayon::prelude::*;
// `web_time::Instant` is `std::time::Instant` natively and `performance.now()` on wasm32.
use web_time::Instant;

pub use crate::backend::SceneBvh;
use crate::backend::{LampParams, Limits, ray_epsilon};
use crate::gbuffer::{GBuffer, rasterize};
use crate::layout::{Layout, LayoutError};
use crate::lightpaths::{self, LampPaths};
use crate::opening::{self, OpeningParams};
use crate::report::{LampModelChoice, Progress, Skipped};
use crate::scene::{Lamp, LampModel, Method, Scene, SettingError, Settings};
use crate::validity;

/// What a node of the bake depends on: when none of it changed, its result can be reused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Deps {
    /// The room: geometry, materials, object placement.
    pub scene: bool,
    /// The lamps: photometry, position, orientation, multiplier, colour.
    pub lamps: bool,
    /// The settings it reads (scene-file `[settings]` keys).
    pub settings: &'static [&'static str],
}

/// A step of host work (CPU, every backend), in the order a bake runs them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum HostNode {
    /// Moves a scene that lies far from the origin next to it ([`recentring_shift`]).
    Recentre,
    /// Places each receiver's light map in the texture arrays ([`Layout`]).
    Layout,
    /// The G-buffer: position, normal, albedo per texel ([`rasterize`]).
    Rasterise,
    /// The BVH: built, encoded for the GPU and collapsed to the CPU's 8-wide form, once.
    Bvh,
    /// Texels inside geometry moved out or emptied ([`validity::unocclude`]).
    Unocclude,
    /// Each lamp's table, its parameters and which texels it can reach unshadowed.
    LampReach,
    /// The first bounce's lamp paths: the pool traced ([`lightpaths`]; the `connect` pass
    /// joins every texel to it on the backend).
    LampPaths,
}

impl HostNode {
    /// Every host node, in execution order.
    pub const ALL: [HostNode; 7] = [
        HostNode::Recentre,
        HostNode::Layout,
        HostNode::Rasterise,
        HostNode::Bvh,
        HostNode::Unocclude,
        HostNode::LampReach,
        HostNode::LampPaths,
    ];

    /// Its label in progress reports and timings.
    pub fn label(self) -> &'static str {
        match self {
            HostNode::Recentre => "recentre",
            HostNode::Layout => "layout",
            HostNode::Rasterise => "rasterise",
            HostNode::Bvh => "bvh",
            HostNode::Unocclude => "unocclude",
            HostNode::LampReach => "lamp reach",
            HostNode::LampPaths => "lamp paths",
        }
    }

    /// What it depends on.
    pub fn depends(self) -> Deps {
        const DENSITY: &[&str] = &["texels_per_metre"];
        let room = |settings| Deps {
            scene: true,
            lamps: false,
            settings,
        };
        match self {
            HostNode::Recentre | HostNode::Bvh => room(&[]),
            HostNode::Layout | HostNode::Rasterise | HostNode::Unocclude => room(DENSITY),
            HostNode::LampReach => Deps {
                scene: true,
                lamps: true,
                settings: DENSITY,
            },
            HostNode::LampPaths => Deps {
                scene: true,
                lamps: true,
                settings: &[
                    "texels_per_metre",
                    "method",
                    "bounces",
                    "rays",
                    "stride",
                    "lamp_paths",
                    "seed",
                ],
            },
        }
    }
}

/// What can stop the host work.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PrepareError {
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
    /// The room was prepared for another texel density or backend limits than asked for.
    #[error("the room was prepared for {prepared}, the bake asks for {asked}")]
    Mismatch {
        /// What the room was prepared for.
        prepared: String,
        /// What the bake asked for.
        asked: String,
    },
}

impl From<SettingError> for PrepareError {
    fn from(e: SettingError) -> Self {
        PrepareError::InvalidSetting {
            name: e.name,
            reason: e.reason,
        }
    }
}

/// A room prepared for baking: the host work that does not depend on the lamps.
#[derive(Debug, Clone)]
pub struct Room {
    /// The scene as baked: recentred ([`Room::shift`]), with the settings it was prepared with.
    pub scene: Scene,
    /// The scene was moved by `−shift` ([`recentring_shift`]); lamps are moved by the same.
    pub shift: Option<[f64; 3]>,
    /// The backend limits the layout was made for.
    pub limits: Limits,
    /// The light-map layout.
    pub layout: Layout,
    /// The G-buffer, after unocclusion.
    pub gbuffer: GBuffer,
    /// The BVH.
    pub bvh: SceneBvh,
    /// Triangles in the scene.
    pub triangles: usize,
    /// The ray offset's size term ([`ray_epsilon`]).
    pub ray_epsilon: f32,
    /// Half the largest side of the bounding box of the scene's geometry, metres.
    pub half_extent: f32,
    /// Valid light-map texels.
    pub valid_texels: u64,
    /// Of those, the texels in narrow gaps against the room ([`crate::validity::NARROW_GAP`]).
    pub narrow_texels: u64,
    /// Objects left without a light map ([`Skipped::NonReceiver`]).
    pub skipped: Vec<Skipped>,
    /// Host steps and their wall time, seconds.
    pub timings: Vec<(&'static str, f64)>,
}

/// Runs `f` as host node `node`: reports it, times it into `timings`.
fn timed<T>(
    node: HostNode,
    timings: &mut Vec<(&'static str, f64)>,
    progress: &mut dyn FnMut(&Progress<'_>),
    f: impl FnOnce() -> T,
) -> T {
    progress(&Progress::Setup(node.label()));
    let t = Instant::now();
    let out = f();
    timings.push((node.label(), t.elapsed().as_secs_f64()));
    out
}

impl Room {
    /// Runs the room's host nodes for `scene` baked with `settings` (which replace
    /// `scene.settings`) on a backend with `limits`.
    pub fn prepare(
        scene: &Scene,
        settings: &Settings,
        limits: Limits,
        progress: &mut dyn FnMut(&Progress<'_>),
    ) -> Result<Room, PrepareError> {
        settings.validate()?;
        let mut scene = Scene {
            settings: settings.clone(),
            ..scene.clone()
        };
        // Not timed: moving the scene is cheap and only far from the origin does anything.
        let shift = recentring_shift(&scene);
        if let Some(shift) = shift {
            scene.translate(shift.map(|c| -c));
        }
        let mut timings = Vec::new();
        let layout = timed(HostNode::Layout, &mut timings, progress, || {
            Layout::new(&scene, limits.max_texture_size, limits.max_array_layers)
        })?;
        let skipped = scene
            .objects
            .iter()
            .enumerate()
            .filter(|(i, _)| layout.regions.get(*i).is_none_or(Option::is_none))
            .map(|(i, o)| Skipped::NonReceiver {
                object: i,
                name: o.name.clone(),
            })
            .collect();
        let mut gbuffer = timed(HostNode::Rasterise, &mut timings, progress, || {
            rasterize(&scene, &layout)
        });
        let (bvh, triangles, half_extent) = timed(HostNode::Bvh, &mut timings, progress, || {
            let (triangles, attributes) = scene.world_triangles();
            let bvh = Bvh::build(&triangles, &BuildOptions::default())?;
            let options = EncodeOptions {
                max_texture_size: limits.max_texture_size,
            };
            let encoded = encode(&bvh, &triangles, &attributes, &options)?;
            Ok::<_, BvhError>((
                SceneBvh::new(encoded),
                triangles.len(),
                half_extent(&triangles),
            ))
        })?;
        // The ray offset's size term from the extent of the scene's geometry (not from where
        // the scene or its lamps lie: backend::offset_origin adds the position's own ULPs).
        let eps = ray_epsilon(half_extent);
        let unoccluded = timed(HostNode::Unocclude, &mut timings, progress, || {
            validity::unocclude(&mut gbuffer, &scene, &bvh, eps)
        });
        let valid_texels = gbuffer.valid_texels();
        Ok(Room {
            scene,
            shift,
            limits,
            layout,
            gbuffer,
            bvh,
            triangles,
            ray_epsilon: eps,
            half_extent,
            valid_texels,
            narrow_texels: unoccluded.gaps,
            skipped,
            timings,
        })
    }

    /// Checks that this room was prepared for `settings` and `limits`: the texel density
    /// (the only setting the room's nodes read) and the backend's texture limits.
    pub fn check(&self, settings: &Settings, limits: Limits) -> Result<(), PrepareError> {
        let density = self.scene.settings.texels_per_metre;
        if density.to_bits() != settings.texels_per_metre.to_bits() {
            return Err(PrepareError::Mismatch {
                prepared: format!("{density} texels per metre"),
                asked: format!("{}", settings.texels_per_metre),
            });
        }
        if self.limits != limits {
            return Err(PrepareError::Mismatch {
                prepared: format!("{:?}", self.limits),
                asked: format!("{limits:?}"),
            });
        }
        Ok(())
    }

    /// `lamps` (in the scene's world frame) as this room bakes them: moved like the room.
    pub fn place_lamps(&self, lamps: &[Lamp]) -> Vec<Lamp> {
        let mut lamps = lamps.to_vec();
        if let Some(shift) = self.shift {
            for l in &mut lamps {
                // As `Scene::translate(−shift)` moves them, bit for bit.
                l.position = [0, 1, 2].map(|c| l.position[c] + -shift[c]);
            }
        }
        lamps
    }

    /// World size of a light-map texel, `[smallest, largest]` over the receivers, metres.
    pub fn texel_sizes(&self) -> [f32; 2] {
        let texels_per_metre = self.scene.settings.texels_per_metre;
        let scales = self
            .scene
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

    fn geometry(&self) -> lightpaths::Geometry<'_> {
        lightpaths::Geometry {
            encoded: &self.bvh.encoded,
            wide: &self.bvh.wide,
            regions: &self.layout.regions,
            gbuffer: &self.gbuffer,
            eps: self.ray_epsilon,
        }
    }
}

/// The largest half-size of the finite extent of `triangles`' vertices.
fn half_extent(triangles: &[[[f32; 3]; 3]]) -> f32 {
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
    (0..3)
        .map(|c| 0.5 * (hi[c] - lo[c]))
        .fold(0.0f32, |m, e| if e.is_finite() { m.max(e) } else { m })
}

/// The lamps prepared for a room: the host work that depends on the lamps.
#[derive(Debug, Clone)]
pub struct Lamps {
    /// One intensity table per lamp of the scene (tilt applied).
    pub tables: Vec<GpuTable>,
    /// Indices of the lamps that light some texel, in order: the direct pass's lamps.
    pub used: Vec<usize>,
    /// The parameters of the used lamps, in order (their `table` indexes [`Lamps::tables`]).
    pub params: Vec<LampParams>,
    /// Shadow rays the direct pass casts: valid texels each used lamp faces.
    pub shadow_rays: u64,
    /// Whether the bake connects its texels to lamp paths ([`lightpaths`]): the pool is then
    /// traced by [`Lamps::trace_paths`], after the direct light (it is the first bounce's
    /// work, and the direct light is shown first).
    pub paths_wanted: bool,
    /// The lamp paths' pool once traced on the host ([`Lamps::trace_paths`]): its points
    /// packed for the scene upload ([`LampPaths::packed`]) and its
    /// [`density_scale`](LampPaths::density_scale); the backend connects every texel to them
    /// (`connect`).
    pub paths: Option<(Vec<f32>, f32)>,
    /// Lamps that light nothing or miss receivers, and lamp paths left out.
    pub skipped: Vec<Skipped>,
    /// The model each lamp of the scene got, and why ([`LampModel`]).
    pub models: Vec<LampModelChoice>,
    /// Host steps and their wall time, seconds.
    pub timings: Vec<(&'static str, f64)>,
}

impl Lamps {
    /// The used lamps' peak intensities, each weighted by the luminance of its colour and
    /// multiplier, summed: candela, the illuminance in lux they could give at 1 m (what
    /// [`crate::program::luminance_scale_for`] sizes the denoiser's arithmetic by).
    pub fn peak_candela(&self) -> f64 {
        self.params
            .iter()
            .map(|l| {
                let peak = self
                    .tables
                    .get(l.table as usize)
                    .map_or(0.0, |t| t.values.iter().fold(0.0f32, |m, &v| m.max(v)));
                f64::from(crate::exact::luminance(l.scale)) * f64::from(peak)
            })
            .sum()
    }

    /// Runs the lamps' host nodes for `lamps` (already placed in the room,
    /// [`Room::place_lamps`]) and `settings`.
    pub fn prepare(room: &Room, lamps: &[Lamp], settings: &Settings) -> Lamps {
        let timings = Vec::new();
        let mut skipped = Vec::new();
        // Not timed: evaluating each lamp once per valid texel, without rays, is cheap (about
        // 33 ms on one core, 17 ms on two for `chairs_05` at 64 texels/m).
        let tables: Vec<GpuTable> = lamps
            .iter()
            .map(|l| l.photometry.gpu_table_tilted(l.tilt_deg()))
            .collect();
        let models = lamp_models(&room.gbuffer, lamps);
        let all: Vec<LampParams> = lamps
            .iter()
            .zip(&models)
            .enumerate()
            .map(|(i, (l, (_, opening)))| LampParams {
                position: l.position.map(|c| c as f32),
                world_to_photometric: l.world_to_photometric_matrix(),
                scale: l.color.map(|c| c * l.multiplier),
                table: i as u32,
                opening: *opening,
            })
            .collect();
        let models = models.into_iter().map(|(choice, _)| choice).collect();
        let (reach, near) = lamp_reach(
            &room.gbuffer,
            &all,
            &tables,
            room.scene.objects.len(),
            settings.opening_samples,
        );
        let mut used = Vec::new();
        let mut shadow_rays = 0u64;
        for (l, per_object) in reach.iter().enumerate() {
            let total: u64 = per_object.iter().sum();
            if total == 0 {
                skipped.push(Skipped::Lamp {
                    lamp: l,
                    name: lamps[l].name.clone(),
                });
                continue;
            }
            used.push(l);
            // A texel near an opening casts a shadow ray per opening sample.
            shadow_rays += total + near[l];
            for (o, &count) in per_object.iter().enumerate() {
                if count == 0 && room.layout.regions.get(o).is_some_and(Option::is_some) {
                    skipped.push(Skipped::LampObject {
                        lamp: l,
                        object: o,
                        name: room.scene.objects[o].name.clone(),
                    });
                }
            }
        }
        let params: Vec<LampParams> = used.iter().map(|&l| all[l]).collect();
        let paths_wanted = match lamp_paths_wanted(settings, params.is_empty()) {
            Err(reason) => {
                skipped.push(Skipped::LampPaths { reason });
                false
            }
            Ok(wanted) => wanted,
        };
        Lamps {
            tables,
            used,
            params,
            shadow_rays,
            paths_wanted,
            paths: None,
            skipped,
            models,
            timings,
        }
    }

    /// Traces the lamp paths' pool ([`HostNode::LampPaths`], timed into
    /// [`Lamps::timings`]) when the bake wants one ([`Lamps::paths_wanted`]) and it is not
    /// traced yet; the same pool whenever it runs (its draws depend on the seed only).
    /// `report` gets the fraction traced as it goes ([`LampPaths::trace_reporting`]).
    /// Whether it traced it now (the scene then needs it uploaded).
    pub fn trace_paths(
        &mut self,
        room: &Room,
        settings: &Settings,
        progress: &mut dyn FnMut(&Progress<'_>),
        report: &mut dyn FnMut(f32),
    ) -> bool {
        if !self.paths_wanted || self.paths.is_some() {
            return false;
        }
        let Lamps {
            params,
            tables,
            timings,
            ..
        } = self;
        let traced = timed(HostNode::LampPaths, timings, progress, || {
            let geometry = room.geometry();
            let size = lightpaths::pool_size(room.valid_texels, settings.lamp_paths);
            let pool =
                LampPaths::trace_reporting(&geometry, params, tables, size, settings.seed, report);
            (pool.packed(), pool.density_scale)
        });
        self.paths = Some(traced);
        true
    }

    /// Rays the lamp paths' pool still to trace casts, about ([`lightpaths::pool_rays`]; 0
    /// when it is traced or not wanted): its share of a bake's progress.
    pub fn pool_rays(&self, room: &Room, settings: &Settings) -> f64 {
        if !self.paths_wanted || self.paths.is_some() {
            return 0.0;
        }
        let size = lightpaths::pool_size(room.valid_texels, settings.lamp_paths);
        lightpaths::pool_rays(size, &self.params)
    }

    /// Points in the traced pool and its density scale (`None` before
    /// [`Lamps::trace_paths`] or without lamp paths).
    pub fn pool(&self) -> Option<(u32, f32)> {
        self.paths.as_ref().map(|(packed, scale)| {
            let count = packed.len() / (4 * crate::backend::LAMP_PATH_TEXELS);
            (u32::try_from(count).unwrap_or(u32::MAX), *scale)
        })
    }
}

/// Each lamp's model ([`LampModel`]): the report's choice, and the opening its parameters
/// carry (`None`: a point).
fn lamp_models(gbuffer: &GBuffer, lamps: &[Lamp]) -> Vec<(LampModelChoice, Option<OpeningParams>)> {
    lamps
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let choice = |opening: Option<OpeningParams>, reason: String| {
                let near_m = opening.map(|o| f64::from(o.near));
                let c = LampModelChoice {
                    lamp: i,
                    name: l.name.clone(),
                    requested: l.model,
                    area: opening.is_some(),
                    reason,
                    near_m: near_m.filter(|d| *d < f64::from(f32::MAX)),
                };
                (c, opening)
            };
            if l.model == LampModel::Point {
                return choice(None, "lamp_model = \"point\"".into());
            }
            let Some(emitter) = l.photometry.emitter() else {
                return choice(
                    None,
                    "its file gives no luminous opening (all sizes 0)".into(),
                );
            };
            if l.model == LampModel::Area {
                return choice(
                    OpeningParams::new(&emitter, f32::MAX),
                    "lamp_model = \"area\"".into(),
                );
            }
            let d1 = emitter.point_model_distance(LampModel::AUTO_TOLERANCE);
            let pct = LampModel::AUTO_TOLERANCE * 100.0;
            if let Some(nearest) = nearest_lit_within(gbuffer, l, d1) {
                let near = (d1 * LampModel::SWITCH_FACTOR) as f32;
                choice(
                    OpeningParams::new(&emitter, near),
                    format!(
                        "auto: a receiver {nearest:.3} m from its centre, nearer than {d1:.3} m, \
                         within which the point model is off by more than {pct} %"
                    ),
                )
            } else {
                choice(
                    None,
                    format!(
                        "auto: no receiver it lights is nearer its centre than {d1:.3} m, \
                         beyond which the point model is within {pct} %"
                    ),
                )
            }
        })
        .collect()
}

/// The distance from `lamp`'s centre to the nearest valid texel within `limit` metres that it
/// sends light toward (its intensity toward the texel is positive: a downlight's ceiling does
/// not count), or `None`. Only texels within `limit` are looked up in the intensity table.
fn nearest_lit_within(gbuffer: &GBuffer, lamp: &Lamp, limit: f64) -> Option<f64> {
    let m = lamp.world_to_photometric_matrix();
    let photometry = &lamp.photometry;
    let limit2 = limit * limit;
    gbuffer
        .position
        .chunks_exact(4)
        .filter(|p| p[3] > 0.5)
        .filter_map(|p| {
            let to = [0, 1, 2].map(|c| f64::from(p[c]) - lamp.position[c]);
            let d2 = to[0] * to[0] + to[1] * to[1] + to[2] * to[2];
            // A NaN position fails too.
            if d2.partial_cmp(&limit2) != Some(std::cmp::Ordering::Less) {
                return None;
            }
            let dir = m.map(|r| (0..3).map(|c| f64::from(r[c]) * to[c]).sum::<f64>());
            (photometry.intensity(dir) > 0.0).then(|| d2.sqrt())
        })
        .reduce(f64::min)
}

/// Whether the bake traces lamp paths: `Ok(false)` when it was not asked to, `Err(reason)`
/// when it was asked to but cannot combine them with the first bounce.
fn lamp_paths_wanted(settings: &Settings, no_lamp: bool) -> Result<bool, &'static str> {
    if settings.method != Method::Converged || settings.lamp_paths == 0 {
        return Ok(false);
    }
    if settings.bounces == 0 {
        Err("no bounce")
    } else if settings.stride > 1 {
        Err("the first bounce is gathered at reduced resolution (stride > 1)")
    } else if no_lamp {
        Err("no lamp lights anything")
    } else {
        Ok(true)
    }
}

/// Per lamp and object, how many valid texels the lamp lights (no shadows), and per lamp how
/// many shadow rays more than one per texel the texels near its opening cast
/// ([`OpeningParams::near`], [`opening::texel_samples`] of `samples`).
fn lamp_reach(
    gbuffer: &GBuffer,
    lamps: &[LampParams],
    tables: &[GpuTable],
    objects: usize,
    samples: u32,
) -> (Vec<Vec<u64>>, Vec<u64>) {
    // Counts per chunk of texels, on every core, then added (integers: the order does not
    // matter).
    let empty = || {
        (
            vec![vec![0u64; objects]; lamps.len()],
            vec![0u64; lamps.len()],
        )
    };
    let add = |(mut reach, mut near): (Vec<Vec<u64>>, Vec<u64>),
               (r, n): (Vec<Vec<u64>>, Vec<u64>)| {
        for (a, b) in reach.iter_mut().zip(r) {
            for (a, b) in a.iter_mut().zip(b) {
                *a += b;
            }
        }
        for (a, b) in near.iter_mut().zip(n) {
            *a += b;
        }
        (reach, near)
    };
    let (reach, near_count) = gbuffer
        .position
        .par_chunks(4 * 4096)
        .zip(gbuffer.normal.par_chunks(4 * 4096))
        .map(|(position, normal)| {
            let (mut reach, mut near_count) = empty();
            for (pos, nrm) in position.chunks_exact(4).zip(normal.chunks_exact(4)) {
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
                    // Near an opening the light comes from its whole surface, which a texel
                    // may see while it faces away from the centre: counted, the shadow rays
                    // tell.
                    let d = (to[0] * to[0] + to[1] * to[1] + to[2] * to[2]).sqrt();
                    if let Some(o) = lamp.opening.filter(|o| d < o.near) {
                        near_count[l] += u64::from(opening::texel_samples(&o, d, samples)) - 1;
                        if let Some(slot) = reach[l].get_mut(object) {
                            *slot += 1;
                        }
                        continue;
                    }
                    let cos = n[0] * to[0] + n[1] * to[1] + n[2] * to[2];
                    if cos.is_nan() || cos <= 0.0 {
                        continue;
                    }
                    let m = &lamp.world_to_photometric;
                    let d =
                        [0, 1, 2].map(|r| -(m[r][0] * to[0] + m[r][1] * to[1] + m[r][2] * to[2]));
                    let lit = tables
                        .get(lamp.table as usize)
                        .is_some_and(|tab| tab.sample(d) > 0.0);
                    if lit && let Some(slot) = reach[l].get_mut(object) {
                        *slot += 1;
                    }
                }
            }
            (reach, near_count)
        })
        .reduce(empty, add);
    (reach, near_count)
}

/// The shift that moves a scene lying far from the world origin next to it, or `None` for a
/// scene around the origin. A light map does not depend on where the room stands, but f32
/// coordinates far out are coarse (1 mm at 10 km), so [`crate::bake()`] bakes the scene moved by
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_lamp_nodes_depend_on_the_lamps() {
        for node in HostNode::ALL {
            let d = node.depends();
            assert!(d.scene, "{node:?}");
            assert_eq!(
                d.lamps,
                matches!(node, HostNode::LampReach | HostNode::LampPaths),
                "{node:?}"
            );
        }
        let labels: std::collections::HashSet<_> =
            HostNode::ALL.iter().map(|n| n.label()).collect();
        assert_eq!(labels.len(), HostNode::ALL.len(), "labels are unique");
    }
}
