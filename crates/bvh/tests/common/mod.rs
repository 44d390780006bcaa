//! Scene generators, a small seeded RNG and a glTF loader shared by the integration tests and
//! the bench (`#[path]`-included there). Not every test binary uses every helper.
#![allow(dead_code)]

use luxbake_bvh::{BuildOptions, Bvh, EncodeOptions, EncodedScene, TriangleAttributes, encode};
use luxbake_testkit::SplitMix64;

/// A triangle as the crate takes it.
pub type Tri = [[f32; 3]; 3];

/// The workspace's SplitMix64 ([`luxbake_testkit::SplitMix64`], its methods through `Deref`)
/// with the ray directions the tests draw.
pub struct Rng(SplitMix64);

impl std::ops::Deref for Rng {
    type Target = SplitMix64;
    fn deref(&self) -> &SplitMix64 {
        &self.0
    }
}

impl std::ops::DerefMut for Rng {
    fn deref_mut(&mut self) -> &mut SplitMix64 {
        &mut self.0
    }
}

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(SplitMix64::new(seed))
    }

    /// A random direction, sometimes axis-aligned with ±0 in the other components.
    pub fn direction(&mut self) -> [f32; 3] {
        match self.below(8) {
            0 => {
                let axis = self.below(3) as usize;
                let mut d = [0.0f32; 3];
                for (a, c) in d.iter_mut().enumerate() {
                    *c = if a == axis {
                        if self.below(2) == 0 { 1.0 } else { -1.0 }
                    } else if self.below(2) == 0 {
                        0.0
                    } else {
                        -0.0
                    };
                }
                d
            }
            1 => {
                // One zero component.
                let mut d = self.point(-1.0, 1.0);
                d[self.below(3) as usize] = if self.below(2) == 0 { 0.0 } else { -0.0 };
                if d.iter().all(|c| *c == 0.0) {
                    [1.0, 0.0, 0.0]
                } else {
                    d
                }
            }
            _ => loop {
                let d = self.point(-1.0, 1.0);
                let l2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                if l2 > 1e-4 && l2 <= 1.0 {
                    break d;
                }
            },
        }
    }
}

/// The property tests' configuration: `cases` cases, or `PROPTEST_CASES` where set (a long
/// run: `PROPTEST_CASES=20000 cargo test -p luxbake-bvh --test agreement`); failures saved
/// beside the test's source (`<test>.proptest-regressions`) and replayed first on every run.
pub fn proptest_config(cases: u32) -> proptest::test_runner::Config {
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(cases);
    proptest::test_runner::Config {
        cases,
        failure_persistence: Some(Box::new(
            proptest::test_runner::FileFailurePersistence::WithSource("proptest-regressions"),
        )),
        ..proptest::test_runner::Config::default()
    }
}

/// A random "soup" in [0, 1]³: ordinary triangles of random size, plus some zero-area ones,
/// exact duplicates, axis-aligned flat ones and shared edges.
pub fn random_scene(rng: &mut Rng, count: usize) -> Vec<Tri> {
    let mut tris: Vec<Tri> = Vec::with_capacity(count);
    while tris.len() < count {
        let kind = rng.below(12);
        let c = rng.point(0.0, 1.0);
        let s = rng.range(0.001, 0.3);
        let pick = rng.below(tris.len().max(1) as u64) as usize;
        let mut v = || {
            let o = rng.point(-s, s);
            [c[0] + o[0], c[1] + o[1], c[2] + o[2]]
        };
        let tri = match kind {
            0 => [c, c, c], // a point
            1 => {
                let a = v();
                let b = v();
                [
                    a,
                    b,
                    [
                        a[0] * 0.5 + b[0] * 0.5,
                        a[1] * 0.5 + b[1] * 0.5,
                        a[2] * 0.5 + b[2] * 0.5,
                    ],
                ]
            } // collinear
            2 if !tris.is_empty() => tris[pick], // duplicate
            3 => {
                // flat in an axis plane
                let axis = (kind as usize + pick) % 3;
                let mut t = [v(), v(), v()];
                for p in &mut t {
                    p[axis] = c[axis];
                }
                t
            }
            4 if !tris.is_empty() => {
                // shares an edge with an earlier triangle
                let o = tris[pick];
                [o[0], o[1], v()]
            }
            _ => [v(), v(), v()],
        };
        tris.push(tri);
    }
    tris
}

