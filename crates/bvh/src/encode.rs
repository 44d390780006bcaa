//! Encoding of the BVH, its link orders and the triangle data into RGBA32F texel arrays.

use crate::build::{Bvh, NodeKind, check_finite_vertices};
use crate::layout::{self, FLOATS_PER_TEXEL, MAX_EXACT_INTEGER};
use crate::links::{ChildOrder, Link};
use crate::sliver::is_sliver;
use crate::{BvhError, TriangleAttributes};

/// Options for [`encode`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EncodeOptions {
    /// Largest texture width and height the device supports (`MAX_TEXTURE_SIZE`; WebGL2
    /// guarantees 2048, desktop GPUs give 16384). Must be ≥ 1.
    pub max_texture_size: u32,
}

impl Default for EncodeOptions {
    /// 2048, the WebGL2 minimum.
    fn default() -> Self {
        Self {
            max_texture_size: 2048,
        }
    }
}

/// Width and height of a texture.
pub type TextureSize = [u32; 2];

/// The texture size used for `count` texels per layer: width `⌈√count⌉` (at least 1, at most
/// `max_texture_size`), height `⌈count / width⌉`, so the texture is close to square.
///
/// # Errors
/// [`BvhError::TextureTooSmall`] if the height would exceed `max_texture_size`;
/// [`BvhError::InvalidOption`] if `max_texture_size` is 0.
pub fn texture_size(
    what: &'static str,
    count: usize,
    max_texture_size: u32,
) -> Result<TextureSize, BvhError> {
    if max_texture_size == 0 {
        return Err(BvhError::InvalidOption {
            name: "max_texture_size",
            reason: "must be at least 1",
        });
    }
    let count_u64 = count.max(1) as u64;
    let mut width = (count_u64 as f64).sqrt().ceil() as u64;
    // Correct the float square root so width = ⌈√count⌉ exactly.
    while width > 1 && (width - 1) * (width - 1) >= count_u64 {
        width -= 1;
    }
    while width * width < count_u64 {
        width += 1;
    }
    let width = width.clamp(1, u64::from(max_texture_size));
    let height = count_u64.div_ceil(width);
    if height > u64::from(max_texture_size) {
        return Err(BvhError::TextureTooSmall {
            what,
            count,
            max_size: max_texture_size,
        });
    }
    Ok([width as u32, height as u32])
}

/// Everything a shader reads, as RGBA32F texel arrays laid out as described in [`layout`].
///
/// Build with [`encode`]; the fields are plain data for upload. Reading them back
/// ([`EncodedScene::closest_hit`], [`EncodedScene::node`], …) goes through the same
/// `texelFetch`-like accessor a shader uses, and is robust against arbitrary (even corrupt)
/// field contents: out-of-range reads return zero texels, as WebGL's robust buffer access may.
#[derive(Clone, Debug, PartialEq)]
pub struct EncodedScene {
    /// Width and height of every node texture; node `i` is texel `(i % w, i / w)`.
    pub node_size: TextureSize,
    /// Number of BVH nodes (≥ 1).
    pub node_count: u32,
    /// MTBVH links: [`layout::LINK_LAYERS`] layers, layer `d` for dominant direction `d`
    /// (+x, −x, +y, −y, +z, −z); texel `(hit.x, hit.y, miss.x, miss.y)`, −1 ends.
    pub links: Vec<f32>,
    /// TBVH links: one layer, same texel format (canonical depth-first order).
    pub tbvh_links: Vec<f32>,
    /// Node boxes: 2 layers, `(min.xyz, first_tri)` and `(max.xyz, end_tri)`; inner nodes have
    /// `first_tri == end_tri`.
    pub bounds: Vec<f32>,
    /// Width and height of the triangle textures; triangle `t` is texel `(t % w, t / w)`.
    pub tri_size: TextureSize,
    /// Triangle data: [`layout::TRIANGLE_LAYERS`] layers (positions, normals, UVs + object).
    pub triangles: Vec<f32>,
    /// Number of triangles (encoded order `0 .. triangle_count`).
    pub triangle_count: u32,
    /// Encoded triangle `t` is input triangle `triangle_order[t]` (CPU side only).
    pub triangle_order: Vec<u32>,
}

