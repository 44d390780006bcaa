// Pass "combine" (paper Figure 4, box 6): direct + indirect illuminance.

void main() {
    ivec3 c = luxTexel();
    vec4 a = texelFetch(u_direct, c, 0);
    vec4 b = texelFetch(u_indirect, c, 0);
    o_color = vec4(luxGuard3(a.rgb + b.rgb), a.a);
}
