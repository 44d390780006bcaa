//! CPU traversal of the encoded texels, written as the GLSL ES 3.00 shader is.
//!
//! The GLSL mapping is in the crate documentation.

use crate::encode::{EncodedScene, texel_fetch};
use crate::layout;

/// A ray `origin + t·dir`. `dir` must be finite and non-zero; it need not be normalised
/// (distances `t` are then in units of its length).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin.
    pub origin: [f32; 3],
    /// Direction.
    pub dir: [f32; 3],
}

/// A ray/triangle hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the ray, in units of the direction's length; in `(t_min, t_max)`.
    pub t: f32,
    /// Triangle index in the **encoded** order (see [`EncodedScene::triangle_order`]).
    pub triangle: u32,
    /// Barycentric weight of vertex 1.
    pub u: f32,
    /// Barycentric weight of vertex 2 (vertex 0 has `1 − u − v`).
    pub v: f32,
}

/// Work done by one traversal ([`EncodedScene::traversal_stats`]), for profiling and for
/// comparing link orders.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TraversalStats {
    /// The hit found (closest, or the first for an any-hit query).
    pub hit: Option<Hit>,
    /// Nodes fetched (loop iterations; at most `node_count`).
    pub nodes: u32,
    /// Node boxes the ray hit.
    pub boxes_hit: u32,
    /// Ray/triangle tests.
    pub triangle_tests: u32,
}

/// Which acceleration structure the traversal walks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Traversal {
    /// MTBVH: the link layer of the ray's dominant direction ([`dominant_direction`]).
    Mtbvh,
    /// TBVH: the single canonical link order (`tbvh_links`).
    Tbvh,
    /// No BVH: every triangle is tested (the paper's "no BVH" column).
    BruteForce,
}

/// A link texture to walk explicitly, for testing every MTBVH order with every ray.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinkTexture {
    /// The TBVH links.
    Tbvh,
    /// MTBVH link layer 0..6, regardless of the ray direction.
    Mtbvh(u32),
}

/// The MTBVH direction (link layer) of a ray direction: `2·axis + (negative ? 1 : 0)` for the
/// axis of largest magnitude (ties prefer x, then y), i.e. +x 0, −x 1, +y 2, −y 3, +z 4, −z 5.
///
/// GLSL: `vec3 a = abs(d); int k = (a.x >= a.y && a.x >= a.z) ? 0 : (a.y >= a.z ? 1 : 2);
/// return 2 * k + (d[k] < 0.0 ? 1 : 0);`
pub fn dominant_direction(dir: [f32; 3]) -> u32 {
    let k = dominant_axis(dir);
    2 * k as u32 + u32::from(dir[k] < 0.0)
}

fn dominant_axis(d: [f32; 3]) -> usize {
    let a = [d[0].abs(), d[1].abs(), d[2].abs()];
    if a[0] >= a[1] && a[0] >= a[2] {
        0
    } else if a[1] >= a[2] {
        1
    } else {
        2
    }
}

/// The watertight test's axes `[kx, ky, kz]` for dominant axis `kz`: the other two in cyclic
/// order, swapped where `dir[kz]` is negative (preserving the winding).
pub(crate) const fn permuted_axes(kz: usize, negative: bool) -> [usize; 3] {
    let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
    if negative { [ky, kx, kz] } else { [kx, ky, kz] }
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// GLSL `mix(b, a, c)` for a scalar bool: `c ? a : b`.
fn select(c: bool, a: f32, b: f32) -> f32 {
    if c { a } else { b }
}

/// Per-ray setup shared by the slab and triangle tests (computed once per ray, as in the
/// shader): the watertight test's axis permutation and shear (Woop, Benthin & Wald 2013) and
/// the slab test's safe inverse direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WatertightRay {
    pub(crate) origin: [f32; 3],
    /// Permuted axes: `kz` = dominant axis, `kx`, `ky` the others (swapped if `dir[kz] < 0`,
    /// preserving the winding).
    pub(crate) kx: usize,
    pub(crate) ky: usize,
    pub(crate) kz: usize,
    pub(crate) sx: f32,
    pub(crate) sy: f32,
    pub(crate) sz: f32,
    /// `1 / dir` per axis, with 1 in place of near-zero components.
    pub(crate) inv: [f32; 3],
    /// Whether the axis is (numerically) parallel: `|dir| < PARALLEL_EPSILON`.
    pub(crate) parallel: [bool; 3],
}

