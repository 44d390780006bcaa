//! The bake as a pass graph: plain data, no GPU types.
//!
//! A [`BakeGraph`] lists the textures of a bake ([`TexDesc`]: every one an RGBA32F texture array
//! of the layout's layer size and layer count) and every pass the bake may run
//! ([`PassDesc`]), in execution order. The driver ([`crate::bake()`]) runs them in that order,
//! tile by tile, on a backend; backends never decide the order. The graph is built by small
//! functions, one per stage of the paper's Figure 4, each declaring what it reads and writes
//! and returning the texture it produced. The host work before the passes (layout,
//! rasterising, the BVH, unocclusion, the lamps' reach and paths) is typed too
//! ([`crate::prepare::HostNode`]).
//!
//! # Decisions are data
//! How many bounces a bake runs is decided while it runs, from a few numbers read back. The
//! graph says where and how: a pass may carry a [`Check`] (measure the energy of one texture
//! after it and decide), each pass says when it runs ([`RunWhen`]: always, as part of bounce
//! `k` unless the bake stopped earlier, or only if the bake stopped at bounce `k`), and a pass
//! may take a parameter from the decisions ([`Runtime`]: the tail's weight). The driver
//! executes the graph and never changes it.
//!
//! # What a pass depends on
//! Every pass depends on the room; [`PassDesc::lamps`] says whether it also depends on the
//! lamps (it computes or reads their light), derived from the reads and writes: the G-buffer
//! upload does not, the direct pass, the lamp paths and everything reading their light do. A
//! lamp change re-runs only those.
//!
//! # Stages (the paper's Figure 5 numbering)
//! ```text
//! GBuffer                      → position, normal, albedo(1)        (uploaded from the rasteriser)
//! Connect    position, normal  → connected                          (converged, lamp paths)
//! Direct     position, normal  → direct(2)
//! Copy       direct            → direct_blurred                     (the paper's "copy for later")
//! Blur U/V   direct_blurred    → blur_tmp → direct_blurred(3)       (only when blur ≠ none)
//! AlbedoMul  direct_blurred(3) → reflected_direct(4)
//! per bounce k = 1 ..= bounces:
//!   Gather k  reflected(4 if k = 1, else 8) → indirect(5)
//!   Combine   direct(2) + indirect(5)       → combined(6)
//!   Copy, Blur U/V combined                 → combined_blurred(7)
//!   AlbedoMul combined_blurred(7)           → reflected_combined(8)
//! ```
//! This is the Jacobi iteration `ind_k = gather(ρ · blur(direct + ind_{k−1}))`, `ind_0 = 0`,
//! whose fixed point is the inter-reflection series `Σ ρ^i` of a closed diffuse enclosure.
//! Bounces re-use the same five textures (5–8 and the blur scratch): a gather reads the
//! reflected map of the previous bounce (8) and writes the indirect map (5), which only the
//! combine of the same bounce reads, so no pass ever reads the texture it writes. The paper
//! method ([`Method::Paper`]) checks after each bounce whether it added enough light to go on
//! ([`Check::PaperBounce`]).
//!
//! The converged method ([`Method::Converged`]) reflects the direct light unblurred and
//! gathers increments:
//! ```text
//! per bounce k = 1 ..= bounces:                 (RunWhen::Bounce(k))
//!   Gather k  reflected increment of k − 1      → delta     (reduced: coarse, then Upsample)
//!   accumulate sum_(k−1) + delta                → sum_k      + Check::Increment
//!   AlbedoMul delta                             → reflected  + Check::ConvergedBounce
//!   tail k    sum_k + f · delta                 → indirect  (RunWhen::StoppedAt(k), f decided)
//! once: Variance, Atrous… (denoise indirect), Combine direct + indirect, AlbedoMul
//! ```
//!
//! A converged bake that hands its direct light over first, with a lamp that bakes its
//! luminous opening ([`GraphConfig::direct_preview`]), starts with a `direct_preview` pass:
//! the direct program with every lamp a point (one shadow ray a texel), into `direct`, which
//! the driver reads back and hands over ([`BakeGraph::preview`]) before the opening's direct
//! passes overwrite it.
//!
//! Every light-map texture carries the texel mask in its alpha channel (1 = a valid texel of a
//! receiver's chart, 0 = empty), which the blur and the gather's bilinear look-up use.
//!
//! On a driver that cuts long shader loops ([`crate::Limits::loop_iterations`]) a gather's
//! rays ([`GraphConfig::gather_chunk`]) and the direct pass's opening samples
//! ([`GraphConfig::direct_chunk`]) are split over several passes, each reading the one before
//! (a `prior` slot) and adding its share, alternating with a texture that holds nothing live
//! then, so that the last writes where the unsplit pass would.
//!
//! # Reads, writes and parameters
//! Each computed pass runs one [`Program`]; its reads follow the program's
//! [`Signature::reads`](crate::program::Signature::reads) slots, it writes one texture and carries
//! the program's parameter block ([`Params`]); the uploads read nothing and write position,
//! normal and albedo (the G-buffer).
//! [`BakeGraph::validate`] checks every pass
//! against its signature (the driver runs it before executing a graph).

pub use crate::program::Program;
use crate::program::{
    ATROUS_MIN_PAIRS, AtrousConfig, CombineParams, ConnectParams, DirectParams, GatherParams,
    MAX_ATROUS_ITERATIONS, Params, RefineParams, UpsampleParams, VarianceParams, atrous_steps,
    blur_params, coarse, correction_steps,
};
use crate::rng::Sampler;
use crate::scene::{Blur, BvhMode, Method};

/// Index of a texture in [`BakeGraph::textures`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct TexId(pub u32);

impl TexId {
    /// The index into [`BakeGraph::textures`].
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// Texel format of a graph texture.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TexFormat {
    /// Four 32-bit floats per texel (WebGL2 `RGBA32F` with `EXT_color_buffer_float`).
    Rgba32F,
}

/// Description of one texture array of the graph.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TexDesc {
    /// Short name (for debugging, read-back and file names).
    pub label: &'static str,
    /// Layer size in texels, `[width, height]`.
    pub size: [u32; 2],
    /// Number of array layers.
    pub layers: u32,
    /// Texel format.
    pub format: TexFormat,
}

/// What a pass does: upload data computed on the host, or run a [`Program`] (whose
/// parameters are the pass's [`PassDesc::params`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PassKind {
    /// The G-buffer: world position (w = 1 valid), normal (w = object index) and albedo
    /// (w = coverage) per texel, rasterised on the host and uploaded.
    GBuffer,
    /// A computed pass.
    Run(Program),
}

impl PassKind {
    /// The shader program a backend runs for this pass; `None` for an upload.
    pub fn program(&self) -> Option<Program> {
        match self {
            PassKind::Run(p) => Some(*p),
            PassKind::GBuffer => None,
        }
    }
}

/// One pass: its kind, the textures it reads and writes (in the order of its program's
/// [`Signature::reads`](crate::program::Signature::reads)) and its parameter block.
#[derive(Debug, Clone, PartialEq)]
pub struct PassDesc {
    /// What the pass computes.
    pub kind: PassKind,
    /// Short name for progress reports and timings.
    pub label: &'static str,
    /// Textures read, in the program's slot order.
    pub reads: Vec<TexId>,
    /// Textures written (one, or the three G-buffer textures).
    pub writes: Vec<TexId>,
    /// The bounce this pass belongs to: 0 for the direct part, `k` for bounce `k`.
    pub bounce: u32,
    /// The program's parameter block.
    pub params: Params,
    /// The traversal of a ray-casting pass.
    pub bvh: BvhMode,
    /// When the driver runs it.
    pub when: RunWhen,
    /// What the driver measures after it, to decide which passes run next.
    pub then: Option<Check>,
    /// A parameter the driver sets when it runs the pass, from what a [`Check`] decided.
    pub runtime: Option<Runtime>,
    /// Whether it depends on the lamps: it computes or reads (directly or through earlier
    /// passes) light of the lamps. A pass that does not can be kept when only the lamps
    /// change; every pass depends on the room.
    pub lamps: bool,
}

/// When a pass runs. The graph lists every pass a bake may run; the driver skips, by these
/// rules, the bounces after the one where it stopped ([`Check`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunWhen {
    /// Always.
    Always,
    /// Part of bounce `k`: runs unless the bake stopped at an earlier bounce.
    Bounce(u32),
    /// Runs only if the bake stopped at bounce `k` (the converged method's tail of `k`).
    StoppedAt(u32),
}

/// What the driver measures after a pass — a sum over the valid texels of one texture, a few
/// numbers read back — and what it decides with it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Check {
    /// The energy of the direct illuminance: the reference of the later checks.
    DirectEnergy(TexId),
    /// [`Method::Paper`], end of bounce `bounce`: the energy of the indirect map; the bake
    /// stops when the bounce added less than [`crate::bake::BOUNCE_ENERGY_THRESHOLD`] of the
    /// light, or at the last bounce.
    PaperBounce {
        /// The bounce that ends.
        bounce: u32,
        /// The indirect illuminance after it.
        indirect: TexId,
        /// Whether it is the last bounce of the graph.
        last: bool,
    },
    /// [`Method::Converged`], bounce `bounce`: the energy of its increment `Δ_k`, recorded
    /// ([`crate::series::Series::increments`]); the bounce's [`Check::ConvergedBounce`]
    /// follows.
    Increment {
        /// The bounce.
        bounce: u32,
        /// Its increment.
        delta: TexId,
    },
    /// [`Method::Converged`], end of bounce `bounce`: the energy of the light its increment
    /// reflects, `ρ·Δ_k` ([`crate::series::Series::reflected`]); the bake stops when the
    /// series' tail is estimated within the tolerance
    /// ([`crate::series::Series::converged`]), or at the last bounce, and then sets
    /// [`Runtime::TailWeight`].
    ConvergedBounce {
        /// The bounce that ends.
        bounce: u32,
        /// The reflected increment, which the next bounce gathers.
        reflected: TexId,
        /// Whether it is the last bounce of the graph.
        last: bool,
    },
}

impl Check {
    /// The texture whose energy the check measures.
    pub fn texture(&self) -> TexId {
        match *self {
            Check::DirectEnergy(t)
            | Check::PaperBounce { indirect: t, .. }
            | Check::Increment { delta: t, .. }
            | Check::ConvergedBounce { reflected: t, .. } => t,
        }
    }
}

/// A parameter a pass takes from the driver's decisions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Runtime {
    /// The combine's `b_weight` is the factor of the series' tail
    /// ([`crate::series::Series::tail_factor`]) decided by the last [`Check::ConvergedBounce`].
    TailWeight,
}

/// The G-buffer textures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GBufferTex {
    /// World position, w = 1 on valid texels.
    pub position: TexId,
    /// World normal, w = object index.
    pub normal: TexId,
    /// Albedo, w = coverage.
    pub albedo: TexId,
    /// The lamp paths' part of the first bounce ([`Program::Connect`]),
    /// when the bake has lamp paths ([`GraphConfig::lamp_paths`]).
    pub connected: Option<TexId>,
}

/// The textures of the paper's Figure 5, numbered as there; `None` where the graph has no
/// such stage (5–8 without bounces).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Figure5 {
    /// (1) … (8) in order: albedo, direct, blurred direct, reflected direct, indirect,
    /// combined, blurred combined, reflected combined.
    pub stages: [Option<TexId>; 8],
}

impl Figure5 {
    /// Stages (1)–(4) of the direct part, `[albedo, direct, blurred direct, reflected
    /// direct]`; (5)–(8) not (yet) in the graph.
    pub fn direct_part(stages: [TexId; 4]) -> Figure5 {
        let mut f = Figure5 { stages: [None; 8] };
        for (s, t) in f.stages.iter_mut().zip(stages) {
            *s = Some(t);
        }
        f
    }

    /// Names of the eight stages, as in the paper's caption.
    pub const NAMES: [&'static str; 8] = [
        "albedo",
        "direct",
        "blurred direct",
        "reflected direct",
        "indirect",
        "combined",
        "blurred combined",
        "reflected combined",
    ];
}

