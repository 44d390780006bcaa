// A lamp seen from a surface point, for the direct pass
// (after scene.glsl and ies.glsl).

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
