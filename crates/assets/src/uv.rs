//! Light-map UVs: checking a model's own set and generating one when it has none.
//!
//! # Checking ([`check`])
//! A light-map UV set is usable when every UV is finite and inside [0, 1]², no two triangles
//! overlap in UV space (interiors; shared edges and corners are fine), and no *chart* (triangles
//! connected through shared vertex indices) with surface area has zero UV area. Overlaps are
//! found with a uniform grid and a separating-axis test: triangles whose interiors overlap by
//! more than a tolerance (in UV units) are rejected, so charts that merely touch are accepted.
//! The importers use [`texel_tolerance`], a quarter texel at the bake's density: real assets'
//! second UV sets (SheenChair's, for one) have folds and overlaps of a fraction of a texel
//! that cannot make two triangles own the same texel; anything larger is rejected.
//!
//! # Generating ([`unwrap`]) — our own chart unwrapper and packer
//! 1. Triangles are welded by exact position and grouped into charts by flood fill over shared
//!    edges: a triangle joins the chart when its normal is within [`CHART_ANGLE_DEG`] of the
//!    chart's seed normal (seeds: the largest unassigned triangle first).
//! 2. Each chart is projected onto the plane perpendicular to its seed normal at metric scale
//!    (1 UV unit = 1 m of surface, after the object's scale), so every triangle of the chart
//!    faces the same side of the plane and the projection keeps its orientation. A chart whose
//!    projection still overlaps itself is split into single triangles.
//! 3. Each chart is turned to its minimum-area bounding rectangle (rotating calipers on the
//!    convex hull), laid with its long side horizontal, and the rectangles are packed with a
//!    shelf packer (tallest first), `padding` metres apart and `padding / 2` from the border.
//! 4. The atlas rectangle is mapped onto [0, 1]² with u and v scaled separately, so one metre
//!    of surface spans the same number of texels along u and v once `luxbake`'s layout sizes
//!    the map from the UV-to-surface ratio. Vertices are split where charts meet.
//!
//! `padding = padding_texels / texels_per_metre` ([`UnwrapOptions`]); [`padding_texels`] sizes
//! it for the blur radius. Triangles of zero area get a zero-area UV triangle inside the
//! first chart (they cover no texel).

use std::collections::HashMap;

use glam::{DMat2, DVec2, DVec3, Vec2, Vec3};
use luxbake::scene::Blur;

/// Largest angle between a triangle's normal and its chart's seed normal, degrees.
pub const CHART_ANGLE_DEG: f64 = 40.0;
/// Tolerance of the overlap test, UV units: triangles overlapping by less are "touching".
pub const OVERLAP_TOLERANCE: f64 = 1e-6;

/// Why a light-map UV set was rejected.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum UvIssue {
    /// Fewer UVs than positions.
    Missing,
    /// A UV is not finite or lies outside [0, 1]².
    OutOfRange {
        /// The vertex.
        vertex: usize,
        /// Its UV.
        uv: [f32; 2],
    },
    /// Two triangles overlap in UV space.
    Overlap {
        /// First triangle.
        a: usize,
        /// Second triangle.
        b: usize,
    },
    /// A chart with surface area has no UV area (it would get no texels).
    ZeroAreaChart {
        /// One triangle of the chart.
        triangle: usize,
    },
}

impl std::fmt::Display for UvIssue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            UvIssue::Missing => f.write_str("fewer UVs than positions"),
            UvIssue::OutOfRange { vertex, uv } => {
                write!(f, "UV {uv:?} of vertex {vertex} is outside [0, 1]²")
            }
            UvIssue::Overlap { a, b } => write!(f, "triangles {a} and {b} overlap in UV space"),
            UvIssue::ZeroAreaChart { triangle } => {
                write!(f, "the chart of triangle {triangle} has no UV area")
            }
        }
    }
}

/// Options of [`unwrap`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnwrapOptions {
    /// Light-map density the padding is sized for, texels per metre of (scaled) surface.
    pub texels_per_metre: f32,
    /// Empty texels between two charts at that density.
    pub padding_texels: f32,
    /// Per-axis scale applied to the positions before measuring (the object's scale).
    pub scale: [f32; 3],
}