/// What the graph should compute.
#[derive(Debug, Clone, PartialEq)]
pub struct GraphConfig {
    /// Layer size of every texture array, texels.
    pub layer_size: [u32; 2],
    /// Layers of every texture array.
    pub layers: u32,
    /// Lamps the direct pass evaluates: the first `lamp_count` uploaded lamps.
    pub lamp_count: u32,
    /// Gather rays per texel.
    pub rays: u32,
    /// Indirect bounces (0 = direct light only).
    pub bounces: u32,
    /// Blur of the direct and combined maps.
    pub blur: Blur,
    /// RNG seed.
    pub seed: u32,
    /// Traversal for the ray-casting passes.
    pub bvh: BvhMode,
    /// The pipeline.
    pub method: Method,
    /// [`Method::Converged`]: rays of bounces 2 and later (the first uses `rays`).
    pub higher_rays: u32,
    /// [`Method::Converged`]: grid stride of the first bounce's gather (1: every texel;
    /// [`GatherParams::stride`]).
    pub stride: u32,
    /// [`Method::Converged`]: grid stride of the gather of bounces 2 and later.
    pub higher_stride: u32,
    /// [`Method::Converged`]: progressive refinement of the first bounce, `(rays, max_error)`
    /// ([`Program::Refine`]); `None` or 0 rays: off.
    pub refine: Option<(u32, f32)>,
    /// [`Method::Converged`]: rays per texel in a narrow gap in the first two bounces, half
    /// as many in each bounce after ([`crate::passes::refine::narrow_rays_in`]): a bounce that
    /// gathers fewer there (the first with `stride` 1, the later ones at any `higher_stride`)
    /// adds the rest as a refinement ([`RefineParams::narrow_rays`]; without
    /// `direct_at_hits` the first bounce's refinement gathers all of them there,
    /// [`RefineParams::narrow_direct`]); 0 (or no more than a bounce's rays): none. Within a
    /// budget: [`crate::passes::refine::narrow_more`].
    pub narrow_rays: u32,
    /// The room's texels in narrow gaps and its valid texels, for the budget of
    /// [`GraphConfig::narrow_rays`]; no texel in a gap: no refinement for them.
    pub narrow_texels: [u64; 2],
    /// [`Method::Converged`] with a denoiser: its bias correction ([`correction_steps`]).
    pub denoise_correction: bool,
    /// [`Method::Converged`]: the first bounce evaluates the direct light at its hits
    /// ([`GatherParams::direct_at_hits`]).
    pub direct_at_hits: bool,
    /// Sampler of the gather directions.
    pub sampler: Sampler,
    /// [`Method::Converged`]: world size of a texel, `[smallest, largest]` over the receivers,
    /// metres (the à-trous filter's chart test, [`AtrousConfig::texel_size`]).
    pub texel_size: [f32; 2],
    /// [`Method::Converged`] with a first bounce at stride 1: lamp paths per
    /// texel combined with the first gather ([`crate::lightpaths`]) and their
    /// [`density_scale`](crate::lightpaths::LampPaths::density_scale); 0: none. With lamp
    /// paths a `connect` pass ([`Program::Connect`]) writes a fourth G-buffer texture,
    /// [`GBufferTex::connected`]. A bake builds its graph before the pool is traced (after
    /// the direct light) with a density scale of 0, and puts the traced pool's in when it
    /// runs those passes ([`with_lamp_paths`]).
    pub lamp_paths: (u32, f32),
    /// Points in the lamp paths' pool ([`crate::backend::SceneData::lamp_paths`]; 0 in a
    /// bake's graph until the pool is traced, [`with_lamp_paths`]).
    pub lamp_path_count: u32,
    /// Points of a lamp's luminous opening per texel near it, and how many of the lamps have
    /// an opening ([`DirectParams::samples`], [`DirectParams::openings`]).
    pub openings: (u32, u32),
    /// Opening samples per visibility probe ([`DirectParams::probe_stride`], from
    /// `Settings::opening_probe_stride`).
    pub opening_probe_stride: u32,
    /// [`Method::Converged`] with a lamp's opening among the lamps ([`GraphConfig::openings`]):
    /// a first direct pass with every lamp a point ([`DirectParams::points_only`]), whose
    /// result a bake hands over before the opening's direct pass runs ([`BakeGraph::preview`]).
    pub direct_preview: bool,
    /// [`Method::Converged`]: the denoiser's and refinement's power of two for luminances
    /// ([`AtrousConfig::luminance_scale`], [`crate::program::luminance_scale_for`]); 1:
    /// unscaled.
    pub luminance_scale: f32,
    /// Most rays of a texel one gather pass traces ([`GatherParams::chunk_rays`]; 0: all):
    /// [`GATHER_CHUNK_RAYS`] on a backend whose driver cuts long shader loops
    /// ([`crate::Limits::loop_iterations`]), else 0.
    pub gather_chunk: u32,
    /// Most samples of a lamp's opening one direct pass takes per texel
    /// ([`DirectParams::chunk_samples`]; 0: all): [`DIRECT_CHUNK_SAMPLES`] on a backend
    /// whose driver cuts long shader loops, else 0.
    pub direct_chunk: u32,
    /// [`Method::Converged`]: the largest side of the bounding box of the scene's geometry,
    /// metres ([`AtrousConfig::scene_size`]; 0: the denoiser never takes its wide term).
    pub scene_size: f32,
}

/// [`GraphConfig::gather_chunk`] on a loop-limited driver: 64 rays per texel and pass, a
/// factor 4–8 inside where Mesa's llvmpipe starts to cut them in a furnished room
/// ([`crate::backend::LOOP_LIMITED_SAMPLES`]).
pub const GATHER_CHUNK_RAYS: u32 = 64;

/// [`GraphConfig::direct_chunk`] on a loop-limited driver: 64 opening samples per lamp,
/// texel and pass, as many shadow rays as [`GATHER_CHUNK_RAYS`] gather rays (a shadow ray
/// stops at its first hit, so its traversal is at most a gather ray's).
pub const DIRECT_CHUNK_SAMPLES: u32 = 64;

/// The bake's textures and passes, in execution order.
#[derive(Debug, Clone, PartialEq)]
pub struct BakeGraph {
    /// Every texture array, indexed by [`TexId`].
    pub textures: Vec<TexDesc>,
    /// Passes in execution order.
    pub passes: Vec<PassDesc>,
    /// The G-buffer textures.
    pub gbuffer: GBufferTex,
    /// The Figure 5 stages.
    pub figure5: Figure5,
    /// The unblurred direct illuminance (2).
    pub direct: TexId,
    /// The final illuminance, lux, before albedo: blurred combined (7), or blurred direct (3)
    /// without bounces.
    pub illuminance: TexId,
    /// The final exitance, lm/m², after albedo: (8), or (4) without bounces.
    pub exitance: TexId,
    /// The blurred direct illuminance (3): `illuminance − this` is the (blurred) indirect part.
    pub direct_blurred: TexId,
    /// The pipeline this graph computes.
    pub method: Method,
    /// Explicit bounces the graph can run.
    pub bounces: u32,
    /// The pass after which [`BakeGraph::direct`] holds the preview of the direct light, every
    /// lamp a point ([`GraphConfig::direct_preview`]); the direct passes after it overwrite it.
    pub preview: Option<usize>,
}

/// Builds a [`BakeGraph`]: textures are added on demand, passes appended in order.
#[derive(Debug)]
struct Builder {
    layer_size: [u32; 2],
    layers: u32,
    textures: Vec<TexDesc>,
    passes: Vec<PassDesc>,
    bvh: BvhMode,
    /// When the passes appended next run.
    when: RunWhen,
}

impl Builder {
    /// An empty graph of `config`'s texture size and traversal.
    fn new(config: &GraphConfig) -> Builder {
        Builder {
            layer_size: config.layer_size,
            layers: config.layers,
            textures: Vec::new(),
            passes: Vec::new(),
            bvh: config.bvh,
            when: RunWhen::Always,
        }
    }

    fn texture(&mut self, label: &'static str) -> TexId {
        let id = TexId(self.textures.len() as u32);
        self.textures.push(TexDesc {
            label,
            size: self.layer_size,
            layers: self.layers,
            format: TexFormat::Rgba32F,
        });
        id
    }

    #[allow(clippy::too_many_arguments)]
    fn pass(
        &mut self,
        kind: PassKind,
        label: &'static str,
        reads: Vec<TexId>,
        writes: Vec<TexId>,
        bounce: u32,
        params: Params,
    ) {
        self.passes.push(PassDesc {
            kind,
            label,
            reads,
            writes,
            bounce,
            params,
            bvh: self.bvh,
            when: self.when,
            then: None,
            runtime: None,
            lamps: false,
        });
    }

    /// After every pass with a [`Check`], the two [`Program::Energy`] passes that reduce the
    /// checked texture to one texel per layer (its rows into a row of row sums, that row into
    /// one texel); the check moves onto the second, whose texture the driver reads back.
    fn reduce_checks(&mut self) {
        let passes = std::mem::take(&mut self.passes);
        let mut reductions: Option<[TexId; 2]> = None;
        for mut p in passes {
            let Some(check) = p.then.take() else {
                self.passes.push(p);
                continue;
            };
            let checked = check.texture();
            let (when, bounce) = (p.when, p.bounce);
            self.passes.push(p);
            // Two small textures, shared by every check (each is read back before the next).
            let [rows, total] = *reductions.get_or_insert_with(|| {
                [("energy_rows", [self.layer_size[1], 1]), ("energy", [1, 1])].map(
                    |(label, size)| {
                        self.textures.push(TexDesc {
                            label,
                            size,
                            layers: self.layers,
                            format: TexFormat::Rgba32F,
                        });
                        TexId(self.textures.len() as u32 - 1)
                    },
                )
            });
            self.when = when;
            for (label, read, write) in [("energy_rows", checked, rows), ("energy", rows, total)] {
                self.pass(
                    PassKind::Run(Program::Energy),
                    label,
                    vec![read],
                    vec![write],
                    bounce,
                    Params::None,
                );
            }
            self.last().then = Some(check);
        }
    }

    /// The last pass appended.
    fn last(&mut self) -> &mut PassDesc {
        self.passes
            .last_mut()
            .expect("a check or runtime parameter follows a pass")
    }

    /// The graph: every pass's [`PassDesc::lamps`] set by following the textures from the
    /// passes that compute lamp light (the direct pass and the lamp paths).
    fn finish(mut self, parts: GraphParts) -> BakeGraph {
        let GraphParts {
            gbuffer,
            figure5,
            direct,
            method,
            bounces,
        } = parts;
        let stage = |i: usize| figure5.stages[i];
        self.reduce_checks();
        let mut lit = vec![false; self.textures.len()];
        for p in &mut self.passes {
            p.lamps = matches!(
                p.kind,
                PassKind::Run(Program::Direct) | PassKind::Run(Program::Connect)
            ) || p.reads.iter().any(|r| lit[r.index()]);
            for w in &p.writes {
                lit[w.index()] |= p.lamps;
            }
        }
        let preview = self
            .passes
            .iter()
            .position(|p| matches!(p.params, Params::Direct(d) if d.points_only != 0));
        BakeGraph {
            preview,
            textures: self.textures,
            passes: self.passes,
            gbuffer,
            figure5,
            direct,
            // The last stages the graph has: (7) and (8), or (3) and (4) without bounces.
            illuminance: stage(6).or(stage(2)).unwrap_or(direct),
            exitance: stage(7).or(stage(3)).unwrap_or(direct),
            direct_blurred: stage(2).unwrap_or(direct),
            method,
            bounces,
        }
    }
}

/// What a graph builder found, besides its textures and passes: the final maps are the last
/// stages of its Figure 5.
struct GraphParts {
    gbuffer: GBufferTex,
    figure5: Figure5,
    /// The unblurred direct illuminance (2).
    direct: TexId,
    method: Method,
    bounces: u32,
}

/// Stage (1): the G-buffer textures, written by the upload of the rasteriser's output, and
/// with lamp paths the texture of their part of the first bounce ([`connect_stage`]).
fn gbuffer_stage(b: &mut Builder, lamp_paths: bool) -> GBufferTex {
    let g = GBufferTex {
        position: b.texture("gbuffer_position"),
        normal: b.texture("gbuffer_normal"),
        albedo: b.texture("gbuffer_albedo"),
        connected: lamp_paths.then(|| b.texture("lamp_paths")),
    };
    b.pass(
        PassKind::GBuffer,
        "gbuffer",
        Vec::new(),
        vec![g.position, g.normal, g.albedo],
        0,
        Params::None,
    );
    g
}