/// The 12 triangles of an axis-aligned box, outward winding, shared corners.
pub fn box_triangles(min: [f32; 3], max: [f32; 3]) -> Vec<Tri> {
    let p = |i: usize| {
        [
            if i & 1 == 0 { min[0] } else { max[0] },
            if i & 2 == 0 { min[1] } else { max[1] },
            if i & 4 == 0 { min[2] } else { max[2] },
        ]
    };
    const QUADS: [[usize; 4]; 6] = [
        [0, 4, 6, 2], // -x
        [1, 3, 7, 5], // +x
        [0, 1, 5, 4], // -y
        [2, 6, 7, 3], // +y
        [0, 2, 3, 1], // -z
        [4, 5, 7, 6], // +z
    ];
    QUADS
        .iter()
        .flat_map(|q| [[p(q[0]), p(q[1]), p(q[2])], [p(q[0]), p(q[2]), p(q[3])]])
        .collect()
}

/// A simple chair from boxes: seat, back, four legs (72 triangles), at `(x, z)` on the floor.
pub fn chair(x: f32, z: f32) -> Vec<Tri> {
    let mut t = Vec::new();
    t.extend(box_triangles([x, 0.45, z], [x + 0.45, 0.5, z + 0.45]));
    t.extend(box_triangles([x, 0.5, z + 0.4], [x + 0.45, 1.0, z + 0.45]));
    for (dx, dz) in [(0.0, 0.0), (0.4, 0.0), (0.0, 0.4), (0.4, 0.4)] {
        t.extend(box_triangles(
            [x + dx, 0.0, z + dz],
            [x + dx + 0.05, 0.45, z + dz + 0.05],
        ));
    }
    t
}

/// A tessellated closed box: each face an `n × n` grid of quads (two triangles each), vertices
/// shared exactly between neighbours and across the cube's edges. Coordinates are multiples
/// of `size / n` (exact for power-of-two `n`).
pub fn tessellated_box(min: [f32; 3], size: f32, n: usize) -> Vec<Tri> {
    let mut tris = Vec::new();
    let step = size / n as f32;
    let g = |i: usize| i as f32 * step;
    for axis in 0..3 {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        for side in [0usize, n] {
            for i in 0..n {
                for j in 0..n {
                    let corner = |di: usize, dj: usize| {
                        let mut p = min;
                        p[axis] += g(side);
                        p[u] += g(i + di);
                        p[v] += g(j + dj);
                        p
                    };
                    // Alternate the diagonal so edges run in several directions.
                    if (i + j) % 2 == 0 {
                        tris.push([corner(0, 0), corner(1, 0), corner(1, 1)]);
                        tris.push([corner(0, 0), corner(1, 1), corner(0, 1)]);
                    } else {
                        tris.push([corner(0, 0), corner(1, 0), corner(0, 1)]);
                        tris.push([corner(1, 0), corner(1, 1), corner(0, 1)]);
                    }
                }
            }
        }
    }
    tris
}

/// A closed UV sphere with exactly shared vertices (poles are fans).
pub fn uv_sphere(centre: [f32; 3], radius: f32, rings: usize, segments: usize) -> Vec<Tri> {
    let vertex = |r: usize, s: usize| -> [f32; 3] {
        if r == 0 {
            return [centre[0], centre[1] + radius, centre[2]];
        }
        if r == rings {
            return [centre[0], centre[1] - radius, centre[2]];
        }
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        let phi = std::f32::consts::TAU * (s % segments) as f32 / segments as f32;
        [
            centre[0] + radius * theta.sin() * phi.cos(),
            centre[1] + radius * theta.cos(),
            centre[2] + radius * theta.sin() * phi.sin(),
        ]
    };
    let mut tris = Vec::new();
    for r in 0..rings {
        for s in 0..segments {
            let (a, b, c, d) = (
                vertex(r, s),
                vertex(r, s + 1),
                vertex(r + 1, s),
                vertex(r + 1, s + 1),
            );
            if r != 0 {
                tris.push([a, c, b]);
            }
            if r != rings - 1 {
                tris.push([b, c, d]);
            }
        }
    }
    tris
}

