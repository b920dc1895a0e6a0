// glint-view: the resolve of a multisampled reflection map M into its single-sampled texture
// (`src/view/reflections/map_target.rs`), so an edge in the reflection is anti-aliased as the
// frame's own edges are.
//
// `fs_resolve_all` (geometry mode: an empty sample reflects black): the mean of every sample.
// `fs_resolve_covered` (image mode: alpha 0 marks a hole the gap fill and the pyramid fill):
// the mean of the samples holding a reflection (alpha > 0), a hole where none does, so a
// texel on a splat's rim keeps its radiance and its beyond fraction.

@group(0) @binding(0) var samples: texture_multisampled_2d<f32>;

// One triangle over the whole target.
@vertex
fn vs_full(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - vec2<f32>(1.0), 0.0, 1.0);
}

@fragment
fn fs_resolve_all(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let texel = vec2<i32>(floor(p.xy));
    let n = textureNumSamples(samples);
    var sum = vec4<f32>(0.0);
    for (var s = 0u; s < n; s++) {
        sum += textureLoad(samples, texel, i32(s));
    }
    return sum / f32(n);
}

@fragment
fn fs_resolve_covered(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let texel = vec2<i32>(floor(p.xy));
    let n = textureNumSamples(samples);
    var sum = vec4<f32>(0.0);
    var covered = 0.0;
    for (var s = 0u; s < n; s++) {
        let m = textureLoad(samples, texel, i32(s));
        if m.a > 0.0 {
            sum += m;
            covered += 1.0;
        }
    }
    return select(vec4<f32>(0.0), sum / max(covered, 1.0), covered > 0.0);
}
