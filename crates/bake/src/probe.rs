//! Calculation points: from a world point on a baked surface to the light-map UV where its
//! value is stored (what `cargo xtask measure` and the tests read).
//!
//! [`locate`] finds the receiving object's triangle closest to the point (exact closest point
//! on each world-space triangle, in `f64`), and accepts it when the distance is within the
//! tolerance. The light-map UV is the barycentric interpolation of the triangle's UVs at that
//! closest point; the value is then read with the masked bilinear rule of [`crate::map`].

use glam::{DVec2, DVec3, Vec2};

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

/// Barycentric weights `(w0, w1, w2)` of the point of triangle `abc` closest to `p`
/// (Ericson, *Real-Time Collision Detection*, 5.1.5), robust for degenerate triangles.
pub fn closest_barycentric(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return DVec3::X;
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return DVec3::Y;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return DVec3::new(1.0 - v, v, 0.0);
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return DVec3::Z;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return DVec3::new(1.0 - w, 0.0, w);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return DVec3::new(0.0, 1.0 - w, w);
    }
    let denom = va + vb + vc;
    if denom == 0.0 || !denom.is_finite() {
        return DVec3::X;
    }
    let v = vb / denom;
    let w = vc / denom;
    DVec3::new(1.0 - v - w, v, w)
}

/// The receiving surface point closest to `point` within `tolerance` metres, if any.
/// Objects without a light map (`receiver == false`) are ignored.
pub fn locate(scene: &Scene, point: [f64; 3], tolerance: f64) -> Option<SurfacePoint> {
    let point = DVec3::from(point);
    let mut best: Option<SurfacePoint> = None;
    for (o, obj) in scene.objects.iter().enumerate() {
        if !obj.receiver {
            continue;
        }
        let m = &obj.mesh;
        let world: Vec<DVec3> = m
            .positions
            .iter()
            .map(|p| DVec3::from(obj.transform.point_f64(p.map(f64::from))))
            .collect();
        for tri in &m.indices {
            let idx = tri.map(|i| i as usize);
            let (Some(&a), Some(&b), Some(&c)) =
                (world.get(idx[0]), world.get(idx[1]), world.get(idx[2]))
            else {
                continue;
            };
            let w = closest_barycentric(point, a, b, c);
            let d = point.distance(a * w.x + b * w.y + c * w.z);
            if d.is_nan() || d > tolerance || best.is_some_and(|b| b.distance <= d) {
                continue;
            }
            let uvs = idx.map(|i| {
                m.lightmap_uvs
                    .get(i)
                    .map_or(DVec2::ZERO, |&uv| Vec2::from(uv).as_dvec2())
            });
            let uv = (uvs[0] * w.x + uvs[1] * w.y + uvs[2] * w.z)
                .as_vec2()
                .to_array();
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
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        assert_eq!(
            closest_barycentric(DVec3::new(0.25, 0.25, 1.0), a, b, c),
            DVec3::new(0.5, 0.25, 0.25)
        );
        assert_eq!(
            closest_barycentric(DVec3::new(-1.0, -1.0, 0.0), a, b, c),
            DVec3::new(1.0, 0.0, 0.0)
        );
        assert_eq!(
            closest_barycentric(DVec3::new(2.0, -0.1, 0.0), a, b, c),
            DVec3::new(0.0, 1.0, 0.0)
        );
        assert_eq!(
            closest_barycentric(DVec3::new(0.5, -1.0, 0.0), a, b, c),
            DVec3::new(0.5, 0.5, 0.0)
        );
        // Degenerate (all points equal): vertex a, no NaN.
        let w = closest_barycentric(DVec3::new(1.0, 2.0, 3.0), a, a, a);
        assert!(w.is_finite());
    }
}
