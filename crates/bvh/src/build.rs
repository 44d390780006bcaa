//! The canonical binary BVH and its top-down binned-SAH builder.

use crate::BvhError;

/// Options for [`Bvh::build`].
///
/// The cost model is Goldsmith & Salmon's surface area heuristic: a node costs
/// `traversal_cost` if it is an inner node and `intersection_cost × triangles` if it is a leaf,
/// each weighted by its surface area relative to the root's ([`Bvh::sah_cost`]).
#[derive(Clone, Debug, PartialEq)]
pub struct BuildOptions {
    /// Hard upper bound on triangles per leaf (≥ 1). Below it, the SAH decides between leaf and
    /// split; above it, the node is always split.
    pub max_leaf_size: u32,
    /// Number of centroid bins per axis for the SAH sweep (2 ..= 256).
    pub bins: u32,
    /// SAH cost of traversing an inner node (finite, ≥ 0).
    pub traversal_cost: f32,
    /// SAH cost of one ray/triangle test (finite, > 0).
    pub intersection_cost: f32,
}

impl Default for BuildOptions {
    /// `max_leaf_size` 4, 16 bins, traversal and intersection cost 1.
    fn default() -> Self {
        Self {
            max_leaf_size: 4,
            bins: 16,
            traversal_cost: 1.0,
            intersection_cost: 1.0,
        }
    }
}

impl BuildOptions {
    fn validate(&self) -> Result<(), BvhError> {
        if self.max_leaf_size == 0 {
            return Err(BvhError::InvalidOption {
                name: "max_leaf_size",
                reason: "must be at least 1",
            });
        }
        if !(2..=256).contains(&self.bins) {
            return Err(BvhError::InvalidOption {
                name: "bins",
                reason: "must be in 2..=256",
            });
        }
        if !(self.traversal_cost.is_finite() && self.traversal_cost >= 0.0) {
            return Err(BvhError::InvalidOption {
                name: "traversal_cost",
                reason: "must be finite and non-negative",
            });
        }
        if !(self.intersection_cost.is_finite() && self.intersection_cost > 0.0) {
            return Err(BvhError::InvalidOption {
                name: "intersection_cost",
                reason: "must be finite and positive",
            });
        }
        Ok(())
    }
}

/// What a [`Node`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeKind {
    /// Inner node with two children (node indices). `left` is always the parent's index + 1.
    Inner {
        /// Index of the left child.
        left: u32,
        /// Index of the right child.
        right: u32,
    },
    /// Leaf holding triangles `first .. first + count` of [`Bvh::triangle_order`].
    Leaf {
        /// First slot in the triangle order.
        first: u32,
        /// Number of triangles (0 only for the single leaf of an empty BVH).
        count: u32,
    },
}

/// One node of the canonical BVH: its axis-aligned box and its kind.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    /// Lower corner of the box.
    pub min: [f32; 3],
    /// Upper corner of the box.
    pub max: [f32; 3],
    /// Inner node or leaf.
    pub kind: NodeKind,
}

/// The canonical binary BVH every layout is converted from.
///
/// Invariants (checked by the tests): nodes are in depth-first pre-order with node 0 the root
/// and every left child directly after its parent; every triangle slot is in exactly one leaf,
/// and leaves appear in increasing slot order; every box contains its children's boxes (and
/// its triangles). An empty BVH (no triangles) is a single empty leaf with a zero box at the
/// origin.
#[derive(Clone, Debug, PartialEq)]
pub struct Bvh {
    nodes: Vec<Node>,
    order: Vec<u32>,
}

/// Per-triangle bounds used by the builder.
struct Prims {
    min: Vec<[f32; 3]>,
    max: Vec<[f32; 3]>,
    centroid: Vec<[f32; 3]>,
}

#[derive(Clone, Copy)]
struct Aabb {
    min: [f32; 3],
    max: [f32; 3],
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        min: [f32::INFINITY; 3],
        max: [f32::NEG_INFINITY; 3],
    };

    fn grow(&mut self, min: &[f32; 3], max: &[f32; 3]) {
        for a in 0..3 {
            self.min[a] = self.min[a].min(min[a]);
            self.max[a] = self.max[a].max(max[a]);
        }
    }

    fn union(&self, other: &Aabb) -> Aabb {
        let mut out = *self;
        out.grow(&other.min, &other.max);
        out
    }

    /// Half the surface area, in f64 (0 for an empty box).
    fn half_area(&self) -> f64 {
        half_area(&self.min, &self.max)
    }
}

/// [`BvhError::NonFiniteVertex`] for the first vertex of triangle `i` with a NaN or infinite
/// coordinate.
pub(crate) fn check_finite_vertices(i: usize, tri: &[[f32; 3]; 3]) -> Result<(), BvhError> {
    match tri.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        Some(vertex) => Err(BvhError::NonFiniteVertex {
            triangle: i,
            vertex,
            position: tri[vertex],
        }),
        None => Ok(()),
    }
}

