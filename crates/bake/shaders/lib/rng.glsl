// The stateless random numbers of the gather passes: a bit-exact port of luxbake::rng (see its
// module docs for the specification). uint arithmetic wraps and shifts are logical in
// GLSL ES 3.00, exactly as u32 wrapping_* in Rust. The LUX_SAMPLER_* ids are generated
// (shader::glsl_constants).

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

// rng::uniform2: the two uniforms of one draw of the hash sampler.
vec2 luxUniform2(uint texel, uint sampleIndex, uint pass, uint seed) {
    uint h = luxHash(texel, sampleIndex, pass, seed);
    return vec2(luxUnit(h), luxUnit(luxPcg(h)));
}

// u32::reverse_bits (GLSL ES 3.00 has no bitfieldReverse).
uint luxReverseBits(uint x) {
    x = ((x >> 1u) & 0x55555555u) | ((x & 0x55555555u) << 1u);
    x = ((x >> 2u) & 0x33333333u) | ((x & 0x33333333u) << 2u);
    x = ((x >> 4u) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4u);
    x = ((x >> 8u) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8u);
    return (x >> 16u) | (x << 16u);
}

// rng::laine_karras (Burley 2020).
uint luxLaineKarras(uint x, uint key) {
    x += key;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

// rng::owen: nested uniform scramble of the bits of x.
uint luxOwen(uint x, uint key) {
    return luxReverseBits(luxLaineKarras(luxReverseBits(x), key));
}

// rng::pascal: x times Pascal's triangle mod 2 (reversed, Sobol's dimension 1).
uint luxPascal(uint x) {
    x ^= (x >> 1u) & 0x55555555u;
    x ^= (x >> 2u) & 0x33333333u;
    x ^= (x >> 4u) & 0x0f0f0f0fu;
    x ^= (x >> 8u) & 0x00ff00ffu;
    x ^= (x >> 16u) & 0x0000ffffu;
    return x;
}

// rng::sobol2_bits: the texel's shuffled, Owen-scrambled Sobol point of one draw.
uvec2 luxSobol2Bits(uint texel, uint sampleIndex, uint pass, uint seed) {
    uint key = luxHash(texel, 0u, pass, seed);
    uint i = luxOwen(sampleIndex, key);
    uint kx = luxPcg(key);
    uint ky = luxPcg(kx);
    return uvec2(luxReverseBits(luxLaineKarras(i, kx)),
                 luxReverseBits(luxLaineKarras(luxPascal(i), ky)));
}

// rng::sobol2: the two uniforms of one draw of the Sobol sampler.
vec2 luxSobol2(uint texel, uint sampleIndex, uint pass, uint seed) {
    uvec2 b = luxSobol2Bits(texel, sampleIndex, pass, seed);
    return vec2(luxUnit(b.x), luxUnit(b.y));
}

// rng::sequence: `rays` rounded up to a power of two (1 for 0, 2^31 past it).
uint luxSequence(uint rays) {
    uint p = 1u;
    while (p < rays && p < 0x80000000u) {
        p <<= 1u;
    }
    return p;
}

// rng::Stream::gather: (key, first) of the draws of a gather of `rays` rays at texel (x, y) on
// the grid of every `stride`-th texel; with the Sobol sampler a grid texel's rank in its block
// of LUX_SOBOL_BLOCK² grid texels times the rays rounded up, in the sequence of the block's
// first texel.
uvec2 luxGatherStream(uint samplerId, uvec2 layerSize, uint layer, uint x, uint y, uint stride,
                      uint rays) {
    uint s = max(stride, 1u);
    if (samplerId == LUX_SAMPLER_SOBOL && x % s == 0u && y % s == 0u) {
        uint gx = x / s;
        uint gy = y / s;
        uint key = luxTexelIndex(layerSize, layer, (gx - gx % LUX_SOBOL_BLOCK) * s,
                                 (gy - gy % LUX_SOBOL_BLOCK) * s);
        uint rank = gx % LUX_SOBOL_BLOCK + LUX_SOBOL_BLOCK * (gy % LUX_SOBOL_BLOCK);
        return uvec2(key, rank * luxSequence(rays));
    }
    return uvec2(luxTexelIndex(layerSize, layer, x, y), 0u);
}

// rng::Stream::refine: (key, first) of `more` rays refining a gather of `firstRays` rays.
uvec2 luxRefineStream(uint samplerId, uvec2 layerSize, uint layer, uint x, uint y,
                      uint firstRays, uint more) {
    uvec2 g = luxGatherStream(samplerId, layerSize, layer, x, y, 1u, more);
    uint skip = samplerId == LUX_SAMPLER_SOBOL
        ? LUX_SOBOL_BLOCK * LUX_SOBOL_BLOCK * max(luxSequence(firstRays), luxSequence(more))
        : firstRays;
    return uvec2(g.x, skip + g.y);
}

// rng::Sampler::uniform2: the uniforms of sampler `samplerId` (GatherParams::sampler).
vec2 luxSample2(uint samplerId, uint texel, uint sampleIndex, uint pass, uint seed) {
    if (samplerId == LUX_SAMPLER_SOBOL) {
        return luxSobol2(texel, sampleIndex, pass, seed);
    }
    return luxUniform2(texel, sampleIndex, pass, seed);
}