/// The paper's `chairs_10`-like scene (2364 triangles): a 6 × 3 × 5 m room (walls and ceiling
/// as boxes, 60 triangles), 10 box chairs (720) and a tessellated floor grid (1584), as a
/// light-mapped room would be.
pub fn room_with_chairs() -> Vec<Tri> {
    let mut tris = Vec::new();
    // Ceiling slab and four walls; the floor is the grid below.
    let slab =
        |tris: &mut Vec<Tri>, min: [f32; 3], max: [f32; 3]| tris.extend(box_triangles(min, max));
    slab(&mut tris, [0.0, 3.0, 0.0], [6.0, 3.1, 5.0]);
    slab(&mut tris, [-0.1, 0.0, 0.0], [0.0, 3.0, 5.0]);
    slab(&mut tris, [6.0, 0.0, 0.0], [6.1, 3.0, 5.0]);
    slab(&mut tris, [0.0, 0.0, -0.1], [6.0, 3.0, 0.0]);
    slab(&mut tris, [0.0, 0.0, 5.0], [6.0, 3.0, 5.1]);
    for k in 0..10 {
        let x = 0.5 + (k % 5) as f32 * 1.1;
        let z = 1.0 + (k / 5) as f32 * 2.0;
        tris.extend(chair(x, z));
    }
    // The floor: a 36 × 22 grid of quads.
    let (nx, nz) = (36usize, 22usize);
    for i in 0..nx {
        for j in 0..nz {
            let (x0, x1) = (6.0 * i as f32 / nx as f32, 6.0 * (i + 1) as f32 / nx as f32);
            let (z0, z1) = (5.0 * j as f32 / nz as f32, 5.0 * (j + 1) as f32 / nz as f32);
            tris.push([[x0, 0.0, z0], [x1, 0.0, z0], [x1, 0.0, z1]]);
            tris.push([[x0, 0.0, z0], [x1, 0.0, z1], [x0, 0.0, z1]]);
        }
    }
    tris
}

/// Simple attributes: face normal at every vertex, UVs from x/z, object id from the index.
pub fn attributes(tris: &[Tri], objects: u32) -> Vec<TriangleAttributes> {
    tris.iter()
        .enumerate()
        .map(|(i, t)| {
            let e1 = [t[1][0] - t[0][0], t[1][1] - t[0][1], t[1][2] - t[0][2]];
            let e2 = [t[2][0] - t[0][0], t[2][1] - t[0][1], t[2][2] - t[0][2]];
            let n = [
                e1[1] * e2[2] - e1[2] * e2[1],
                e1[2] * e2[0] - e1[0] * e2[2],
                e1[0] * e2[1] - e1[1] * e2[0],
            ];
            TriangleAttributes {
                normals: [n; 3],
                uvs: t.map(|p| [p[0], p[2]]),
                object: i as u32 % objects.max(1),
            }
        })
        .collect()
}

/// Builds and encodes with default options.
pub fn build_and_encode(tris: &[Tri]) -> EncodedScene {
    build_and_encode_objects(tris, 7).1
}

/// Builds with default options and encodes with the attributes of `objects` objects
/// ([`attributes`]): the tree and the encoding.
pub fn build_and_encode_objects(tris: &[Tri], objects: u32) -> (Bvh, EncodedScene) {
    let bvh = build(tris, BuildOptions::default());
    let scene = encode(
        &bvh,
        tris,
        &attributes(tris, objects),
        &EncodeOptions::default(),
    )
    .expect("encode");
    (bvh, scene)
}

/// Builds with `options`.
pub fn build(tris: &[Tri], options: BuildOptions) -> Bvh {
    Bvh::build(tris, &options).expect("build")
}

