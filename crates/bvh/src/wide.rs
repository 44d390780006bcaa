//! A 4-wide BVH for fast CPU traversal, collapsed from the canonical SAH tree of an
//! [`EncodedScene`].
//!
//! Each wide node holds the boxes of up to four children in structure-of-arrays form, so one
//! ray is tested against all four with SSE on x86_64 (baseline SSE2, no run-time detection) and
//! with a plain loop over the lanes elsewhere. Children come from the binary tree by repeatedly
//! opening the inner child of largest surface area until there are four; leaves keep their
//! triangle ranges, so triangle indices are the encoded ones ([`Hit::triangle`]) and every
//! triangle is tested with the same watertight test ([`WatertightRay::hits_triangle`]) as the
//! encoded traversal. The slab test computes the encoded one's entry and exit distances bit for
//! bit ([`WatertightRay::hits_box`], the same slack and parallel-axis rule), so a box is
//! accepted exactly when the encoded traversal would accept it against the same `t_max` (one
//! exception: where a plane distance overflows to ±∞, the encoded test accepts the box through
//! a NaN and this one rejects it; the ray cannot reach such a box at a finite `t`): the closest
//! hit agrees with [`EncodedScene::closest_hit`] except where two triangles tie.
//!
//! The traversal keeps a stack of the children a ray hit, nearest on top, each with its entry
//! distance, and drops entries that start beyond the closest hit found so far.

use crate::encode::EncodedScene;
use crate::layout;
use crate::traverse::{Hit, Ray, WatertightRay};

/// Lanes (children) per wide node.
const LANES: usize = 4;
/// Child tag of a leaf lane: `LEAF | first triangle`.
const LEAF: u32 = 1 << 31;
/// Stack entries kept on the thread's stack; deeper trees use a heap stack.
const INLINE_STACK: usize = 64;

/// One wide node: four child boxes, structure of arrays.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
struct Node {
    /// Per lane: min x, min y, min z, max x, max y, max z. Empty lanes have min +∞, max −∞.
    planes: [[f32; LANES]; 6],
    /// Inner child: its node index. Leaf child: `LEAF | first triangle`.
    child: [u32; LANES],
    /// Triangles of a leaf child (0 for inner children and empty lanes).
    count: [u32; LANES],
}

const EMPTY_NODE: Node = Node {
    planes: [
        [f32::INFINITY; LANES],
        [f32::INFINITY; LANES],
        [f32::INFINITY; LANES],
        [f32::NEG_INFINITY; LANES],
        [f32::NEG_INFINITY; LANES],
        [f32::NEG_INFINITY; LANES],
    ],
    child: [LEAF; LANES],
    count: [0; LANES],
};

/// A pending child: node index or `LEAF | first`, its triangle count, its entry distance.
#[derive(Clone, Copy, Debug, Default)]
struct Entry {
    child: u32,
    count: u32,
    t: f32,
}

/// The 4-wide BVH of an [`EncodedScene`] and its triangle positions (encoded order).
///
/// ```
/// use luxbake_bvh::{encode, BuildOptions, Bvh, EncodeOptions, Ray, Traversal, TriangleAttributes, WideBvh};
///
/// let tris = [[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]];
/// let bvh = Bvh::build(&tris, &BuildOptions::default())?;
/// let scene = encode(&bvh, &tris, &[TriangleAttributes::default()], &EncodeOptions { max_texture_size: 64 })?;
/// let wide = WideBvh::from_encoded(&scene);
/// let ray = Ray { origin: [0.25, 0.25, 1.0], dir: [0.0, 0.0, -1.0] };
/// let hit = wide.closest_hit(&ray, 0.0, f32::INFINITY);
/// assert_eq!(hit, scene.closest_hit(&ray, 0.0, f32::INFINITY, Traversal::Mtbvh));
/// assert!(!wide.any_hit(&ray, 0.0, 0.5));
/// # Ok::<(), luxbake_bvh::BvhError>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct WideBvh {
    nodes: Vec<Node>,
    triangles: Vec<[[f32; 3]; 3]>,
    /// Stack entries a traversal may need: 3 per level below the root, plus one.
    stack_size: usize,
}

