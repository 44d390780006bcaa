//! Calculation points: from a world point on a baked surface to the light-map UV where its
//! value is stored (what `cargo xtask measure` and the tests read).
//!
//! [`locate`] finds the receiving object's triangle closest to the point (exact closest point
//! on each world-space triangle, in `f64`), and accepts it when the distance is within the
//! tolerance. The light-map UV is the barycentric interpolation of the triangle's UVs at that
//! closest point; the value is then read with the masked bilinear rule of [`crate::map`].

use crate::scene::Scene;

/// A point located on a receiving surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// Object index.
    pub object: usize,
    /// Light-map UV of the point.
    pub uv: [f32; 2],
    /// Distance from the query point to the surface, metres.
    pub distance: f64,
}

type V = [f64; 3];

fn sub(a: V, b: V) -> V {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: V, b: V) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Barycentric weights `(w0, w1, w2)` of the point of triangle `abc` closest to `p`
/// (Ericson, *Real-Time Collision Detection*, 5.1.5), robust for degenerate triangles.
pub fn closest_barycentric(p: V, a: V, b: V, c: V) -> [f64; 3] {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return [1.0 - v, v, 0.0];
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - w, w];
    }
    let denom = va + vb + vc;
    if denom == 0.0 || !denom.is_finite() {
        return [1.0, 0.0, 0.0];
    }
    let v = vb / denom;
    let w = vc / denom;
    [1.0 - v - w, v, w]
}

/// The receiving surface point closest to `point` within `tolerance` metres, if any.
/// Objects without a light map (`receiver == false`) are ignored.
pub fn locate(scene: &Scene, point: [f64; 3], tolerance: f64) -> Option<SurfacePoint> {
    let mut best: Option<SurfacePoint> = None;
    for (o, obj) in scene.objects.iter().enumerate() {
        if !obj.receiver {
            continue;
        }
        let m = &obj.mesh;
        let world: Vec<V> = m
            .positions
            .iter()
            .map(|p| obj.transform.point_f64(p.map(f64::from)))
            .collect();
        for tri in &m.indices {
            let idx = tri.map(|i| i as usize);
            let (Some(&a), Some(&b), Some(&c)) =
                (world.get(idx[0]), world.get(idx[1]), world.get(idx[2]))
            else {
                continue;
            };
            let w = closest_barycentric(point, a, b, c);
            let q = [0, 1, 2].map(|k| w[0] * a[k] + w[1] * b[k] + w[2] * c[k]);
            let d = dot(sub(point, q), sub(point, q)).sqrt();
            if d.is_nan() || d > tolerance || best.is_some_and(|b| b.distance <= d) {
                continue;
            }
            let uvs = idx.map(|i| m.lightmap_uvs.get(i).copied().unwrap_or([0.0; 2]));
            let uv = [0, 1].map(|k| {
                (w[0] * f64::from(uvs[0][k])
                    + w[1] * f64::from(uvs[1][k])
                    + w[2] * f64::from(uvs[2][k])) as f32
            });
            best = Some(SurfacePoint {
                object: o,
                uv,
                distance: d,
            });
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closest_point_regions() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        assert_eq!(
            closest_barycentric([0.25, 0.25, 1.0], a, b, c),
            [0.5, 0.25, 0.25]
        );
        assert_eq!(
            closest_barycentric([-1.0, -1.0, 0.0], a, b, c),
            [1.0, 0.0, 0.0]
        );
        assert_eq!(
            closest_barycentric([2.0, -0.1, 0.0], a, b, c),
            [0.0, 1.0, 0.0]
        );
        assert_eq!(
            closest_barycentric([0.5, -1.0, 0.0], a, b, c),
            [0.5, 0.5, 0.0]
        );
        // Degenerate (all points equal): vertex a, no NaN.
        let w = closest_barycentric([1.0, 2.0, 3.0], a, a, a);
        assert!(w.iter().all(|x| x.is_finite()));
    }
}
