//! Structural invariants of the canonical BVH, its link orders and the encoding.

mod common;

use common::{Rng, attributes, build, random_scene};
use luxbake_bvh::{BuildOptions, Bvh, ChildOrder, EncodeOptions, Link, NodeKind, encode, layout};

fn scenes() -> Vec<(u64, Vec<common::Tri>)> {
    (0..40u64)
        .map(|seed| {
            let mut rng = Rng::new(seed);
            let n = 1 + rng.below(400) as usize;
            (seed, random_scene(&mut rng, n))
        })
        .collect()
}

fn option_sets() -> Vec<BuildOptions> {
    vec![
        BuildOptions::default(),
        BuildOptions {
            max_leaf_size: 1,
            bins: 2,
            ..BuildOptions::default()
        },
        BuildOptions {
            max_leaf_size: 16,
            bins: 64,
            traversal_cost: 0.0,
            ..BuildOptions::default()
        },
        BuildOptions {
            max_leaf_size: 8,
            bins: 256,
            traversal_cost: 10.0,
            intersection_cost: 0.5,
        },
    ]
}

#[test]
fn every_triangle_is_in_exactly_one_leaf_and_boxes_nest() {
    for (seed, tris) in scenes() {
        for options in option_sets() {
            let bvh = Bvh::build(&tris, &options).expect("build");
            let nodes = bvh.nodes();
            let order = bvh.triangle_order();
            let mut seen = vec![0u32; tris.len()];
            for &t in order {
                seen[t as usize] += 1;
            }
            assert!(
                seen.iter().all(|&c| c == 1),
                "seed {seed}: order is not a permutation"
            );
            let mut covered = vec![0u32; tris.len()];
            for (i, node) in nodes.iter().enumerate() {
                match node.kind {
                    NodeKind::Leaf { first, count } => {
                        assert!(
                            count >= 1 && count <= options.max_leaf_size,
                            "seed {seed}: leaf size {count}"
                        );
                        for slot in first..first + count {
                            covered[slot as usize] += 1;
                            for p in tris[order[slot as usize] as usize] {
                                assert!(
                                    (0..3).all(|a| node.min[a] <= p[a] && p[a] <= node.max[a]),
                                    "seed {seed}: triangle outside leaf {i}"
                                );
                            }
                        }
                    }
                    NodeKind::Inner { left, right } => {
                        assert_eq!(left as usize, i + 1, "seed {seed}: not pre-order");
                        for c in [left, right] {
                            let c = &nodes[c as usize];
                            assert!(
                                (0..3).all(|a| node.min[a] <= c.min[a] && c.max[a] <= node.max[a]),
                                "seed {seed}: child box escapes node {i}"
                            );
                        }
                    }
                }
            }
            assert!(
                covered.iter().all(|&c| c == 1),
                "seed {seed}: slot not in exactly one leaf"
            );
            assert_eq!(
                nodes.len(),
                2 * leaf_count(&bvh) - 1,
                "seed {seed}: not a full binary tree"
            );
            // The same tree passes the public invariant check.
            let rebuilt = Bvh::from_parts(nodes.to_vec(), order.to_vec()).expect("valid parts");
            assert_eq!(rebuilt, bvh);
        }
    }
}

fn leaf_count(bvh: &Bvh) -> usize {
    bvh.nodes()
        .iter()
        .filter(|n| matches!(n.kind, NodeKind::Leaf { .. }))
        .count()
}

#[test]
fn from_parts_rejects_broken_trees() {
    let mut rng = Rng::new(3);
    let tris = random_scene(&mut rng, 50);
    let bvh = Bvh::build(&tris, &BuildOptions::default()).expect("build");
    let (nodes, order) = (bvh.nodes().to_vec(), bvh.triangle_order().to_vec());
    // Duplicate index in the order.
    let mut bad = order.clone();
    bad[1] = bad[0];
    assert!(Bvh::from_parts(nodes.clone(), bad).is_none());
    // A child box that escapes its parent.
    let mut bad = nodes.clone();
    bad[1].max[0] = bad[0].max[0] + 1.0;
    assert!(Bvh::from_parts(bad, order.clone()).is_none());
    // Children swapped: no longer pre-order.
    let mut bad = nodes.clone();
    if let NodeKind::Inner { left, right } = bad[0].kind {
        bad[0].kind = NodeKind::Inner {
            left: right,
            right: left,
        };
    }
    assert!(Bvh::from_parts(bad, order.clone()).is_none());
    // A dangling child index.
    let mut bad = nodes.clone();
    bad[0].kind = NodeKind::Inner {
        left: 1,
        right: 10_000,
    };
    assert!(Bvh::from_parts(bad, order.clone()).is_none());
    assert!(Bvh::from_parts(Vec::new(), order).is_none());
}

