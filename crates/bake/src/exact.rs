//! The few vector operations that must agree bit for bit: with the shaders, and between the
//! native and the wasm32 builds of the CPU steps that feed every backend.
//!
//! Every CPU path whose result a shader also computes — the CPU reference backend
//! ([`crate::cpu`]), the lamps seen from a point ([`crate::backend::lamp_toward`]), the lamp
//! paths ([`crate::lightpaths`]) — and the host steps that prepare what all backends read (the
//! G-buffer's normals, [`crate::gbuffer`]; texel validity, [`crate::validity`]) use these
//! functions and only these for their vector arithmetic. Everything else (geometry set-up in
//! `f64`, the viewer's camera) uses [`glam`].
//!
//! # Why not glam
//! The results must not depend on how an operation is written, so each function fixes its
//! order of operations and its rounding, and its shader twin is written operation for operation
//! the same way:
//! - **Dot products are summed left to right**: `(a.x·b.x + a.y·b.y) + a.z·b.z`. GLSL's and
//!   WGSL's built-in `dot` may sum in any order or fuse, so the shaders call
//!   `luxDot` / `lux_dot`.
//! - **Normalisation divides** each component by the length: `v / |v|`. glam's `normalize`
//!   multiplies by `1 / |v|` (`length_recip`), which rounds twice and changes last bits (and
//!   its `try_normalize` draws the zero/non-finite line elsewhere).
//! - **No fused multiply-add.** Rust never contracts `a + b * s` into an FMA (nor
//!   reassociates); a shader compiler may contract (GLSL without `precise`), which the CPU
//!   side cannot follow: there the shaders' result is what it is, and the CPU keeps the
//!   unfused one.
//!
//! Each function's doc names its GLSL twin (in `shaders/lib/*.glsl` or a pass's `.glsl`) and
//! its WGSL twin. Functions without a shader twin say so: they run on the CPU only but feed
//! every backend, so they must give the same bits in the native and the wasm32 builds, which
//! plain IEEE `f32`/`f64` arithmetic and `sqrt` (correctly rounded) do.
//!
//! The functions are `#[inline]` and take `[f32; 3]` as the hot loops store their vectors, so
//! calling them costs nothing over the hand-written expressions.

/// `a·b` summed left to right: `a[0]·b[0] + a[1]·b[1] + a[2]·b[2]`.
///
/// GLSL: `luxDot` (`shaders/lib/common.glsl`); WGSL: `lux_dot` (`shaders/lib/common.wgsl`).
#[inline]
pub fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `a − b`, per component.
///
/// GLSL and WGSL: the vector operator `a - b`, one rounding per component (e.g. `o0 - p` in
/// `luxRun`, `passes/direct/direct.glsl`, and `lux_run`, `direct.wgsl`).
#[inline]
pub fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `a + b·s`, per component: a product rounded, then a sum rounded (no fused multiply-add).
///
/// GLSL and WGSL: `p + n * s` (the direct pass's near-lamp origin `p + n * (0.25 * d)` in
/// `luxRun`, `passes/direct/direct.glsl`, and `lux_run`, `direct.wgsl`); a driver may fuse it
/// there.
#[inline]
pub fn mad(a: [f32; 3], b: [f32; 3], s: f32) -> [f32; 3] {
    [a[0] + b[0] * s, a[1] + b[1] * s, a[2] + b[2] * s]
}

/// `v / s`, dividing each component (never multiplying by `1 / s`).
///
/// GLSL: `vec3(v.x / s, v.y / s, v.z / s)` (in `luxNormalize`, `shaders/lib/common.glsl`, and
/// `luxLampToward`, `shaders/lib/lamp.glsl`); WGSL: `vec3<f32>(v.x / s, v.y / s, v.z / s)` (in
/// `lux_normalize`, `common.wgsl`, and `lux_lamp_toward`, `lamp.wgsl`).
#[inline]
pub fn div(v: [f32; 3], s: f32) -> [f32; 3] {
    [v[0] / s, v[1] / s, v[2] / s]
}

/// `a × b`: `(a.y·b.z − a.z·b.y, a.z·b.x − a.x·b.z, a.x·b.y − a.y·b.x)`, each difference of two
/// rounded products.
///
/// No shader twin: only the validity test ([`crate::validity`], on the CPU for every backend)
/// takes a triangle's geometric normal. glam's `Vec3::cross` computes the same expressions.
#[inline]
pub fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `v / |v|` ([`div`]), `|v|` the square root of [`dot`]`(v, v)`; `None` for a zero or
/// non-finite length. The normalisation of every pass (`n̂` in [`crate::cpu`]'s docs).
///
/// GLSL: `luxNormalize` (`shaders/lib/common.glsl`, `false` for `None`); WGSL:
/// `lux_normalize` (`shaders/lib/common.wgsl`).
#[inline]
pub fn normalize(v: [f32; 3]) -> Option<[f32; 3]> {
    let l = dot(v, v).sqrt();
    (l > 0.0 && l.is_finite()).then(|| div(v, l))
}

/// [`normalize`] in double precision (the scene crate's, re-exported here beside its `f32`
/// twin).
pub use luxbake_scene::normalize_f64;

