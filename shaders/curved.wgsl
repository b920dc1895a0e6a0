// glint-view: curved reflectors by cube maps (Nielsen & Christensen 2002 §3.2) and glossy
// curved objects by regular sampling (Luksch et al. §6–7).
//
// Appended to `shaders/view.wgsl` at pipeline creation (`src/view/curved/gpu/mod.rs`): it uses
// that file's `frame` uniforms, `VertexIn`, `VertexOut`, `FragmentOut`, `sample_radiosity`
// and `linear_to_srgb`. Group 1 starts at binding 4 so it never meets view.wgsl's probe
// bindings (group 1, bindings 0–1).
//
// Entry points:
// - `vs_world` (view.wgsl)/`fs_env`: D into a cube face (linear Rgba16Float, the face camera in `frame`),
//   alpha the distance from the face camera (0 where nothing is seen);
// - `vs_env_light`/`fs_env_light`: the scene's area lights in a cube face, added;
// - `vs_curved`/`fs_curved_env`: another curved reflector's mirror term in that face, looked
//   up in the previous generation's cube map (McReynolds' scheme, as Nielsen adopts it);
// - `vs_curved`/`fs_curved`: a curved reflector's pixels in the frame, ks·(Fresnel)·cube(r)
//   (mirror) or Eq. 9 with a regular pattern (glossy), added to kd·D of the scene pass;
// - `vs_curved`/`fs_curved_mirror`: the same inside a planar mirror's pass (mirrored view),
//   clipped at the mirror's plane;
// - `vs_fullscreen`/`fs_downsample`: the next MIP level of a live cube face (2×2 box);
// - `cs_glossy_probe`, `cs_env_probe`, `cs_own_probe`: the same functions on given inputs,
//   for tests.
//
// Keep `CurvedParams` in sync with `curved::CurvedParams`, `OwnNode` and `OwnTri` with
// `curved::own_mesh` (tests compare them).

struct CurvedLobe {
    // rgb: ks; a: r0 (Schlick's Fresnel at normal incidence).
    ks: vec4<f32>,
    // m_x, m_y (clamped as the pattern uses them), ξ₀, the shadowing exponent α.
    rough: vec4<f32>,
    // x: first sample in `pattern`, y: sample count, z: model (0 kurt, 1 ggx, 2 beckmann;
    // `curved::model_code`), w: unused.
    samples: vec4<u32>,
    // x: p_h, the pattern's half-vector density (Eq. 18); yzw: unused.
    pdf: vec4<f32>,
};

struct CurvedParams {
    // xyz: the eye (the camera, or the centre of the cube map being rendered); w: LOD bias.
    eye: vec4<f32>,
    // xyz: the reflector's centre (where its cube map was taken); w > 0: reflected rays are
    // cast against its own triangles (`own_closest`) from this distance on; 0: they are not.
    centre: vec4<f32>,
    // x: lobes; y: 1 = regular sampling (Eq. 9), 0 = one mirror lookup; z: face size of the
    // environment's level 0 (Eq. 16's N = z²); w: bit 1 = distance-corrected lookups
    // (`curved_lookup`, else lookups from the centre), bit 2 = specular anti-aliasing.
    info: vec4<u32>,
    // Inside a planar mirror's pass (`fs_curved_mirror`): the mirror's plane, xyz its normal,
    // w = normal · point + clip distance; fragments p with xyz · p ≤ w are discarded.
    clip: vec4<f32>,
    lobes: array<CurvedLobe, 2>,
};

@group(1) @binding(4) var<uniform> curved: CurvedParams;
@group(1) @binding(5) var<storage, read> pattern: array<vec4<f32>>;
@group(1) @binding(6) var env: texture_cube<f32>;
@group(1) @binding(7) var env_sampler: sampler;
// The reflector's live cube map: alpha holds each texel's distance from the centre (`fs_env`;
// 0: nothing seen). The glossy term may read a baked pyramid from `env`, which has none.
@group(1) @binding(9) var env_distance: texture_cube<f32>;
// The reflector's own triangles (`curved::own_mesh`): a BVH2, node 0 the root, and the
// triangles in leaf order with what D needs at a hit.
struct OwnNode {
    min: vec3<f32>,
    // 0: an inner node, children at `first` and `first + 1`; else a leaf's triangle count.
    count: u32,
    max: vec3<f32>,
    first: u32,
};
struct OwnTri {
    v0: vec4<f32>,
    e1: vec4<f32>,
    e2: vec4<f32>,
    n: array<vec4<f32>, 3>,
    // x: atlas page, y: material, z: scene triangle, w: unused.
    ids: vec4<u32>,
    lightmap: array<vec2<f32>, 4>,
    uv0: array<vec2<f32>, 4>,
    uv1: array<vec2<f32>, 4>,
};
@group(1) @binding(10) var<storage, read> own_nodes: array<OwnNode>;
@group(1) @binding(11) var<storage, read> own_tris: array<OwnTri>;

