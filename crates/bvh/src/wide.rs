//! An 8-wide BVH for fast CPU traversal, collapsed from the canonical SAH tree of an
//! [`EncodedScene`].
//!
//! Each wide node holds the boxes of up to eight children in structure-of-arrays form, so one
//! ray is tested against all eight at once: with 256-bit AVX where the CPU has it (detected at
//! run time when the tree is built; the whole traversal is compiled twice, once for AVX), as
//! two 128-bit SSE halves on other x86_64 CPUs (baseline SSE2), and with a plain loop over the
//! lanes elsewhere; all three compute the same per-lane arithmetic, so they accept the same
//! boxes with the same entry distances bit for bit. Children come from the binary tree by
//! repeatedly opening the inner child of largest surface area until there are eight; leaves
//! keep their triangle ranges, so triangle indices are the encoded ones ([`Hit::triangle`]),
//! and a child whose subtree holds at most sixteen triangles becomes one leaf (its box bounds
//! them all, so every triangle a ray can hit is still tested). A node for such a subtree had
//! two to four lanes, so with leaves of at most four triangles most nodes near the bottom
//! were mostly empty: on the furnished room, leaves of up to 8, 12, 16 and 24 triangles took
//! the wide nodes from 12 726 to 7 042, 4 967, 3 783 and 2 728 and its gather rays from 0.89
//! to 0.94, 0.97, 1.00 and 1.00 times Embree's rate, the other scenes unchanged within noise.
//! A node's leaf lanes are packed into packets of four triangles, structure of arrays, stored
//! contiguously: a lane of at most four triangles lies in one packet, which it may share with
//! sibling lanes (their triangles are tested too, harmlessly), so packets are full where the
//! SAH tree has small leaves; a larger lane has packets of its own. A
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
//! The closest-hit traversal visits the nearest child a ray hit next and keeps the others on a
//! stack, nearer ones on top, each with its entry distance; it drops entries that start beyond
//! the closest hit found so far. The any-hit (shadow) traversal stops at the first triangle
//! hit, so it does not sort: it visits the first leaf child hit, then the inner children, then
//! the other leaves. The stack is not initialised (only entries written are read), and pushed
//! children are prefetched.

use std::mem::MaybeUninit;

use crate::encode::EncodedScene;
use crate::layout;
use crate::traverse::{Hit, Ray, WatertightRay};

/// Children (lanes) per wide node.
const WIDTH: usize = 8;
/// Triangles (lanes) per leaf packet.
const LANES: usize = 4;
/// The most triangles a subtree made into one leaf lane holds (four packets).
const LEAF_TRIANGLES: usize = 4 * LANES;
/// Child tag of a leaf lane: `LEAF | first packet`.
const LEAF: u32 = 1 << 31;
/// Stack entries kept on the thread's stack; deeper trees use a heap stack.
const INLINE_STACK: usize = 128;

/// One wide node: eight child boxes, structure of arrays (256 bytes, four cache lines).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
struct Node {
    /// Per lane: min x, min y, min z, max x, max y, max z. Empty lanes have min +∞, max −∞.
    planes: [[f32; WIDTH]; 6],
    /// Inner child: its node index. Leaf child: `LEAF | first packet`.
    child: [u32; WIDTH],
    /// Packets of a leaf child (0 for inner children and empty lanes).
    count: [u32; WIDTH],
}

impl Node {
    /// The lanes whose child is a leaf (bit per lane): the sign bits of `child` (`LEAF`).
    #[inline(always)]
    fn leaf_mask(&self) -> u32 {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::*;
            // SAFETY: SSE is part of the x86_64 baseline; the loads read the 16-byte aligned
            // halves of `child` (at offset 192 of a 64-byte aligned `Node`).
            unsafe {
                let lo = _mm_load_ps(self.child.as_ptr().cast());
                let hi = _mm_load_ps(self.child.as_ptr().add(4).cast());
                (_mm_movemask_ps(lo) | (_mm_movemask_ps(hi) << 4)) as u32
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let mut mask = 0;
            for (lane, &c) in self.child.iter().enumerate() {
                if c & LEAF != 0 {
                    mask |= 1 << lane;
                }
            }
            mask
        }
    }
}

