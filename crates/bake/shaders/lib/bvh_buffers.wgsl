// BVH data access, storage-buffer variant: the EncodedScene texel arrays uploaded unchanged as
// array<vec4<f32>>. Texel (x, y) of layer l of a w x h "texture" is element (l * h + y) * w + x,
// exactly luxbake_bvh::layout's float layout divided by 4. Out-of-range indices read zero, as
// the CPU's texel_fetch does (WGSL would clamp or return zero; we never rely on either).
@group(1) @binding(0) var<storage, read> lux_bounds: array<vec4<f32>>;
@group(1) @binding(1) var<storage, read> lux_links: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> lux_triangles: array<vec4<f32>>;

fn lux_fetch_index(c: vec2<i32>, layer: i32, w: u32, h: u32) -> u32 {
    return (u32(layer) * h + u32(c.y)) * w + u32(c.x);
}

fn lux_bounds_at(node: vec2<i32>, layer: i32) -> vec4<f32> {
    let i = lux_fetch_index(node, layer, lux_scene.node_w, lux_scene.node_h);
    if (i >= arrayLength(&lux_bounds)) {
        return vec4<f32>(0.0);
    }
    return lux_bounds[i];
}

fn lux_link_at(node: vec2<i32>, layer: i32) -> vec4<f32> {
    let i = lux_fetch_index(node, layer, lux_scene.node_w, lux_scene.node_h);
    if (i >= arrayLength(&lux_links)) {
        return vec4<f32>(0.0);
    }
    return lux_links[i];
}

fn lux_triangle_at(c: vec2<i32>, layer: i32) -> vec4<f32> {
    let i = lux_fetch_index(c, layer, lux_scene.tri_w, lux_scene.tri_h);
    if (i >= arrayLength(&lux_triangles)) {
        return vec4<f32>(0.0);
    }
    return lux_triangles[i];
}
