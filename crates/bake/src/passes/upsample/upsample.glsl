// Pass "upsample": fills the texels a reduced-resolution gather left out with the bilinear,
// surface-masked mean of its grid-cell corners (coarse.glsl; cpu::upsample_texel). Grid
// texels and orphans keep the gathered value.
// Parameters (program::UpsampleParams): the gather's u_stride and u_reach.

vec4 luxRun(ivec3 c) {
    if (texelFetch(u_position, c, 0).w <= 0.5) {
        return vec4(0.0);
    }
    vec4 own = texelFetch(u_src, c, 0);
    ivec2 corners[4];
    float weights[4];
    float total = luxCoarseWeights(c, u_stride, u_reach, corners, weights);
    if (!(total > 0.0)) {
        return own;
    }
    vec3 sum = vec3(0.0);
    for (int i = 0; i < 4; ++i) {
        if (weights[i] > 0.0) {
            sum += weights[i] * texelFetch(u_src, ivec3(corners[i], c.z), 0).rgb;
        }
    }
    return vec4(luxGuard3(vec3(sum.x / total, sum.y / total, sum.z / total)), 1.0);
}