/// The binary tree read back from the encoded textures.
struct Binary<'a> {
    scene: &'a EncodedScene,
    /// Nodes already placed in the wide tree (corrupt links could share a subtree).
    taken: Vec<bool>,
}

impl Binary<'_> {
    /// `Some((left, right))` for an inner node: an empty triangle range, left child `i + 1` and
    /// right child the TBVH miss link of the left child (the node after the left subtree).
    /// Inconsistent (corrupt) links, or children already taken, make the node a leaf.
    fn children(&self, i: u32) -> Option<(u32, u32)> {
        let n = self.scene.node(i);
        let left = i.checked_add(1).filter(|&l| l < self.scene.node_count)?;
        if n.first_tri != n.end_tri {
            return None;
        }
        let right = self.scene.link(left, None).miss?;
        let free = |c: u32| !self.taken.get(c as usize).copied().unwrap_or(true);
        (right > left && right < self.scene.node_count && free(left) && free(right))
            .then_some((left, right))
    }

    fn take(&mut self, i: u32) {
        if let Some(t) = self.taken.get_mut(i as usize) {
            *t = true;
        }
    }

    fn half_area(&self, i: u32) -> f32 {
        let n = self.scene.node(i);
        let d = [0, 1, 2].map(|a| (n.max[a] - n.min[a]).max(0.0));
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    }
}

impl WideBvh {
    /// Collapses the encoded scene's binary tree (read back from its bounds and TBVH link
    /// textures) into a 4-wide tree and copies its triangle positions.
    ///
    /// Never panics, even for corrupt encodings: inconsistent links end a subtree and
    /// triangle ranges are clamped to `0 .. triangle_count`.
    pub fn from_encoded(scene: &EncodedScene) -> WideBvh {
        let triangles: Vec<[[f32; 3]; 3]> = (0..scene.triangle_count)
            .map(|t| scene.triangle_positions(t))
            .collect();
        let mut nodes = vec![EMPTY_NODE];
        let mut max_depth = 1usize;
        if scene.node_count == 0 {
            return WideBvh {
                nodes,
                triangles,
                stack_size: 1,
            };
        }
        let mut binary = Binary {
            scene,
            taken: vec![false; scene.node_count as usize],
        };
        binary.take(0);
        // (binary node, wide node to fill, depth of that wide node)
        let mut work = vec![(0u32, 0usize, 1usize)];
        while let Some((b, slot, depth)) = work.pop() {
            max_depth = max_depth.max(depth);
            let mut kids: Vec<u32> = match binary.children(b) {
                Some((l, r)) => {
                    binary.take(l);
                    binary.take(r);
                    vec![l, r]
                }
                None => vec![b],
            };
            while kids.len() < LANES {
                let widest = kids
                    .iter()
                    .enumerate()
                    .filter_map(|(j, &k)| binary.children(k).map(|c| (j, c, binary.half_area(k))))
                    .max_by(|a, b| a.2.total_cmp(&b.2));
                let Some((j, (l, r), _)) = widest else {
                    break;
                };
                binary.take(l);
                binary.take(r);
                kids[j] = l;
                kids.insert(j + 1, r);
            }
            for (lane, &k) in kids.iter().enumerate() {
                let n = scene.node(k);
                for a in 0..3 {
                    nodes[slot].planes[a][lane] = n.min[a];
                    nodes[slot].planes[a + 3][lane] = n.max[a];
                }
                if binary.children(k).is_some() {
                    let index = nodes.len();
                    nodes.push(EMPTY_NODE);
                    nodes[slot].child[lane] = index as u32;
                    work.push((k, index, depth + 1));
                } else {
                    let end = n.end_tri.min(scene.triangle_count);
                    let first = n.first_tri.min(end).min(LEAF - 1);
                    nodes[slot].child[lane] = LEAF | first;
                    nodes[slot].count[lane] = end - first;
                }
            }
        }
        WideBvh {
            nodes,
            triangles,
            stack_size: 3 * max_depth + 1,
        }
    }

