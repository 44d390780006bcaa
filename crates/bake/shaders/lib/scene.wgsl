// The static scene data of the ray-casting passes (bind group 1), uploaded once per bake.
// Bindings 0-2 (the BVH) are declared by bvh_buffers.wgsl or bvh_textures.wgsl.

struct LuxScene {
    node_w: u32,         // node texture width: node i is texel (i % node_w, i / node_w)
    node_h: u32,
    tri_w: u32,          // triangle texture width: triangle t is texel (t % tri_w, t / tri_w)
    tri_h: u32,
    node_count: i32,
    triangle_count: i32,
    object_count: i32,   // entries of lux_regions / 2
    pad0: u32,
    ray_epsilon: f32,    // SceneData::ray_epsilon
    t_far: f32,          // +infinity (the gather's closest-hit range), set from the CPU
    pad1: u32,
    pad2: u32,
}

// Intensity tables, candela, concatenated: value (row j, column i) of a table at `offset` with
// `width` columns is lux_ies[offset + j * width + i] (see ies.wgsl).
@group(1) @binding(3) var<storage, read> lux_ies: array<f32>;
// Two entries per object id: (layer, offset.x, offset.y, receiver ? 1 : 0), (width, height, 0, 0).
@group(1) @binding(4) var<storage, read> lux_regions: array<vec4<u32>>;
@group(1) @binding(5) var<uniform> lux_scene: LuxScene;

// One uploaded lamp (LampParams), in the order the direct pass evaluates them: position.xyz;
// the rows of the world-to-photometric matrix; scale.rgb; (offset of its table in lux_ies,
// width, height).
struct LuxLamp {
    position: vec4<f32>,
    m0: vec4<f32>,
    m1: vec4<f32>,
    m2: vec4<f32>,
    scale: vec4<f32>,
    table: vec4<u32>,
    // The luminous opening (opening.wgsl): (half.uvw, near), (kind, axis, faces, size).
    opening: vec4<f32>,
    shape: vec4<f32>,
}

@group(1) @binding(6) var<storage, read> lux_lamps: array<LuxLamp>;

// The lamp paths' points (backend::SceneData::lamp_paths), 3 entries each: (position.xyz,
// density), (normal.xyz, 0), (power.rgb, 0). At least one (zero) point is bound.
@group(1) @binding(7) var<storage, read> lux_path_points: array<vec4<f32>>;

fn lux_path_point(path: u32, row: u32) -> vec4<f32> {
    return lux_path_points[path * 3u + row];
}

// The points the buffer holds.
fn lux_path_point_count() -> u32 {
    return arrayLength(&lux_path_points) / 3u;
}

// backend::offset_coordinate / offset_origin: the ray origin for surface point p with unit
// normal n (Wächter & Binder, Ray Tracing Gems ch. 6, plus the size term ray_epsilon):
// p + n * size, then each coordinate stepped trunc(4 * n) ULPs along n in integer space.
fn lux_offset_coordinate(p: f32, n: f32, size: f32) -> f32 {
    let q = p + n * size;
    let steps = i32(4.0 * n);
    if (!(abs(q) >= 1e-30) || !lux_finite(q)) {
        return q;
    }
    let bits = bitcast<i32>(q);
    if (q < 0.0) {
        return bitcast<f32>(bits - steps);
    }
    return bitcast<f32>(bits + steps);
}

fn lux_offset_origin(p: vec3<f32>, n: vec3<f32>, size: f32) -> vec3<f32> {
    return vec3<f32>(lux_offset_coordinate(p.x, n.x, size), lux_offset_coordinate(p.y, n.y, size),
                     lux_offset_coordinate(p.z, n.z, size));
}
