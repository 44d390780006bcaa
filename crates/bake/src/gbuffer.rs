//! The G-buffer: per light-map texel, the world position, normal and albedo of the surface
//! point it samples, made by rasterising every receiver's triangles in light-map UV space.
//!
//! # Decision: the G-buffer is computed on the CPU, for every backend
//! [`rasterize`] runs here, once, and every backend uploads its result. Hardware
//! rasterisation differs between drivers in exactly the places that matter (coverage of
//! texels on chart edges, conservative-raster support, f32 interpolation), and WebGL2 has no
//! conservative rasterisation at all; one CPU rasteriser keeps the backends' inputs
//! bit-identical, so backend differences are differences of the light passes only. It costs
//! tens of milliseconds for the built-in scenes (parallel over objects with rayon).
//!
//! # Layout of the data
//! Three RGBA32F texture arrays of `layers` layers of `layer_size[0] × layer_size[1]`
//! texels, row 0 first, 4 floats per texel: the float index of texel `(x, y)` of layer `l` is
//! `((l · height + y) · width + x) · 4` ([`GBuffer::index`]).
//! - `position`: world xyz in metres, w = 1 for a valid texel, 0 for an empty one; after
//!   unocclusion, w = 2 ([`crate::validity::NARROW`]) for a valid texel facing another surface
//!   a few texels away. A texel is valid where w > 0.5.
//! - `normal`: world unit normal xyz (the interpolated vertex normal; the triangle's geometric
//!   normal where that cannot be normalised), w = object index as f32.
//! - `albedo`: linear RGB in [0, 1] (factor × vertex colour × texture), w = coverage: the
//!   fraction of the texel's area inside the object's charts, estimated with 4×4 samples
//!   (for diagnostics; a valid texel may have coverage 0 when a chart only grazes it).
//!
//! Empty texels are all zeros.
//!
//! After rasterising, the bake moves texels that lie inside geometry out of it or makes them
//! empty ([`crate::validity`]), before any backend uploads the G-buffer.
//!
//! # Conservative coverage
//! Every texel that a triangle's UV footprint overlaps with positive area gets valid data,
//! not only the texels whose centre lies inside a triangle, so the light passes sample the
//! texels on chart edges that bilinear look-ups and the blur read. A texel takes its sample
//! from the triangle nearest its centre among the triangles overlapping it (distance 0 when
//! the centre is inside): the point of that triangle closest to the texel centre (clamped
//! barycentrics), nudged 0.1 % of the way toward the triangle's centroid so it lies strictly
//! inside the surface rather than on an edge that another surface shares. A centre that lies
//! on an edge itself (or nearer to it than the nudge: a texel grid aligned with a room's
//! corner) is nudged the same way: sampled on the corner line, the floor would see the wall
//! edge-on and a texel row along the corner read 25–45 % dark (issue 29's box room at 16
//! texels/m, its first bounce).
//! So an edge texel samples the surface at the chart's border, never empty space.
//!
//! Triangles with zero (or non-finite) UV area cover no texel and are skipped; triangles with
//! zero world area still give finite positions (their interpolated normal, else their first
//! vertex normal; a texel with no usable normal stays empty). Indices out of range and
//! non-finite data are skipped, never a panic.

use glam::{DVec2, DVec3, Vec2, Vec3};
use rayon::prelude::*;

use crate::exact::normalize_f64;
use crate::layout::{Layout, Region};
use crate::scene::{Object, Scene, tri_indices};

/// Fraction of the way toward the centroid that a clamped edge sample is moved.
pub const EDGE_NUDGE: f64 = 1e-3;

/// Per-texel world position, normal, albedo and validity of every light map (see the module
/// docs for the exact layout).
#[derive(Debug, Clone, PartialEq)]
pub struct GBuffer {
    /// Width and height of every layer, texels.
    pub layer_size: [u32; 2],
    /// Number of layers.
    pub layers: u32,
    /// World xyz, w = 1 for a valid texel, 0 for empty (2 for a valid texel in a narrow gap,
    /// after [`crate::validity::unocclude`]).
    pub position: Vec<f32>,
    /// World unit normal xyz, w = object index as f32.
    pub normal: Vec<f32>,
    /// Linear rgb in [0, 1], w = coverage (fraction of the texel inside the charts).
    pub albedo: Vec<f32>,
}

