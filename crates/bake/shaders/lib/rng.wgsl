// The stateless random-number hash of the gather passes: a bit-exact port of luxbake::rng (see
// its module docs for the specification). u32 arithmetic wraps and shifts are logical in WGSL,
// exactly as u32 wrapping_* in Rust.

// PCG-RXS-M-XS 32 used as a hash (rng::pcg).
fn lux_pcg(v: u32) -> u32 {
    let s = v * 747796405u + 2891336453u;
    let w = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
    return (w >> 22u) ^ w;
}

// rng::hash: pcg(texel + pcg(sample + pcg(pass + pcg(seed)))).
fn lux_hash(texel: u32, sample_index: u32, pass_index: u32, seed: u32) -> u32 {
    return lux_pcg(texel + lux_pcg(sample_index + lux_pcg(pass_index + lux_pcg(seed))));
}

// rng::texel_index: (layer * height + y) * width + x, wrapping.
fn lux_texel_index(layer_size: vec2<u32>, layer: u32, x: u32, y: u32) -> u32 {
    return (layer * layer_size.y + y) * layer_size.x + x;
}

// rng::unit_f32: the top 24 bits as a float in [0, 1) (exact).
fn lux_unit(h: u32) -> f32 {
    return f32(h >> 8u) * (1.0 / 16777216.0);
}

// rng::uniform2: the two uniforms of one draw.
fn lux_uniform2(texel: u32, sample_index: u32, pass_index: u32, seed: u32) -> vec2<f32> {
    let h = lux_hash(texel, sample_index, pass_index, seed);
    return vec2<f32>(lux_unit(h), lux_unit(lux_pcg(h)));
}
