//! `luxbake-bench-embree`: single-thread ray throughput of luxbake's CPU traversals against
//! Intel Embree 3 in the same process, on the same triangles and the same rays. Run by
//! `cargo xtask bench rays`, which renders the JSON this prints on stdout.
//!
//! Scenes: built-in ones by name (`chairs_05`, `sofa_01`, ...) and `room`, three SheenChairs
//! and a GlamVelvetSofa from `--models` in a 6 m × 2.6 m × 5 m room (skipped with a message when
//! the models are absent). Ray sets, seeded, per scene (bounds = the scene's box):
//! - `random` (closest hit): origin uniform in the bounds, direction uniform on the sphere;
//! - `gather` (closest hit): origin on a triangle (area-weighted) lifted by the bake's ray
//!   epsilon along a random side of its normal, direction cosine-weighted about that side;
//! - `shadow` (any hit): from a `gather` origin to a point uniform in the bounds, `t < 1`.
//!
//! Bake level (`--bake-gather`, `gather` module): the paper-method bake's gather rays per
//! second against the same rays traced alone, on one thread.
//!
//! Rates are rays per second of the measuring thread's CPU time (`CLOCK_THREAD_CPUTIME_ID`),
//! the median over `--runs` rounds in which the tracers alternate, so that load from other
//! processes on a shared machine hits them alike. `agree` is the fraction of rays whose result
//! (hit triangle, or occluded or not) equals the encoded MTBVH traversal's.

use std::hint::black_box;
use std::path::{Path, PathBuf};

use clap::Parser;
use luxbake::exact::{cross, sub};
use luxbake::scene::{Object, Scene, Settings, Transform};
use luxbake::sources::meshes::{self, RoomAlbedo};
use luxbake_bvh::{
    BuildOptions, Bvh, EncodeOptions, EncodedScene, Ray, Traversal, TriangleAttributes, WideBvh,
    encode,
};
use luxbake_testkit::SplitMix64;
use serde_json::json;

use clock::thread_seconds;

mod clock;
#[cfg(embree)]
mod embree;
mod gather;

#[derive(Parser)]
struct Args {
    /// Scenes, comma separated: built-in names and `room`.
    #[arg(long, value_delimiter = ',', default_value = "chairs_05,sofa_01,room")]
    scenes: Vec<String>,
    /// Rays per set.
    #[arg(long, default_value_t = 400_000)]
    rays: usize,
    /// Measuring rounds (the median is reported).
    #[arg(long, default_value_t = 5)]
    runs: usize,
    /// The shared glTF models (SheenChair/, GlamVelvetSofa/).
    #[arg(long, default_value = "../shared/models")]
    models: PathBuf,
    /// Built-in scenes, comma separated, whose paper-method bake measures the gather's
    /// overhead over pure traversal of the same rays (`gather` module); empty: none.
    #[arg(long, value_delimiter = ',', default_value = "chairs_05")]
    bake_gather: Vec<String>,
}

