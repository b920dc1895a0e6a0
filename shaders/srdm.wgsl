// glint-view: the ray–SRDM intersection of Popescu et al. 2006 §4.3, ported from
// `src/srdm/intersect.rs` (the CPU reference it is tested against, `tests/view_impostors.rs`).
// Every step follows the CPU code line for line; comments name the step.
//
// The tables (`src/view/impostors/srdm_tables.rs` packs them; keep the structs in sync, a test
// compares their sizes):
// - `srdm_views`: one entry per captured view: its camera and where its rows live;
// - `srdm_points`: every view's n·w·m points (u, z), row (i, j) at first_point + (i·w + j)·m;
// - `srdm_counts`: points in use per row, row (i, j) at first_row + i·w + j;
// - `srdm_domains`: the row direction (cos θᵢ, sin θᵢ) of each rotated domain, computed on the
//   CPU in f64 as `srdm::Domain::new` does, so both sides use the same directions;
// - `srdm_colours`: the captured colour (D at the hit, linear), w² texels per view;
// - `srdm_impostors`: per impostor object, its first view and view count.

const SRDM_PI: f32 = 3.14159265358979;

struct SrdmView {
    // xyz: eye position; w: tan(fov / 2).
    position: vec4<f32>,
    // xyz: right (image +x); w: hither distance.
    right: vec4<f32>,
    // xyz: up (image −y); w: yon distance.
    up: vec4<f32>,
    // xyz: forward (view direction); w: resolution w in texels.
    forward: vec4<f32>,
    // n domains, m points per row, first point, first row.
    shape: vec4<u32>,
    // first domain, first colour texel, impostor index, 0.
    offsets: vec4<u32>,
};

@group(1) @binding(0) var<storage, read> srdm_views: array<SrdmView>;
@group(1) @binding(1) var<storage, read> srdm_points: array<vec2<f32>>;
@group(1) @binding(2) var<storage, read> srdm_counts: array<u32>;
@group(1) @binding(3) var<storage, read> srdm_domains: array<vec2<f32>>;
@group(1) @binding(4) var<storage, read> srdm_colours: array<vec4<f32>>;
@group(1) @binding(5) var<storage, read> srdm_impostors: array<vec4<u32>>;

struct SrdmHit {
    hit: bool,
    // Distance along the ray, in units of its direction.
    t: f32,
    // Image position of the hit (where the colour is looked up, §4.3 step 6).
    pixel: vec2<f32>,
    // Normalized 1/z of the hit.
    depth: f32,
    domain: u32,
    row: u32,
};

fn srdm_miss() -> SrdmHit {
    return SrdmHit(false, 0.0, vec2<f32>(0.0), 0.0, 0u, 0u);
}

fn srdm_eye(v: SrdmView, p: vec3<f32>) -> vec3<f32> {
    let q = p - v.position.xyz;
    return vec3<f32>(dot(q, v.right.xyz), dot(q, v.up.xyz), dot(q, v.forward.xyz));
}

fn srdm_eye_dir(v: SrdmView, d: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(d, v.right.xyz), dot(d, v.up.xyz), dot(d, v.forward.xyz));
}

// Normalized 1/z (Figure 10): 1 on the hither plane, 0 on the yon plane.
fn srdm_depth_of_z(v: SrdmView, z: f32) -> f32 {
    let inv_yon = 1.0 / v.up.w;
    return (1.0 / z - inv_yon) / (1.0 / v.right.w - inv_yon);
}

// (pixel x, pixel y, depth) of an eye-space point with z > 0.
fn srdm_project_eye(v: SrdmView, e: vec3<f32>) -> vec3<f32> {
    let half = 0.5 * v.forward.w;
    let s = 1.0 / (e.z * v.position.w);
    return vec3<f32>((e.x * s + 1.0) * half, (1.0 - e.y * s) * half, srdm_depth_of_z(v, e.z));
}

