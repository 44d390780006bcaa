//! Executing a [`BakeGraph`] on a backend, and reading its maps back.
//!
//! The driver is generic: it creates the graph's textures, uploads the scene, then runs the
//! passes in order — an upload, or a program dispatched tile by tile — skipping those whose
//! [`RunWhen`] the decisions so far rule out. After a pass with a [`Check`] — the second of
//! the two reductions ([`crate::passes::energy`]) the graph puts after the checked map — it
//! reads back one texel per layer (16 bytes, not the map: no stall on a whole read-back per
//! bounce) and decides: where the bounces stop, and the tail's weight
//! ([`Runtime::TailWeight`]). Where the f32 sum overflowed it reads the map and sums it in f64.
//! The graph itself is never changed.
//!
//! # Progress
//! [`Progress::Work`] follows the work (texels × rays or taps of every dispatch run): at the
//! start of each pass the fraction still to go is split between that pass and the passes still
//! expected — the bounces up to the one where the decisions so far expect the series to stop
//! ([`Decisions::expected_stop`]: the tail's fraction, shrinking by the bounce ratio per
//! bounce, under the tolerance; before two bounces have run, [`EXPECTED_BOUNCES`]) — and the
//! pass moves it by its share as its tiles finish. A graph that reserves 32 bounces and stops
//! after 4 therefore does not sit at an eighth for most of the bake, and an estimate that
//! grows slows the fraction down instead of stopping it.

// `web_time::Instant` is `std::time::Instant` natively and `performance.now()` on wasm32.
use web_time::Instant;

use rayon::prelude::*;

use crate::backend::{Dispatch, GpuBackend, SceneData};
use crate::graph::{
    BakeGraph, Check, PassDesc, PassKind, RunWhen, Runtime, TexId, with_lamp_paths,
};
use crate::layout::Region;
use crate::map::MapImage;
use crate::prepare::{Lamps, Room};
use crate::program::{
    CombineParams, Params, Program, RowKind, TileParams, TilePlan, tiles_by_rows,
};
use crate::report::{DirectStage, ObjectMaps, OnDirect, PassTiming, Progress, ReadBack, Skipped};
use crate::scene::Settings;
use crate::series::Series;

/// Bounces stop once one adds less than this fraction of the total illuminance.
pub const BOUNCE_ENERGY_THRESHOLD: f32 = 1e-3;

/// Bounces a progress estimate expects before two have run and their ratio is known (the
/// default preset's rooms stop after 3 to 6).
pub const EXPECTED_BOUNCES: u32 = 4;

/// What the decisions of a run found.
#[derive(Debug, Default)]
pub(crate) struct Decisions {
    /// The bounce at which the bake stopped.
    stopped: Option<u32>,
    /// The tail's weight ([`Runtime::TailWeight`]).
    tail_weight: f32,
    /// Energy of the direct light and of the paper method's indirect map so far.
    direct_energy: f64,
    previous_indirect: f64,
    /// The converged method's series of increments.
    pub(crate) series: Series,
    /// Explicit bounces run.
    pub(crate) bounces_run: u32,
    /// Bounces left out.
    pub(crate) skipped: Option<Skipped>,
}

impl Decisions {
    /// Whether a pass that runs `when` runs after the decisions so far.
    fn runs(&self, when: RunWhen) -> bool {
        match when {
            RunWhen::Always => true,
            RunWhen::Bounce(k) => self.stopped.is_none_or(|s| k <= s),
            RunWhen::StoppedAt(k) => self.stopped == Some(k),
        }
    }

    /// Decides `check` with the energy `energy` of its texture.
    fn decide(&mut self, check: Check, energy: f64, settings: &Settings) {
        match check {
            Check::DirectEnergy(_) => {
                self.direct_energy = energy;
                self.series.direct = energy;
            }
            Check::PaperBounce { bounce, last, .. } => {
                self.bounces_run = bounce;
                let total = self.direct_energy + energy;
                let added = if total > 0.0 {
                    ((energy - self.previous_indirect) / total) as f32
                } else {
                    0.0
                };
                // The increments, for the progress estimate.
                self.series.increments.push(energy - self.previous_indirect);
                self.previous_indirect = energy;
                if !last && added.abs() < BOUNCE_ENERGY_THRESHOLD {
                    self.stop(bounce, settings.bounces, added);
                }
            }
            Check::Increment { bounce, .. } => {
                self.bounces_run = bounce;
                self.series.increments.push(energy);
            }
            Check::ConvergedBounce { bounce, last, .. } => {
                self.series.reflected.push(energy);
                // Without the tail an explicit count of bounces runs to the last one, and
                // adds nothing after it.
                if last {
                    self.stopped = Some(bounce);
                } else if settings.tail && self.series.converged(f64::from(settings.tail_tolerance))
                {
                    self.stop(bounce, settings.bounces, self.series.tail_fraction() as f32);
                }
                if self.stopped.is_some() && settings.tail {
                    self.tail_weight = self.series.tail_factor() as f32;
                }
            }
        }
    }