/// Orthonormal basis `(t, b)` around unit `n` (Duff et al. 2017, "Building an Orthonormal
/// Basis, Revisited"): with `s = ±1` the sign of `n.z` (of `-0.0` too), `a = −1 / (s + n.z)`,
/// `k = n.x·n.y·a`, `t = (1 + s·n.x²·a, s·k, −s·n.x)`, `b = (k, s + n.y²·a, −n.y)`.
///
/// GLSL: `luxBasis` (`shaders/lib/gather.glsl`); WGSL: `lux_basis` (`shaders/lib/gather.wgsl`);
/// both take the sign from the sign bit. Also the tangent plane of the validity test
/// ([`crate::validity`]).
#[inline]
pub fn basis(n: [f32; 3]) -> ([f32; 3], [f32; 3]) {
    let sign = 1.0f32.copysign(n[2]);
    let a = -1.0 / (sign + n[2]);
    let b = n[0] * n[1] * a;
    (
        [1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]],
        [b, sign + n[1] * n[1] * a, -n[1]],
    )
}

/// Maps NaN to 0 and clamps to `[0, f32::MAX]`: the guard on every value a pass writes, so no
/// NaN or infinity ever reaches a map.
///
/// GLSL: `luxGuard` / `luxGuard3` (`shaders/lib/common.glsl`); WGSL: `lux_guard` /
/// `lux_guard3` (`shaders/lib/common.wgsl`).
#[inline]
pub fn guard(v: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, f32::MAX)
    }
}

/// Photometric (Rec. 709) luminance of linear RGB, summed left to right:
/// `0.2126·r + 0.7152·g + 0.0722·b`.
///
/// GLSL: `luxLuminance` (`shaders/lib/common.glsl`); WGSL: `lux_luminance`
/// (`shaders/lib/common.wgsl`).
#[inline]
pub fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// A triangle's shading normal (as interpolated, not normalised) and light-map UV at the
/// barycentrics `u`, `v` of its second and third vertex: `w₀·a₀ + u·a₁ + v·a₂`, `w₀ = 1 − u −
/// v`, summed left to right — where a ray meets a surface, as the lamp paths' pool and the
/// calculation points' gather read it.
#[inline]
pub fn interpolate(attr: &luxbake_bvh::TriangleAttributes, u: f32, v: f32) -> ([f32; 3], [f32; 2]) {
    let w0 = 1.0 - u - v;
    let [n0, n1, n2] = attr.normals;
    let [t0, t1, t2] = attr.uvs;
    (
        [0, 1, 2].map(|c| w0 * n0[c] + u * n1[c] + v * n2[c]),
        [0, 1].map(|c| w0 * t0[c] + u * t1[c] + v * t2[c]),
    )
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;

    #[test]
    fn normalize_divides_rather_than_multiplying_by_the_reciprocal() {
        // A vector whose components come out differently as v / |v| and v · (1 / |v|): the
        // reason these functions exist. Searched, not hand-picked; any such vector will do.
        let v = (1..10_000)
            .map(|i| [i as f32 * 0.37, 1.0 + i as f32 * 0.011, -0.5])
            .find(|&v| {
                let l = dot(v, v).sqrt();
                let r = 1.0 / l;
                (0..3).any(|c| v[c] / l != v[c] * r)
            })
            .expect("some vector rounds differently");
        let l = dot(v, v).sqrt();
        assert_eq!(normalize(v), Some([v[0] / l, v[1] / l, v[2] / l]));
        let d = DVec3::new(0.1, 0.7, -0.3);
        let n = normalize_f64(d).expect("unit");
        assert_eq!(n, d / d.length());
    }

    #[test]
    fn normalize_refuses_zero_and_non_finite_lengths() {
        assert_eq!(normalize([0.0; 3]), None);
        assert_eq!(normalize([f32::NAN, 0.0, 1.0]), None);
        assert_eq!(normalize([f32::MAX, f32::MAX, 0.0]), None, "|v|² overflows");
        assert_eq!(normalize_f64(DVec3::ZERO), None);
        assert_eq!(normalize_f64(DVec3::new(f64::INFINITY, 0.0, 0.0)), None);
    }

    #[test]
    fn dot_sums_left_to_right_and_cross_matches_glam() {
        let (a, b) = ([1e8f32, 1.0, -1e8], [1.0f32, 1.0, 1.0]);
        // (1e8 + 1) rounds to 1e8, then − 1e8: 0, where another order would give 1.
        assert_eq!(dot(a, b), 0.0);
        let (a, b) = ([0.3f32, -1.7, 2.9], [4.1f32, 0.23, -0.77]);
        assert_eq!(
            cross(a, b),
            glam::Vec3::from(a).cross(glam::Vec3::from(b)).to_array()
        );
        assert_eq!(mad([1.0; 3], [2.0, 3.0, 4.0], 0.5), [2.0, 2.5, 3.0]);
        assert_eq!(sub([1.0; 3], [2.0, 3.0, 4.0]), [-1.0, -2.0, -3.0]);
        assert_eq!(div([1.0, 2.0, 3.0], 2.0), [0.5, 1.0, 1.5]);
    }

    #[test]
    fn guard_maps_nan_to_zero_and_clamps() {
        assert_eq!(guard(f32::NAN), 0.0);
        assert_eq!(guard(f32::INFINITY), f32::MAX);
        assert_eq!(guard(-1.0), 0.0);
        assert_eq!(guard(2.5), 2.5);
        assert_eq!(luminance([1.0, 1.0, 1.0]), 0.2126 + 0.7152 + 0.0722);
    }
}