// §4.3 step 2: Liang–Barsky clip of origin + t dir, t ∈ [0, t_max], to the frustum's six
// planes (each a + t b ≤ 0). (t0, t1, 1) when something is left, z = 0 otherwise.
fn srdm_clip(v: SrdmView, origin: vec3<f32>, dir: vec3<f32>, t_max: f32) -> vec3<f32> {
    let o = srdm_eye(v, origin);
    let d = srdm_eye_dir(v, dir);
    let h = v.position.w;
    var planes = array<vec2<f32>, 6>(
        vec2<f32>(v.right.w - o.z, -d.z),
        vec2<f32>(o.z - v.up.w, d.z),
        vec2<f32>(o.x - h * o.z, d.x - h * d.z),
        vec2<f32>(-o.x - h * o.z, -d.x - h * d.z),
        vec2<f32>(o.y - h * o.z, d.y - h * d.z),
        vec2<f32>(-o.y - h * o.z, -d.y - h * d.z),
    );
    var t0 = 0.0;
    var t1 = t_max;
    for (var i = 0u; i < 6u; i++) {
        let a = planes[i].x;
        let b = planes[i].y;
        if b == 0.0 {
            if a > 0.0 {
                return vec3<f32>(0.0);
            }
        } else if b > 0.0 {
            t1 = min(t1, -a / b);
        } else {
            t0 = max(t0, -a / b);
        }
        if t0 > t1 {
            return vec3<f32>(0.0);
        }
    }
    return vec3<f32>(t0, t1, 1.0);
}

// The eye point at ray parameter t, its z kept inside [hither, yon] (clipping rounds).
fn srdm_clamped_eye(v: SrdmView, origin: vec3<f32>, dir: vec3<f32>, t: f32) -> vec3<f32> {
    var e = srdm_eye(v, origin + t * dir);
    e.z = clamp(e.z, v.right.w, v.up.w);
    return e;
}

// §4.3 step 3: the domain whose rows are most nearly parallel to image direction d,
// i = round(φ n / π), φ ∈ [0, π). Rounds half away from zero like the CPU.
fn srdm_nearest_domain(d: vec2<f32>, n: u32) -> u32 {
    var phi = atan2(d.y, d.x);
    if phi < 0.0 {
        phi += SRDM_PI;
    }
    return u32(floor(phi * f32(n) / SRDM_PI + 0.5)) % n;
}

// The polyline's depth at u over points [base, base + count); x = depth, y = 1 when found
// (a gap or outside the row gives y = 0).
fn srdm_row_depth(base: u32, count: u32, u: f32) -> vec2<f32> {
    for (var k = 0u; k + 1u < count; k++) {
        let p = srdm_points[base + k];
        let q = srdm_points[base + k + 1u];
        if q.y >= 0.0 && p.x <= u && u <= q.x {
            let za = abs(p.y);
            return vec2<f32>(za + (u - p.x) * (q.y - za) / (q.x - p.x), 1.0);
        }
    }
    return vec2<f32>(0.0);
}

// §4.3 step 5: the first u, in the ray's order, where the ray (u0, d0) → (u1, d1) crosses the
// row's segments (skipping gaps: a segment whose end opens a span). y = 1 when found.
fn srdm_walk(base: u32, count: u32, u0: f32, u1: f32, d0: f32, d1: f32) -> vec2<f32> {
    let forward = u1 > u0;
    let umin = min(u0, u1);
    let umax = max(u0, u1);
    let ray_slope = (d1 - d0) / (u1 - u0);
    var segs = 0u;
    if count > 0u {
        segs = count - 1u;
    }
    for (var i = 0u; i < segs; i++) {
        var k = i;
        if !forward {
            k = segs - 1u - i;
        }
        let p = srdm_points[base + k];
        let q = srdm_points[base + k + 1u];
        if q.y < 0.0 {
            continue;
        }
        let a = p.x;
        let b = q.x;
        let lo = max(a, umin);
        let hi = min(b, umax);
        if lo > hi {
            continue;
        }
        let za = abs(p.y);
        let zb = q.y;
        let seg_slope = (zb - za) / (b - a);
        var entry = lo;
        var exit = hi;
        if !forward {
            entry = hi;
            exit = lo;
        }
        let fe = (d0 + (entry - u0) * ray_slope) - (za + (entry - a) * seg_slope);
        let fx = (d0 + (exit - u0) * ray_slope) - (za + (exit - a) * seg_slope);
        if fe == 0.0 {
            return vec2<f32>(entry, 1.0);
        }
        if fx == 0.0 || (fe > 0.0) != (fx > 0.0) {
            return vec2<f32>(entry + (exit - entry) * (fe / (fe - fx)), 1.0);
        }
    }
    return vec2<f32>(0.0);
}