const CURVED_PI: f32 = 3.14159265358979;
// `brdf::COS_FLOOR`.
const COS_FLOOR: f32 = 1e-6;
// `pattern::ALPHA_MAX`.
const ALPHA_MAX: f32 = 1.5697963;
// `curved::PARALLAX_STEPS`.
const PARALLAX_STEPS: u32 = 3u;
// `own_mesh::OWN_STACK`.
const OWN_STACK: u32 = 48u;
// ξ₀ of the kernel's lobe in `mirror_level`: its border at slope α (e = 1), where the GGX
// density falls to a quarter of its peak, as wide as the pixel's spread of normals.
const SAA_XI0: f32 = 0.25;

// The tangent frame of `sampling::basis` (Duff et al. 2017): columns tangent, bitangent, n.
fn curved_basis(n: vec3<f32>) -> mat3x3<f32> {
    let sign = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = vec3<f32>(b, sign + n.y * n.y * a, -n.y);
    return mat3x3<f32>(t, bt, n);
}

// Eq. 3.
fn fresnel_schlick(r0: f32, u: f32) -> f32 {
    let c = 1.0 - clamp(u, 0.0, 1.0);
    let c2 = c * c;
    return r0 + (1.0 - r0) * c2 * c2 * c;
}

// Eq. 4–5: the normalized anisotropic Beckmann distribution.
fn beckmann_d(h: vec3<f32>, mx: f32, my: f32) -> f32 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let a = h.x / mx;
    let b = h.y / my;
    let e = (a * a + b * b) / (h.z * h.z);
    if e >= 87.0 {
        return 0.0;
    }
    let c2 = h.z * h.z;
    return exp(-e) / (CURVED_PI * mx * my * c2 * c2);
}

// The anisotropic GGX distribution (`brdf::ggx::d`).
fn ggx_d(h: vec3<f32>, ax: f32, ay: f32) -> f32 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let x = h.x / ax;
    let y = h.y / ay;
    let s = x * x + y * y + h.z * h.z;
    return 1.0 / (CURVED_PI * ax * ay * s * s);
}

// Smith's Λ for GGX (`brdf::ggx::lambda`).
fn ggx_lambda(w: vec3<f32>, ax: f32, ay: f32) -> f32 {
    let x = w.x * ax;
    let y = w.y * ay;
    let a2 = (x * x + y * y) / max(w.z * w.z, 1e-30);
    return a2 / (2.0 * (1.0 + sqrt(1.0 + a2)));
}

// erfc for x ≥ 0 (`brdf::beckmann`: Numerical Recipes' erfcc fit).
fn curved_erfc(x: f32) -> f32 {
    let t = 1.0 / (1.0 + 0.5 * x);
    let p = -x * x - 1.26551223 + t * (1.00002368 + t * (0.37409196 + t * (0.09678418
        + t * (-0.18628806 + t * (0.27886807 + t * (-1.13520398 + t * (1.48851587
        + t * (-0.82215223 + t * 0.17087277))))))));
    return t * exp(p);
}

// Smith's Λ for Beckmann, exact form (`brdf::beckmann::lambda`).
fn beckmann_lambda(w: vec3<f32>, mx: f32, my: f32) -> f32 {
    let x = w.x * mx;
    let y = w.y * my;
    let s = sqrt(x * x + y * y);
    if s == 0.0 {
        return 0.0;
    }
    let a = w.z / s;
    return max(0.5 * (exp(-a * a) / (a * 1.7724538509) - curved_erfc(a)), 0.0);
}

// 2 (w·h) h − w.
fn reflect_about(w: vec3<f32>, h: vec3<f32>) -> vec3<f32> {
    return 2.0 * dot(w, h) * h - w;
}