/// Half the surface area of a box, in f64; 0 for an empty or inverted box.
fn half_area(min: &[f32; 3], max: &[f32; 3]) -> f64 {
    let d = [
        (f64::from(max[0]) - f64::from(min[0])).max(0.0),
        (f64::from(max[1]) - f64::from(min[1])).max(0.0),
        (f64::from(max[2]) - f64::from(min[2])).max(0.0),
    ];
    d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
}

struct Split {
    axis: usize,
    /// Triangles whose bin is `<= bin` go left.
    bin: usize,
    cost: f64,
}

/// A pending subtree: triangle slots `start..end`; `parent` is the inner node whose right
/// child this is (`None` for the root and for left children, which are `parent + 1`).
struct Task {
    start: usize,
    end: usize,
    parent: Option<usize>,
}

impl Bvh {
    /// Builds the BVH over `triangles` (top-down, binned SAH).
    ///
    /// Every triangle, including zero-area ones and duplicates, ends up in exactly one leaf.
    /// Zero triangles give a single empty leaf. The build is deterministic: identical input
    /// gives an identical tree.
    ///
    /// # Errors
    /// [`BvhError::NonFiniteVertex`] naming the first triangle with a NaN or infinite
    /// coordinate; [`BvhError::InvalidOption`] for out-of-range options;
    /// [`BvhError::TooManyTriangles`] above 2^32 − 1 triangles.
    pub fn build(triangles: &[[[f32; 3]; 3]], options: &BuildOptions) -> Result<Bvh, BvhError> {
        options.validate()?;
        if u32::try_from(triangles.len()).is_err() {
            return Err(BvhError::TooManyTriangles {
                count: triangles.len(),
                max: u32::MAX as usize,
            });
        }
        let mut prims = Prims {
            min: Vec::with_capacity(triangles.len()),
            max: Vec::with_capacity(triangles.len()),
            centroid: Vec::with_capacity(triangles.len()),
        };
        for (i, tri) in triangles.iter().enumerate() {
            let mut b = Aabb::EMPTY;
            check_finite_vertices(i, tri)?;
            for p in tri {
                b.grow(p, p);
            }
            prims.min.push(b.min);
            prims.max.push(b.max);
            // Halves first: no overflow for coordinates near f32::MAX.
            prims
                .centroid
                .push(std::array::from_fn(|a| b.min[a] * 0.5 + b.max[a] * 0.5));
        }
        if triangles.is_empty() {
            return Ok(Bvh {
                nodes: vec![Node {
                    min: [0.0; 3],
                    max: [0.0; 3],
                    kind: NodeKind::Leaf { first: 0, count: 0 },
                }],
                order: Vec::new(),
            });
        }

        let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
        let mut nodes: Vec<Node> = Vec::with_capacity(2 * triangles.len());
        let mut scratch = Bins::new(options.bins as usize);
        let mut stack = vec![Task {
            start: 0,
            end: triangles.len(),
            parent: None,
        }];
        while let Some(task) = stack.pop() {
            let index = nodes.len();
            if let Some(parent) = task.parent
                && let NodeKind::Inner { right, .. } = &mut nodes[parent].kind
            {
                *right = index as u32;
            }
            let slots = &mut order[task.start..task.end];
            let mut bounds = Aabb::EMPTY;
            let mut centroids = Aabb::EMPTY;
            for &t in slots.iter() {
                let t = t as usize;
                bounds.grow(&prims.min[t], &prims.max[t]);
                centroids.grow(&prims.centroid[t], &prims.centroid[t]);
            }
            let count = slots.len();
            let split = find_split(slots, &prims, &bounds, &centroids, options, &mut scratch);
            let leaf_cost =
                f64::from(options.intersection_cost) * count as f64 * bounds.half_area();
            let make_leaf = count <= options.max_leaf_size as usize
                && split.as_ref().is_none_or(|s| leaf_cost <= s.cost);
            if make_leaf {
                nodes.push(Node {
                    min: bounds.min,
                    max: bounds.max,
                    kind: NodeKind::Leaf {
                        first: task.start as u32,
                        count: count as u32,
                    },
                });
                continue;
            }
            let mid = match split {
                Some(s) => {
                    task.start + partition(slots, &prims, &centroids, options.bins as usize, &s)
                }
                // All centroids coincide: any partition is as good; halve the range.
                None => task.start + count / 2,
            };
            nodes.push(Node {
                min: bounds.min,
                max: bounds.max,
                kind: NodeKind::Inner {
                    left: index as u32 + 1,
                    right: 0, // patched when the right task is popped
                },
            });
            stack.push(Task {
                start: mid,
                end: task.end,
                parent: Some(index),
            });
            stack.push(Task {
                start: task.start,
                end: mid,
                parent: None,
            });
        }
        Ok(Bvh { nodes, order })
    }