/// Each link order is a valid stackless traversal: the hit chain from the root visits every
/// node exactly once, a miss link skips exactly the node's subtree, a leaf's hit equals its
/// miss, and both links point strictly forward in the chain (so a ray visits each node at
/// most once).
#[test]
fn link_orders_are_valid_threaded_traversals() {
    let orders: Vec<ChildOrder> = std::iter::once(ChildOrder::Canonical)
        .chain((0..6).map(|direction| ChildOrder::NearFirst { direction }))
        .collect();
    for (seed, tris) in scenes() {
        let bvh = Bvh::build(&tris, &BuildOptions::default()).expect("build");
        let nodes = bvh.nodes();
        for &order in &orders {
            let links = bvh.threaded_links(order);
            assert_eq!(links.len(), nodes.len());
            let mut chain = Vec::new();
            let mut at = Some(0u32);
            while let Some(i) = at {
                assert!(
                    chain.len() < nodes.len(),
                    "seed {seed} {order:?}: hit chain loops"
                );
                chain.push(i);
                at = links[i as usize].hit;
            }
            let mut pos = vec![usize::MAX; nodes.len()];
            for (p, &i) in chain.iter().enumerate() {
                assert_eq!(
                    pos[i as usize],
                    usize::MAX,
                    "seed {seed} {order:?}: node visited twice"
                );
                pos[i as usize] = p;
            }
            assert_eq!(
                chain.len(),
                nodes.len(),
                "seed {seed} {order:?}: node never visited"
            );
            let subtree = subtree_sizes(&bvh);
            for (i, link) in links.iter().enumerate() {
                let after = pos[i] + subtree[i];
                let expected_miss = chain.get(after).copied();
                assert_eq!(
                    link.miss, expected_miss,
                    "seed {seed} {order:?}: miss of node {i}"
                );
                for target in [link.hit, link.miss].into_iter().flatten() {
                    assert!(
                        pos[target as usize] > pos[i],
                        "seed {seed} {order:?}: backward link"
                    );
                }
                match nodes[i].kind {
                    NodeKind::Leaf { .. } => assert_eq!(link.hit, link.miss),
                    NodeKind::Inner { left, right } => {
                        assert!(link.hit == Some(left) || link.hit == Some(right));
                    }
                }
            }
            if order == ChildOrder::Canonical {
                // TBVH: the hit chain is the depth-first numbering itself (paper Figure 8).
                assert!(chain.iter().enumerate().all(|(p, &i)| p == i as usize));
            }
        }
    }
}

/// MTBVH orders put the child nearer along the direction first.
#[test]
fn mtbvh_orders_visit_the_near_child_first() {
    let mut rng = Rng::new(11);
    let tris = random_scene(&mut rng, 500);
    let bvh = Bvh::build(&tris, &BuildOptions::default()).expect("build");
    let nodes = bvh.nodes();
    for direction in 0..6u32 {
        let links = bvh.threaded_links(ChildOrder::NearFirst { direction });
        let axis = (direction / 2) as usize;
        let sign = if direction % 2 == 0 { 1.0 } else { -1.0 };
        for (i, node) in nodes.iter().enumerate() {
            if let NodeKind::Inner { left, right } = node.kind {
                let first = links[i].hit.expect("inner node has a hit link");
                let second = if first == left { right } else { left };
                let c = |n: u32| sign * (nodes[n as usize].min[axis] + nodes[n as usize].max[axis]);
                assert!(c(first) <= c(second), "direction {direction} node {i}");
            }
        }
    }
}

fn subtree_sizes(bvh: &Bvh) -> Vec<usize> {
    let nodes = bvh.nodes();
    let mut size = vec![1usize; nodes.len()];
    for i in (0..nodes.len()).rev() {
        if let NodeKind::Inner { left, right } = nodes[i].kind {
            size[i] = 1 + size[left as usize] + size[right as usize];
        }
    }
    size
}