// The lobe without ks, in the tangent frame (`Lobe::eval`): Eq. 2 for Kurt lobes,
// F D G₂ / (4 (n·ω_i)(n·ω_o)) with GGX or Beckmann D and Smith's height-correlated G₂.
fn lobe_eval(l: CurvedLobe, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    let s = wo + wi;
    let len2 = dot(s, s);
    if wo.z <= 0.0 || wi.z <= 0.0 || len2 <= 1e-30 {
        return 0.0;
    }
    let h = s / sqrt(len2);
    let model = l.samples.z;
    var d = 0.0;
    if model == 1u {
        d = ggx_d(h, l.rough.x, l.rough.y);
    } else {
        d = beckmann_d(h, l.rough.x, l.rough.y);
    }
    if d == 0.0 {
        return 0.0;
    }
    let oh = max(dot(wo, h), COS_FLOOR);
    if model != 0u {
        var lambdas = 0.0;
        if model == 1u {
            lambdas = ggx_lambda(wo, l.rough.x, l.rough.y) + ggx_lambda(wi, l.rough.x, l.rough.y);
        } else {
            lambdas = beckmann_lambda(wo, l.rough.x, l.rough.y)
                + beckmann_lambda(wi, l.rough.x, l.rough.y);
        }
        let g2 = 1.0 / (1.0 + lambdas);
        return fresnel_schlick(l.ks.a, oh) * d * g2
            / (4.0 * max(wi.z, COS_FLOOR) * max(wo.z, COS_FLOOR));
    }
    var shadow = 1.0;
    if l.rough.w != 0.0 {
        shadow = pow(max(wi.z, COS_FLOOR) * max(wo.z, COS_FLOOR), l.rough.w);
    }
    return fresnel_schlick(l.ks.a, oh) * d / (4.0 * oh * shadow);
}

// Eq. 14–15: the lobe's cross-section area A at unit distance (`pattern::lobe_area_for`),
// the ξ₀ border at q(h) = ξ₀: e = −ln ξ₀ (Beckmann) or ξ₀^(−1/2) − 1 (GGX, model 1).
fn lobe_area(mx: f32, my: f32, xi0: f32, wo: vec3<f32>, model: u32) -> f32 {
    var e = max(-log(xi0), 0.0);
    if model == 1u {
        e = max(1.0 / sqrt(xi0) - 1.0, 0.0);
    }
    let r = sqrt(e);
    let wc = vec3<f32>(-wo.x, -wo.y, wo.z);
    let hu = normalize(vec3<f32>(r * mx, 0.0, 1.0));
    let hv = normalize(vec3<f32>(0.0, r * my, 1.0));
    let au = min(acos(clamp(dot(wc, reflect_about(wo, hu)), -1.0, 1.0)), ALPHA_MAX);
    let av = min(acos(clamp(dot(wc, reflect_about(wo, hv)), -1.0, 1.0)), ALPHA_MAX);
    return CURVED_PI * tan(au) * tan(av);
}

// Eq. 16: the MIP level of one of n samples (`pattern::mip_level`).
fn mip_level(area: f32, face: f32, n: f32, wi: vec3<f32>, h: vec3<f32>) -> f32 {
    let a = abs(wi);
    let to_cube = length(wi) / max(max(a.x, max(a.y, a.z)), 1e-30);
    let pixels = area * face * face / (4.0 * max(n, 1.0)) * to_cube / max(dot(wi, h), COS_FLOOR);
    return max(0.5 * log2(max(pixels, 1.0)), 0.0);
}

// Where the ray offset + t·dir (b = offset · dir, c = |offset|²) leaves the sphere of `radius`
// about the centre, the far root; the closest approach where it misses (`curved::sphere_exit`).
fn sphere_exit(b: f32, c: f32, radius: f32) -> f32 {
    return -b + sqrt(max(b * b - c + radius * radius, 0.0));
}

