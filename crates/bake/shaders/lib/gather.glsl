// The gather's ray loop, shared by the gather and refine passes (cpu::gather_rays, operation
// for operation). For programs reading the slot `reflected`; objects' regions are in
// u_regions (scene.glsl); non-receivers reflect nothing.

// exact::basis: orthonormal basis around unit n (Duff et al. 2017); copysign via the sign bit.
void luxBasis(vec3 n, out vec3 t, out vec3 b) {
    float s = (floatBitsToUint(n.z) & 0x80000000u) != 0u ? -1.0 : 1.0;
    float a = -1.0 / (s + n.z);
    float bb = n.x * n.y * a;
    t = vec3(1.0 + s * n.x * n.x * a, s * bb, -s * n.x);
    b = vec3(bb, s + n.y * n.y * a, -n.y);
}

// cpu::Frame::cosine_direction, or with `uniform` Frame::uniform_direction (the rays of a
// texel in a narrow gap, lightpaths::gather_weight).
vec3 luxGatherDirection(vec3 n, vec2 u, bool uniformRays) {
    const float TWO_PI = 6.28318530717959;
    vec3 t;
    vec3 b;
    luxBasis(n, t, b);
    float r = uniformRays ? sqrt(max(u.x * (2.0 - u.x), 0.0)) : sqrt(u.x);
    float phi = TWO_PI * u.y;
    float x = r * cos(phi);
    float y = r * sin(phi);
    float z = uniformRays ? 1.0 - u.x : sqrt(max(1.0 - u.x, 0.0));
    return vec3(t.x * x + b.x * y + n.x * z, t.y * x + b.y * y + n.y * z,
                t.z * x + b.z * y + n.z * z);
}

// One corner of luxSampleMasked: texel `at` of the reflected map (or, with `albedo`, of the
// albedo map) added with weight w where the reflected map is valid.
void luxMaskedTap(ivec3 at, float w, bool albedo, inout vec3 sum, inout float wsum) {
    vec4 t = texelFetch(u_reflected, at, 0);
    if (t.a > 0.5) {
        sum += w * (albedo ? texelFetch(u_albedo, at, 0).rgb : t.rgb);
        wsum += w;
    }
}

// map::sample_masked: masked bilinear look-up of light-map UV `uv` in a region of the
// reflected map; with `albedo` the albedo map's (slot `albedo`) with the reflected map's mask
// and weights (gather::GatherParams::direct_at_hits).
vec3 luxSampleMasked(int layer, ivec2 offset, ivec2 size, vec2 uv, bool albedo) {
    if (size.x == 0 || size.y == 0 || !luxFinite(uv.x) || !luxFinite(uv.y)) {
        return vec3(0.0);
    }
    float fx = clamp(uv.x * float(size.x) - 0.5, 0.0, float(size.x - 1));
    float fy = clamp(uv.y * float(size.y) - 0.5, 0.0, float(size.y - 1));
    float x0f = floor(fx);
    float y0f = floor(fy);
    float tx = fx - x0f;
    float ty = fy - y0f;
    int x0 = int(x0f);
    int y0 = int(y0f);
    int x1 = min(x0 + 1, size.x - 1);
    int y1 = min(y0 + 1, size.y - 1);
    // The four corners in the CPU's order, each by a call rather than from an array (a variable
    // index into one keeps it in memory on some drivers).
    vec3 sum = vec3(0.0);
    float wsum = 0.0;
    luxMaskedTap(ivec3(offset + ivec2(x0, y0), layer), (1.0 - tx) * (1.0 - ty), albedo, sum,
                 wsum);
    luxMaskedTap(ivec3(offset + ivec2(x1, y0), layer), tx * (1.0 - ty), albedo, sum, wsum);
    luxMaskedTap(ivec3(offset + ivec2(x0, y1), layer), (1.0 - tx) * ty, albedo, sum, wsum);
    luxMaskedTap(ivec3(offset + ivec2(x1, y1), layer), tx * ty, albedo, sum, wsum);
    if (wsum > 0.0) {
        return vec3(sum.x / wsum, sum.y / wsum, sum.z / wsum);
    }
    return vec3(0.0);
}

// lightpaths::density: the lamps' unshadowed luminance-weighted illuminance at y (unit normal
// n) over the first `lamps` uploaded lamps, each lamp's intensity from its density proxy, the
// lamp paths' density proxy.
float luxLampDensity(vec3 y, vec3 n, int lamps) {
    float sum = 0.0;
    for (int li = 0; li < lamps; ++li) {
        vec4 l0 = luxLamp(li, 0);
        vec3 to = l0.xyz - y;
        float d2 = luxDot(to, to);
        if (!(d2 > 0.0 && luxFinite(d2))) {
            continue;
        }
        float c = luxDot(n, to);
        if (!(c > 0.0)) {
            continue;
        }
        vec3 back = -to;
        vec3 photometric = vec3(luxDot(luxLamp(li, 1).xyz, back), luxDot(luxLamp(li, 2).xyz, back),
                                luxDot(luxLamp(li, 3).xyz, back));
        float intensity = luxProxySample(int(l0.w), int(luxLamp(li, 5).z), photometric);
        if (intensity > 0.0) {
            sum += luxLuminance(luxLamp(li, 4).rgb) * (intensity * c / (d2 * sqrt(d2)));
        }
    }
    return sum;
}