    /// Builds a BVH from nodes and a triangle order made elsewhere (for example converted from
    /// another builder), checking every invariant listed on [`Bvh`].
    ///
    /// Returns `None` if the nodes are not in depth-first pre-order, a leaf range is out of
    /// order or out of bounds, `order` is not a permutation of `0..order.len()`, or a box does
    /// not contain its children.
    pub fn from_parts(nodes: Vec<Node>, order: Vec<u32>) -> Option<Bvh> {
        let bvh = Bvh { nodes, order };
        bvh.check_invariants().then_some(bvh)
    }

    fn check_invariants(&self) -> bool {
        let n = self.order.len();
        let mut seen = vec![false; n];
        for &t in &self.order {
            match seen.get_mut(t as usize) {
                Some(s) if !*s => *s = true,
                _ => return false,
            }
        }
        if self.nodes.is_empty() {
            return false;
        }
        // Walk in pre-order with an explicit stack; the walk must visit nodes 0, 1, 2, ...
        let mut next_node = 0usize;
        let mut next_slot = 0usize;
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            if i != next_node {
                return false;
            }
            next_node += 1;
            let Some(node) = self.nodes.get(i) else {
                return false;
            };
            if !(0..3).all(|a| node.min[a] <= node.max[a]) {
                return false;
            }
            match node.kind {
                NodeKind::Leaf { first, count } => {
                    if first as usize != next_slot || (count == 0 && n > 0) {
                        return false;
                    }
                    next_slot += count as usize;
                    if next_slot > n {
                        return false;
                    }
                }
                NodeKind::Inner { left, right } => {
                    let (l, r) = (left as usize, right as usize);
                    if l != i + 1 || r <= l {
                        return false;
                    }
                    for c in [l, r] {
                        let Some(child) = self.nodes.get(c) else {
                            return false;
                        };
                        if !(0..3)
                            .all(|a| node.min[a] <= child.min[a] && child.max[a] <= node.max[a])
                        {
                            return false;
                        }
                    }
                    stack.push(r);
                    stack.push(l);
                }
            }
        }
        next_node == self.nodes.len() && next_slot == n
    }

    /// The nodes in depth-first pre-order; node 0 is the root.
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// Leaf order of the triangles: slot `s` holds input triangle `triangle_order()[s]`.
    pub fn triangle_order(&self) -> &[u32] {
        &self.order
    }

    /// Number of triangles the BVH was built over.
    pub fn triangle_count(&self) -> usize {
        self.order.len()
    }

    /// Depth of the tree (1 for a single leaf).
    pub fn depth(&self) -> usize {
        let mut depth = vec![1usize; self.nodes.len()];
        let mut max = 1;
        for (i, node) in self.nodes.iter().enumerate() {
            if let NodeKind::Inner { left, right } = node.kind {
                let child_depth = depth[i] + 1;
                for c in [left, right] {
                    if let Some(d) = depth.get_mut(c as usize) {
                        *d = child_depth;
                        max = max.max(*d);
                    }
                }
            }
        }
        max
    }

    /// The tree's SAH cost with the given cost constants:
    /// `Σ_inner traversal_cost·A(n)/A(root) + Σ_leaf intersection_cost·count·A(n)/A(root)`,
    /// `A` the surface area. When the root box has zero area, every ratio is taken as 1.
    pub fn sah_cost_with(&self, traversal_cost: f32, intersection_cost: f32) -> f32 {
        sah_cost(
            self.nodes.iter().map(|n| {
                let count = match n.kind {
                    NodeKind::Inner { .. } => None,
                    NodeKind::Leaf { count, .. } => Some(count),
                };
                (n.min, n.max, count)
            }),
            traversal_cost,
            intersection_cost,
        )
    }

    /// [`Bvh::sah_cost_with`] with the default constants (traversal 1, intersection 1).
    pub fn sah_cost(&self) -> f32 {
        let d = BuildOptions::default();
        self.sah_cost_with(d.traversal_cost, d.intersection_cost)
    }
}

/// SAH cost of any binary tree given as `(min, max, leaf triangle count or None for inner)` per
/// node, the root first. Used for [`Bvh::sah_cost_with`] and to score other builders' trees
/// with the same constants.
pub fn sah_cost(
    nodes: impl IntoIterator<Item = ([f32; 3], [f32; 3], Option<u32>)>,
    traversal_cost: f32,
    intersection_cost: f32,
) -> f32 {
    let mut root_area = None;
    let mut total = 0.0f64;
    for (min, max, count) in nodes {
        let area = half_area(&min, &max);
        let root = *root_area.get_or_insert(area);
        let ratio = if root > 0.0 { area / root } else { 1.0 };
        total += ratio
            * match count {
                None => f64::from(traversal_cost),
                Some(c) => f64::from(intersection_cost) * f64::from(c),
            };
    }
    total as f32
}