impl WatertightRay {
    /// Sets up `ray`. Returns `None` if its direction is zero or it has a non-finite component.
    #[inline]
    pub fn new(ray: &Ray) -> Option<WatertightRay> {
        let d = ray.dir;
        let finite = d.iter().chain(&ray.origin).all(|c| c.is_finite());
        let kz = dominant_axis(d);
        if !finite || d[kz] == 0.0 {
            return None;
        }
        let [kx, ky, kz] = permuted_axes(kz, d[kz] < 0.0);
        let parallel = d.map(|c| c.abs() < layout::PARALLEL_EPSILON);
        let inv = [0, 1, 2].map(|a| 1.0 / select(parallel[a], 1.0, d[a]));
        Some(WatertightRay {
            origin: ray.origin,
            kx,
            ky,
            kz,
            sx: d[kx] / d[kz],
            sy: d[ky] / d[kz],
            sz: 1.0 / d[kz],
            inv,
            parallel,
        })
    }

    /// Slab test: does the ray, restricted to `[t_min, t_max]`, touch the box?
    ///
    /// Parallel axes (zero, ±0 or subnormal direction components) are decided by whether the
    /// origin lies in the slab, so no `0·∞` or infinite inverse arises and both signs of zero
    /// behave alike. Entry and exit get a relative slack of [`layout::BOX_SLACK`] so rounding
    /// does not reject a box the ray touches (boxes may be accepted slightly too often).
    pub fn hits_box(&self, min: [f32; 3], max: [f32; 3], t_min: f32, t_max: f32) -> bool {
        let mut box_near = -layout::BIG;
        let mut box_far = layout::BIG;
        for a in 0..3 {
            let t0 = (min[a] - self.origin[a]) * self.inv[a];
            let t1 = (max[a] - self.origin[a]) * self.inv[a];
            let inside = min[a] <= self.origin[a] && self.origin[a] <= max[a];
            let lo = select(
                self.parallel[a],
                select(inside, -layout::BIG, layout::BIG),
                t0.min(t1),
            );
            let hi = select(
                self.parallel[a],
                select(inside, layout::BIG, -layout::BIG),
                t0.max(t1),
            );
            box_near = box_near.max(lo);
            box_far = box_far.min(hi);
        }
        let t_near = t_min.max(box_near - box_near.abs() * layout::BOX_SLACK);
        let t_far = t_max.min(box_far + box_far.abs() * layout::BOX_SLACK);
        t_near <= t_far
    }

    /// Watertight ray/triangle test. Returns `(t, u, v)` with `t` in the open interval
    /// `(t_min, t_max)` and `u`, `v` the barycentric weights of `p1`, `p2`. Both faces count;
    /// a point (three equal vertices), a segment (two) and rays in the triangle's plane whose
    /// sheared coordinates are exact never hit. Other slivers (collinear vertices,
    /// [`crate::is_sliver`]) can be reported hit at a meaningless `t` by a ray through their
    /// line, when the rounding noise of the edge functions has one sign: [`crate::encode`]
    /// stores them as points.
    pub fn hits_triangle(
        &self,
        p0: [f32; 3],
        p1: [f32; 3],
        p2: [f32; 3],
        t_min: f32,
        t_max: f32,
    ) -> Option<(f32, f32, f32)> {
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        let a = sub(p0, self.origin);
        let b = sub(p1, self.origin);
        let c = sub(p2, self.origin);
        let ax = a[kx] - self.sx * a[kz];
        let ay = a[ky] - self.sy * a[kz];
        let bx = b[kx] - self.sx * b[kz];
        let by = b[ky] - self.sy * b[kz];
        let cx = c[kx] - self.sx * c[kz];
        let cy = c[ky] - self.sy * c[kz];
        // Edge functions, all in the antisymmetric form e(P, Q) = P.x·Q.y − P.y·Q.x.
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let az = self.sz * a[kz];
        let bz = self.sz * b[kz];
        let cz = self.sz * c[kz];
        let t = (u * az + v * bz + w * cz) / det;
        if !(t > t_min && t < t_max) {
            return None;
        }
        Some((t, v / det, w / det))
    }
}

impl EncodedScene {
    /// The closest hit with `t` in `(t_min, t_max)` (`t_max` may be `f32::INFINITY`), or
    /// `None`. Exact ties in `t` keep the triangle found first. Rays with a zero or non-finite
    /// direction never hit.
    pub fn closest_hit(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        traversal: Traversal,
    ) -> Option<Hit> {
        self.trace(
            ray,
            t_min,
            t_max,
            traversal,
            false,
            &mut TraversalStats::default(),
        )
    }

    /// Whether any triangle is hit with `t` in `(t_min, t_max)`: the shadow-ray query (returns
    /// at the first hit found).
    pub fn any_hit(&self, ray: &Ray, t_min: f32, t_max: f32, traversal: Traversal) -> bool {
        self.trace(
            ray,
            t_min,
            t_max,
            traversal,
            true,
            &mut TraversalStats::default(),
        )
        .is_some()
    }

