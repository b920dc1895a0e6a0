// glint-view: the MIP pyramid of a reflected image M that the composite's constant-cost M*K
// reads (`src/view/reflections/pyramid.rs`; the CPU form is `filter::Pyramid`).
//
// Level 0: (rgb·c, c) of M, c = 1 for a texel holding a reflection (alpha > 0), 0 for a hole
// (`fs_base_covered`, image mode), or c = 1 everywhere (`fs_base_all`, geometry mode: an empty
// texel reflects black). Level k: the bilinear read of level k − 1 at the texel's centre (a
// 2×2 box where the sizes halve exactly), `fs_down`.

@group(0) @binding(0) var source: texture_2d<f32>;
@group(0) @binding(1) var source_sampler: sampler;

// One triangle over the whole target.
@vertex
fn vs_full(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - vec2<f32>(1.0), 0.0, 1.0);
}

@fragment
fn fs_base_covered(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let m = textureLoad(source, vec2<i32>(floor(p.xy)), 0);
    return select(vec4<f32>(0.0), vec4<f32>(m.rgb, 1.0), m.a > 0.0);
}

@fragment
fn fs_base_all(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let m = textureLoad(source, vec2<i32>(floor(p.xy)), 0);
    return vec4<f32>(m.rgb, 1.0);
}

@fragment
fn fs_down(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    // The target's size: the source level halved, at least 1.
    let size = max(vec2<f32>(textureDimensions(source)) * 0.5, vec2<f32>(1.0));
    return textureSampleLevel(source, source_sampler, p.xy / floor(size), 0.0);
}
