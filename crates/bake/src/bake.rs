//! The bake driver: prepare → build → execute → collect.
//!
//! - **prepare**: the room's host work ([`Room::prepare`]: layout, G-buffer, one BVH build,
//!   unocclusion) and the lamps' ([`crate::prepare::Lamps`]: tables, reach, lamp paths);
//! - **build**: the [`BakeGraph`] of the passes for that layout and those lamps;
//! - **execute**: the passes on a backend, with the decisions the graph declares
//!   ([`crate::graph::Check`]);
//! - **collect**: the maps read back and cropped per object.
//!
//! [`bake()`] does all four; [`bake_room`] bakes a prepared room under other lamps without
//! repeating the room's work.
//!
//! # Modelling only what the scene requires
//! - **Lamps**: before the direct pass, every lamp is evaluated (without shadow rays) at every
//!   valid texel on the CPU: a lamp that faces no texel with a non-zero intensity (it is behind
//!   every receiving surface, turned away, or has a zero multiplier, colour or table) is left out
//!   of the direct pass. A lamp that reaches some receivers but not others is reported per
//!   object.
//! - **Bounces**: after bounce `k` the backend sums the indirect map (two reduction passes,
//!   [`crate::passes::energy`]; 16 bytes per layer read back) and the driver computes the
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

// `web_time::Instant` is `std::time::Instant` natively and `performance.now()` on wasm32, where
// std's clock panics (the bake runs in a browser in `luxbake-viewer`).
use web_time::Instant;

use crate::backend::GpuBackend;
use crate::execute;
pub use crate::execute::BOUNCE_ENERGY_THRESHOLD;
use crate::graph::{BakeGraph, GraphConfig, GraphError};
use crate::prepare::{Lamps, PrepareError};
pub use crate::prepare::{Room, recentring_shift};
pub use crate::report::{
    BakeOutput, BakeReport, DirectStage, ObjectMaps, OnDirect, PassTiming, Progress, ReadBack,
    Skipped,
};
use crate::scene::{BvhMode, Lamp, Method, Scene, Settings};

/// Scenes with at most this many triangles are traced by brute force.
pub const BRUTE_FORCE_MAX_TRIANGLES: usize = 8;

