// Pass "direct" (paper Figure 4, box 2): illuminance from the pass's lamps, with shadow rays
// through the BVH (cpu::direct_texel, operation for operation).
//
// Evaluates the first u_lamp_count uploaded lamps (luxLamp, scene.glsl); near a lamp's
// luminous opening, u_samples points of it (luxOpening*, opening.glsl). With
// u_chunk_samples > 0 an opening's samples are split over dispatches, each adding its share
// to the one before (u_prior); the lamps without an opening come with the first. With
// u_points_only = 1 every lamp is a point (the preview of the direct light).

// cpu::OpeningView::point: lattice point k of count on part `part` of an opening (its lamp
// at lampPos, rows m0..m2 of its rotation, its table and size) as the texel at p sees it, before
// the point's shadow ray: its share `value`, its geometric share `geom` (the control
// variate's) and the ray's end x, back, r, r2; false when it gives p nothing whatever the ray
// finds.
bool luxOpeningPoint(LuxOpening o, vec3 lampPos, vec3 m0, vec3 m1, vec3 m2, int table,
                     ivec2 size, int part, uint k, uint count, uvec2 shift, vec3 receiver,
                     vec3 p, vec3 n, float off2, out float value, out float geom, out vec3 x,
                     out vec3 back, out float r, out float r2) {
    value = 0.0;
    geom = 0.0;
    x = vec3(0.0);
    back = vec3(0.0);
    r = 0.0;
    r2 = 0.0;
    vec3 q;
    vec3 qn;
    float weight;
    if (!luxOpeningSamplePart(o, part, luxOpeningLattice(k, count, shift), receiver, q, qn,
                              weight)) {
        return false;
    }
    x = vec3(lampPos.x + q.x * m0.x + q.y * m1.x + q.z * m2.x,
             lampPos.y + q.x * m0.y + q.y * m1.y + q.z * m2.y,
             lampPos.z + q.x * m0.z + q.y * m1.z + q.z * m2.z);
    vec3 to = x - p;
    r2 = luxDot(to, to);
    r = sqrt(r2);
    if (!(r > 0.0 && luxFinite(r))) {
        return false;
    }
    vec3 w = vec3(to.x / r, to.y / r, to.z / r);
    float cosP = luxDot(n, w);
    if (!(cosP > 0.0)) {
        return false;
    }
    back = -w;
    vec3 emit = vec3(luxDot(m0, back), luxDot(m1, back), luxDot(m2, back));
    float cosX = luxDot(qn, emit);
    if (!(cosX > 0.0)) {
        return false;
    }
    float area = luxOpeningProjectedArea(o, emit);
    if (!(area > 0.0)) {
        return false;
    }
    float intensity = luxIesSample(table, size, emit);
    if (!(intensity > 0.0)) {
        return false;
    }
    float r2e = max(max(r2, off2), weight / (LUX_PI * float(count)));
    value = intensity * cosX * weight / area * cosP / r2e;
    geom = cosX * weight * cosP / r2;
    return true;
}

