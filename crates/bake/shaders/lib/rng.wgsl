// The stateless random numbers of the gather passes: a bit-exact port of luxbake::rng (see its
// module docs for the specification). u32 arithmetic wraps and shifts are logical in WGSL,
// exactly as u32 wrapping_* in Rust. The LUX_SAMPLER_* ids are generated
// (shader::wgsl_constants).

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

// rng::uniform2: the two uniforms of one draw of the hash sampler.
fn lux_uniform2(texel: u32, sample_index: u32, pass_index: u32, seed: u32) -> vec2<f32> {
    let h = lux_hash(texel, sample_index, pass_index, seed);
    return vec2<f32>(lux_unit(h), lux_unit(lux_pcg(h)));
}

// rng::laine_karras (Burley 2020).
fn lux_laine_karras(v: u32, key: u32) -> u32 {
    var x = v + key;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

// rng::owen: nested uniform scramble of the bits of x.
fn lux_owen(x: u32, key: u32) -> u32 {
    return reverseBits(lux_laine_karras(reverseBits(x), key));
}

// rng::pascal: x times Pascal's triangle mod 2 (reversed, Sobol's dimension 1).
fn lux_pascal(v: u32) -> u32 {
    var x = v;
    x ^= (x >> 1u) & 0x55555555u;
    x ^= (x >> 2u) & 0x33333333u;
    x ^= (x >> 4u) & 0x0f0f0f0fu;
    x ^= (x >> 8u) & 0x00ff00ffu;
    x ^= (x >> 16u) & 0x0000ffffu;
    return x;
}

// rng::sobol2_bits: the texel's shuffled, Owen-scrambled Sobol point of one draw.
fn lux_sobol2_bits(texel: u32, sample_index: u32, pass_index: u32, seed: u32) -> vec2<u32> {
    let key = lux_hash(texel, 0u, pass_index, seed);
    let i = lux_owen(sample_index, key);
    let kx = lux_pcg(key);
    let ky = lux_pcg(kx);
    return vec2<u32>(reverseBits(lux_laine_karras(i, kx)),
                     reverseBits(lux_laine_karras(lux_pascal(i), ky)));
}

// rng::sobol2: the two uniforms of one draw of the Sobol sampler.
fn lux_sobol2(texel: u32, sample_index: u32, pass_index: u32, seed: u32) -> vec2<f32> {
    let b = lux_sobol2_bits(texel, sample_index, pass_index, seed);
    return vec2<f32>(lux_unit(b.x), lux_unit(b.y));
}

// rng::sequence: `rays` rounded up to a power of two (1 for 0, 2^31 past it).
fn lux_sequence(rays: u32) -> u32 {
    var p = 1u;
    while (p < rays && p < 0x80000000u) {
        p <<= 1u;
    }
    return p;
}

// rng::Stream::gather: (key, first) of the draws of a gather of `rays` rays at texel (x, y) on
// the grid of every `stride`-th texel; with the Sobol sampler a grid texel's rank in its block
// of LUX_SOBOL_BLOCK² grid texels times the rays rounded up, in the sequence of the block's
// first texel.
fn lux_gather_stream(sampler_id: u32, layer_size: vec2<u32>, layer: u32, x: u32, y: u32,
                     stride: u32, rays: u32) -> vec2<u32> {
    let s = max(stride, 1u);
    if (sampler_id == LUX_SAMPLER_SOBOL && x % s == 0u && y % s == 0u) {
        let gx = x / s;
        let gy = y / s;
        let key = lux_texel_index(layer_size, layer, (gx - gx % LUX_SOBOL_BLOCK) * s,
                                  (gy - gy % LUX_SOBOL_BLOCK) * s);
        let rank = gx % LUX_SOBOL_BLOCK + LUX_SOBOL_BLOCK * (gy % LUX_SOBOL_BLOCK);
        return vec2<u32>(key, rank * lux_sequence(rays));
    }
    return vec2<u32>(lux_texel_index(layer_size, layer, x, y), 0u);
}

// rng::Stream::refine: (key, first) of `more` rays refining a gather of `first_rays` rays.
fn lux_refine_stream(sampler_id: u32, layer_size: vec2<u32>, layer: u32, x: u32, y: u32,
                     first_rays: u32, more: u32) -> vec2<u32> {
    let g = lux_gather_stream(sampler_id, layer_size, layer, x, y, 1u, more);
    var skip = first_rays;
    if (sampler_id == LUX_SAMPLER_SOBOL) {
        skip = LUX_SOBOL_BLOCK * LUX_SOBOL_BLOCK * max(lux_sequence(first_rays),
                                                       lux_sequence(more));
    }
    return vec2<u32>(g.x, skip + g.y);
}

// rng::Sampler::uniform2: the uniforms of sampler `sampler_id` (GatherParams::sampler).
fn lux_sample2(sampler_id: u32, texel: u32, sample_index: u32, pass_index: u32, seed: u32)
    -> vec2<f32> {
    if (sampler_id == LUX_SAMPLER_SOBOL) {
        return lux_sobol2(texel, sample_index, pass_index, seed);
    }
    return lux_uniform2(texel, sample_index, pass_index, seed);
}