const EMPTY_NODE: Node = Node {
    planes: [
        [f32::INFINITY; WIDTH],
        [f32::INFINITY; WIDTH],
        [f32::INFINITY; WIDTH],
        [f32::NEG_INFINITY; WIDTH],
        [f32::NEG_INFINITY; WIDTH],
        [f32::NEG_INFINITY; WIDTH],
    ],
    child: [LEAF; WIDTH],
    count: [0; WIDTH],
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

/// What the any-hit walk returns for an occluded ray: it stops at the first lane hit without
/// working out which lane, or its barycentrics.
const OCCLUDED: Hit = Hit {
    t: 0.0,
    triangle: u32::MAX,
    u: 0.0,
    v: 0.0,
};

/// A pending child: node index or `LEAF | first packet`, its packet count, its entry distance.
#[derive(Clone, Copy, Debug, Default)]
struct Entry {
    child: u32,
    count: u32,
    t: f32,
}

/// The 8-wide BVH of an [`EncodedScene`] and its triangle positions (encoded order).
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
    /// Stack entries a traversal may need: `WIDTH − 1` per level below the root, plus one.
    stack_size: usize,
    /// Whether this CPU has AVX (the traversal's 256-bit form); detected when the tree is built.
    avx: bool,
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
    /// encoded order), when it holds at most [`LEAF_TRIANGLES`] triangles in at most twice as
    /// many nodes: such a subtree becomes one leaf lane, and is marked taken.
    fn small_subtree(&mut self, i: u32) -> Option<Vec<u32>> {
        let mut tris = Vec::new();
        let mut seen = Vec::new();
        let mut todo = vec![i];
        while let Some(k) = todo.pop() {
            seen.push(k);
            if seen.len() > 2 * LEAF_TRIANGLES {
                return None;
            }
            match self.children(k) {
                Some((l, r)) => todo.extend([r, l]),
                None => {
                    let n = self.scene.node(k);
                    let end = n.end_tri.min(self.scene.triangle_count);
                    let first = n.first_tri.min(end);
                    if tris.len() + (end - first) as usize > LEAF_TRIANGLES {
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
    /// textures) into an 8-wide tree and copies its leaves' triangle positions into packets.
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
                avx: avx_available(),
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
            while kids.len() < WIDTH {
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
            // The node's leaf lanes and their triangles, packed into packets below.
            let mut leaves: Vec<(usize, Vec<u32>)> = Vec::new();
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
                    leaves.push((lane, leaf));
                } else {
                    let index = nodes.len();
                    nodes.push(EMPTY_NODE);
                    nodes[slot].child[lane] = index as u32;
                    work.push((k, index, depth + 1));
                }
            }
            let base = packets.len();
            let (packed, lanes) = pack_leaves(&leaves);
            for (lane, first, count) in lanes {
                let start = u32::try_from(base + first)
                    .unwrap_or(u32::MAX)
                    .min(LEAF - 1);
                nodes[slot].child[lane] = LEAF | start;
                nodes[slot].count[lane] = count as u32;
            }
            for chunk in packed {
                let tris: Vec<(u32, [[f32; 3]; 3])> = chunk
                    .into_iter()
                    .map(|t| (t, scene.triangle_positions(t)))
                    .collect();
                packets.push(Packet::new(&tris));
            }
        }
        WideBvh {
            nodes,
            packets,
            stack_size: (WIDTH - 1) * max_depth + 1,
            avx: avx_available(),
        }
    }

    /// Number of wide nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Number of leaf packets (of up to four triangles each).
    pub fn packet_count(&self) -> usize {
        self.packets.len()
    }

    /// The closest hit with `t` in `(t_min, t_max)`, as [`EncodedScene::closest_hit`] (same
    /// triangle indices, the same `t`, `u`, `v` bit for bit for the same triangle). Rays with a
    /// zero or non-finite direction never hit.
    pub fn closest_hit(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        if self.avx {
            // SAFETY: `avx` is set only where the CPU reports AVX (`avx_available`).
            return unsafe { self.walk_avx::<false>(ray, t_min, t_max) };
        }
        self.walk::<false, false>(ray, t_min, t_max)
    }

    /// Whether any triangle is hit with `t` in `(t_min, t_max)` (the shadow-ray query).
    pub fn any_hit(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        #[cfg(target_arch = "x86_64")]
        if self.avx {
            // SAFETY: `avx` is set only where the CPU reports AVX (`avx_available`).
            return unsafe { self.walk_avx::<true>(ray, t_min, t_max) }.is_some();
        }
        self.walk::<false, true>(ray, t_min, t_max).is_some()
    }

    /// The traversal compiled with AVX enabled (its box test is one 256-bit test per node, and
    /// the rest of the walk is VEX-encoded).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn walk_avx<const ANY: bool>(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        self.walk::<true, ANY>(ray, t_min, t_max)
    }

    /// Runs the walk with a stack of at least `stack_size` entries: on the thread's stack when
    /// [`INLINE_STACK`] entries are enough, else on the heap. The stack is not initialised (the
    /// walk reads only the entries it wrote), so a ray costs nothing for the stack's size.
    #[inline(always)]
    fn walk<const AVX: bool, const ANY: bool>(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
    ) -> Option<Hit> {
        if self.stack_size <= INLINE_STACK {
            let mut stack = [MaybeUninit::uninit(); INLINE_STACK];
            self.walk_with::<AVX, ANY>(ray, t_min, t_max, &mut stack)
        } else {
            let mut stack = vec![MaybeUninit::uninit(); self.stack_size];
            self.walk_with::<AVX, ANY>(ray, t_min, t_max, &mut stack)
        }
    }

    /// The traversal (`AVX`: the 256-bit box test; `ANY`: stop at the first hit, children
    /// pushed unsorted, and return [`OCCLUDED`] rather than the hit). It sets the ray up
    /// itself, so that the per-ray constants stay in registers: set up by the caller, they were
    /// read back from its stack with vector loads over fresh scalar stores, where `perf` put
    /// ~8 % of this function's samples.
    #[inline(always)]
    fn walk_with<const AVX: bool, const ANY: bool>(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        stack: &mut [MaybeUninit<Entry>],
    ) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        let (q, tri) = if AVX {
            // SAFETY: only `WideBvh::walk_avx`, compiled with AVX and called only where the
            // CPU has it, instantiates the walk with `AVX`.
            unsafe { setup_avx(ray) }?
        } else {
            setup(ray)?
        };
        #[cfg(not(target_arch = "x86_64"))]
        let (q, tri) = setup(ray)?;
        let mut closest = t_max;
        // The closest hit's triangle and its barycentrics' numerators and denominator.
        let mut best: Option<(u32, f32, f32, f32)> = None;
        // The entry to visit next without a round trip through the stack (the nearest child
        // hit), then the stack's entries `0 .. top`, all initialised.
        let mut next = Some(Entry {
            child: 0,
            count: 0,
            t: t_min,
        });
        let mut top = 0usize;
        loop {
            let e = match next.take() {
                Some(e) => e,
                None if top == 0 => break,
                None => {
                    top -= 1;
                    // SAFETY: `top` < the count of entries written (see above).
                    let e = unsafe { stack.get_unchecked(top).assume_init() };
                    if e.t > closest {
                        continue;
                    }
                    e
                }
            };
            if e.child & LEAF != 0 {
                let first = (e.child & !LEAF) as usize;
                let packets = self
                    .packets
                    .get(first..first + e.count as usize)
                    .unwrap_or_default();
                for packet in packets {
                    if ANY {
                        if tri.any(packet, t_min, closest) {
                            return Some(OCCLUDED);
                        }
                    } else if let Some(n) = tri.nearest(packet, t_min, closest) {
                        closest = n.t;
                        best = Some((packet.index[n.lane], n.u, n.v, n.det));
                    }
                }
                continue;
            }
            let Some(node) = self.nodes.get(e.child as usize) else {
                continue;
            };
            let (mut mask, near) = q.hits::<AVX>(node, t_min, closest);
            if ANY {
                // No sort (a triangle hit ends the walk): the first leaf child hit is visited
                // next, the inner children hit are pushed last so they come after it, then the
                // other leaves (measured 1.00-1.04x against visiting every leaf first).
                let leaves = node.leaf_mask();
                let mut first = None;
                for group in [mask & leaves, mask & !leaves] {
                    let mut group = group;
                    while group != 0 {
                        let lane = group.trailing_zeros() as usize;
                        group &= group - 1;
                        if first.is_none() {
                            first = Some(lane);
                        } else if let Some(slot) = stack.get_mut(top) {
                            slot.write(Entry {
                                child: node.child[lane],
                                count: node.count[lane],
                                t: near[lane],
                            });
                            self.prefetch(node.child[lane]);
                            top += 1;
                        }
                    }
                }
                next = first.map(|lane| Entry {
                    child: node.child[lane],
                    count: node.count[lane],
                    t: near[lane],
                });
                continue;
            }
            if mask & (mask.wrapping_sub(1)) == 0 {
                // At most one lane: visit it next.
                if mask != 0 {
                    let lane = mask.trailing_zeros() as usize;
                    next = Some(Entry {
                        child: node.child[lane],
                        count: node.count[lane],
                        t: near[lane],
                    });
                }
                continue;
            }
            let entry = |lane: usize| Entry {
                child: node.child[lane],
                count: node.count[lane],
                t: near[lane],
            };
            if (mask & (mask - 1)).count_ones() == 1 {
                // Two lanes (the most common case after one): push the farther, visit the
                // nearer next; on equal distances the lower lane is visited first.
                let a = mask.trailing_zeros() as usize;
                let b = (mask & (mask - 1)).trailing_zeros() as usize;
                let (first, second) = if near[b] < near[a] { (b, a) } else { (a, b) };
                if let Some(slot) = stack.get_mut(top) {
                    slot.write(entry(second));
                    self.prefetch(node.child[second]);
                    top += 1;
                }
                next = Some(entry(first));
                continue;
            }
            // Push the hit lanes farthest first; the nearest is visited next.
            let mut order = [0u8; WIDTH];
            let mut n = 0;
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let mut j = n;
                while j > 0 && near[order[j - 1] as usize] < near[lane] {
                    order[j] = order[j - 1];
                    j -= 1;
                }
                order[j] = lane as u8;
                n += 1;
            }
            for &lane in &order[..n - 1] {
                if let Some(slot) = stack.get_mut(top) {
                    slot.write(entry(lane as usize));
                    self.prefetch(node.child[lane as usize]);
                    top += 1;
                }
            }
            next = Some(entry(order[n - 1] as usize));
        }
        hit(best, closest)
    }
}