/// Everything that can stop a bake.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BakeError<E: std::error::Error + 'static> {
    /// The host work could not be done: a setting out of range, light maps that do not fit
    /// the backend's textures, a BVH that cannot be built, or (for [`bake_room`]) a room
    /// prepared for another texel density or backend.
    #[error(transparent)]
    Prepare(#[from] PrepareError),
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

/// Bakes `scene` with `settings` on `backend` (see the module docs). `settings` replaces
/// `scene.settings` (texel density, rays, bounces, blur, traversal, seed).
///
/// Prepare → build → execute → collect: [`Room::prepare`] runs the room's host work,
/// [`bake_room`] the rest. To bake one room under several lamps, prepare it once and call
/// [`bake_room`] for each.
pub fn bake<B: GpuBackend>(
    backend: &mut B,
    scene: &Scene,
    settings: &Settings,
    progress: &mut dyn FnMut(&Progress<'_>),
) -> Result<BakeOutput, BakeError<B::Error>> {
    let start = Instant::now();
    let room = Room::prepare(scene, settings, backend.limits(), progress)?;
    let mut out = bake_room(backend, &room, &scene.lamps, settings, progress)?;
    out.count_preparation(&room.timings, start);
    Ok(out)
}

/// Bakes the prepared `room` lit by `lamps` (world positions, as in the scene) with
/// `settings` on `backend`: only the work that depends on the lamps and the passes run. The
/// room must have been prepared with the same texel density and the backend's limits.
pub fn bake_room<B: GpuBackend>(
    backend: &mut B,
    room: &Room,
    lamps: &[Lamp],
    settings: &Settings,
    progress: &mut dyn FnMut(&Progress<'_>),
) -> Result<BakeOutput, BakeError<B::Error>> {
    bake_room_reading(
        backend,
        room,
        lamps,
        settings,
        ReadBack::ALL,
        progress,
        None,
    )
}

/// [`bake_room`], handing the direct light to `direct` as soon as it exists: per receiver,
/// [`ObjectMaps`] with only the blurred direct illuminance (Figure 5 stage 3, which
/// [`ObjectMaps::illuminance`] and [`ObjectMaps::direct`] return), before the bounces run,
/// with [`DirectStage::Direct`]. It costs one read-back of one map. In the converged method,
/// when a lamp bakes its luminous opening, a preview comes first ([`DirectStage::Preview`]:
/// every lamp a point, one shadow ray a texel, before the opening's direct pass): one more
/// direct pass without openings and one more read-back.
pub fn bake_room_direct_first<B: GpuBackend>(
    backend: &mut B,
    room: &Room,
    lamps: &[Lamp],
    settings: &Settings,
    progress: &mut dyn FnMut(&Progress<'_>),
    direct: OnDirect<'_>,
) -> Result<BakeOutput, BakeError<B::Error>> {
    bake_room_reading(
        backend,
        room,
        lamps,
        settings,
        ReadBack::ALL,
        progress,
        Some(direct),
    )
}

/// [`bake_room`] reading back only the stages `read_back` names, and with `direct`, handing
/// the direct light to it as soon as it exists ([`bake_room_direct_first`]).
pub fn bake_room_reading<B: GpuBackend>(
    backend: &mut B,
    room: &Room,
    lamps: &[Lamp],
    settings: &Settings,
    read_back: ReadBack,
    progress: &mut dyn FnMut(&Progress<'_>),
    direct: Option<OnDirect<'_>>,
) -> Result<BakeOutput, BakeError<B::Error>> {
    let start = Instant::now();
    let name = backend.name();
    let be = |source| BakeError::Backend {
        backend: name,
        source,
    };
    settings.validate().map_err(PrepareError::from)?;
    let limits = backend.limits();
    room.check(settings, limits)?;
    let mut lamps = Lamps::prepare(room, &room.place_lamps(lamps), settings);

    // Build: the graph of the passes, for this room's layout and these lamps.
    let mut skipped = room.skipped.clone();
    let mut bvh = settings.bvh;
    if room.triangles <= BRUTE_FORCE_MAX_TRIANGLES && bvh != BvhMode::None {
        skipped.push(Skipped::Bvh {
            requested: bvh,
            triangles: room.triangles,
        });
        bvh = BvhMode::None;
    }
    skipped.extend(lamps.skipped.iter().cloned());
    skipped.extend(Skipped::loop_limit(settings, &limits));
    let (gather_chunk, direct_chunk) = limits.loop_chunks();
    let graph = BakeGraph::build(&GraphConfig {
        layer_size: room.layout.layer_size,
        layers: room.layout.layers,
        lamp_count: u32::try_from(lamps.used.len()).unwrap_or(u32::MAX),
        rays: settings.rays,
        bounces: settings.bounces,
        blur: settings.blur,
        seed: settings.seed,
        sampler: settings.sampler,
        bvh,
        method: settings.method,
        higher_rays: settings.higher_rays,
        stride: settings.stride,
        higher_stride: settings.higher_stride,
        refine: Some((settings.refine_rays, settings.refine_error)),
        narrow_rays: settings.narrow_rays,
        narrow_texels: [room.narrow_texels, room.valid_texels],
        denoise_correction: settings.denoise_correction,
        direct_at_hits: settings.direct_at_hits,
        texel_size: room.texel_sizes(),
        // The pool is traced after the direct pass: its size and density scale go into the
        // passes then ([`execute::run`]).
        lamp_paths: if lamps.paths_wanted {
            (settings.lamp_paths, 0.0)
        } else {
            (0, 0.0)
        },
        lamp_path_count: 0,
        openings: (
            settings.opening_samples,
            u32::try_from(lamps.params.iter().filter(|l| l.opening.is_some()).count())
                .unwrap_or(u32::MAX),
        ),
        opening_probe_stride: settings.opening_probe_stride,
        // Direct light handed over first: a preview with every lamp a point before an
        // opening's direct pass.
        direct_preview: direct.is_some(),
        luminance_scale: crate::program::luminance_scale_for(lamps.peak_candela()),
        gather_chunk,
        direct_chunk,
        scene_size: 2.0 * room.half_extent,
    });
    graph.validate()?;

    // Execute, then collect.
    let run = execute::run(
        backend,
        (room, &mut lamps),
        &graph,
        settings,
        progress,
        direct,
    )
    .map_err(be)?;
    // The graph as it ran: with the pool's size and density scale.
    let graph = graph.with_lamp_paths(lamps.pool());
    progress(&Progress::Setup("read back"));
    let t = Instant::now();
    let maps = execute::collect(backend, room, &graph, &run.textures, read_back).map_err(be)?;
    // The maps are on the host: the backend frees the bake's textures and scene, and keeps
    // what it compiled for the next bake.
    backend.release().map_err(be)?;
    let mut setup = lamps.timings.clone();
    setup.push(("upload", run.upload_seconds));
    setup.push(("read back", t.elapsed().as_secs_f64()));
    let decisions = run.decisions;
    skipped.extend(decisions.skipped);
    let bounces_run = decisions.bounces_run;
    let converged = settings.method == Method::Converged && settings.bounces > 0;
    let report = BakeReport {
        backend: name,
        texels: room.valid_texels,
        region_texels: room.layout.texel_count(),
        triangles: room.triangles,
        shadow_rays: lamps.shadow_rays,
        gather_rays: room.valid_texels * nominal_gather_rays(settings, bounces_run),
        tail_fraction: if converged && settings.tail {
            decisions.series.tail_fraction()
        } else {
            0.0
        },
        bounce_ratio: if converged {
            decisions.series.ratio()
        } else {
            None
        },
        series: converged.then(|| decisions.series.clone()),
        bvh,
        bounces_run,
        setup,
        passes: run.passes,
        skipped,
        lamp_models: lamps.models.clone(),
        total_seconds: start.elapsed().as_secs_f64(),
    };
    Ok(BakeOutput {
        settings: settings.clone(),
        layout: room.layout.clone(),
        graph,
        maps,
        lamps_used: lamps.used,
        report,
    })
}

/// Gather rays per valid texel of a bake that ran `bounces` explicit bounces: nominal, grid
/// texels × rays (orphans and refinement rays not counted).
fn nominal_gather_rays(settings: &Settings, bounces: u32) -> u64 {
    match (settings.method, bounces) {
        (Method::Paper, k) => u64::from(settings.rays) * u64::from(k),
        (Method::Converged, 0) => 0,
        (Method::Converged, k) => {
            let per = |rays: u32, stride: u32| u64::from(rays) / u64::from(stride.max(1)).pow(2);
            per(settings.rays, settings.stride)
                + per(settings.higher_rays, settings.higher_stride) * u64::from(k - 1)
        }
    }
}
