// glint-view: the reflected image M, drawn at FACTOR × the frame's resolution, box-filtered to
// the frame's pixels before the gap fill, M's pyramid and the composite read it
// (`src/view/reflections/downsample.rs`, whose CPU form `downsample::downsample` this shader
// follows). A frame pixel's reflection is then the mean over its area, as its multisampled
// edges are, not one point of the mirrored view.
//
// The mean is over the texels something was drawn to (alpha > 0): a texel nothing was drawn
// to is a hole in image mode, which the composite fills from its neighbours, and in geometry
// mode mostly the mirror's plane continued past its edge behind a wall, where the composite
// reads the nearest covered texels too; averaged in as black it left a dark line along the
// edge. A pixel with no texel drawn to stays empty (alpha 0).

@group(0) @binding(0) var source: texture_2d<f32>;

override FACTOR: u32 = 2u;

@vertex
fn vs_full(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - vec2<f32>(1.0), 0.0, 1.0);
}

@fragment
fn fs_downsample(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let base = vec2<i32>(floor(p.xy)) * i32(FACTOR);
    var sum = vec4<f32>(0.0);
    var n = 0.0;
    for (var y = 0; y < i32(FACTOR); y = y + 1) {
        for (var x = 0; x < i32(FACTOR); x = x + 1) {
            let t = textureLoad(source, base + vec2<i32>(x, y), 0);
            if t.a > 0.0 {
                sum = sum + t;
                n = n + 1.0;
            }
        }
    }
    if n == 0.0 {
        return vec4<f32>(0.0);
    }
    return sum / n;
}