/// Chart padding for a blur, texels: the rule of the built-in meshes,
/// [`luxbake::layout::chart_padding_texels`] (`max(4, 2 + ⌈3σ⌉)`: the paper blur's reach plus
/// one texel each side for conservative rasterisation, at least 4).
pub fn padding_texels(blur: Blur) -> f32 {
    luxbake::layout::chart_padding_texels(blur)
}

/// The result of [`unwrap`]: a re-indexed mesh (vertices split along chart seams).
#[derive(Debug, Clone, PartialEq)]
pub struct Unwrapped {
    /// For each new vertex, the index of the input vertex it copies.
    pub source_vertex: Vec<u32>,
    /// Light-map UV per new vertex.
    pub uvs: Vec<[f32; 2]>,
    /// Triangles over the new vertices, same order as the input.
    pub indices: Vec<[u32; 3]>,
    /// Number of charts.
    pub charts: usize,
    /// Atlas size in metres (u, v): one UV unit spans this much surface.
    pub extent_m: [f64; 2],
}

/// Twice the signed area of the triangle `o a b` (positive when counter-clockwise).
fn cross2(o: DVec2, a: DVec2, b: DVec2) -> f64 {
    (a - o).perp_dot(b - o)
}

/// Twice the signed UV area of a triangle.
fn area2(t: &[DVec2; 3]) -> f64 {
    cross2(t[0], t[1], t[2])
}

/// Whether two triangles' interiors overlap by more than `tol` along every separating axis.
fn triangles_overlap(a: &[DVec2; 3], b: &[DVec2; 3], tol: f64) -> bool {
    for tri in [a, b] {
        for i in 0..3 {
            let p = tri[i];
            let q = tri[(i + 1) % 3];
            let axis = (p - q).perp();
            let len = axis.length();
            if len == 0.0 {
                continue;
            }
            let proj = |t: &[DVec2; 3]| {
                let v = t.map(|p| p.dot(axis) / len);
                (v[0].min(v[1]).min(v[2]), v[0].max(v[1]).max(v[2]))
            };
            let (a0, a1) = proj(a);
            let (b0, b1) = proj(b);
            if a1.min(b1) - a0.max(b0) <= tol {
                return false;
            }
        }
    }
    true
}

