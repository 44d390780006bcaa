// Bilinear sampling of a lamp's resampled intensity table, a port of
// luxbake_ies::GpuTable::sample: row j <-> gamma = pi j / (height - 1) from nadir, column
// i <-> C = 2 pi i / width; wraps in C, clamps in gamma. The table's values are lux_ies[offset
// + j * width + i] (scene.wgsl).

// Driver acos/atan are far from exact (the glow backend measured ~2000 and ~170 ulps on
// llvmpipe), which would move the bilinear look-up by up to 1e-4 of a table's range. These f32
// versions (Cephes' asinf and atanf minimax polynomials, peak relative error ~2.5e-7, the same
// as the glow backend's ies.glsl) are the CPU's luxbake_ies::acos_f32 / atan2_f32 operation
// for operation (test the_table_angles_are_the_shaders_polynomials).
const LUX_PI: f32 = 3.14159265358979;
const LUX_HALF_PI: f32 = 1.57079632679490;
const LUX_TAU: f32 = 6.28318530717959;

// asin(x) for |x| <= 0.5.
fn lux_asin_small(x: f32) -> f32 {
    let z = x * x;
    return ((((4.2163199048e-2 * z + 2.4181311049e-2) * z + 4.5470025998e-2) * z
        + 7.4953002686e-2) * z + 1.6666752422e-1) * z * x + x;
}

// acos(x) for x in [-1, 1].
fn lux_acos(x: f32) -> f32 {
    if (x > 0.5) {
        return 2.0 * lux_asin_small(sqrt(0.5 * (1.0 - x)));
    }
    if (x < -0.5) {
        return LUX_PI - 2.0 * lux_asin_small(sqrt(0.5 * (1.0 + x)));
    }
    return LUX_HALF_PI - lux_asin_small(x);
}

// atan(x) for x in [0, 1].
fn lux_atan_unit(x: f32) -> f32 {
    var y0 = 0.0;
    var z = x;
    if (x > 0.4142135623730950) {
        y0 = 0.25 * LUX_PI;
        z = (x - 1.0) / (x + 1.0);
    }
    let zz = z * z;
    return y0 + ((((8.05374449538e-2 * zz - 1.38776856032e-1) * zz + 1.99777106478e-1) * zz
        - 3.33329491539e-1) * zz * z + z);
}

// atan2(y, x) in [-pi, pi] with IEEE signed-zero conventions (atan2(+-0, -0) = +-pi).
fn lux_atan2(y: f32, x: f32) -> f32 {
    let ax = abs(x);
    let ay = abs(y);
    var a: f32;
    if (ax == 0.0 && ay == 0.0) {
        a = 0.0;
    } else if (ax >= ay) {
        a = lux_atan_unit(ay / ax);
    } else {
        a = LUX_HALF_PI - lux_atan_unit(ax / ay);
    }
    if (lux_sign_bit(x)) {
        a = LUX_PI - a;
    }
    return select(a, -a, lux_sign_bit(y));
}

fn lux_ies_at(offset: u32, width: i32, row: i32, col: i32) -> f32 {
    let i = offset + u32(row * width + col);
    if (i >= arrayLength(&lux_ies)) {
        return 0.0;
    }
    return lux_ies[i];
}

// Candela toward `dir` (photometric frame, any length) from the table at `offset` of
// `size` = (width, height).
fn lux_ies_sample(offset: u32, size: vec2<i32>, dir: vec3<f32>) -> f32 {
    let len = sqrt(dir.x * dir.x + dir.y * dir.y + dir.z * dir.z);
    if (!(len > 0.0 && lux_finite(len)) || size.x == 0 || size.y < 2) {
        return 0.0;
    }
    let gamma = lux_acos(clamp(-dir.z / len, -1.0, 1.0));
    var c = lux_atan2(dir.y, dir.x);
    if (c < 0.0) {
        c += LUX_TAU;
    }
    let fy = gamma / LUX_PI * f32(size.y - 1);
    let fx = c / LUX_TAU * f32(size.x);
    let x0 = floor(fx);
    let tx = fx - x0;
    var i0 = i32(x0) % size.x;
    if (i0 < 0) {
        i0 += size.x;
    }
    let i1 = (i0 + 1) % size.x;
    let y0f = clamp(floor(fy), 0.0, f32(size.y - 1));
    let ty = clamp(fy - y0f, 0.0, 1.0);
    let y0 = i32(y0f);
    let y1 = min(y0 + 1, size.y - 1);
    let a = lux_ies_at(offset, size.x, y0, i0)
        + (lux_ies_at(offset, size.x, y0, i1) - lux_ies_at(offset, size.x, y0, i0)) * tx;
    let b = lux_ies_at(offset, size.x, y1, i0)
        + (lux_ies_at(offset, size.x, y1, i1) - lux_ies_at(offset, size.x, y1, i0)) * tx;
    return a + (b - a) * ty;
}


// lightpaths::DensityProxy::sample: the density proxy's octahedral grid (LUX_PROXY_CELLS + 1
// nodes per side) at `offset` in lux_ies (right after its table, pack::ies_values).
fn lux_proxy_sample(offset: u32, dir: vec3<f32>) -> f32 {
    let s = abs(dir.x) + abs(dir.y) + abs(dir.z);
    if (!(s > 0.0 && lux_finite(s))) {
        return 0.0;
    }
    let r = 1.0 / s;
    var p = dir.x * r;
    var q = dir.y * r;
    if (dir.z > 0.0) {
        let ap = abs(p);
        let aq = abs(q);
        p = (1.0 - aq) * select(-1.0, 1.0, p >= 0.0);
        q = (1.0 - ap) * select(-1.0, 1.0, q >= 0.0);
    }
    let n = f32(LUX_PROXY_CELLS);
    let fu = clamp((p * 0.5 + 0.5) * n, 0.0, n);
    let fv = clamp((q * 0.5 + 0.5) * n, 0.0, n);
    let i = min(i32(fu), LUX_PROXY_CELLS - 1);
    let j = min(i32(fv), LUX_PROXY_CELLS - 1);
    let tu = fu - f32(i);
    let tv = fv - f32(j);
    let w = LUX_PROXY_CELLS + 1;
    let a = lux_ies_at(offset, w, j, i)
        + (lux_ies_at(offset, w, j, i + 1) - lux_ies_at(offset, w, j, i)) * tu;
    let b = lux_ies_at(offset, w, j + 1, i)
        + (lux_ies_at(offset, w, j + 1, i + 1) - lux_ies_at(offset, w, j + 1, i)) * tu;
    return a + (b - a) * tv;
}