impl GBuffer {
    /// Float index of the first component of texel `(x, y)` of `layer`. The caller keeps the
    /// coordinates in range.
    pub fn index(&self, layer: u32, x: u32, y: u32) -> usize {
        let (w, h) = (self.layer_size[0] as usize, self.layer_size[1] as usize);
        ((layer as usize * h + y as usize) * w + x as usize) * 4
    }

    /// Floats in one layer of one of the three arrays.
    pub fn layer_len(&self) -> usize {
        self.layer_size[0] as usize * self.layer_size[1] as usize * 4
    }

    /// Whether texel `(x, y)` of `layer` samples a surface; `false` out of range.
    pub fn is_valid(&self, layer: u32, x: u32, y: u32) -> bool {
        if layer >= self.layers || x >= self.layer_size[0] || y >= self.layer_size[1] {
            return false;
        }
        self.position
            .get(self.index(layer, x, y) + 3)
            .is_some_and(|&w| w > 0.5)
    }

    /// Number of valid texels.
    pub fn valid_texels(&self) -> u64 {
        self.position.chunks_exact(4).filter(|t| t[3] > 0.5).count() as u64
    }
}

/// One texel's data: position, normal, albedo (RGBA each).
type Texel = [[f32; 4]; 3];

/// Rasterises every receiver of `scene` into its region of `layout` (which must have been
/// made for this scene: one region entry per object).
pub fn rasterize(scene: &Scene, layout: &Layout) -> GBuffer {
    let (w, h) = (layout.layer_size[0] as usize, layout.layer_size[1] as usize);
    let len = layout.layers as usize * w * h * 4;
    let mut g = GBuffer {
        layer_size: layout.layer_size,
        layers: layout.layers,
        position: vec![0.0; len],
        normal: vec![0.0; len],
        albedo: vec![0.0; len],
    };
    let jobs: Vec<(usize, &Object, Region)> = scene
        .objects
        .iter()
        .enumerate()
        .filter_map(|(i, o)| layout.regions.get(i).copied().flatten().map(|r| (i, o, r)))
        .collect();
    let maps: Vec<(Region, Vec<Option<Texel>>)> = jobs
        .par_iter()
        .map(|&(i, o, r)| (r, rasterize_object(o, i as u32, r.size)))
        .collect();
    for (r, texels) in maps {
        for (k, t) in texels.iter().enumerate() {
            let Some(t) = t else { continue };
            let (x, y) = (k % r.size[0] as usize, k / r.size[0] as usize);
            let (gx, gy) = (r.offset[0] as usize + x, r.offset[1] as usize + y);
            if r.layer >= layout.layers || gx >= w || gy >= h {
                continue;
            }
            let base = ((r.layer as usize * h + gy) * w + gx) * 4;
            g.position[base..base + 4].copy_from_slice(&t[0]);
            g.normal[base..base + 4].copy_from_slice(&t[1]);
            g.albedo[base..base + 4].copy_from_slice(&t[2]);
        }
    }
    g
}

#[derive(Clone, Copy)]
struct Best {
    dist: f64,
    tri: u32,
    bary: DVec3,
}

/// Per-vertex world data of one object, computed once.
struct WorldVerts {
    positions: Vec<DVec3>,
    /// Unit world normals (zero where the normal cannot be transformed or normalised).
    normals: Vec<DVec3>,
}

/// Rows per band of parallel work within one object.
const BAND_ROWS: usize = 16;

/// A triangle in texel coordinates, ready to rasterise.
struct UvTriangle {
    index: u32,
    p: [DVec2; 3],
    area2: f64,
    /// Height of the triangle over the edge opposite each vertex, texels.
    height: DVec3,
    /// Texel rows and columns its bounding box touches (half-open).
    rows: [usize; 2],
    cols: [usize; 2],
}

