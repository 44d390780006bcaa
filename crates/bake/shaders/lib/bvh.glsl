// Stackless BVH traversal over the encoded textures of luxbake-bvh, line for line the CPU code
// of `luxbake_bvh::traverse` (WatertightRay::new / hits_box / hits_triangle, EncodedScene::walk /
// brute_force). The LUX_* texel-layout constants are generated from `luxbake_bvh::layout` and
// prefixed at run time, so the two cannot drift.
//
// Compile-time selection: LUX_TRAVERSAL is LUX_TRAVERSAL_MTBVH (u_links = the 6-layer MTBVH
// links, layer = dominant ray direction), LUX_TRAVERSAL_TBVH (u_links = the 1-layer TBVH links,
// layer 0) or LUX_TRAVERSAL_NONE (every triangle tested; no node texture is read).

uniform highp sampler2DArray u_triangles; // LUX_TRIANGLE_LAYERS layers, triangle t at (t % w, t / w)
uniform int u_triangle_count;
#if LUX_TRAVERSAL != LUX_TRAVERSAL_NONE
uniform highp sampler2DArray u_bounds;    // LUX_BOUNDS_LAYERS layers
uniform highp sampler2DArray u_links;     // MTBVH (6 layers) or TBVH (1 layer) links
uniform int u_node_count;
#endif

// traverse::dominant_axis: ties prefer x, then y.
int luxDominantAxis(vec3 d) {
    vec3 a = abs(d);
    return (a.x >= a.y && a.x >= a.z) ? 0 : (a.y >= a.z ? 1 : 2);
}

// traverse::dominant_direction: the MTBVH link layer, 2 * axis + (negative ? 1 : 0).
int luxDominantDirection(vec3 d) {
    int k = luxDominantAxis(d);
    return 2 * k + (d[k] < 0.0 ? 1 : 0);
}

// traverse::WatertightRay.
struct LuxRay {
    vec3 origin;
    int kx;
    int ky;
    int kz;
    float sx;
    float sy;
    float sz;
    vec3 inv;
    bvec3 parallel;
};

// WatertightRay::new; false for a zero or non-finite direction (no hit).
bool luxRaySetup(vec3 origin, vec3 dir, out LuxRay r) {
    int kz = luxDominantAxis(dir);
    bool finite = !any(isnan(dir)) && !any(isinf(dir)) && !any(isnan(origin))
        && !any(isinf(origin));
    if (!finite || dir[kz] == 0.0) {
        return false;
    }
    int kx = kz + 1;
    if (kx == 3) kx = 0;
    int ky = kx + 1;
    if (ky == 3) ky = 0;
    if (dir[kz] < 0.0) {
        int tmp = kx;
        kx = ky;
        ky = tmp;
    }
    r.origin = origin;
    r.kx = kx;
    r.ky = ky;
    r.kz = kz;
    r.parallel = lessThan(abs(dir), vec3(LUX_PARALLEL_EPSILON));
    r.inv = vec3(1.0) / mix(dir, vec3(1.0), r.parallel);
    r.sx = dir[kx] / dir[kz];
    r.sy = dir[ky] / dir[kz];
    r.sz = 1.0 / dir[kz];
    return true;
}

// WatertightRay::hits_box: slab test on [tMin, tMax], entry and exit widened by LUX_BOX_SLACK.
bool luxHitsBox(LuxRay r, vec3 bmin, vec3 bmax, float tMin, float tMax) {
    float boxNear = -LUX_BIG;
    float boxFar = LUX_BIG;
    for (int a = 0; a < 3; ++a) {
        float t0 = (bmin[a] - r.origin[a]) * r.inv[a];
        float t1 = (bmax[a] - r.origin[a]) * r.inv[a];
        bool inside = bmin[a] <= r.origin[a] && r.origin[a] <= bmax[a];
        float lo = r.parallel[a] ? (inside ? -LUX_BIG : LUX_BIG) : min(t0, t1);
        float hi = r.parallel[a] ? (inside ? LUX_BIG : -LUX_BIG) : max(t0, t1);
        boxNear = max(boxNear, lo);
        boxFar = min(boxFar, hi);
    }
    float tNear = max(tMin, boxNear - abs(boxNear) * LUX_BOX_SLACK);
    float tFar = min(tMax, boxFar + abs(boxFar) * LUX_BOX_SLACK);
    return tNear <= tFar;
}

