//! Slivers: triangles that are degenerate at `f32` precision, encoded so that they are never hit.
//!
//! The watertight test ([`crate::WatertightRay::hits_triangle`]) decides a hit from the signs
//! of three edge functions and takes `t` as their weighted mean of the vertices' depths. For a
//! triangle whose vertices lie on a line (up to the rounding of their coordinates), the exact
//! edge functions of a ray passing through or near that line are all zero or within rounding of
//! zero: their computed values are rounding noise. When the noise happens to give them one sign
//! (for example `0, 0, +ε`) the test reports a hit, with barycentrics and `t` that are noise
//! too: the hit point is anywhere along the ray between the vertices' depths, possibly far
//! outside the triangle and its bounding box. The tree traversals then disagree with brute force
//! (their boxes cull the ray before the test), and a bake sees a shadow speck or a light leak
//! where nothing is. Woop, Benthin & Wald (2013) recompute zero edge functions in double
//! precision; GLSL ES has no doubles, and such a triangle has no area to hit anyway.
//!
//! So [`crate::encode`] writes a sliver's three position texels as its first vertex, three
//! times: all three sheared vertices are then equal, every edge function is `x·y − y·x`, exactly
//! 0 (as for the zero-area triangles padding [`crate::WideBvh`]'s packets), `det` is 0 and no
//! traversal (brute force, TBVH, MTBVH, the wide BVH, the GLSL and WGSL shaders, which read the
//! same texels) ever reports a hit on it. Nothing else changes: the tree, the triangle order and
//! count, the leaf ranges and the attribute texels are the same, so the other triangles' hits
//! are unchanged bit for bit, and a scene without slivers encodes exactly as before.

/// A triangle is a sliver when its height over its longest edge is at most this many units of
/// `f32::EPSILON × m`, `m` the largest coordinate magnitude of its vertices (so about this many
/// ulps of its largest coordinate): its vertices lie within a few roundings of a line.
///
/// A vertex rounded onto the line through the other two (a midpoint `0.5·a + 0.5·b` computed
/// in `f32`) lies within `√3 / 2` such units of it; 4 leaves room for a few more roundings
/// (a transformed collinear triangle). Triangles of real models are far above it: the thinnest
/// of SheenChair (39 936 triangles) is 1 413 units high, of GlamVelvetSofa 3 882, of the
/// procedural room 55 436.
pub const SLIVER_HEIGHT_ULPS: f64 = 4.0;

/// Whether `tri` is a sliver: its height over its longest edge (twice its area over that edge's
/// length, computed in `f64` from the `f32` coordinates) is at most [`SLIVER_HEIGHT_ULPS`] ×
/// `f32::EPSILON` × its largest coordinate magnitude. Points, segments (two equal vertices)
/// and exactly collinear triangles are slivers. Non-finite input is not.
///
/// [`crate::encode`] collapses every sliver to its first vertex, so it is never hit; see the
/// crate docs ("Slivers").
///
/// ```
/// use luxbake_bvh::is_sliver;
///
/// let a = [0.7086488f32, 0.39277095, 0.50476086];
/// let b = [1.0859984f32, 0.56056345, 0.43668592];
/// let mid = [0, 1, 2].map(|k| a[k] * 0.5 + b[k] * 0.5);
/// assert!(is_sliver(&[a, b, mid]));
/// assert!(is_sliver(&[a, a, a]));
/// assert!(!is_sliver(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 1e-5, 0.0]]));
/// ```
pub fn is_sliver(tri: &[[f32; 3]; 3]) -> bool {
    let p = tri.map(|v| v.map(f64::from));
    if !p.iter().flatten().all(|c| c.is_finite()) {
        return false;
    }
    let sub = |i: usize, j: usize| [0, 1, 2].map(|k| p[j][k] - p[i][k]);
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let (e0, e1, e2) = (sub(0, 1), sub(1, 2), sub(2, 0));
    let n = [
        e0[1] * e2[2] - e0[2] * e2[1],
        e0[2] * e2[0] - e0[0] * e2[2],
        e0[0] * e2[1] - e0[1] * e2[0],
    ];
    // (2·area)² ≤ (k·ε·m)² · longest² (squares: no division, and a point is 0 ≤ 0).
    let longest2 = dot(e0, e0).max(dot(e1, e1)).max(dot(e2, e2));
    let m = p.iter().flatten().fold(0.0f64, |m, c| m.max(c.abs()));
    let h = SLIVER_HEIGHT_ULPS * f64::from(f32::EPSILON) * m;
    dot(n, n) <= h * h * longest2
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slivers_and_thin_triangles() {
        let a = [0.7086488f32, 0.39277095, 0.50476086];
        let b = [1.0859984f32, 0.56056345, 0.43668592];
        let mid = [0, 1, 2].map(|k| a[k] * 0.5 + b[k] * 0.5);
        for tri in [
            [a, b, mid],
            [mid, a, b],
            [a, a, a],
            [a, b, b],
            [[0.0; 3]; 3],
        ] {
            assert!(is_sliver(&tri), "{tri:?}");
        }
        // A vertex 2 ulps (of 1.5) off the line through (1, 1, 1) and (2, 2, 1) is √2·ε from
        // it, under the bound 4·ε·2: a sliver; 32 ulps off (22.6·ε) is not.
        let one = [1.0f32, 1.0, 1.0];
        let far = [2.0f32, 2.0, 1.0];
        let near = |ulps: f32| [1.5f32, 1.5 + ulps * f32::EPSILON * 2.0, 1.0];
        assert!(is_sliver(&[one, far, near(1.0)]));
        assert!(!is_sliver(&[one, far, near(16.0)]));
        // Small but well-shaped triangles far from the origin are not slivers.
        let c = 1000.0f32;
        assert!(!is_sliver(&[
            [c, c, c],
            [c + 0.001, c, c],
            [c, c + 0.001, c]
        ]));
        // Subnormal but well-shaped: not a sliver (the test is relative).
        assert!(!is_sliver(&[
            [0.0, 0.0, 0.0],
            [1e-40, 0.0, 0.0],
            [0.0, 1e-40, 0.0]
        ]));
        // Huge coordinates do not overflow the f64 arithmetic.
        assert!(!is_sliver(&[
            [f32::MAX, 0.0, 0.0],
            [0.0, f32::MAX, 0.0],
            [f32::MIN, f32::MIN, 0.0]
        ]));
        assert!(!is_sliver(&[
            [f32::NAN, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0]
        ]));
    }
}
