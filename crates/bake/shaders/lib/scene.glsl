// Scene resources of the ray-casting passes, uploaded once per bake (program::SceneNeeds).

// Ray-origin offset along the normal, world units (SceneData::ray_epsilon).
uniform float u_ray_epsilon;

// u_lamps holds one column per uploaded lamp, its six rows packed by luxbake::pack: row 0
// (position.xyz, table), rows 1-3 world-to-photometric matrix rows (xyz, 0), row 4
// (scale.rgb, 0), row 5 (table offset, table width, table height, 0).
uniform highp sampler2DArray u_lamps;

vec4 luxLamp(int lamp, int row) {
    return texelFetch(u_lamps, ivec3(lamp, row, 0), 0);
}

// u_regions: one column per object id: row 0 (layer, offset.x, offset.y, receiver ? 1 : 0),
// row 1 (width, height, 0, 0); non-receivers (receiver = 0) reflect nothing.
uniform highp sampler2DArray u_regions;