// lightpaths::gather_weight: a gather hit's share of the reflected exitance (1 for the
// cosine-weighted rays, 2 cx for a gap's uniform ones) times the balance heuristic against `k`
// lamp paths.
float luxGatherWeight(uint rays, uint k, float scale, float density, float r, float cx, float cy,
                      bool uniformRays) {
    float pdf = uniformRays ? 0.5 : cx;
    float share = uniformRays ? 2.0 * cx : 1.0;
    if (k == 0u) {
        return share;
    }
    float v = 3.14159265358979 * float(k) * (scale * density) * (r * r);
    if (!(v > 0.0)) {
        return share;
    }
    float g = float(rays) * (pdf * cy);
    float d = g + v;
    return luxFinite(d) ? share * (g / d) : 0.0;
}

// cpu::gather_rays: the sum of the reflected exitance seen along rays `firstRay .. firstRay + count`
// of the texel's draws (`stream`: rng::Stream's key and first index), cast from `origin` around
// the unit normal `n`, each weighted against `lampPaths` lamp paths of a gather of `misRays`
// rays (lightpaths; 0: weight 1). With directAtHits = 1 a hit away from every lamp's opening
// reads the lamps' direct light there times its albedo (luxPointLampsAt,
// gather::GatherParams::direct_at_hits). With `uniform` (a texel in a narrow gap) the rays
// are drawn uniformly over the hemisphere and weighted by their share (luxGatherWeight).
vec3 luxGatherSum(vec3 origin, vec3 n, uvec2 stream, uint firstRay, uint count,
                  uint samplerId, uint bounce, uint seed, uint lampPaths, uint misRays,
                  float densityScale, int lamps, uint directAtHits, bool uniformRays) {
    float infinity = uintBitsToFloat(0x7f800000u);
    int objects = textureSize(u_regions, 0).x;
    vec3 sum = vec3(0.0);
    for (uint s = firstRay; s < firstRay + count; ++s) {
        vec3 dir = luxGatherDirection(n, luxSample2(samplerId, stream.x, stream.y + s, bounce,
                                                    seed), uniformRays);
        vec3 hit;
#ifdef LUX_REPLAY
        // Kept hits (luxbake::kept): the hit this ray had when its trace pass cast it,
        // (t, triangle, u, v), from layer `s - firstRay` of u_hits at the texel's place in the
        // tile (u_hit_origin its first texel).
        vec4 kept = texelFetch(u_hits, ivec3(ivec2(gl_FragCoord.xy) - u_hit_origin,
                                             int(s - firstRay)), 0);
        int tri = int(kept.y);
        hit = kept.xzw;
#else
        int tri = luxTrace(origin, dir, 0.0, infinity, false, hit);
#endif
        if (tri < 0) {
            continue;
        }
        ivec2 tc = luxTriangleCoord(tri);
        vec4 uv2Object = texelFetch(u_triangles, ivec3(tc, LUX_TRI_UV2_OBJECT_LAYER), 0);
        int object = int(uv2Object.z);
        if (object < 0 || object >= objects) {
            continue;
        }
        vec4 region0 = texelFetch(u_regions, ivec3(object, 0, 0), 0);
        if (region0.w <= 0.5) {
            continue;
        }
        vec4 region1 = texelFetch(u_regions, ivec3(object, 1, 0), 0);
        float u = hit.y;
        float v = hit.z;
        float w0 = 1.0 - u - v;
        vec3 n0 = texelFetch(u_triangles, ivec3(tc, LUX_TRI_N0_LAYER), 0).xyz;
        vec3 n1 = texelFetch(u_triangles, ivec3(tc, LUX_TRI_N1_LAYER), 0).xyz;
        vec3 n2 = texelFetch(u_triangles, ivec3(tc, LUX_TRI_N2_LAYER), 0).xyz;
        vec3 nh = vec3(w0 * n0.x + u * n1.x + v * n2.x, w0 * n0.y + u * n1.y + v * n2.y,
                       w0 * n0.z + u * n1.z + v * n2.z);
        if (!(luxDot(nh, dir) < 0.0)) {
            continue;
        }
        vec4 uv01 = texelFetch(u_triangles, ivec3(tc, LUX_TRI_UV01_LAYER), 0);
        vec2 uv = vec2(w0 * uv01.x + u * uv01.z + v * uv2Object.x,
                       w0 * uv01.y + u * uv01.w + v * uv2Object.y);
        // The hit's point, for the direct light there and the lamp paths' weight.
        vec3 y = vec3(origin.x + hit.x * dir.x, origin.y + hit.x * dir.y,
                      origin.z + hit.x * dir.z);
        vec3 m;
#ifndef LUX_REPLAY
        // Not in the replay: a gather with the direct light at its hits keeps no hits
        // (kept::replayable), and the replay stays a look-up without the lamps' shadow rays.
        vec3 e;
        vec3 nd;
        if (directAtHits != 0u && luxNormalize(nh, nd) && luxPointLampsAt(y, nd, lamps, e)) {
            vec3 a = luxSampleMasked(int(region0.x), ivec2(region0.yz), ivec2(region1.xy), uv,
                                     true);
            m = vec3(a.x * e.x, a.y * e.y, a.z * e.z);
        } else
#endif
        {
            m = luxSampleMasked(int(region0.x), ivec2(region0.yz), ivec2(region1.xy), uv, false);
        }
        float weight = uniformRays ? 2.0 * luxDot(n, dir) : 1.0;
        // Nothing to weigh where the hit reflects no light (cpu::GatherChunk::sum).
        if (lampPaths > 0u && (m.x != 0.0 || m.y != 0.0 || m.z != 0.0)) {
            vec3 ny;
            if (!luxNormalize(nh, ny)) {
                ny = vec3(0.0);
            }
            float density = luxLampDensity(y, ny, lamps);
            weight = luxGatherWeight(misRays, lampPaths, densityScale, density, hit.x,
                                     luxDot(n, dir), -luxDot(ny, dir), uniformRays);
        }
        sum += weight * m;
    }
    return sum;
}