/// World-space triangles of every mesh instance of the default scene of a `.glb` file.
pub fn load_glb(path: &std::path::Path) -> Result<Vec<Tri>, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    // Without validation: the models require material extensions (KHR_texture_transform)
    // that do not matter for geometry.
    let gltf = gltf::Gltf::from_slice_without_validation(&bytes)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let blob = gltf.blob.as_deref().ok_or("no binary chunk")?;
    let scene = gltf
        .default_scene()
        .or_else(|| gltf.scenes().next())
        .ok_or("no scene")?;
    let mut tris = Vec::new();
    let mut stack: Vec<(gltf::Node, [[f32; 4]; 4])> =
        scene.nodes().map(|n| (n, IDENTITY)).collect();
    while let Some((node, parent)) = stack.pop() {
        let m = mul(&parent, &node.transform().matrix());
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                if prim.mode() != gltf::mesh::Mode::Triangles {
                    continue;
                }
                let reader = prim.reader(|b| match b.source() {
                    gltf::buffer::Source::Bin => Some(blob),
                    gltf::buffer::Source::Uri(_) => None,
                });
                let Some(positions) = reader.read_positions() else {
                    continue;
                };
                let p: Vec<[f32; 3]> = positions.map(|v| transform(&m, v)).collect();
                let indices: Vec<u32> = match reader.read_indices() {
                    Some(i) => i.into_u32().collect(),
                    None => (0..p.len() as u32).collect(),
                };
                for t in indices.chunks_exact(3) {
                    let get = |i: u32| p.get(i as usize).copied().ok_or("index out of range");
                    tris.push([get(t[0])?, get(t[1])?, get(t[2])?]);
                }
            }
        }
        stack.extend(node.children().map(|c| (c, m)));
    }
    Ok(tris)
}

const IDENTITY: [[f32; 4]; 4] = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

/// Column-major 4×4 product `a · b`.
fn mul(a: &[[f32; 4]; 4], b: &[[f32; 4]; 4]) -> [[f32; 4]; 4] {
    let mut out = [[0.0; 4]; 4];
    for (c, col) in out.iter_mut().enumerate() {
        for (r, v) in col.iter_mut().enumerate() {
            *v = (0..4).map(|k| a[k][r] * b[c][k]).sum();
        }
    }
    out
}

fn transform(m: &[[f32; 4]; 4], p: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|r| m[0][r] * p[0] + m[1][r] * p[1] + m[2][r] * p[2] + m[3][r])
}

/// The named model of `../shared/models` (repository root), its triangles, or `None` after
/// [`luxbake_testkit::skip_or_fail`] (which fails the test under CI).
pub fn load_model(name: &str) -> Option<Vec<Tri>> {
    let path = luxbake_testkit::shared_data(name, &format!("models/{name}/{name}.glb"))?;
    Some(load_glb(&path).expect("loading a shared model"))
}