// The first intersection of origin + t dir, t ∈ [0, t_max], with view `vi`'s depth map as its
// SRDM approximates it (§4.3, `Srdm::intersect`).
fn srdm_intersect(vi: u32, origin: vec3<f32>, dir: vec3<f32>, t_max: f32) -> SrdmHit {
    let v = srdm_views[vi];
    // Step 2: clip and project.
    let clipped = srdm_clip(v, origin, dir, t_max);
    if clipped.z == 0.0 {
        return srdm_miss();
    }
    let t0 = clipped.x;
    let t1 = clipped.y;
    let e0 = srdm_clamped_eye(v, origin, dir, t0);
    let e1 = srdm_clamped_eye(v, origin, dir, t1);
    let p0 = srdm_project_eye(v, e0);
    let p1 = srdm_project_eye(v, e1);
    // Step 3: the domain nearest r_p's direction.
    let n = v.shape.x;
    let m = v.shape.y;
    let w = v.forward.w;
    let wi = u32(w);
    let dxy = p1.xy - p0.xy;
    var domain = 0u;
    if dot(dxy, dxy) > 0.0 {
        domain = srdm_nearest_domain(dxy, n);
    }
    let e = srdm_domains[v.offsets.x + domain];
    let across = vec2<f32>(-e.y, e.x);
    let half = 0.5 * w;
    let q0 = p0.xy - vec2<f32>(half);
    let q1 = p1.xy - vec2<f32>(half);
    let c0 = vec2<f32>(dot(q0, e) + half, dot(q0, across) + half);
    let c1 = vec2<f32>(dot(q1, e) + half, dot(q1, across) + half);
    // Step 4: the part of r_p over the domain's window, and the row under its midpoint.
    var s0 = 0.0;
    var s1 = 1.0;
    let dc = c1 - c0;
    for (var axis = 0u; axis < 2u; axis++) {
        let c = c0[axis];
        let d = dc[axis];
        for (var side = 0u; side < 2u; side++) {
            var a = -c;
            var b = -d;
            if side == 1u {
                a = c - w;
                b = d;
            }
            if b == 0.0 {
                if a > 0.0 {
                    return srdm_miss();
                }
            } else if b > 0.0 {
                s1 = min(s1, -a / b);
            } else {
                s0 = max(s0, -a / b);
            }
        }
    }
    if s0 > s1 {
        return srdm_miss();
    }
    let vm = c0.y + 0.5 * (s0 + s1) * dc.y;
    let row = min(u32(max(vm, 0.0)), wi - 1u);
    let row_index = v.shape.w + domain * wi + row;
    let count = srdm_counts[row_index];
    let base = v.shape.z + (domain * wi + row) * m;
    let u0 = c0.x;
    let u1 = c1.x;
    let d0 = p0.z;
    let d1 = p1.z;
    // Step 5: walk the row (or, for a projection shorter than 1e-4 texel, test its depth).
    var s = 0.0;
    if abs(u1 - u0) < 1e-4 {
        let z = srdm_row_depth(base, count, 0.5 * (u0 + u1));
        if z.y == 0.0 {
            return srdm_miss();
        }
        if d1 == d0 {
            if z.x != d0 {
                return srdm_miss();
            }
        } else {
            s = (z.x - d0) / (d1 - d0);
            if !(s >= 0.0 && s <= 1.0) {
                return srdm_miss();
            }
        }
    } else {
        let u = srdm_walk(base, count, u0, u1, d0, d1);
        if u.y == 0.0 {
            return srdm_miss();
        }
        s = clamp((u.x - u0) / (u1 - u0), 0.0, 1.0);
    }
    // Eye z is not affine in s; σ = s z0 / ((1 − s) z1 + s z0) is the fraction of the ray.
    let sigma = s * e0.z / ((1.0 - s) * e1.z + s * e0.z);
    return SrdmHit(true, t0 + sigma * (t1 - t0), p0.xy + s * dxy, d0 + s * (d1 - d0), domain, row);
}

// §4.3 step 6: the captured colour at the hit's image position (nearest texel).
fn srdm_colour(vi: u32, pixel: vec2<f32>) -> vec3<f32> {
    let v = srdm_views[vi];
    let wi = u32(v.forward.w);
    let x = min(u32(max(pixel.x, 0.0)), wi - 1u);
    let y = min(u32(max(pixel.y, 0.0)), wi - 1u);
    return srdm_colours[v.offsets.y + y * wi + x].rgb;
}

// The view of impostor `k` to search for a ray of direction `dir`: the one whose camera looks
// most nearly along the ray (it captured the surfaces the ray meets first).
fn srdm_pick_view(k: u32, dir: vec3<f32>) -> u32 {
    let range = srdm_impostors[k];
    var best = range.x;
    var best_dot = -2.0;
    for (var i = 0u; i < range.y; i++) {
        let d = dot(dir, srdm_views[range.x + i].forward.xyz);
        if d > best_dot {
            best_dot = d;
            best = range.x + i;
        }
    }
    return best;
}