    /// Stops after `bounce`; bounces up to `to` are left out.
    fn stop(&mut self, bounce: u32, to: u32, added: f32) {
        self.stopped = Some(bounce);
        self.skipped = Some(Skipped::Bounces {
            from: bounce + 1,
            to,
            added,
        });
    }

    /// The bounce at which the bake is expected to stop, for progress: the decided one, or
    /// where the series' tail (the paper method's increment) falls under the tolerance if it
    /// keeps shrinking by the last ratio, at most `settings.bounces`.
    fn expected_stop(&self, settings: &Settings) -> u32 {
        if let Some(s) = self.stopped {
            return s;
        }
        let done = self.bounces_run;
        let (left, tolerance, ratio) = match settings.method {
            crate::scene::Method::Converged if settings.tail => (
                self.series.tail_fraction(),
                f64::from(settings.tail_tolerance),
                self.series.ratio(),
            ),
            // Without the tail every bounce runs.
            crate::scene::Method::Converged => return settings.bounces,
            crate::scene::Method::Paper => {
                let total = self.direct_energy + self.previous_indirect;
                let last = self.series.increments.last().copied().unwrap_or(0.0);
                let left = if total > 0.0 { last.abs() / total } else { 0.0 };
                (
                    left,
                    f64::from(BOUNCE_ENERGY_THRESHOLD),
                    self.series.ratio(),
                )
            }
        };
        let more = match ratio {
            Some(r) if r > 0.0 && r < 1.0 && left > tolerance => {
                ((tolerance / left).ln() / r.ln()).ceil().clamp(1.0, 64.0) as u32
            }
            Some(_) if left <= tolerance => 1,
            _ => EXPECTED_BOUNCES.saturating_sub(done).max(1),
        };
        (done + more).min(settings.bounces)
    }

    /// `pass`'s parameter block with the decided runtime values.
    fn params(&self, pass: &PassDesc) -> Params {
        match (pass.runtime, pass.params) {
            (Some(Runtime::TailWeight), Params::Combine(c)) => Params::Combine(CombineParams {
                b_weight: self.tail_weight,
                ..c
            }),
            (_, params) => params,
        }
    }
}

