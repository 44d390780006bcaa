// The glow backend's trace pass for kept gather hits (luxbake::kept): rays
// u_first_ray .. u_first_ray + u_hit_rays (at most four) of each texel's gather sequence —
// gather.glsl's prologue and lib/gather.glsl's rays, operation for operation — cast and their
// closest hits written at the texel's place in the tile (u_hit_origin the tile's first texel),
// one colour attachment per ray: (t, triangle, u, v), triangle -1 where the texel casts no such
// ray or the ray meets nothing. The gather compiled with LUX_REPLAY
// (shader::GLSL_GATHER_REPLAY) reads these instead of tracing: the same hits, bit for bit. In
// a grid draw (u_grid > 1, coarse.glsl) the texels are the grid's, u_hit_origin (0, 0).

uniform ivec2 u_hit_origin;
uniform uint u_hit_rays;
layout(location = 1) out vec4 o_hit1;
layout(location = 2) out vec4 o_hit2;
layout(location = 3) out vec4 o_hit3;

void main() {
    const vec4 NONE = vec4(0.0, -1.0, 0.0, 0.0);
    vec4 hits[4] = vec4[4](NONE, NONE, NONE, NONE);
    ivec3 c = luxGridTexel(ivec3(ivec2(gl_FragCoord.xy) + u_hit_origin, u_layer));
    vec4 pos = texelFetch(u_position, c, 0);
    vec4 nrm = texelFetch(u_normal, c, 0);
    vec3 n;
    // The tile's draw after its grid's keeps no hit of a grid texel.
    uint rays = pos.w > 0.5 && !luxGridCopied(c, u_stride)
                    ? luxCoarseRays(c, u_stride, u_reach, u_rays, u_orphan_rays) : 0u;
    if (rays > u_first_ray && luxNormalize(nrm.xyz, n)) {
        uvec3 layerSize = uvec3(textureSize(u_position, 0));
        uvec2 stream = luxGatherStream(u_sampler, layerSize.xy, uint(c.z), uint(c.x), uint(c.y),
                                       u_stride, rays);
        vec3 origin = luxOffsetOrigin(pos.xyz, n, u_ray_epsilon);
        uint count = min(min(u_hit_rays, 4u), rays - u_first_ray);
        for (uint k = 0u; k < count; ++k) {
            uint s = u_first_ray + k;
            vec3 dir = luxGatherDirection(n, luxSample2(u_sampler, stream.x, stream.y + s,
                                                        u_bounce, u_seed),
                                          pos.w >= LUX_NARROW_GAP);
            vec3 hit;
            int tri = luxTrace(origin, dir, 0.0, uintBitsToFloat(0x7f800000u), false, hit);
            if (tri >= 0) {
                hits[k] = vec4(hit.x, float(tri), hit.y, hit.z);
            }
        }
    }
    o_color = hits[0];
    o_hit1 = hits[1];
    o_hit2 = hits[2];
    o_hit3 = hits[3];
}
