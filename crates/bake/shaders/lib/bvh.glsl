// Stackless BVH traversal over the encoded textures of luxbake-bvh (after common.glsl), line for
// line the CPU code of `luxbake_bvh::traverse` (WatertightRay::new / hits_box / hits_triangle,
// EncodedScene::walk / brute_force). The LUX_* texel-layout constants are generated from
// `luxbake_bvh::layout` and prefixed at run time, so the two cannot drift.
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
    return 2 * k + (luxPick(d, k) < 0.0 ? 1 : 0);
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
    float dz = luxPick(dir, kz);
    if (!finite || dz == 0.0) {
        return false;
    }
    int kx = kz + 1;
    if (kx == 3) kx = 0;
    int ky = kx + 1;
    if (ky == 3) ky = 0;
    if (dz < 0.0) {
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
    r.sx = luxPick(dir, kx) / dz;
    r.sy = luxPick(dir, ky) / dz;
    r.sz = 1.0 / dz;
    return true;
}

// WatertightRay::hits_box: slab test on [tMin, tMax], entry and exit widened by LUX_BOX_SLACK.
bool luxHitsBox(LuxRay r, vec3 bmin, vec3 bmax, float tMin, float tMax) {
    // The three axes side by side, in vectors rather than a loop over components (a variable
    // index into a vector is slow on some drivers); the same operations per axis, and the
    // nearest and farthest taken in the axes' order.
    vec3 o = r.origin;
    vec3 t0 = (bmin - o) * r.inv;
    vec3 t1 = (bmax - o) * r.inv;
    bvec3 inside = bvec3(bmin.x <= o.x && o.x <= bmax.x, bmin.y <= o.y && o.y <= bmax.y,
                         bmin.z <= o.z && o.z <= bmax.z);
    vec3 lo = mix(min(t0, t1), mix(vec3(LUX_BIG), vec3(-LUX_BIG), inside), r.parallel);
    vec3 hi = mix(max(t0, t1), mix(vec3(-LUX_BIG), vec3(LUX_BIG), inside), r.parallel);
    float boxNear = max(max(max(-LUX_BIG, lo.x), lo.y), lo.z);
    float boxFar = min(min(min(LUX_BIG, hi.x), hi.y), hi.z);
    float tNear = max(tMin, boxNear - abs(boxNear) * LUX_BOX_SLACK);
    float tFar = min(tMax, boxFar + abs(boxFar) * LUX_BOX_SLACK);
    return tNear <= tFar;
}

// (v[kx], v[ky], v[kz]) of ray r's axes (luxPick).
vec3 luxPermute(vec3 v, LuxRay r) {
    return vec3(luxPick(v, r.kx), luxPick(v, r.ky), luxPick(v, r.kz));
}

// WatertightRay::hits_triangle: true with (t, u, v) when t is in (tMin, tMax).
bool luxHitsTriangle(LuxRay r, vec3 p0, vec3 p1, vec3 p2, float tMin, float tMax,
                     out vec3 tuv) {
    // The vertices relative to the origin, permuted to (kx, ky, kz).
    vec3 a = luxPermute(p0 - r.origin, r);
    vec3 b = luxPermute(p1 - r.origin, r);
    vec3 c = luxPermute(p2 - r.origin, r);
    float ax = a.x - r.sx * a.z;
    float ay = a.y - r.sy * a.z;
    float bx = b.x - r.sx * b.z;
    float by = b.y - r.sy * b.z;
    float cx = c.x - r.sx * c.z;
    float cy = c.y - r.sy * c.z;
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
    float az = r.sz * a.z;
    float bz = r.sz * b.z;
    float cz = r.sz * c.z;
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
    ivec2 qr = luxDivMod(t, w);
    return ivec2(qr.y, qr.x);
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
