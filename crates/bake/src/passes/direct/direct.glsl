// Pass "direct" (paper Figure 4, box 2): illuminance from the pass's lamps, with shadow rays
// through the BVH (cpu::direct_texel, operation for operation).
//
// Evaluates the first u_lamp_count uploaded lamps (luxLamp, scene.glsl); near a lamp's
// luminous opening, u_samples points of it (luxOpening*, opening.glsl). With
// u_chunk_samples > 0 an opening's samples are split over dispatches, each adding its share
// to the one before (u_prior); the lamps without an opening come with the first.

// cpu::Start::sees: nothing lies between texel p (unit normal n, offset origin o0, offset
// squared off2) and x, r away (r2 its square), back the unit direction from x toward p.
bool luxSees(vec3 p, vec3 n, vec3 o0, float off2, vec3 x, vec3 back, float r, float r2) {
    vec3 origin = 16.0 * off2 > r2 ? p + n * (0.25 * r) : o0;
    vec3 dir = x - origin;
    float len = sqrt(luxDot(dir, dir));
    vec3 xOff = luxOffsetOrigin(x, back, u_ray_epsilon) - x;
    float stopShort = min(sqrt(luxDot(xOff, xOff)), 0.25 * r);
    float tMax = 1.0 - stopShort / len;
    vec3 hit;
    return !(len > 0.0 && tMax > 0.0 && luxTrace(origin, dir, 0.0, tMax, true, hit) >= 0);
}

// cpu::from_opening: the illuminance at p from lattice points of lamp li's opening
// (luxTexelSamples of u_samples), shared among the parts p can see, before the lamp's scale;
// the points whose index over the parts lies in [first, end).
float luxFromOpening(int li, LuxOpening o, vec3 p, vec3 n, vec3 o0, float off2, uvec2 shift,
                     uint first, uint end) {
    vec4 l0 = luxLamp(li, 0);
    vec3 lampPos = l0.xyz;
    vec3 m0 = luxLamp(li, 1).xyz;
    vec3 m1 = luxLamp(li, 2).xyz;
    vec3 m2 = luxLamp(li, 3).xyz;
    ivec2 size = ivec2(luxLamp(li, 5).yz);
    // The receiver in the lamp's photometric frame: M·(p − centre).
    vec3 rel = p - lampPos;
    vec3 receiver = vec3(luxDot(m0, rel), luxDot(m1, rel), luxDot(m2, rel));
    float areas[6];
    luxVisibleAreas(o, receiver, areas);
    uint counts[6];
    luxCounts(areas, luxTexelSamples(o, sqrt(luxDot(rel, rel)), u_samples), counts);
    float sum = 0.0;
    // Index of the part's first point among all the opening's.
    uint base = 0u;
    for (int part = 0; part < 6; ++part) {
        uint count = counts[part];
        float nf = float(count);
        float partSum = 0.0;
        uint lo = min(first - min(first, base), count);
        uint hi = min(end - min(end, base), count);
        base += count;
        for (uint k = lo; k < hi; ++k) {
            vec3 q;
            vec3 qn;
            float weight;
            if (!luxOpeningSamplePart(o, part, luxOpeningLattice(k, count, shift), receiver, q,
                                      qn, weight)) {
                continue;
            }
            vec3 x = vec3(lampPos.x + q.x * m0.x + q.y * m1.x + q.z * m2.x,
                          lampPos.y + q.x * m0.y + q.y * m1.y + q.z * m2.y,
                          lampPos.z + q.x * m0.z + q.y * m1.z + q.z * m2.z);
            vec3 to = x - p;
            float r2 = luxDot(to, to);
            float r = sqrt(r2);
            if (!(r > 0.0 && luxFinite(r))) {
                continue;
            }
            vec3 w = vec3(to.x / r, to.y / r, to.z / r);
            float cosP = luxDot(n, w);
            if (!(cosP > 0.0)) {
                continue;
            }
            vec3 back = -w;
            vec3 emit = vec3(luxDot(m0, back), luxDot(m1, back), luxDot(m2, back));
            float cosX = luxDot(qn, emit);
            if (!(cosX > 0.0)) {
                continue;
            }
            float area = luxOpeningProjectedArea(o, emit);
            if (!(area > 0.0)) {
                continue;
            }
            float intensity = luxIesSample(int(l0.w), size, emit);
            if (!(intensity > 0.0)) {
                continue;
            }
            if (!luxSees(p, n, o0, off2, x, back, r, r2)) {
                continue;
            }
            float r2e = max(max(r2, off2), weight / (LUX_PI * nf));
            partSum += intensity * cosX * weight / area * cosP / r2e;
        }
        if (count > 0u) {
            sum += partSum / nf;
        }
    }
    return sum;
}

vec4 luxRun(ivec3 c) {
    vec4 pos = texelFetch(u_position, c, 0);
    vec4 nrm = texelFetch(u_normal, c, 0);
    if (pos.w <= 0.5) {
        return vec4(0.0);
    }
    vec3 p = pos.xyz;
    vec3 n;
    if (!luxNormalize(nrm.xyz, n)) {
        return vec4(0.0, 0.0, 0.0, 1.0);
    }
    uint texel = luxTexelIndex(uvec2(textureSize(u_position, 0).xy), uint(c.z), uint(c.x),
                               uint(c.y));
    vec3 o0 = luxOffsetOrigin(p, n, u_ray_epsilon);
    vec3 off = o0 - p;
    float off2 = luxDot(off, off);
    // A chunk of the opening samples: flattened indices first..end of each opening's.
    uint first = u_first_sample;
    uint end = u_chunk_samples > 0u ? first + min(u_chunk_samples, 0xffffffffu - first)
                                    : 0xffffffffu;
    vec3 e = first > 0u ? texelFetch(u_prior, c, 0).rgb : vec3(0.0);
    for (int li = 0; li < int(u_lamp_count); ++li) {
        vec3 lampPos = luxLamp(li, 0).xyz;
        LuxOpening opening = luxOpening(li);
        if (luxOpeningNear(opening, lampPos, p)) {
            uvec2 shift = luxOpeningShift(texel, uint(li), u_seed);
            float k = luxFromOpening(li, opening, p, n, o0, off2, shift, first, end);
            e += k * luxLamp(li, 4).rgb;
            continue;
        }
        // A lamp without an opening is the first chunk's.
        if (first > 0u) {
            continue;
        }
        float d2;
        float d;
        vec3 w;
        float cosTheta;
        float intensity;
        if (!luxLampToward(li, p, n, d2, d, w, cosTheta, intensity)) {
            continue;
        }
        if (!luxSees(p, n, o0, off2, lampPos, -w, d, d2)) {
            continue;
        }
        float k = intensity * cosTheta / max(d2, off2);
        e += k * luxLamp(li, 4).rgb;
    }
    return vec4(luxGuard3(e), 1.0);
}