/// One node as read back from the encoded textures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EncodedNode {
    /// Box lower corner.
    pub min: [f32; 3],
    /// Box upper corner.
    pub max: [f32; 3],
    /// First triangle of the leaf range.
    pub first_tri: u32,
    /// One past the last triangle of the leaf range (`== first_tri` for inner nodes).
    pub end_tri: u32,
}

/// Encodes `bvh`, built from `triangles`, with per-triangle `attributes` (input order).
///
/// Deterministic: identical input gives identical (bit-for-bit) textures.
///
/// Slivers ([`is_sliver`](crate::is_sliver): triangles whose vertices lie within a few
/// roundings of a line) are written with all three positions equal to their first vertex, so
/// that no traversal ever hits them; their attributes, slot and leaf are as for any other
/// triangle (crate docs, "Slivers").
///
/// # Errors
/// [`BvhError::TriangleCountMismatch`] / [`BvhError::AttributeCountMismatch`] /
/// [`BvhError::TriangleOutsideLeaf`] if the inputs do not belong together,
/// [`BvhError::NonFiniteVertex`] / [`BvhError::NonFiniteAttribute`] for NaN or infinite data,
/// [`BvhError::TooManyTriangles`] above 2^24 triangles, [`BvhError::ObjectIdTooLarge`] for
/// object ids above 2^24, [`BvhError::TextureTooSmall`] if nodes or triangles do not fit.
pub fn encode(
    bvh: &Bvh,
    triangles: &[[[f32; 3]; 3]],
    attributes: &[TriangleAttributes],
    options: &EncodeOptions,
) -> Result<EncodedScene, BvhError> {
    if triangles.len() != bvh.triangle_count() {
        return Err(BvhError::TriangleCountMismatch {
            bvh: bvh.triangle_count(),
            given: triangles.len(),
        });
    }
    if attributes.len() != triangles.len() {
        return Err(BvhError::AttributeCountMismatch {
            triangles: triangles.len(),
            attributes: attributes.len(),
        });
    }
    check_triangle_capacity(triangles.len())?;
    for (i, (tri, attr)) in triangles.iter().zip(attributes).enumerate() {
        check_finite_vertices(i, tri)?;
        let finite = attr.normals.iter().flatten().all(|c| c.is_finite())
            && attr.uvs.iter().flatten().all(|c| c.is_finite());
        if !finite {
            return Err(BvhError::NonFiniteAttribute { triangle: i });
        }
        if attr.object > MAX_EXACT_INTEGER {
            return Err(BvhError::ObjectIdTooLarge {
                triangle: i,
                object: attr.object,
                max: MAX_EXACT_INTEGER,
            });
        }
    }
    let nodes = bvh.nodes();
    let order = bvh.triangle_order();
    let node_size = texture_size("nodes", nodes.len(), options.max_texture_size)?;
    let tri_size = texture_size("triangles", triangles.len(), options.max_texture_size)?;

    // Every triangle must lie in its leaf's box: the BVH belongs to these triangles.
    for node in nodes {
        if let NodeKind::Leaf { first, count } = node.kind {
            for slot in first..first + count {
                let input = order[slot as usize] as usize;
                let inside = triangles[input]
                    .iter()
                    .all(|p| (0..3).all(|a| node.min[a] <= p[a] && p[a] <= node.max[a]));
                if !inside {
                    return Err(BvhError::TriangleOutsideLeaf { triangle: input });
                }
            }
        }
    }

    let node_layer = (node_size[0] * node_size[1]) as usize * FLOATS_PER_TEXEL;
    let coord = |i: Option<u32>| -> [f32; 2] {
        match i {
            Some(i) => [(i % node_size[0]) as f32, (i / node_size[0]) as f32],
            None => [layout::END_LINK, layout::END_LINK],
        }
    };
    let write_links = |out: &mut [f32], links: &[Link]| {
        for (i, link) in links.iter().enumerate() {
            let [hx, hy] = coord(link.hit);
            let [mx, my] = coord(link.miss);
            out[i * FLOATS_PER_TEXEL..(i + 1) * FLOATS_PER_TEXEL]
                .copy_from_slice(&[hx, hy, mx, my]);
        }
    };
    let mut links = vec![0.0f32; node_layer * layout::LINK_LAYERS as usize];
    for (d, layer) in links.chunks_exact_mut(node_layer).enumerate() {
        let direction = d as u32;
        write_links(
            layer,
            &bvh.threaded_links(ChildOrder::NearFirst { direction }),
        );
    }
    let mut tbvh_links = vec![0.0f32; node_layer * layout::TBVH_LINK_LAYERS as usize];
    write_links(&mut tbvh_links, &bvh.threaded_links(ChildOrder::Canonical));

    let mut bounds = vec![0.0f32; node_layer * layout::BOUNDS_LAYERS as usize];
    let (min_layer, max_layer) = bounds.split_at_mut(node_layer);
    // First triangle of each subtree: pre-order, so a node's first leaf comes after it.
    let mut subtree_first = vec![0u32; nodes.len()];
    for (i, node) in nodes.iter().enumerate().rev() {
        subtree_first[i] = match node.kind {
            NodeKind::Leaf { first, .. } => first,
            NodeKind::Inner { left, .. } => subtree_first[left as usize],
        };
    }
    for (i, node) in nodes.iter().enumerate() {
        let (first, end) = match node.kind {
            NodeKind::Leaf { first, count } => (first, first + count),
            NodeKind::Inner { .. } => (subtree_first[i], subtree_first[i]),
        };
        let t = i * FLOATS_PER_TEXEL;
        min_layer[t..t + 4].copy_from_slice(&[node.min[0], node.min[1], node.min[2], first as f32]);
        max_layer[t..t + 4].copy_from_slice(&[node.max[0], node.max[1], node.max[2], end as f32]);
    }

    let tri_layer = (tri_size[0] * tri_size[1]) as usize * FLOATS_PER_TEXEL;
    let mut tri_data = vec![0.0f32; tri_layer * layout::TRIANGLE_LAYERS as usize];
    for (slot, &input) in order.iter().enumerate() {
        let p = &triangles[input as usize];
        let a = &attributes[input as usize];
        let mut put = |layer: u32, texel: [f32; 4]| {
            let at = layer as usize * tri_layer + slot * FLOATS_PER_TEXEL;
            tri_data[at..at + 4].copy_from_slice(&texel);
        };
        // A sliver is collapsed to its first vertex, so that no traversal ever hits it.
        let p = if is_sliver(p) { &[p[0]; 3] } else { p };
        put(layout::TRI_P0_LAYER, [p[0][0], p[0][1], p[0][2], 0.0]);
        put(layout::TRI_P1_LAYER, [p[1][0], p[1][1], p[1][2], 0.0]);
        put(layout::TRI_P2_LAYER, [p[2][0], p[2][1], p[2][2], 0.0]);
        let n = &a.normals;
        put(layout::TRI_N0_LAYER, [n[0][0], n[0][1], n[0][2], 0.0]);
        put(layout::TRI_N1_LAYER, [n[1][0], n[1][1], n[1][2], 0.0]);
        put(layout::TRI_N2_LAYER, [n[2][0], n[2][1], n[2][2], 0.0]);
        let uv = &a.uvs;
        put(
            layout::TRI_UV01_LAYER,
            [uv[0][0], uv[0][1], uv[1][0], uv[1][1]],
        );
        put(
            layout::TRI_UV2_OBJECT_LAYER,
            [uv[2][0], uv[2][1], a.object as f32, 0.0],
        );
    }

    Ok(EncodedScene {
        node_size,
        node_count: nodes.len() as u32,
        links,
        tbvh_links,
        bounds,
        tri_size,
        triangles: tri_data,
        triangle_count: triangles.len() as u32,
        triangle_order: order.to_vec(),
    })
}

