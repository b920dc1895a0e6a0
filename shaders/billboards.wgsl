// glint-view: reflected billboards (Popescu et al. 2006 §3, §3.1, §3.2).
//
// The tables of `src/view/impostors/billboard_tables.rs` (group 3) and the per-ray algorithm of
// §3.1, mirrored step by step by `BillboardTables::trace` (the CPU reference the tests hold this
// to):
// 1. the reflected ray is intersected with every billboard of the reflector's group, alpha
//    tested; the nearest opaque texel wins (`bb_nearest`);
// 2. a diffuse billboard gives its texel; a reflective one (per-texel normals) gives its texel
//    plus ks × what the tertiary ray, reflected about the texel's normal, finds among the
//    diffuse billboards made for that object, else its environment (second order); the
//    tertiary ray leaves from the captured surface (the texel's stored offset from the plane);
// 3. no hit: the environment map EM(r) of the group, when there is one;
// §3.2: a billboard connected to the environment has transition walls of height H on its
// edges; a ray hitting one at height h reads EM along the blend of r_a (from E to the hit)
// and r₁ᵈ (the ray's direction) by h/H.
// Keep the structs in sync with `GpuBillboard` and `GpuGroup`.

struct Billboard {
    centre: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    spec: vec4<f32>,
    info: vec4<u32>,
};

struct BbGroup {
    range: vec4<u32>,
    centre: vec4<f32>,
};

@group(3) @binding(0) var<storage, read> bb_billboards: array<Billboard>;
@group(3) @binding(1) var<storage, read> bb_groups: array<BbGroup>;
@group(3) @binding(2) var<storage, read> bb_texels: array<vec4<f32>>;
@group(3) @binding(3) var<storage, read> bb_normals: array<vec4<f32>>;
@group(3) @binding(4) var<storage, read> bb_env: array<vec4<f32>>;

const BB_NONE: u32 = 0xffffffffu;
const BB_ALPHA_CUTOFF: f32 = 0.5;
const BB_T_MIN: f32 = 1e-4;

struct BbHit {
    found: bool,
    t: f32,
    billboard: u32,
    texel: u32,
    wall_h: f32,
};

struct BbResult {
    // 0 nothing, 1 diffuse texel, 2 reflective, 3 environment, 4 transition wall.
    kind: u32,
    colour: vec3<f32>,
    t: f32,
    billboard: u32,
};

// Nearest texel of a cube map face coordinate, as `BillboardTables::env` (faces and (s, t)
// as `envmap::locate`).
fn bb_env_lookup(g: u32, d: vec3<f32>, out_found: ptr<function, bool>) -> vec3<f32> {
    let r = bb_groups[g].range;
    if r.z == BB_NONE || r.w == 0u {
        *out_found = false;
        return vec3<f32>(0.0);
    }
    *out_found = true;
    let a = abs(d);
    var face = 0u;
    var s = 0.0;
    var t = 0.0;
    if a.x >= a.y && a.x >= a.z {
        let m = max(a.x, 1.17549435e-38);
        if d.x >= 0.0 {
            face = 0u; s = -d.z / m; t = -d.y / m;
        } else {
            face = 1u; s = d.z / m; t = -d.y / m;
        }
    } else if a.y >= a.z {
        let m = a.y;
        if d.y >= 0.0 {
            face = 2u; s = d.x / m; t = d.z / m;
        } else {
            face = 3u; s = d.x / m; t = -d.z / m;
        }
    } else {
        let m = a.z;
        if d.z >= 0.0 {
            face = 4u; s = d.x / m; t = -d.y / m;
        } else {
            face = 5u; s = -d.x / m; t = -d.y / m;
        }
    }
    let size = f32(r.w);
    let x = u32(clamp(floor((s * 0.5 + 0.5) * size), 0.0, size - 1.0));
    let y = u32(clamp(floor((t * 0.5 + 0.5) * size), 0.0, size - 1.0));
    return bb_env[r.z + (face * r.w + y) * r.w + x].rgb;
}

