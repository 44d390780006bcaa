// The stateless random-number hash of the gather passes: a bit-exact port of luxbake::rng
// (see its module docs for the specification). uint arithmetic wraps and shifts are logical in
// GLSL ES 3.00, exactly as u32 wrapping_* in Rust.

// PCG-RXS-M-XS 32 used as a hash (rng::pcg).
uint luxPcg(uint v) {
    uint s = v * 747796405u + 2891336453u;
    uint w = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
    return (w >> 22u) ^ w;
}

// rng::hash: pcg(texel + pcg(sample + pcg(pass + pcg(seed)))).
uint luxHash(uint texel, uint sampleIndex, uint pass, uint seed) {
    return luxPcg(texel + luxPcg(sampleIndex + luxPcg(pass + luxPcg(seed))));
}

// rng::texel_index: (layer * height + y) * width + x, wrapping.
uint luxTexelIndex(uvec2 layerSize, uint layer, uint x, uint y) {
    return (layer * layerSize.y + y) * layerSize.x + x;
}

// rng::unit_f32: the top 24 bits as a float in [0, 1) (exact).
float luxUnit(uint h) {
    return float(h >> 8u) * (1.0 / 16777216.0);
}

// rng::uniform2: the two uniforms of one draw.
vec2 luxUniform2(uint texel, uint sampleIndex, uint pass, uint seed) {
    uint h = luxHash(texel, sampleIndex, pass, seed);
    return vec2(luxUnit(h), luxUnit(luxPcg(h)));
}