/// Fails with [`BvhError::TooManyTriangles`] if `count` triangle indices (and the end index
/// `count`) cannot all be stored exactly in `f32`, i.e. if `count > 2^24`.
pub(crate) fn check_triangle_capacity(count: usize) -> Result<(), BvhError> {
    if count > MAX_EXACT_INTEGER as usize {
        return Err(BvhError::TooManyTriangles {
            count,
            max: MAX_EXACT_INTEGER as usize,
        });
    }
    Ok(())
}

/// GLSL `texelFetch(tex, ivec3(coord, layer), 0)` on a `size`-sized texture array stored as in
/// [`layout`]: out-of-range coordinates read `vec4(0)`.
pub(crate) fn texel_fetch(tex: &[f32], size: TextureSize, coord: [i32; 2], layer: u32) -> [f32; 4] {
    let [w, h] = [size[0] as usize, size[1] as usize];
    let (Ok(x), Ok(y)) = (usize::try_from(coord[0]), usize::try_from(coord[1])) else {
        return [0.0; 4];
    };
    if x >= w || y >= h {
        return [0.0; 4];
    }
    let at = ((layer as usize)
        .checked_mul(h)
        .and_then(|v| v.checked_add(y))
        .and_then(|v| v.checked_mul(w))
        .and_then(|v| v.checked_add(x))
        .and_then(|v| v.checked_mul(FLOATS_PER_TEXEL)))
    .unwrap_or(usize::MAX);
    match tex.get(at..at.saturating_add(FLOATS_PER_TEXEL)) {
        Some(&[a, b, c, d]) => [a, b, c, d],
        _ => [0.0; 4],
    }
}