    /// Number of wide nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// The closest hit with `t` in `(t_min, t_max)`, as [`EncodedScene::closest_hit`] (same
    /// triangle indices, the same `t`, `u`, `v` bit for bit for the same triangle). Rays with a
    /// zero or non-finite direction never hit.
    pub fn closest_hit(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        let r = WatertightRay::new(ray)?;
        self.with_stack(|stack| self.walk(&r, t_min, t_max, false, stack))
    }

    /// Whether any triangle is hit with `t` in `(t_min, t_max)` (the shadow-ray query).
    pub fn any_hit(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        WatertightRay::new(ray)
            .and_then(|r| self.with_stack(|stack| self.walk(&r, t_min, t_max, true, stack)))
            .is_some()
    }

    fn with_stack<T>(&self, f: impl FnOnce(&mut [Entry]) -> T) -> T {
        if self.stack_size <= INLINE_STACK {
            f(&mut [Entry::default(); INLINE_STACK])
        } else {
            f(&mut vec![Entry::default(); self.stack_size])
        }
    }

    fn walk(
        &self,
        r: &WatertightRay,
        t_min: f32,
        t_max: f32,
        any: bool,
        stack: &mut [Entry],
    ) -> Option<Hit> {
        let q = BoxRay::new(r);
        let mut closest = t_max;
        let mut best: Option<(u32, f32, f32)> = None;
        stack[0] = Entry {
            child: 0,
            count: 0,
            t: t_min,
        };
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let e = stack[top];
            if e.t > closest {
                continue;
            }
            if e.child & LEAF != 0 {
                let first = (e.child & !LEAF) as usize;
                let tris = self.triangles.get(first..first + e.count as usize);
                for (k, p) in tris.into_iter().flatten().enumerate() {
                    if let Some((t, u, v)) = r.hits_triangle(p[0], p[1], p[2], t_min, closest) {
                        closest = t;
                        best = Some(((first + k) as u32, u, v));
                        if any {
                            return hit(best, closest);
                        }
                    }
                }
                continue;
            }
            let Some(node) = self.nodes.get(e.child as usize) else {
                continue;
            };
            let (mask, near) = q.hits(node, t_min, closest);
            // Push the hit lanes farthest first, so the nearest is on top.
            let mut order = [0usize; LANES];
            let mut n = 0;
            for lane in 0..LANES {
                if mask & (1 << lane) != 0 {
                    let mut j = n;
                    while j > 0 && near[order[j - 1]] < near[lane] {
                        order[j] = order[j - 1];
                        j -= 1;
                    }
                    order[j] = lane;
                    n += 1;
                }
            }
            for &lane in &order[..n] {
                if let Some(slot) = stack.get_mut(top) {
                    *slot = Entry {
                        child: node.child[lane],
                        count: node.count[lane],
                        t: near[lane],
                    };
                    top += 1;
                }
            }
        }
        hit(best, closest)
    }
}

fn hit(best: Option<(u32, f32, f32)>, t: f32) -> Option<Hit> {
    best.map(|(triangle, u, v)| Hit { t, triangle, u, v })
}

/// The slab-test form of a ray for wide nodes: per axis the origin, the inverse direction
/// (±∞ on parallel axes, [`layout::PARALLEL_EPSILON`]) and which planes are entry and exit.
struct BoxRay {
    origin: [f32; 3],
    inv: [f32; 3],
    /// Plane row (0..6 in [`Node::planes`]) of the entry / exit plane per axis.
    near: [usize; 3],
    far: [usize; 3],
}