// Where the ray from the point `offset` away from the centre along unit `dir` meets the room,
// as a direction from the centre: a first guess on a sphere, then steps that bracket the
// surface the distances `env_distance` stores and take the secant of g = |x|/s − 1
// (`curved::parallax_direction`, distance impostors, Szirmay-Kalos et al. 2005). `dir`
// itself when the correction is off or nothing was seen.
fn curved_lookup(offset: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {
    if (curved.info.w & 1u) == 0u {
        return dir;
    }
    let b = dot(offset, dir);
    let c = dot(offset, offset);
    let s0 = textureSampleLevel(env_distance, env_sampler, dir, 0.0).a;
    if !(s0 > 0.0) {
        return dir;
    }
    var t = max(sphere_exit(b, c, s0), 0.0);
    // (t, g) of the farthest point found in front (g ≤ 0) and the nearest found behind
    // (g > 0); the other sign of g marks none found yet.
    var front = vec2<f32>(0.0, 1.0);
    var behind = vec2<f32>(0.0, -1.0);
    for (var k = 0u; k < PARALLAX_STEPS; k++) {
        let x = offset + dir * t;
        if dot(x, x) <= 0.0 {
            break;
        }
        let s = textureSampleLevel(env_distance, env_sampler, normalize(x), 0.0).a;
        if !(s > 0.0) {
            break;
        }
        let g = length(x) / s - 1.0;
        if g <= 0.0 {
            if front.y > 0.0 || t > front.x {
                front = vec2<f32>(t, g);
            }
        } else if behind.y <= 0.0 || t < behind.x {
            behind = vec2<f32>(t, g);
        }
        if front.y <= 0.0 && behind.y > 0.0 {
            t = front.x + (behind.x - front.x) * front.y / (front.y - behind.y);
        } else {
            t = max(sphere_exit(b, c, s), 0.0);
        }
    }
    let x = offset + dir * t;
    if dot(x, x) <= 0.0 {
        return dir;
    }
    return normalize(x);
}

// Where the ray enters node `i`'s box within (t_min, t_max), or -1 (slab test; the far
// distance widened a little, as `own_mesh::box_entry`).
fn own_box(i: u32, origin: vec3<f32>, inv: vec3<f32>, t_min: f32, t_max: f32) -> f32 {
    let n = own_nodes[i];
    let a = (n.min - origin) * inv;
    let b = (n.max - origin) * inv;
    let lo = min(a, b);
    let hi = max(a, b);
    let near = max(max(max(lo.x, lo.y), lo.z), t_min);
    let far = min(min(min(hi.x, hi.y), hi.z), t_max) * (1.0 + 4.0 * 1.1920929e-7);
    return select(-1.0, near, near <= far);
}

// Möller–Trumbore (1997), either face: (t, u, v) with t in (t_min, t_max), else t = -1.
// Reads only the record's first three fields: the hot loop never loads what shading needs.
fn own_triangle(k: u32, origin: vec3<f32>, dir: vec3<f32>, t_min: f32, t_max: f32) -> vec3<f32> {
    let e1 = own_tris[k].e1.xyz;
    let e2 = own_tris[k].e2.xyz;
    let p = cross(dir, e2);
    let det = dot(e1, p);
    let none = vec3<f32>(-1.0, 0.0, 0.0);
    if abs(det) < 1e-20 {
        return none;
    }
    let inv = 1.0 / det;
    let s = origin - own_tris[k].v0.xyz;
    let u = dot(s, p) * inv;
    if u < 0.0 || u > 1.0 {
        return none;
    }
    let q = cross(s, e1);
    let v = dot(dir, q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return none;
    }
    let t = dot(e2, q) * inv;
    if t <= t_min || t >= t_max {
        return none;
    }
    return vec3<f32>(t, u, v);
}

// 1/d per axis, ±1e30 for a zero component (`own_mesh::safe_inverse`).
fn own_inverse(d: vec3<f32>) -> vec3<f32> {
    let big = select(vec3<f32>(1e30), vec3<f32>(-1e30), d < vec3<f32>(0.0));
    return select(1.0 / d, big, abs(d) < vec3<f32>(1e-30));
}

// The nearest hit of the ray from `origin` (world) along unit `dir` with the reflector's own
// triangles, t in (t_min, ∞) (`OwnMesh::closest_hit`, the same traversal): x = t, y = the
// triangle's index in `own_tris` (bits), zw = barycentrics; x < 0 when there is none.
fn own_closest(origin: vec3<f32>, dir: vec3<f32>, t_min: f32) -> vec4<f32> {
    var best = vec4<f32>(-1.0, 0.0, 0.0, 0.0);
    var t_max = 3.0e38;
    let inv = own_inverse(dir);
    var stack: array<u32, OWN_STACK>;
    var sp = 0u;
    var node = 0u;
    var live = own_box(0u, origin, inv, t_min, t_max) >= 0.0;
    while live {
        let n = own_nodes[node];
        live = false;
        if n.count > 0u {
            for (var k = n.first; k < n.first + n.count; k++) {
                let h = own_triangle(k, origin, dir, t_min, t_max);
                if h.x >= 0.0 {
                    t_max = h.x;
                    best = vec4<f32>(h.x, bitcast<f32>(k), h.y, h.z);
                }
            }
        } else {
            let a = n.first;
            let b = n.first + 1u;
            let ta = own_box(a, origin, inv, t_min, t_max);
            let tb = own_box(b, origin, inv, t_min, t_max);
            if ta >= 0.0 && tb >= 0.0 {
                let a_first = ta <= tb;
                stack[sp] = select(a, b, a_first);
                sp += 1u;
                node = select(b, a, a_first);
                live = true;
            } else if ta >= 0.0 {
                node = a;
                live = true;
            } else if tb >= 0.0 {
                node = b;
                live = true;
            }
        }
        // Pop until a node still in reach (a hit may have shortened the ray).
        while !live && sp > 0u {
            sp -= 1u;
            let c = stack[sp];
            if own_box(c, origin, inv, t_min, t_max) >= 0.0 {
                node = c;
                live = true;
            }
        }
    }
    return best;
}

// What the reflected ray from `offset` (from the centre) along `dir` sees where it meets the
// reflector itself (`hit` from `own_closest`; `curved::own_radiance`): the hit's kd·D, as the
// scene pass draws it, plus each lobe's mirror term there, ks·F(n·ω_o) times one
// distance-corrected lookup at level `lod` (not cast again: one self-reflection).
fn own_radiance(hit: vec4<f32>, offset: vec3<f32>, dir: vec3<f32>, lod: f32) -> vec3<f32> {
    let r = own_tris[bitcast<u32>(hit.y)];
    let w = vec3<f32>(1.0 - hit.z - hit.w, hit.z, hit.w);
    let lm = r.lightmap[0] * w.x + r.lightmap[1] * w.y + r.lightmap[2] * w.z;
    let uv0 = r.uv0[0] * w.x + r.uv0[1] * w.y + r.uv0[2] * w.z;
    let uv1 = r.uv1[0] * w.x + r.uv1[1] * w.y + r.uv1[2] * w.z;
    let q = max(sample_radiosity(lm, r.ids.x), vec3<f32>(0.0));
    var sum = surface_d(q, r.ids.y, uv0, uv1, level_zero());
    let m = r.n[0].xyz * w.x + r.n[1].xyz * w.y + r.n[2].xyz * w.z;
    if dot(m, m) <= 1e-12 {
        return sum;
    }
    let wo = -dir;
    var n = normalize(m);
    if dot(n, wo) < 0.0 {
        n = -n;
    }
    let c = dot(n, wo);
    let point = offset + dir * hit.x;
    let seen = curved_lookup(point, reflect_about(wo, n));
    let l_env = textureSampleLevel(env, env_sampler, seen, lod).rgb;
    for (var i = 0u; i < min(curved.info.x, 2u); i++) {
        let l = curved.lobes[i];
        sum += l.ks.rgb * fresnel_schlick(l.ks.a, c) * l_env;
    }
    return sum;
}

// Where a reflected ray from the surface point `origin` (world) starts looking for the
// reflector itself: `curved.centre.w` (relative to its size, `curved::own_offset`), and never
// within a few ulps of the coordinates (the interpolated point lies that far off its triangle).
fn own_t_min(origin: vec3<f32>) -> f32 {
    let a = abs(origin);
    return max(curved.centre.w, 64.0 * 1.1920929e-7 * max(max(a.x, a.y), a.z));
}

// The radiance the reflected ray from `offset` along `dir` brings: the reflector itself
// where it meets it, its reflection there looked up at level `own_lod`, else the environment
// at level `lod`, distance-corrected.
fn curved_environment(offset: vec3<f32>, dir: vec3<f32>, lod: f32, own_lod: f32) -> vec3<f32> {
    if curved.centre.w > 0.0 {
        let origin = curved.centre.xyz + offset;
        let hit = own_closest(origin, dir, own_t_min(origin));
        if hit.x >= 0.0 {
            return own_radiance(hit, offset, dir, own_lod);
        }
    }
    return textureSampleLevel(env, env_sampler, curved_lookup(offset, dir), lod).rgb;
}

// `curved_environment` at level `lod` for a caller that has made the lookup `u` of `dir`
// already (`fs_curved_mirror` reads the hit distance there too).
fn curved_environment_at(offset: vec3<f32>, dir: vec3<f32>, u: vec3<f32>, lod: f32) -> vec3<f32> {
    if curved.centre.w > 0.0 {
        let origin = curved.centre.xyz + offset;
        let hit = own_closest(origin, dir, own_t_min(origin));
        if hit.x >= 0.0 {
            return own_radiance(hit, offset, dir, lod);
        }
    }
    return textureSampleLevel(env, env_sampler, u, lod).rgb;
}

// `kernel_roughness2` of the interpolated `normal` where the reflector's specular AA is on
// (`info.w` bit 1), else 0. Derivatives: call in uniform control flow, before any discard.
fn pixel_roughness2(normal: vec3<f32>) -> f32 {
    return select(0.0, kernel_roughness2(normalize(normal)), (curved.info.w & 2u) != 0u);
}

// A roughness m widened by the kernel's α² (`kernel_roughness2`); m itself where it adds none.
fn widened(m: f32, kernel2: f32) -> f32 {
    return select(m, sqrt(m * m + kernel2), kernel2 > 0.0);
}

// Eq. 9 with a regular pattern: (1/N) Σ L(ω_i) f(ω_i, ω_o) cos θ_i / p(ω_i), p from Eq. 17–18,
// each L at its Eq. 16 level (`envmap::specular_regular`, ks included here), the lobe's area
// widened by the pixel's kernel α² `kernel2`.
fn specular_regular(l: CurvedLobe, frame_m: mat3x3<f32>, wo_l: vec3<f32>, offset: vec3<f32>, kernel2: f32) -> vec3<f32> {
    let count = l.samples.y;
    if wo_l.z <= 0.0 || count == 0u {
        return vec3<f32>(0.0);
    }
    let n = f32(count);
    let mx = widened(l.rough.x, kernel2);
    let my = widened(l.rough.y, kernel2);
    let area = lobe_area(mx, my, l.rough.z, wo_l, l.samples.z); // Eq. 14–15
    let face = f32(curved.info.z);
    // A sample that meets the reflector itself shows the hit's reflection by one lookup, which
    // stands for the whole lobe there: N samples' solid angle, ½·log2 N levels above Eq. 16's.
    let own_spread = 0.5 * log2(n);
    var sum = vec3<f32>(0.0);
    for (var k = 0u; k < count; k++) {
        let h = pattern[l.samples.x + k].xyz;
        let wi = reflect_about(wo_l, h);
        if wi.z <= 0.0 {
            continue;
        }
        let wi_world = frame_m * wi;
        let lod = mip_level(area, face, n, wi_world, frame_m * h) + curved.eye.w; // Eq. 16
        let f = lobe_eval(l, wo_l, wi); // Eq. 2
        let pdf = l.pdf.x / (4.0 * max(dot(h, wi), COS_FLOOR)); // Eq. 17
        if pdf > 0.0 {
            let radiance = curved_environment(offset, wi_world, lod, lod + own_spread);
            sum += radiance * (f * wi.z / pdf);
        }
    }
    return l.ks.rgb * sum / n;
}

// One lookup in the mirror direction, weighted by ks and Schlick's Fresnel at n·ω_o.
// Every lobe's mirror term, ks·F(n·wo), times the `radiance` the mirror direction sees (one
// lookup shared by the lobes).
fn specular_mirror(n: vec3<f32>, wo: vec3<f32>, radiance: vec3<f32>) -> vec3<f32> {
    let c = dot(n, wo);
    if c <= 0.0 {
        return vec3<f32>(0.0);
    }
    var sum = vec3<f32>(0.0);
    for (var i = 0u; i < min(curved.info.x, 2u); i++) {
        let l = curved.lobes[i];
        sum += l.ks.rgb * fresnel_schlick(l.ks.a, c);
    }
    return sum * radiance;
}

// The MIP level of the mirror lookup in direction `r`: level 0 for a mirror, the Eq. 16
// level of one sample of a GGX lobe of α² = `kernel2` (Eq. 14–15) where the pixel adds one.
fn mirror_level(n: vec3<f32>, wo: vec3<f32>, r: vec3<f32>, kernel2: f32) -> f32 {
    if kernel2 <= 0.0 {
        return 0.0;
    }
    let a = sqrt(kernel2);
    let area = lobe_area(a, a, SAA_XI0, wo * curved_basis(n), 1u);
    return mip_level(area, f32(curved.info.z), 1.0, r, n);
}

// The specular radiance of every lobe at the point `offset` from the centre, with normal `n`,
// seen from direction `wo` (unit, world), each lobe widened by the pixel's kernel α²
// `kernel2` (`kernel_roughness2`; 0: none).
fn curved_specular(offset: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, regular: bool, kernel2: f32) -> vec3<f32> {
    if !regular {
        let r = reflect_about(wo, n);
        let lod = mirror_level(n, wo, r, kernel2);
        return specular_mirror(n, wo, curved_environment(offset, r, lod, lod));
    }
    var sum = vec3<f32>(0.0);
    let frame_m = curved_basis(n);
    let wo_l = wo * frame_m; // to the tangent frame: dot with each column
    for (var i = 0u; i < min(curved.info.x, 2u); i++) {
        sum += specular_regular(curved.lobes[i], frame_m, wo_l, offset, kernel2);
    }
    return sum;
}

struct CurvedVertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
};