/// Every way of walking the encoding: brute force, TBVH, MTBVH by direction and each of the
/// six MTBVH link layers forced for every ray; and the wide BVH collapsed from it (`wide`,
/// [`luxbake_bvh::WideBvh::from_encoded`] of `scene`).
pub fn check_agreement(
    scene: &EncodedScene,
    wide: &luxbake_bvh::WideBvh,
    ray: &luxbake_bvh::Ray,
    t_min: f32,
    t_max: f32,
) -> Result<Option<luxbake_bvh::Hit>, String> {
    use luxbake_bvh::{LinkTexture, Traversal};
    let reference = scene.closest_hit(ray, t_min, t_max, Traversal::BruteForce);
    let any_reference = scene.any_hit(ray, t_min, t_max, Traversal::BruteForce);
    if any_reference != reference.is_some() {
        return Err(format!(
            "brute force any-hit {any_reference} vs closest {reference:?}"
        ));
    }
    // The hit lies in its triangle's box (up to rounding): no hit far from its triangle, as
    // slivers gave before they were encoded unhittable.
    if let Some(r) = reference {
        let p = scene.triangle_positions(r.triangle);
        let outside = (0..3).find(|&k| {
            let at = f64::from(ray.origin[k]) + f64::from(r.t) * f64::from(ray.dir[k]);
            let (lo, hi) = axis_range(&p, k);
            let slack = 1e-4 * (1.0 + lo.abs().max(hi.abs()));
            !(lo - slack <= at && at <= hi + slack)
        });
        if let Some(k) = outside {
            return Err(format!(
                "brute force hit {r:?} lies outside its triangle {p:?}'s box on axis {k}"
            ));
        }
    }
    let mut results = vec![
        (
            "TBVH",
            scene.closest_hit(ray, t_min, t_max, Traversal::Tbvh),
        ),
        (
            "MTBVH",
            scene.closest_hit(ray, t_min, t_max, Traversal::Mtbvh),
        ),
        ("wide", wide.closest_hit(ray, t_min, t_max)),
    ];
    let mut any = vec![
        ("TBVH", scene.any_hit(ray, t_min, t_max, Traversal::Tbvh)),
        ("MTBVH", scene.any_hit(ray, t_min, t_max, Traversal::Mtbvh)),
        ("wide", wide.any_hit(ray, t_min, t_max)),
    ];
    const LAYERS: [&str; 6] = ["+x", "-x", "+y", "-y", "+z", "-z"];
    for (d, name) in LAYERS.iter().enumerate() {
        let links = LinkTexture::Mtbvh(d as u32);
        results.push((name, scene.closest_hit_with(ray, t_min, t_max, links)));
        any.push((name, scene.any_hit_with(ray, t_min, t_max, links)));
    }
    for (name, hit) in results {
        match (reference, hit) {
            (None, None) => {}
            (Some(r), Some(h)) => {
                let close = |t: f32| (t - r.t).abs() <= 1e-5 * r.t.abs().max(1e-2);
                if h.triangle == r.triangle {
                    // The same triangle's test is computed identically: bit-identical result.
                    if (h.t.to_bits(), h.u.to_bits(), h.v.to_bits())
                        != (r.t.to_bits(), r.u.to_bits(), r.v.to_bits())
                    {
                        return Err(format!(
                            "{name}: same triangle, different hit {h:?} vs {r:?}"
                        ));
                    }
                } else {
                    // Another triangle only for a tie (up to rounding): its own t must be the
                    // reference t within the tolerance.
                    let p = scene.triangle_positions(h.triangle);
                    let own = luxbake_bvh::WatertightRay::new(ray)
                        .and_then(|w| w.hits_triangle(p[0], p[1], p[2], t_min, t_max))
                        .map(|(t, _, _)| t);
                    if !(close(h.t) && own == Some(h.t)) {
                        return Err(format!("{name}: {h:?} vs brute force {r:?}"));
                    }
                }
            }
            (r, h) => return Err(format!("{name}: {h:?} vs brute force {r:?}")),
        }
    }
    for (name, a) in any {
        if a != any_reference {
            return Err(format!(
                "{name}: any-hit {a} vs brute force {any_reference}"
            ));
        }
    }
    Ok(reference)
}

/// obvhs's own triangles for the same input.
pub fn obvhs_triangles(tris: &[Tri]) -> Vec<obvhs::triangle::Triangle> {
    tris.iter()
        .map(|t| obvhs::triangle::Triangle {
            v0: glam::Vec3A::from_array(t[0]),
            v1: glam::Vec3A::from_array(t[1]),
            v2: glam::Vec3A::from_array(t[2]),
        })
        .collect()
}

/// obvhs parameters comparable with ours: no spatial splits (every triangle in exactly one
/// leaf), at most `max_leaf` triangles per leaf, collapse cost ratio 1 (our default costs).
pub fn obvhs_params(slow: bool, max_leaf: u32) -> obvhs::BvhBuildParams {
    let mut p = if slow {
        obvhs::BvhBuildParams::very_slow_build()
    } else {
        obvhs::BvhBuildParams::medium_build()
    };
    p.pre_split = false;
    p.max_prims_per_leaf = max_leaf;
    p.collapse_traversal_cost = 1.0;
    p
}

pub fn obvhs_build(
    tris: &[obvhs::triangle::Triangle],
    params: obvhs::BvhBuildParams,
) -> obvhs::bvh2::Bvh2 {
    obvhs::bvh2::builder::build_bvh2_from_tris(tris, params, &mut std::time::Duration::default())
}