    /// The same traversal as [`EncodedScene::closest_hit`] (or [`EncodedScene::any_hit`] with
    /// `any_hit`), counting the work done.
    pub fn traversal_stats(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        traversal: Traversal,
        any_hit: bool,
    ) -> TraversalStats {
        let mut stats = TraversalStats::default();
        stats.hit = self.trace(ray, t_min, t_max, traversal, any_hit, &mut stats);
        stats
    }

    /// [`EncodedScene::closest_hit`] walking a given link texture whatever the ray direction
    /// (any MTBVH layer gives a correct, if slower, traversal for every ray).
    pub fn closest_hit_with(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        links: LinkTexture,
    ) -> Option<Hit> {
        let setup = WatertightRay::new(ray)?;
        self.walk(
            &setup,
            t_min,
            t_max,
            links,
            false,
            &mut TraversalStats::default(),
        )
    }

    /// [`EncodedScene::any_hit`] walking a given link texture whatever the ray direction.
    pub fn any_hit_with(&self, ray: &Ray, t_min: f32, t_max: f32, links: LinkTexture) -> bool {
        WatertightRay::new(ray)
            .and_then(|setup| {
                self.walk(
                    &setup,
                    t_min,
                    t_max,
                    links,
                    true,
                    &mut TraversalStats::default(),
                )
            })
            .is_some()
    }

    fn trace(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        traversal: Traversal,
        any: bool,
        stats: &mut TraversalStats,
    ) -> Option<Hit> {
        let setup = WatertightRay::new(ray)?;
        match traversal {
            Traversal::Mtbvh => self.walk(
                &setup,
                t_min,
                t_max,
                LinkTexture::Mtbvh(dominant_direction(ray.dir)),
                any,
                stats,
            ),
            Traversal::Tbvh => self.walk(&setup, t_min, t_max, LinkTexture::Tbvh, any, stats),
            Traversal::BruteForce => self.brute_force(&setup, t_min, t_max, any, stats),
        }
    }

    /// Tests encoded triangle `t` (three `texelFetch`es, then the watertight test).
    fn triangle_test(
        &self,
        r: &WatertightRay,
        t: i32,
        t_min: f32,
        t_max: f32,
    ) -> Option<(f32, f32, f32)> {
        let w = i32::try_from(self.tri_size[0]).unwrap_or(i32::MAX).max(1);
        let c = [t % w, t / w];
        let p0 = texel_fetch(&self.triangles, self.tri_size, c, layout::TRI_P0_LAYER);
        let p1 = texel_fetch(&self.triangles, self.tri_size, c, layout::TRI_P1_LAYER);
        let p2 = texel_fetch(&self.triangles, self.tri_size, c, layout::TRI_P2_LAYER);
        r.hits_triangle(
            [p0[0], p0[1], p0[2]],
            [p1[0], p1[1], p1[2]],
            [p2[0], p2[1], p2[2]],
            t_min,
            t_max,
        )
    }

    /// The stackless threaded walk (mirrors the GLSL loop in the module docs).
    fn walk(
        &self,
        r: &WatertightRay,
        t_min: f32,
        t_max: f32,
        links: LinkTexture,
        any: bool,
        stats: &mut TraversalStats,
    ) -> Option<Hit> {
        let (link_tex, layer) = match links {
            LinkTexture::Tbvh => (&self.tbvh_links, 0),
            LinkTexture::Mtbvh(d) => (&self.links, d),
        };
        let triangle_count = i32::try_from(self.triangle_count).unwrap_or(i32::MAX);
        let node_count = i32::try_from(self.node_count).unwrap_or(i32::MAX);
        let mut node = [layout::ROOT_X, layout::ROOT_Y];
        let mut found = Closest::new(t_max);
        let mut steps = 0;
        while steps < node_count && node[0] >= 0 {
            steps += 1;
            stats.nodes += 1;
            let lo = texel_fetch(&self.bounds, self.node_size, node, layout::BOUNDS_MIN_LAYER);
            let hi = texel_fetch(&self.bounds, self.node_size, node, layout::BOUNDS_MAX_LAYER);
            let link = texel_fetch(link_tex, self.node_size, node, layer);
            if r.hits_box([lo[0], lo[1], lo[2]], [hi[0], hi[1], hi[2]], t_min, found.t) {
                stats.boxes_hit += 1;
                let leaf = (lo[3] as i32).max(0)..(hi[3] as i32).min(triangle_count);
                if self.test_triangles(r, leaf, t_min, &mut found, any, stats) {
                    return found.hit();
                }
                node = [link[0] as i32, link[1] as i32];
            } else {
                node = [link[2] as i32, link[3] as i32];
            }
        }
        found.hit()
    }

