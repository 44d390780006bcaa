// Pass "copy" (paper Figure 4, box 2 -> 3 and 6 -> 7): texel-for-texel copy.

void main() {
    o_color = texelFetch(u_src, luxTexel(), 0);
}
