//! Watertightness: rays aimed exactly at shared edges and vertices of closed meshes never
//! escape, with every traversal.

mod common;

use common::{Rng, Tri, build_and_encode, check_agreement, tessellated_box, uv_sphere};
use luxbake_bvh::{EncodedScene, Ray, Traversal, WideBvh};

const ALL: [Traversal; 3] = [Traversal::Mtbvh, Traversal::Tbvh, Traversal::BruteForce];

/// Vertices and points on edges (exact edge midpoints where representable, otherwise the
/// rounded point `a + s·(b − a)`) of every triangle.
fn edge_and_vertex_targets(tris: &[Tri], rng: &mut Rng) -> Vec<[f32; 3]> {
    let mut targets = Vec::new();
    for t in tris {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            targets.push(a);
            targets.push(std::array::from_fn(|i| a[i] * 0.5 + b[i] * 0.5));
            let s = rng.f32();
            targets.push(std::array::from_fn(|i| a[i] + s * (b[i] - a[i])));
        }
    }
    targets
}

/// Panics (naming `label` and `ray`) unless `hit` is a hit at `t = 1` (the ray's target).
fn assert_hit_at_target(hit: Option<luxbake_bvh::Hit>, label: &str, ray: &Ray) {
    let hit = hit.unwrap_or_else(|| panic!("{label} ray {ray:?} escaped"));
    assert!((hit.t - 1.0).abs() < 1e-4, "{label} {ray:?} t = {}", hit.t);
}

/// Every ray from `origin` (inside the closed mesh) through each target must hit, and the
/// closest hit must be the surface point itself (the mesh is convex around the origin).
fn assert_no_escape(
    scene: &EncodedScene,
    origin: [f32; 3],
    targets: &[[f32; 3]],
    what: &str,
) -> usize {
    let wide = WideBvh::from_encoded(scene);
    let mut rays = 0;
    for (i, target) in targets.iter().enumerate() {
        let dir = [
            target[0] - origin[0],
            target[1] - origin[1],
            target[2] - origin[2],
        ];
        if dir.iter().all(|c| *c == 0.0) {
            continue;
        }
        let ray = Ray { origin, dir };
        for traversal in ALL {
            let hit = scene.closest_hit(&ray, 0.0, f32::INFINITY, traversal);
            assert_hit_at_target(hit, &format!("{what}: {traversal:?}"), &ray);
            assert!(
                scene.any_hit(&ray, 0.0, f32::INFINITY, traversal),
                "{what}: any-hit escaped"
            );
        }
        let hit = wide.closest_hit(&ray, 0.0, f32::INFINITY);
        assert_hit_at_target(hit, &format!("{what}: wide"), &ray);
        assert!(
            wide.any_hit(&ray, 0.0, f32::INFINITY),
            "{what}: wide any-hit escaped"
        );
        if i % 8 == 0 {
            check_agreement(scene, &wide, &ray, 0.0, f32::INFINITY)
                .unwrap_or_else(|e| panic!("{what}: {e}"));
        }
        rays += 1;
    }
    rays
}

#[test]
fn tessellated_box_has_no_cracks() {
    // Coordinates are multiples of 1/16: vertices and edge midpoints are exact.
    let tris = tessellated_box([0.0, 0.0, 0.0], 1.0, 8);
    let scene = build_and_encode(&tris);
    let mut rng = Rng::new(1);
    let targets = edge_and_vertex_targets(&tris, &mut rng);
    let mut origins = vec![
        [0.5, 0.5, 0.5],
        [0.25, 0.5, 0.125],
        [0.125, 0.125, 0.125],
        [0.875, 0.5, 0.0625],
    ];
    origins.extend((0..2).map(|_| rng.point(0.01, 0.99)));
    let mut rays = 0;
    for origin in origins {
        rays += assert_no_escape(&scene, origin, &targets, "box");
    }
    assert!(rays > 30_000, "{rays}");
}

#[test]
fn uv_sphere_has_no_cracks() {
    let tris = uv_sphere([0.1, -0.2, 0.3], 1.5, 16, 32);
    let scene = build_and_encode(&tris);
    let mut rng = Rng::new(2);
    let targets = edge_and_vertex_targets(&tris, &mut rng);
    let mut origins = vec![[0.1, -0.2, 0.3], [0.1, 1.0, 0.3], [0.1, -0.2, -1.0]];
    origins.extend((0..3).map(|_| {
        let p = rng.point(-0.7, 0.7);
        [p[0] + 0.1, p[1] - 0.2, p[2] + 0.3]
    }));
    for origin in origins {
        assert_no_escape(&scene, origin, &targets, "sphere");
    }
}

/// Rays from outside through shared edges and vertices, continuing into the mesh: they must
/// hit (the entry point), and rays through the centre along the axes (with ±0 components)
/// hit exactly at grid vertices.
#[test]
fn rays_from_outside_through_edges_hit() {
    let tris = tessellated_box([-1.0, -1.0, -1.0], 2.0, 4);
    let scene = build_and_encode(&tris);
    let mut rng = Rng::new(3);
    let targets = edge_and_vertex_targets(&tris, &mut rng);
    for (i, target) in targets.iter().enumerate() {
        // An origin outside, on the side of the target's face, so the ray enters there.
        let outward: [f32; 3] = std::array::from_fn(|k| {
            if target[k].abs() == 1.0 {
                target[k]
            } else {
                0.0
            }
        });
        let jitter = rng.point(-0.5, 0.5);
        let origin: [f32; 3] = std::array::from_fn(|k| {
            target[k] + 2.0 * outward[k] + jitter[k] * (1.0 - outward[k].abs())
        });
        let dir: [f32; 3] = std::array::from_fn(|k| target[k] - origin[k]);
        let ray = Ray { origin, dir };
        for traversal in ALL {
            let hit = scene.closest_hit(&ray, 0.0, f32::INFINITY, traversal);
            assert!(
                hit.is_some_and(|h| (h.t - 1.0).abs() < 1e-5),
                "target {i}: {traversal:?} {ray:?} {hit:?}"
            );
        }
    }
    for (origin, dir) in [
        ([0.0, 0.0, -5.0], [0.0, -0.0, 1.0]),
        ([-0.0, 5.0, 0.0], [-0.0, -1.0, 0.0]),
        ([-5.0, 0.0, 0.0], [1.0, 0.0, -0.0]),
        ([0.5, 0.5, 5.0], [-0.0, 0.0, -1.0]),
    ] {
        for traversal in ALL {
            let hit = scene.closest_hit(&Ray { origin, dir }, 0.0, f32::INFINITY, traversal);
            assert_eq!(
                hit.map(|h| h.t),
                Some(4.0),
                "{origin:?} {dir:?} {traversal:?}"
            );
        }
    }
}
