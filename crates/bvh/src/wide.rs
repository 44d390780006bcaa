//! A 4-wide BVH for fast CPU traversal, collapsed from the canonical SAH tree of an
//! [`EncodedScene`].
//!
//! Each wide node holds the boxes of up to four children in structure-of-arrays form, so one
//! ray is tested against all four with SSE on x86_64 (baseline SSE2, no run-time detection) and
//! with a plain loop over the lanes elsewhere. Children come from the binary tree by repeatedly
//! opening the inner child of largest surface area until there are four; leaves keep their
//! triangle ranges, so triangle indices are the encoded ones ([`Hit::triangle`]), and a child
//! whose subtree holds at most four triangles becomes one leaf (its box bounds them all, so
//! every triangle a ray can hit is still tested). A leaf's triangles are copied into packets
//! of four, structure of arrays, stored contiguously, and a
//! packet's four triangles are tested at once with the arithmetic of the encoded traversal's
//! watertight test ([`WatertightRay::hits_triangle`]) lane by lane, the same operations in the
//! same order, so each lane's hit and its `t`, `u`, `v` are the scalar test's bit for bit; of
//! the lanes hit, the nearest wins and ties go to the lower lane, which is the triangle the
//! scalar loop over the leaf (strict `t < closest`) keeps. The slab test computes the encoded one's entry and exit distances bit for
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
/// The inline stack of shallower trees (most scenes of a few thousand triangles).
const SMALL_STACK: usize = 32;

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

/// Up to four triangles of one leaf, structure of arrays: tested together.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
struct Packet {
    /// Row `3·vertex + axis` (p0.x, p0.y, p0.z, p1.x, …, p2.z), one lane per triangle. Unused
    /// lanes hold a zero-area triangle at the origin, which never hits: its three sheared
    /// vertices are equal, so every edge function is `x·y − y·x` = 0 exactly and `det` is 0.
    p: [[f32; LANES]; 9],
    /// Encoded triangle index per lane (`u32::MAX` for unused lanes).
    index: [u32; LANES],
}

impl Packet {
    fn new(triangles: &[(u32, [[f32; 3]; 3])]) -> Packet {
        let mut packet = Packet {
            p: [[0.0; LANES]; 9],
            index: [u32::MAX; LANES],
        };
        for (lane, (index, p)) in triangles.iter().take(LANES).enumerate() {
            packet.index[lane] = *index;
            for (v, vertex) in p.iter().enumerate() {
                for (a, &c) in vertex.iter().enumerate() {
                    packet.p[3 * v + a][lane] = c;
                }
            }
        }
        packet
    }

    #[cfg(test)]
    fn triangle(&self, lane: usize) -> [[f32; 3]; 3] {
        std::array::from_fn(|v| std::array::from_fn(|a| self.p[3 * v + a][lane]))
    }
}

/// A pending child: node index or `LEAF | first packet`, its packet count, its entry distance.
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
    /// The leaves' triangles, a leaf's packets contiguous, in the encoded order.
    packets: Vec<Packet>,
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

    /// The triangles of the subtree under inner node `i`, leaf ranges in tree order (the
    /// encoded order), when it holds at most [`LANES`] triangles in at most `2·LANES` nodes:
    /// such a subtree becomes one leaf lane, its triangles one packet, and is marked taken.
    fn small_subtree(&mut self, i: u32) -> Option<Vec<u32>> {
        let mut tris = Vec::new();
        let mut seen = Vec::new();
        let mut todo = vec![i];
        while let Some(k) = todo.pop() {
            seen.push(k);
            if seen.len() > 2 * LANES {
                return None;
            }
            match self.children(k) {
                Some((l, r)) => todo.extend([r, l]),
                None => {
                    let n = self.scene.node(k);
                    let end = n.end_tri.min(self.scene.triangle_count);
                    let first = n.first_tri.min(end);
                    if tris.len() + (end - first) as usize > LANES {
                        return None;
                    }
                    tris.extend(first..end);
                }
            }
        }
        for k in seen {
            self.take(k);
        }
        Some(tris)
    }

    fn half_area(&self, i: u32) -> f32 {
        let n = self.scene.node(i);
        let d = [0, 1, 2].map(|a| (n.max[a] - n.min[a]).max(0.0));
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    }
}