/// Rasterises one object into a `size` map (row-major, region-local texels), in parallel
/// bands of rows.
pub(crate) fn rasterize_object(o: &Object, index: u32, size: [u32; 2]) -> Vec<Option<Texel>> {
    let (w, h) = (size[0] as usize, size[1] as usize);
    let m = &o.mesh;
    let scale = DVec2::new(f64::from(size[0]), f64::from(size[1]));
    let tris: Vec<UvTriangle> = m
        .indices
        .iter()
        .enumerate()
        .filter_map(|(ti, tri)| {
            let idx = tri_indices(tri, m)?;
            let p = idx.map(|i| Vec2::from(m.lightmap_uvs[i]).as_dvec2() * scale);
            let area2 = (p[1] - p[0]).perp_dot(p[2] - p[0]);
            if !(area2.is_finite() && area2.abs() > 1e-12) {
                return None;
            }
            let height = DVec3::from_array(std::array::from_fn(|i| {
                area2.abs() / (p[(i + 2) % 3] - p[(i + 1) % 3]).length()
            }));
            let range = |k: usize, n: usize| {
                let lo = p[0][k].min(p[1][k]).min(p[2][k]);
                let hi = p[0][k].max(p[1][k]).max(p[2][k]);
                [
                    lo.floor().clamp(0.0, n as f64) as usize,
                    hi.ceil().clamp(0.0, n as f64) as usize,
                ]
            };
            Some(UvTriangle {
                index: ti as u32,
                p,
                area2,
                height,
                rows: range(1, h),
                cols: range(0, w),
            })
        })
        .collect();
    let verts = WorldVerts {
        positions: m
            .positions
            .iter()
            .map(|&q| DVec3::from(o.transform.point_f64(q.map(f64::from))))
            .collect(),
        normals: m
            .normals
            .iter()
            .map(|&n| {
                o.transform
                    .normal_f64(n.map(f64::from))
                    .map_or(DVec3::ZERO, DVec3::from)
            })
            .collect(),
    };
    let bands: Vec<Vec<Option<Texel>>> = (0..h.div_ceil(BAND_ROWS))
        .into_par_iter()
        .map(|band| {
            let rows = [band * BAND_ROWS, ((band + 1) * BAND_ROWS).min(h)];
            let (best, mask) = rasterize_band(&tris, w, rows);
            best.iter()
                .zip(&mask)
                .map(|(b, &mk)| texel(o, &verts, index, (*b)?, mk))
                .collect()
        })
        .collect();
    bands.concat()
}

/// The nearest triangle sample and coverage mask of every texel in `rows` of a `w`-wide map.
fn rasterize_band(
    tris: &[UvTriangle],
    w: usize,
    rows: [usize; 2],
) -> (Vec<Option<Best>>, Vec<u16>) {
    // Half the diagonal of a texel: a centre at least this far inside every edge means the
    // whole texel is inside the triangle; this far outside any edge, none of it is.
    const HALF_DIAGONAL: f64 = std::f64::consts::FRAC_1_SQRT_2;
    let n = w * (rows[1] - rows[0]);
    let mut best: Vec<Option<Best>> = vec![None; n];
    let mut mask = vec![0u16; n];
    for t in tris {
        let (y0, y1) = (t.rows[0].max(rows[0]), t.rows[1].min(rows[1]));
        for y in y0..y1 {
            for x in t.cols[0]..t.cols[1] {
                let cell = DVec2::new(x as f64, y as f64);
                let centre = cell + 0.5;
                let b = barycentric(&t.p, t.area2, centre);
                let inside = b * t.height;
                if inside.cmple(DVec3::splat(-HALF_DIAGONAL)).any() {
                    continue;
                }
                let (dist, bary, mk) = if inside.cmpge(DVec3::splat(HALF_DIAGONAL)).all() {
                    (0.0, b, u16::MAX)
                } else {
                    if !overlaps(&t.p, cell) {
                        continue;
                    }
                    let (dist, bary) = closest(&t.p, b, centre);
                    (dist, bary, coverage_mask(&t.p, t.area2, cell))
                };
                let k = (y - rows[0]) * w + x;
                if best[k].is_none_or(|old| dist < old.dist) {
                    best[k] = Some(Best {
                        dist,
                        tri: t.index,
                        bary,
                    });
                }
                mask[k] |= mk;
            }
        }
    }
    (best, mask)
}