/// SAH cost of an obvhs tree with our formula and constants (walked from the root).
pub fn obvhs_sah(bvh: &obvhs::bvh2::Bvh2, traversal_cost: f32, intersection_cost: f32) -> f32 {
    let mut order = Vec::with_capacity(bvh.nodes.len());
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        let n = &bvh.nodes[i];
        let leaf = n.prim_count > 0;
        order.push((
            n.aabb().min.to_array(),
            n.aabb().max.to_array(),
            leaf.then_some(n.prim_count),
        ));
        if !leaf {
            stack.push(n.first_index as usize + 1);
            stack.push(n.first_index as usize);
        }
    }
    luxbake_bvh::sah_cost(order, traversal_cost, intersection_cost)
}

/// `ray` for obvhs, over `[t_min, t_max]`.
fn obvhs_ray(ray: &luxbake_bvh::Ray, t_min: f32, t_max: f32) -> obvhs::ray::Ray {
    obvhs::ray::Ray::new(
        glam::Vec3A::from_array(ray.origin),
        glam::Vec3A::from_array(ray.dir),
        t_min,
        t_max,
    )
}

/// obvhs closest hit (its own stack traversal and Möller–Trumbore test): `(t, input index)`.
pub fn obvhs_closest(
    bvh: &obvhs::bvh2::Bvh2,
    tris: &[obvhs::triangle::Triangle],
    ray: &luxbake_bvh::Ray,
    t_min: f32,
    t_max: f32,
) -> Option<(f32, u32)> {
    let r = obvhs_ray(ray, t_min, t_max);
    let mut hit = obvhs::ray::RayHit::none();
    bvh.ray_traverse(r, &mut hit, |r, id| {
        tris[bvh.primitive_indices[id] as usize].intersect(r)
    })
    .then(|| (hit.t, bvh.primitive_indices[hit.primitive_id as usize]))
}

/// obvhs any hit.
pub fn obvhs_any(
    bvh: &obvhs::bvh2::Bvh2,
    tris: &[obvhs::triangle::Triangle],
    ray: &luxbake_bvh::Ray,
    t_min: f32,
    t_max: f32,
) -> bool {
    let r = obvhs_ray(ray, t_min, t_max);
    !bvh.ray_traverse_miss(r, |r, id| {
        tris[bvh.primitive_indices[id] as usize].intersect(r)
    })
}

/// The bounding box of `tris`: (min, max) per axis.
pub fn bounds(tris: &[Tri]) -> ([f32; 3], [f32; 3]) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in tris.iter().flatten() {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    (lo, hi)
}

/// The range of `tri`'s coordinate `k`, in f64: (min, max).
pub fn axis_range(tri: &[[f32; 3]; 3], k: usize) -> (f64, f64) {
    let c = tri.map(|v| f64::from(v[k]));
    (
        c.into_iter().fold(f64::INFINITY, f64::min),
        c.into_iter().fold(f64::NEG_INFINITY, f64::max),
    )
}

/// Rays for a model: half from random points around its bounds towards random points on
/// random triangles, half from random points inside the bounds in random directions.
pub fn model_rays(tris: &[Tri], count: usize, seed: u64) -> Vec<luxbake_bvh::Ray> {
    let (lo, hi) = bounds(tris);
    let mut rng = Rng::new(seed);
    (0..count)
        .map(|i| {
            let pick = |rng: &mut Rng, grow: f32| -> [f32; 3] {
                std::array::from_fn(|a| {
                    let e = hi[a] - lo[a];
                    rng.range(lo[a] - grow * e, hi[a] + grow * e)
                })
            };
            if i % 2 == 0 && !tris.is_empty() {
                let origin = pick(&mut rng, 0.5);
                let t = tris[rng.below(tris.len() as u64) as usize];
                let (a, b) = (rng.f32() * 0.5, rng.f32() * 0.5);
                let target: [f32; 3] = std::array::from_fn(|k| {
                    t[0][k] + a * (t[1][k] - t[0][k]) + b * (t[2][k] - t[0][k])
                });
                let dir = std::array::from_fn(|k| target[k] - origin[k]);
                luxbake_bvh::Ray { origin, dir }
            } else {
                luxbake_bvh::Ray {
                    origin: pick(&mut rng, 0.0),
                    dir: rng.direction(),
                }
            }
        })
        .collect()
}