impl EncodedScene {
    /// Texel coordinate of node or triangle index `i` in a texture of the given size
    /// (`ivec2(i % w, i / w)`).
    pub fn coord_of(i: u32, size: TextureSize) -> [i32; 2] {
        let w = size[0].max(1);
        [(i % w) as i32, (i / w) as i32]
    }

    /// Reads node `i` back from the bounds texture.
    pub fn node(&self, i: u32) -> EncodedNode {
        let c = Self::coord_of(i, self.node_size);
        let lo = texel_fetch(&self.bounds, self.node_size, c, layout::BOUNDS_MIN_LAYER);
        let hi = texel_fetch(&self.bounds, self.node_size, c, layout::BOUNDS_MAX_LAYER);
        EncodedNode {
            min: [lo[0], lo[1], lo[2]],
            max: [hi[0], hi[1], hi[2]],
            first_tri: lo[3] as u32,
            end_tri: hi[3] as u32,
        }
    }

    /// Reads node `i`'s links back: `None` for the TBVH texture, `Some(d)` for MTBVH layer `d`.
    /// Link targets are decoded to node indices (`None` = end).
    pub fn link(&self, i: u32, mtbvh_layer: Option<u32>) -> Link {
        let c = Self::coord_of(i, self.node_size);
        let texel = match mtbvh_layer {
            None => texel_fetch(&self.tbvh_links, self.node_size, c, 0),
            Some(d) => texel_fetch(&self.links, self.node_size, c, d),
        };
        // Saturating casts and checked arithmetic: corrupt texels decode to `None`, never panic.
        let decode = |x: f32, y: f32| {
            if x >= 0.0 && y >= 0.0 {
                (y as u32)
                    .checked_mul(self.node_size[0])
                    .and_then(|v| v.checked_add(x as u32))
            } else {
                None
            }
        };
        Link {
            hit: decode(texel[0], texel[1]),
            miss: decode(texel[2], texel[3]),
        }
    }

    /// Reads encoded triangle `t`'s vertex positions back, as the traversal does (a sliver's
    /// are its first vertex three times, see [`encode`]).
    pub fn triangle_positions(&self, t: u32) -> [[f32; 3]; 3] {
        let c = Self::coord_of(t, self.tri_size);
        [
            layout::TRI_P0_LAYER,
            layout::TRI_P1_LAYER,
            layout::TRI_P2_LAYER,
        ]
        .map(|l| {
            let v = texel_fetch(&self.triangles, self.tri_size, c, l);
            [v[0], v[1], v[2]]
        })
    }