struct CurvedOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
};

@vertex
fn vs_curved(v: CurvedVertexIn) -> CurvedOut {
    var out: CurvedOut;
    out.clip = frame.view_proj * vec4<f32>(v.position, 1.0);
    out.world = v.position;
    out.normal = v.normal;
    return out;
}

// The shading normal facing the eye (reflectors are drawn two-sided, as the scene is).
fn facing_normal(in: CurvedOut) -> vec3<f32> {
    let n = normalize(in.normal);
    let wo = normalize(curved.eye.xyz - in.world);
    return select(-n, n, dot(n, wo) >= 0.0);
}

@fragment
fn fs_curved(in: CurvedOut) -> FragmentOut {
    let wo = normalize(curved.eye.xyz - in.world);
    let offset = in.world - curved.centre.xyz;
    let kernel2 = pixel_roughness2(in.normal);
    let c = curved_specular(offset, facing_normal(in), wo, curved.info.y != 0u, kernel2) * frame.exposure;
    var out: FragmentOut;
    // Added to kd·D of the scene pass by the blend state (as `fs_composite` of reflect.wgsl).
    var color = c;
    if frame.encode_srgb != 0u {
        color = linear_to_srgb(c);
    }
    out.color = vec4<f32>(color, 0.0);
    out.hdr = vec4<f32>(c, 0.0);
    return out;
}

