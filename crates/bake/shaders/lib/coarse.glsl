// The reduced-resolution gather's grid (program::coarse; cpu::coarse_weights, operation for
// operation): which corners of a texel's grid cell lie on its surface, and with what bilinear
// weight. For programs reading the slots position and normal.

// The glow backend draws a strided gather in two (program::coarse::grid_tile): its grid texels
// alone (u_grid the stride, u_grid_origin the draw's first grid column and row), then the tile
// (u_from_grid 1), whose grid texels copy the first draw's values (u_grid_values, layer 0).
// Both 0 in every other draw.
uniform int u_grid;
uniform ivec2 u_grid_origin;
uniform int u_from_grid;
uniform highp sampler2DArray u_grid_values;

// The layout's texel of texel c of the draw: c itself, or in the grid draw the grid texel
// ((c.xy + u_grid_origin) · u_grid) of c's layer.
ivec3 luxGridTexel(ivec3 c) {
    return u_grid > 1 ? ivec3((c.xy + u_grid_origin) * u_grid, c.z) : c;
}

// Whether texel c of the tile's draw after the grid's is a grid texel (at `stride`), whose
// value that draw copies.
bool luxGridCopied(ivec3 c, uint stride) {
    int s = int(stride);
    return u_from_grid != 0 && s > 1 && c.x % s == 0 && c.y % s == 0;
}

// The weights of texel c's grid-cell corners (order (x0, y0), (x1, y0), (x0, y1), (x1, y1))
// that lie on c's surface, 0 for the others (all 0 where c lies in a narrow gap); returns their
// sum.
float luxCoarseWeights(ivec3 c, uint stride, float reach, out ivec2 corners[4],
                       out float weights[4]) {
    int s = int(max(stride, 1u));
    ivec2 size = textureSize(u_position, 0).xy;
    int x0 = c.x / s * s;
    int y0 = c.y / s * s;
    float fx = float(c.x - x0) / float(s);
    float fy = float(c.y - y0) / float(s);
    corners = ivec2[4](ivec2(x0, y0), ivec2(x0 + s, y0), ivec2(x0, y0 + s), ivec2(x0 + s, y0 + s));
    float bilinear[4] = float[4]((1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy,
                                 fx * fy);
    weights = float[4](0.0, 0.0, 0.0, 0.0);
    vec4 nc = texelFetch(u_normal, c, 0);
    vec4 pc = texelFetch(u_position, c, 0);
    vec3 p = pc.xyz;
    vec3 n;
    // A texel in a narrow gap (validity::NARROW) counts no corner: an orphan.
    if (!luxNormalize(nc.xyz, n) || pc.w >= LUX_NARROW) {
        return 0.0;
    }
    float reach2 = reach * reach;
    float total = 0.0;
    for (int i = 0; i < 4; ++i) {
        ivec2 t = corners[i];
        if (!(bilinear[i] > 0.0) || t.x >= size.x || t.y >= size.y) {
            continue;
        }
        ivec3 tc = ivec3(t, c.z);
        vec4 pt = texelFetch(u_position, tc, 0);
        if (pt.w <= 0.5) {
            continue;
        }
        vec4 nt = texelFetch(u_normal, tc, 0);
        // The G-buffer's normals are unit: used as stored (as cpu::kernel::CoarseCentre).
        if (nt.w != nc.w || !(luxDot(n, nt.xyz) >= LUX_BLUR_NORMAL_COS)) {
            continue;
        }
        vec3 d = pt.xyz - p;
        int ox = t.x - c.x;
        int oy = t.y - c.y;
        if (!(luxDot(d, d) <= reach2 * float(ox * ox + oy * oy))) {
            continue;
        }
        weights[i] = bilinear[i];
        total += bilinear[i];
    }
    return total;
}

// cpu::coarse_rays: the rays the gather at `stride` casts at texel c: `rays` at every texel at
// stride 1, at grid texels and in a narrow gap, `orphanRays` at the other orphans (no corner on
// c's surface), else 0.
uint luxCoarseRays(ivec3 c, uint stride, float reach, uint rays, uint orphanRays) {
    int s = int(stride);
    if (s <= 1 || (c.x % s == 0 && c.y % s == 0) || texelFetch(u_position, c, 0).w >= LUX_NARROW) {
        return rays;
    }
    ivec2 corners[4];
    float weights[4];
    return luxCoarseWeights(c, stride, reach, corners, weights) > 0.0 ? 0u : orphanRays;
}