/// Bin of a centroid coordinate: `0 ..= bins - 1`.
fn bin_of(c: f32, lo: f32, scale: f32, bins: usize) -> usize {
    // `as` saturates (and maps NaN to 0): never out of range.
    (((c - lo) * scale) as usize).min(bins - 1)
}

/// `bins / extent` for an axis, or `None` if the centroids do not spread along it.
fn bin_scale(centroids: &Aabb, axis: usize, bins: usize) -> Option<f32> {
    let extent = centroids.max[axis] - centroids.min[axis];
    let scale = bins as f32 / extent;
    (extent > 0.0 && scale.is_finite()).then_some(scale)
}

/// Scratch space for [`find_split`], allocated once per build.
struct Bins {
    boxes: [Vec<Aabb>; 3],
    counts: [Vec<usize>; 3],
    right_area: Vec<f64>,
    right_count: Vec<usize>,
}

impl Bins {
    fn new(bins: usize) -> Bins {
        Bins {
            boxes: std::array::from_fn(|_| vec![Aabb::EMPTY; bins]),
            counts: std::array::from_fn(|_| vec![0; bins]),
            right_area: vec![0.0; bins],
            right_count: vec![0; bins],
        }
    }
}

/// Best binned-SAH split of `slots` (cost in the same unnormalised units as the leaf cost:
/// `traversal_cost·A(P) + intersection_cost·(A(L)·n_L + A(R)·n_R)`), or `None` if the
/// centroids spread along no axis. Ties keep the first candidate (x before y before z, lower
/// bin first). All three axes are binned in one pass over the triangles.
fn find_split(
    slots: &[u32],
    prims: &Prims,
    bounds: &Aabb,
    centroids: &Aabb,
    options: &BuildOptions,
    scratch: &mut Bins,
) -> Option<Split> {
    let bins = options.bins as usize;
    let scales = [0, 1, 2].map(|axis| bin_scale(centroids, axis, bins));
    if scales.iter().all(Option::is_none) {
        return None;
    }
    for axis in 0..3 {
        scratch.boxes[axis].fill(Aabb::EMPTY);
        scratch.counts[axis].fill(0);
    }
    for &t in slots {
        let t = t as usize;
        let (lo, hi, c) = (&prims.min[t], &prims.max[t], &prims.centroid[t]);
        for axis in 0..3 {
            if let Some(scale) = scales[axis] {
                let b = bin_of(c[axis], centroids.min[axis], scale, bins);
                scratch.boxes[axis][b].grow(lo, hi);
                scratch.counts[axis][b] += 1;
            }
        }
    }
    let mut best: Option<Split> = None;
    for (axis, scale) in scales.iter().enumerate() {
        if scale.is_none() {
            continue;
        }
        let (boxes, counts) = (&scratch.boxes[axis], &scratch.counts[axis]);
        // right_*[i]: bins i.. ; the split after bin i has right side i + 1..
        let mut acc = Aabb::EMPTY;
        let mut n = 0;
        for i in (0..bins).rev() {
            acc = acc.union(&boxes[i]);
            n += counts[i];
            scratch.right_area[i] = acc.half_area();
            scratch.right_count[i] = n;
        }
        let mut left = Aabb::EMPTY;
        let mut n_left = 0;
        for i in 0..bins - 1 {
            left = left.union(&boxes[i]);
            n_left += counts[i];
            let n_right = scratch.right_count[i + 1];
            if n_left == 0 || n_right == 0 {
                continue;
            }
            let cost = f64::from(options.traversal_cost) * bounds.half_area()
                + f64::from(options.intersection_cost)
                    * (left.half_area() * n_left as f64
                        + scratch.right_area[i + 1] * n_right as f64);
            if best.as_ref().is_none_or(|b| cost < b.cost) {
                best = Some(Split { axis, bin: i, cost });
            }
        }
    }
    best
}

/// Partitions `slots` in place by `split`; returns the number of slots going left (≥ 1 and
/// < `slots.len()` because the split came from non-empty bins on both sides).
fn partition(
    slots: &mut [u32],
    prims: &Prims,
    centroids: &Aabb,
    bins: usize,
    split: &Split,
) -> usize {
    let Some(scale) = bin_scale(centroids, split.axis, bins) else {
        return slots.len() / 2;
    };
    let goes_left = |t: u32| {
        bin_of(
            prims.centroid[t as usize][split.axis],
            centroids.min[split.axis],
            scale,
            bins,
        ) <= split.bin
    };
    let mut left = 0;
    for i in 0..slots.len() {
        if goes_left(slots[i]) {
            slots.swap(left, i);
            left += 1;
        }
    }
    left
}
