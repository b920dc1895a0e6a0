// glint-view: filling the holes that image mode's splats leave in the reflected image M
// (`src/view/reflections/hole_fill.rs`), by pull-push (Gortler et al. 1996, "The
// Lumigraph" §3.3; Grossman & Dally 1998): a pyramid of M's covered texels averaged 2×2
// (premultiplied by coverage: rgb·w, w), then every texel nothing was drawn to read from the
// finest level that has coverage there. Holes are where the splat pass left the map's depth
// at its clear value: the fill pass draws at that depth with an `Equal` test, scissored to the
// reflector's screen rectangle, so covered texels are never touched.

@group(0) @binding(0) var source: texture_2d<f32>;
@group(0) @binding(1) var pyramid_sampler: sampler;

@vertex
fn vs_fill_screen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let p = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    // z = 0: reverse Z's clear value, so the `Equal` test passes only where nothing was drawn.
    return vec4<f32>(p * 2.0 - 1.0, 0.0, 1.0);
}

// The 2×2 texels of `source` under a texel of the next level (clamped at the edge; the last
// row and column of an odd size folded into the level's last texel).
fn children(p: vec2<f32>, premultiply: bool) -> vec4<f32> {
    let size = vec2<i32>(textureDimensions(source));
    let q = vec2<i32>(floor(p)) * 2;
    let out_size = max(size / 2, vec2<i32>(1));
    // The last texel of the next level also takes an odd size's last row/column.
    let extra = select(vec2<i32>(0), size - out_size * 2, vec2<i32>(floor(p)) == out_size - 1);
    var sum = vec4<f32>(0.0);
    for (var y = 0; y <= 1 + extra.y; y++) {
        for (var x = 0; x <= 1 + extra.x; x++) {
            let t = textureLoad(source, min(q + vec2<i32>(x, y), size - 1), 0);
            if premultiply {
                // M: alpha > 0 where a splat was drawn (the beyond fraction).
                let w = select(0.0, 1.0, t.a > 0.0);
                sum += vec4<f32>(t.rgb * w, w);
            } else {
                sum += t;
            }
        }
    }
    let n = f32((2 + extra.x) * (2 + extra.y));
    return sum / n;
}

// Pyramid level 1 from M.
@fragment
fn fs_pull_first(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    return children(p.xy, true);
}

// Pyramid level ℓ + 1 from level ℓ.
@fragment
fn fs_pull(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    return children(p.xy, false);
}

// A hole of M (`source` is the whole pyramid here): the finest level whose bilinear,
// coverage-weighted sample has coverage; alpha 1 (K at its widest: the fill is a blurred
// estimate anyway).
@fragment
fn fs_fill(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let levels = textureNumLevels(source);
    // Level ℓ of the pyramid is M's level ℓ + 1: normalised coordinates are shared.
    let uv = p.xy / (vec2<f32>(textureDimensions(source, 0)) * 2.0);
    for (var l = 0u; l < levels; l++) {
        let s = textureSampleLevel(source, pyramid_sampler, uv, f32(l));
        if s.a > 1e-3 {
            return vec4<f32>(s.rgb / s.a, 1.0);
        }
    }
    return vec4<f32>(0.0);
}