// WatertightRay::hits_triangle: true with (t, u, v) when t is in (tMin, tMax).
bool luxHitsTriangle(LuxRay r, vec3 p0, vec3 p1, vec3 p2, float tMin, float tMax,
                     out vec3 tuv) {
    vec3 a = p0 - r.origin;
    vec3 b = p1 - r.origin;
    vec3 c = p2 - r.origin;
    float ax = a[r.kx] - r.sx * a[r.kz];
    float ay = a[r.ky] - r.sy * a[r.kz];
    float bx = b[r.kx] - r.sx * b[r.kz];
    float by = b[r.ky] - r.sy * b[r.kz];
    float cx = c[r.kx] - r.sx * c[r.kz];
    float cy = c[r.ky] - r.sy * c[r.kz];
    // Edge functions, all in the antisymmetric form e(P, Q) = P.x * Q.y - P.y * Q.x.
    float u = cx * by - cy * bx;
    float v = ax * cy - ay * cx;
    float w = bx * ay - by * ax;
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) {
        return false;
    }
    float det = u + v + w;
    if (det == 0.0) {
        return false;
    }
    float az = r.sz * a[r.kz];
    float bz = r.sz * b[r.kz];
    float cz = r.sz * c[r.kz];
    float t = (u * az + v * bz + w * cz) / det;
    if (!(t > tMin && t < tMax)) {
        return false;
    }
    tuv = vec3(t, v / det, w / det);
    return true;
}

// EncodedScene::coord_of for the triangle textures.
ivec2 luxTriangleCoord(int t) {
    int w = max(textureSize(u_triangles, 0).x, 1);
    return ivec2(t % w, t / w);
}

// EncodedScene::triangle_test: three texelFetches, then the watertight test.
bool luxTriangleTest(LuxRay r, int t, float tMin, float tMax, out vec3 tuv) {
    ivec2 c = luxTriangleCoord(t);
    vec3 p0 = texelFetch(u_triangles, ivec3(c, LUX_TRI_P0_LAYER), 0).xyz;
    vec3 p1 = texelFetch(u_triangles, ivec3(c, LUX_TRI_P1_LAYER), 0).xyz;
    vec3 p2 = texelFetch(u_triangles, ivec3(c, LUX_TRI_P2_LAYER), 0).xyz;
    return luxHitsTriangle(r, p0, p1, p2, tMin, tMax, tuv);
}

// EncodedScene::closest_hit / any_hit: the encoded index of the closest (or, with anyHit, the
// first found) triangle hit with t in (tMin, tMax), or -1; hit = (t, u, v).
int luxTrace(vec3 origin, vec3 dir, float tMin, float tMax, bool anyHit, out vec3 hit) {
    hit = vec3(tMax, 0.0, 0.0);
    LuxRay r;
    if (!luxRaySetup(origin, dir, r)) {
        return -1;
    }
    float closest = tMax;
    int best = -1;
    vec2 bary = vec2(0.0);
    vec3 tuv;
#if LUX_TRAVERSAL == LUX_TRAVERSAL_NONE
    // EncodedScene::brute_force.
    for (int t = 0; t < u_triangle_count; ++t) {
        if (luxTriangleTest(r, t, tMin, closest, tuv)) {
            closest = tuv.x;
            best = t;
            bary = tuv.yz;
            if (anyHit) {
                break;
            }
        }
    }
#else
    // EncodedScene::walk.
#if LUX_TRAVERSAL == LUX_TRAVERSAL_MTBVH
    int layer = luxDominantDirection(dir);
#else
    int layer = 0;
#endif
    ivec2 node = ivec2(LUX_ROOT_X, LUX_ROOT_Y);
    bool done = false;
    for (int steps = 0; steps < u_node_count && node.x >= 0 && !done; ++steps) {
        vec4 lo = texelFetch(u_bounds, ivec3(node, LUX_BOUNDS_MIN_LAYER), 0);
        vec4 hi = texelFetch(u_bounds, ivec3(node, LUX_BOUNDS_MAX_LAYER), 0);
        vec4 link = texelFetch(u_links, ivec3(node, layer), 0);
        if (luxHitsBox(r, lo.xyz, hi.xyz, tMin, closest)) {
            int end = min(int(hi.w), u_triangle_count);
            for (int t = int(lo.w); t < end; ++t) {
                if (luxTriangleTest(r, t, tMin, closest, tuv)) {
                    closest = tuv.x;
                    best = t;
                    bary = tuv.yz;
                    if (anyHit) {
                        done = true;
                        break;
                    }
                }
            }
            node = ivec2(link.xy);
        } else {
            node = ivec2(link.zw);
        }
    }
#endif
    hit = vec3(closest, bary);
    return best;
}
