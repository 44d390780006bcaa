//! The bake-level gather against pure traversal of the same rays (issue 15: "gather rays/s ≥
//! 0.6× the pure-traversal rays/s of the same rays").
//!
//! Each round bakes the scene on the CPU backend with the settings of `cargo xtask bake
//! --method paper` (`Settings::paper()` with the default texel density, traversal and seed),
//! on a rayon pool of one thread, through [`Recorder`]: a backend that forwards every call to
//! [`CpuBackend`] and measures each gather dispatch in thread CPU time. The bake-level rate of
//! a bounce is its gather rays (valid texels with a normal × rays per texel) over its gather
//! dispatches' time: per texel the G-buffer fetches, directions, closest hits, hit shading and
//! masked look-ups, as the bake runs them.
//!
//! In the first round the recorder also rebuilds bounce 1's rays from the dispatches' own
//! inputs by the gather's documented rule (`luxbake::cpu` module docs): per tile, row by row,
//! for each texel whose G-buffer position is valid and whose normal `n` normalises to `n̂`,
//! origin `offset_origin(p, n̂, ray_epsilon)` and directions `cosine_direction(n̂,
//! sampler.uniform2(key, first + s, bounce, seed))`, `s = 0 .. rays`, with the texel's
//! `rng::Stream` (`key`, `first`). It checks them: the gather
//! recomputed from their closest hits (`WideBvh::closest_hit`, `map::sample_masked` of the
//! reflected map) must equal every texel the dispatch wrote, bit for bit. Then, in each round,
//! those rays alone are traced with `WideBvh::closest_hit` in the same order on one thread: the
//! pure-traversal rate. Rates are medians over the rounds; the ratio is bake ÷ traversal.

use std::hint::black_box;
use std::sync::Arc;

use luxbake::backend::{Dispatch, SceneData, offset_origin};
use luxbake::cpu::{CpuScene, cosine_direction};
use luxbake::exact::{guard, normalize};
use luxbake::graph::TexDesc;
use luxbake::layout::Region;
use luxbake::map::sample_masked;
use luxbake::program::{GatherParams, Params};
use luxbake::rng::{Draw, Sampler, Stream};
use luxbake::scene::{BvhMode, Scene, Settings};
use luxbake::{GpuBackend, Limits};
use luxbake_backend_cpu::{CpuBackend, CpuError, CpuTexture};
use luxbake_bvh::{EncodedScene, Ray, WideBvh};
use serde_json::json;

use crate::clock::thread_seconds;

/// What the recorder keeps of the uploaded scene.
struct Uploaded {
    encoded: Arc<EncodedScene>,
    wide: Arc<WideBvh>,
    regions: Vec<Option<Region>>,
    layer_size: [u32; 2],
    ray_epsilon: f32,
}

/// Bounce 1's rays, rebuilt from the dispatches' inputs, and their check.
#[derive(Default)]
struct Recording {
    rays: Vec<Ray>,
    /// Texels of bounce 1 whose recomputed gather was compared with the dispatch's output.
    texels: u64,
    /// Those that differed.
    mismatches: u64,
    /// Rays that hit something.
    hits: u64,
}

/// A [`CpuBackend`] that times its gather dispatches and, when `recording` is set, rebuilds
/// bounce 1's rays (see the module docs).
struct Recorder {
    inner: CpuBackend,
    uploaded: Option<Uploaded>,
    /// Layers of every texture created.
    layers: Vec<(CpuTexture, u32)>,
    /// The G-buffer's position and normal layers, read back once: `(texture, layer, texels)`.
    gbuffer: Vec<(CpuTexture, u32, Vec<f32>)>,
    /// Per gather dispatch: bounce, rays, thread seconds.
    dispatches: Vec<(u32, u64, f64)>,
    recording: Option<Recording>,
}

impl Recorder {
    fn new(record: bool) -> Recorder {
        Recorder {
            inner: CpuBackend::new(),
            uploaded: None,
            layers: Vec::new(),
            gbuffer: Vec::new(),
            dispatches: Vec::new(),
            recording: record.then(Recording::default),
        }
    }

