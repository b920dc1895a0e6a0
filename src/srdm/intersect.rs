//! Ray–SRDM intersection (Popescu §4.3) and the brute-force march it is checked against.
//!
//! This CPU version is the reference for the viewer's shader port: every step is written as
//! the shader will do it, with no early-outs that change the answer.

use glam::{Vec2, Vec3};

use super::{DepthMap, Domain, ImpostorCamera, Srdm};

/// Where a ray meets an SRDM.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SrdmHit {
    /// Distance along the ray (in units of `dir`).
    pub t: f32,
    /// Image position of the hit on the ray's projection: where to look up the impostor's
    /// colour (§4.3 step 6).
    pub pixel: Vec2,
    /// Normalized 1/z of the hit.
    pub depth: f32,
    /// The rotated domain searched.
    pub domain: u32,
    /// Its row searched.
    pub row: u32,
}

/// Where a ray meets the depth map's height field, found by marching.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MarchHit {
    /// Distance along the ray (in units of `dir`).
    pub t: f32,
    /// Image position of the hit.
    pub pixel: Vec2,
    /// Normalized 1/z of the hit.
    pub depth: f32,
}

/// The clipped ray in the image: endpoints (pixel x, pixel y, depth) and their eye depths.
struct Projected {
    t0: f32,
    t1: f32,
    p0: Vec3,
    p1: Vec3,
    z0: f32,
    z1: f32,
}

impl Projected {
    /// §4.3 steps 2–3: clip the ray to the frustum and project what is left.
    fn new(cam: &ImpostorCamera, origin: Vec3, dir: Vec3, t_max: f32) -> Option<Projected> {
        let (t0, t1) = cam.clip(origin, dir, 0.0, t_max)?;
        // Clipping leaves z ≥ hither up to rounding; keep it there.
        let eye = |t: f32| {
            let mut e = cam.eye(origin + t * dir);
            e.z = e.z.clamp(cam.hither, cam.yon);
            e
        };
        let (e0, e1) = (eye(t0), eye(t1));
        Some(Projected {
            t0,
            t1,
            p0: cam.project_eye(e0),
            p1: cam.project_eye(e1),
            z0: e0.z,
            z1: e1.z,
        })
    }

    /// The ray parameter t of screen parameter s ∈ [0, 1] along p0 → p1. Depth is affine in
    /// s, eye z is not: σ = s z0 / ((1 − s) z1 + s z0) is the fraction of the clipped ray.
    fn t_at(&self, s: f32) -> f32 {
        let sigma = s * self.z0 / ((1.0 - s) * self.z1 + s * self.z0);
        self.t0 + sigma * (self.t1 - self.t0)
    }
}

/// §4.3 steps 2–4 for one ray: the clipped projection, and the domain and row to search.
struct Search {
    pr: Projected,
    /// r_p's direction in the image.
    dxy: Vec2,
    domain: u32,
    row: u32,
    /// Row coordinates of r_p's ends.
    u0: f32,
    u1: f32,
}