impl WideBvh {
    /// Asks the cache for the first lines of a pushed child (its node, or its first packet).
    #[inline(always)]
    fn prefetch(&self, child: u32) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::*;
            let p: *const i8 = if child & LEAF != 0 {
                match self.packets.get((child & !LEAF) as usize) {
                    Some(p) => (p as *const Packet).cast(),
                    None => return,
                }
            } else {
                match self.nodes.get(child as usize) {
                    Some(n) => (n as *const Node).cast(),
                    None => return,
                }
            };
            // SAFETY: a prefetch never faults; `p` and the lines after it lie in one object.
            unsafe {
                _mm_prefetch::<_MM_HINT_T0>(p);
                _mm_prefetch::<_MM_HINT_T0>(p.add(64));
                _mm_prefetch::<_MM_HINT_T0>(p.add(128));
            }
        }
        // The portable form has no prefetch.
        #[cfg(not(target_arch = "x86_64"))]
        let _ = child;
    }
}

/// A leaf lane's packets: (lane, first packet, packet count).
type LanePackets = (usize, usize, usize);

/// Packs one node's leaf lanes (lane, triangles) into packets of at most [`LANES`] triangles.
/// A lane with more triangles gets packets of its own, filled in order (the last may have room
/// left); the other lanes, largest first, go into the first packet with room for all of their
/// triangles (first fit decreasing), so such a lane lies in one packet, which it may share with
/// sibling lanes: a ray that enters it also tests their triangles, which is harmless (each hit
/// is a real hit) and fills SIMD lanes that would otherwise be empty. Returns the packets'
/// triangles and, per lane, its first packet (index into them) and packet count.
fn pack_leaves(leaves: &[(usize, Vec<u32>)]) -> (Vec<Vec<u32>>, Vec<LanePackets>) {
    let mut packets: Vec<Vec<u32>> = Vec::new();
    let mut lanes = Vec::with_capacity(leaves.len());
    for (lane, tris) in leaves.iter().filter(|(_, t)| t.len() > LANES) {
        let first = packets.len();
        packets.extend(tris.chunks(LANES).map(<[u32]>::to_vec));
        lanes.push((*lane, first, packets.len() - first));
    }
    let mut small: Vec<&(usize, Vec<u32>)> =
        leaves.iter().filter(|(_, t)| t.len() <= LANES).collect();
    small.sort_by_key(|(lane, t)| (std::cmp::Reverse(t.len()), *lane));
    for (lane, tris) in small {
        if tris.is_empty() {
            lanes.push((*lane, 0, 0));
            continue;
        }
        let at = match packets.iter().position(|p| p.len() + tris.len() <= LANES) {
            Some(i) => i,
            None => {
                packets.push(Vec::new());
                packets.len() - 1
            }
        };
        packets[at].extend_from_slice(tris);
        lanes.push((*lane, at, 1));
    }
    (packets, lanes)
}