/// The lamp paths' part of the first bounce ([`Program::Connect`]), after the direct part so
/// that the direct light is ready first.
fn connect_stage(b: &mut Builder, g: GBufferTex, params: ConnectParams) {
    if let Some(connected) = g.connected {
        b.pass(
            PassKind::Run(Program::Connect),
            "connect",
            // `position` stands in for the variance map, which the first connections do not
            // read.
            vec![g.position, g.normal, g.position],
            vec![connected],
            1,
            Params::Connect(params),
        );
    }
}

/// Stage (2): direct illuminance from the first `lamp_count` uploaded lamps; with bounces,
/// its energy is measured for the bounces' checks. With [`GraphConfig::direct_chunk`] an
/// opening's samples are split over several direct passes, each adding to the one before,
/// alternating between the target and `spare` (which holds nothing live before the direct
/// light is done) so that the last lands in the target. With `preview` and a lamp's opening,
/// a first pass writes the target with every lamp a point ([`BakeGraph::preview`]).
fn direct_stage(
    b: &mut Builder,
    g: GBufferTex,
    config: &GraphConfig,
    spare: TexId,
    preview: bool,
) -> TexId {
    let direct = b.texture("direct");
    let whole = DirectParams {
        lamp_count: config.lamp_count,
        seed: config.seed,
        samples: config.openings.0,
        openings: config.openings.1,
        probe_stride: config.opening_probe_stride,
        ..DirectParams::default()
    };
    if preview && whole.openings > 0 {
        b.pass(
            PassKind::Run(Program::Direct),
            "direct_preview",
            vec![g.position, g.normal, g.position],
            vec![direct],
            0,
            Params::Direct(DirectParams {
                openings: 0,
                points_only: 1,
                ..whole
            }),
        );
    }
    let chunks = whole.chunked(config.direct_chunk);
    let mut prior = g.position;
    for (c, params) in chunks.iter().enumerate() {
        // The last chunk writes the target: count back from it, alternating.
        let out = if (chunks.len() - 1 - c).is_multiple_of(2) {
            direct
        } else {
            spare
        };
        b.pass(
            PassKind::Run(Program::Direct),
            "direct",
            // Before the first chunk nothing is added: `position` stands in for `prior`.
            vec![g.position, g.normal, prior],
            vec![out],
            0,
            Params::Direct(*params),
        );
        prior = out;
    }
    if config.bounces > 0 {
        b.last().then = Some(Check::DirectEnergy(direct));
    }
    direct
}

