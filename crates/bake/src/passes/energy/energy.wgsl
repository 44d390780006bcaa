// Pass "energy": the sum of one row of `lux_src` — texel (i, 0) is the sum of r + g + b over
// the valid texels (alpha > 0.5) of row i of the source, in runs of 64 texels (each run's sum
// added to the total), with alpha 1. Applied to a map and then to its row of row sums, it
// leaves a check's energy in one texel per layer.

fn lux_run(c: vec2<i32>) -> vec4<f32> {
    let width = i32(textureDimensions(lux_src).x);
    var total = 0.0;
    for (var x0 = 0; x0 < width; x0 += 64) {
        var run = 0.0;
        let x1 = min(x0 + 64, width);
        for (var x = x0; x < x1; x += 1) {
            let t = lux_load(lux_src, vec2<i32>(x, c.x));
            if (t.a > 0.5) {
                run += (t.r + t.g) + t.b;
            }
        }
        total += run;
    }
    return vec4<f32>(total, 0.0, 0.0, 1.0);
}