/// The G-buffer entry for the sample `b` of object `o`.
fn texel(o: &Object, verts: &WorldVerts, index: u32, b: Best, mask: u16) -> Option<Texel> {
    let m = &o.mesh;
    let idx = tri_indices(m.indices.get(b.tri as usize)?, m)?;
    // A clamped sample, or a centre on (or within the nudge of) an edge: nudged inside.
    let bary = if b.dist > 0.0 || b.bary.min_element() < EDGE_NUDGE / 3.0 {
        b.bary * (1.0 - EDGE_NUDGE) + EDGE_NUDGE / 3.0
    } else {
        b.bary
    };
    let interp3 = |v: [DVec3; 3]| v[0] * bary.x + v[1] * bary.y + v[2] * bary.z;
    let wp = idx.map(|i| verts.positions[i]);
    let pos = interp3(wp);
    if !pos.is_finite() {
        return None;
    }
    let wn = idx.map(|i| verts.normals[i]);
    let n = normalize_f64(interp3(wn))
        .or_else(|| normalize_f64((wp[1] - wp[0]).cross(wp[2] - wp[0])))
        .or_else(|| wn.iter().find_map(|&v| normalize_f64(v)))?;
    let mut albedo = Vec3::from(o.albedo.factor).as_dvec3();
    if let Some(colors) = &m.colors
        && let [Some(c0), Some(c1), Some(c2)] = idx.map(|i| colors.get(i))
    {
        albedo *= interp3([*c0, *c1, *c2].map(|v| Vec3::from(v).as_dvec3()));
    }
    if let (Some(tex), Some(uvs)) = (&o.albedo.texture, &m.material_uvs)
        && let [Some(t0), Some(t1), Some(t2)] = idx.map(|i| uvs.get(i))
    {
        let [t0, t1, t2] = [t0, t1, t2].map(|&t| Vec2::from(t).as_dvec2());
        let uv = t0 * bary.x + t1 * bary.y + t2 * bary.z;
        albedo *= Vec3::from(tex.sample(uv.as_vec2().to_array())).as_dvec3();
    }
    let albedo = albedo
        .map(|a| {
            if a.is_finite() {
                a.clamp(0.0, 1.0)
            } else {
                0.0
            }
        })
        .as_vec3();
    let coverage = mask.count_ones() as f32 / 16.0;
    Some([
        pos.as_vec3().extend(1.0).to_array(),
        n.as_vec3().extend(index as f32).to_array(),
        albedo.extend(coverage).to_array(),
    ])
}

/// Whether the triangle `p` and the unit texel square with top-left corner `cell` overlap
/// with positive area (separating-axis test; touching along an edge does not count). Points
/// are `DVec2`s or `[f64; 2]`s.
pub fn overlaps<P: Into<DVec2> + Copy>(p: &[P; 3], cell: impl Into<DVec2>) -> bool {
    const EPS: f64 = 1e-9;
    let (p, cell) = (p.map(Into::into), cell.into());
    for k in 0..2 {
        let lo = p[0][k].min(p[1][k]).min(p[2][k]);
        let hi = p[0][k].max(p[1][k]).max(p[2][k]);
        if hi <= cell[k] + EPS || lo >= cell[k] + 1.0 - EPS {
            return false;
        }
    }
    let centre = cell + 0.5;
    for i in 0..3 {
        let n = (p[(i + 1) % 3] - p[i]).perp();
        let len = n.length();
        let proj = p.map(|q| n.dot(q));
        let (tlo, thi) = (
            proj[0].min(proj[1]).min(proj[2]),
            proj[0].max(proj[1]).max(proj[2]),
        );
        let c = n.dot(centre);
        let r = 0.5 * n.abs().element_sum();
        if thi <= c - r + EPS * len || tlo >= c + r - EPS * len {
            return false;
        }
    }
    true
}

/// Barycentrics of `q` in triangle `p` (twice-signed-area `area2`).
fn barycentric(p: &[DVec2; 3], area2: f64, q: DVec2) -> DVec3 {
    let l0 = (p[1] - q).perp_dot(p[2] - q) / area2;
    let l1 = (p[2] - q).perp_dot(p[0] - q) / area2;
    DVec3::new(l0, l1, 1.0 - l0 - l1)
}

