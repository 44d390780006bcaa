//! What a bake reports: progress events, what it left out, timings, and its maps.

use std::fmt;

// `web_time::Instant` is `std::time::Instant` natively and `performance.now()` on wasm32.
use web_time::Instant;

use crate::gbuffer::GBuffer;
use crate::graph::{BakeGraph, PassKind};
use crate::layout::{Layout, Region};
use crate::map::MapImage;
use crate::scene::{BvhMode, LampModel, Settings};

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
    /// Pass `index` finished after `seconds` (its check's read-back included).
    PassDone {
        /// Index in the graph.
        index: usize,
        /// Wall time, seconds.
        seconds: f64,
    },
    /// The share (0–1) of the passes' work done so far, after every dispatch: work done over
    /// work done plus the work still expected (texels × rays or taps per pass, for the bounces
    /// the decisions so far expect: see `execute`'s docs). Non-decreasing, 1 after the last
    /// pass; the bounces left out are never counted as work to come.
    Work(f32),
}

/// The Figure 5 stages a bake reads back from the backend at its end; the others stay `None`
/// in its [`ObjectMaps`]. Each stage is one RGBA f32 texture array: on a GPU, reading back
/// what nobody shows is the bake's largest transfer (8 stages ≈ 128 bytes per texel of the
/// layout), and in a browser it is where WebGL's deferred work waits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReadBack([bool; 8]);

impl ReadBack {
    /// Every stage the graph computes (what [`crate::bake()`] and [`crate::bake::bake_room`] read).
    pub const ALL: ReadBack = ReadBack([true; 8]);
    /// What a viewer shows: the final illuminance and the blurred direct illuminance
    /// (stages 7 and 3, [`ObjectMaps::illuminance`] and [`ObjectMaps::direct`], exactly as
    /// [`ReadBack::ALL`] reads them): a quarter of its bytes.
    pub const LIGHT: ReadBack = ReadBack([false, false, true, false, false, false, true, false]);

    /// Whether stage `index` (0-based, [`crate::graph::Figure5::NAMES`]) is read back.
    pub fn reads(self, index: usize) -> bool {
        self.0.get(index).copied().unwrap_or(false)
    }
}

/// Receives the direct light of a bake as soon as it exists
/// ([`crate::bake::bake_room_direct_first`]): which light it is, and its maps.
pub type OnDirect<'a> = &'a mut dyn FnMut(DirectStage, &[ObjectMaps]);

/// Which direct light a bake hands to [`OnDirect`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DirectStage {
    /// Every lamp from its photometric centre, as a lamp without an opening: handed over
    /// first when a lamp bakes its luminous opening ([`crate::opening`]), whose direct pass is
    /// then most of the direct light's time (a point costs one shadow ray a texel, an opening
    /// 12–96). Near the opening it misses what the opening adds: the point model's error
    /// (a few per cent within the lamp's 1 % distance, more under a long luminaire's ends) and
    /// hard shadow edges where the opening's are soft. [`DirectStage::Direct`] follows.
    Preview,
    /// The bake's direct light (Figure 5 stage 3), as its result reports it.
    Direct,
}

impl DirectStage {
    /// The lower-case name the JavaScript package and the viewer give it: `preview`, `direct`.
    pub fn name(self) -> &'static str {
        match self {
            DirectStage::Preview => "preview",
            DirectStage::Direct => "direct",
        }
    }
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
    /// The backend's driver ends a shader invocation's loops after `limit` iterations in all
    /// ([`crate::Limits::loop_iterations`]) and the bake asks up to `samples` refinement
    /// rays or lamp paths of one texel (the gathers' rays and the openings' samples are split
    /// over passes there): beyond
    /// [`LOOP_LIMITED_SAMPLES`](crate::backend::LOOP_LIMITED_SAMPLES) the driver may leave
    /// some of them out, and those texels read low. Nothing is changed; the bake says so.
    LoopLimit {
        /// Most refinement rays or lamp paths one texel asks of one invocation.
        samples: u32,
        /// The driver's limit.
        limit: u32,
    },
}

