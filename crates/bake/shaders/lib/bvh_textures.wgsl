// BVH data access, texture variant (the paper's encoding as it is): RGBA32F texture arrays read
// with textureLoad, exactly as the glow backend's bvh.glsl reads them with texelFetch.
@group(1) @binding(0) var lux_bounds: texture_2d_array<f32>;
@group(1) @binding(1) var lux_links: texture_2d_array<f32>;
@group(1) @binding(2) var lux_triangles: texture_2d_array<f32>;

fn lux_bounds_at(node: vec2<i32>, layer: i32) -> vec4<f32> {
    return textureLoad(lux_bounds, node, layer, 0);
}

fn lux_link_at(node: vec2<i32>, layer: i32) -> vec4<f32> {
    return textureLoad(lux_links, node, layer, 0);
}

fn lux_triangle_at(c: vec2<i32>, layer: i32) -> vec4<f32> {
    return textureLoad(lux_triangles, c, layer, 0);
}