    /// Layer `layer` of a G-buffer texture, read back on first use.
    fn gbuffer_layer(&mut self, texture: CpuTexture, layer: u32) -> Result<usize, CpuError> {
        if let Some(i) = self
            .gbuffer
            .iter()
            .position(|(t, l, _)| *t == texture && *l == layer)
        {
            return Ok(i);
        }
        let texels = self.inner.read_back(&texture, layer)?;
        self.gbuffer.push((texture, layer, texels));
        Ok(self.gbuffer.len() - 1)
    }

    /// Rays the gather dispatch `call` casts (texels of its tile with a valid position and a
    /// normal that normalises, × rays per texel; every texel at the paper's stride 1).
    fn count_rays(
        &mut self,
        call: &Dispatch<'_, CpuTexture, CpuScene>,
        params: &GatherParams,
    ) -> Result<u64, CpuError> {
        let t = call.tile;
        let pos = self.gbuffer_layer(*call.reads[0], t.layer)?;
        let nrm = self.gbuffer_layer(*call.reads[1], t.layer)?;
        let (pos, nrm) = (&self.gbuffer[pos].2, &self.gbuffer[nrm].2);
        let mut texels = 0u64;
        for y in t.y0..t.y0 + t.height {
            for x in t.x0..t.x0 + t.width {
                let i = 4 * (y as usize * t.layer_w as usize + x as usize);
                if pos[i + 3] > 0.5 && normalize([nrm[i], nrm[i + 1], nrm[i + 2]]).is_some() {
                    texels += 1;
                }
            }
        }
        Ok(texels * u64::from(params.rays))
    }

    /// Rebuilds the rays of bounce 1's dispatch `call` (already run) and checks them against
    /// what it wrote (see the module docs).
    fn record(
        &mut self,
        call: &Dispatch<'_, CpuTexture, CpuScene>,
        params: &GatherParams,
    ) -> Result<(), String> {
        let t = call.tile;
        let pos = self
            .gbuffer_layer(*call.reads[0], t.layer)
            .map_err(|e| e.to_string())?;
        let nrm = self
            .gbuffer_layer(*call.reads[1], t.layer)
            .map_err(|e| e.to_string())?;
        let written = self
            .inner
            .read_back(call.write, t.layer)
            .map_err(|e| e.to_string())?;
        if call.bvh != BvhMode::Wide || params.stride > 1 || params.lamp_paths > 0 {
            return Err(format!(
                "the rays are rebuilt for the paper method's gather (wide BVH, stride 1, no lamp \
                 paths), not {:?} with {params:?}",
                call.bvh
            ));
        }
        let layers = self
            .layers
            .iter()
            .find(|(t, _)| t == call.reads[2])
            .map_or(0, |&(_, l)| l);
        let reflected: Vec<Vec<f32>> = (0..layers)
            .map(|l| self.inner.read_back(call.reads[2], l))
            .collect::<Result<_, _>>()
            .map_err(|e| e.to_string())?;
        let (Some(up), Some(rec)) = (&self.uploaded, &mut self.recording) else {
            return Err("a gather dispatch before the scene upload".into());
        };
        let (pos, nrm) = (&self.gbuffer[pos].2, &self.gbuffer[nrm].2);
        let [w, h] = up.layer_size;
        let fetch = |layer: u32, x: u32, y: u32| -> [f32; 4] {
            let i = 4 * (y as usize * w as usize + x as usize);
            match reflected.get(layer as usize).and_then(|m| m.get(i..i + 4)) {
                Some(v) if x < w && y < h => [v[0], v[1], v[2], v[3]],
                _ => [0.0; 4],
            }
        };
        let sampler = Sampler::from_id(params.sampler);
        for y in t.y0..t.y0 + t.height {
            for x in t.x0..t.x0 + t.width {
                let i = 4 * (y as usize * w as usize + x as usize);
                if pos[i + 3] <= 0.5 {
                    continue;
                }
                let Some(n) = normalize([nrm[i], nrm[i + 1], nrm[i + 2]]) else {
                    continue;
                };
                let o = offset_origin([pos[i], pos[i + 1], pos[i + 2]], n, up.ray_epsilon);
                let at = [t.layer, x, y];
                let stream = Stream::gather(sampler, up.layer_size, at, params.stride, params.rays);
                let mut sum = [0.0f32; 3];
                for s in 0..params.rays {
                    let k = stream.first + s;
                    let u = sampler.uniform2(stream.key, k, params.bounce, params.seed);
                    let ray = Ray {
                        origin: o,
                        dir: cosine_direction(n, u),
                    };
                    rec.rays.push(ray);
                    let Some(hit) = up.wide.closest_hit(&ray, 0.0, f32::INFINITY) else {
                        continue;
                    };
                    rec.hits += 1;
                    let attr = up.encoded.triangle_attributes(hit.triangle);
                    let Some(Some(region)) = up.regions.get(attr.object as usize) else {
                        continue;
                    };
                    let w0 = 1.0 - hit.u - hit.v;
                    let nh = [0, 1, 2].map(|c| {
                        w0 * attr.normals[0][c]
                            + hit.u * attr.normals[1][c]
                            + hit.v * attr.normals[2][c]
                    });
                    let d = ray.dir;
                    let facing = nh[0] * d[0] + nh[1] * d[1] + nh[2] * d[2];
                    if facing.is_nan() || facing >= 0.0 {
                        continue;
                    }
                    let uv = [0, 1].map(|c| {
                        w0 * attr.uvs[0][c] + hit.u * attr.uvs[1][c] + hit.v * attr.uvs[2][c]
                    });
                    let m = sample_masked(
                        |x, y| fetch(region.layer, x, y),
                        region.offset,
                        region.size,
                        uv,
                    );
                    for c in 0..3 {
                        sum[c] += m[c];
                    }
                }
                let inv = 1.0 / params.rays as f32;
                let expected = [0, 1, 2].map(|c| guard(sum[c] * inv + 0.0));
                let got = &written[i..i + 4];
                rec.texels += 1;
                if expected
                    .iter()
                    .zip(got)
                    .any(|(e, g)| e.to_bits() != g.to_bits())
                    || got[3] != 1.0
                {
                    rec.mismatches += 1;
                }
            }
        }
        Ok(())
    }
}