/// Copy `src` into `dst`, then blur `dst` in place through `tmp` (U then V): stages (3), (7).
#[allow(clippy::too_many_arguments)]
fn blur_stage(
    b: &mut Builder,
    g: GBufferTex,
    src: TexId,
    dst: TexId,
    tmp: Option<TexId>,
    blur: Blur,
    bounce: u32,
    labels: [&'static str; 3],
) {
    b.pass(
        PassKind::Run(Program::Copy),
        labels[0],
        vec![src],
        vec![dst],
        bounce,
        Params::None,
    );
    if let (Blur::Sigma(sigma), Some(tmp)) = (blur, tmp) {
        for (step, from, to, label) in
            [([1, 0], dst, tmp, labels[1]), ([0, 1], tmp, dst, labels[2])]
        {
            b.pass(
                PassKind::Run(Program::Blur),
                label,
                vec![from, g.normal],
                vec![to],
                bounce,
                Params::Blur(blur_params(step, sigma)),
            );
        }
    }
}

/// × albedo: stages (4), (8).
fn albedo_stage(
    b: &mut Builder,
    g: GBufferTex,
    src: TexId,
    dst: TexId,
    bounce: u32,
    label: &'static str,
) {
    b.pass(
        PassKind::Run(Program::AlbedoMul),
        label,
        vec![src, g.albedo],
        vec![dst],
        bounce,
        Params::None,
    );
}

/// How one gather samples: rays per texel, and the grid of a reduced-resolution gather.
#[derive(Debug, Clone, Copy)]
struct GatherSampling {
    rays: u32,
    seed: u32,
    sampler: Sampler,
    /// Grid stride (1: every texel) and its chart reach, metres.
    stride: u32,
    reach: f32,
    /// Lamp paths combined with this gather, their density scale and the uploaded lamps
    /// ([`GatherParams::lamp_paths`]); 0 paths: none.
    lamp_paths: (u32, f32, u32),
    /// Most rays of a texel per dispatch ([`GraphConfig::gather_chunk`]); 0: all at once.
    chunk: u32,
    /// [`GatherParams::direct_at_hits`].
    direct_at_hits: bool,
    /// A later bounce's further rays at the texels in narrow gaps (which a reduced gather
    /// gathers at full resolution with `rays`): a refine pass after the gather, before the
    /// upsample of a reduced one ([`RefineParams::narrow_rays`]); 0: none.
    narrow_rays: u32,
}

/// Stage (5): one bounce of indirect light gathered from `reflected` into `indirect`; a
/// reduced-resolution gather goes through `coarse` and is upsampled into `indirect`. With
/// [`GatherSampling::chunk`] a texel's rays are split over several gather passes, each adding
/// to the one before, alternating between the target and `spare` (which holds nothing live
/// during the gather) so that the last lands in the target. With
/// [`GatherSampling::narrow_rays`] the texels in narrow gaps get that many more rays: the
/// gather writes `coarse`, and the refine pass reads it and writes `spare`, which the upsample
/// then reads, or at full resolution `indirect`.
fn gather_stage(
    b: &mut Builder,
    g: GBufferTex,
    [reflected, indirect, coarse, spare]: [TexId; 4],
    bounce: u32,
    sampling: GatherSampling,
) {
    let reduced = sampling.stride > 1;
    let (paths, density_scale, lamps) = sampling.lamp_paths;
    // Without lamp paths the `connected` slot is not read: `reflected` stands in for it.
    let connected = match g.connected {
        Some(c) if paths > 0 => c,
        _ => reflected,
    };
    // A refined gather goes through `coarse` too, the refinement writing what it read on.
    let refined = sampling.narrow_rays > 0;
    let target = if reduced || refined { coarse } else { indirect };
    let orphan_rays = coarse::orphan_rays(sampling.rays, sampling.stride);
    let most = sampling.rays.max(orphan_rays);
    let chunks = if sampling.chunk > 0 {
        most.div_ceil(sampling.chunk).max(1)
    } else {
        1
    };
    debug_assert!(
        chunks == 1 || spare != target,
        "a split gather needs a spare texture"
    );
    let mut prior = reflected;
    for c in 0..chunks {
        // The last chunk writes the target: count back from it, alternating.
        let out = if (chunks - 1 - c).is_multiple_of(2) {
            target
        } else {
            spare
        };
        b.pass(
            PassKind::Run(Program::Gather),
            "gather",
            // Before the first chunk nothing is added: `reflected` stands in for `prior`.
            vec![g.position, g.normal, reflected, connected, prior, g.albedo],
            vec![out],
            bounce,
            Params::Gather(GatherParams {
                rays: sampling.rays,
                bounce,
                seed: sampling.seed,
                sampler: sampling.sampler.id(),
                stride: sampling.stride.max(1),
                reach: sampling.reach,
                orphan_rays,
                lamp_paths: if g.connected.is_some() { paths } else { 0 },
                density_scale,
                lamp_count: lamps,
                first_ray: c * sampling.chunk,
                chunk_rays: if chunks > 1 { sampling.chunk } else { 0 },
                direct_at_hits: u32::from(sampling.direct_at_hits),
                ..GatherParams::default()
            }),
        );
        prior = out;
    }
    let coarse = if refined {
        debug_assert!(spare != coarse, "a refined gather needs a spare texture");
        // At full resolution the refinement writes the bounce itself.
        let out = if reduced { spare } else { indirect };
        // The refine pass copies every other texel as it is; the slots it does not read
        // (no variance estimate, no lamp paths) take `coarse`.
        b.pass(
            PassKind::Run(Program::Refine),
            "refine_narrow",
            vec![
                g.position, g.normal, reflected, coarse, coarse, coarse, g.albedo,
            ],
            vec![out],
            bounce,
            Params::Refine(RefineParams {
                bounce,
                seed: sampling.seed,
                sampler: sampling.sampler.id(),
                first_rays: sampling.rays,
                narrow_rays: sampling.narrow_rays,
                direct_at_hits: u32::from(sampling.direct_at_hits),
                ..RefineParams::default()
            }),
        );
        out
    } else {
        coarse
    };
    if reduced {
        b.pass(
            PassKind::Run(Program::Upsample),
            "upsample",
            vec![coarse, g.position, g.normal],
            vec![indirect],
            bounce,
            Params::Upsample(UpsampleParams {
                stride: sampling.stride,
                reach: sampling.reach,
                ..UpsampleParams::default()
            }),
        );
    }
}

/// Stage (6): direct + indirect.
fn combine_stage(b: &mut Builder, direct: TexId, indirect: TexId, combined: TexId, bounce: u32) {
    b.pass(
        PassKind::Run(Program::Combine),
        "combine",
        vec![direct, indirect],
        vec![combined],
        bounce,
        Params::Combine(CombineParams::SUM),
    );
}

/// The à-trous iterations of the converged method's filter for `blur`: none for
/// [`Blur::None`], else `3 + round(log2 σ)` within `1 ..= MAX_ATROUS_ITERATIONS` (σ 2: four
/// iterations, taps up to ±30 texels; σ 1: three).
pub fn atrous_iterations(blur: Blur) -> u32 {
    match blur {
        Blur::Sigma(sigma) if sigma > 0.0 && sigma.is_finite() => {
            (3.0 + sigma.log2().round()).clamp(1.0, MAX_ATROUS_ITERATIONS as f32) as u32
        }
        _ => 0,
    }
}

/// Denoises `noisy` and returns the texture that holds the result: the variance estimate into
/// `variance` (with `direct`, the direct light, in its alpha as the variance pass always
/// writes it), then the à-trous iterations. Without the bias correction
/// ([`correction_steps`]) they alternate between `scratch` and `noisy`, ending in `noisy`;
/// with it they alternate between `scratch` and a texture of its own (`residual`), keeping
/// the noisy map `x` for the luminances of `x` and of their result `y`, whose linear filter
/// `B` ping-pongs between `noisy` and the spare; `y · B(L(x)) / B(L(y))` goes to the texture
/// left free.
#[allow(clippy::too_many_arguments)]
fn denoise_stage(
    b: &mut Builder,
    g: GBufferTex,
    noisy: TexId,
    scratch: TexId,
    variance: TexId,
    direct: TexId,
    config: &AtrousConfig,
    bounce: u32,
) -> TexId {
    let correction = correction_steps(config);
    // The iterations alternate between `noisy` and `scratch`, or, to keep `x` for the
    // correction's residual, between `scratch` and another spare.
    let ping = if correction.is_empty() {
        [noisy, scratch]
    } else {
        [scratch, b.texture("residual")]
    };
    let mut current = noisy;
    // `atrous_steps` yields the variance estimate, then the iterations.
    for (_, params) in atrous_steps(config) {
        match params {
            Params::Variance(_) => b.pass(
                PassKind::Run(Program::Variance),
                "variance",
                vec![noisy, g.position, g.normal, direct],
                vec![variance],
                bounce,
                params,
            ),
            Params::Atrous(_) => {
                let target = if current == ping[1] { ping[0] } else { ping[1] };
                b.pass(
                    PassKind::Run(Program::Atrous),
                    "atrous",
                    vec![current, variance, g.position, g.normal],
                    vec![target],
                    bounce,
                    params,
                );
                current = target;
            }
            _ => {}
        }
    }
    if !correction.is_empty() {
        return correct_stage(b, g, [noisy, current], ping, variance, &correction, bounce);
    }
    if current != noisy {
        b.pass(
            PassKind::Run(Program::Copy),
            "atrous_copy",
            vec![current],
            vec![noisy],
            bounce,
            Params::None,
        );
    }
    noisy
}

/// The bias correction `y · B(L(x)) / B(L(y))` ([`correction_steps`]) of the à-trous
/// filter's output `y` from the noisy map `x` (`[x, y]`), through `x`'s texture and the spare
/// `y` is not in: returns the texture of the result.
fn correct_stage(
    b: &mut Builder,
    g: GBufferTex,
    [noisy, y]: [TexId; 2],
    spare: [TexId; 2],
    variance: TexId,
    correction: &[(Program, Params)],
    bounce: u32,
) -> TexId {
    let textures = [noisy, spare[0], spare[1]];
    let other = |a: TexId, b: TexId| -> TexId {
        *textures
            .iter()
            .find(|&&t| t != a && t != b)
            .expect("three textures")
    };
    // The luminances of `x` and `y` side by side (the pass keeps its label, "residual": what
    // `B` filters), into the spare `y` is not in.
    let mut pair = other(noisy, y);
    b.pass(
        PassKind::Run(Program::Combine),
        "residual",
        vec![noisy, y],
        vec![pair],
        bounce,
        Params::Combine(CombineParams::PAIR),
    );
    // `B` of both, between that spare and `noisy` (`x` is no longer read).
    for &(_, params) in correction {
        let target = other(y, pair);
        b.pass(
            PassKind::Run(Program::Atrous),
            "correction",
            vec![pair, variance, g.position, g.normal],
            vec![target],
            bounce,
            params,
        );
        pair = target;
    }
    let out = other(y, pair);
    b.pass(
        PassKind::Run(Program::Combine),
        "corrected",
        vec![y, pair],
        vec![out],
        bounce,
        Params::Combine(CombineParams::RATIO),
    );
    out
}

/// The converged pipeline ([`Method::Converged`], see the module docs).
fn build_converged(config: &GraphConfig) -> BakeGraph {
    let mut b = Builder::new(config);
    let refine = config.refine.filter(|&(rays, _)| rays > 0);
    // A bounce's further rays in narrow gaps, up to its share of `narrow_rays` there, within
    // the budget.
    let narrow_more = |rays: u32, bounce: u32| {
        crate::passes::refine::narrow_more(
            crate::passes::refine::narrow_rays_in(config.narrow_rays, bounce),
            rays,
            config.rays,
            config.narrow_texels,
        )
    };
    // Without the direct light at every hit, the first bounce's texels in narrow gaps take
    // their refinement's estimate alone, which reads the direct light at its hits
    // ([`RefineParams::narrow_direct`]): all their rays are the refinement's.
    let narrow_direct = !config.direct_at_hits;
    let narrow = if config.stride <= 1 && narrow_more(config.rays, 1) > 0 {
        narrow_more(if narrow_direct { 0 } else { config.rays }, 1)
    } else {
        0
    };
    // The rays of a texel in a narrow gap in the first bounce (for the denoiser's early term).
    let narrow_total = match narrow {
        0 => config.rays,
        n if narrow_direct => n,
        n => config.rays + n,
    };
    // The first bounce's refinement: `(rays by noise, target, rays in narrow gaps)`, when
    // either applies.
    let refinement = (refine.is_some() || narrow > 0).then(|| {
        let (more, max_error) = refine.unwrap_or((0, 0.0));
        (more, max_error, narrow)
    });
    let lamp_paths = config.lamp_paths.0 > 0 && config.bounces > 0 && config.stride <= 1;
    let g = gbuffer_stage(&mut b, lamp_paths);
    // The direct light carries no Monte Carlo noise: it is reflected unfiltered. Until then
    // its texture is the split direct pass's spare.
    let reflected_direct = b.texture("reflected_direct");
    let direct = direct_stage(&mut b, g, config, reflected_direct, config.direct_preview);
    albedo_stage(&mut b, g, direct, reflected_direct, 0, "albedo_direct");
    let connect = ConnectParams {
        rays: config.rays,
        k: config.lamp_paths.0,
        seed: config.seed,
        count: config.lamp_path_count,
        density_scale: config.lamp_paths.1,
        ..ConnectParams::default()
    };
    connect_stage(&mut b, g, connect);
    let mut figure5 = Figure5::direct_part([g.albedo, direct, direct, reflected_direct]);
    if config.bounces > 0 {
        // Bounce k gathers the reflected increment of bounce k − 1 (the direct light's first).
        let reflected = b.texture("reflected");
        let delta = b.texture("delta");
        let scratch = b.texture("scratch");
        // The running sum alternates between two textures (no copy per bounce).
        let sums = [
            b.texture("indirect_sum"),
            if config.bounces > 1 {
                b.texture("indirect_sum_b")
            } else {
                // Unused: one bounce only ever writes the first.
                delta
            },
        ];
        let denoise = AtrousConfig {
            texel_size: config.texel_size,
            scene_size: config.scene_size,
            luminance_scale: config.luminance_scale,
            ..AtrousConfig::for_rays(
                atrous_iterations(config.blur),
                config.texel_size[0],
                config.rays,
            )
            .with_correction(config.denoise_correction)
            .with_narrow_rays(narrow_total)
        };
        let variance = (denoise.iterations > 0 || refine.is_some()).then(|| b.texture("variance"));
        // At full resolution the later bounces' refinements in narrow gaps need it too.
        let later_narrow = config.bounces > 1 && narrow_more(config.higher_rays, 2) > 0;
        let coarse = (config.stride > 1
            || (config.bounces > 1 && (config.higher_stride > 1 || later_narrow)))
            .then(|| b.texture("coarse"));
        for k in 1..=config.bounces {
            b.when = RunWhen::Bounce(k);
            let source = if k == 1 { reflected_direct } else { reflected };
            let sampling = GatherSampling {
                rays: if k == 1 {
                    config.rays
                } else {
                    config.higher_rays
                },
                seed: config.seed,
                sampler: config.sampler,
                stride: if k == 1 {
                    config.stride
                } else {
                    config.higher_stride
                },
                reach: denoise.reach(),
                lamp_paths: if k == 1 {
                    (config.lamp_paths.0, config.lamp_paths.1, config.lamp_count)
                } else {
                    (0, 0.0, 0)
                },
                chunk: config.gather_chunk,
                direct_at_hits: k == 1 && config.direct_at_hits,
                // The later bounces' gathers: their texels in narrow gaps up to their share
                // of `narrow_rays` (the first bounce's are refined below).
                narrow_rays: if k > 1 {
                    narrow_more(config.higher_rays, k)
                } else {
                    0
                },
            };
            // The next bounce gathers this increment as it is: its noise averages out in the
            // gather (unbiased); only what is reported is denoised, once, at the end.
            match (k, refinement) {
                (1, Some((more, max_error, narrow_more))) if config.stride <= 1 => {
                    // Progressive refinement: the first gather into `scratch`, its variance
                    // estimate (when texels are refined by their noise), then more rays where
                    // the estimate misses the target and in narrow gaps (`delta`, which the
                    // refinement writes last, is free until then).
                    gather_stage(&mut b, g, [source, scratch, scratch, delta], k, sampling);
                    // Without refinement by noise the slot is not read: the first gather
                    // stands in for it.
                    let variance = match variance.filter(|_| more > 0) {
                        Some(variance) => {
                            b.pass(
                                PassKind::Run(Program::Variance),
                                "refine_variance",
                                vec![scratch, g.position, g.normal, direct],
                                vec![variance],
                                k,
                                Params::Variance(VarianceParams {
                                    reach: denoise.reach(),
                                    min_pairs: ATROUS_MIN_PAIRS,
                                    luminance_scale: denoise.luminance_scale(),
                                    ..VarianceParams::default()
                                }),
                            );
                            variance
                        }
                        None => scratch,
                    };
                    // With lamp paths the second estimate's connections, at the texels the
                    // refinement refines (`Program::Refine`, module docs).
                    let connected = g.connected.map(|_| {
                        let second = b.texture("refine_connected");
                        b.pass(
                            PassKind::Run(Program::Connect),
                            "refine_connect",
                            vec![g.position, g.normal, variance],
                            vec![second],
                            k,
                            Params::Connect(connect.refinement(more, max_error, narrow_more)),
                        );
                        second
                    });
                    b.pass(
                        PassKind::Run(Program::Refine),
                        "refine",
                        // The second estimate's connections (without lamp paths the slot is
                        // not read: `source` stands in for it).
                        vec![
                            g.position,
                            g.normal,
                            source,
                            scratch,
                            variance,
                            connected.unwrap_or(source),
                            g.albedo,
                        ],
                        vec![delta],
                        k,
                        Params::Refine(RefineParams {
                            rays: more,
                            bounce: k,
                            seed: config.seed,
                            sampler: config.sampler.id(),
                            first_rays: config.rays,
                            max_error,
                            lamp_paths: if g.connected.is_some() {
                                sampling.lamp_paths.0
                            } else {
                                0
                            },
                            density_scale: sampling.lamp_paths.1,
                            lamp_count: sampling.lamp_paths.2,
                            direct_at_hits: u32::from(sampling.direct_at_hits),
                            narrow_rays: narrow_more,
                            narrow_direct: u32::from(narrow_more > 0 && narrow_direct),
                        }),
                    );
                }
                // `scratch` holds nothing live during a bounce's gather (the tail writes it
                // only when the bake stops).
                _ => gather_stage(
                    &mut b,
                    g,
                    [source, delta, coarse.unwrap_or(scratch), scratch],
                    k,
                    sampling,
                ),
            }
            let sum = sums[(k as usize - 1) % 2];
            if k == 1 {
                b.pass(
                    PassKind::Run(Program::Copy),
                    "accumulate",
                    vec![delta],
                    vec![sum],
                    k,
                    Params::None,
                );
            } else {
                b.pass(
                    PassKind::Run(Program::Combine),
                    "accumulate",
                    vec![sums[k as usize % 2], delta],
                    vec![sum],
                    k,
                    Params::Combine(CombineParams::SUM),
                );
            }
            b.last().then = Some(Check::Increment { bounce: k, delta });
            albedo_stage(&mut b, g, delta, reflected, k, "albedo_delta");
            b.last().then = Some(Check::ConvergedBounce {
                bounce: k,
                reflected,
                last: k == config.bounces,
            });
            // The tail Σ_{j>k} Δ_j ≈ f · Δ_k when the bake stops at bounce k; the driver
            // decides f ([`Runtime::TailWeight`]).
            b.when = RunWhen::StoppedAt(k);
            b.pass(
                PassKind::Run(Program::Combine),
                "tail",
                vec![sum, delta],
                vec![scratch],
                k,
                Params::Combine(CombineParams {
                    b_weight: 0.0,
                    ..CombineParams::SUM
                }),
            );
            b.last().runtime = Some(Runtime::TailWeight);
        }
        b.when = RunWhen::Always;
        // The indirect light (explicit bounces and tail) is noisy: denoise it through
        // `delta`, which nothing reads any more.
        let indirect = match variance {
            Some(variance) => denoise_stage(
                &mut b,
                g,
                scratch,
                delta,
                variance,
                direct,
                &denoise,
                config.bounces,
            ),
            None => scratch,
        };
        let combined = b.texture("combined");
        combine_stage(&mut b, direct, indirect, combined, config.bounces);
        let reflected_combined = b.texture("reflected_combined");
        albedo_stage(
            &mut b,
            g,
            combined,
            reflected_combined,
            config.bounces,
            "albedo_combined",
        );
        figure5.stages[4..]
            .copy_from_slice(&[indirect, combined, combined, reflected_combined].map(Some));
    }
    b.finish(GraphParts {
        gbuffer: g,
        figure5,
        direct,
        method: Method::Converged,
        bounces: config.bounces,
    })
}

/// `params` with the lamp paths' pool once traced (`pool`: its points and density scale,
/// [`crate::prepare::Lamps::pool`]; the graph is built before, with 0 for both): a connect
/// pass's count and density scale, and the density scale of a gather or a refinement that
/// combines lamp paths; anything else unchanged.
pub fn with_lamp_paths(params: Params, pool: Option<(u32, f32)>) -> Params {
    match (params, pool) {
        (Params::Connect(c), Some((count, density_scale))) => Params::Connect(ConnectParams {
            count,
            density_scale,
            ..c
        }),
        (Params::Gather(g), Some((_, density_scale))) if g.lamp_paths > 0 => {
            Params::Gather(GatherParams { density_scale, ..g })
        }
        (Params::Refine(r), Some((_, density_scale))) if r.lamp_paths > 0 => {
            Params::Refine(RefineParams { density_scale, ..r })
        }
        (p, _) => p,
    }
}

impl BakeGraph {
    /// The graph with the traced lamp paths' pool in its passes ([`with_lamp_paths`]).
    pub fn with_lamp_paths(mut self, pool: Option<(u32, f32)>) -> BakeGraph {
        for p in &mut self.passes {
            p.params = with_lamp_paths(p.params, pool);
        }
        self
    }

    /// Builds the graph of `config.method`'s pipeline (see the module docs).
    pub fn build(config: &GraphConfig) -> BakeGraph {
        if config.method == Method::Converged {
            return build_converged(config);
        }
        let mut b = Builder::new(config);
        let g = gbuffer_stage(&mut b, false);
        // Written after the direct light: until then the split direct pass's spare.
        let direct_blurred = b.texture("direct_blurred");
        // The paper's direct light is handed over blurred: no preview before it.
        let direct = direct_stage(&mut b, g, config, direct_blurred, false);
        let blurs = matches!(config.blur, Blur::Sigma(s) if s > 0.0 && s.is_finite());
        // The blur scratch texture exists only when a blur runs.
        let tmp = blurs.then(|| b.texture("blur_tmp"));
        blur_stage(
            &mut b,
            g,
            direct,
            direct_blurred,
            tmp,
            config.blur,
            0,
            ["copy_direct", "blur_direct_u", "blur_direct_v"],
        );
        let reflected_direct = b.texture("reflected_direct");
        albedo_stage(
            &mut b,
            g,
            direct_blurred,
            reflected_direct,
            0,
            "albedo_direct",
        );

        let mut figure5 =
            Figure5::direct_part([g.albedo, direct, direct_blurred, reflected_direct]);
        if config.bounces > 0 {
            let indirect = b.texture("indirect");
            let combined = b.texture("combined");
            let combined_blurred = b.texture("combined_blurred");
            let reflected_combined = b.texture("reflected_combined");
            for k in 1..=config.bounces {
                b.when = RunWhen::Bounce(k);
                let reflected = if k == 1 {
                    reflected_direct
                } else {
                    reflected_combined
                };
                let sampling = GatherSampling {
                    rays: config.rays,
                    seed: config.seed,
                    sampler: config.sampler,
                    stride: 1,
                    reach: 0.0,
                    lamp_paths: (0, 0.0, 0),
                    chunk: config.gather_chunk,
                    direct_at_hits: false,
                    narrow_rays: 0,
                };
                // `combined` is rewritten from this gather's result: free during it.
                gather_stage(
                    &mut b,
                    g,
                    [reflected, indirect, indirect, combined],
                    k,
                    sampling,
                );
                combine_stage(&mut b, direct, indirect, combined, k);
                blur_stage(
                    &mut b,
                    g,
                    combined,
                    combined_blurred,
                    tmp,
                    config.blur,
                    k,
                    ["copy_combined", "blur_combined_u", "blur_combined_v"],
                );
                albedo_stage(
                    &mut b,
                    g,
                    combined_blurred,
                    reflected_combined,
                    k,
                    "albedo_combined",
                );
                b.last().then = Some(Check::PaperBounce {
                    bounce: k,
                    indirect,
                    last: k == config.bounces,
                });
            }
            figure5.stages[4..].copy_from_slice(
                &[indirect, combined, combined_blurred, reflected_combined].map(Some),
            );
        }
        b.finish(GraphParts {
            gbuffer: g,
            figure5,
            direct,
            method: Method::Paper,
            bounces: config.bounces,
        })
    }

    /// Every pass of bounce `k` (`RunWhen::Bounce(k)`), in order.
    pub fn bounce(&self, k: u32) -> impl Iterator<Item = &PassDesc> {
        self.passes
            .iter()
            .filter(move |p| p.when == RunWhen::Bounce(k))
    }

    /// The description of texture `id`, if it belongs to this graph.
    pub fn texture(&self, id: TexId) -> Option<&TexDesc> {
        self.textures.get(id.index())
    }

    /// Checks every pass against its program's [`Signature`](crate::program::Signature): as
    /// many reads as slots, one write (three for the G-buffer), the program's parameter block,
    /// textures of the graph of one size, nothing read that is written by the same pass or
    /// not written before.
    pub fn validate(&self) -> Result<(), GraphError> {
        let mut written = vec![false; self.textures.len()];
        for (index, p) in self.passes.iter().enumerate() {
            let fail = |reason: String| GraphError {
                index,
                label: p.label,
                reason,
            };
            match p.kind.program() {
                None => {
                    let uploads = if p.kind == PassKind::GBuffer { 3 } else { 1 };
                    if !p.reads.is_empty() || p.writes.len() != uploads || p.params != Params::None
                    {
                        return Err(fail(
                            "an upload reads nothing, takes no parameters and writes three \
                             textures (the G-buffer) or one (the lamp paths)"
                                .into(),
                        ));
                    }
                }
                Some(program) => {
                    let sig = program.signature();
                    if p.reads.len() != sig.reads.len() {
                        return Err(fail(format!(
                            "reads {} textures, program `{}` has the slots {:?}",
                            p.reads.len(),
                            program.label(),
                            sig.reads
                        )));
                    }
                    if p.writes.len() != 1 {
                        return Err(fail(format!("writes {} textures, not 1", p.writes.len())));
                    }
                    if !program.takes(&p.params) {
                        return Err(fail(format!(
                            "parameters {:?} are not the block of program `{}`",
                            p.params,
                            program.label()
                        )));
                    }
                }
            }
            if p.runtime == Some(Runtime::TailWeight) && !matches!(p.params, Params::Combine(_)) {
                return Err(fail("only a combine takes the tail weight".into()));
            }
            if let Some(check) = p.then {
                let t = check.texture();
                if self.texture(t).is_none() {
                    return Err(fail(format!(
                        "its check reads texture {}, not in the graph",
                        t.0
                    )));
                }
            }
            let first = p.writes.first().and_then(|&w| self.texture(w));
            // A reduction writes a smaller texture than it reads, with as many layers.
            let reduces = p.kind == PassKind::Run(Program::Energy);
            for &t in p.reads.iter().chain(&p.writes) {
                let Some(desc) = self.texture(t) else {
                    return Err(fail(format!("texture {} is not in the graph", t.0)));
                };
                let differs =
                    |f: &TexDesc| f.layers != desc.layers || (!reduces && f.size != desc.size);
                if first.is_some_and(differs) {
                    return Err(fail(format!("texture `{}` differs in size", desc.label)));
                }
            }
            for r in &p.reads {
                if p.writes.contains(r) {
                    return Err(fail(format!("reads the texture {} it writes", r.0)));
                }
                if !written[r.index()] {
                    return Err(fail(format!(
                        "reads texture {} before any pass wrote it",
                        r.0
                    )));
                }
            }
            for w in &p.writes {
                written[w.index()] = true;
            }
        }
        Ok(())
    }
}

/// A pass that breaks its program's signature ([`BakeGraph::validate`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("pass {index} `{label}`: {reason}")]
pub struct GraphError {
    /// Index of the pass.
    pub index: usize,
    /// Its label.
    pub label: &'static str,
    /// What is wrong.
    pub reason: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The graph's gather passes, in order.
    fn gather_passes(g: &BakeGraph) -> Vec<&PassDesc> {
        g.passes
            .iter()
            .filter(|p| p.kind == PassKind::Run(Program::Gather))
            .collect()
    }

    /// The labels of bounce `k`'s passes (`k` 0-based).
    fn labels(g: &BakeGraph, k: usize) -> Vec<&'static str> {
        g.bounce(k as u32 + 1).map(|p| p.label).collect()
    }

    /// The first pass of bounce `k` (0-based) and those after it.
    fn bounce_from(g: &BakeGraph, k: usize) -> &[PassDesc] {
        let first = g
            .passes
            .iter()
            .position(|p| p.when == RunWhen::Bounce(k as u32 + 1))
            .expect("bounce");
        &g.passes[first..]
    }

    /// The converged graph's increment: what its increment checks measure.
    fn delta(g: &BakeGraph) -> Option<TexId> {
        g.passes.iter().find_map(|p| match p.then {
            Some(Check::Increment { delta, .. }) => Some(delta),
            _ => None,
        })
    }

    /// The converged graph's reflected increment: what its bounce checks measure.
    fn reflected(g: &BakeGraph) -> Option<TexId> {
        g.passes.iter().find_map(|p| match p.then {
            Some(Check::ConvergedBounce { reflected, .. }) => Some(reflected),
            _ => None,
        })
    }

    /// The passes that run once the bounces are done, whenever they stop.
    fn finish(g: &BakeGraph) -> &[PassDesc] {
        let end = g
            .passes
            .iter()
            .rposition(|p| p.when != RunWhen::Always)
            .map_or(0, |i| i + 1);
        &g.passes[end..]
    }

    fn config(bounces: u32, blur: Blur) -> GraphConfig {
        GraphConfig {
            layer_size: [64, 32],
            layers: 2,
            lamp_count: 2,
            rays: 16,
            bounces,
            blur,
            seed: 9,
            bvh: BvhMode::Mtbvh,
            method: Method::Paper,
            higher_rays: 4,
            stride: 1,
            higher_stride: 1,
            refine: None,
            narrow_rays: 0,
            narrow_texels: [0, 0],
            denoise_correction: false,
            direct_at_hits: false,
            texel_size: [1.0 / 64.0; 2],
            sampler: Sampler::Sobol,
            lamp_paths: (0, 0.0),
            lamp_path_count: 0,
            openings: (0, 0),
            opening_probe_stride: 0,
            direct_preview: false,
            luminance_scale: 1.0,
            gather_chunk: 0,
            direct_chunk: 0,
            scene_size: 4.0,
        }
    }

    #[test]
    fn reduced_resolution_gathers_are_upsampled_and_refinement_follows_the_first_gather() {
        // Stride 2, then 4: every gather writes the grid texture, an upsample fills `delta`.
        let g = BakeGraph::build(&GraphConfig {
            stride: 2,
            higher_stride: 4,
            ..converged(3, Blur::Sigma(1.0))
        });
        assert_eq!(g.validate(), Ok(()));
        let increment = delta(&g).expect("delta");
        for k in 0..3 {
            assert_eq!(
                labels(&g, k)[..2],
                ["gather", "upsample"],
                "bounce {}",
                k + 1
            );
            let (gather, up) = (&bounce_from(&g, k)[0], &bounce_from(&g, k)[1]);
            let (Params::Gather(gp), Params::Upsample(up_params)) = (gather.params, up.params)
            else {
                panic!("{:?} {:?}", gather.params, up.params)
            };
            let stride = if k == 0 { 2 } else { 4 };
            assert_eq!((gp.stride, up_params.stride), (stride, stride));
            assert_eq!(gp.reach, up_params.reach);
            assert!(gp.reach > 0.0);
            assert_eq!(up.reads[0], gather.writes[0]);
            assert_ne!(gather.writes[0], increment);
            assert_eq!(up.writes[0], increment);
        }
        // Refinement: gather, its variance, then the refine pass into `delta`; later bounces
        // unchanged.
        let g = BakeGraph::build(&GraphConfig {
            refine: Some((8, 0.1)),
            ..converged(2, Blur::None)
        });
        assert_eq!(g.validate(), Ok(()));
        assert_eq!(labels(&g, 0)[..3], ["gather", "refine_variance", "refine"]);
        assert_eq!(labels(&g, 1)[0], "gather");
        let [first, variance, refine, ..] = bounce_from(&g, 0) else {
            panic!("bounce 1")
        };
        let Params::Refine(rp) = refine.params else {
            panic!("{:?}", refine.params)
        };
        assert_eq!((rp.rays, rp.first_rays, rp.max_error), (8, 16, 0.1));
        assert_eq!(variance.reads[0], first.writes[0]);
        // Refinement weighs the noise against the direct light (the variance's alpha).
        assert_eq!(variance.reads[3], g.direct);
        assert_eq!(refine.reads[3..5], [first.writes[0], variance.writes[0]]);
        assert_eq!(rp.lamp_paths, 0);
        assert_eq!(Some(refine.writes[0]), delta(&g));
        // With lamp paths the refinement weights its rays against them and reads its own
        // connections: K·rays/N further picks at the refined texels (the connect pass with
        // `picks`, after the variance estimate); the traced pool reaches both.
        let g = BakeGraph::build(&GraphConfig {
            refine: Some((8, 0.1)),
            lamp_paths: (12, 0.0),
            ..converged(2, Blur::None)
        });
        assert_eq!(g.validate(), Ok(()));
        let labels_1 = labels(&g, 0);
        assert_eq!(
            labels_1[..4],
            ["gather", "refine_variance", "refine_connect", "refine"]
        );
        let pass = |label: &str| g.passes.iter().find(|p| p.label == label).expect(label);
        let (refine, second) = (pass("refine"), pass("refine_connect"));
        assert_eq!(refine.reads[5], second.writes[0]);
        assert_ne!(second.writes[0], pass("connect").writes[0]);
        assert_eq!(second.reads[2], pass("refine_variance").writes[0]);
        let Params::Refine(rp) = with_lamp_paths(refine.params, Some((100, 0.5))) else {
            panic!("{:?}", refine.params)
        };
        assert_eq!((rp.lamp_paths, rp.density_scale), (12, 0.5));
        let Params::Connect(cp) = with_lamp_paths(second.params, Some((100, 0.5))) else {
            panic!("{:?}", second.params)
        };
        assert_eq!(
            (
                cp.k,
                cp.picks,
                cp.rays,
                cp.max_error,
                cp.count,
                cp.density_scale
            ),
            (12, 6, 16, 0.1, 100, 0.5)
        );
        // Refinement needs a gather at every texel: with a stride it is not built (settings
        // reject the combination before).
        let g = BakeGraph::build(&GraphConfig {
            refine: Some((8, 0.1)),
            stride: 2,
            ..converged(2, Blur::None)
        });
        assert!(g.passes.iter().all(|p| p.label != "refine"));
    }

    /// Rays in narrow gaps alone: the first bounce's refinement without its variance
    /// estimate (the slot reads the first gather, which the passes do not read for it), the
    /// later bounces' reduced gathers refined between gather and upsample, the counts up to
    /// `narrow_rays` in the refine and connect parameters (halved from the third bounce on),
    /// and the denoiser's early term
    /// narrowed for those texels by their rays; with strides of 1 and 2 in turn, or with none
    /// asked, no refinement of that bounce and the denoiser's terms as without.
    #[test]
    fn narrow_gaps_are_refined_without_a_variance_estimate() {
        use crate::program::{ATROUS_EARLY_ITERATIONS, AtrousParams};
        let base = GraphConfig {
            rays: 8,
            higher_rays: 16,
            higher_stride: 4,
            lamp_paths: (4, 0.0),
            // 1 % of the texels in narrow gaps: within the budget.
            narrow_texels: [100, 10_000],
            ..converged(4, Blur::Sigma(1.0))
        };
        let g = BakeGraph::build(&GraphConfig {
            narrow_rays: 64,
            ..base
        });
        assert_eq!(g.validate(), Ok(()));
        assert_eq!(labels(&g, 0)[..3], ["gather", "refine_connect", "refine"]);
        let pass = |label: &str| g.passes.iter().find(|p| p.label == label).expect(label);
        let (first, refine, second) = (pass("gather"), pass("refine"), pass("refine_connect"));
        assert_eq!(refine.reads[3..5], [first.writes[0], first.writes[0]]);
        assert_eq!(second.reads[2], first.writes[0]);
        assert_eq!(refine.reads[5], second.writes[0]);
        let Params::Refine(rp) = refine.params else {
            panic!("{:?}", refine.params)
        };
        // Up to 64 rays, all the refinement's: its estimate alone, reading the direct light
        // at its hits, stands for the texel's first bounce.
        assert_eq!(
            (rp.rays, rp.narrow_rays, rp.first_rays, rp.narrow_direct),
            (0, 64, 8, 1)
        );
        let Params::Connect(cp) = second.params else {
            panic!("{:?}", second.params)
        };
        // K · 64 / N = 4 · 64 / 8.
        assert_eq!((cp.k, cp.picks, cp.narrow_picks), (4, 0, 32));
        // With the direct light at every hit the first gather's rays count: 56 more.
        let at_hits = BakeGraph::build(&GraphConfig {
            narrow_rays: 64,
            direct_at_hits: true,
            ..base
        });
        let Params::Refine(rp) = at_hits
            .passes
            .iter()
            .find(|p| p.label == "refine")
            .expect("refine")
            .params
        else {
            panic!("not a refinement")
        };
        assert_eq!((rp.narrow_rays, rp.narrow_direct), (56, 0));
        // Bounces 2 and 3: the coarse gather, its narrow texels refined into the spare, which
        // the upsample reads; up to 64 rays in the second bounce, 32 in the third.
        for (bounce, more) in [(1, 48), (2, 16)] {
            assert_eq!(
                labels(&g, bounce)[..3],
                ["gather", "refine_narrow", "upsample"]
            );
            let [gather, narrow, up, ..] = bounce_from(&g, bounce) else {
                panic!("bounce {}", bounce + 1)
            };
            let Params::Refine(np) = narrow.params else {
                panic!("{:?}", narrow.params)
            };
            assert_eq!(
                (np.rays, np.narrow_rays, np.first_rays, np.lamp_paths),
                (0, more, 16, 0)
            );
            assert_eq!(np.bounce as usize, bounce + 1);
            assert_eq!(narrow.reads[3], gather.writes[0]);
            assert_eq!(up.reads[0], narrow.writes[0]);
            assert_ne!(narrow.writes[0], gather.writes[0]);
        }
        // The fourth bounce's 16 rays are its share, 64 / 4: nothing added.
        assert_eq!(labels(&g, 3)[..2], ["gather", "upsample"]);
        let atrous = |g: &BakeGraph| -> Vec<AtrousParams> {
            g.passes
                .iter()
                .filter_map(|p| match p.params {
                    Params::Atrous(a) if a.linear == 0 => Some(a),
                    _ => None,
                })
                .collect()
        };
        let steps = atrous(&g);
        assert!(steps.len() > ATROUS_EARLY_ITERATIONS as usize);
        for (i, a) in steps.iter().enumerate() {
            if i < ATROUS_EARLY_ITERATIONS as usize {
                // The early term of 64 rays against 8 rays' (√8 narrower): σ² an eighth.
                let ratio = a.narrow_variance_scale / a.variance_scale;
                assert!((ratio - 0.125).abs() < 1e-5, "{i}: {ratio}");
            } else {
                assert_eq!(a.narrow_variance_scale, a.variance_scale, "{i}");
            }
        }
        // With noise refinement too: its variance estimate comes back, and both counts.
        let both = BakeGraph::build(&GraphConfig {
            narrow_rays: 64,
            refine: Some((8, 0.2)),
            ..base
        });
        assert_eq!(both.validate(), Ok(()));
        assert_eq!(
            labels(&both, 0)[..4],
            ["gather", "refine_variance", "refine_connect", "refine"]
        );
        // A room with no texel in a gap: no refinement; with a fifth of its texels in gaps, a
        // quarter of 8 rays over the room is 10 more a texel there, in every bounce that
        // adds more than that.
        let none = BakeGraph::build(&GraphConfig {
            narrow_rays: 64,
            narrow_texels: [0, 10_000],
            ..base
        });
        assert!(none.passes.iter().all(|p| !p.label.starts_with("refine")));
        let many = BakeGraph::build(&GraphConfig {
            narrow_rays: 64,
            narrow_texels: [2_000, 10_000],
            ..base
        });
        let counts: Vec<u32> = many
            .passes
            .iter()
            .filter_map(|p| match p.params {
                Params::Refine(r) => Some(r.narrow_rays),
                _ => None,
            })
            .collect();
        assert_eq!(counts, [10, 10, 10]);
        // A first bounce on a grid: not refined; later bounces at full resolution: the gather
        // into `coarse`, refined from there into the bounce's texture, no upsample.
        let strided = BakeGraph::build(&GraphConfig {
            narrow_rays: 64,
            stride: 2,
            higher_stride: 1,
            ..base
        });
        assert_eq!(strided.validate(), Ok(()));
        assert_eq!(labels(&strided, 0)[..2], ["gather", "upsample"]);
        let [gather, narrow, accumulate, ..] = bounce_from(&strided, 1) else {
            panic!("bounce 2")
        };
        assert_eq!(
            [gather.label, narrow.label, accumulate.label],
            ["gather", "refine_narrow", "accumulate"]
        );
        assert_eq!(narrow.reads[3], gather.writes[0]);
        assert_eq!(accumulate.reads[1], narrow.writes[0]);
        assert_ne!(narrow.writes[0], gather.writes[0]);
        // None asked, or no more than the bounces' own rays: no refinement, equal terms.
        for narrow_rays in [0, 8, 16] {
            let g = BakeGraph::build(&GraphConfig {
                narrow_rays,
                ..base
            });
            assert_eq!(g.validate(), Ok(()));
            assert!(g.passes.iter().all(|p| p.label != "refine_narrow"));
            if narrow_rays <= 8 {
                assert!(g.passes.iter().all(|p| !p.label.starts_with("refine")));
                for a in atrous(&g) {
                    assert_eq!(a.narrow_variance_scale, a.variance_scale);
                }
            }
        }
    }

    fn converged(bounces: u32, blur: Blur) -> GraphConfig {
        GraphConfig {
            method: Method::Converged,
            ..config(bounces, blur)
        }
    }

    /// With a preview asked for and a lamp's opening, the converged graph's first direct pass
    /// is the preview (every lamp a point, no opening's work in its tile plan) into `direct`,
    /// before the opening's (chunked) direct passes that overwrite it; without an opening, or
    /// in the paper method, there is none and the graph is the one without a preview.
    #[test]
    fn a_preview_of_the_direct_light_comes_first_only_where_an_opening_is_baked() {
        let opening = GraphConfig {
            openings: (48, 1),
            opening_probe_stride: 4,
            direct_chunk: 64,
            ..converged(2, Blur::Sigma(1.0))
        };
        let with = BakeGraph::build(&GraphConfig {
            direct_preview: true,
            ..opening.clone()
        });
        with.validate().expect("valid");
        let directs: Vec<usize> = (0..with.passes.len())
            .filter(|&i| with.passes[i].kind == PassKind::Run(Program::Direct))
            .collect();
        // The preview, then the opening's 96 samples in two chunks of 64.
        assert_eq!(directs.len(), 3, "{directs:?}");
        assert_eq!(with.preview, Some(directs[0]));
        let p = &with.passes[directs[0]];
        assert_eq!(p.writes, vec![with.direct]);
        match p.params {
            Params::Direct(d) => {
                assert_eq!((d.points_only, d.openings, d.first_sample), (1, 0, 0));
                assert_eq!(crate::passes::direct::work(&d), u64::from(d.lamp_count));
            }
            other => panic!("{other:?}"),
        }
        assert!(directs[1..].iter().all(|&i| matches!(
            with.passes[i].params,
            Params::Direct(d) if d.points_only == 0
        )));
        assert_eq!(with.passes[directs[2]].writes, vec![with.direct]);
        let without = BakeGraph::build(&opening);
        assert_eq!(without.preview, None);
        assert_eq!(without.passes.len() + 1, with.passes.len());
        for config in [
            GraphConfig {
                openings: (48, 0),
                ..opening.clone()
            },
            GraphConfig {
                method: Method::Paper,
                ..opening.clone()
            },
        ] {
            let g = BakeGraph::build(&GraphConfig {
                direct_preview: true,
                ..config.clone()
            });
            assert_eq!(g.preview, None);
            assert_eq!(g, BakeGraph::build(&config));
        }
    }

    /// On a loop-limited driver a texel's rays are split over gather passes of
    /// `gather_chunk` rays that add up, alternating with a spare texture so that the last
    /// writes where the unsplit gather would; both methods and refinement, and the graph
    /// stays valid.
    #[test]
    fn chunked_gathers_add_up_into_the_same_texture() {
        for (method, refine) in [
            (Method::Converged, None),
            (Method::Converged, Some((16, 0.1))),
            (Method::Paper, None),
        ] {
            let base = GraphConfig {
                method,
                rays: 200,
                higher_rays: 200,
                refine,
                ..config(2, Blur::None)
            };
            let whole = BakeGraph::build(&base);
            let split = BakeGraph::build(&GraphConfig {
                gather_chunk: 64,
                ..base.clone()
            });
            split.validate().expect("valid");
            let (w, s) = (gather_passes(&whole), gather_passes(&split));
            assert_eq!((w.len(), s.len()), (2, 8), "{method:?}");
            for bounce in 0..2 {
                let chunks = &s[4 * bounce..4 * bounce + 4];
                assert_eq!(chunks[3].writes, w[bounce].writes, "{method:?}");
                for (c, p) in chunks.iter().enumerate() {
                    let Params::Gather(g) = p.params else {
                        panic!("gather params");
                    };
                    assert_eq!((g.first_ray, g.chunk_rays), (64 * c as u32, 64));
                    assert_eq!(p.reads[..4], w[bounce].reads[..4]);
                    assert!(!p.reads.contains(&p.writes[0]), "reads what it writes");
                    if c > 0 {
                        assert_eq!(
                            p.reads[4],
                            chunks[c - 1].writes[0],
                            "reads the chunk before"
                        );
                        assert_ne!(p.writes[0], chunks[c - 1].writes[0]);
                    }
                }
                let Params::Gather(g) = w[bounce].params else {
                    panic!("gather params");
                };
                assert_eq!((g.first_ray, g.chunk_rays), (0, 0));
            }
        }
    }

    /// On a loop-limited driver an opening's samples are split over direct passes of
    /// `direct_chunk` samples that add up, alternating with a texture that is written only
    /// after the direct light, so that the last writes where the unsplit pass would and
    /// carries the direct light's check; both methods, and the graph stays valid.
    #[test]
    fn chunked_direct_passes_add_up_into_the_same_texture() {
        let direct_passes = |g: &BakeGraph| -> Vec<PassDesc> {
            g.passes
                .iter()
                .filter(|p| p.kind == PassKind::Run(Program::Direct))
                .cloned()
                .collect()
        };
        for method in [Method::Converged, Method::Paper] {
            for (openings, chunks) in [((48, 1), 2), ((100, 2), 4), ((1024, 0), 1)] {
                let base = GraphConfig {
                    method,
                    openings,
                    ..config(2, Blur::None)
                };
                let whole = BakeGraph::build(&base);
                let split = BakeGraph::build(&GraphConfig {
                    direct_chunk: 64,
                    ..base.clone()
                });
                split.validate().expect("valid");
                let (w, s) = (direct_passes(&whole), direct_passes(&split));
                assert_eq!((w.len(), s.len()), (1, chunks), "{method:?} {openings:?}");
                assert_eq!(s[chunks - 1].writes, w[0].writes);
                assert_eq!(s[chunks - 1].then, w[0].then);
                assert_eq!(w[0].writes, vec![whole.direct]);
                for (c, p) in s.iter().enumerate() {
                    let Params::Direct(d) = p.params else {
                        panic!("direct params");
                    };
                    let chunk = if chunks > 1 { 64 } else { 0 };
                    assert_eq!((d.first_sample, d.chunk_samples), (64 * c as u32, chunk));
                    assert_eq!(p.reads[..2], w[0].reads[..2]);
                    assert!(!p.reads.contains(&p.writes[0]), "reads what it writes");
                    if c > 0 {
                        assert_eq!(p.reads[2], s[c - 1].writes[0], "reads the chunk before");
                        assert_ne!(p.writes[0], s[c - 1].writes[0]);
                        assert!(p.then.is_none() || c == chunks - 1);
                    }
                }
                let Params::Direct(d) = w[0].params else {
                    panic!("direct params");
                };
                assert_eq!((d.first_sample, d.chunk_samples), (0, 0));
            }
        }
    }

    #[test]
    fn the_converged_graph_accumulates_filtered_increments_and_finishes_with_the_tail() {
        for (blur, correction) in [
            (Blur::None, false),
            (Blur::Sigma(2.0), false),
            (Blur::Sigma(2.0), true),
        ] {
            for bounces in 0..4 {
                let g = BakeGraph::build(&GraphConfig {
                    denoise_correction: correction,
                    ..converged(bounces, blur)
                });
                assert_eq!(g.validate(), Ok(()), "{bounces} {blur:?}");
                assert_eq!(g.method, Method::Converged);
                assert_eq!(g.bounces, bounces);
                for k in 1..=bounces {
                    assert!(g.bounce(k).count() > 0, "bounce {k}");
                }
                assert_eq!(g.bounce(bounces + 1).count(), 0);
                // The reported direct light is never blurred.
                assert_eq!(g.direct_blurred, g.direct);
                let gathers: Vec<&PassDesc> = g
                    .passes
                    .iter()
                    .filter(|p| p.kind == PassKind::Run(Program::Gather))
                    .collect();
                for (k, p) in gathers.iter().enumerate() {
                    let Params::Gather(gp) = p.params else {
                        panic!("{:?}", p.params)
                    };
                    // The first bounce uses `rays`, later ones `higher_rays`.
                    assert_eq!(gp.rays, if k == 0 { 16 } else { 4 });
                    assert_eq!(Some(p.writes[0]), delta(&g));
                }
                if bounces == 0 {
                    assert_eq!(delta(&g), None);
                    assert!(g.passes.iter().all(|p| p.runtime.is_none()));
                    assert_eq!(g.illuminance, g.direct);
                    continue;
                }
                // Each bounce measures its increment after accumulating it and ends with its
                // check of the reflected increment, then its own tail, which runs only if the
                // bake stops there: the running sum after the bounce (two textures
                // alternate) plus the tail weight times the increment.
                let mut sums = Vec::new();
                for k in 1..=bounces {
                    let end = g.bounce(k).last().expect("bounce");
                    assert_eq!(
                        end.then,
                        Some(Check::ConvergedBounce {
                            bounce: k,
                            reflected: reflected(&g).expect("reflected"),
                            last: k == bounces
                        })
                    );
                    // Each check sits on the second of its two reductions, right after the
                    // pass it follows; the first reads the checked texture.
                    let passes: Vec<&PassDesc> = g.bounce(k).collect();
                    let checks: Vec<(usize, Check)> = passes
                        .iter()
                        .enumerate()
                        .filter_map(|(i, p)| p.then.map(|c| (i, c)))
                        .collect();
                    let [(i, increment), (j, _)] = checks[..] else {
                        panic!("bounce {k}: {checks:?}")
                    };
                    assert_eq!(
                        increment,
                        Check::Increment {
                            bounce: k,
                            delta: delta(&g).expect("delta")
                        }
                    );
                    assert_eq!(j, passes.len() - 1);
                    for (at, checked) in [(i, delta(&g)), (j, reflected(&g))] {
                        assert_eq!(passes[at - 1].reads, [checked.expect("checked")]);
                    }
                    assert_eq!(passes[j - 2].label, "albedo_delta");
                    assert_eq!(passes[j - 2].writes, [reflected(&g).expect("reflected")]);
                    assert_eq!(passes[i - 2].label, "accumulate");
                    let tails: Vec<&PassDesc> = g
                        .passes
                        .iter()
                        .filter(|p| p.when == RunWhen::StoppedAt(k))
                        .collect();
                    let [tail] = tails[..] else {
                        panic!("bounce {k}: {tails:?}")
                    };
                    assert_eq!(
                        (tail.label, tail.runtime),
                        ("tail", Some(Runtime::TailWeight))
                    );
                    let accumulate = g.bounce(k).find(|p| p.label == "accumulate");
                    assert_eq!(Some(tail.reads[0]), accumulate.map(|p| p.writes[0]));
                    assert_eq!(tail.reads[1], delta(&g).expect("delta"));
                    sums.push(tail.reads[0]);
                }
                for w in sums.windows(2) {
                    assert_ne!(w[0], w[1]);
                }
                let labels: Vec<_> = finish(&g).iter().map(|p| p.label).collect();
                // After the bounces and the tail: the variance estimate and four à-trous
                // iterations (σ 2) that end back in the indirect map, with the bias
                // correction the residual, five iterations of its linear filter and the
                // corrected sum, once; no Gaussian blur.
                let filter: &[&str] = if blur == Blur::None {
                    &[]
                } else if !correction {
                    &["variance", "atrous", "atrous", "atrous", "atrous"]
                } else {
                    &[
                        "variance",
                        "atrous",
                        "atrous",
                        "atrous",
                        "atrous",
                        "residual",
                        "correction",
                        "correction",
                        "correction",
                        "correction",
                        "correction",
                        "corrected",
                    ]
                };
                let want: Vec<&str> = filter
                    .iter()
                    .copied()
                    .chain(["combine", "albedo_combined"])
                    .collect();
                assert_eq!(labels, want);
                if correction && bounces > 0 {
                    assert_bias_corrected(finish(&g));
                }
                let count =
                    |f: fn(&PassKind) -> bool| g.passes.iter().filter(|p| f(&p.kind)).count();
                assert_eq!(count(|k| *k == PassKind::Run(Program::Blur)), 0);
                // Each filter reads an increment (never the direct light); the variance
                // estimate carries the direct light's luminance beside it.
                for p in &g.passes {
                    if matches!(p.kind, PassKind::Run(Program::Variance | Program::Atrous)) {
                        assert_ne!(p.reads[0], g.direct);
                    }
                    if p.kind == PassKind::Run(Program::Variance) {
                        assert_eq!(p.reads[3], g.direct);
                    }
                }
            }
        }
    }

    /// The denoiser's passes `finish` (from the variance estimate to the final combine) chain
    /// `y · B(L(x)) / B(L(y))`: the luminances of the noisy map `x` (what the variance estimate
    /// and the first iteration read) and of the à-trous result `y`; `B`'s linear iterations
    /// from them, each reading the last one's output; `y` scaled by the ratio of `B`'s two
    /// channels, which the combine with the direct light reads; no pass writes `x` or `y`
    /// before they are read.
    fn assert_bias_corrected(finish: &[PassDesc]) {
        let find = |label: &str| finish.iter().position(|p| p.label == label).expect(label);
        let x = finish[find("variance")].reads[0];
        let atrous: Vec<&PassDesc> = finish.iter().filter(|p| p.label == "atrous").collect();
        assert_eq!(atrous[0].reads[0], x);
        let y = atrous.last().expect("à-trous").writes[0];
        let residual = &finish[find("residual")];
        assert_eq!(residual.reads, [x, y]);
        assert_eq!(residual.params, Params::Combine(CombineParams::PAIR));
        let mut last = residual.writes[0];
        for p in finish.iter().filter(|p| p.label == "correction") {
            assert_eq!(p.kind, PassKind::Run(Program::Atrous));
            assert!(
                matches!(p.params, Params::Atrous(a) if a.linear == 1),
                "{p:?}"
            );
            assert_eq!(p.reads[0], last);
            assert!(![y, last].contains(&p.writes[0]), "{p:?}");
            last = p.writes[0];
        }
        let corrected = &finish[find("corrected")];
        assert_eq!(corrected.reads, [y, last]);
        assert_eq!(corrected.params, Params::Combine(CombineParams::RATIO));
        let out = corrected.writes[0];
        assert!(![y, last].contains(&out));
        assert_eq!(finish[find("combine")].reads[1], out);
    }

    fn kinds(g: &BakeGraph) -> Vec<&'static str> {
        g.passes.iter().map(|p| p.label).collect()
    }

    #[test]
    fn every_computed_pass_has_one_program_and_the_graph_uses_them_all() {
        let g = BakeGraph::build(&config(2, Blur::Sigma(1.5)));
        let c = BakeGraph::build(&GraphConfig {
            lamp_paths: (4, 0.5),
            lamp_path_count: 100,
            openings: (0, 0),
            opening_probe_stride: 0,
            direct_preview: false,
            luminance_scale: 1.0,
            ..converged(2, Blur::Sigma(1.5))
        });
        let reduced = BakeGraph::build(&GraphConfig {
            higher_stride: 2,
            refine: Some((4, 0.1)),
            ..converged(2, Blur::Sigma(1.5))
        });
        let used: std::collections::HashSet<Program> = g
            .passes
            .iter()
            .chain(&c.passes)
            .chain(&reduced.passes)
            .filter_map(|p| p.kind.program())
            .collect();
        assert_eq!(used, Program::ALL.into_iter().collect());
        assert_eq!(PassKind::GBuffer.program(), None);
        let labels: std::collections::HashSet<&str> =
            Program::ALL.iter().map(|p| p.label()).collect();
        assert_eq!(labels.len(), Program::ALL.len());
        for p in g.passes.iter().chain(&c.passes) {
            let rays = matches!(
                p.kind,
                PassKind::Run(Program::Direct | Program::Gather | Program::Connect)
            );
            assert_eq!(p.kind.program().is_some_and(Program::traces_rays), rays);
        }
    }

    #[test]
    fn paper_order_one_bounce_with_blur() {
        let g = BakeGraph::build(&config(1, Blur::Sigma(1.5)));
        assert_eq!(
            kinds(&g),
            [
                "gbuffer",
                "direct",
                "energy_rows",
                "energy",
                "copy_direct",
                "blur_direct_u",
                "blur_direct_v",
                "albedo_direct",
                "gather",
                "combine",
                "copy_combined",
                "blur_combined_u",
                "blur_combined_v",
                "albedo_combined",
                "energy_rows",
                "energy",
            ]
        );
        assert_eq!(labels(&g, 0), kinds(&g)[8..16]);
        // A check sits on the reduction of the texture it measures: its rows into a row of
        // row sums, that row into one texel per layer.
        for (at, check) in [
            (
                15,
                Check::PaperBounce {
                    bounce: 1,
                    indirect: g.figure5.stages[4].expect("indirect"),
                    last: true,
                },
            ),
            (3, Check::DirectEnergy(g.direct)),
        ] {
            assert_eq!(g.passes[at].then, Some(check));
            let (rows, total) = (&g.passes[at - 1], &g.passes[at]);
            let (Check::DirectEnergy(checked)
            | Check::PaperBounce {
                indirect: checked, ..
            }) = check
            else {
                unreachable!("the paper graph's checks")
            };
            assert_eq!(rows.reads, [checked]);
            assert_eq!(total.reads, rows.writes);
            let size = |p: &PassDesc| g.texture(p.writes[0]).map(|t| (t.size, t.layers));
            assert_eq!(size(rows), Some(([32, 1], 2)));
            assert_eq!(size(total), Some(([1, 1], 2)));
            assert!(g.passes.iter().filter(|p| p.then.is_some()).count() == 2);
        }
        // Every map has the layout's size and is RGBA32F.
        for t in g.textures.iter().filter(|t| !t.label.starts_with("energy")) {
            assert_eq!(t.size, [64, 32]);
            assert_eq!(t.layers, 2);
            assert_eq!(t.format, TexFormat::Rgba32F);
        }
        let f = g
            .figure5
            .stages
            .map(|s| s.expect("all eight stages with a bounce"));
        let labels: Vec<_> = f.iter().map(|&t| g.texture(t).map(|d| d.label)).collect();
        assert_eq!(
            labels,
            [
                Some("gbuffer_albedo"),
                Some("direct"),
                Some("direct_blurred"),
                Some("reflected_direct"),
                Some("indirect"),
                Some("combined"),
                Some("combined_blurred"),
                Some("reflected_combined"),
            ]
        );
        assert_eq!(g.illuminance, f[6]);
        assert_eq!(g.exitance, f[7]);
        assert_eq!(g.direct, f[1]);
        assert_eq!(g.direct_blurred, f[2]);
    }

    #[test]
    fn lamp_paths_are_connected_and_read_by_the_first_gather_only() {
        let config = GraphConfig {
            method: Method::Converged,
            lamp_paths: (4, 0.5),
            lamp_path_count: 1000,
            openings: (0, 0),
            opening_probe_stride: 0,
            direct_preview: false,
            luminance_scale: 1.0,
            ..config(3, Blur::Sigma(1.0))
        };
        let g = BakeGraph::build(&config);
        g.validate().expect("valid");
        let connected = g.gbuffer.connected.expect("lamp paths connected");
        assert_eq!(g.passes[0].writes.len(), 3);
        // After the direct part (its light is ready first), before the first gather.
        let at = g
            .passes
            .iter()
            .position(|p| p.kind == PassKind::Run(Program::Connect))
            .expect("a connect pass");
        let direct_part = g.passes.iter().position(|p| p.label == "albedo_direct");
        let first_gather = g.passes.iter().position(|p| p.label == "gather");
        assert!(direct_part < Some(at) && Some(at) < first_gather);
        let connect = &g.passes[at];
        assert_eq!(connect.writes, [connected]);
        assert_eq!(
            connect.reads,
            [g.gbuffer.position, g.gbuffer.normal, g.gbuffer.position]
        );
        let Params::Connect(cp) = connect.params else {
            panic!("connect parameters");
        };
        assert_eq!(
            (cp.k, cp.count, cp.density_scale, cp.rays, cp.picks),
            (4, 1000, 0.5, 16, 0)
        );
        // The G-buffer is the room's; the lamp paths and everything after depend on the lamps.
        assert!(!g.passes[0].lamps);
        assert!(g.passes[1..].iter().all(|p| p.lamps));
        let gathers = gather_passes(&g);
        assert_eq!(gathers.len(), 3);
        for p in &gathers {
            let Params::Gather(gp) = p.params else {
                panic!("gather parameters");
            };
            if p.bounce == 1 {
                assert_eq!(p.reads[3], connected);
                assert_eq!(
                    (gp.lamp_paths, gp.density_scale, gp.lamp_count),
                    (4, 0.5, 2)
                );
            } else {
                assert_ne!(p.reads[3], connected);
                assert_eq!(gp.lamp_paths, 0);
            }
        }
        // A reduced first bounce: no lamp paths. Refinement keeps them.
        let reduced = GraphConfig {
            stride: 2,
            ..config.clone()
        };
        assert_eq!(BakeGraph::build(&reduced).gbuffer.connected, None);
        let refined = GraphConfig {
            refine: Some((8, 0.1)),
            ..config.clone()
        };
        assert_eq!(
            BakeGraph::build(&refined).gbuffer.connected,
            Some(connected)
        );
    }

    #[test]
    fn reads_and_writes_follow_the_documented_conventions() {
        let g = BakeGraph::build(&config(1, Blur::Sigma(2.0)));
        let gb = g.gbuffer;
        let f = g.figure5.stages.map(|s| s.expect("stage"));
        let tmp = g
            .textures
            .iter()
            .position(|t| t.label == "blur_tmp")
            .map(|i| TexId(i as u32))
            .expect("blur scratch");
        let rw: Vec<(Vec<TexId>, Vec<TexId>)> = g
            .passes
            .iter()
            .map(|p| (p.reads.clone(), p.writes.clone()))
            .collect();
        // The check's reductions left out.
        let rw: Vec<_> = rw
            .into_iter()
            .zip(&g.passes)
            .filter(|(_, p)| p.kind != PassKind::Run(Program::Energy))
            .map(|(rw, _)| rw)
            .collect();
        assert_eq!(rw[0], (vec![], vec![gb.position, gb.normal, gb.albedo]));
        // Unsplit: `position` stands in for the prior chunk, which is not read.
        assert_eq!(
            rw[1],
            (vec![gb.position, gb.normal, gb.position], vec![f[1]])
        );
        assert_eq!(rw[2], (vec![f[1]], vec![f[2]]));
        assert_eq!(rw[3], (vec![f[2], gb.normal], vec![tmp]));
        assert_eq!(rw[4], (vec![tmp, gb.normal], vec![f[2]]));
        assert_eq!(rw[5], (vec![f[2], gb.albedo], vec![f[3]]));
        // Without lamp paths the gather's `connected` slot holds `reflected` (never read), and
        // so does `prior` of an unsplit gather; `albedo` is read with `direct_at_hits`.
        assert_eq!(
            rw[6],
            (
                vec![gb.position, gb.normal, f[3], f[3], f[3], gb.albedo],
                vec![f[4]]
            )
        );
        assert_eq!(rw[7], (vec![f[1], f[4]], vec![f[5]]));
        assert_eq!(rw[8], (vec![f[5]], vec![f[6]]));
        assert_eq!(rw[9], (vec![f[6], gb.normal], vec![tmp]));
        assert_eq!(rw[10], (vec![tmp, gb.normal], vec![f[6]]));
        assert_eq!(rw[11], (vec![f[6], gb.albedo], vec![f[7]]));
        // Parameters: the direct pass carries the lamp list, the gather its rays and seed.
        assert_eq!(
            g.passes[1].params,
            Params::Direct(DirectParams {
                lamp_count: 2,
                seed: 9,
                ..DirectParams::default()
            })
        );
        assert_eq!(g.passes[8].kind, PassKind::Run(Program::Gather));
        let Params::Gather(gp) = g.passes[8].params else {
            panic!("gather parameters: {:?}", g.passes[8].params);
        };
        assert_eq!(
            (gp.rays, gp.bounce, gp.seed, gp.sampler),
            (16, 1, 9, Sampler::Sobol.id())
        );
        assert_eq!(g.passes[5].params, Params::Blur(blur_params([1, 0], 2.0)));
        assert_eq!(g.passes[6].params, Params::Blur(blur_params([0, 1], 2.0)));
        assert!(g.passes.iter().all(|p| p.bvh == BvhMode::Mtbvh));
    }

    #[test]
    fn no_pass_reads_what_it_writes_and_everything_read_was_written_before() {
        for bounces in 0..4 {
            for blur in [Blur::None, Blur::Sigma(1.0)] {
                let g = BakeGraph::build(&config(bounces, blur));
                assert_eq!(g.validate(), Ok(()));
                let mut written = vec![false; g.textures.len()];
                for p in &g.passes {
                    for r in &p.reads {
                        assert!(!p.writes.contains(r), "{} reads its target", p.label);
                        assert!(written[r.index()], "{} reads unwritten {:?}", p.label, r);
                    }
                    for w in &p.writes {
                        written[w.index()] = true;
                    }
                }
                // Every texture of the graph is used.
                assert!(
                    written.iter().all(|&w| w),
                    "unused texture at {bounces} {blur:?}"
                );
            }
        }
    }

    #[test]
    fn bounces_reuse_textures_and_chain_through_the_reflected_map() {
        let g = BakeGraph::build(&config(3, Blur::None));
        assert_eq!(g.bounces, 3);
        let f = g.figure5.stages.map(|s| s.expect("stage"));
        let gathers = gather_passes(&g);
        assert_eq!(gathers.len(), 3);
        // Bounce 1 gathers the reflected direct map, later bounces the reflected combined one;
        // all write the same indirect texture.
        assert_eq!(gathers[0].reads[2], f[3]);
        assert_eq!(gathers[1].reads[2], f[7]);
        assert_eq!(gathers[2].reads[2], f[7]);
        for (k, p) in gathers.iter().enumerate() {
            assert_eq!(p.kind, PassKind::Run(Program::Gather));
            assert_eq!(p.bounce, k as u32 + 1);
            assert_eq!(p.writes, vec![f[4]]);
        }
        // Without blur: no blur pass and no scratch texture; same texture count for any k ≥ 1.
        assert!(
            g.passes
                .iter()
                .all(|p| p.kind != PassKind::Run(Program::Blur))
        );
        let one = BakeGraph::build(&config(1, Blur::None));
        assert_eq!(one.textures.len(), g.textures.len());
        assert_eq!(one.passes.len() + 2 * 6, g.passes.len());
        // Each bounce range is gather, combine, copy, albedo and the check's reduction.
        for k in 0..3 {
            assert_eq!(
                labels(&g, k),
                [
                    "gather",
                    "combine",
                    "copy_combined",
                    "albedo_combined",
                    "energy_rows",
                    "energy"
                ]
            );
        }
        // Only the paper method's G-buffer upload does not depend on the lamps.
        assert!(!g.passes[0].lamps);
        assert!(g.passes[1..].iter().all(|p| p.lamps));
    }

    #[test]
    fn validate_rejects_passes_that_break_their_signature() {
        let good = BakeGraph::build(&config(1, Blur::Sigma(1.0)));
        let gather = good
            .passes
            .iter()
            .position(|p| p.label == "gather")
            .expect("gather");
        let mut g = good.clone();
        g.passes[gather].reads.pop();
        assert!(g.validate().unwrap_err().reason.contains("slots"));
        let mut g = good.clone();
        g.passes[gather].params = Params::None;
        assert!(g.validate().unwrap_err().reason.contains("block"));
        let mut g = good.clone();
        g.passes[gather].reads[2] = g.passes[gather].writes[0];
        assert!(g.validate().unwrap_err().reason.contains("it writes"));
        let mut g = good.clone();
        g.passes[1].reads[0] = TexId(99);
        assert!(
            g.validate()
                .unwrap_err()
                .reason
                .contains("not in the graph")
        );
        let mut g = good;
        g.passes.swap(1, 2);
        let e = g.validate().unwrap_err();
        assert_eq!(e.index, 1);
        assert!(e.reason.contains("before any pass wrote it"), "{e}");
    }

    #[test]
    fn direct_only_graph_ends_at_stage_four() {
        let g = BakeGraph::build(&config(0, Blur::None));
        assert_eq!(
            kinds(&g),
            ["gbuffer", "direct", "copy_direct", "albedo_direct"]
        );
        assert_eq!(g.figure5.stages[4..], [None; 4]);
        assert_eq!(Some(g.illuminance), g.figure5.stages[2]);
        assert_eq!(Some(g.exitance), g.figure5.stages[3]);
        assert_eq!(g.bounce(1).count(), 0);
        assert!(g.passes.iter().all(|p| p.then.is_none()));
        // Zero or non-finite sigma means no blur.
        for s in [0.0, f32::NAN, f32::INFINITY] {
            let g = BakeGraph::build(&config(0, Blur::Sigma(s)));
            assert_eq!(g.passes.len(), 4);
        }
    }
}