fn seg_point_dist(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let ab = b - a;
    let ap = p - a;
    let l2 = ab.length_squared();
    let t = if l2 > 0.0 {
        (ap.dot(ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (ap - ab * t).length()
}

/// Euclidean distance between two triangles (0 when they overlap or touch).
fn triangle_distance(a: &[DVec2; 3], b: &[DVec2; 3]) -> f64 {
    if triangles_overlap(a, b, -1e-12) {
        return 0.0;
    }
    let mut d = f64::INFINITY;
    for (s, t) in [(a, b), (b, a)] {
        for p in s {
            for i in 0..3 {
                d = d.min(seg_point_dist(*p, t[i], t[(i + 1) % 3]));
            }
        }
    }
    d
}

/// A uniform grid over the UV bounding box of some triangles, for pair queries.
struct Grid {
    origin: DVec2,
    cell: f64,
    dims: [usize; 2],
    cells: HashMap<(usize, usize), Vec<u32>>,
}

impl Grid {
    /// Bins triangles (by bounding box grown by `margin`) into about `tris.len()` cells.
    fn new(tris: &[[DVec2; 3]], margin: f64) -> Grid {
        let mut lo = DVec2::INFINITY;
        let mut hi = DVec2::NEG_INFINITY;
        for t in tris {
            for p in t {
                for k in 0..2 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
        if !(lo.is_finite() && hi.is_finite()) {
            lo = DVec2::ZERO;
            hi = DVec2::ONE;
        }
        let size = (hi - lo).map(|d| d.max(1e-12));
        let n = (tris.len() as f64).max(1.0);
        let cell = ((size.x * size.y / n).sqrt())
            .max(margin)
            .max(size.x.max(size.y) / 2048.0);
        let dims = [
            ((size.x / cell).ceil() as usize).clamp(1, 4096),
            ((size.y / cell).ceil() as usize).clamp(1, 4096),
        ];
        let mut grid = Grid {
            origin: lo,
            cell,
            dims,
            cells: HashMap::new(),
        };
        for (i, t) in tris.iter().enumerate() {
            let (c0, c1) = grid.range(t, margin);
            for y in c0[1]..=c1[1] {
                for x in c0[0]..=c1[0] {
                    grid.cells.entry((x, y)).or_default().push(i as u32);
                }
            }
        }
        grid
    }

    fn cell_of(&self, p: DVec2) -> [usize; 2] {
        std::array::from_fn(|k| {
            let c = ((p[k] - self.origin[k]) / self.cell).floor();
            if c.is_finite() {
                (c.max(0.0) as usize).min(self.dims[k] - 1)
            } else {
                0
            }
        })
    }

    fn range(&self, t: &[DVec2; 3], margin: f64) -> ([usize; 2], [usize; 2]) {
        let lo = DVec2::new(
            t[0].x.min(t[1].x).min(t[2].x),
            t[0].y.min(t[1].y).min(t[2].y),
        ) - margin;
        let hi = DVec2::new(
            t[0].x.max(t[1].x).max(t[2].x),
            t[0].y.max(t[1].y).max(t[2].y),
        ) + margin;
        (self.cell_of(lo), self.cell_of(hi))
    }

    /// Calls `f(i, j)` once for every pair `i < j` of triangles sharing a cell.
    fn pairs(&self, tris: &[[DVec2; 3]], margin: f64, mut f: impl FnMut(usize, usize) -> bool) {
        for (&(x, y), list) in &self.cells {
            for (ai, &a) in list.iter().enumerate() {
                for &b in &list[ai + 1..] {
                    let (i, j) = (a.min(b) as usize, a.max(b) as usize);
                    // Report a pair only in the first cell both ranges share.
                    let (ri0, _) = self.range(&tris[i], margin);
                    let (rj0, _) = self.range(&tris[j], margin);
                    if [ri0[0].max(rj0[0]), ri0[1].max(rj0[1])] != [x, y] {
                        continue;
                    }
                    if !f(i, j) {
                        return;
                    }
                }
            }
        }
    }
}

fn uv_tris(uvs: &[[f32; 2]], indices: &[[u32; 3]]) -> Vec<[DVec2; 3]> {
    indices
        .iter()
        .map(|t| {
            t.map(|i| {
                uvs.get(i as usize)
                    .map_or(DVec2::ZERO, |&uv| Vec2::from(uv).as_dvec2())
            })
        })
        .collect()
}

/// Charts: connected components of triangles through shared vertex indices.
pub fn charts(vertex_count: usize, indices: &[[u32; 3]]) -> Vec<u32> {
    let mut parent: Vec<u32> = (0..vertex_count as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            let up = p[p[x as usize] as usize];
            p[x as usize] = up;
            x = up;
        }
        x
    }
    for t in indices {
        if t.iter().any(|&i| i as usize >= vertex_count) {
            continue;
        }
        let a = find(&mut parent, t[0]);
        for &v in &t[1..] {
            let b = find(&mut parent, v);
            if a != b {
                parent[b as usize] = a;
            }
        }
    }
    indices
        .iter()
        .map(|t| {
            if (t[0] as usize) < vertex_count {
                find(&mut parent, t[0])
            } else {
                u32::MAX
            }
        })
        .collect()
}

/// The overlap tolerance of [`check`] for a bake at `texels_per_metre`: a quarter of a texel
/// in UV units, the texel size estimated from the surface-to-UV area ratio (as `luxbake`'s
/// layout sizes maps), at least [`OVERLAP_TOLERANCE`]. Overlaps below it cannot make two
/// triangles claim the same texel centre.
pub fn texel_tolerance(
    uvs: &[[f32; 2]],
    positions: &[[f32; 3]],
    indices: &[[u32; 3]],
    texels_per_metre: f32,
) -> f64 {
    let tris = uv_tris(uvs, indices);
    let (mut world, mut uv) = (0.0f64, 0.0f64);
    for (t, tri) in tris.iter().enumerate() {
        world += world_area2(positions, &indices[t]);
        uv += area2(tri).abs();
    }
    let side_m = (world / uv).sqrt();
    let texel = 1.0 / (side_m * f64::from(texels_per_metre));
    if texel.is_finite() && texel > 0.0 {
        (0.25 * texel).max(OVERLAP_TOLERANCE)
    } else {
        OVERLAP_TOLERANCE
    }
}

/// Twice the world area of a triangle (0 for out-of-range indices).
fn world_area2(positions: &[[f32; 3]], t: &[u32; 3]) -> f64 {
    let p = t.map(|i| {
        positions
            .get(i as usize)
            .map_or(DVec3::ZERO, |&p| Vec3::from(p).as_dvec3())
    });
    (p[1] - p[0]).cross(p[2] - p[0]).length()
}

/// Checks a light-map UV set (see the module docs); `positions` measure surface area;
/// overlaps up to `tolerance` (UV units, see [`texel_tolerance`]) are accepted.
pub fn check(
    uvs: &[[f32; 2]],
    positions: &[[f32; 3]],
    indices: &[[u32; 3]],
    tolerance: f64,
) -> Result<(), UvIssue> {
    if uvs.len() < positions.len() {
        return Err(UvIssue::Missing);
    }
    for (vertex, uv) in uvs.iter().enumerate() {
        if !uv.iter().all(|c| c.is_finite() && (0.0..=1.0).contains(c)) {
            return Err(UvIssue::OutOfRange { vertex, uv: *uv });
        }
    }
    let tris = uv_tris(uvs, indices);
    // Zero-area charts.
    let chart = charts(uvs.len(), indices);
    let mut sums: HashMap<u32, (f64, f64, usize)> = HashMap::new();
    for (t, (tri, &c)) in tris.iter().zip(&chart).enumerate() {
        let world = world_area2(positions, &indices[t]);
        let e = sums.entry(c).or_insert((0.0, 0.0, t));
        e.0 += world;
        e.1 += area2(tri).abs();
    }
    let mut zero: Vec<usize> = sums
        .values()
        .filter(|(w, a, _)| *w > 0.0 && *a <= 1e-14)
        .map(|s| s.2)
        .collect();
    zero.sort_unstable();
    if let Some(&triangle) = zero.first() {
        return Err(UvIssue::ZeroAreaChart { triangle });
    }
    // Overlaps.
    let live: Vec<usize> = (0..tris.len())
        .filter(|&t| area2(&tris[t]).abs() > 1e-14)
        .collect();
    let sub: Vec<[DVec2; 3]> = live.iter().map(|&t| tris[t]).collect();
    let grid = Grid::new(&sub, 0.0);
    let mut found = None;
    grid.pairs(&sub, 0.0, |i, j| {
        if triangles_overlap(&sub[i], &sub[j], tolerance.max(OVERLAP_TOLERANCE)) {
            found = Some((live[i], live[j]));
            false
        } else {
            true
        }
    });
    match found {
        Some((a, b)) => Err(UvIssue::Overlap {
            a: a.min(b),
            b: a.max(b),
        }),
        None => Ok(()),
    }
}

/// Smallest UV-space distance between triangles of different charts, if there are two
/// charts closer than `limit`; `None` when every gap is at least `limit`. Charts here are
/// triangles connected through shared vertex indices or bit-identical UVs (vertices split
/// for normals or materials inside one chart keep their UV).
pub fn min_chart_gap(uvs: &[[f32; 2]], indices: &[[u32; 3]], limit: f64) -> Option<f64> {
    let tris = uv_tris(uvs, indices);
    let mut weld: HashMap<[u32; 2], u32> = HashMap::new();
    let canon: Vec<u32> = uvs
        .iter()
        .enumerate()
        .map(|(i, uv)| *weld.entry(uv.map(f32::to_bits)).or_insert(i as u32))
        .collect();
    let welded: Vec<[u32; 3]> = indices
        .iter()
        .map(|t| t.map(|i| canon.get(i as usize).copied().unwrap_or(i)))
        .collect();
    let chart = charts(uvs.len(), &welded);
    let live: Vec<usize> = (0..tris.len())
        .filter(|&t| area2(&tris[t]).abs() > 1e-14)
        .collect();
    let sub: Vec<[DVec2; 3]> = live.iter().map(|&t| tris[t]).collect();
    let grid = Grid::new(&sub, limit);
    let mut best: Option<f64> = None;
    grid.pairs(&sub, limit, |i, j| {
        if chart[live[i]] != chart[live[j]] {
            let d = triangle_distance(&sub[i], &sub[j]);
            if d < limit && best.is_none_or(|b| d < b) {
                best = Some(d);
            }
        }
        true
    });
    best
}

/// Generates light-map UVs for a triangle mesh (see the module docs).
pub fn unwrap(positions: &[[f32; 3]], indices: &[[u32; 3]], options: &UnwrapOptions) -> Unwrapped {
    let scale = Vec3::from(options.scale)
        .as_dvec3()
        .map(|s| if s.is_finite() { s.abs() } else { 1.0 });
    let pos: Vec<DVec3> = positions
        .iter()
        .map(|&p| Vec3::from(p).as_dvec3() * scale)
        .collect();
    let density = f64::from(options.texels_per_metre);
    let pad = if density.is_finite() && density > 0.0 {
        (f64::from(options.padding_texels).max(0.0) / density).max(0.0)
    } else {
        0.0
    };
    let corner = |t: usize, k: usize| -> DVec3 {
        pos.get(indices[t][k] as usize)
            .copied()
            .unwrap_or(DVec3::ZERO)
    };
    // Face normals and areas.
    let nf = indices.len();
    let mut normal = vec![DVec3::ZERO; nf];
    let mut area = vec![0.0f64; nf];
    for t in 0..nf {
        let c = (corner(t, 1) - corner(t, 0)).cross(corner(t, 2) - corner(t, 0));
        let l = c.length();
        if l.is_finite() && l > 0.0 {
            normal[t] = c / l;
            area[t] = l / 2.0;
        }
    }
    let max_area = area.iter().copied().fold(0.0, f64::max);
    let degenerate = |t: usize| area[t] <= max_area * 1e-14 || area[t] == 0.0;
    // Adjacency over welded positions.
    let mut weld: HashMap<[u64; 3], u32> = HashMap::new();
    let welded: Vec<u32> = positions
        .iter()
        .map(|p| {
            let key = p.map(|c| u64::from((c + 0.0).to_bits()));
            let n = weld.len() as u32;
            *weld.entry(key).or_insert(n)
        })
        .collect();
    let wv = |t: usize, k: usize| {
        welded
            .get(indices[t][k] as usize)
            .copied()
            .unwrap_or(u32::MAX)
    };
    let mut edges: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for t in 0..nf {
        if degenerate(t) {
            continue;
        }
        for k in 0..3 {
            let (a, b) = (wv(t, k), wv(t, (k + 1) % 3));
            edges
                .entry((a.min(b), a.max(b)))
                .or_default()
                .push(t as u32);
        }
    }
    // Flood fill, largest seeds first.
    let cos_max = CHART_ANGLE_DEG.to_radians().cos();
    let mut order: Vec<usize> = (0..nf).filter(|&t| !degenerate(t)).collect();
    order.sort_by(|&a, &b| area[b].total_cmp(&area[a]).then(a.cmp(&b)));
    let mut chart_of = vec![u32::MAX; nf];
    let mut charts: Vec<(DVec3, Vec<usize>)> = Vec::new();
    for &seed in &order {
        if chart_of[seed] != u32::MAX {
            continue;
        }
        let id = charts.len() as u32;
        let n = normal[seed];
        let mut faces = vec![seed];
        chart_of[seed] = id;
        let mut head = 0;
        while head < faces.len() {
            let t = faces[head];
            head += 1;
            for k in 0..3 {
                let (a, b) = (wv(t, k), wv(t, (k + 1) % 3));
                if let Some(list) = edges.get(&(a.min(b), a.max(b))) {
                    for &u in list {
                        let u = u as usize;
                        if chart_of[u] == u32::MAX && normal[u].dot(n) >= cos_max {
                            chart_of[u] = id;
                            faces.push(u);
                        }
                    }
                }
            }
        }
        charts.push((n, faces));
    }
    // Project each chart; split self-overlapping charts into single triangles.
    let mut flat: Vec<(Vec<usize>, Vec<[DVec2; 3]>)> = Vec::new();
    for (n, faces) in charts {
        let (tan, bit) = basis(n);
        let proj: Vec<[DVec2; 3]> = faces
            .iter()
            .map(|&t| {
                std::array::from_fn(|k| {
                    let p = corner(t, k);
                    DVec2::new(p.dot(tan), p.dot(bit))
                })
            })
            .collect();
        let mut overlapping = false;
        if proj.len() > 1 {
            let grid = Grid::new(&proj, 0.0);
            grid.pairs(&proj, 0.0, |i, j| {
                // Tolerance relative to the chart's size.
                if triangles_overlap(&proj[i], &proj[j], 1e-9 * (1.0 + pad)) {
                    overlapping = true;
                    false
                } else {
                    true
                }
            });
        }
        if overlapping {
            for (t, p) in faces.into_iter().zip(proj) {
                flat.push((vec![t], vec![p]));
            }
        } else {
            flat.push((faces, proj));
        }
    }
    // Minimum-area rectangles, long side horizontal, origin at 0.
    let mut rects: Vec<DVec2> = Vec::with_capacity(flat.len());
    for (_, tris) in &mut flat {
        let pts: Vec<DVec2> = tris.iter().flatten().copied().collect();
        let rot = rotation(min_area_angle(&pts));
        let mut lo = DVec2::INFINITY;
        let mut hi = DVec2::NEG_INFINITY;
        for t in tris.iter_mut() {
            for p in t.iter_mut() {
                *p = rot * *p;
                for k in 0..2 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
        let mut size = (hi - lo).map(|d| d.max(0.0));
        let swap = size.y > size.x;
        for t in tris.iter_mut() {
            for p in t.iter_mut() {
                let q = *p - lo;
                *p = if swap { DVec2::new(q.y, q.x) } else { q };
            }
        }
        if swap {
            size = DVec2::new(size.y, size.x);
        }
        rects.push(size);
    }
    // Shelf packing, tallest first.
    let slot = |r: DVec2| r + pad;
    let total: f64 = rects.iter().map(|&r| slot(r).element_product()).sum();
    let widest = rects.iter().map(|&r| slot(r).x).fold(0.0, f64::max);
    let width = widest.max(total.sqrt() * 1.1).max(1e-9);
    let mut by_height: Vec<usize> = (0..rects.len()).collect();
    by_height.sort_by(|&a, &b| rects[b].y.total_cmp(&rects[a].y).then(a.cmp(&b)));
    let mut offsets = vec![DVec2::ZERO; rects.len()];
    let (mut x, mut y, mut shelf_h, mut used_w) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for &i in &by_height {
        let s = slot(rects[i]);
        if x > 0.0 && x + s.x > width {
            y += shelf_h;
            x = 0.0;
            shelf_h = 0.0;
        }
        offsets[i] = DVec2::new(x, y) + pad / 2.0;
        x += s.x;
        used_w = used_w.max(x);
        shelf_h = shelf_h.max(s.y);
    }
    let extent = DVec2::new(used_w.max(1e-9), (y + shelf_h).max(1e-9));
    // Emit split vertices.
    let mut out = Unwrapped {
        source_vertex: Vec::new(),
        uvs: Vec::new(),
        indices: vec![[0; 3]; nf],
        charts: flat.len(),
        extent_m: extent.to_array(),
    };
    let mut remap: HashMap<(u32, u32), u32> = HashMap::new();
    let to_uv = |p: DVec2, o: DVec2| -> [f32; 2] {
        ((p + o) / extent)
            .map(|c| c.clamp(0.0, 1.0))
            .as_vec2()
            .to_array()
    };
    let mut first_uv = None;
    for (c, (faces, tris)) in flat.iter().enumerate() {
        for (&t, tri) in faces.iter().zip(tris) {
            for k in 0..3 {
                let src = indices[t][k];
                let uv = to_uv(tri[k], offsets[c]);
                first_uv.get_or_insert(uv);
                let next = out.source_vertex.len() as u32;
                let id = *remap.entry((src, c as u32)).or_insert_with(|| {
                    out.source_vertex.push(src);
                    out.uvs.push(uv);
                    next
                });
                out.indices[t][k] = id;
            }
        }
    }
    // Degenerate triangles: a zero-area UV triangle at one point of the first chart.
    let parked = first_uv.unwrap_or([0.5, 0.5]);
    for t in 0..nf {
        if chart_of[t] == u32::MAX {
            for (k, &src) in indices[t].iter().enumerate() {
                let next = out.source_vertex.len() as u32;
                let id = *remap.entry((src, u32::MAX)).or_insert_with(|| {
                    out.source_vertex.push(src);
                    out.uvs.push(parked);
                    next
                });
                out.indices[t][k] = id;
            }
        }
    }
    out
}

/// An orthonormal tangent basis of the plane perpendicular to `n`.
fn basis(n: DVec3) -> (DVec3, DVec3) {
    let a = if n.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    let t = a.cross(n);
    let l = t.length();
    let t = if l > 0.0 { t / l } else { DVec3::X };
    (t, n.cross(t))
}

/// The rotation by `-angle` radians: it turns the direction at `angle` onto +x.
fn rotation(angle: f64) -> DMat2 {
    let (s, c) = angle.sin_cos();
    DMat2::from_cols(DVec2::new(c, -s), DVec2::new(s, c))
}

/// The rotation (radians) that gives the points' minimum-area bounding rectangle, found by
/// rotating calipers over the convex hull's edges.
fn min_area_angle(points: &[DVec2]) -> f64 {
    let hull = convex_hull(points);
    if hull.len() < 3 {
        return 0.0;
    }
    let mut best = (f64::INFINITY, 0.0);
    for i in 0..hull.len() {
        let p = hull[i];
        let q = hull[(i + 1) % hull.len()];
        let d = q - p;
        let angle = d.y.atan2(d.x);
        let rot = rotation(angle);
        let mut lo = DVec2::INFINITY;
        let mut hi = DVec2::NEG_INFINITY;
        for &h in &hull {
            let r = rot * h;
            for k in 0..2 {
                lo[k] = lo[k].min(r[k]);
                hi[k] = hi[k].max(r[k]);
            }
        }
        let a = (hi - lo).element_product();
        if a < best.0 {
            best = (a, angle);
        }
    }
    best.1
}

/// Andrew's monotone chain; counter-clockwise, no collinear points.
fn convex_hull(points: &[DVec2]) -> Vec<DVec2> {
    let mut p: Vec<DVec2> = points.iter().copied().filter(|q| q.is_finite()).collect();
    p.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let mut hull: Vec<DVec2> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &DVec2>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for &q in iter {
            while hull.len() >= start + 2
                && cross2(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0
            {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    hull
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed unit cube with flat-shaded faces (24 vertices, 12 triangles).
    fn cube() -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        let mut p = Vec::new();
        let mut idx = Vec::new();
        for axis in 0..3 {
            for side in [0.0f32, 1.0] {
                let base = p.len() as u32;
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                for (a, b) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
                    let mut q = [0.0; 3];
                    q[axis] = side;
                    q[u] = a;
                    q[v] = b;
                    p.push(q);
                }
                if side > 0.5 {
                    idx.push([base, base + 1, base + 2]);
                    idx.push([base, base + 2, base + 3]);
                } else {
                    idx.push([base, base + 2, base + 1]);
                    idx.push([base, base + 3, base + 2]);
                }
            }
        }
        (p, idx)
    }

    #[test]
    fn overlap_test_accepts_touching_and_rejects_overlapping() {
        let [a, touching, overlapping, apart] = [
            [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
            [[1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
            [[0.4, 0.0], [1.0, 0.0], [0.4, 1.0]],
            [[2.0, 0.0], [3.0, 0.0], [2.0, 1.0]],
        ]
        .map(|t| t.map(DVec2::from));
        assert!(!triangles_overlap(&a, &touching, OVERLAP_TOLERANCE));
        assert!(triangles_overlap(&a, &overlapping, OVERLAP_TOLERANCE));
        assert!(!triangles_overlap(&a, &apart, OVERLAP_TOLERANCE));
        assert!((triangle_distance(&a, &apart) - 1.0).abs() < 1e-12);
        assert_eq!(triangle_distance(&a, &overlapping), 0.0);
    }

    #[test]
    fn check_finds_each_problem() {
        let pos = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
        ];
        let idx = vec![[0, 1, 2], [1, 3, 2]];
        let good = vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]];
        assert_eq!(check(&good, &pos, &idx, OVERLAP_TOLERANCE), Ok(()));
        let mut out = good.clone();
        out[3] = [1.5, 1.0];
        assert!(matches!(
            check(&out, &pos, &idx, OVERLAP_TOLERANCE),
            Err(UvIssue::OutOfRange { vertex: 3, .. })
        ));
        let mut nan = good.clone();
        nan[0][1] = f32::NAN;
        assert!(matches!(
            check(&nan, &pos, &idx, OVERLAP_TOLERANCE),
            Err(UvIssue::OutOfRange { vertex: 0, .. })
        ));
        // Vertex 3 folded back over the first triangle.
        let mut folded = good.clone();
        folded[3] = [0.2, 0.2];
        assert_eq!(
            check(&folded, &pos, &idx, OVERLAP_TOLERANCE),
            Err(UvIssue::Overlap { a: 0, b: 1 })
        );
        let zero = vec![[0.5, 0.5]; 4];
        assert_eq!(
            check(&zero, &pos, &idx, OVERLAP_TOLERANCE),
            Err(UvIssue::ZeroAreaChart { triangle: 0 })
        );
        assert_eq!(
            check(&good[..2], &pos, &idx, OVERLAP_TOLERANCE),
            Err(UvIssue::Missing)
        );
    }

    #[test]
    fn cube_unwraps_into_six_padded_charts() {
        let (p, idx) = cube();
        let opts = UnwrapOptions {
            texels_per_metre: 32.0,
            padding_texels: 4.0,
            scale: [2.0, 1.0, 1.0],
        };
        let u = unwrap(&p, &idx, &opts);
        assert_eq!(u.charts, 6);
        assert_eq!(u.indices.len(), 12);
        assert_eq!(u.uvs.len(), 24, "faces do not share vertices across charts");
        let pos: Vec<[f32; 3]> = u.source_vertex.iter().map(|&s| p[s as usize]).collect();
        assert_eq!(check(&u.uvs, &pos, &u.indices, OVERLAP_TOLERANCE), Ok(()));
        // Padding: 4 texels at 32 texels/m = 0.125 m; in UV units per axis.
        let pad_uv = 0.125 / u.extent_m[0].max(u.extent_m[1]);
        assert_eq!(min_chart_gap(&u.uvs, &u.indices, pad_uv * 0.999), None);
        // The area in metres is kept: 2 faces 1×1, 4 faces 2×1 (scaled along x) → 10 m².
        let uv_area: f64 = uv_tris(&u.uvs, &u.indices)
            .iter()
            .map(|t| area2(t).abs() / 2.0)
            .sum();
        let m2 = uv_area * u.extent_m[0] * u.extent_m[1];
        assert!((m2 - 10.0).abs() < 1e-4, "{m2}");
    }

    #[test]
    fn folded_strip_splits_and_degenerates_park() {
        // Two triangles on top of each other (same plane, same facing): they overlap in one
        // projection, so the chart splits; plus a degenerate triangle.
        let p = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 0.0, -1.0],
            [0.0, 0.1, 0.0],
            [1.0, 0.1, 0.0],
            [0.0, 0.1, -1.0],
            [5.0, 5.0, 5.0],
        ];
        let idx = vec![[0, 1, 2], [3, 4, 5], [6, 6, 6], [0, 1, 4]];
        let u = unwrap(
            &p,
            &idx,
            &UnwrapOptions {
                texels_per_metre: 16.0,
                padding_texels: 2.0,
                scale: [1.0; 3],
            },
        );
        let pos: Vec<[f32; 3]> = u.source_vertex.iter().map(|&s| p[s as usize]).collect();
        assert_eq!(check(&u.uvs, &pos, &u.indices, OVERLAP_TOLERANCE), Ok(()));
        assert!(u.charts >= 2);
        assert!(u.uvs.iter().flatten().all(|c| (0.0..=1.0).contains(c)));
    }

    #[test]
    fn padding_follows_the_blur() {
        assert_eq!(padding_texels(Blur::None), 4.0);
        assert_eq!(padding_texels(Blur::Sigma(2.0)), 8.0);
        assert_eq!(padding_texels(Blur::Sigma(0.4)), 4.0);
    }
}