impl GpuBackend for Recorder {
    type Texture = CpuTexture;
    type Scene = CpuScene;
    type Error = CpuError;

    fn name(&self) -> &'static str {
        self.inner.name()
    }

    fn limits(&self) -> Limits {
        self.inner.limits()
    }

    fn tile_work(&self) -> u64 {
        self.inner.tile_work()
    }

    fn create_texture(&mut self, desc: &TexDesc) -> Result<CpuTexture, CpuError> {
        let texture = self.inner.create_texture(desc)?;
        self.layers.push((texture, desc.layers));
        Ok(texture)
    }

    fn upload(&mut self, texture: &CpuTexture, layer: u32, texels: &[f32]) -> Result<(), CpuError> {
        self.inner.upload(texture, layer, texels)
    }

    fn upload_scene(&mut self, scene: &SceneData<'_>) -> Result<CpuScene, CpuError> {
        self.uploaded = Some(Uploaded {
            encoded: Arc::clone(&scene.bvh.encoded),
            wide: Arc::clone(&scene.bvh.wide),
            regions: scene.regions.to_vec(),
            layer_size: scene.layer_size,
            ray_epsilon: scene.ray_epsilon,
        });
        self.inner.upload_scene(scene)
    }

    fn dispatch(&mut self, call: &Dispatch<'_, CpuTexture, CpuScene>) -> Result<(), CpuError> {
        let Params::Gather(params) = Params::decode(call.program, call.params) else {
            return self.inner.dispatch(call);
        };
        let t0 = thread_seconds();
        self.inner.dispatch(call)?;
        let seconds = thread_seconds() - t0;
        let rays = self.count_rays(call, &params)?;
        self.dispatches.push((params.bounce, rays, seconds));
        if params.bounce == 1 && self.recording.is_some() {
            self.record(call, &params)
                .map_err(|reason| CpuError::BadBindings {
                    pass: call.label,
                    reason,
                })?;
        }
        Ok(())
    }

    fn read_back(&mut self, texture: &CpuTexture, layer: u32) -> Result<Vec<f32>, CpuError> {
        self.inner.read_back(texture, layer)
    }

    fn release(&mut self) -> Result<(), CpuError> {
        self.layers.clear();
        self.inner.release()
    }
}

/// The settings of `cargo xtask bake --method paper`.
fn paper_settings() -> Settings {
    let d = Settings::default();
    Settings {
        texels_per_metre: d.texels_per_metre,
        bvh: d.bvh,
        seed: d.seed,
        ..Settings::paper()
    }
}

