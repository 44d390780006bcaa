// Pass "copy" (paper Figure 4, box 2 -> 3 and 6 -> 7): texel-for-texel copy.

vec4 luxRun(ivec3 c) {
    return texelFetch(u_src, c, 0);
}