impl Srdm {
    fn search(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<Search> {
        let pr = Projected::new(&self.camera, origin, dir, t_max)?;
        let (w, n) = (self.resolution(), self.domains);
        let dxy = pr.p1.truncate() - pr.p0.truncate();
        let domain = if dxy.length_squared() > 0.0 {
            Domain::nearest(dxy, n)
        } else {
            0
        };
        let dom = Domain::new(domain, n, w);
        let (c0, c1) = (dom.coords(pr.p0.truncate()), dom.coords(pr.p1.truncate()));
        // The part of r_p over the domain's window, where its rows have data.
        let (mut s0, mut s1) = (0.0f32, 1.0f32);
        let dc = c1 - c0;
        for (c, d) in [(c0.x, dc.x), (c0.y, dc.y)] {
            for (a, b) in [(-c, -d), (c - w as f32, d)] {
                // a + s b ≤ 0
                if b == 0.0 {
                    if a > 0.0 {
                        return None;
                    }
                } else if b > 0.0 {
                    s1 = s1.min(-a / b);
                } else {
                    s0 = s0.max(-a / b);
                }
            }
        }
        if s0 > s1 {
            return None;
        }
        let vm = c0.y + 0.5 * (s0 + s1) * dc.y;
        let row = (vm.max(0.0) as u32).min(w - 1);
        Some(Search {
            pr,
            dxy,
            domain,
            row,
            u0: c0.x,
            u1: c1.x,
        })
    }

    /// The domain and row that [`Srdm::intersect`] searches for this ray (§4.3 steps 2–4),
    /// `None` when the ray misses the frustum or the domain's window.
    pub fn search_row(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<(u32, u32)> {
        self.search(origin, dir, t_max).map(|s| (s.domain, s.row))
    }

    /// The first intersection of the ray `origin + t dir`, t ∈ [0, t_max], with the depth map
    /// as this SRDM approximates it (§4.3):
    /// 1. clip the ray to the six planes of the camera's frustum;
    /// 2. project it: a segment r_p in the image along which depth is affine;
    /// 3. pick domain i = round(φ n / π) where φ ∈ [0, π) is r_p's direction, so r_p is within
    ///    π/2n of the rows, and the row j holding the midpoint of the part of r_p over the
    ///    domain's window (which halves the largest distance between r_p and the row there);
    /// 4. walk the row's segments in ray order; the first whose (u, depth) segment the ray's
    ///    (u, depth) segment crosses or touches is the hit. Segments ending at a span opener
    ///    (z < 0) are gaps.
    ///
    /// A ray whose projection is shorter than 10⁻⁴ texel along the row (it runs along a line
    /// of sight, or across the rows when n is small) tests the row's depth at the midpoint.
    pub fn intersect(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<SrdmHit> {
        let Search {
            pr,
            dxy,
            domain,
            row,
            u0,
            u1,
        } = self.search(origin, dir, t_max)?;
        let points = self.row_used(domain, row);
        let (d0, d1) = (pr.p0.z, pr.p1.z);
        let s = if (u1 - u0).abs() < 1e-4 {
            let z = row_depth(points, 0.5 * (u0 + u1))?;
            if d1 == d0 {
                (z == d0).then_some(0.0)?
            } else {
                let s = (z - d0) / (d1 - d0);
                (0.0..=1.0).contains(&s).then_some(s)?
            }
        } else {
            let u = walk(points, u0, u1, d0, d1)?;
            ((u - u0) / (u1 - u0)).clamp(0.0, 1.0)
        };
        Some(SrdmHit {
            t: pr.t_at(s),
            pixel: pr.p0.truncate() + s * dxy,
            depth: d0 + s * (d1 - d0),
            domain,
            row,
        })
    }
}

/// The polyline's depth at u, `None` over a gap or outside the row.
fn row_depth(row: &[[f32; 2]], u: f32) -> Option<f32> {
    row.windows(2).find_map(|pq| {
        let (p, q) = (pq[0], pq[1]);
        (q[1] >= 0.0 && p[0] <= u && u <= q[0]).then(|| {
            let za = p[1].abs();
            za + (u - p[0]) * (q[1] - za) / (q[0] - p[0])
        })
    })
}

/// The first u, in the ray's order, where the ray (u0, d0) → (u1, d1) crosses the row.
fn walk(row: &[[f32; 2]], u0: f32, u1: f32, d0: f32, d1: f32) -> Option<f32> {
    let forward = u1 > u0;
    let (umin, umax) = (u0.min(u1), u0.max(u1));
    let ray_slope = (d1 - d0) / (u1 - u0);
    let segs = row.len().saturating_sub(1);
    for k in 0..segs {
        let k = if forward { k } else { segs - 1 - k };
        let (p, q) = (row[k], row[k + 1]);
        if q[1] < 0.0 {
            continue; // a gap between spans
        }
        let (a, b) = (p[0], q[0]);
        let (lo, hi) = (a.max(umin), b.min(umax));
        if lo > hi {
            continue;
        }
        let (za, zb) = (p[1].abs(), q[1]);
        let seg_slope = (zb - za) / (b - a);
        let f = |u: f32| (d0 + (u - u0) * ray_slope) - (za + (u - a) * seg_slope);
        let (entry, exit) = if forward { (lo, hi) } else { (hi, lo) };
        let (fe, fx) = (f(entry), f(exit));
        if fe == 0.0 {
            return Some(entry);
        }
        if fx == 0.0 || (fe > 0.0) != (fx > 0.0) {
            return Some(entry + (exit - entry) * (fe / (fe - fx)));
        }
    }
    None
}

/// Brute-force reference: the first crossing of the ray with the depth map's continuous
/// height field ([`DepthMap::sample`]), marching the clipped projection in steps of at most
/// `step` texels and interpolating linearly between the last two steps. As for the SRDM, the
/// field is a sheet: the ray must cross it inside covered texels, not enter it from a gap.
pub fn march(
    map: &DepthMap,
    camera: &ImpostorCamera,
    origin: Vec3,
    dir: Vec3,
    t_max: f32,
    step: f32,
) -> Option<MarchHit> {
    let pr = Projected::new(camera, origin, dir, t_max)?;
    let dxy = pr.p1.truncate() - pr.p0.truncate();
    let steps = ((dxy.length() / step).ceil() as usize).max(1);
    let at = |s: f32| {
        let p = pr.p0.truncate() + s * dxy;
        let field = map.sample_raw(p.x, p.y);
        let ray = pr.p0.z + s * (pr.p1.z - pr.p0.z);
        (field >= 0.0).then_some(ray - field)
    };
    let hit = |s: f32| MarchHit {
        t: pr.t_at(s),
        pixel: pr.p0.truncate() + s * dxy,
        depth: pr.p0.z + s * (pr.p1.z - pr.p0.z),
    };
    let mut prev: Option<(f32, f32)> = None;
    for q in 0..=steps {
        let s = q as f32 / steps as f32;
        let cur = at(s);
        if let Some(f) = cur {
            if f == 0.0 {
                return Some(hit(s));
            }
            if let Some((sp, fp)) = prev
                && (fp > 0.0) != (f > 0.0)
            {
                return Some(hit(sp + (s - sp) * (fp / (fp - f))));
            }
        }
        prev = cur.map(|f| (s, f));
    }
    None
}