/// One round's bake: its gather dispatches, and the recording when asked for.
fn bake_once(
    pool: &rayon::ThreadPool,
    scene: &Scene,
    settings: &Settings,
    record: bool,
) -> Result<Recorder, String> {
    let mut recorder = Recorder::new(record);
    pool.install(|| luxbake::bake(&mut recorder, scene, settings, &mut |_| {}))
        .map_err(|e| e.to_string())?;
    Ok(recorder)
}

/// Sum of `(rays, seconds)` over the dispatches of `bounce` (all bounces for `None`).
fn totals(dispatches: &[(u32, u64, f64)], bounce: Option<u32>) -> (u64, f64) {
    dispatches
        .iter()
        .filter(|d| bounce.is_none_or(|b| d.0 == b))
        .fold((0, 0.0), |(r, s), d| (r + d.1, s + d.2))
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// Measures `name` (a built-in scene) over `runs` rounds; the JSON of one `bake_gather` entry.
pub fn measure(name: &str, runs: usize) -> Result<serde_json::Value, String> {
    let settings = paper_settings();
    let scene = Scene::builtin_with_settings(name, settings.clone()).map_err(|e| e.to_string())?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|e| e.to_string())?;
    let mut recording = None;
    let mut wide = None;
    let (mut bake_s, mut trace_s, mut all_bounces) = (Vec::new(), Vec::new(), Vec::new());
    let mut bounce1_rays = 0;
    for round in 0..runs.max(1) {
        let mut recorder = bake_once(&pool, &scene, &settings, round == 0)?;
        let (rays, seconds) = totals(&recorder.dispatches, Some(1));
        let (all_rays, all_seconds) = totals(&recorder.dispatches, None);
        bounce1_rays = rays;
        bake_s.push(seconds);
        all_bounces.push((all_rays, all_seconds));
        if round == 0 {
            recording = recorder.recording.take();
            wide = recorder.uploaded.take().map(|u| u.wide);
        }
        let (Some(rec), Some(wide)) = (&recording, &wide) else {
            return Err(format!("{name}: the bake cast no gather rays"));
        };
        let t0 = thread_seconds();
        let mut sum = 0u32;
        for ray in &rec.rays {
            let hit = wide.closest_hit(black_box(ray), 0.0, f32::INFINITY);
            sum = sum.wrapping_add(hit.map_or(u32::MAX, |h| h.triangle));
        }
        black_box(sum);
        trace_s.push(thread_seconds() - t0);
    }
    let Some(rec) = recording else {
        return Err(format!("{name}: nothing recorded"));
    };
    if rec.rays.len() as u64 != bounce1_rays {
        return Err(format!(
            "{name}: {} rays rebuilt, the bake's bounce 1 casts {bounce1_rays}",
            rec.rays.len()
        ));
    }
    // Rays that do not reproduce the bake's gather are not "the same rays": no ratio then.
    if rec.texels == 0 || rec.mismatches > 0 {
        return Err(format!(
            "{name}: the rebuilt rays reproduce {} of {} texels' gathers",
            rec.texels - rec.mismatches,
            rec.texels
        ));
    }
    let rays = rec.rays.len() as f64;
    let bake_rate = rays / median(bake_s.clone());
    let trace_rate = rays / median(trace_s.clone());
    let all_rate = median(all_bounces.iter().map(|&(r, s)| r as f64 / s).collect());
    eprintln!(
        "  bake gather {name}: bounce 1 {:.2} M rays/s in the bake, {:.2} M rays/s traced alone: \
         {:.2}× ({} of {} texels' gathers reproduced bit for bit)",
        bake_rate * 1e-6,
        trace_rate * 1e-6,
        bake_rate / trace_rate,
        rec.texels - rec.mismatches,
        rec.texels
    );
    Ok(json!({
        "scene": name,
        "settings": "cargo xtask bake --method paper",
        "bvh": BvhMode::Wide.name(),
        "bounce": 1,
        "rays": rec.rays.len(),
        "hits": rec.hits,
        "bake_rays_per_s": bake_rate,
        "traversal_rays_per_s": trace_rate,
        "ratio": bake_rate / trace_rate,
        "bake_seconds": bake_s,
        "traversal_seconds": trace_s,
        "all_bounces_rays": all_bounces.first().map(|b| b.0),
        "all_bounces_rays_per_s": all_rate,
        "checked_texels": rec.texels,
        "mismatched_texels": rec.mismatches,
    }))
}
