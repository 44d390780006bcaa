// Shared by every pass: f32 helpers that mirror luxbake::exact operation for operation (dot products left to right, division rather than
// multiplication by a reciprocal). WGSL has no isnan/isinf: they are bit tests here, which no
// compiler may fold away.

// The generated prefix (luxbake::shader) declares the program's slots (lux_<slot>), the output
// lux_out, the tile lux_tile (program::TileParams) and the parameter block lux_pass.

const LUX_FLT_MAX: f32 = 3.40282347e38;

// exact::dot
fn lux_dot(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

fn lux_is_nan(v: f32) -> bool {
    return (bitcast<u32>(v) & 0x7fffffffu) > 0x7f800000u;
}

fn lux_finite(v: f32) -> bool {
    return (bitcast<u32>(v) & 0x7fffffffu) < 0x7f800000u;
}

fn lux_finite3(v: vec3<f32>) -> bool {
    return lux_finite(v.x) && lux_finite(v.y) && lux_finite(v.z);
}

fn lux_sign_bit(v: f32) -> bool {
    return (bitcast<u32>(v) & 0x80000000u) != 0u;
}

// exact::normalize: false for a zero or non-finite vector (then *n = v).
fn lux_normalize(v: vec3<f32>, n: ptr<function, vec3<f32>>) -> bool {
    let l = sqrt(lux_dot(v, v));
    *n = v;
    if (!(l > 0.0 && lux_finite(l))) {
        return false;
    }
    *n = vec3<f32>(v.x / l, v.y / l, v.z / l);
    return true;
}

// exact::guard: NaN to 0, clamped to [0, FLT_MAX].
fn lux_guard(v: f32) -> f32 {
    if (lux_is_nan(v)) {
        return 0.0;
    }
    return clamp(v, 0.0, LUX_FLT_MAX);
}

fn lux_guard3(v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(lux_guard(v.x), lux_guard(v.y), lux_guard(v.z));
}

// passes::refine::refines: whether the first bounce's refinement refines a texel whose
// variance estimate (the variance pass's texel) is `noise`: its first gather's standard error
// over the light known at the texel, the window's mean and the texel's direct light.
fn lux_refines(noise: vec4<f32>, max_error: f32) -> bool {
    return !(sqrt(max(noise.z, 0.0)) <= max_error * (noise.y + noise.w));
}

// The texel of invocation `gid` in the bound tile, or x = -1 outside it.
fn lux_texel(gid: vec3<u32>) -> vec2<i32> {
    if (gid.x >= lux_tile.width || gid.y >= lux_tile.height) {
        return vec2<i32>(-1, -1);
    }
    // A strided gather's grid texels alone (TileParams::grid ≥ 2): invocation (i, j) of the
    // compact tile is the layout's texel (i·grid, j·grid).
    let s = max(lux_tile.grid, 1u);
    return vec2<i32>(i32((lux_tile.x0 + gid.x) * s), i32((lux_tile.y0 + gid.y) * s));
}

// Texel c of the tile's layer of map `t` (GLSL: texelFetch(u_<slot>, c, 0), c.z the layer).
fn lux_load(t: texture_2d_array<f32>, c: vec2<i32>) -> vec4<f32> {
    return textureLoad(t, c, i32(lux_tile.layer), 0);
}

fn lux_store(c: vec2<i32>, value: vec4<f32>) {
    textureStore(lux_out, c, i32(lux_tile.layer), value);
}

// exact::luminance: Rec. 709, left to right.
fn lux_luminance(c: vec3<f32>) -> f32 {
    return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}