// A curved reflector seen in a planar mirror (Nielsen §3.1 and §3.2 together): inside the
// planar mirror pass of `reflect.wgsl` (`frame` holds the mirrored camera, `curved.eye` the
// mirrored eye), its specular term is added to the kd·D that `fs_mirror` wrote into the
// reflection map M (linear, × exposure as there; alpha, the beyond fraction, kept by the
// blend), depth tested against the mirrored scene. Whatever lies behind the mirror's plane is
// discarded, as `fs_mirror` does.
@fragment
fn fs_curved_mirror(in: CurvedOut) -> @location(0) vec4<f32> {
    // The map M has the frame's pixels: its lobes are widened as `fs_curved` widens them.
    let kernel2 = pixel_roughness2(in.normal);
    if dot(curved.clip.xyz, in.world) <= curved.clip.w {
        discard;
    }
    let wo = normalize(curved.eye.xyz - in.world);
    let offset = in.world - curved.centre.xyz;
    let n = facing_normal(in);
    let r = reflect_about(wo, n);
    let u = curved_lookup(offset, r);
    var c: vec3<f32>;
    if curved.info.y != 0u {
        c = curved_specular(offset, n, wo, true, kernel2);
    } else {
        // One lookup for the mirror term and the hit distance below.
        let lod = mirror_level(n, wo, r, kernel2);
        c = specular_mirror(n, wo, curved_environment_at(offset, r, u, lod));
    }
    c = c * frame.exposure;
    // M's alpha (K's scale in the composite) for what this reflector shows: the beyond
    // fraction of the unfolded path, mirrored eye → this point → what its mirror direction
    // meets, not of this point (the blend replaces M's alpha). The mirror's reflection of a
    // lamp seen in a glossy floor is blurred as far as the lamp lies, not the mirror.
    let s = textureSampleLevel(env_distance, env_sampler, u, 0.0).a;
    let d_hit = select(0.0, length(curved.centre.xyz + u * s - in.world), s > 0.0);
    let to_q = length(in.world - curved.eye.xyz);
    let s_q = max(dot(curved.clip.xyz, in.world) - curved.clip.w, 0.0);
    let e_s = max(curved.clip.w - dot(curved.clip.xyz, curved.eye.xyz), 0.0);
    let f_q = s_q / max(s_q + e_s, 1e-20);
    let f = (to_q * f_q + d_hit) / max(to_q + d_hit, 1e-20);
    return vec4<f32>(c, f);
}

