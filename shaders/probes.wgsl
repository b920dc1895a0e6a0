// glint-view: reflection probes, the specular term of glossy surfaces that no reflector
// declares (`src/view/probes`).
//
// Appended to `shaders/view.wgsl` at pipeline creation: it uses that file's `frame` uniforms.
// Group 1 starts at binding 20, clear of view.wgsl's and curved.wgsl's bindings.
//
// Per fragment: ks·A(n·ω_o) × the probe's radiance over the material's lobe, added to kd·D.
// The lobe is read as PROBE_SAMPLES directions drawn from its GGX distribution of normals
// (filtered importance sampling: each sample at the MIP level of its share of the lobe),
// those under the surface dropped, each weighted by the lobe's F G (ω_o·h)/(n·h) (its
// f cos θ_i over the density it was drawn with); each direction first moved to where
// the ray from the fragment meets the room (the distances the probe stores), its level to
// its footprint there as the centre sees it. At grazing view the lobe's samples that stay
// above the surface are what it reflects, which a single mirror lookup misses. The lobe is
// widened by the pixel's spread of normals (specular anti-aliasing). The result is
// scaled by the square root of the irradiance the fragment's lightmap texel was solved with
// over the probe's at its normal, at most 1 (`probes::Normalization`).
//
// Keep `ProbeParams` in sync with `view::probes::ProbeParams` (a test compares them).

struct ProbeParams {
    // xyz: the probe's centre; w: 1 = distance-corrected lookups, 0 = from the centre.
    centre: vec4<f32>,
    // x: the MIP level of the material's lobe; y: 1 double-sided, 0 back faces black
    // (`probes::sides`); z: the lobe's GGX α; w: its Fresnel reflectance at normal incidence.
    info: vec4<f32>,
    // x: luminance of the material's albedo factor (0: probe light not normalized); y: the
    // luminance of the emission its stored texels hold (`probes::Normalization`); z: 1 with
    // specular anti-aliasing, 0 without.
    surface: vec4<f32>,
    // The probe's irradiance over π as luminance on bands 0-2 (`probes::irradiance_sh`).
    irradiance: array<vec4<f32>, 3>,
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
    // Lightmap coordinates in texels of the vertex's page (`probes::gpu::ProbeLightmap`).
    @location(2) lightmap: vec2<f32>,
    @location(3) page: u32,
};

struct ProbeOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    // Centroid: a multisampled edge pixel reads D inside the triangle.
    @location(2) @interpolate(perspective, centroid) lightmap: vec2<f32>,
    @location(3) @interpolate(flat) page: u32,
};

// `reflectance::C_GRAZING`.
const PROBE_C_GRAZING: f32 = 0.03125;
// Fixed-point steps of the distance correction.
const PROBE_STEPS: u32 = 4u;
// Directions of the lobe read per fragment (`probes::LOBE_SAMPLES`).
const PROBE_SAMPLES: u32 = 8u;
const PROBE_PI: f32 = 3.14159265;
// `probes::MIN_FOOTPRINT_RATIO`.
const PROBE_MIN_RATIO: f32 = 0.001;

@vertex
fn vs_probe(v: ProbeVertexIn) -> ProbeOut {
    var out: ProbeOut;
    out.clip = frame.view_proj * vec4<f32>(v.position, 1.0);
    out.world = v.position;
    out.normal = v.normal;
    out.lightmap = v.lightmap;
    out.page = v.page;
    return out;
}

// The probe's irradiance over π at unit `n` (`probes::irradiance_at`, `probes::sh_basis`).
fn probe_irradiance(n: vec3<f32>) -> f32 {
    let c = probe.irradiance;
    return c[0].x * 0.282095
        + 0.488603 * (c[0].y * n.y + c[0].z * n.z + c[0].w * n.x)
        + 1.092548 * (c[1].x * n.x * n.y + c[1].y * n.y * n.z + c[1].w * n.x * n.z)
        + c[1].z * 0.315392 * (3.0 * n.z * n.z - 1.0)
        + c[2].x * 0.546274 * (n.x * n.x - n.y * n.y);
}

