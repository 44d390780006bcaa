// Scene resources of the ray-casting passes, uploaded once per bake (program::SceneNeeds).

// Ray-origin offset along the normal, world units (SceneData::ray_epsilon).
uniform float u_ray_epsilon;

// u_lamps holds one column per uploaded lamp, its eight rows packed by luxbake::pack: row 0
// (position.xyz, table), rows 1-3 world-to-photometric matrix rows (xyz, 0), row 4
// (scale.rgb, 0), row 5 (table offset, table width, table height, 0), rows 6-7 the luminous
// opening (half.uvw, near), (kind, axis, faces, size) (opening.glsl).
uniform highp sampler2DArray u_lamps;

vec4 luxLamp(int lamp, int row) {
    return texelFetch(u_lamps, ivec3(lamp, row, 0), 0);
}

// u_path_points: the lamp paths' points (backend::SceneData::lamp_paths), LAMP_PATH_TEXELS = 3
// texels each — (position.xyz, density), (normal.xyz, 0), (power.rgb, 0) — texel i at
// (i % width, i / width).
uniform highp sampler2DArray u_path_points;

vec4 luxPathPoint(uint path, int row) {
    int i = int(path) * 3 + row;
    int width = textureSize(u_path_points, 0).x;
    ivec2 qr = luxDivMod(i, width);
    return texelFetch(u_path_points, ivec3(qr.y, qr.x, 0), 0);
}

// The points the texture holds.
uint luxPathPointCount() {
    ivec3 size = textureSize(u_path_points, 0);
    return uint(size.x * size.y) / 3u;
}

// u_regions: one column per object id: row 0 (layer, offset.x, offset.y, receiver ? 1 : 0),
// row 1 (width, height, 0, 0); non-receivers (receiver = 0) reflect nothing.
uniform highp sampler2DArray u_regions;

// backend::offset_coordinate / offset_origin: the ray origin for surface point p with unit
// normal n (Wächter & Binder, Ray Tracing Gems ch. 6, plus the size term u_ray_epsilon):
// p + n * size, then each coordinate stepped trunc(4 * n) ULPs along n in integer space.
float luxOffsetCoordinate(float p, float n, float size) {
    float q = p + n * size;
    int steps = int(4.0 * n);
    if (!(abs(q) >= 1e-30) || isinf(q)) {
        return q;
    }
    int bits = floatBitsToInt(q);
    return intBitsToFloat(q < 0.0 ? bits - steps : bits + steps);
}

vec3 luxOffsetOrigin(vec3 p, vec3 n, float size) {
    return vec3(luxOffsetCoordinate(p.x, n.x, size), luxOffsetCoordinate(p.y, n.y, size),
                luxOffsetCoordinate(p.z, n.z, size));
}