/// Whether the traversal may use AVX on this CPU.
fn avx_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The walk's per-ray constants: [`WatertightRay::new`] in the forms the box and packet tests
/// read. `None` for a zero or non-finite direction or a non-finite origin.
#[inline(always)]
fn setup(ray: &Ray) -> Option<(BoxRay, PacketRay)> {
    let r = WatertightRay::new(ray)?;
    Some((BoxRay::new(&r), PacketRay::new(&r)))
}

/// [`setup`] with SSE/AVX vector operations (one division for `sx`, `sy`, `sz`, one for the
/// inverse direction, the axis permutation as a lane permutation): the same values bit for bit
/// (unit test), in about half the instructions of the scalar form.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
fn setup_avx(ray: &Ray) -> Option<(BoxRay, PacketRay)> {
    use std::arch::x86_64::*;
    // One 4-byte load per component: the callers have usually just stored the ray, component
    // by component, and a wider load over several fresh stores stalls until they retire (in
    // the bake's gather this cost more than the vector set-up saved).
    // (Volatile, as the compiler otherwise merges them into one overlapping 16-byte load.)
    // SAFETY: reads of the three components through references.
    let load = |c: &[f32; 3]| [0, 1, 2].map(|i| unsafe { std::ptr::read_volatile(&c[i]) });
    let [dx, dy, dz] = load(&ray.dir);
    let origin = load(&ray.origin);
    let d = _mm_setr_ps(dx, dy, dz, 0.0);
    let o = _mm_setr_ps(origin[0], origin[1], origin[2], 0.0);
    let abs = _mm_castsi128_ps(_mm_set1_epi32(0x7fff_ffff));
    let max = _mm_set1_ps(f32::MAX);
    let finite = _mm_and_ps(
        _mm_cmple_ps(_mm_and_ps(d, abs), max),
        _mm_cmple_ps(_mm_and_ps(o, abs), max),
    );
    if _mm_movemask_ps(finite) & 0b111 != 0b111 {
        return None;
    }
    // `dominant_axis` and the permuted axes without branches (with branches on the random
    // axis of a gather ray the set-up mispredicted): kz, then `permuted_axes` from a table.
    let (a0, a1, a2) = (dx.abs(), dy.abs(), dz.abs());
    let x_dominates = usize::from(a0 >= a1) & usize::from(a0 >= a2);
    let kz = (1 - x_dominates) * (2 - usize::from(a1 >= a2));
    // `dir[kz]` is 0 only where all of `dir` is; it is negative where its sign bit is set
    // (these signs are known before `kz`, from the vector).
    if _mm_movemask_ps(_mm_cmpeq_ps(d, _mm_setzero_ps())) & 0b111 == 0b111 {
        return None;
    }
    let signs = _mm_movemask_ps(d) as usize;
    // Lanes `[kx, ky, kz, 3]` by `2·kz + (dir[kz] < 0)`.
    const AXES: [[i32; 4]; 6] = {
        let mut table = [[0; 4]; 6];
        let mut i = 0;
        while i < 6 {
            let [kx, ky, kz] = crate::traverse::permuted_axes(i / 2, i % 2 == 1);
            table[i] = [kx as i32, ky as i32, kz as i32, 3];
            i += 1;
        }
        table
    };
    let axes = AXES[2 * kz + ((signs >> kz) & 1)];
    let (kx, ky) = (axes[0] as usize, axes[1] as usize);
    // SAFETY: an unaligned load of four `i32`s.
    let permutation = unsafe { _mm_loadu_si128(axes.as_ptr().cast()) };
    let dk = _mm_permutevar_ps(d, permutation);
    let ok = _mm_permutevar_ps(o, permutation);
    // (d[kx], d[ky], 1) / d[kz]: sx, sy, sz.
    let one = _mm_set1_ps(1.0);
    let shear = _mm_div_ps(
        _mm_blend_ps::<0b1100>(dk, one),
        _mm_shuffle_ps::<0b10_10_10_10>(dk, dk),
    );
    // 1 / dir, with 1 in place of parallel components, then +∞ there for the slab test.
    let parallel = _mm_cmplt_ps(_mm_and_ps(d, abs), _mm_set1_ps(layout::PARALLEL_EPSILON));
    let inv = _mm_div_ps(one, _mm_blendv_ps(d, one, parallel));
    let inv = _mm_blendv_ps(inv, _mm_set1_ps(f32::INFINITY), parallel);
    // The signs of `inv` (+∞ on parallel axes) without waiting for the division.
    let negative = _mm_movemask_ps(_mm_andnot_ps(parallel, d)) as usize;
    let mut box_inv = [0.0f32; 4];
    let mut shears = [0.0f32; 4];
    let mut permuted = [0.0f32; 4];
    // SAFETY: unaligned stores into four-float arrays.
    unsafe {
        _mm_storeu_ps(box_inv.as_mut_ptr(), inv);
        _mm_storeu_ps(shears.as_mut_ptr(), shear);
        _mm_storeu_ps(permuted.as_mut_ptr(), ok);
    }
    let negative = [0, 1, 2].map(|a| (negative >> a) & 1);
    Some((
        BoxRay {
            origin,
            inv: [box_inv[0], box_inv[1], box_inv[2]],
            near: [0, 1, 2].map(|a| a + 3 * negative[a]),
            far: [0, 1, 2].map(|a| a + 3 * (1 - negative[a])),
        },
        PacketRay {
            axis: [kx, ky, kz],
            origin: [permuted[0], permuted[1], permuted[2]],
            sx: shears[0],
            sy: shears[1],
            sz: shears[2],
            #[cfg(test)]
            ray: WatertightRay::new(ray)?,
        },
    ))
}

/// The closest hit from the walk's best triangle, its barycentrics' numerators and denominator
/// (one division each, here rather than at every packet hit on the way).
fn hit(best: Option<(u32, f32, f32, f32)>, t: f32) -> Option<Hit> {
    best.map(|(triangle, u, v, det)| Hit {
        t,
        triangle,
        u: u / det,
        v: v / det,
    })
}

