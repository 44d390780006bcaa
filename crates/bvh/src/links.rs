//! Threaded (stackless) link orders derived from the canonical BVH: TBVH and MTBVH.

use crate::build::{Bvh, NodeKind};

/// Which child an inner node's hit link visits first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChildOrder {
    /// The canonical order, left child first: the TBVH of the paper's Figure 8, whose hit
    /// links follow the depth-first node numbering.
    Canonical,
    /// MTBVH order for rays whose dominant direction is `direction` (0..6 in the order
    /// +x, −x, +y, −y, +z, −z, see [`crate::dominant_direction`]): the child whose box centre
    /// comes first along that direction is visited first; ties keep the left child first.
    NearFirst {
        /// Direction index 0..6.
        direction: u32,
    },
}

/// The two links of a node in one link order. `None` ends the traversal (−1 in the texture).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Link {
    /// Next node when the ray hits this node's box (first child; for a leaf, = `miss`).
    pub hit: Option<u32>,
    /// Next node when the ray misses this node's box: the node after this subtree.
    pub miss: Option<u32>,
}

impl Bvh {
    /// The hit and miss link of every node (indexed like [`Bvh::nodes`]) in the given order.
    ///
    /// Following hit links from the root visits every node once (a depth-first order with the
    /// children ordered by `order`); a miss link skips the node's subtree. Both links only ever
    /// point forward in that sequence, so a traversal visits each node at most once.
    pub fn threaded_links(&self, order: ChildOrder) -> Vec<Link> {
        let nodes = self.nodes();
        let mut links = vec![
            Link {
                hit: None,
                miss: None
            };
            nodes.len()
        ];
        // (node, its miss link); explicit stack, so degenerate deep trees cannot overflow.
        let mut stack: Vec<(u32, Option<u32>)> = vec![(0, None)];
        while let Some((i, miss)) = stack.pop() {
            let Some(node) = nodes.get(i as usize) else {
                continue;
            };
            match node.kind {
                NodeKind::Leaf { .. } => {
                    links[i as usize] = Link { hit: miss, miss };
                }
                NodeKind::Inner { left, right } => {
                    let (first, second) = match order {
                        ChildOrder::Canonical => (left, right),
                        ChildOrder::NearFirst { direction } => {
                            let axis = (direction / 2).min(2) as usize;
                            let negative = direction % 2 == 1;
                            let centre = |c: u32| {
                                let n = &nodes[c as usize];
                                n.min[axis] * 0.5 + n.max[axis] * 0.5
                            };
                            let (cl, cr) = (centre(left), centre(right));
                            let right_first = if negative { cr > cl } else { cr < cl };
                            if right_first {
                                (right, left)
                            } else {
                                (left, right)
                            }
                        }
                    };
                    links[i as usize] = Link {
                        hit: Some(first),
                        miss,
                    };
                    stack.push((second, miss));
                    stack.push((first, Some(second)));
                }
            }
        }
        links
    }
}