impl Skipped {
    /// [`Skipped::LoopLimit`] when `limits` has a loop limit and `settings` asks more than
    /// [`LOOP_LIMITED_SAMPLES`](crate::backend::LOOP_LIMITED_SAMPLES) refinement rays or lamp
    /// paths of one texel.
    pub fn loop_limit(settings: &Settings, limits: &crate::Limits) -> Option<Skipped> {
        let limit = limits.loop_iterations?;
        // The gathers split a texel's rays over passes on such a driver
        // ([`crate::graph::GraphConfig::gather_chunk`]), the direct pass an opening's samples
        // ([`crate::graph::GraphConfig::direct_chunk`]); refinement and lamp paths do not yet.
        let samples = settings
            .refine_rays
            .max(settings.narrow_rays)
            .max(settings.lamp_paths);
        (samples > crate::backend::LOOP_LIMITED_SAMPLES)
            .then_some(Skipped::LoopLimit { samples, limit })
    }
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
            Skipped::LoopLimit { samples, limit } => write!(
                f,
                "up to {samples} refinement rays or lamp paths per texel: \
                 this GPU driver (Mesa's software rasterizer) ends a shader's loops after \
                 {limit} iterations in all and may leave some out, so texels can read low; \
                 keep to {} per texel, or bake with `--backend cpu`",
                crate::backend::LOOP_LIMITED_SAMPLES
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
    /// Shadow rays cast (one per valid texel facing a used lamp with non-zero intensity, one
    /// per opening sample near a lamp's opening).
    pub shadow_rays: u64,
    /// Gather rays cast (valid texels × rays × bounces run).
    pub gather_rays: u64,
    /// Traversal used.
    pub bvh: BvhMode,
    /// Explicit bounces run.
    pub bounces_run: u32,
    /// [`Method::Converged`](crate::scene::Method::Converged): the estimated tail of the
    /// inter-reflection series that the explicit bounces left out and the bake added, as a
    /// fraction of the total illuminance ([`crate::series`]); 0 for the paper's method and
    /// without [`Settings::tail`].
    pub tail_fraction: f64,
    /// [`Method::Converged`](crate::scene::Method::Converged): the bounce ratio λ of the last two explicit bounces, which the
    /// tail is extrapolated with when [`Settings::tail`] is on (`None` before a second bounce
    /// or for the paper's method).
    pub bounce_ratio: Option<f64>,
    /// [`Method::Converged`](crate::scene::Method::Converged): the energies of the series the
    /// bake decided on ([`crate::series::Series`]: Σ (r + g + b) over the valid texels of the
    /// direct illuminance, then of each explicit bounce's increment), so that its ratios and
    /// its tail can be checked; `None` for the paper's method.
    pub series: Option<crate::series::Series>,
    /// Set-up steps and their wall time, seconds.
    pub setup: Vec<(&'static str, f64)>,
    /// Every executed pass.
    pub passes: Vec<PassTiming>,
    /// What was left out.
    pub skipped: Vec<Skipped>,
    /// The model each lamp of the scene was baked with, and why.
    pub lamp_models: Vec<LampModelChoice>,
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

    /// Every valid texel of the object's region, row by row: its world position (from `g`,
    /// the G-buffer of the bake's layout) and its RGBA in `map` (one of this object's maps).
    pub fn texels<'a>(
        &'a self,
        g: &'a GBuffer,
        map: &'a MapImage,
    ) -> impl Iterator<Item = ([f64; 3], [f32; 4])> + 'a {
        let r = self.region;
        (0..r.size[1]).flat_map(move |y| {
            (0..r.size[0]).filter_map(move |x| {
                let i = g.index(r.layer, r.offset[0] + x, r.offset[1] + y);
                let p = &g.position[i..i + 4];
                (p[3] > 0.5).then(|| {
                    let p = [p[0], p[1], p[2]].map(f64::from);
                    (p, map.texel(x, y))
                })
            })
        })
    }
}

/// The model a lamp was baked with, and why ([`crate::scene::LampModel`]).
#[derive(Debug, Clone, PartialEq)]
pub struct LampModelChoice {
    /// Lamp index in the scene.
    pub lamp: usize,
    /// Lamp name.
    pub name: String,
    /// The model asked for.
    pub requested: LampModel,
    /// `true`: the luminous opening ([`crate::opening`]); `false`: the point.
    pub area: bool,
    /// Why, in words.
    pub reason: String,
    /// With the opening: the distance from the lamp's centre within which texels evaluate it,
    /// metres (`None`: everywhere).
    pub near_m: Option<f64>,
}

impl LampModelChoice {
    /// `"area"` or `"point"`.
    pub fn used(&self) -> &'static str {
        if self.area { "area" } else { "point" }
    }
}

impl fmt::Display for LampModelChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "lamp {} `{}`: {} model ({})",
            self.lamp,
            self.name,
            self.used(),
            self.reason
        )?;
        if let Some(d) = self.near_m {
            write!(
                f,
                "; texels within {d:.3} m see the opening, farther ones the point"
            )?;
        }
        Ok(())
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

impl BakeOutput {
    /// Counts the preparation of the room in the report of a bake that prepared it, as
    /// [`crate::bake()`] does: the room's host steps `room_steps`
    /// ([`crate::bake::Room::timings`]) first in [`BakeReport::setup`], and
    /// [`BakeReport::total_seconds`] the wall time since `start`, before the preparation.
    pub fn count_preparation(&mut self, room_steps: &[(&'static str, f64)], start: Instant) {
        self.report.setup.splice(0..0, room_steps.iter().copied());
        self.report.total_seconds = start.elapsed().as_secs_f64();
    }

    /// The first texel of any stage of any object's maps that is not a finite, non-negative
    /// number, as `(object name, stage 1..=8, value)`; `None` — as every bake promises (no NaN
    /// or infinity reaches a map) — for tools and tests that check the promise.
    pub fn first_invalid_texel(&self) -> Option<(&str, usize, f32)> {
        self.maps.iter().find_map(|m| {
            m.stages.iter().enumerate().find_map(|(s, stage)| {
                let v = stage
                    .as_ref()?
                    .texels
                    .iter()
                    .find(|v| !(v.is_finite() && **v >= 0.0))?;
                Some((m.name.as_str(), s + 1, *v))
            })
        })
    }
}