/// The nearest lane hit in a packet: its `t`, and its barycentrics `u / det`, `v / det`.
#[derive(Clone, Copy, Debug)]
struct Nearest {
    lane: usize,
    t: f32,
    u: f32,
    v: f32,
    det: f32,
}

impl Nearest {
    /// `(lane, t, u, v)` with the barycentrics divided out.
    #[cfg(test)]
    fn divided(self) -> (usize, f32, f32, f32) {
        (self.lane, self.t, self.u / self.det, self.v / self.det)
    }
}

/// The lanes of a [`Packet`] a ray hits, with their `t`, `u`, `v` (unspecified in other lanes):
/// the portable packet test's result.
#[cfg(any(test, not(target_arch = "x86_64")))]
struct PacketHits {
    mask: u32,
    t: [f32; LANES],
    u: [f32; LANES],
    v: [f32; LANES],
}

#[cfg(any(test, not(target_arch = "x86_64")))]
impl PacketHits {
    /// The nearest lane hit and its `t`, `u`, `v`; ties keep the lower lane (the earlier
    /// triangle), as the scalar loop over a leaf with a strict `t < closest` does.
    fn nearest(&self) -> Option<(usize, f32, f32, f32)> {
        let mut lane = None::<usize>;
        for l in 0..LANES {
            if self.mask & (1 << l) != 0 && lane.is_none_or(|k| self.t[l] < self.t[k]) {
                lane = Some(l);
            }
        }
        lane.map(|l| (l, self.t[l], self.u[l], self.v[l]))
    }
}

/// The SSE packet test's lanes ([`PacketRay::lanes`]): the mask of lanes hit and, per lane,
/// `t`, the edge functions `v`, `w` and `det` (meaningful in the lanes hit).
#[cfg(target_arch = "x86_64")]
struct LaneHits {
    accept: std::arch::x86_64::__m128,
    t: std::arch::x86_64::__m128,
    v: std::arch::x86_64::__m128,
    w: std::arch::x86_64::__m128,
    det: std::arch::x86_64::__m128,
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
    /// u + v + w`; `t = (u·az + v·bz + w·cz) / det`; `t_min < t < t_max`), each one correctly
    /// rounded in SSE as in scalar code, so every lane's result is the scalar one bit for
    /// bit. `None` when no lane is hit; the barycentrics' divisions are left to
    /// [`PacketRay::nearest`], which alone needs them.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn lanes(&self, packet: &Packet, t_min: f32, t_max: f32) -> Option<LaneHits> {
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
            // Lanes whose edge functions differ in sign miss; when that is all of them (most
            // packets a ray reaches), `det`, `t` and the division are not needed.
            let mixed = _mm_and_ps(negative, positive);
            if _mm_movemask_ps(mixed) == 0xf {
                return None;
            }
            let det = _mm_add_ps(_mm_add_ps(u, v), w);
            let num = _mm_add_ps(
                _mm_add_ps(_mm_mul_ps(u, az), _mm_mul_ps(v, bz)),
                _mm_mul_ps(w, cz),
            );
            if t_min >= 0.0 {
                // An accepted `t = num / det > t_min ≥ 0` needs `num` and `det` non-zero, not
                // NaN and of one sign. Where no lane can pass (the triangle a ray leaves from,
                // behind its origin), the division is skipped; lanes that can still go on to
                // the exact test below.
                let signs_differ = _mm_movemask_ps(_mm_xor_ps(num, det));
                let never = _mm_movemask_ps(_mm_or_ps(mixed, _mm_cmpeq_ps(num, zero)));
                if (signs_differ | never) == 0xf {
                    return None;
                }
            }
            let t = _mm_div_ps(num, det);
            // `cmpneq` is true for NaN, as `det == 0.0` is false; the `t` comparisons reject
            // NaN as `!(t > t_min && t < t_max)` does.
            let accept = _mm_andnot_ps(
                mixed,
                _mm_and_ps(
                    _mm_cmpneq_ps(det, zero),
                    _mm_and_ps(
                        _mm_cmpgt_ps(t, _mm_set1_ps(t_min)),
                        _mm_cmplt_ps(t, _mm_set1_ps(t_max)),
                    ),
                ),
            );
            if _mm_movemask_ps(accept) == 0 {
                return None;
            }
            Some(LaneHits {
                accept,
                t,
                v,
                w,
                det,
            })
        }
    }

    /// The nearest lane of `packet` hit (ties: the lower lane) with its `t` and its
    /// barycentrics as a [`Nearest`]: [`PacketHits::nearest`] of the lane-by-lane results
    /// ([`PacketRay::lanes`]), the barycentrics left as `v`, `w` over `det`, whose one correctly
    /// rounded division each, as in the scalar test, the walk does once for the closest hit.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn nearest(&self, packet: &Packet, t_min: f32, t_max: f32) -> Option<Nearest> {
        use std::arch::x86_64::*;
        let LaneHits {
            accept,
            t,
            v,
            w,
            det,
        } = self.lanes(packet, t_min, t_max)?;
        // SAFETY: SSE and SSE2 are part of the x86_64 baseline.
        unsafe {
            // The smallest accepted `t` (others +∞), and the lowest lane holding it.
            let far = _mm_andnot_ps(accept, _mm_set1_ps(f32::INFINITY));
            let tm = _mm_or_ps(_mm_and_ps(accept, t), far);
            let m = _mm_min_ps(tm, _mm_shuffle_ps::<0b10_11_00_01>(tm, tm));
            let m = _mm_min_ps(m, _mm_shuffle_ps::<0b01_00_11_10>(m, m));
            let nearest = _mm_movemask_ps(_mm_and_ps(accept, _mm_cmpeq_ps(tm, m)));
            let lane = nearest.trailing_zeros() as usize;
            let mut ts = [0.0f32; LANES];
            let mut vs = [0.0f32; LANES];
            let mut ws = [0.0f32; LANES];
            let mut dets = [0.0f32; LANES];
            _mm_storeu_ps(ts.as_mut_ptr(), t);
            _mm_storeu_ps(vs.as_mut_ptr(), v);
            _mm_storeu_ps(ws.as_mut_ptr(), w);
            _mm_storeu_ps(dets.as_mut_ptr(), det);
            // The lane's own `t` (a −0 / +0 tie keeps the lower lane's sign).
            Some(Nearest {
                lane,
                t: ts[lane],
                u: vs[lane],
                v: ws[lane],
                det: dets[lane],
            })
        }
    }

    /// Whether any lane of `packet` is hit ([`PacketRay::lanes`]): the shadow rays' test,
    /// which needs neither the nearest lane nor barycentrics.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn any(&self, packet: &Packet, t_min: f32, t_max: f32) -> bool {
        self.lanes(packet, t_min, t_max).is_some()
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
    fn nearest(&self, packet: &Packet, t_min: f32, t_max: f32) -> Option<Nearest> {
        // The scalar test's barycentrics are final: over 1, which divides exactly.
        let (lane, t, u, v) = self.hits_scalar(packet, t_min, t_max).nearest()?;
        Some(Nearest {
            lane,
            t,
            u,
            v,
            det: 1.0,
        })
    }

    #[cfg(not(target_arch = "x86_64"))]
    #[inline(always)]
    fn any(&self, packet: &Packet, t_min: f32, t_max: f32) -> bool {
        self.hits_scalar(packet, t_min, t_max).mask != 0
    }
}