impl WideBvh {
    /// Collapses the encoded scene's binary tree (read back from its bounds and TBVH link
    /// textures) into a 4-wide tree and copies its leaves' triangle positions into packets.
    ///
    /// Never panics, even for corrupt encodings: inconsistent links end a subtree and
    /// triangle ranges are clamped to `0 .. triangle_count`.
    pub fn from_encoded(scene: &EncodedScene) -> WideBvh {
        let mut packets = Vec::new();
        let mut nodes = vec![EMPTY_NODE];
        let mut max_depth = 1usize;
        if scene.node_count == 0 {
            return WideBvh {
                nodes,
                packets,
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
                let leaf: Option<Vec<u32>> = if binary.children(k).is_some() {
                    binary.small_subtree(k)
                } else {
                    let end = n.end_tri.min(scene.triangle_count);
                    Some((n.first_tri.min(end)..end).collect())
                };
                if let Some(leaf) = leaf {
                    let tris: Vec<(u32, [[f32; 3]; 3])> = leaf
                        .into_iter()
                        .map(|t| (t, scene.triangle_positions(t)))
                        .collect();
                    let start = packets.len();
                    packets.extend(tris.chunks(LANES).map(Packet::new));
                    let start = u32::try_from(start).unwrap_or(u32::MAX).min(LEAF - 1);
                    nodes[slot].child[lane] = LEAF | start;
                    nodes[slot].count[lane] = (packets.len() - start as usize) as u32;
                } else {
                    let index = nodes.len();
                    nodes.push(EMPTY_NODE);
                    nodes[slot].child[lane] = index as u32;
                    work.push((k, index, depth + 1));
                }
            }
        }
        WideBvh {
            nodes,
            packets,
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
        self.with_stack(|stack| self.walk(ray, t_min, t_max, false, stack))
    }

    /// Whether any triangle is hit with `t` in `(t_min, t_max)` (the shadow-ray query).
    pub fn any_hit(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        self.with_stack(|stack| self.walk(ray, t_min, t_max, true, stack))
            .is_some()
    }

    /// Runs `f` with a stack of at least `stack_size` entries: the smallest of two inline
    /// sizes that fits (each ray zeroes its stack, so small scenes clear less), else the heap.
    #[inline(always)]
    fn with_stack<T>(&self, f: impl FnOnce(&mut [Entry]) -> T) -> T {
        if self.stack_size <= SMALL_STACK {
            f(&mut [Entry::default(); SMALL_STACK])
        } else if self.stack_size <= INLINE_STACK {
            f(&mut [Entry::default(); INLINE_STACK])
        } else {
            f(&mut vec![Entry::default(); self.stack_size])
        }
    }

    /// The traversal. It sets the ray up itself, so that the per-ray constants stay in
    /// registers: set up by the caller, they were read back from its stack with vector loads
    /// over fresh scalar stores, where `perf` put ~8 % of this function's samples.
    fn walk(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        any: bool,
        stack: &mut [Entry],
    ) -> Option<Hit> {
        let r = WatertightRay::new(ray)?;
        let q = BoxRay::new(&r);
        let tri = PacketRay::new(&r);
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
                let packets = self.packets.get(first..first + e.count as usize);
                for packet in packets.into_iter().flatten() {
                    let h = tri.hits(packet, t_min, closest);
                    if h.mask == 0 {
                        continue;
                    }
                    // The nearest lane hit; ties keep the lower lane (the earlier triangle).
                    let mut lane = h.mask.trailing_zeros() as usize;
                    for l in lane + 1..LANES {
                        if h.mask & (1 << l) != 0 && h.t[l] < h.t[lane] {
                            lane = l;
                        }
                    }
                    closest = h.t[lane];
                    best = Some((packet.index[lane], h.u[lane], h.v[lane]));
                    if any {
                        return hit(best, closest);
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

/// The lanes of a [`Packet`] a ray hits, with their `t`, `u`, `v` (unspecified in other lanes).
struct PacketHits {
    mask: u32,
    t: [f32; LANES],
    u: [f32; LANES],
    v: [f32; LANES],
}

/// The watertight test's per-ray constants ([`WatertightRay`]) in the form the packet test
/// reads them: the packet rows of the permuted axes and the origin in that order.
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
struct PacketRay {
    /// Axes `kx`, `ky`, `kz`.
    axis: [usize; 3],
    /// Origin along `kx`, `ky`, `kz`.
    origin: [f32; 3],
    sx: f32,
    sy: f32,
    sz: f32,
    /// The ray, for the portable test.
    #[cfg(any(test, not(target_arch = "x86_64")))]
    ray: WatertightRay,
}

impl PacketRay {
    fn new(r: &WatertightRay) -> PacketRay {
        let axis = [r.kx, r.ky, r.kz];
        PacketRay {
            axis,
            origin: axis.map(|a| r.origin[a]),
            sx: r.sx,
            sy: r.sy,
            sz: r.sz,
            #[cfg(any(test, not(target_arch = "x86_64")))]
            ray: *r,
        }
    }

    /// Each lane's [`WatertightRay::hits_triangle`] against `(t_min, t_max)`, four at once:
    /// the same operations in the same order (`a = p0 − origin`; `ax = a[kx] − sx·a[kz]`, …;
    /// `u = cx·by − cy·bx`, `v = ax·cy − ay·cx`, `w = bx·ay − by·ax`; the sign test; `det =
    /// u + v + w`; `t = (u·az + v·bz + w·cz) / det`; `t_min < t < t_max`; barycentrics `v /
    /// det`, `w / det`), each one correctly rounded in SSE as in scalar code, so every lane's
    /// result is the scalar one bit for bit.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn hits(&self, packet: &Packet, t_min: f32, t_max: f32) -> PacketHits {
        use std::arch::x86_64::*;
        // SAFETY: SSE and SSE2 are part of the x86_64 baseline; the loads read the 16-byte
        // aligned `[f32; 4]` rows of a `Packet` (16-byte aligned, rows at multiples of 16).
        unsafe {
            let row = |i: usize| _mm_load_ps(packet.p[i].as_ptr());
            let [ox, oy, oz] = self.origin.map(|o| _mm_set1_ps(o));
            let (sx, sy, sz) = (
                _mm_set1_ps(self.sx),
                _mm_set1_ps(self.sy),
                _mm_set1_ps(self.sz),
            );
            let [kx, ky, kz] = self.axis;
            // (p − origin) sheared: (x − sx·z, y − sy·z, sz·z) along the permuted axes.
            let vertex = |v: usize| {
                let dx = _mm_sub_ps(row(3 * v + kx), ox);
                let dy = _mm_sub_ps(row(3 * v + ky), oy);
                let dz = _mm_sub_ps(row(3 * v + kz), oz);
                (
                    _mm_sub_ps(dx, _mm_mul_ps(sx, dz)),
                    _mm_sub_ps(dy, _mm_mul_ps(sy, dz)),
                    _mm_mul_ps(sz, dz),
                )
            };
            let (ax, ay, az) = vertex(0);
            let (bx, by, bz) = vertex(1);
            let (cx, cy, cz) = vertex(2);
            let u = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
            let v = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
            let w = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
            let zero = _mm_setzero_ps();
            let negative = _mm_or_ps(
                _mm_or_ps(_mm_cmplt_ps(u, zero), _mm_cmplt_ps(v, zero)),
                _mm_cmplt_ps(w, zero),
            );
            let positive = _mm_or_ps(
                _mm_or_ps(_mm_cmpgt_ps(u, zero), _mm_cmpgt_ps(v, zero)),
                _mm_cmpgt_ps(w, zero),
            );
            let det = _mm_add_ps(_mm_add_ps(u, v), w);
            let t = _mm_div_ps(
                _mm_add_ps(
                    _mm_add_ps(_mm_mul_ps(u, az), _mm_mul_ps(v, bz)),
                    _mm_mul_ps(w, cz),
                ),
                det,
            );
            // `cmpneq` is true for NaN, as `det == 0.0` is false; the `t` comparisons reject
            // NaN as `!(t > t_min && t < t_max)` does.
            let accept = _mm_andnot_ps(
                _mm_and_ps(negative, positive),
                _mm_and_ps(
                    _mm_cmpneq_ps(det, zero),
                    _mm_and_ps(
                        _mm_cmpgt_ps(t, _mm_set1_ps(t_min)),
                        _mm_cmplt_ps(t, _mm_set1_ps(t_max)),
                    ),
                ),
            );
            let mut hits = PacketHits {
                mask: _mm_movemask_ps(accept) as u32,
                t: [0.0; LANES],
                u: [0.0; LANES],
                v: [0.0; LANES],
            };
            if hits.mask != 0 {
                _mm_storeu_ps(hits.t.as_mut_ptr(), t);
                _mm_storeu_ps(hits.u.as_mut_ptr(), _mm_div_ps(v, det));
                _mm_storeu_ps(hits.v.as_mut_ptr(), _mm_div_ps(w, det));
            }
            hits
        }
    }

    /// The portable form of the SSE test above: [`WatertightRay::hits_triangle`] lane by lane
    /// (also the reference the tests compare the SSE form with).
    #[cfg(any(test, not(target_arch = "x86_64")))]
    fn hits_scalar(&self, packet: &Packet, t_min: f32, t_max: f32) -> PacketHits {
        let mut hits = PacketHits {
            mask: 0,
            t: [0.0; LANES],
            u: [0.0; LANES],
            v: [0.0; LANES],
        };
        for lane in 0..LANES {
            let p: [[f32; 3]; 3] =
                std::array::from_fn(|v| std::array::from_fn(|a| packet.p[3 * v + a][lane]));
            if let Some((t, u, v)) = self.ray.hits_triangle(p[0], p[1], p[2], t_min, t_max) {
                hits.mask |= 1 << lane;
                hits.t[lane] = t;
                hits.u[lane] = u;
                hits.v[lane] = v;
            }
        }
        hits
    }

    #[cfg(not(target_arch = "x86_64"))]
    #[inline(always)]
    fn hits(&self, packet: &Packet, t_min: f32, t_max: f32) -> PacketHits {
        self.hits_scalar(packet, t_min, t_max)
    }
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

    /// SplitMix64, for seeded test data.
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }

        /// Uniform in `[lo, hi)`, on a coarse grid a quarter of the time (exact ties, shared
        /// coordinates, axis-aligned edges).
        fn coord(&mut self, lo: f32, hi: f32) -> f32 {
            let x = (self.next() >> 40) as f32 / (1u64 << 24) as f32;
            if self.next().is_multiple_of(4) {
                lo + ((x * 8.0).floor() / 8.0) * (hi - lo)
            } else {
                lo + x * (hi - lo)
            }
        }
    }

    /// The SSE packet test equals the scalar watertight test lane by lane, bit for bit (mask,
    /// `t`, `u`, `v`), on seeded random packets: triangles sharing vertices and edges, zero-area
    /// ones, unused lanes, rays aimed at vertices and edges, axis-aligned and negative
    /// directions, and a range of `t_max`.
    #[test]
    fn packet_test_matches_the_scalar_watertight_test() {
        let mut lanes_hit = 0;
        for seed in 0..400u64 {
            let mut rng = Rng(seed);
            let v: Vec<[f32; 3]> = (0..6)
                .map(|_| std::array::from_fn(|_| rng.coord(-1.0, 1.0)))
                .collect();
            let used = 1 + (rng.next() % 4) as usize;
            let tris: Vec<(u32, [[f32; 3]; 3])> = (0..used)
                .map(|i| {
                    let mut p = [0, 1, 2].map(|_| v[(rng.next() % 6) as usize]);
                    if rng.next().is_multiple_of(3) {
                        // A fresh triangle rather than one on the shared vertices.
                        p = [0, 1, 2].map(|_| std::array::from_fn(|_| rng.coord(-1.0, 1.0)));
                    }
                    (i as u32 + 10, p)
                })
                .collect();
            let packet = Packet::new(&tris);
            for lane in used..LANES {
                assert_eq!(packet.index[lane], u32::MAX);
            }
            for k in 0..64 {
                let origin: [f32; 3] = std::array::from_fn(|_| rng.coord(-2.0, 2.0));
                let mut dir: [f32; 3] = std::array::from_fn(|_| rng.coord(-1.0, 1.0));
                match k % 4 {
                    0 => {
                        // At a vertex or an edge midpoint of a lane.
                        let p = tris[(rng.next() as usize) % used].1;
                        let (i, j) = ((rng.next() % 3) as usize, (rng.next() % 3) as usize);
                        dir = std::array::from_fn(|a| 0.5 * (p[i][a] + p[j][a]) - origin[a]);
                    }
                    1 => {
                        let a = (rng.next() % 3) as usize;
                        dir = [0.0; 3];
                        dir[a] = if rng.next().is_multiple_of(2) {
                            1.0
                        } else {
                            -1.0
                        };
                    }
                    _ => {}
                }
                let ray = Ray { origin, dir };
                let Some(r) = WatertightRay::new(&ray) else {
                    continue;
                };
                let q = PacketRay::new(&r);
                for (t_min, t_max) in [(0.0, f32::INFINITY), (0.0, 1.0), (0.5, 2.0), (-1.0, 0.0)] {
                    let simd = q.hits(&packet, t_min, t_max);
                    let scalar = q.hits_scalar(&packet, t_min, t_max);
                    let msg = format!("seed {seed}, ray {k} {ray:?}, t in ({t_min}, {t_max})");
                    assert_eq!(simd.mask, scalar.mask, "{msg}");
                    lanes_hit += simd.mask.count_ones();
                    for lane in 0..LANES {
                        if simd.mask & (1 << lane) != 0 {
                            let bits = |h: &PacketHits| {
                                [h.t[lane], h.u[lane], h.v[lane]].map(f32::to_bits)
                            };
                            assert_eq!(bits(&simd), bits(&scalar), "{msg}, lane {lane}");
                            let p = packet.triangle(lane);
                            assert_eq!(
                                r.hits_triangle(p[0], p[1], p[2], t_min, t_max)
                                    .map(|(t, u, v)| [t, u, v].map(f32::to_bits)),
                                Some(bits(&simd)),
                                "{msg}, lane {lane}"
                            );
                        }
                    }
                }
            }
        }
        assert!(lanes_hit > 10_000, "only {lanes_hit} lanes hit");
    }

    /// Subtrees of at most four triangles become one leaf: with one triangle per binary leaf,
    /// packets still hold several triangles, and every triangle is in exactly one lane.
    #[test]
    fn small_subtrees_share_a_packet() {
        use crate::{BuildOptions, Bvh, EncodeOptions, TriangleAttributes, encode};
        let mut rng = Rng(5);
        let tris: Vec<[[f32; 3]; 3]> = (0..300)
            .map(|_| {
                let c: [f32; 3] = std::array::from_fn(|_| rng.coord(0.0, 10.0));
                [0, 1, 2].map(|_| std::array::from_fn(|a| c[a] + rng.coord(-0.3, 0.3)))
            })
            .collect();
        let options = BuildOptions {
            max_leaf_size: 1,
            ..BuildOptions::default()
        };
        let bvh = Bvh::build(&tris, &options).expect("build");
        let attributes = vec![TriangleAttributes::default(); tris.len()];
        let scene = encode(&bvh, &tris, &attributes, &EncodeOptions::default()).expect("encode");
        let wide = WideBvh::from_encoded(&scene);
        let mut seen = vec![0u32; tris.len()];
        for packet in &wide.packets {
            for &i in packet.index.iter().filter(|&&i| i != u32::MAX) {
                seen[i as usize] += 1;
            }
        }
        assert!(seen.iter().all(|&n| n == 1), "{seen:?}");
        assert!(
            wide.packets.len() < tris.len() / 2,
            "{} packets for {} triangles",
            wide.packets.len(),
            tris.len()
        );
    }
}