// cpu::from_opening: the illuminance at p from lattice points of lamp li's opening
// (luxTexelSamples of u_samples), shared among the parts p can see, before the lamp's scale,
// each with its shadow ray unless the probes all see the opening (cpu::sees_all: the points
// k = 0, u_probe_stride, 2·u_probe_stride, … of each part that give light); the points whose
// index over the parts lies in [first, end).
float luxFromOpening(int li, LuxOpening o, vec3 p, vec3 n, vec3 o0, float off2, uvec2 shift,
                     uint first, uint end) {
    vec4 l0 = luxLamp(li, 0);
    vec3 lampPos = l0.xyz;
    vec3 m0 = luxLamp(li, 1).xyz;
    vec3 m1 = luxLamp(li, 2).xyz;
    vec3 m2 = luxLamp(li, 3).xyz;
    int table = int(l0.w);
    ivec2 size = ivec2(luxLamp(li, 5).yz);
    // The receiver in the lamp's photometric frame: M·(p − centre).
    vec3 rel = p - lampPos;
    vec3 receiver = vec3(luxDot(m0, rel), luxDot(m1, rel), luxDot(m2, rel));
    float areas[6];
    luxVisibleAreas(o, receiver, areas);
    uint counts[6];
    luxCounts(areas, luxTexelSamples(o, sqrt(luxDot(rel, rel)), u_samples), counts);
    // A chunk past the texel's points adds nothing (and asks no probe).
    uint total = 0u;
    for (int part = 0; part < 6; ++part) {
        total += counts[part];
    }
    if (first >= total) {
        return 0.0;
    }
    float value;
    float geom;
    vec3 x;
    vec3 back;
    float r;
    float r2;
    // cpu::sees_all, and where every probe sees the opening, cpu::control: each share of a
    // part with a closed form (a rectangle, a disk) from its probes alone (cvParts: those parts;
    // cvSum: the shares of those whose first point is this chunk's).
    int occluder = -1;
    bool trace = true;
    uint cvParts = 0u;
    float cvSum = 0.0;
    if (u_probe_stride > 1u) {
        // The receiver's normal in the photometric frame.
        vec3 normal = vec3(luxDot(m0, n), luxDot(m1, n), luxDot(m2, n));
        bool seen = false;
        bool blocked = false;
        uint base = 0u;
        for (int part = 0; part < 6 && !blocked; ++part) {
            uint count = counts[part];
            uint lo = min(first - min(first, base), count);
            uint hi = min(end - min(end, base), count);
            base += count;
            if (count == 0u) {
                continue;
            }
            float g;
            vec3 toward;
            bool cv = luxPartControl(o, part, receiver, normal, g, toward);
            float area = cv ? luxOpeningProjectedArea(o, toward) : 0.0;
            float luminance = cv ? luxIesSample(table, size, toward) / area : 0.0;
            cv = cv && area > 0.0 && luminance > 0.0 && luxFinite(luminance);
            float residual = 0.0;
            float square = 0.0;
            uint probes = 0u;
            for (uint k = 0u; k < count; k += u_probe_stride) {
                if (!luxOpeningPoint(o, lampPos, m0, m1, m2, table, size, part, k, count, shift,
                                     receiver, p, n, off2, value, geom, x, back, r, r2)) {
                    cv = false;
                    continue;
                }
                if (!luxSees(p, n, o0, off2, x, back, r, r2, occluder)) {
                    blocked = true;
                    break;
                }
                seen = true;
                float d = value - luminance * geom;
                residual += d;
                square += d * d;
                probes += 1u;
            }
            // The probes' own estimate of their mean's error (cpu::control).
            float nf = float(probes);
            float estimate = luminance * g + residual / nf;
            float mean = residual / nf;
            float variance = max(square / nf - mean * mean, 0.0) / (nf - 1.0);
            cv = cv && probes >= LUX_CONTROL_MIN_PROBES &&
                 variance <= LUX_CONTROL_MAX_ERROR * LUX_CONTROL_MAX_ERROR * estimate * estimate;
            if (cv && !blocked) {
                cvParts |= 1u << uint(part);
                if (lo == 0u && hi > 0u) {
                    cvSum += estimate;
                }
            }
        }
        trace = blocked || !seen;
    }
    if (trace) {
        cvParts = 0u;
        cvSum = 0.0;
    }
    float sum = cvSum;
    // Index of the part's first point among all the opening's.
    uint base = 0u;
    for (int part = 0; part < 6; ++part) {
        uint count = counts[part];
        float nf = float(count);
        float partSum = 0.0;
        uint lo = min(first - min(first, base), count);
        uint hi = min(end - min(end, base), count);
        base += count;
        if ((cvParts & (1u << uint(part))) != 0u) {
            continue;
        }
        for (uint k = lo; k < hi; ++k) {
            if (!luxOpeningPoint(o, lampPos, m0, m1, m2, table, size, part, k, count, shift,
                                 receiver, p, n, off2, value, geom, x, back, r, r2)) {
                continue;
            }
            if (trace && !luxSees(p, n, o0, off2, x, back, r, r2, occluder)) {
                continue;
            }
            partSum += value;
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
    int occluder = -1;
    for (int li = 0; li < int(u_lamp_count); ++li) {
        vec3 lampPos = luxLamp(li, 0).xyz;
        LuxOpening opening = luxOpening(li);
        if (u_points_only == 0u && luxOpeningNear(opening, lampPos, p)) {
            uvec2 shift = luxOpeningShift(texel, uint(li), u_seed);
            float k = luxFromOpening(li, opening, p, n, o0, off2, shift, first, end);
            e += k * luxLamp(li, 4).rgb;
            continue;
        }
        // A lamp without an opening is the first chunk's.
        if (first > 0u) {
            continue;
        }
        vec3 k;
        if (luxPointLamp(li, p, n, o0, off2, occluder, k)) {
            e += k;
        }
    }
    return vec4(luxGuard3(e), 1.0);
}