@fragment
fn fs_env(in: WorldOut) -> @location(0) vec4<f32> {
    let g = uv_grads(in.uv0, in.uv1);
    if cut_out(in.material, in.uv0, in.uv1) {
        discard;
    }
    let q = max(sample_radiosity(in.lightmap, in.page), vec3<f32>(0.0));
    // Alpha: the distance from the face camera (the map's centre), for `curved_lookup`.
    let distance = length(in.world - frame.eye.xyz);
    return vec4<f32>(surface_d(q, in.material, in.uv0, in.uv1, g) * frame.exposure, distance);
}

// The scene's area lights in a cube face: not geometry (nothing hides behind them, and the
// frame never shows them), but a reflected ray that crosses one collects its radiance, as
// the path tracer's do. Added over what lies behind (alpha, the distance, kept), depth
// tested against the scene.
struct LightVertexIn {
    @location(0) position: vec3<f32>,
    // The emitting side; zero for a light that emits from both.
    @location(1) normal: vec3<f32>,
    @location(2) radiance: vec3<f32>,
};

struct LightOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) @interpolate(flat) normal: vec3<f32>,
    @location(2) @interpolate(flat) radiance: vec3<f32>,
};

@vertex
fn vs_env_light(v: LightVertexIn) -> LightOut {
    var out: LightOut;
    out.clip = frame.view_proj * vec4<f32>(v.position, 1.0);
    out.world = v.position;
    out.normal = v.normal;
    out.radiance = v.radiance;
    return out;
}

