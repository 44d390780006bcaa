// Shared helpers of every pass, mirroring luxbake::exact operation for operation
// (dot products left to right, division rather than multiplication by a reciprocal).

uniform int u_layer;   // the texture-array layer this draw renders
layout(location = 0) out vec4 o_color;

// exact::dot
float luxDot(vec3 a, vec3 b) {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

// v[k] for k in 0..2, by selection: a variable index into a vector is slow on some drivers
// (SwiftShader, on which Chromium runs WebGL without a GPU, keeps the vector in memory).
float luxPick(vec3 v, int k) {
    return k == 0 ? v.x : (k == 1 ? v.y : v.z);
}

// (a / b rounded down, a - b * that) for |a| and 0 < b under 2^24, without an integer
// division, which the drivers that run on a CPU (llvmpipe, SwiftShader) emulate lane by lane:
// the float quotient of two exact integers, truncated, is off by at most one and corrected —
// upward for a negative a, and either way on a GPU whose division is not correctly rounded
// (GLSL ES allows 2.5 ULP).
ivec2 luxDivMod(int a, int b) {
    int q = int(float(a) / float(b));
    int r = a - q * b;
    if (r < 0) {
        q -= 1;
        r += b;
    } else if (r >= b) {
        q += 1;
        r -= b;
    }
    return ivec2(q, r);
}

bool luxFinite(float v) {
    return !isnan(v) && !isinf(v);
}

// exact::normalize: false for a zero or non-finite vector.
bool luxNormalize(vec3 v, out vec3 n) {
    float l = sqrt(luxDot(v, v));
    n = v;
    if (!(l > 0.0 && luxFinite(l))) {
        return false;
    }
    n = vec3(v.x / l, v.y / l, v.z / l);
    return true;
}

// exact::guard: NaN to 0, clamped to [0, FLT_MAX].
float luxGuard(float v) {
    return isnan(v) ? 0.0 : clamp(v, 0.0, 3.40282347e38);
}

vec3 luxGuard3(vec3 v) {
    return vec3(luxGuard(v.x), luxGuard(v.y), luxGuard(v.z));
}

// passes::refine::refines: whether the first bounce's refinement refines a texel whose
// variance estimate (the variance pass's texel) is `noise`: its first gather's standard error
// over the light known at the texel, the window's mean and the texel's direct light.
bool luxRefines(vec4 noise, float maxError) {
    return !(sqrt(max(noise.z, 0.0)) <= maxError * (noise.y + noise.w));
}

// This fragment's texel in the bound layer.
ivec3 luxTexel() {
    return ivec3(ivec2(gl_FragCoord.xy), u_layer);
}

// exact::luminance: Rec. 709, left to right.
float luxLuminance(vec3 c) {
    return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}