impl BoxRay {
    fn new(r: &WatertightRay) -> BoxRay {
        // Either sign of ∞ works on a parallel axis: the box is entered at −∞ (or never).
        let inv = [0, 1, 2].map(|a| {
            if r.parallel[a] {
                f32::INFINITY
            } else {
                r.inv[a]
            }
        });
        let negative = inv.map(|i| i.is_sign_negative());
        BoxRay {
            origin: r.origin,
            inv,
            near: [0, 1, 2].map(|a| a + 3 * usize::from(negative[a])),
            far: [0, 1, 2].map(|a| a + 3 * usize::from(!negative[a])),
        }
    }

    /// Which lanes' boxes the ray touches within `[t_min, t_max]` (bit per lane) and each
    /// lane's entry distance. Per lane this is [`WatertightRay::hits_box`]: the entry distance
    /// is the largest plane distance (at least −[`layout::BIG`]), the exit the smallest (at
    /// most `BIG`), both widened by [`layout::BOX_SLACK`]. A parallel axis gives ±∞, or NaN
    /// for an origin on the plane, and `max`/`min` with the NaN first keep the other operand:
    /// so such an axis constrains nothing when the origin is in the slab and rejects the box
    /// otherwise, as the encoded test's ±`BIG` does. An entry at +∞ or an exit at −∞ (empty
    /// lanes, overflow) turns into NaN with the slack and rejects the lane.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn hits(&self, node: &Node, t_min: f32, t_max: f32) -> (u32, [f32; LANES]) {
        use std::arch::x86_64::*;
        // SAFETY: SSE and SSE2 are part of the x86_64 baseline; the loads read the 16-byte
        // aligned `[f32; 4]` rows of a `Node` (64-byte aligned, rows at multiples of 16).
        unsafe {
            let row = |i: usize| _mm_load_ps(node.planes[i].as_ptr());
            let mut near = _mm_set1_ps(f32::NEG_INFINITY);
            let mut far = _mm_set1_ps(f32::INFINITY);
            for a in 0..3 {
                let o = _mm_set1_ps(self.origin[a]);
                let inv = _mm_set1_ps(self.inv[a]);
                let tn = _mm_mul_ps(_mm_sub_ps(row(self.near[a]), o), inv);
                let tf = _mm_mul_ps(_mm_sub_ps(row(self.far[a]), o), inv);
                near = _mm_max_ps(tn, near);
                far = _mm_min_ps(tf, far);
            }
            let big = _mm_set1_ps(layout::BIG);
            near = _mm_max_ps(near, _mm_sub_ps(_mm_setzero_ps(), big));
            far = _mm_min_ps(far, big);
            let abs = _mm_castsi128_ps(_mm_set1_epi32(0x7fff_ffff));
            let slack = _mm_set1_ps(layout::BOX_SLACK);
            let t_near = _mm_max_ps(
                _mm_set1_ps(t_min),
                _mm_sub_ps(near, _mm_mul_ps(_mm_and_ps(near, abs), slack)),
            );
            let t_far = _mm_min_ps(
                _mm_set1_ps(t_max),
                _mm_add_ps(far, _mm_mul_ps(_mm_and_ps(far, abs), slack)),
            );
            let mask = _mm_movemask_ps(_mm_cmple_ps(t_near, t_far)) as u32;
            let mut out = [0.0f32; LANES];
            _mm_storeu_ps(out.as_mut_ptr(), t_near);
            (mask, out)
        }
    }

    /// The portable form of the SSE test above, lane by lane (also the reference the tests
    /// compare the SSE form with).
    #[cfg(any(test, not(target_arch = "x86_64")))]
    fn hits_scalar(&self, node: &Node, t_min: f32, t_max: f32) -> (u32, [f32; LANES]) {
        // `_mm_max_ps(a, b)` / `_mm_min_ps(a, b)`: `b` unless `a` compares greater / less.
        let max = |a: f32, b: f32| if a > b { a } else { b };
        let min = |a: f32, b: f32| if a < b { a } else { b };
        let mut mask = 0;
        let mut out = [0.0f32; LANES];
        for (lane, out) in out.iter_mut().enumerate() {
            let mut near = f32::NEG_INFINITY;
            let mut far = f32::INFINITY;
            for a in 0..3 {
                let tn = (node.planes[self.near[a]][lane] - self.origin[a]) * self.inv[a];
                let tf = (node.planes[self.far[a]][lane] - self.origin[a]) * self.inv[a];
                near = max(tn, near);
                far = min(tf, far);
            }
            near = max(near, -layout::BIG);
            far = min(far, layout::BIG);
            let t_near = max(t_min, near - near.abs() * layout::BOX_SLACK);
            let t_far = min(t_max, far + far.abs() * layout::BOX_SLACK);
            if t_near <= t_far {
                mask |= 1 << lane;
            }
            *out = t_near;
        }
        (mask, out)
    }

    #[cfg(not(target_arch = "x86_64"))]
    #[inline(always)]
    fn hits(&self, node: &Node, t_min: f32, t_max: f32) -> (u32, [f32; LANES]) {
        self.hits_scalar(node, t_min, t_max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn node_with(boxes: &[([f32; 3], [f32; 3])]) -> Node {
        let mut n = EMPTY_NODE;
        for (lane, (lo, hi)) in boxes.iter().enumerate() {
            for a in 0..3 {
                n.planes[a][lane] = lo[a];
                n.planes[a + 3][lane] = hi[a];
            }
        }
        n
    }

    /// The SSE slab test, its scalar form and the encoded traversal's `hits_box` agree on
    /// every lane, for parallel axes, origins on a plane, empty lanes and shrinking `t_max`.
    #[test]
    fn box_test_matches_the_encoded_slab_test() {
        let boxes = [
            ([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]),
            ([2.0, -1.0, 0.5], [3.0, 1.0, 0.5]),
            ([-1e30, 0.25, -4.0], [1e30, 0.25, 4.0]),
        ];
        let node = node_with(&boxes);
        let coords = [-2.0f32, -0.0, 0.0, 0.25, 0.5, 1.0, 2.5, 1e20];
        let dirs = [-1.0f32, -1e-39, -0.0, 0.0, 1e-39, 1e-30, 0.3, 1.0];
        let mut checked = 0;
        for &ox in &coords {
            for &oy in &coords[..4] {
                for &dx in &dirs {
                    for &dy in &dirs {
                        for dz in [1.0f32, -0.5] {
                            let ray = Ray {
                                origin: [ox, oy, 0.5],
                                dir: [dx, dy, dz],
                            };
                            let r = WatertightRay::new(&ray).expect("ray");
                            let q = BoxRay::new(&r);
                            // Plane distances that overflow to ±∞ (a 1e20 origin, 1e-30
                            // directions against 1e30 planes).
                            let extreme = ox == 1e20
                                || [dx, dy]
                                    .iter()
                                    .any(|d| (f32::MIN_POSITIVE..1e-20).contains(&d.abs()));
                            for (t_min, t_max) in [(0.0, f32::INFINITY), (0.0, 0.6), (-1.0, 1e-3)] {
                                let (mask, near) = q.hits(&node, t_min, t_max);
                                assert_eq!(
                                    (mask, near.map(f32::to_bits)),
                                    {
                                        let (m, n) = q.hits_scalar(&node, t_min, t_max);
                                        (m, n.map(f32::to_bits))
                                    },
                                    "{ray:?}"
                                );
                                for (lane, (lo, hi)) in boxes.iter().enumerate() {
                                    let wide = mask & (1 << lane) != 0;
                                    let encoded = r.hits_box(*lo, *hi, t_min, t_max);
                                    let msg =
                                        format!("lane {lane} {ray:?} t in ({t_min}, {t_max})");
                                    if extreme {
                                        assert!(!wide || encoded, "{msg}");
                                    } else {
                                        assert_eq!(wide, encoded, "{msg}");
                                    }
                                }
                                assert_eq!(mask >> boxes.len(), 0, "empty lanes never hit");
                                checked += 1;
                            }
                        }
                    }
                }
            }
        }
        assert_eq!(checked, 8 * 4 * 8 * 8 * 2 * 3);
    }
}