/// A graph run on a backend: its textures, timings and decisions.
pub(crate) struct Run<T> {
    pub(crate) textures: Vec<T>,
    pub(crate) passes: Vec<PassTiming>,
    pub(crate) upload_seconds: f64,
    pub(crate) decisions: Decisions,
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

/// Every layer of `texture`.
fn read_all<B: GpuBackend>(
    backend: &mut B,
    room: &Room,
    texture: &B::Texture,
) -> Result<Vec<Vec<f32>>, B::Error> {
    (0..room.layout.layers)
        .map(|l| backend.read_back(texture, l))
        .collect()
}

/// What one ray costs against one filter tap, for progress (the CPU backend on `chairs_05`:
/// a gather ray about 14 à-trous taps, a shadow ray about 9).
const RAY_COST: f64 = 12.0;

/// Work of `pass`, for progress, in filter taps: texels of the layout × its work per texel,
/// rays weighted by [`RAY_COST`], a strided gather on its grid only (the lamp-path
/// connections are the connect pass's work, not the gather's).
fn pass_work(pass: &PassDesc, room: &Room) -> f64 {
    let [w, h] = room.layout.layer_size;
    let texels = f64::from(w) * f64::from(h) * f64::from(room.layout.layers);
    let ray_cost = if pass.kind.program().is_some_and(|p| p.signature().scene.bvh) {
        RAY_COST
    } else {
        1.0
    };
    // A refinement in narrow gaps works at the gaps' texels alone.
    if let Some(gap) = pass.params.gap_work() {
        return texels + room.narrow_texels as f64 * gap as f64 * ray_cost;
    }
    let mut per_texel = pass.params.work_per_texel() as f64;
    if let Params::Gather(g) = pass.params {
        per_texel /= f64::from(g.stride.max(1)).powi(2);
    }
    texels * per_texel * ray_cost
}

/// Per row of the layout (layer by layer, rows top to bottom), its texels in narrow gaps, from
/// the G-buffer's positions.
fn gap_rows_of(room: &Room) -> Vec<u64> {
    let width = room.layout.layer_size[0] as usize;
    room.gbuffer
        .position
        .chunks(4 * width.max(1))
        .map(|row| {
            row.chunks_exact(4)
                .filter(|p| p[3] >= crate::validity::NARROW_GAP)
                .count() as u64
        })
        .collect()
}

/// Work of the passes after `index` that run if the bake stops at bounce `stop`.
fn work_to_come(graph: &BakeGraph, room: &Room, index: usize, stop: u32) -> f64 {
    graph
        .passes
        .iter()
        .skip(index + 1)
        .filter(|p| match p.when {
            RunWhen::Always => true,
            RunWhen::Bounce(k) => k <= stop,
            RunWhen::StoppedAt(k) => k == stop,
        })
        .map(|p| pass_work(p, room))
        .sum()
}

/// Runs `graph` for `room` lit by `lamps` on `backend` (module docs). `direct`, if given,
/// receives the blurred direct maps (Figure 5 stage 3, the maps a bake without bounces
/// shows) as soon as the graph has computed them, and before them the graph's preview
/// ([`BakeGraph::preview`]) if it has one.
pub(crate) fn run<B: GpuBackend>(
    backend: &mut B,
    (room, lamps): (&Room, &mut Lamps),
    graph: &BakeGraph,
    settings: &Settings,
    progress: &mut dyn FnMut(&Progress<'_>),
    mut direct: Option<OnDirect<'_>>,
) -> Result<Run<B::Texture>, B::Error> {
    progress(&Progress::Setup("upload"));
    let t = Instant::now();
    let textures = graph
        .textures
        .iter()
        .map(|d| backend.create_texture(d))
        .collect::<Result<Vec<_>, _>>()?;
    let layout = &room.layout;
    let upload = |backend: &mut B, lamps: &Lamps| {
        backend.upload_scene(&SceneData {
            bvh: &room.bvh,
            lamps: &lamps.params,
            ies_tables: &lamps.tables,
            regions: &layout.regions,
            layer_size: layout.layer_size,
            layers: layout.layers,
            ray_epsilon: room.ray_epsilon,
            lamp_paths: lamps.paths.as_ref().map_or(&[][..], |p| &p.0),
        })
    };
    let mut scene = upload(backend, lamps)?;
    let mut upload_seconds = t.elapsed().as_secs_f64();

    let layer_floats = 4 * layout.layer_size[0] as usize * layout.layer_size[1] as usize;
    let mut decisions = Decisions::default();
    let mut passes = Vec::new();
    let count = graph.passes.len();
    // The last pass that writes the blurred direct map: after it, the direct light exists.
    let blurred_direct = graph.figure5.stages[2];
    let direct_done = graph
        .passes
        .iter()
        .rposition(|p| blurred_direct.is_some_and(|t| p.writes.contains(&t)));
    let mut shown = 0.0f32;
    // The texels in narrow gaps per row ([`gap_rows_of`]), once a pass needs them.
    let mut gap_rows: Option<Vec<u64>> = None;
    // What each row holds (`validity::row_kinds`), once a pass needs it.
    let mut row_kinds: Option<Vec<RowKind>> = None;
    for (index, pass) in graph.passes.iter().enumerate() {
        if !decisions.runs(pass.when) {
            continue;
        }
        let work = pass_work(pass, room);
        let to_come = work_to_come(graph, room, index, decisions.expected_stop(settings));
        // The lamp paths' pool is traced (on the host) and uploaded with the scene when the
        // first pass that reads it comes, after the direct light; the fraction moves with it
        // by its share of the work still to come (its rays as the passes' rays count).
        if reads_lamp_paths(&pass.params) {
            let pool = lamps.pool_rays(room, settings) * RAY_COST;
            let (base, share) = (shown, pool / (pool + work + to_come));
            let sink = std::cell::RefCell::new(&mut *progress);
            let mut moved = |fraction: f32| {
                let f = base + (1.0 - base) * (share * f64::from(fraction)) as f32;
                if share.is_finite() && f > shown {
                    shown = f.min(1.0);
                    (sink.borrow_mut())(&Progress::Work(shown));
                }
            };
            let mut setup = |p: &Progress<'_>| (sink.borrow_mut())(p);
            if lamps.trace_paths(room, settings, &mut setup, &mut moved) {
                let t = Instant::now();
                scene = upload(backend, lamps)?;
                upload_seconds += t.elapsed().as_secs_f64();
            }
        }
        // What is shown so far stays; this pass moves the rest of the way in proportion to its
        // share of the work still expected (re-estimated at each pass: a later stop slows the
        // fraction down, it never stops it).
        let base = shown;
        let share = if work + to_come > 0.0 {
            work / (work + to_come)
        } else {
            1.0
        };
        progress(&Progress::PassStart {
            index,
            count,
            label: pass.label,
            bounce: pass.bounce,
        });
        let t = Instant::now();
        let mut report = |fraction: f32| {
            progress(&Progress::PassProgress { index, fraction });
            let f = base + (1.0 - base) * (share * f64::from(fraction)) as f32;
            if f > shown {
                shown = f.min(1.0);
                progress(&Progress::Work(shown));
            }
        };
        let uploads: [&[f32]; 3] = match pass.kind {
            PassKind::GBuffer => [
                &room.gbuffer.position,
                &room.gbuffer.normal,
                &room.gbuffer.albedo,
            ],
            _ => [&[]; 3],
        };
        if let (Some(program), Some(write)) = (pass.kind.program(), pass.writes.first()) {
            // `graph.validate()` checked the slots, the parameter block and the sizes.
            let reads: Vec<&B::Texture> = pass.reads.iter().map(|r| &textures[r.index()]).collect();
            let params = with_lamp_paths(decisions.params(pass), lamps.pool()).words();
            let size = graph.textures[write.index()].size;
            let uniform = TilePlan::new(
                size,
                layout.layers,
                pass.params.work_per_texel(),
                backend.tile_work(),
            );
            // Each tile with whether it is idle (`Dispatch::idle`) and may hold a narrow
            // texel (`Dispatch::narrow`).
            let plan: Vec<(TileParams, bool, bool)> = match (pass.params.gap_work(), pass.params) {
                // A refinement in narrow gaps in tiles by where its work lies
                // (`tiles_by_rows`): rows without a gap share a dispatch, idle.
                (Some(gap), _) if size == layout.layer_size => {
                    let rows = gap_rows.get_or_insert_with(|| gap_rows_of(room));
                    tiles_by_rows(size, layout.layers, rows, gap, backend.tile_work())
                        .into_iter()
                        .map(|(t, idle)| (t, idle, true))
                        .collect()
                }
                // A gather's tiles cut around long runs of rows without a valid texel, which
                // keep no hits (idle), and a strided gather's around those without a narrow
                // texel, whose texels off the grid keep the orphans' rays' alone.
                (_, Params::Gather(g)) if size == layout.layer_size => {
                    let rows = row_kinds.get_or_insert_with(|| {
                        crate::validity::row_kinds(&room.gbuffer.position, size[0])
                    });
                    uniform
                        .gather_tiles(rows, g.stride)
                        .into_iter()
                        .map(|(t, k)| (t, k == RowKind::Empty, k == RowKind::Narrow))
                        .collect()
                }
                _ => uniform.tiles().map(|t| (t, false, true)).collect(),
            };
            let tiles = plan.len();
            for (done, &(tile, idle, narrow)) in plan.iter().enumerate() {
                backend.dispatch(&Dispatch {
                    label: pass.label,
                    program,
                    bvh: pass.bvh,
                    reads: &reads,
                    write: &textures[write.index()],
                    scene: &scene,
                    params: &params,
                    tile,
                    idle,
                    narrow,
                })?;
                report((done as u64 + 1) as f32 / tiles as f32);
            }
            if tiles == 0 {
                report(1.0);
            }
        } else {
            for (w, src) in pass.writes.iter().zip(uploads) {
                for l in 0..layout.layers as usize {
                    let slice = src
                        .get(l * layer_floats..(l + 1) * layer_floats)
                        .unwrap_or(&[]);
                    backend.upload(&textures[w.index()], l as u32, slice)?;
                }
            }
            report(1.0);
        }
        // The check's read-back waits for the pass's GPU work: it is part of the pass's time.
        if let Some(check) = pass.then {
            let tex = check.texture();
            // A reduction's one texel per layer; the map itself where the f32 sum overflowed
            // (or without a reduction).
            let reduced = match (pass.kind, pass.writes.first()) {
                (PassKind::Run(Program::Energy), Some(w)) => {
                    Some(energy(&read_all(backend, room, &textures[w.index()])?))
                }
                _ => None,
            };
            let e = match reduced {
                Some(e) if e.is_finite() => e,
                _ => energy(&read_all(backend, room, &textures[tex.index()])?),
            };
            decisions.decide(check, e, settings);
        }
        let seconds = t.elapsed().as_secs_f64();
        progress(&Progress::PassDone { index, seconds });
        passes.push(PassTiming {
            label: pass.label,
            kind: pass.kind,
            bounce: pass.bounce,
            seconds,
        });
        if let Some(show) = direct.as_mut() {
            let shown = if graph.preview == Some(index) {
                Some((DirectStage::Preview, graph.direct))
            } else if direct_done == Some(index) {
                blurred_direct.map(|t| (DirectStage::Direct, t))
            } else {
                None
            };
            if let Some((stage, tex)) = shown {
                let maps = collect_stages(backend, room, &textures, &[(2, tex)])?;
                show(stage, &maps);
            }
        }
    }
    if shown < 1.0 {
        progress(&Progress::Work(1.0));
    }
    Ok(Run {
        textures,
        passes,
        upload_seconds,
        decisions,
    })
}

/// Whether a pass with `params` uses the lamp paths' pool: the connect pass, and a gather
/// that combines its hits with lamp paths (their density scale).
fn reads_lamp_paths(params: &Params) -> bool {
    match params {
        Params::Connect(_) => true,
        Params::Gather(g) => g.lamp_paths > 0,
        _ => false,
    }
}

/// Reads the Figure 5 stages `read_back` names back and crops each receiver's maps, one
/// stage at a time: its
/// layers read back, every object's region cropped (in parallel), the layers dropped before
/// the next stage's are read.
pub(crate) fn collect<B: GpuBackend>(
    backend: &mut B,
    room: &Room,
    graph: &BakeGraph,
    textures: &[B::Texture],
    read_back: ReadBack,
) -> Result<Vec<ObjectMaps>, B::Error> {
    let stages: Vec<(usize, TexId)> = graph
        .figure5
        .stages
        .iter()
        .enumerate()
        .filter(|&(i, _)| read_back.reads(i))
        .filter_map(|(i, t)| Some((i, (*t)?)))
        .collect();
    collect_stages(backend, room, textures, &stages)
}

/// Reads the Figure 5 stages `stages` (index, texture) back, cropped per receiver; the other
/// stages stay `None`.
fn collect_stages<B: GpuBackend>(
    backend: &mut B,
    room: &Room,
    textures: &[B::Texture],
    wanted: &[(usize, TexId)],
) -> Result<Vec<ObjectMaps>, B::Error> {
    let layout = &room.layout;
    let mut stages: Vec<[Option<MapImage>; 8]> = vec![Default::default(); layout.regions.len()];
    for &(i, tex) in wanted {
        let layers = read_all(backend, room, &textures[tex.index()])?;
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
            name: room
                .scene
                .objects
                .get(o)
                .map(|ob| ob.name.clone())
                .unwrap_or_default(),
            region: *region,
            stages,
        });
    }
    Ok(maps)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stop_skips_the_later_bounces_and_runs_only_its_own_tail() {
        let mut d = Decisions::default();
        assert!(d.runs(RunWhen::Bounce(3)) && !d.runs(RunWhen::StoppedAt(1)));
        d.stop(2, 5, 1e-4);
        for (when, runs) in [
            (RunWhen::Always, true),
            (RunWhen::Bounce(1), true),
            (RunWhen::Bounce(2), true),
            (RunWhen::Bounce(3), false),
            (RunWhen::StoppedAt(1), false),
            (RunWhen::StoppedAt(2), true),
            (RunWhen::StoppedAt(3), false),
        ] {
            assert_eq!(d.runs(when), runs, "{when:?}");
        }
        assert_eq!(
            d.skipped,
            Some(Skipped::Bounces {
                from: 3,
                to: 5,
                added: 1e-4
            })
        );
    }
}
