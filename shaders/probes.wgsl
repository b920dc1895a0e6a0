// glint-view: reflection probes, the specular term of glossy surfaces that no reflector
// declares (`src/view/probes`).
//
// Appended to `shaders/view.wgsl` at pipeline creation: it uses that file's `frame` uniforms.
// Group 1 starts at binding 20, clear of view.wgsl's and curved.wgsl's bindings.
//
// Per fragment: ks·A(n·ω_o) × the probe's prefiltered radiance in the mirror direction, at
// the MIP level of the material's lobe, the direction first moved to where the reflected ray
// from the fragment meets the room (the distances the probe stores), added to kd·D.
//
// Keep `ProbeParams` in sync with `view::probes::ProbeParams` (a test compares them).

struct ProbeParams {
    // xyz: the probe's centre; w: 1 = distance-corrected lookups, 0 = from the centre.
    centre: vec4<f32>,
    // x: the MIP level of the material's lobe; y: 1 double-sided, 0 back faces black
    // (`probes::sides`); zw: unused.
    info: vec4<f32>,
    // ks·A at the 1D reflectance map's cosines (`reflectance::map_1d_cos`, 64 entries).
    modulation: array<vec4<f32>, 64>,
};

@group(1) @binding(20) var<uniform> probe: ProbeParams;
@group(1) @binding(21) var probe_env: texture_cube<f32>;
// Level 0 only: the distance from the centre to what each texel sees (0: nothing).
@group(1) @binding(22) var probe_distance: texture_cube<f32>;
@group(1) @binding(23) var probe_sampler: sampler;

struct ProbeVertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
};

struct ProbeOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
};

// `reflectance::C_GRAZING`.
const PROBE_C_GRAZING: f32 = 0.03125;
// Fixed-point steps of the distance correction.
const PROBE_STEPS: u32 = 4u;

@vertex
fn vs_probe(v: ProbeVertexIn) -> ProbeOut {
    var out: ProbeOut;
    out.clip = frame.view_proj * vec4<f32>(v.position, 1.0);
    out.world = v.position;
    out.normal = v.normal;
    return out;
}

// ks·A at view cosine `c`: the table read linearly at s = √((c − C)/(1 − C))
// (`reflectance::map_1d_coordinate`; `material::sample_modulation` on the CPU).
fn probe_modulation(c: f32) -> vec3<f32> {
    let s = sqrt(clamp((c - PROBE_C_GRAZING) / (1.0 - PROBE_C_GRAZING), 0.0, 1.0));
    let x = s * 63.0;
    let k = min(u32(floor(x)), 62u);
    let f = x - f32(k);
    return mix(probe.modulation[k].rgb, probe.modulation[k + 1u].rgb, f);
}

// Where the ray from the point `offset` away from the centre along unit `dir` meets the room,
// as a direction from the centre (`probes::parallax_direction`): the distance the probe
// stores in the current direction is taken as a sphere about the centre, the ray's exit from
// it gives the next direction.
fn probe_lookup(offset: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {
    if probe.centre.w == 0.0 {
        return dir;
    }
    let b = dot(offset, dir);
    let c = dot(offset, offset);
    var d = dir;
    for (var i = 0u; i < PROBE_STEPS; i++) {
        let s = textureSampleLevel(probe_distance, probe_sampler, d, 0.0).r;
        if s <= 0.0 {
            return d;
        }
        let t = -b + sqrt(max(b * b - c + s * s, 0.0));
        let x = offset + dir * t;
        if dot(x, x) <= 0.0 {
            return d;
        }
        d = normalize(x);
    }
    return d;
}

@fragment
fn fs_probe(in: ProbeOut) -> @location(0) vec4<f32> {
    let wo = normalize(frame.eye.xyz - in.world);
    var n = normalize(in.normal);
    if dot(n, wo) < 0.0 {
        if probe.info.y == 0.0 {
            return vec4<f32>(0.0);
        }
        n = -n;
    }
    let c = dot(n, wo);
    let r = 2.0 * c * n - wo;
    let d = probe_lookup(in.world - probe.centre.xyz, r);
    let env = textureSampleLevel(probe_env, probe_sampler, d, probe.info.x).rgb;
    // Added to kd·D of the scene pass by the blend state.
    return vec4<f32>(env * probe_modulation(c) * frame.exposure, 0.0);
}