    /// Reads encoded triangle `t`'s attributes back from the data texture, as a shader would.
    pub fn triangle_attributes(&self, t: u32) -> TriangleAttributes {
        let c = Self::coord_of(t, self.tri_size);
        let fetch = |l| texel_fetch(&self.triangles, self.tri_size, c, l);
        let normals = [
            layout::TRI_N0_LAYER,
            layout::TRI_N1_LAYER,
            layout::TRI_N2_LAYER,
        ]
        .map(|l| {
            let v = fetch(l);
            [v[0], v[1], v[2]]
        });
        let uv01 = fetch(layout::TRI_UV01_LAYER);
        let uv2 = fetch(layout::TRI_UV2_OBJECT_LAYER);
        TriangleAttributes {
            normals,
            uvs: [[uv01[0], uv01[1]], [uv01[2], uv01[3]], [uv2[0], uv2[1]]],
            object: uv2[2] as u32,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texture_size_is_near_square_and_bounded() {
        assert_eq!(texture_size("n", 0, 2048), Ok([1, 1]));
        assert_eq!(texture_size("n", 1, 2048), Ok([1, 1]));
        assert_eq!(texture_size("n", 2, 2048), Ok([2, 1]));
        assert_eq!(texture_size("n", 5, 2048), Ok([3, 2]));
        assert_eq!(texture_size("n", 9, 2048), Ok([3, 3]));
        assert_eq!(texture_size("n", 10, 2048), Ok([4, 3]));
        // Capacity boundary: 4×4 = 16 texels.
        assert_eq!(texture_size("n", 16, 4), Ok([4, 4]));
        assert!(matches!(
            texture_size("n", 17, 4),
            Err(BvhError::TextureTooSmall {
                count: 17,
                max_size: 4,
                ..
            })
        ));
        assert_eq!(texture_size("n", 2048 * 2048, 2048), Ok([2048, 2048]));
        assert!(texture_size("n", 2048 * 2048 + 1, 2048).is_err());
        assert_eq!(texture_size("n", 25, 5), Ok([5, 5]));
        assert!(texture_size("n", 26, 5).is_err());
        assert!(texture_size("n", 1, 0).is_err());
        for count in 1..2000usize {
            let [w, h] = texture_size("n", count, 16384).unwrap_or([0, 0]);
            assert!((w * h) as usize >= count && ((w * (h - 1)) as usize) < count);
        }
    }

    #[test]
    fn triangle_capacity_boundary_is_two_to_the_24() {
        assert_eq!(check_triangle_capacity(1 << 24), Ok(()));
        assert_eq!(
            check_triangle_capacity((1 << 24) + 1),
            Err(BvhError::TooManyTriangles {
                count: (1 << 24) + 1,
                max: 1 << 24
            })
        );
        // The largest end index stored is exactly representable.
        assert_eq!((1u32 << 24) as f32 as u32, 1 << 24);
    }

    #[test]
    fn texel_fetch_out_of_range_reads_zero() {
        let tex: Vec<f32> = (0..2 * 3 * 2 * 4).map(|i| i as f32).collect();
        let size = [2, 3];
        assert_eq!(
            texel_fetch(&tex, size, [1, 2,], 1),
            [44.0, 45.0, 46.0, 47.0]
        );
        assert_eq!(texel_fetch(&tex, size, [0, 0], 0), [0.0, 1.0, 2.0, 3.0]);
        assert_eq!(texel_fetch(&tex, size, [2, 0], 0), [0.0; 4]);
        assert_eq!(texel_fetch(&tex, size, [-1, 0], 0), [0.0; 4]);
        assert_eq!(texel_fetch(&tex, size, [0, 0], 2), [0.0; 4]);
        assert_eq!(
            texel_fetch(&tex, [u32::MAX, u32::MAX], [5, 5], u32::MAX),
            [0.0; 4]
        );
    }
}
