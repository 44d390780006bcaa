// Bilinear sampling of a lamp's resampled intensity table, a port of luxbake_ies::GpuTable::sample.
// Table layer `table` of u_ies holds the table's rows (row j <-> gamma = pi j / (height - 1)
// from nadir) with four consecutive columns (column i <-> C = 2 pi i / width) per RGBA texel:
// value (row j, column i) is texel (i / 4, j) component i % 4. Wraps in C, clamps in gamma.

uniform highp sampler2DArray u_ies;

// Driver acos/atan are far from exact (llvmpipe: ~2000 and ~170 ulps), which would move the
// bilinear look-up by up to 1e-4 of a table's range. These f32 versions (Cephes' asinf and atanf
// minimax polynomials, peak relative error ~2.5e-7) are the CPU's luxbake_ies::acos_f32 /
// atan2_f32 operation for operation (test the_table_angles_are_the_shaders_polynomials).
const float LUX_PI = 3.14159265358979;
const float LUX_HALF_PI = 1.57079632679490;

// asin(x) for |x| <= 0.5.
float luxAsinSmall(float x) {
    float z = x * x;
    return ((((4.2163199048e-2 * z + 2.4181311049e-2) * z + 4.5470025998e-2) * z
        + 7.4953002686e-2) * z + 1.6666752422e-1) * z * x + x;
}

// acos(x) for x in [-1, 1].
float luxAcos(float x) {
    if (x > 0.5) {
        return 2.0 * luxAsinSmall(sqrt(0.5 * (1.0 - x)));
    }
    if (x < -0.5) {
        return LUX_PI - 2.0 * luxAsinSmall(sqrt(0.5 * (1.0 + x)));
    }
    return LUX_HALF_PI - luxAsinSmall(x);
}

// atan(x) for x in [0, 1].
float luxAtanUnit(float x) {
    float y0 = 0.0;
    float z = x;
    if (x > 0.4142135623730950) {
        y0 = 0.25 * LUX_PI;
        z = (x - 1.0) / (x + 1.0);
    }
    float zz = z * z;
    return y0 + ((((8.05374449538e-2 * zz - 1.38776856032e-1) * zz + 1.99777106478e-1) * zz
        - 3.33329491539e-1) * zz * z + z);
}

bool luxSignBit(float v) {
    return (floatBitsToUint(v) & 0x80000000u) != 0u;
}

// atan2(y, x) in [-pi, pi] with IEEE signed-zero conventions (atan2(+-0, -0) = +-pi).
float luxAtan2(float y, float x) {
    float ax = abs(x);
    float ay = abs(y);
    float a;
    if (ax == 0.0 && ay == 0.0) {
        a = 0.0;
    } else if (ax >= ay) {
        a = luxAtanUnit(ay / ax);
    } else {
        a = LUX_HALF_PI - luxAtanUnit(ax / ay);
    }
    if (luxSignBit(x)) {
        a = LUX_PI - a;
    }
    return luxSignBit(y) ? -a : a;
}

float luxIesAt(int table, int row, int col) {
    vec4 v = texelFetch(u_ies, ivec3(col >> 2, row, table), 0);
    // The component by selection: a variable index into a vector is slow on some drivers
    // (SwiftShader keeps the vector in memory).
    int k = col & 3;
    return k == 0 ? v.x : (k == 1 ? v.y : (k == 2 ? v.z : v.w));
}

// Candela toward `dir` (photometric frame, any length); size = (width, height) of the table.
float luxIesSample(int table, ivec2 size, vec3 dir) {
    const float TAU = 6.28318530717959;
    float len = sqrt(dir.x * dir.x + dir.y * dir.y + dir.z * dir.z);
    if (!(len > 0.0 && luxFinite(len)) || size.x == 0 || size.y < 2) {
        return 0.0;
    }
    float gamma = luxAcos(clamp(-dir.z / len, -1.0, 1.0));
    float c = luxAtan2(dir.y, dir.x);
    if (c < 0.0) {
        c += TAU;
    }
    float fy = gamma / LUX_PI * float(size.y - 1);
    float fx = c / TAU * float(size.x);
    float x0 = floor(fx);
    float tx = fx - x0;
    // The column and the next, modulo the width.
    int i0 = luxDivMod(int(x0), size.x).y;
    int i1 = i0 + 1 == size.x ? 0 : i0 + 1;
    float y0f = clamp(floor(fy), 0.0, float(size.y - 1));
    float ty = clamp(fy - y0f, 0.0, 1.0);
    int y0 = int(y0f);
    int y1 = min(y0 + 1, size.y - 1);
    // Each corner read once.
    float v00 = luxIesAt(table, y0, i0);
    float v01 = luxIesAt(table, y0, i1);
    float v10 = luxIesAt(table, y1, i0);
    float v11 = luxIesAt(table, y1, i1);
    float a = v00 + (v01 - v00) * tx;
    float b = v10 + (v11 - v10) * tx;
    return a + (b - a) * ty;
}


// lightpaths::DensityProxy::sample: the density proxy's octahedral grid of table `table`
// (LUX_PROXY_CELLS + 1 nodes per side), stored from row `height` of the table's layer (scene.rs).
float luxProxySample(int table, int height, vec3 dir) {
    float s = abs(dir.x) + abs(dir.y) + abs(dir.z);
    if (!(s > 0.0 && luxFinite(s))) {
        return 0.0;
    }
    float r = 1.0 / s;
    float p = dir.x * r;
    float q = dir.y * r;
    if (dir.z > 0.0) {
        float ap = abs(p);
        float aq = abs(q);
        p = (1.0 - aq) * (p >= 0.0 ? 1.0 : -1.0);
        q = (1.0 - ap) * (q >= 0.0 ? 1.0 : -1.0);
    }
    float n = float(LUX_PROXY_CELLS);
    float fu = clamp((p * 0.5 + 0.5) * n, 0.0, n);
    float fv = clamp((q * 0.5 + 0.5) * n, 0.0, n);
    int i = min(int(fu), LUX_PROXY_CELLS - 1);
    int j = min(int(fv), LUX_PROXY_CELLS - 1);
    float tu = fu - float(i);
    float tv = fv - float(j);
    int row = height + j;
    float v00 = luxIesAt(table, row, i);
    float v01 = luxIesAt(table, row, i + 1);
    float v10 = luxIesAt(table, row + 1, i);
    float v11 = luxIesAt(table, row + 1, i + 1);
    float a = v00 + (v01 - v00) * tu;
    float b = v10 + (v11 - v10) * tu;
    return a + (b - a) * tv;
}