fn main() {
    let args = Args::parse();
    match run(&args) {
        Ok(report) => println!("{report:#}"),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}

/// One query: origin, direction, `t_max`.
type Query = ([f32; 3], [f32; 3], f32);

struct RaySet {
    name: &'static str,
    any_hit: bool,
    rays: Vec<Query>,
}

fn unit_sphere(rng: &mut SplitMix64) -> [f32; 3] {
    let z = 2.0 * rng.f32() - 1.0;
    let phi = std::f32::consts::TAU * rng.f32();
    let r = (1.0 - z * z).max(0.0).sqrt();
    [r * phi.cos(), r * phi.sin(), z]
}

fn ray_sets(tris: &[[[f32; 3]; 3]], n: usize) -> Vec<RaySet> {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in tris.iter().flatten() {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let max_abs = lo.iter().chain(&hi).fold(0.0f32, |m, c| m.max(c.abs()));
    let eps = luxbake::backend::ray_epsilon(max_abs);
    let in_box = |rng: &mut SplitMix64| [0, 1, 2].map(|k| lo[k] + (hi[k] - lo[k]) * rng.f32());
    // Area-weighted triangle choice by binary search in the cumulative areas.
    let mut cumulative = Vec::with_capacity(tris.len());
    let mut total = 0.0f64;
    for t in tris {
        let c = cross(sub(t[1], t[0]), sub(t[2], t[0]));
        total += 0.5 * f64::from(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        cumulative.push(total);
    }
    let on_surface = |rng: &mut SplitMix64| -> ([f32; 3], [f32; 3]) {
        loop {
            let a = f64::from(rng.f32()) * total;
            let i = cumulative.partition_point(|&c| c <= a).min(tris.len() - 1);
            let t = tris[i];
            let c = cross(sub(t[1], t[0]), sub(t[2], t[0]));
            let len = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
            if len.is_nan() || len <= 0.0 {
                continue;
            }
            let side = if rng.f32() < 0.5 { 1.0 } else { -1.0 };
            let nrm = c.map(|x| side * x / len);
            let (mut u, mut v) = (rng.f32(), rng.f32());
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            let p = [0, 1, 2].map(|k| {
                t[0][k] + u * (t[1][k] - t[0][k]) + v * (t[2][k] - t[0][k]) + eps * nrm[k]
            });
            return (p, nrm);
        }
    };
    let mut rng = SplitMix64::new(0x1234_5678);
    let random = (0..n)
        .map(|_| (in_box(&mut rng), unit_sphere(&mut rng), f32::INFINITY))
        .collect();
    let gather = (0..n)
        .map(|_| {
            let (p, nrm) = on_surface(&mut rng);
            // Cosine-weighted: a unit-sphere point added to the normal (Malley-equivalent).
            let s = unit_sphere(&mut rng);
            let d = [nrm[0] + s[0], nrm[1] + s[1], nrm[2] + s[2]];
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-20);
            (p, d.map(|c| c / l), f32::INFINITY)
        })
        .collect();
    let shadow = (0..n)
        .map(|_| {
            let (p, _) = on_surface(&mut rng);
            (p, sub(in_box(&mut rng), p), 1.0)
        })
        .collect();
    vec![
        RaySet {
            name: "random",
            any_hit: false,
            rays: random,
        },
        RaySet {
            name: "gather",
            any_hit: false,
            rays: gather,
        },
        RaySet {
            name: "shadow",
            any_hit: true,
            rays: shadow,
        },
    ]
}

/// A traversal under test. `trace` returns the tracer's own index of the hit triangle (closest
/// hit: the encoded order for luxbake's traversals, the input order for Embree) or 0 / 1 for
/// occluded (any hit); `u32::MAX` for a miss: what each returns to its caller, so that the
/// timed loop measures no mapping. `input_index` maps a closest hit's index to the input order,
/// for `agree`.
enum Tracer<'a> {
    Mtbvh(&'a EncodedScene),
    Wide(&'a WideBvh, &'a EncodedScene),
    #[cfg(embree)]
    Embree(&'a embree::Embree),
}

impl Tracer<'_> {
    fn name(&self) -> &'static str {
        match self {
            Tracer::Mtbvh(_) => "luxbake mtbvh",
            Tracer::Wide(..) => "luxbake wide",
            #[cfg(embree)]
            Tracer::Embree(_) => "embree",
        }
    }

    /// The input index of a closest hit `trace` returned (misses and any-hit results as they
    /// are).
    fn input_index(&self, traced: u32, any_hit: bool) -> u32 {
        match self {
            Tracer::Mtbvh(s) | Tracer::Wide(_, s) if !any_hit => s
                .triangle_order
                .get(traced as usize)
                .copied()
                .unwrap_or(traced),
            _ => traced,
        }
    }

    #[inline]
    fn trace(&self, (origin, dir, t_max): Query, any_hit: bool) -> u32 {
        const MISS: u32 = u32::MAX;
        match self {
            Tracer::Mtbvh(s) => {
                let ray = Ray { origin, dir };
                if any_hit {
                    u32::from(s.any_hit(&ray, 0.0, t_max, Traversal::Mtbvh))
                } else {
                    s.closest_hit(&ray, 0.0, t_max, Traversal::Mtbvh)
                        .map_or(MISS, |h| h.triangle)
                }
            }
            Tracer::Wide(w, _) => {
                let ray = Ray { origin, dir };
                if any_hit {
                    u32::from(w.any_hit(&ray, 0.0, t_max))
                } else {
                    w.closest_hit(&ray, 0.0, t_max).map_or(MISS, |h| h.triangle)
                }
            }
            #[cfg(embree)]
            Tracer::Embree(e) => {
                if any_hit {
                    u32::from(e.any_hit(origin, dir, 0.0, t_max))
                } else {
                    e.closest_hit(origin, dir, 0.0, t_max).map_or(MISS, |h| h.1)
                }
            }
        }
    }
}

/// The room of three SheenChairs and a GlamVelvetSofa (as in `crates/assets/tests/models.rs`).
fn furnished_room(models: &Path) -> Result<Scene, String> {
    let options = luxbake_assets::ImportOptions::default();
    let load = |p: &str| {
        luxbake_assets::import(&models.join(p), &options).map_err(|e| format!("{p}: {e}"))
    };
    let chair = load("SheenChair/SheenChair.glb")?;
    let sofa = load("GlamVelvetSofa/GlamVelvetSofa.glb")?;
    let object = |name: String, mesh, transform| Object {
        name,
        mesh,
        transform,
        albedo: luxbake::scene::Albedo::grey(0.5),
        receiver: true,
        texel_scale: 1.0,
    };
    let mut objects = vec![object(
        "room".into(),
        meshes::room([6.0, 2.6, 5.0], RoomAlbedo::uniform([0.7; 3]), 0.0),
        Transform::IDENTITY,
    )];
    for (i, x) in [-1.5f32, 0.0, 1.5].iter().enumerate() {
        let t = Transform::from_trs([f64::from(*x), 0.0, 1.2], [0.0, 180.0, 0.0], [1.0; 3]);
        for p in &chair.parts {
            objects.push(object(format!("chair{i}_{}", p.name), p.mesh.clone(), t));
        }
    }
    let t = Transform::from_trs([0.0, 0.0, -1.6], [0.0; 3], [1.0; 3]);
    for p in &sofa.parts {
        objects.push(object(format!("sofa_{}", p.name), p.mesh.clone(), t));
    }
    Ok(Scene {
        objects,
        lamps: Vec::new(),
        settings: Settings::default(),
    })
}

fn load(name: &str, models: &Path) -> Result<Vec<[[f32; 3]; 3]>, String> {
    let scene = if name == "room" {
        furnished_room(models)?
    } else {
        Scene::builtin(name).map_err(|e| e.to_string())?
    };
    Ok(scene.world_triangles().0)
}

#[cfg(embree)]
const EMBREE: Result<&str, &str> = Ok("3.13 (libembree3, rtcIntersect1 / rtcOccluded1)");
#[cfg(not(embree))]
const EMBREE: Result<&str, &str> =
    Err("Embree not available (libembree-dev not found when this bench was built)");

fn run(args: &Args) -> Result<serde_json::Value, String> {
    if let Err(why) = EMBREE {
        eprintln!("{why}: measuring luxbake alone");
    }
    let mut scenes = Vec::new();
    for name in &args.scenes {
        let tris = match load(name, &args.models) {
            Ok(t) => t,
            Err(e) if name == "room" => {
                eprintln!("skipping room: {e}");
                continue;
            }
            Err(e) => return Err(e),
        };
        let bvh = Bvh::build(&tris, &BuildOptions::default()).map_err(|e| e.to_string())?;
        let attributes = vec![TriangleAttributes::default(); tris.len()];
        let encoded = encode(
            &bvh,
            &tris,
            &attributes,
            &EncodeOptions {
                max_texture_size: 16_384,
            },
        )
        .map_err(|e| e.to_string())?;
        #[cfg(embree)]
        let embree = embree::Embree::new(&tris)?;
        let wide = WideBvh::from_encoded(&encoded);
        let tracers = [
            Tracer::Mtbvh(&encoded),
            Tracer::Wide(&wide, &encoded),
            #[cfg(embree)]
            Tracer::Embree(&embree),
        ];
        eprintln!(
            "{name}: {} triangles, {} wide nodes, {} packets",
            tris.len(),
            wide.node_count(),
            wide.packet_count()
        );
        let mut sets = Vec::new();
        for set in ray_sets(&tris, args.rays) {
            let reference: Vec<u32> = set
                .rays
                .iter()
                .map(|&q| tracers[0].input_index(tracers[0].trace(q, set.any_hit), set.any_hit))
                .collect();
            let mut times = vec![Vec::new(); tracers.len()];
            for _ in 0..args.runs.max(1) {
                for (tracer, t) in tracers.iter().zip(&mut times) {
                    let t0 = thread_seconds();
                    let mut sum = 0u32;
                    for &q in &set.rays {
                        sum = sum.wrapping_add(tracer.trace(black_box(q), set.any_hit));
                    }
                    black_box(sum);
                    t.push(thread_seconds() - t0);
                }
            }
            let results: Vec<_> = tracers
                .iter()
                .zip(&times)
                .map(|(tracer, t)| {
                    let mut t = t.clone();
                    t.sort_by(f64::total_cmp);
                    let median = t[t.len() / 2];
                    let agree = set
                        .rays
                        .iter()
                        .zip(&reference)
                        .filter(|&(&q, &r)| {
                            tracer.input_index(tracer.trace(q, set.any_hit), set.any_hit) == r
                        })
                        .count() as f64
                        / set.rays.len().max(1) as f64;
                    let hits = reference
                        .iter()
                        .filter(|&&r| r != u32::MAX && r != 0)
                        .count();
                    eprintln!(
                        "  {:7} {:14} {:7.2} M rays/s  agree {:.5}",
                        set.name,
                        tracer.name(),
                        set.rays.len() as f64 / median * 1e-6,
                        agree
                    );
                    json!({
                        "tracer": tracer.name(),
                        "rays_per_s": set.rays.len() as f64 / median,
                        "seconds": t,
                        "agree": agree,
                        "reference_hits": hits,
                    })
                })
                .collect();
            sets.push(json!({
                "set": set.name,
                "query": if set.any_hit { "any hit" } else { "closest hit" },
                "rays": set.rays.len(),
                "results": results,
            }));
        }
        scenes.push(json!({ "scene": name, "triangles": tris.len(), "sets": sets }));
    }
    let mut bake_gather = Vec::new();
    for name in args.bake_gather.iter().filter(|n| !n.is_empty()) {
        eprintln!("{name}: bake-level gather, {} rounds", args.runs.max(1));
        bake_gather.push(gather::measure(name, args.runs)?);
    }
    Ok(json!({
        "embree": EMBREE.ok(),
        "embree_missing": EMBREE.err(),
        "threads": 1,
        "runs": args.runs,
        "scenes": scenes,
        "bake_gather": bake_gather,
    }))
}
