// glint-view: geometry-based planar reflections (issue 9, mode `geometry`).
//
// Appended to `shaders/view.wgsl` at pipeline creation (`src/view/reflections.rs`): it uses
// that file's `frame` uniforms, `VertexIn`, `VertexOut`, `FragmentOut` and `sample_radiosity`.
//
// Per glossy planar reflector and frame:
// 1. `vs_mirror`/`fs_mirror`: the scene drawn from the viewpoint mirrored about the reflector's
//    plane (`frame` holds the mirrored camera's matrix) into an Rgba16Float texture the size of
//    the frame; whatever lies behind the plane (or on it: the reflector itself) is discarded,
//    the clip plane of the mirrored view.
// 2. `vs_main`/`fs_composite`: the reflector's triangles drawn again over the frame, depth
//    tested (GreaterEqual, reverse Z) against the scene pass's depth so only its visible pixels
//    are touched (the mask), adding ks·R(θ) × the reflected radiance at the same pixel
//    (additive blend): L = D + ks·R·M, D being the baked exitant radiance (kd included), R the
//    material's 1D reflectance map (its A channel) at the view angle θ from the normal.
//
// Keep `ReflectParams` in sync with `reflections::ReflectParams` (a test compares them).

struct ReflectParams {
    // xyz: the plane's unit normal (the side it reflects); w: normal · (a point of the plane).
    plane: vec4<f32>,
    // rgb: ks of the reflector's material (sum of its lobes); a: clip distance (metres):
    // fragments at a signed distance ≤ a from the plane are discarded in the mirrored view.
    ks: vec4<f32>,
    // xyz: the eye (per frame); w: the 1D reflectance map's grazing bound C (cos θ).
    eye: vec4<f32>,
    // The mirrored camera's right and up axes (splat billboards).
    right: vec4<f32>,
    up: vec4<f32>,
    // ks·R at the 1D map's cosines C + (1 − C) s², s = k/63 (rgb): Σ_lobes ks × A(cos θ).
    modulation: array<vec4<f32>, 64>,
};

@group(1) @binding(2) var<uniform> reflect_params: ReflectParams;
@group(1) @binding(3) var reflection: texture_2d<f32>;

struct MirrorOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) lightmap: vec2<f32>,
    @location(1) @interpolate(flat) page: u32,
    @location(2) world: vec3<f32>,
};

@vertex
fn vs_mirror(v: VertexIn) -> MirrorOut {
    var out: MirrorOut;
    out.clip = frame.view_proj * vec4<f32>(v.position, 1.0);
    out.lightmap = v.lightmap;
    out.page = v.page;
    out.world = v.position;
    return out;
}

@fragment
fn fs_mirror(in: MirrorOut) -> @location(0) vec4<f32> {
    let side = dot(reflect_params.plane.xyz, in.world) - reflect_params.plane.w;
    if side <= reflect_params.ks.a {
        discard;
    }
    let d = max(sample_radiosity(in.lightmap, in.page), vec3<f32>(0.0)) * frame.exposure;
    return vec4<f32>(d, 1.0);
}

// ks·R at view cosine c: linear in the 1D map's coordinate s = √((c − C)/(1 − C)), clamped
// (`reflectance::sample_1d` on the CPU).
fn modulation(c: f32) -> vec3<f32> {
    let g = reflect_params.eye.w;
    let s = sqrt(clamp((c - g) / (1.0 - g), 0.0, 1.0));
    let x = s * 63.0;
    let i = min(u32(floor(x)), 63u);
    let j = min(i + 1u, 63u);
    let f = x - f32(i);
    return reflect_params.modulation[i].rgb * (1.0 - f) + reflect_params.modulation[j].rgb * f;
}

@fragment
fn fs_composite(in: MirrorOut) -> FragmentOut {
    let m = textureLoad(reflection, vec2<i32>(floor(in.clip.xy)), 0).rgb;
    let cos_theta = dot(reflect_params.plane.xyz, normalize(reflect_params.eye.xyz - in.world));
    let c = modulation(cos_theta) * m;
    var out: FragmentOut;
    // Added to the scene pass's colour by the blend state. A non-sRGB target (the shader
    // encodes there) gets the linear sum approximated by encoding the added term alone.
    var color = c;
    if frame.encode_srgb != 0u {
        color = linear_to_srgb(c);
    }
    out.color = vec4<f32>(color, 0.0);
    out.hdr = vec4<f32>(c, 0.0);
    return out;
}

// Image-based mode: the selected radiance maps' points as camera-facing squares in the
// mirrored view (instanced triangle strips; WebGPU has no point size), nearest wins.
struct SplatIn {
    @location(3) position: vec3<f32>,
    @location(4) radius: f32,
    @location(5) color: vec3<f32>,
};

struct SplatOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) color: vec3<f32>,
};

@vertex
fn vs_splat(@builtin(vertex_index) vi: u32, s: SplatIn) -> SplatOut {
    let corner = vec2<f32>(f32(vi & 1u) * 2.0 - 1.0, f32((vi >> 1u) & 1u) * 2.0 - 1.0);
    let w = s.position
        + (corner.x * reflect_params.right.xyz + corner.y * reflect_params.up.xyz) * s.radius;
    var out: SplatOut;
    out.clip = frame.view_proj * vec4<f32>(w, 1.0);
    out.color = s.color * frame.exposure;
    return out;
}

@fragment
fn fs_splat(in: SplatOut) -> @location(0) vec4<f32> {
    return vec4<f32>(in.color, 1.0);
}