// §3.1 step 1 (and the §3.2 walls): the nearest alpha-tested hit in group g.
fn bb_nearest(g: u32, o: vec3<f32>, d: vec3<f32>, t_max: f32, diffuse_only: bool) -> BbHit {
    let range = bb_groups[g].range;
    var best: BbHit;
    best.found = false;
    best.t = t_max;
    best.billboard = BB_NONE;
    best.texel = BB_NONE;
    best.wall_h = -1.0;
    for (var i = range.x; i < range.x + range.y; i++) {
        let b = bb_billboards[i];
        if diffuse_only && b.info.z != BB_NONE {
            continue;
        }
        let c = b.centre.xyz;
        let s = b.centre.w;
        let su = b.up.w;
        let r = b.right.xyz;
        let u = b.up.xyz;
        let n = cross(r, u);
        let denom = dot(d, n);
        if abs(denom) > 1e-8 {
            let t = dot(c - o, n) / denom;
            if t > BB_T_MIN && t < best.t {
                let p = o + d * t - c;
                let x = dot(p, r) / s;
                let y = dot(p, u) / su;
                if abs(x) <= 1.0 && abs(y) <= 1.0 {
                    let w = f32(b.info.x);
                    let tx = clamp(floor((x * 0.5 + 0.5) * w), 0.0, w - 1.0);
                    let ty = clamp(floor((0.5 - y * 0.5) * w), 0.0, w - 1.0);
                    let texel = b.info.y + u32(ty) * b.info.x + u32(tx);
                    if bb_texels[texel].a >= BB_ALPHA_CUTOFF {
                        best.found = true;
                        best.t = t;
                        best.billboard = i;
                        best.texel = texel;
                        best.wall_h = -1.0;
                    }
                }
            }
        }
        // §3.2: transition walls of height H on the four edges, rising along n.
        let height = b.right.w;
        if height > 0.0 {
            for (var e = 0u; e < 4u; e++) {
                var axis = r;
                var along = u;
                var off = s;
                var ext = su;
                if e == 1u { axis = -r; }
                if e == 2u { axis = u; along = r; off = su; ext = s; }
                if e == 3u { axis = -u; along = r; off = su; ext = s; }
                let den = dot(d, axis);
                if abs(den) <= 1e-8 {
                    continue;
                }
                let t = (off - dot(o - c, axis)) / den;
                if !(t > BB_T_MIN && t < best.t) {
                    continue;
                }
                let p = o + d * t - c;
                let h = dot(p, n);
                if abs(dot(p, along)) <= ext && h >= 0.0 && h <= height {
                    best.found = true;
                    best.t = t;
                    best.billboard = i;
                    best.texel = BB_NONE;
                    best.wall_h = h;
                }
            }
        }
    }
    return best;
}

// §3.2: EM along r_m = mix(r_a, r₁ᵈ, h/H) for a transition-wall hit.
fn bb_morph(g: u32, h: BbHit, o: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    let b = bb_billboards[h.billboard];
    let e = bb_groups[g].centre.xyz;
    let a = o + d * h.t;
    var ra = vec3<f32>(0.0);
    if length(a - e) > 0.0 {
        ra = normalize(a - e);
    }
    let k = clamp(h.wall_h / b.right.w, 0.0, 1.0);
    var found = false;
    return bb_env_lookup(g, ra * (1.0 - k) + d * k, &found);
}

// §3.1 for one reflected ray of group g.
fn bb_trace(g: u32, o: vec3<f32>, d: vec3<f32>, t_max: f32) -> BbResult {
    var res: BbResult;
    res.t = 0.0;
    res.billboard = BB_NONE;
    let hit = bb_nearest(g, o, d, t_max, false);
    if !hit.found {
        var found = false;
        res.colour = bb_env_lookup(g, d, &found);
        res.kind = select(0u, 3u, found);
        return res;
    }
    res.t = hit.t;
    res.billboard = hit.billboard;
    if hit.texel == BB_NONE {
        res.kind = 4u;
        res.colour = bb_morph(g, hit, o, d);
        return res;
    }
    let b = bb_billboards[hit.billboard];
    let base = bb_texels[hit.texel].rgb;
    if b.info.z == BB_NONE || b.info.w == BB_NONE {
        res.kind = 1u;
        res.colour = base;
        return res;
    }
    // Second order: the tertiary ray from the reflective billboard's texel normal.
    let nw = bb_normals[b.info.z + (hit.texel - b.info.y)];
    let n = nw.xyz;
    // Leave from the captured surface: back along the ray to the texel's offset from the plane.
    let dn = dot(d, cross(b.right.xyz, b.up.xyz));
    var back = 0.0;
    if abs(dn) > 1e-6 {
        back = nw.w / dn;
    }
    let p = o + d * (hit.t + back);
    var d2 = d - 2.0 * dot(d, n) * n;
    if length(d2) > 0.0 {
        d2 = normalize(d2);
    }
    let g2 = b.info.w;
    let h2 = bb_nearest(g2, p, d2, t_max, true);
    var second = vec3<f32>(0.0);
    if h2.found && h2.texel != BB_NONE {
        second = bb_texels[h2.texel].rgb;
    } else if h2.found {
        second = bb_morph(g2, h2, p, d2);
    } else {
        var found = false;
        second = bb_env_lookup(g2, d2, &found);
    }
    res.kind = 2u;
    res.colour = base + b.spec.rgb * second;
    return res;
}