/// Distance (texels) from `q` (barycentrics `b`) to triangle `p` and the barycentrics of
/// the closest point.
fn closest(p: &[DVec2; 3], b: DVec3, q: DVec2) -> (f64, DVec3) {
    if b.cmpge(DVec3::ZERO).all() {
        return (0.0, b);
    }
    let mut best = (f64::INFINITY, DVec3::splat(1.0 / 3.0));
    for i in 0..3 {
        let j = (i + 1) % 3;
        let e = p[j] - p[i];
        let ee = e.length_squared();
        let t = if ee > 0.0 {
            (q - p[i]).dot(e) / ee
        } else {
            0.0
        }
        .clamp(0.0, 1.0);
        let d = q.distance(p[i] + e * t);
        if d < best.0 {
            let mut bary = DVec3::ZERO;
            bary[i] = 1.0 - t;
            bary[j] = t;
            best = (d, bary);
        }
    }
    best
}

/// 4×4 sample mask of the texel `cell` inside triangle `p`.
fn coverage_mask(p: &[DVec2; 3], area2: f64, cell: DVec2) -> u16 {
    let inside = |q: DVec2| barycentric(p, area2, q).cmpge(DVec3::ZERO).all();
    let corners = [DVec2::ZERO, DVec2::X, DVec2::Y, DVec2::ONE];
    if corners.iter().all(|&c| inside(cell + c)) {
        return u16::MAX;
    }
    let mut mask = 0u16;
    for j in 0..4 {
        for i in 0..4 {
            let q = cell + DVec2::new(i as f64 + 0.5, j as f64 + 0.5) / 4.0;
            if inside(q) {
                mask |= 1 << (j * 4 + i);
            }
        }
    }
    mask
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Albedo, Mesh, Settings, Transform};
    use crate::sources::meshes;

    fn raster(scene: &Scene) -> (Layout, GBuffer) {
        let l = Layout::new(scene, 8192, 256).expect("layout");
        let g = rasterize(scene, &l);
        (l, g)
    }

    /// A scene of one grey receiver, `mesh` placed by `transform`, baked with `settings`.
    fn one_receiver(mesh: Mesh, transform: Transform, settings: Settings) -> Scene {
        Scene {
            objects: vec![Object {
                name: "r".into(),
                mesh,
                transform,
                albedo: Albedo::grey(0.5),
                receiver: true,
                texel_scale: 1.0,
            }],
            lamps: Vec::new(),
            settings,
        }
    }

    /// One layer of `size` texels, all of it the first object's region.
    fn whole_layer(size: [u32; 2]) -> Layout {
        Layout {
            layer_size: size,
            layers: 1,
            regions: vec![Some(Region {
                layer: 0,
                offset: [0, 0],
                size,
            })],
        }
    }

    /// Distance from `q` to triangle `t` (3D, brute force, for tests).
    fn point_triangle_distance(q: DVec3, t: [DVec3; 3]) -> f64 {
        let n = (t[1] - t[0]).cross(t[2] - t[0]);
        let nn = n.length_squared();
        if nn > 0.0 {
            let s = (q - t[0]).dot(n) / nn;
            let proj = q - n * s;
            let inside = (0..3).all(|i| {
                let (a, b) = (t[i], t[(i + 1) % 3]);
                (b - a).cross(proj - a).dot(n) >= 0.0
            });
            if inside {
                return (s * s * nn).sqrt();
            }
        }
        (0..3)
            .map(|i| {
                let (a, b) = (t[i], t[(i + 1) % 3]);
                let ab = b - a;
                let l = ab.length_squared();
                let s = if l > 0.0 {
                    ((q - a).dot(ab) / l).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                q.distance(a + ab * s)
            })
            .fold(f64::INFINITY, f64::min)
    }

    fn world_tris(o: &Object) -> Vec<[DVec3; 3]> {
        o.mesh
            .indices
            .iter()
            .map(|t| {
                t.map(|i| {
                    DVec3::from(
                        o.transform
                            .point_f64(o.mesh.positions[i as usize].map(f64::from)),
                    )
                })
            })
            .collect()
    }

    /// Whether every channel of `g`'s maps is finite.
    fn all_finite(g: &GBuffer) -> bool {
        g.position
            .iter()
            .chain(&g.normal)
            .chain(&g.albedo)
            .all(|v| v.is_finite())
    }

    /// Checks the invariants of every texel and returns the number of valid ones checked
    /// against their surface (every `stride`-th).
    fn check(scene: &Scene, l: &Layout, g: &GBuffer, stride: usize) -> usize {
        assert!(all_finite(g));
        let tris: Vec<_> = scene.objects.iter().map(world_tris).collect();
        let mut checked = 0;
        for (k, t) in g.position.chunks_exact(4).enumerate() {
            let (n, a) = (&g.normal[k * 4..k * 4 + 4], &g.albedo[k * 4..k * 4 + 4]);
            if t[3] == 0.0 {
                assert!(
                    t.iter().chain(n).chain(a).all(|&v| v == 0.0),
                    "empty texel {k} not zero"
                );
                continue;
            }
            assert_eq!(t[3], 1.0);
            let len = Vec3::from_slice(n).length();
            assert!((len - 1.0).abs() < 1e-5, "texel {k}: normal length {len}");
            let obj = n[3] as usize;
            assert_eq!(n[3], obj as f32);
            assert!(
                a.iter().all(|v| (0.0..=1.0).contains(v)),
                "texel {k}: albedo {a:?}"
            );
            // The texel lies in its object's region.
            let layer_len = (g.layer_size[0] * g.layer_size[1]) as usize;
            let (layer, rest) = (k / layer_len, k % layer_len);
            let (x, y) = (
                (rest % g.layer_size[0] as usize) as u32,
                (rest / g.layer_size[0] as usize) as u32,
            );
            let r = l.regions[obj].expect("valid texel of a receiver");
            assert_eq!(r.layer as usize, layer);
            assert!(x >= r.offset[0] && x < r.offset[0] + r.size[0]);
            assert!(y >= r.offset[1] && y < r.offset[1] + r.size[1]);
            if k % stride == 0 {
                let q = Vec3::from_slice(t).as_dvec3();
                let d = tris[obj]
                    .iter()
                    .map(|&tri| point_triangle_distance(q, tri))
                    .fold(f64::INFINITY, f64::min);
                assert!(
                    d < 2e-5,
                    "texel {k} of object {obj} is {d} m off its surface"
                );
                checked += 1;
            }
        }
        checked
    }

    #[test]
    fn valid_texels_lie_on_their_surfaces() {
        let s = Scene::builtin("chairs_03").expect("builtin");
        let (l, g) = raster(&s);
        let checked = check(&s, &l, &g, 1);
        assert!(
            checked as u64 == g.valid_texels() && checked > 400_000,
            "{checked}"
        );
        let s = Scene::builtin("sofa_01").expect("builtin");
        let (l, g) = raster(&s);
        assert!(check(&s, &l, &g, 37) > 10_000);
    }

    #[test]
    fn sphere_texels_lie_on_the_sphere_and_face_inward() {
        let s = Scene::builtin("sphere").expect("builtin");
        let (l, g) = raster(&s);
        assert!(check(&s, &l, &g, 97) > 300);
        let r = f64::from(crate::sources::builtin::SPHERE_RADIUS);
        for (p, n) in g.position.chunks_exact(4).zip(g.normal.chunks_exact(4)) {
            if p[3] == 1.0 {
                let q = Vec3::from_slice(p).as_dvec3();
                let d = q.length();
                assert!(d <= r * (1.0 + 1e-6) && d > r * 0.998, "{d}");
                let c = q.dot(Vec3::from_slice(n).as_dvec3()) / d;
                assert!(c < -0.999, "normal not toward the centre: {c}");
            }
        }
    }

    /// Every texel that contains a point of a triangle is valid (conservative coverage),
    /// including texels whose centre lies outside every triangle.
    #[test]
    fn coverage_is_conservative() {
        let s = Scene::builtin("chairs_01").expect("builtin");
        let (l, g) = raster(&s);
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut centre_outside = 0;
        for (oi, o) in s.objects.iter().enumerate() {
            let r = l.regions[oi].expect("receiver");
            for t in &o.mesh.indices {
                let uv = t.map(|i| Vec2::from(o.mesh.lightmap_uvs[i as usize]).as_dvec2());
                for _ in 0..64 {
                    let (mut a, mut b) = (rnd(), rnd());
                    if a + b > 1.0 {
                        (a, b) = (1.0 - a, 1.0 - b);
                    }
                    let q = uv[0] + (uv[1] - uv[0]) * a + (uv[2] - uv[0]) * b;
                    let x = (q.x * f64::from(r.size[0])).floor() as u32 + r.offset[0];
                    let y = (q.y * f64::from(r.size[1])).floor() as u32 + r.offset[1];
                    assert!(
                        g.is_valid(r.layer, x, y),
                        "{}: texel ({x}, {y}) holds surface but is empty",
                        o.name
                    );
                }
            }
        }
        for (k, a) in g.albedo.chunks_exact(4).enumerate() {
            if g.position[k * 4 + 3] == 1.0 && a[3] < 0.5 {
                centre_outside += 1;
            }
        }
        assert!(
            centre_outside > 1000,
            "edge texels are sampled: {centre_outside}"
        );
    }

    /// Edge texels whose centre is outside the chart take the nearest surface point: inside
    /// the plane's bounds, never in empty space.
    #[test]
    fn edge_texels_sample_the_surface_border() {
        let s = one_receiver(
            meshes::plane([1.0, 1.0], 0.13),
            Transform::from_trs([0.0, 1.0, 0.0], [0.0; 3], [1.0; 3]),
            Settings {
                texels_per_metre: 10.3,
                ..Settings::default()
            },
        );
        let (_, g) = raster(&s);
        let (mut valid, mut full) = (0, 0);
        for (p, a) in g.position.chunks_exact(4).zip(g.albedo.chunks_exact(4)) {
            if p[3] == 1.0 {
                valid += 1;
                full += usize::from(a[3] == 1.0);
                assert!(p[0].abs() < 0.5 && p[2].abs() < 0.5 && p[1] == 1.0, "{p:?}");
                assert!(p[0].abs() > 0.0 || p[2].abs() > 0.0);
            }
        }
        // 1 m at 10.3 texels/m crosses 11 or 12 texel columns; fully covered ones are fewer.
        assert!(
            valid >= 11 * 11 && full < valid,
            "{valid} valid, {full} fully covered"
        );
    }

    /// The box room of issue 29 at 16 texels/m: its floor's texel grid lies on the corner
    /// lines, so some texel centres lie exactly on the floor's edge that the walls share.
    /// Every floor sample lies strictly inside the floor, so a gather from it sees the walls.
    #[test]
    fn texel_centres_on_a_shared_edge_are_nudged_inside() {
        let settings = Settings {
            texels_per_metre: 16.0,
            ..Settings::default()
        };
        let padding = crate::sources::builtin::padding_m(&settings, 1.0);
        let room = meshes::room(
            [4.0, 2.5, 3.0],
            meshes::RoomAlbedo::uniform([0.5; 3]),
            padding,
        );
        let s = one_receiver(room, Transform::IDENTITY, settings);
        let (_, g) = raster(&s);
        let (mut floor, mut nearest) = (0, f32::INFINITY);
        for (p, n) in g.position.chunks_exact(4).zip(g.normal.chunks_exact(4)) {
            if p[3] == 1.0 && n[1] > 0.9 {
                floor += 1;
                nearest = nearest.min(2.0 - p[0].abs()).min(1.5 - p[2].abs());
            }
        }
        assert!(floor >= 64 * 48, "{floor} floor texels");
        assert!(nearest >= 5e-4, "a floor sample {nearest} m from a wall");
    }

    #[test]
    fn degenerate_triangles_give_no_nan() {
        let mut mesh = Mesh {
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0],
                [2.0, 0.0, 2.0],
                [2.0, 0.0, 2.0],
                [2.0, 0.0, 2.0],
                [0.0, 0.0, 0.0],
                [1e-9, 0.0, 1.0],
                [f32::NAN, 0.0, 0.0],
            ],
            normals: vec![[0.0, 1.0, 0.0]; 9],
            lightmap_uvs: vec![
                [0.1, 0.1],
                [0.4, 0.1],
                [0.1, 0.4],
                [0.5, 0.5],
                [0.9, 0.5],
                [0.5, 0.9],
                [0.6, 0.1],
                [0.6, 0.1],
                [0.95, 0.05],
            ],
            indices: vec![
                [0, 1, 2],  // fine
                [3, 4, 5],  // zero world area
                [6, 7, 0],  // sliver in world, zero-ish UV area
                [0, 1, 6],  // sliver in UV
                [6, 7, 1],  // thin in UV
                [8, 1, 2],  // NaN position
                [0, 1, 99], // out of range
            ],
            ..Mesh::default()
        };
        // Zero-area triangle with two zero normals: the third one still gives a direction.
        mesh.normals[4] = [0.0; 3];
        mesh.normals[5] = [0.0; 3];
        let s = one_receiver(mesh, Transform::IDENTITY, Settings::default());
        let g = rasterize(&s, &whole_layer([64, 64]));
        assert!(all_finite(&g));
        assert!(g.valid_texels() > 100);
        for n in g.normal.chunks_exact(4) {
            let len = Vec3::from_slice(n).length();
            assert!(len == 0.0 || (len - 1.0).abs() < 1e-5);
        }
        // The zero-area triangle's texels sit at its one point.
        let centre = g.index(0, 44, 44);
        assert_eq!(&g.position[centre..centre + 4], &[2.0, 0.0, 2.0, 1.0]);
        let (tris, _) = s.world_triangles();
        assert_eq!(
            tris.len(),
            5,
            "NaN and out-of-range triangles are left out of the BVH soup"
        );
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(200))]
        /// Random triangle soups (overlapping, degenerate, slivers) at random map sizes: all
        /// data finite, normals unit, every valid texel on a triangle, and every texel that
        /// holds a triangle's centroid valid.
        #[test]
        fn random_triangles(
            tris in proptest::collection::vec(
                (proptest::array::uniform3(proptest::array::uniform3(-2.0f32..2.0)),
                 proptest::array::uniform3(proptest::array::uniform2(0.0f32..1.0))),
                1..8,
            ),
            size in (1u32..40, 1u32..40),
        ) {
            let mut mesh = Mesh::default();
            for (p, uv) in &tris {
                let base = mesh.positions.len() as u32;
                mesh.positions.extend_from_slice(p);
                mesh.lightmap_uvs.extend_from_slice(uv);
                mesh.normals.extend_from_slice(&[[0.0, 1.0, 0.0]; 3]);
                mesh.indices.push([base, base + 1, base + 2]);
            }
            let size = [size.0, size.1];
            let s = one_receiver(mesh, Transform::IDENTITY, Settings::default());
            let l = whole_layer(size);
            let g = rasterize(&s, &l);
            check(&s, &l, &g, 1);
            for (_, uv) in &tris {
                let uv = uv.map(Vec2::from);
                let a2 = (uv[1] - uv[0]).perp_dot(uv[2] - uv[0]);
                if a2.abs() * (size[0] * size[1]) as f32 > 1e-6 {
                    let c = (uv[0] + uv[1] + uv[2]) / 3.0;
                    let x = ((c.x * size[0] as f32) as u32).min(size[0] - 1);
                    let y = ((c.y * size[1] as f32) as u32).min(size[1] - 1);
                    proptest::prop_assert!(g.is_valid(0, x, y), "centroid texel ({}, {}) empty", x, y);
                }
            }
        }
    }

    #[test]
    fn albedo_non_receivers_and_determinism() {
        let mut s = Scene::builtin("chairs_01").expect("builtin");
        s.objects[1].receiver = false;
        let (l, g) = raster(&s);
        assert!(l.regions[1].is_none());
        let mut floor = 0;
        for (k, n) in g.normal.chunks_exact(4).enumerate() {
            if g.position[k * 4 + 3] == 1.0 {
                assert_eq!(n[3], 0.0, "only the room has texels");
                if n[1] > 0.99 {
                    floor += 1;
                    let a = &g.albedo[k * 4..k * 4 + 3];
                    assert_eq!(a, crate::sources::builtin::ROOM_ALBEDO.floor);
                }
            }
        }
        assert!(floor > 70_000);
        assert_eq!(rasterize(&s, &l), g, "deterministic");
        let none = Scene {
            objects: Vec::new(),
            ..s
        };
        let (l, g) = raster(&none);
        assert_eq!((l.layers, g.position.len(), g.valid_texels()), (0, 0, 0));
        assert!(!g.is_valid(0, 0, 0));
    }
}
