// The reduced-resolution gather's grid (program::coarse; cpu::coarse_weights, operation for
// operation): which corners of a texel's grid cell lie on its surface, and with what bilinear
// weight. For programs reading the slots position and normal.

struct LuxCoarse {
    corners: array<vec2<i32>, 4>,
    weights: array<f32, 4>,
    total: f32,
}

// The weights of texel c's grid-cell corners (order (x0, y0), (x1, y0), (x0, y1), (x1, y1))
// that lie on c's surface, 0 for the others (all 0 where c lies in a narrow gap), and their sum.
fn lux_coarse_weights(c: vec2<i32>, stride: u32, reach: f32) -> LuxCoarse {
    var r: LuxCoarse;
    let s = i32(max(stride, 1u));
    let x0 = c.x / s * s;
    let y0 = c.y / s * s;
    let fx = f32(c.x - x0) / f32(s);
    let fy = f32(c.y - y0) / f32(s);
    r.corners = array<vec2<i32>, 4>(vec2<i32>(x0, y0), vec2<i32>(x0 + s, y0),
                                    vec2<i32>(x0, y0 + s), vec2<i32>(x0 + s, y0 + s));
    // A variable, not a value: naga's SPIR-V copies an array value at every access with a
    // variable index.
    var bilinear = array<f32, 4>((1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy,
                                 fx * fy);
    r.weights = array<f32, 4>(0.0, 0.0, 0.0, 0.0);
    r.total = 0.0;
    let nc = lux_load(lux_normal, c);
    let pc = lux_load(lux_position, c);
    let p = pc.xyz;
    var n: vec3<f32>;
    // A texel in a narrow gap (validity::NARROW) counts no corner: an orphan.
    if (!lux_normalize(nc.xyz, &n) || pc.w >= LUX_NARROW) {
        return r;
    }
    let reach2 = reach * reach;
    for (var i = 0; i < 4; i++) {
        let t = r.corners[i];
        if (!(bilinear[i] > 0.0) || t.x >= i32(lux_tile.layer_w) || t.y >= i32(lux_tile.layer_h)) {
            continue;
        }
        let pt = lux_load(lux_position, t);
        if (pt.w <= 0.5) {
            continue;
        }
        let nt = lux_load(lux_normal, t);
        // The G-buffer's normals are unit: used as stored (as cpu::kernel::CoarseCentre).
        if (nt.w != nc.w || !(lux_dot(n, nt.xyz) >= LUX_BLUR_NORMAL_COS)) {
            continue;
        }
        let d = pt.xyz - p;
        let ox = t.x - c.x;
        let oy = t.y - c.y;
        if (!(lux_dot(d, d) <= reach2 * f32(ox * ox + oy * oy))) {
            continue;
        }
        r.weights[i] = bilinear[i];
        r.total += bilinear[i];
    }
    return r;
}

// cpu::coarse_rays: the rays the gather at `stride` casts at texel c: `rays` at every texel at
// stride 1, at grid texels and in a narrow gap, `orphan_rays` at the other orphans (no corner
// on c's surface), else 0.
fn lux_coarse_rays(c: vec2<i32>, stride: u32, reach: f32, rays: u32, orphan_rays: u32) -> u32 {
    let s = i32(stride);
    if (s <= 1 || (c.x % s == 0 && c.y % s == 0) || lux_load(lux_position, c).w >= LUX_NARROW) {
        return rays;
    }
    return select(orphan_rays, 0u, lux_coarse_weights(c, stride, reach).total > 0.0);
}