// The box tests below leave out the encoded test's clamps to ±`BIG`, exact only for this value.
const _: () = assert!(layout::BIG == f32::MAX);

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
    /// is the largest plane distance, the exit the smallest, both widened by
    /// [`layout::BOX_SLACK`]. A parallel axis gives ±∞, or NaN for an origin on the plane, and
    /// `max`/`min` with the NaN first keep the other operand: so such an axis constrains
    /// nothing when the origin is in the slab and rejects the box otherwise, as the encoded
    /// test's ±`BIG` does. An entry at +∞ or an exit at −∞ (empty lanes, overflow) turns into
    /// NaN with the slack and rejects the lane. The encoded test also clamps the entry to at
    /// least −`BIG` and the exit to at most `BIG`; with `BIG` = `f32::MAX` that changes only
    /// ∓∞, which the slack then turns back into ∓∞ (`MAX · (1 + BOX_SLACK)` overflows), so
    /// the clamps are left out here and both tests still give the same entry distance and
    /// verdict bit for bit.
    ///
    /// `AVX` selects the 256-bit form, which only a caller compiled with AVX may ask for.
    #[inline(always)]
    fn hits<const AVX: bool>(&self, node: &Node, t_min: f32, t_max: f32) -> (u32, [f32; WIDTH]) {
        #[cfg(target_arch = "x86_64")]
        {
            if AVX {
                // SAFETY: only `WideBvh::walk_avx`, compiled with AVX and called only where the
                // CPU has it, instantiates the walk with `AVX`.
                unsafe { self.hits_avx(node, t_min, t_max) }
            } else {
                self.hits_sse(node, t_min, t_max)
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            self.hits_scalar(node, t_min, t_max)
        }
    }

    /// The test with 256-bit AVX: all eight lanes at once.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn hits_avx(&self, node: &Node, t_min: f32, t_max: f32) -> (u32, [f32; WIDTH]) {
        use std::arch::x86_64::*;
        // SAFETY: the loads read the 32-byte aligned `[f32; 8]` rows of a `Node` (64-byte
        // aligned, rows at multiples of 32); this function runs only where AVX is available.
        unsafe {
            let mut near = _mm256_set1_ps(f32::NEG_INFINITY);
            let mut far = _mm256_set1_ps(f32::INFINITY);
            for a in 0..3 {
                let o = _mm256_set1_ps(self.origin[a]);
                let inv = _mm256_set1_ps(self.inv[a]);
                let rn = _mm256_load_ps(node.planes[self.near[a]].as_ptr());
                let rf = _mm256_load_ps(node.planes[self.far[a]].as_ptr());
                let tn = _mm256_mul_ps(_mm256_sub_ps(rn, o), inv);
                let tf = _mm256_mul_ps(_mm256_sub_ps(rf, o), inv);
                near = _mm256_max_ps(tn, near);
                far = _mm256_min_ps(tf, far);
            }
            let abs = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fff_ffff));
            let slack = _mm256_set1_ps(layout::BOX_SLACK);
            let t_near = _mm256_max_ps(
                _mm256_set1_ps(t_min),
                _mm256_sub_ps(near, _mm256_mul_ps(_mm256_and_ps(near, abs), slack)),
            );
            let t_far = _mm256_min_ps(
                _mm256_set1_ps(t_max),
                _mm256_add_ps(far, _mm256_mul_ps(_mm256_and_ps(far, abs), slack)),
            );
            // Ordered `<=`: false for NaN, as SSE's `cmple`.
            let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t_near, t_far)) as u32;
            let mut out = [0.0f32; WIDTH];
            _mm256_storeu_ps(out.as_mut_ptr(), t_near);
            (mask, out)
        }
    }

    /// The test with 128-bit SSE (x86_64 baseline), four lanes at a time.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn hits_sse(&self, node: &Node, t_min: f32, t_max: f32) -> (u32, [f32; WIDTH]) {
        use std::arch::x86_64::*;
        let mut mask = 0;
        let mut out = [0.0f32; WIDTH];
        for half in 0..WIDTH / 4 {
            // SAFETY: SSE and SSE2 are part of the x86_64 baseline; the loads read 16-byte
            // aligned quarters of the `[f32; 8]` rows of a `Node` (64-byte aligned, rows at
            // multiples of 32).
            unsafe {
                let row = |i: usize| _mm_load_ps(node.planes[i].as_ptr().add(4 * half));
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
                mask |= (_mm_movemask_ps(_mm_cmple_ps(t_near, t_far)) as u32) << (4 * half);
                _mm_storeu_ps(out.as_mut_ptr().add(4 * half), t_near);
            }
        }
        (mask, out)
    }

    /// The portable form of the SIMD tests above, lane by lane (also the reference the tests
    /// compare them with).
    #[cfg(any(test, not(target_arch = "x86_64")))]
    fn hits_scalar(&self, node: &Node, t_min: f32, t_max: f32) -> (u32, [f32; WIDTH]) {
        // `_mm_max_ps(a, b)` / `_mm_min_ps(a, b)`: `b` unless `a` compares greater / less.
        let max = |a: f32, b: f32| if a > b { a } else { b };
        let min = |a: f32, b: f32| if a < b { a } else { b };
        let mut mask = 0;
        let mut out = [0.0f32; WIDTH];
        for (lane, out) in out.iter_mut().enumerate() {
            let mut near = f32::NEG_INFINITY;
            let mut far = f32::INFINITY;
            for a in 0..3 {
                let tn = (node.planes[self.near[a]][lane] - self.origin[a]) * self.inv[a];
                let tf = (node.planes[self.far[a]][lane] - self.origin[a]) * self.inv[a];
                near = max(tn, near);
                far = min(tf, far);
            }
            let t_near = max(t_min, near - near.abs() * layout::BOX_SLACK);
            let t_far = min(t_max, far + far.abs() * layout::BOX_SLACK);
            if t_near <= t_far {
                mask |= 1 << lane;
            }
            *out = t_near;
        }
        (mask, out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use luxbake_testkit::SplitMix64;

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

    /// The AVX and SSE slab tests, their scalar form and the encoded traversal's `hits_box`
    /// agree on every lane, for parallel axes, origins on a plane, boxes behind the origin,
    /// point boxes, empty lanes and shrinking `t_max`.
    #[test]
    fn box_test_matches_the_encoded_slab_test() {
        let boxes = [
            ([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]),
            ([2.0, -1.0, 0.5], [3.0, 1.0, 0.5]),
            ([-1e30, 0.25, -4.0], [1e30, 0.25, 4.0]),
            ([-1.0, -1.0, -1.0], [-0.5, -0.5, 2.0]),
            ([0.25, 0.25, 0.5], [0.25, 0.25, 0.5]),
            ([-2.0, -2.0, 0.5], [3.0, 3.0, 0.5]),
            ([1e20, 0.0, 0.0], [2e20, 1.0, 1.0]),
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
                                let (mask, near) = q.hits_scalar(&node, t_min, t_max);
                                #[cfg(target_arch = "x86_64")]
                                {
                                    let bits =
                                        |(m, n): (u32, [f32; WIDTH])| (m, n.map(f32::to_bits));
                                    let scalar = bits((mask, near));
                                    let sse = bits(q.hits_sse(&node, t_min, t_max));
                                    assert_eq!(sse, scalar, "SSE {ray:?}");
                                    if avx_available() {
                                        // SAFETY: this CPU has AVX.
                                        let avx = bits(unsafe { q.hits_avx(&node, t_min, t_max) });
                                        assert_eq!(avx, scalar, "AVX {ray:?}");
                                    }
                                }
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

    /// The workspace's SplitMix64 (`luxbake_testkit`), with coordinates on a coarse grid a quarter of the time.
    struct Rng(SplitMix64);

    impl Rng {
        fn next(&mut self) -> u64 {
            self.0.next_u64()
        }

        /// Uniform in `[lo, hi)`, on a coarse grid a quarter of the time (exact ties, shared
        /// coordinates, axis-aligned edges).
        fn coord(&mut self, lo: f32, hi: f32) -> f32 {
            let x = self.0.f32();
            if self.next().is_multiple_of(4) {
                lo + ((x * 8.0).floor() / 8.0) * (hi - lo)
            } else {
                lo + x * (hi - lo)
            }
        }
    }

    /// `count` small triangles over `[0, 10)³`, each vertex within `±spread` of its centre
    /// (drawn from `rng`), built with `options` and encoded with default attributes: the
    /// triangles, the encoding and its wide BVH.
    fn clustered_scene(
        rng: &mut Rng,
        count: usize,
        spread: f32,
        options: &crate::BuildOptions,
    ) -> (Vec<[[f32; 3]; 3]>, crate::EncodedScene, WideBvh) {
        use crate::{Bvh, EncodeOptions, TriangleAttributes, encode};
        let tris: Vec<[[f32; 3]; 3]> = (0..count)
            .map(|_| {
                let c: [f32; 3] = std::array::from_fn(|_| rng.coord(0.0, 10.0));
                [0, 1, 2].map(|_| std::array::from_fn(|a| c[a] + rng.coord(-spread, spread)))
            })
            .collect();
        let bvh = Bvh::build(&tris, options).expect("build");
        let attributes = vec![TriangleAttributes::default(); tris.len()];
        let scene = encode(&bvh, &tris, &attributes, &EncodeOptions::default()).expect("encode");
        let wide = WideBvh::from_encoded(&scene);
        (tris, scene, wide)
    }

    /// The SSE packet test equals the scalar watertight test lane by lane, bit for bit (mask,
    /// `t`, `u`, `v`; the any-hit form: whether the mask is non-zero), on seeded random
    /// packets: triangles sharing vertices and edges, zero-area ones, unused lanes, rays aimed
    /// at vertices and edges, axis-aligned and negative directions, and a range of `t_max`.
    #[test]
    fn packet_test_matches_the_scalar_watertight_test() {
        let mut lanes_hit = 0;
        for seed in 0..400u64 {
            let mut rng = Rng(SplitMix64(seed));
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
                    let scalar = q.hits_scalar(&packet, t_min, t_max);
                    let msg = format!("seed {seed}, ray {k} {ray:?}, t in ({t_min}, {t_max})");
                    let bits = |h: Option<(usize, f32, f32, f32)>| {
                        h.map(|(lane, t, u, v)| (lane, [t, u, v].map(f32::to_bits)))
                    };
                    assert_eq!(
                        bits(q.nearest(&packet, t_min, t_max).map(Nearest::divided)),
                        bits(scalar.nearest()),
                        "{msg}"
                    );
                    assert_eq!(q.any(&packet, t_min, t_max), scalar.mask != 0, "{msg}");
                    lanes_hit += scalar.mask.count_ones();
                    for lane in 0..LANES {
                        let p = packet.triangle(lane);
                        let expected = r.hits_triangle(p[0], p[1], p[2], t_min, t_max);
                        assert_eq!(scalar.mask & (1 << lane) != 0, expected.is_some(), "{msg}");
                        if let Some((t, u, v)) = expected {
                            assert_eq!(
                                [scalar.t[lane], scalar.u[lane], scalar.v[lane]].map(f32::to_bits),
                                [t, u, v].map(f32::to_bits),
                                "{msg}, lane {lane}"
                            );
                        }
                        if scalar.mask == 1 << lane {
                            // A packet hit in one lane only: the SIMD test returns that lane's
                            // own `t`, `u`, `v`.
                            assert_eq!(
                                bits(q.nearest(&packet, t_min, t_max).map(Nearest::divided)),
                                bits(expected.map(|(t, u, v)| (lane, t, u, v))),
                                "{msg}"
                            );
                        }
                    }
                }
            }
        }
        assert!(lanes_hit > 10_000, "only {lanes_hit} lanes hit");
    }

    /// The SSE walk and the public queries (the AVX walk where the CPU has it) return the same
    /// hits bit for bit, and the nearest `t` of a brute-force loop over the triangles, on a
    /// seeded scene deep enough for several levels of 8-wide nodes.
    #[test]
    fn avx_and_sse_walks_agree_with_brute_force() {
        let mut rng = Rng(SplitMix64(11));
        let (_, scene, wide) =
            clustered_scene(&mut rng, 3000, 0.4, &crate::BuildOptions::default());
        assert!(wide.node_count() > 9, "{} nodes", wide.node_count());
        let positions: Vec<[[f32; 3]; 3]> = (0..scene.triangle_count)
            .map(|t| scene.triangle_positions(t))
            .collect();
        let bits = |h: Option<Hit>| h.map(|h| (h.triangle, [h.t, h.u, h.v].map(f32::to_bits)));
        let mut hits = 0;
        for k in 0..2000 {
            let origin: [f32; 3] = std::array::from_fn(|_| rng.coord(-1.0, 11.0));
            let dir: [f32; 3] = std::array::from_fn(|_| rng.coord(-1.0, 1.0));
            let ray = Ray { origin, dir };
            let Some(r) = WatertightRay::new(&ray) else {
                continue;
            };
            let t_max = if k % 2 == 0 { f32::INFINITY } else { 0.5 };
            let sse = wide.walk::<false, false>(&ray, 0.0, t_max);
            assert_eq!(
                bits(sse),
                bits(wide.closest_hit(&ray, 0.0, t_max)),
                "ray {k}"
            );
            let brute = positions
                .iter()
                .filter_map(|p| r.hits_triangle(p[0], p[1], p[2], 0.0, t_max))
                .map(|(t, _, _)| t)
                .reduce(f32::min);
            assert_eq!(
                sse.map(|h| h.t.to_bits()),
                brute.map(f32::to_bits),
                "ray {k}"
            );
            let any = wide.walk::<false, true>(&ray, 0.0, t_max).is_some();
            assert_eq!(any, brute.is_some(), "ray {k}");
            assert_eq!(wide.any_hit(&ray, 0.0, t_max), any, "ray {k}");
            hits += usize::from(any);
        }
        assert!((200..1800).contains(&hits), "{hits} of 2000 rays hit");
    }

    /// The vector set-up equals the scalar one bit for bit (every field of both forms), on
    /// seeded rays with zero, negative-zero, subnormal, tied, huge and non-finite components.
    #[test]
    fn vector_setup_matches_the_scalar_setup() {
        if !avx_available() {
            luxbake_testkit::skip_or_fail(
                "vector_setup_matches_the_scalar_setup",
                &"no AVX on this CPU: the vector set-up is not used here",
            );
            return;
        }
        let special = [
            0.0,
            -0.0,
            1e-40,
            -1e-40,
            1.0,
            -1.0,
            0.5,
            f32::MAX,
            f32::INFINITY,
            f32::NAN,
        ];
        let mut rng = Rng(SplitMix64(23));
        let mut compared = 0;
        for k in 0..20_000 {
            let mut c = || {
                if rng.next().is_multiple_of(3) {
                    special[(rng.next() % special.len() as u64) as usize]
                } else {
                    rng.coord(-3.0, 3.0)
                }
            };
            let ray = Ray {
                origin: [c(), c(), c()],
                dir: [c(), c(), c()],
            };
            let scalar = setup(&ray);
            // SAFETY: this CPU has AVX.
            let vector = unsafe { setup_avx(&ray) };
            let fields = |s: Option<(BoxRay, PacketRay)>| {
                s.map(|(b, p)| {
                    (
                        b.origin.map(f32::to_bits),
                        b.inv.map(f32::to_bits),
                        b.near,
                        b.far,
                        p.axis,
                        p.origin.map(f32::to_bits),
                        [p.sx, p.sy, p.sz].map(f32::to_bits),
                    )
                })
            };
            compared += usize::from(scalar.is_some());
            assert_eq!(fields(vector), fields(scalar), "ray {k} {ray:?}");
        }
        assert!(compared > 10_000, "{compared}");
    }

    /// Subtrees of at most sixteen triangles become one leaf, and a node's small leaves share
    /// packets: with one triangle per binary leaf, packets still hold several triangles, and
    /// every triangle is in exactly one packet lane.
    #[test]
    fn small_subtrees_share_a_packet() {
        let options = crate::BuildOptions {
            max_leaf_size: 1,
            ..crate::BuildOptions::default()
        };
        let mut rng = Rng(SplitMix64(5));
        let (tris, _, wide) = clustered_scene(&mut rng, 300, 0.3, &options);
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
