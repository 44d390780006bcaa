// The gather's ray when it replays kept hits (luxbake::kept; lib/gather_hit.wgsl's twin): the
// hit ray `k` of the dispatch had when trace.wgsl cast it, read from plane `k` of lux_hits at
// the texel's place in the tile. `texel` is lux_texel_index of the texel, which gives back its
// column and row. lux_hits is declared by shader::wgsl_gather_replay_source.

fn lux_gather_hit(origin: vec3<f32>, dir: vec3<f32>, texel: u32, k: u32,
                  hit: ptr<function, vec3<f32>>) -> i32 {
    // In a dispatch of a strided gather's grid texels alone (TileParams::grid ≥ 2) the place is
    // the grid texel's in the compact tile.
    let s = select(1u, lux_tile.grid, lux_tile.grid > 1u);
    let x = (texel % lux_tile.layer_w) / s - lux_tile.x0;
    let y = ((texel / lux_tile.layer_w) % lux_tile.layer_h) / s - lux_tile.y0;
    let kept = lux_hits[(k * lux_tile.height + y) * lux_tile.width + x];
    *hit = kept.xzw;
    return i32(kept.y);
}

// lib/gather_hit.wgsl's lux_gather_direct in the replay: never (kept::replayable), so that
// the replay is a look-up without the lamps' shadow rays.
fn lux_gather_direct(y: vec3<f32>, nh: vec3<f32>, lamps: u32, e: ptr<function, vec3<f32>>)
    -> bool {
    *e = vec3<f32>(0.0);
    return false;
}
