// A lamp seen from a surface point, for the direct pass and the gather's direct light at its
// hits (after scene.glsl, bvh.glsl and ies.glsl).

// backend::lamp_toward: uploaded lamp `li` seen unshadowed from surface point p with unit
// normal n (luxLamp, scene.glsl). False when the lamp stands at p, behind the surface or dark
// toward it; else its distance squared d2, distance d, unit direction w toward the lamp, the
// cosine at the surface and the intensity toward p (candela, before the lamp's scale).
bool luxLampToward(int li, vec3 p, vec3 n, out float d2, out float d, out vec3 w,
                   out float cosTheta, out float intensity) {
    vec4 l0 = luxLamp(li, 0);
    vec3 to = l0.xyz - p;
    d2 = luxDot(to, to);
    d = sqrt(d2);
    w = vec3(0.0);
    cosTheta = 0.0;
    intensity = 0.0;
    if (!(d > 0.0 && luxFinite(d))) {
        return false;
    }
    w = vec3(to.x / d, to.y / d, to.z / d);
    cosTheta = luxDot(n, w);
    if (!(cosTheta > 0.0)) {
        return false;
    }
    vec3 back = -w;
    vec3 photometric = vec3(luxDot(luxLamp(li, 1).xyz, back), luxDot(luxLamp(li, 2).xyz, back),
                            luxDot(luxLamp(li, 3).xyz, back));
    intensity = luxIesSample(int(l0.w), ivec2(luxLamp(li, 5).yz), photometric);
    return intensity > 0.0;
}

// cpu::Start::sees: nothing lies between texel p (unit normal n, offset origin o0, offset
// squared off2) and x, r away (r2 its square), back the unit direction from x toward p.
// occluder: the triangle that blocked the texel's last ray (-1: none yet), tested first; it
// blocks most of the texel's next rays and spares their traversal (the same answer: a ray that
// hits it would hit a leaf the traversal reaches).
bool luxSees(vec3 p, vec3 n, vec3 o0, float off2, vec3 x, vec3 back, float r, float r2,
             inout int occluder) {
    vec3 origin = 16.0 * off2 > r2 ? p + n * (0.25 * r) : o0;
    vec3 dir = x - origin;
    float len = sqrt(luxDot(dir, dir));
    vec3 xOff = luxOffsetOrigin(x, back, u_ray_epsilon) - x;
    float stopShort = min(sqrt(luxDot(xOff, xOff)), 0.25 * r);
    float tMax = 1.0 - stopShort / len;
    if (!(len > 0.0 && tMax > 0.0)) {
        return true;
    }
    vec3 tuv;
    LuxRay ray;
    if (occluder >= 0 && luxRaySetup(origin, dir, ray)
        && luxTriangleTest(ray, occluder, 0.0, tMax, tuv)) {
        return false;
    }
    vec3 hit;
    int t = luxTrace(origin, dir, 0.0, tMax, true, hit);
    if (t >= 0) {
        occluder = t;
        return false;
    }
    return true;
}

// cpu::direct_texel's point term: uploaded lamp li as a point from its photometric centre,
// seen from p (unit normal n, offset origin o0, offset squared off2) through its shadow ray
// (luxSees, `occluder` its cache): false when it gives p nothing, else its illuminance k.
bool luxPointLamp(int li, vec3 p, vec3 n, vec3 o0, float off2, inout int occluder, out vec3 k) {
    k = vec3(0.0);
    float d2;
    float d;
    vec3 w;
    float cosTheta;
    float intensity;
    if (!luxLampToward(li, p, n, d2, d, w, cosTheta, intensity)) {
        return false;
    }
    if (!luxSees(p, n, o0, off2, luxLamp(li, 0).xyz, -w, d, d2, occluder)) {
        return false;
    }
    k = intensity * cosTheta / max(d2, off2) * luxLamp(li, 4).rgb;
    return true;
}

// passes::direct::cpu::points_at: the direct illuminance e at a gather hit p (unit normal n)
// from the first `lamps` uploaded lamps, each as a point from its photometric centre with its
// shadow ray (the direct pass's sum with u_points_only = 1); false where p lies within a
// lamp's opening's near distance (opening.glsl's luxOpeningNear).
bool luxPointLampsAt(vec3 p, vec3 n, int lamps, out vec3 e) {
    e = vec3(0.0);
    for (int li = 0; li < lamps; ++li) {
        vec3 to = luxLamp(li, 0).xyz - p;
        if (int(luxLamp(li, 7).z) != 0 && sqrt(luxDot(to, to)) < luxLamp(li, 6).w) {
            return false;
        }
    }
    vec3 o0 = luxOffsetOrigin(p, n, u_ray_epsilon);
    vec3 off = o0 - p;
    float off2 = luxDot(off, off);
    int occluder = -1;
    for (int li = 0; li < lamps; ++li) {
        vec3 k;
        if (luxPointLamp(li, p, n, o0, off2, occluder, k)) {
            e += k;
        }
    }
    e = luxGuard3(e);
    return true;
}
