// glint-view's display pass: the frame's linear radiance (Rgba16Float, every pass drawn into
// it) to the 8-bit target: × 2^EV, the tone curve, sRGB. `src/view/tonemap.rs` is the same
// mapping on the CPU (`tonemap::neutral`, `image_io::linear_to_srgb`); keep them in step.
// Keep `DisplayUniforms` in sync with `src/view/passes/display.rs` (a test compares their layouts).

struct DisplayUniforms {
    // 2^EV: multiplies the radiance before the curve.
    scale: f32,
    // 0: none (clamp), 1: Khronos PBR Neutral.
    mode: u32,
    // 1: the target is not an sRGB format, so encode sRGB here; 0: the hardware does.
    encode_srgb: u32,
    _pad: u32,
};

@group(0) @binding(0) var<uniform> display: DisplayUniforms;
@group(0) @binding(1) var radiance: texture_2d<f32>;

// One triangle over the whole target.
@vertex
fn vs_display(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - vec2<f32>(1.0), 0.0, 1.0);
}

// Khronos PBR Neutral (KhronosGroup/ToneMapping, PBR_Neutral): F90 = 0.04, K_s = 0.8 − F90,
// K_d = 0.15.
fn pbr_neutral(c_in: vec3<f32>) -> vec3<f32> {
    let f90 = 0.04;
    let start = 0.8 - f90;
    let x = min(c_in.r, min(c_in.g, c_in.b));
    var offset = f90;
    if x < 2.0 * f90 {
        offset = x - x * x / (4.0 * f90);
    }
    let c = c_in - vec3<f32>(offset);
    let peak = max(c.r, max(c.g, c.b));
    if peak < start {
        return c;
    }
    let d = 1.0 - start;
    let new_peak = 1.0 - d * d / (peak + d - start);
    let g = 1.0 / (0.15 * (peak - new_peak) + 1.0);
    return c * (new_peak / peak) * g + vec3<f32>(new_peak * (1.0 - g));
}

fn srgb_encode(c: vec3<f32>) -> vec3<f32> {
    let v = clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
    let lo = 12.92 * v;
    let hi = 1.055 * pow(v, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(hi, lo, v <= vec3<f32>(0.0031308));
}

@fragment
fn fs_display(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let l = max(textureLoad(radiance, vec2<i32>(p.xy), 0).rgb, vec3<f32>(0.0)) * display.scale;
    var c = clamp(l, vec3<f32>(0.0), vec3<f32>(1.0));
    if display.mode == 1u {
        c = clamp(pbr_neutral(l), vec3<f32>(0.0), vec3<f32>(1.0));
    }
    if display.encode_srgb != 0u {
        c = srgb_encode(c);
    }
    return vec4<f32>(c, 1.0);
}
