// Pass "energy": the sum of one row of `u_src` — texel (i, 0) is the sum of r + g + b over the
// valid texels (alpha > 0.5) of row i of the source, in runs of 64 texels (each run's sum
// added to the total), with alpha 1. Applied to a map and then to its row of row sums, it
// leaves a check's energy in one texel per layer.

vec4 luxRun(ivec3 c) {
    int width = textureSize(u_src, 0).x;
    float total = 0.0;
    for (int x0 = 0; x0 < width; x0 += 64) {
        float run = 0.0;
        int x1 = min(x0 + 64, width);
        for (int x = x0; x < x1; x++) {
            vec4 t = texelFetch(u_src, ivec3(x, c.x, c.z), 0);
            if (t.a > 0.5) {
                run += (t.r + t.g) + t.b;
            }
        }
        total += run;
    }
    return vec4(total, 0.0, 0.0, 1.0);
}