#[test]
fn encode_decode_round_trip() {
    for (seed, tris) in scenes() {
        let bvh = Bvh::build(&tris, &BuildOptions::default()).expect("build");
        let attrs = attributes(&tris, 5);
        for max_texture_size in [2048, 16384, 64] {
            let scene =
                encode(&bvh, &tris, &attrs, &EncodeOptions { max_texture_size }).expect("encode");
            let [w, h] = scene.node_size;
            let node_layer = (w * h * 4) as usize;
            assert!(w <= max_texture_size && h <= max_texture_size);
            assert!((w * h) as usize >= bvh.nodes().len());
            assert_eq!(scene.links.len(), node_layer * layout::LINK_LAYERS as usize);
            assert_eq!(
                scene.tbvh_links.len(),
                node_layer * layout::TBVH_LINK_LAYERS as usize
            );
            assert_eq!(
                scene.bounds.len(),
                node_layer * layout::BOUNDS_LAYERS as usize
            );
            let [tw, th] = scene.tri_size;
            assert_eq!(
                scene.triangles.len(),
                (tw * th * 4 * layout::TRIANGLE_LAYERS) as usize
            );
            assert_eq!(scene.triangle_count as usize, tris.len());
            assert_eq!(scene.node_count as usize, bvh.nodes().len());
            assert_eq!(scene.triangle_order, bvh.triangle_order());

            let tbvh = bvh.threaded_links(ChildOrder::Canonical);
            let mtbvh: Vec<Vec<Link>> = (0..6)
                .map(|direction| bvh.threaded_links(ChildOrder::NearFirst { direction }))
                .collect();
            for (i, node) in bvh.nodes().iter().enumerate() {
                let e = scene.node(i as u32);
                assert_eq!((e.min, e.max), (node.min, node.max), "seed {seed} node {i}");
                match node.kind {
                    NodeKind::Leaf { first, count } => {
                        assert_eq!((e.first_tri, e.end_tri), (first, first + count));
                    }
                    NodeKind::Inner { .. } => assert_eq!(e.first_tri, e.end_tri),
                }
                assert_eq!(scene.link(i as u32, None), tbvh[i], "seed {seed} node {i}");
                for (d, links) in mtbvh.iter().enumerate() {
                    assert_eq!(scene.link(i as u32, Some(d as u32)), links[i]);
                }
            }
            for (slot, &input) in bvh.triangle_order().iter().enumerate() {
                // Slivers are stored as their first vertex three times (never hit).
                let t = tris[input as usize];
                let expected = if luxbake_bvh::is_sliver(&t) {
                    [t[0]; 3]
                } else {
                    t
                };
                assert_eq!(
                    scene.triangle_positions(slot as u32),
                    expected,
                    "seed {seed} slot {slot}"
                );
                assert_eq!(
                    scene.triangle_attributes(slot as u32),
                    attrs[input as usize]
                );
            }
        }
    }
}

/// Texel (x, y) of node i is (i % w, i / w) and links store exactly these coordinates; the
/// root is at the layout's root texel.
#[test]
fn link_texels_hold_node_coordinates() {
    let mut rng = Rng::new(5);
    let tris = random_scene(&mut rng, 200);
    let bvh = Bvh::build(&tris, &BuildOptions::default()).expect("build");
    let scene = encode(
        &bvh,
        &tris,
        &attributes(&tris, 1),
        &EncodeOptions::default(),
    )
    .expect("encode");
    let w = scene.node_size[0];
    let tbvh = bvh.threaded_links(ChildOrder::Canonical);
    for (i, link) in tbvh.iter().enumerate() {
        let texel = &scene.tbvh_links[i * 4..i * 4 + 4];
        let expect = |l: Option<u32>| match l {
            Some(n) => [(n % w) as f32, (n / w) as f32],
            None => [layout::END_LINK; 2],
        };
        assert_eq!(texel[..2], expect(link.hit));
        assert_eq!(texel[2..], expect(link.miss));
    }
    assert_eq!((layout::ROOT_X, layout::ROOT_Y), (0, 0));
}

#[test]
fn identical_input_gives_byte_identical_textures() {
    for (_, tris) in scenes().into_iter().take(10) {
        let attrs = attributes(&tris, 9);
        let a = Bvh::build(&tris, &BuildOptions::default()).expect("build");
        let b = Bvh::build(&tris.clone(), &BuildOptions::default()).expect("build");
        assert_eq!(a, b);
        let ea = encode(&a, &tris, &attrs, &EncodeOptions::default()).expect("encode");
        let eb = encode(&b, &tris, &attrs, &EncodeOptions::default()).expect("encode");
        let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&ea.links), bits(&eb.links));
        assert_eq!(bits(&ea.tbvh_links), bits(&eb.tbvh_links));
        assert_eq!(bits(&ea.bounds), bits(&eb.bounds));
        assert_eq!(bits(&ea.triangles), bits(&eb.triangles));
        assert_eq!((ea.node_size, ea.tri_size), (eb.node_size, eb.tri_size));
    }
}