// The factor on the probe's light (`probes::Normalization::factor`): the square root of what
// the surface received, from the texel the solve lit it with, over what the probe sees at its
// normal, at most 1.
fn probe_normalization(lightmap: vec2<f32>, page: u32, n: vec3<f32>) -> f32 {
    let seen = probe_irradiance(n);
    if probe.surface.x <= 0.0 || seen <= 0.0 {
        return 1.0;
    }
    let stored = dot(max(sample_radiosity(lightmap, page), vec3<f32>(0.0)), vec3<f32>(0.2126, 0.7152, 0.0722));
    let received = max(stored - probe.surface.y, 0.0) / probe.surface.x;
    return sqrt(min(received / seen, 1.0));
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
// as a direction from the centre (xyz), and that point's distance from the shaded point over
// its distance from the centre (w; 1 where nothing moved) (`probes::parallax_lookup`): the
// distance the probe stores in the current direction is taken as a sphere about the centre,
// the ray's exit from it gives the next direction.
fn probe_lookup(offset: vec3<f32>, dir: vec3<f32>) -> vec4<f32> {
    if probe.centre.w == 0.0 {
        return vec4<f32>(dir, 1.0);
    }
    let b = dot(offset, dir);
    let c = dot(offset, offset);
    var d = dir;
    var ratio = 1.0;
    for (var i = 0u; i < PROBE_STEPS; i++) {
        let s = textureSampleLevel(probe_distance, probe_sampler, d, 0.0).r;
        if s <= 0.0 {
            break;
        }
        let t = -b + sqrt(max(b * b - c + s * s, 0.0));
        let x = offset + dir * t;
        if dot(x, x) <= 0.0 {
            break;
        }
        ratio = t / length(x);
        d = normalize(x);
    }
    return vec4<f32>(d, ratio);
}

// The level of a lookup whose lobe, `lod` as the centre would see it, meets the room at
// `ratio` times its distance from the centre (`probes::footprint_lod`): the lobe's footprint
// there subtends ratio² of its solid angle from the centre.
fn probe_footprint_lod(lod: f32, ratio: f32) -> f32 {
    return max(lod + log2(max(ratio, PROBE_MIN_RATIO)), 0.0);
}

// Sample `i` of PROBE_SAMPLES of the unit square (Hammersley: i/N, radical inverse of i).
fn probe_hammersley(i: u32) -> vec2<f32> {
    return vec2<f32>(
        (f32(i) + 0.5) / f32(PROBE_SAMPLES),
        f32(reverseBits(i)) * 2.3283064e-10,
    );
}

// Smith's Λ of the GGX lobe of α² = `a2` at cosine `c` to the normal.
fn probe_smith_lambda(c: f32, a2: f32) -> f32 {
    let t2 = max(1.0 - c * c, 0.0) / max(c * c, 1e-8);
    return 0.5 * (sqrt(1.0 + a2 * t2) - 1.0);
}

// The probe's radiance over the GGX lobe of α = `alpha` about `n` seen from `wo`, at the
// point `offset` from the centre (the weighted mean of the samples above the surface; the
// mirror direction `r` alone where none is).
fn probe_lobe(offset: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, r: vec3<f32>, alpha: f32) -> vec3<f32> {
    let size = f32(textureDimensions(probe_env).x);
    // A level-0 texel's solid angle, 4π / (6 size²).
    let texel = 4.0 * PROBE_PI / (6.0 * size * size);
    let a2 = max(alpha * alpha, 1e-8);
    let up = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 0.0, 1.0), abs(n.x) > 0.9);
    let tx = normalize(cross(up, n));
    let ty = cross(n, tx);
    let r0 = probe.info.w;
    let lambda_o = probe_smith_lambda(dot(n, wo), a2);
    var sum = vec3<f32>(0.0);
    var weight = 0.0;
    for (var i = 0u; i < PROBE_SAMPLES; i++) {
        let xi = probe_hammersley(i);
        let cos_h = sqrt((1.0 - xi.x) / (1.0 + (a2 - 1.0) * xi.x));
        let sin_h = sqrt(max(1.0 - cos_h * cos_h, 0.0));
        let phi = 2.0 * PROBE_PI * xi.y;
        let h = tx * (sin_h * cos(phi)) + ty * (sin_h * sin(phi)) + n * cos_h;
        let vh = dot(wo, h);
        let wi = 2.0 * vh * h - wo;
        let nl = dot(n, wi);
        if nl <= 0.0 || vh <= 0.0 {
            continue;
        }
        // The sample's share of the lobe, 1 / (N pdf), pdf = D(h) (n·h) / (4 v·h).
        let q = cos_h * cos_h * (a2 - 1.0) + 1.0;
        let pdf = a2 / (PROBE_PI * q * q) * cos_h / (4.0 * vh);
        // A trilinear lookup spans about 2×2 texels of its level (as `probes::lobe_lod`).
        let lod = 0.5 * log2(max(1.0 / (4.0 * f32(PROBE_SAMPLES) * pdf * texel), 1.0));
        let u = probe_lookup(offset, wi);
        let level = probe_footprint_lod(lod, u.w);
        // f cos θ_i / pdf up to factors common to all samples: F G (ω_o·h) / (n·h).
        let fresnel = r0 + (1.0 - r0) * pow(1.0 - vh, 5.0);
        let g = 1.0 / (1.0 + lambda_o + probe_smith_lambda(nl, a2));
        let w = fresnel * g * vh / max(cos_h, 1e-4);
        sum += textureSampleLevel(probe_env, probe_sampler, u.xyz, level).rgb * w;
        weight += w;
    }
    if weight > 0.0 {
        return sum / weight;
    }
    let u = probe_lookup(offset, r);
    return textureSampleLevel(probe_env, probe_sampler, u.xyz, probe_footprint_lod(probe.info.x, u.w)).rgb;
}

@fragment
fn fs_probe(in: ProbeOut) -> @location(0) vec4<f32> {
    let wo = normalize(frame.eye.xyz - in.world);
    var n = normalize(in.normal);
    // The lobe widened by the pixel's spread of normals (view.wgsl's `kernel_roughness2`), so
    // that a highlight narrower than a pixel (a chair's chrome wire, a rim) spreads over it.
    // Derivatives before any return.
    let kernel2 = select(0.0, kernel_roughness2(n), probe.surface.z != 0.0);
    let alpha = sqrt(probe.info.z * probe.info.z + kernel2);
    if dot(n, wo) < 0.0 {
        if probe.info.y == 0.0 {
            return vec4<f32>(0.0);
        }
        n = -n;
    }
    let c = dot(n, wo);
    let r = 2.0 * c * n - wo;
    let env = probe_lobe(in.world - probe.centre.xyz, n, wo, r, alpha)
        * probe_normalization(in.lightmap, in.page, n);
    // Added to kd·D of the scene pass by the blend state.
    return vec4<f32>(env * probe_modulation(c) * frame.exposure, 0.0);
}