@fragment
fn fs_env_light(in: LightOut) -> @location(0) vec4<f32> {
    if dot(in.normal, frame.eye.xyz - in.world) < 0.0 {
        discard;
    }
    return vec4<f32>(in.radiance * frame.exposure, 0.0);
}

@fragment
fn fs_curved_env(in: CurvedOut) -> @location(0) vec4<f32> {
    let wo = normalize(curved.eye.xyz - in.world);
    return vec4<f32>(curved_specular(in.world - curved.centre.xyz, facing_normal(in), wo, false, 0.0), 0.0);
}

// MIP generation of live cube maps: one face of level ℓ from level ℓ − 1 (2×2 box).
@group(1) @binding(8) var mip_source: texture_2d<f32>;

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let p = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(p * 2.0 - 1.0, 0.0, 1.0);
}

@fragment
fn fs_downsample(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let size = vec2<i32>(textureDimensions(mip_source));
    let q = vec2<i32>(floor(p.xy)) * 2;
    var sum = vec4<f32>(0.0);
    for (var k = 0; k < 4; k++) {
        let t = min(q + vec2<i32>(k & 1, k >> 1), size - 1);
        sum += textureLoad(mip_source, t, 0);
    }
    return sum * 0.25;
}

// Test entries. `GlossyProbe`: a world normal (xyz) and the direction to the eye (xyz).
struct GlossyProbe {
    normal: vec4<f32>,
    wo: vec4<f32>,
};

@group(2) @binding(0) var<storage, read> glossy_in: array<GlossyProbe>;
@group(2) @binding(1) var<storage, read_write> glossy_out: array<vec4<f32>>;

// Per input: the specular term (mode from `curved.info.y`); for `cs_env_probe`, the
// environment at direction `normal.xyz` and level `normal.w` (alpha: the live map's distance).
@compute @workgroup_size(64)
fn cs_glossy_probe(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x;
    if k >= arrayLength(&glossy_in) {
        return;
    }
    let p = glossy_in[k];
    glossy_out[k] = vec4<f32>(curved_specular(vec3<f32>(0.0), normalize(p.normal.xyz), normalize(p.wo.xyz), curved.info.y != 0u, 0.0), 1.0);
}

// Per input: the ray from `normal.xyz` along `wo.xyz` with t_min `normal.w`, cast against
// the reflector's own triangles: (t, the scene triangle's index bits, u, v), t < 0 for none.
@compute @workgroup_size(64)
fn cs_own_probe(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x;
    if k >= arrayLength(&glossy_in) {
        return;
    }
    let p = glossy_in[k];
    var h = own_closest(p.normal.xyz, p.wo.xyz, p.normal.w);
    if h.x >= 0.0 {
        h.y = bitcast<f32>(own_tris[bitcast<u32>(h.y)].ids.z);
    }
    glossy_out[k] = h;
}

@compute @workgroup_size(64)
fn cs_env_probe(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x;
    if k >= arrayLength(&glossy_in) {
        return;
    }
    let p = glossy_in[k];
    glossy_out[k] = textureSampleLevel(env, env_sampler, p.normal.xyz, p.normal.w);
}