#[test]
fn sah_cost_matches_the_formula() {
    // Two unit triangles far apart along x: a root with two leaves.
    let tris = [
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        [[10.0, 0.0, 0.0], [11.0, 0.0, 0.0], [10.0, 1.0, 0.0]],
    ];
    let options = BuildOptions {
        max_leaf_size: 1,
        ..BuildOptions::default()
    };
    let bvh = Bvh::build(&tris, &options).expect("build");
    assert_eq!(bvh.nodes().len(), 3);
    // Half areas: root 11×1 flat box = 11, leaves 1×1 = 1 each.
    let expected = 1.0 + 2.0 * (1.0 / 11.0);
    assert!(
        (bvh.sah_cost() - expected).abs() < 1e-6,
        "{}",
        bvh.sah_cost()
    );
    assert!((bvh.sah_cost_with(2.0, 3.0) - (2.0 + 6.0 / 11.0)).abs() < 1e-6);
    // A single leaf costs its triangle count.
    let leaf = build(
        &tris,
        BuildOptions {
            max_leaf_size: 2,
            traversal_cost: 100.0,
            ..options
        },
    );
    assert_eq!(leaf.nodes().len(), 1);
    assert_eq!(leaf.sah_cost_with(100.0, 1.0), 2.0);
}

/// The SAH build beats a leaf of everything and does not degrade as bins grow.
#[test]
fn sah_build_is_reasonable() {
    let mut rng = Rng::new(21);
    let tris = random_scene(&mut rng, 2000);
    let coarse = build(
        &tris,
        BuildOptions {
            bins: 4,
            ..BuildOptions::default()
        },
    );
    let fine = build(
        &tris,
        BuildOptions {
            bins: 32,
            ..BuildOptions::default()
        },
    );
    assert!(
        fine.sah_cost() < tris.len() as f32 / 10.0,
        "{}",
        fine.sah_cost()
    );
    assert!(
        fine.sah_cost() <= coarse.sah_cost() * 1.05,
        "{} vs {}",
        fine.sah_cost(),
        coarse.sah_cost()
    );
    assert!(fine.depth() < 64, "depth {}", fine.depth());
}

mod arbitrary_floats {
    use super::*;
    use proptest::prelude::*;

    fn coordinate() -> impl Strategy<Value = f32> {
        prop_oneof![
            prop::num::f32::NORMAL | prop::num::f32::SUBNORMAL | prop::num::f32::ZERO,
            -4.0f32..4.0,
            Just(f32::MAX),
            Just(f32::MIN),
        ]
    }

    fn triangle() -> impl Strategy<Value = common::Tri> {
        prop::array::uniform3(prop::array::uniform3(coordinate()))
    }

    proptest! {
            // A failure prints the minimal failing input (the triangles, leaf size and ray),
            // which reproduces it, and is saved to `structure.proptest-regressions`.
            #![proptest_config(common::proptest_config(128))]

            /// Any finite coordinates, from subnormal to ±f32::MAX: the build keeps every
            /// invariant, the encoding succeeds and traversals terminate without panicking.
            #[test]
            fn any_finite_input_builds_valid_trees(
                tris in prop::collection::vec(triangle(), 0..60),
                leaf in 1u32..6,
                origin in prop::array::uniform3(coordinate()),
                dir in prop::array::uniform3(-1.0f32..1.0),
            ) {
                let options = BuildOptions { max_leaf_size: leaf, ..BuildOptions::default() };
                let bvh = Bvh::build(&tris, &options).expect("finite input builds");
                prop_assert!(Bvh::from_parts(bvh.nodes().to_vec(), bvh.triangle_order().to_vec()).is_some());
                for n in bvh.nodes() {
                    if let NodeKind::Leaf { count, .. } = n.kind {
                        prop_assert!(count <= leaf);
                    }
                }
    // Face normals of such triangles overflow: plain attributes.
                let attrs = vec![luxbake_bvh::TriangleAttributes::default(); tris.len()];
                let scene = encode(&bvh, &tris, &attrs, &EncodeOptions::default()).expect("encode");
                let ray = luxbake_bvh::Ray { origin, dir };
                for t in [luxbake_bvh::Traversal::Mtbvh, luxbake_bvh::Traversal::Tbvh, luxbake_bvh::Traversal::BruteForce] {
                    let s = scene.traversal_stats(&ray, 0.0, f32::INFINITY, t, false);
                    prop_assert!(s.nodes <= scene.node_count && s.triangle_tests <= scene.triangle_count);
                    prop_assert!(s.hit.is_none_or(|h| h.triangle < scene.triangle_count));
                }
            }
        }
}
