// glint-view: reflections of depth-map impostors (Popescu et al. 2006 §3.1 and §4.3).
//
// Appended to `shaders/view.wgsl` (frame uniforms, `VertexIn`, `FragmentOut`,
// `linear_to_srgb`) and `shaders/srdm.wgsl` (the SRDM tables and `srdm_intersect`) by
// `src/view/impostors/pass.rs`. Per reflector, its triangles are drawn over the frame, depth tested
// (GreaterEqual, reverse Z) against the scene pass so only its visible pixels run, and each
// pixel:
// 1. computes its reflected ray from its world position and normal (§3.1 step 1; the
//    reflector's plane normal, or the interpolated vertex normal for curved reflectors, so
//    the method is per pixel and needs no ray coherence, §5);
// 2. intersects it with every impostor object through its SRDM rows (§4.3), picking per object
//    the view captured most nearly along the ray; the nearest hit wins;
// 3. adds ks·R(θ) × the captured colour × the distance attenuation (Figure 15) to the frame
//    (additive blend, as the planar composite does); a miss adds nothing (no environment map
//    is baked yet, §3.1 step 3).
//
// Keep `ImpostorParams` in sync with `impostor_tables::ImpostorParams` (a test compares sizes).

struct ImpostorParams {
    // xyz: the reflector's unit normal (its reflecting side); w: 1 to use it, 0 to take the
    // triangle's normal from screen derivatives (curved reflectors).
    normal: vec4<f32>,
    // xyz: the eye; w: the 1D reflectance map's grazing bound C (cos θ).
    eye: vec4<f32>,
    // x: 1 / attenuation distance (0: no attenuation); y: impostor objects; z: t_max; w: 0.
    settings: vec4<f32>,
    // ks·R at cosines C + (1 − C) s², s = k/63 (rgb): the Fresnel modulation (Figure 15).
    modulation: array<vec4<f32>, 64>,
};

@group(2) @binding(0) var<uniform> impostor_params: ImpostorParams;

// A reflector's vertex: position and vertex normal (`CurvedVertex`).
struct ImpostorIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
};

struct ImpostorOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
};

@vertex
fn vs_impostor(v: ImpostorIn) -> ImpostorOut {
    var out: ImpostorOut;
    out.clip = frame.view_proj * vec4<f32>(v.position, 1.0);
    out.world = v.position;
    out.normal = v.normal;
    return out;
}

// The reflecting normal at a pixel: the reflector's plane normal, or for curved reflectors the
// interpolated vertex normal (the facets of a tessellated sphere turn reflected rays by up to
// ~15°, which loses second-order hits), falling back to the facet's normal where the vertex
// normals cancel. Faces the eye.
fn impostor_normal(in: ImpostorOut, to_pixel: vec3<f32>) -> vec3<f32> {
    let facet = cross(dpdx(in.world), dpdy(in.world));
    var n = impostor_params.normal.xyz;
    if impostor_params.normal.w == 0.0 {
        if dot(in.normal, in.normal) > 1e-12 {
            n = normalize(in.normal);
        } else {
            n = normalize(facet);
        }
    }
    if dot(n, to_pixel) > 0.0 {
        n = -n;
    }
    return n;
}

// ks·R at view cosine c, linear in the 1D map's coordinate s = √((c − C)/(1 − C)).
fn impostor_modulation(c: f32) -> vec3<f32> {
    let g = impostor_params.eye.w;
    let s = sqrt(clamp((c - g) / (1.0 - g), 0.0, 1.0));
    let x = s * 63.0;
    let i = min(u32(floor(x)), 63u);
    let j = min(i + 1u, 63u);
    let f = x - f32(i);
    return impostor_params.modulation[i].rgb * (1.0 - f) + impostor_params.modulation[j].rgb * f;
}

// Figure 15, left: reflections fade with the distance t travelled by the reflected ray,
// exp(−t / distance); 1 when the setting is off (the reference path tracer has no such term).
fn impostor_attenuation(t: f32) -> f32 {
    return exp(-t * impostor_params.settings.x);
}

@fragment
fn fs_impostor(in: ImpostorOut) -> FragmentOut {
    let to_pixel = normalize(in.world - impostor_params.eye.xyz);
    let n = impostor_normal(in, to_pixel);
    // §3.1 step 1: the reflected ray.
    let dir = reflect(to_pixel, n);
    let objects = u32(impostor_params.settings.y);
    var best_t = impostor_params.settings.z;
    var found = false;
    var colour = vec3<f32>(0.0);
    for (var k = 0u; k < objects; k++) {
        let vi = srdm_pick_view(k, dir);
        let h = srdm_intersect(vi, in.world, dir, best_t);
        if h.hit && h.t < best_t {
            best_t = h.t;
            found = true;
            colour = srdm_colour(vi, h.pixel);
        }
    }
    if !found {
        discard;
    }
    let cos_theta = dot(n, -to_pixel);
    let c = impostor_modulation(cos_theta) * colour * impostor_attenuation(best_t)
        * frame.exposure;
    var out: FragmentOut;
    var color = c;
    if frame.encode_srgb != 0u {
        color = linear_to_srgb(c);
    }
    out.color = vec4<f32>(color, 0.0);
    out.hdr = vec4<f32>(c, 0.0);
    return out;
}