    /// Tests every triangle in encoded order (the "no BVH" path).
    fn brute_force(
        &self,
        r: &WatertightRay,
        t_min: f32,
        t_max: f32,
        any: bool,
        stats: &mut TraversalStats,
    ) -> Option<Hit> {
        let triangle_count = i32::try_from(self.triangle_count).unwrap_or(i32::MAX);
        let mut found = Closest::new(t_max);
        self.test_triangles(r, 0..triangle_count, t_min, &mut found, any, stats);
        found.hit()
    }

    /// Tests encoded triangles `range` in order, narrowing `found`; true when `any` and one was
    /// hit (the walk stops there).
    fn test_triangles(
        &self,
        r: &WatertightRay,
        range: std::ops::Range<i32>,
        t_min: f32,
        found: &mut Closest,
        any: bool,
        stats: &mut TraversalStats,
    ) -> bool {
        for t in range {
            stats.triangle_tests += 1;
            if let Some((d, u, v)) = self.triangle_test(r, t, t_min, found.t) {
                *found = Closest {
                    t: d,
                    best: t,
                    bary: [u, v],
                };
                if any {
                    return true;
                }
            }
        }
        false
    }
}

/// The closest hit so far: its distance (the ray's current end), triangle (-1 for none) and
/// barycentrics.
struct Closest {
    t: f32,
    best: i32,
    bary: [f32; 2],
}

impl Closest {
    /// No hit yet; the ray ends at `t_max`.
    fn new(t_max: f32) -> Self {
        Closest {
            t: t_max,
            best: -1,
            bary: [0.0; 2],
        }
    }

    fn hit(&self) -> Option<Hit> {
        u32::try_from(self.best).ok().map(|triangle| Hit {
            t: self.t,
            triangle,
            u: self.bary[0],
            v: self.bary[1],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dominant_direction_layers() {
        assert_eq!(dominant_direction([1.0, 0.0, 0.0]), layout::DIR_POS_X);
        assert_eq!(dominant_direction([-1.0, 0.5, -0.5]), layout::DIR_NEG_X);
        assert_eq!(dominant_direction([0.1, 2.0, -0.0]), layout::DIR_POS_Y);
        assert_eq!(dominant_direction([-0.0, -2.0, 0.0]), layout::DIR_NEG_Y);
        assert_eq!(dominant_direction([0.0, -0.0, 3.0]), layout::DIR_POS_Z);
        assert_eq!(dominant_direction([0.2, 0.1, -3.0]), layout::DIR_NEG_Z);
        // Ties prefer x, then y.
        assert_eq!(dominant_direction([-1.0, 1.0, 1.0]), layout::DIR_NEG_X);
        assert_eq!(dominant_direction([0.0, -1.0, 1.0]), layout::DIR_NEG_Y);
    }

    #[test]
    fn ray_setup_rejects_degenerate_rays() {
        let ok = Ray {
            origin: [0.0; 3],
            dir: [0.0, -0.0, 1.0],
        };
        assert!(WatertightRay::new(&ok).is_some());
        for (origin, dir) in [
            ([0.0; 3], [0.0, -0.0, 0.0]),
            ([0.0; 3], [f32::NAN, 0.0, 1.0]),
            ([0.0; 3], [f32::INFINITY, 0.0, 1.0]),
            ([f32::NAN, 0.0, 0.0], [0.0, 0.0, 1.0]),
        ] {
            assert!(
                WatertightRay::new(&Ray { origin, dir }).is_none(),
                "{origin:?} {dir:?}"
            );
        }
    }

    #[test]
    fn triangle_test_barycentrics_and_winding() {
        let r = WatertightRay::new(&Ray {
            origin: [0.2, 0.3, 5.0],
            dir: [0.0, 0.0, -2.0],
        })
        .expect("ray");
        let (p0, p1, p2) = ([0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]);
        let front = r
            .hits_triangle(p0, p1, p2, 0.0, f32::INFINITY)
            .expect("hit");
        let back = r
            .hits_triangle(p0, p2, p1, 0.0, f32::INFINITY)
            .expect("hit");
        assert_eq!(front, (2.0, 0.2, 0.3));
        assert_eq!(back, (2.0, 0.3, 0.2));
        // Exactly on the shared edge p1–p2 of two triangles: both accept it.
        let e = WatertightRay::new(&Ray {
            origin: [0.5, 0.5, 5.0],
            dir: [0.0, 0.0, -1.0],
        })
        .expect("ray");
        assert!(e.hits_triangle(p0, p1, p2, 0.0, f32::INFINITY).is_some());
        assert!(
            e.hits_triangle(p1, [1.0, 1.0, 1.0], p2, 0.0, f32::INFINITY)
                .is_some()
        );
    }
}
