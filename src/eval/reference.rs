//! The reference renderer: a CPU path tracer over the same scene, BVH and BRDF as the bakers
//! (diffuse k_d/π plus glossy lobes of any model), with next-event estimation on area lights
//! and emissive triangles, MIS (power heuristic, as in the radiosity solver) between emitter and BRDF
//! sampling, and Russian roulette. Besides images it path-traces D itself at probe points
//! ([`trace_probes`]): the ground truth for the radiosity bake, with every transport path.
//!
//! Conventions shared with the radiosity solver, so that both compute the same thing:
//! - area lights are quads that are not geometry: invisible to camera rays and never
//!   occluders; BRDF-sampled rays that cross one collect its emission, MIS-weighted against
//!   next-event estimation (a lamp seen in a mirror is found by BRDF sampling);
//! - emissive triangles emit from their front face only; back faces are black and end a path;
//! - a miss returns [`RenderOptions::background`] (a uniform sky; black for scenes);
//! - thin glass ([`crate::scene::material::Transmission`]) passes a path straight through,
//!   from either side, chosen with the probability of its transmittance's largest channel
//!   (else the path meets its surface: reflection lobe and reduced diffuse part); shadow rays
//!   cross it with its transmittance. The solver walks the same glass deterministically, so
//!   the two agree only if both are right.
//!
//! One concept over 700 lines: one path tracer (`Tracer`), whose two entry points, images and
//! probes of D, share every sampling routine.
//!
//! Deterministic for a seed: pixel `i` draws from its own PCG32 stream, rows are rendered in
//! parallel and every sum is accumulated in f64 per pixel, so the image does not depend on the
//! number of threads.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::probe::{self, ProbeError, ProbePoint, ProbeValue};
use super::{Image, luminance};
use crate::brdf::{Brdf, Frame};
use crate::camera::Camera;
use crate::geometry::{Bvh, ray_quad};
use crate::progress::{Cancelled, Progress};
use crate::sampling::{Rng, cosine_hemisphere_pdf, sample_cosine_hemisphere, sample_triangle};
use crate::scene::Scene;

/// What to render and how.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Paths per pixel: the first ⌊√spp⌋² stratified on a grid over the pixel, the rest
    /// uniform over it (so every spp covers the whole pixel).
    pub spp: u32,
    /// Seed of the per-pixel random streams.
    pub seed: u64,
    /// Longest path in bounces (Russian roulette usually ends paths much earlier).
    pub max_depth: u32,
    /// Bounce from which Russian roulette may end a path.
    pub rr_depth: u32,
    /// Radiance of rays that leave the scene (a uniform sky).
    pub background: Vec3,
    /// Drop every glossy lobe (k_d only): the scene the radiosity bake represents.
    pub diffuse_only: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 256,
            height: 256,
            spp: 64,
            seed: 1,
            max_depth: 64,
            rr_depth: 3,
            background: Vec3::ZERO,
            diffuse_only: false,
        }
    }
}

/// A rendered image with the per-pixel variance of its luminance estimate (the variance of
/// the pixel's mean, i.e. sample variance / spp), so tests can derive tolerances from noise.
#[derive(Clone, Debug)]
pub struct Rendered {
    /// The image.
    pub image: Image,
    /// Variance of each pixel's mean luminance.
    pub variance: Vec<f32>,
}

/// The emissive triangles, chosen in proportion to area × luminance.
struct Emitters {
    tris: Vec<u32>,
    cdf: Vec<f64>,
    total: f64,
}

impl Emitters {
    fn new(scene: &Scene) -> Emitters {
        let (mut tris, mut cdf, mut total) = (Vec::new(), Vec::new(), 0.0f64);
        for (i, t) in scene.triangles.iter().enumerate() {
            let w =
                t.area() as f64 * luminance(scene.materials[t.material as usize].emission) as f64;
            if w > 0.0 {
                total += w;
                tris.push(i as u32);
                cdf.push(total);
            }
        }
        Emitters { tris, cdf, total }
    }

    /// An emissive triangle index for `u` in [0, 1).
    fn pick(&self, u: f32) -> u32 {
        let x = u as f64 * self.total;
        let i = self
            .cdf
            .partition_point(|&c| c <= x)
            .min(self.tris.len() - 1);
        self.tris[i]
    }

    /// Density per unit area of a point on a triangle with emission `e`.
    fn area_pdf(&self, e: Vec3) -> f32 {
        (luminance(e) as f64 / self.total) as f32
    }
}

/// Power heuristic (β = 2) weight of a strategy of density `a` against one of density `b`.
fn power(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 { a2 / (a2 + b2) } else { 0.0 }
}

/// A BRDF with its strategy weights: diffuse (cosine) and one per lobe, by k luminance.
struct Shader {
    brdf: Brdf,
    /// Selection probabilities: [diffuse, lobe 0, lobe 1, ...], summing to 1.
    select: Vec<f32>,
}

impl Shader {
    fn new(brdf: Brdf) -> Shader {
        let mut w: Vec<f32> = std::iter::once(luminance(brdf.kd))
            .chain(brdf.lobes.iter().map(|l| luminance(l.ks)))
            .map(|x| x.max(0.0))
            .collect();
        let s: f32 = w.iter().sum();
        if s > 0.0 {
            w.iter_mut().for_each(|x| *x /= s);
        } else {
            w[0] = 1.0;
        }
        Shader { brdf, select: w }
    }

    /// Density of [`Shader::sample`] w.r.t. solid angle of local `wi`.
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wi.z <= 0.0 {
            return 0.0;
        }
        let mut p = self.select[0] * cosine_hemisphere_pdf(wi);
        for (l, s) in self.brdf.lobes.iter().zip(&self.select[1..]) {
            if *s > 0.0 {
                p += s * l.pdf(wo, wi);
            }
        }
        p
    }

    /// A local incident direction from the one-sample mixture of strategies.
    fn sample(&self, wo: Vec3, u_pick: f32, u: Vec2) -> Option<Vec3> {
        let mut acc = 0.0;
        for (i, s) in self.select.iter().enumerate() {
            acc += s;
            if u_pick < acc || i + 1 == self.select.len() {
                return if i == 0 {
                    Some(sample_cosine_hemisphere(u))
                } else {
                    self.brdf.lobes[i - 1].sample(wo, u)
                };
            }
        }
        None
    }
}

/// Everything a path needs, shared by all pixels.
struct Tracer<'a> {
    scene: &'a Scene,
    bvh: &'a Bvh,
    emitters: Emitters,
    shaders: Vec<Shader>,
    opts: &'a RenderOptions,
    /// Whether any material transmits (else a shadow ray is one occlusion query).
    glass: bool,
}

impl<'a> Tracer<'a> {
    fn new(scene: &'a Scene, bvh: &'a Bvh, opts: &'a RenderOptions) -> Tracer<'a> {
        let shaders = scene
            .materials
            .iter()
            .map(|m| {
                let mut b = Brdf::from(m);
                if opts.diffuse_only {
                    b.lobes.clear();
                }
                Shader::new(b)
            })
            .collect();
        Tracer {
            scene,
            bvh,
            emitters: Emitters::new(scene),
            shaders,
            opts,
            glass: scene.materials.iter().any(|m| m.is_transmissive()),
        }
    }

    /// Radiance arriving at `origin` from direction `dir` (unit), seen by a camera.
    fn radiance(&self, origin: Vec3, dir: Vec3, rng: &mut Rng) -> Vec3 {
        self.trace(origin, dir, Vec3::ONE, None, 0, rng)
    }

    /// `throughput` × the radiance arriving at `origin` from `dir`, for a path that has made
    /// `depth` bounces; `prev_pdf` is the solid-angle density of the BRDF sample that chose
    /// `dir` (`None` for a camera ray, which sees emitters unweighted and no area light).
    fn trace(
        &self,
        mut origin: Vec3,
        mut dir: Vec3,
        mut throughput: Vec3,
        mut prev_pdf: Option<f32>,
        depth: u32,
        rng: &mut Rng,
    ) -> Vec3 {
        let mut l = Vec3::ZERO;
        // Distance from the last scattering vertex to `origin`: glass passed straight through
        // lies in between, and emitters' densities are of the whole distance.
        let mut passed = 0.0f32;
        for depth in depth..=self.opts.max_depth {
            let hit = self.bvh.closest_hit(origin, dir, f32::INFINITY);
            if let Some(p_bsdf) = prev_pdf {
                let t_max = hit.map_or(f32::INFINITY, |h| h.t);
                l += throughput * self.lights_along(origin, dir, t_max, passed, p_bsdf);
            }
            let Some(hit) = hit else {
                l += throughput * self.opts.background;
                break;
            };
            let tri = &self.scene.triangles[hit.triangle as usize];
            let mat = &self.scene.materials[tri.material as usize];
            let mut ng = tri.face_normal();
            let mut cos_hit = -dir.dot(ng);
            // Thin glass: straight through with the probability of its transmittance's
            // largest channel, else the surface (its reflection and reduced diffuse part).
            if mat.is_transmissive() {
                let t = mat.transmission.weight(cos_hit);
                let q = t.max_element().min(1.0);
                if rng.uniform() < q {
                    throughput *= t / q;
                    let p = origin + dir * hit.t;
                    let next = self.bvh.offset_origin(p, -ng * cos_hit.signum());
                    passed += (next - origin).dot(dir);
                    origin = next;
                    continue;
                }
                throughput /= 1.0 - q;
            }
            // A double-sided surface's back is a surface of the same material facing the
            // other way; other back faces are black, as in the radiosity solver.
            let back = cos_hit <= 0.0;
            if back && !mat.double_sided {
                break;
            }
            if back {
                ng = -ng;
                cos_hit = -cos_hit;
            }
            if !back && mat.emission.max_element() > 0.0 {
                let w = match prev_pdf {
                    None => 1.0,
                    Some(p_bsdf) => {
                        let dist = passed + hit.t;
                        let p_light = self.emitters.area_pdf(mat.emission) * dist * dist / cos_hit;
                        power(p_bsdf, p_light)
                    }
                };
                l += throughput * self.scene.emission_at(hit.triangle, hit.bary) * w;
            }
            if depth == self.opts.max_depth {
                break;
            }
            let p = tri.point(hit.bary);
            let mut ns = tri.normal(hit.bary);
            if back {
                ns = -ns;
            }
            if ns.dot(ng) <= 0.0 {
                ns = ng;
            }
            let frame = Frame::from_normal(ns);
            let wo = frame.to_local(-dir);
            if wo.z <= 0.0 {
                break;
            }
            let textured;
            let shader = match &mat.base_texture {
                None => &self.shaders[tri.material as usize],
                Some(_) => {
                    // The base colour texture scales k_d at the hit.
                    let mut brdf = self.shaders[tri.material as usize].brdf.clone();
                    brdf.kd = self.scene.albedo_at(hit.triangle, hit.bary);
                    textured = Shader::new(brdf);
                    &textured
                }
            };
            let o = self.bvh.offset_origin(p, ng);
            l += throughput * self.direct(shader, &frame, wo, p, o, ng, rng);

            // Continue the path by sampling the BRDF mixture.
            let Some((d, pdf, weight)) = self.sample(shader, &frame, wo, ng, rng) else {
                break;
            };
            throughput *= weight;
            if depth + 1 >= self.opts.rr_depth {
                let q = throughput.max_element().min(0.95);
                if q <= 0.0 || rng.uniform() >= q {
                    break;
                }
                throughput /= q;
            }
            origin = o;
            dir = d;
            prev_pdf = Some(pdf);
            passed = 0.0;
        }
        l
    }

    /// The fraction of light that crosses the segment from `origin` along `dir` (unit) up to
    /// `reach`: the product of the transmittances of the glass it passes, `None` when an
    /// opaque surface (or more glass than a path's depth) blocks it.
    fn transmittance(&self, mut origin: Vec3, dir: Vec3, reach: f32) -> Option<Vec3> {
        if !self.bvh.occluded(origin, dir, reach) {
            return Some(Vec3::ONE);
        }
        if !self.glass {
            return None;
        }
        let end = origin + dir * reach;
        let mut w = Vec3::ONE;
        for _ in 0..=self.opts.max_depth {
            let Some(hit) = self.bvh.closest_hit(origin, dir, (end - origin).dot(dir)) else {
                return Some(w);
            };
            let tri = &self.scene.triangles[hit.triangle as usize];
            let mat = &self.scene.materials[tri.material as usize];
            if !mat.is_transmissive() {
                return None;
            }
            let ng = tri.face_normal();
            let cos = dir.dot(ng);
            w *= mat.transmission.weight(cos);
            origin = self
                .bvh
                .offset_origin(origin + dir * hit.t, ng * cos.signum());
        }
        None
    }

    /// A world direction from `shader`'s mixture at a point with frame `frame` and geometric
    /// normal `ng`, its density, and f·cos/pdf; `None` when the sample fails or points under
    /// the surface.
    fn sample(
        &self,
        shader: &Shader,
        frame: &Frame,
        wo: Vec3,
        ng: Vec3,
        rng: &mut Rng,
    ) -> Option<(Vec3, f32, Vec3)> {
        let u_pick = rng.uniform();
        let u = rng.uniform2();
        let wi = shader.sample(wo, u_pick, u)?;
        let pdf = shader.pdf(wo, wi);
        let d = frame.to_world(wi).normalize();
        if pdf <= 0.0 || d.dot(ng) <= 0.0 {
            return None;
        }
        Some((d, pdf, shader.brdf.eval(wo, wi) * (wi.z / pdf)))
    }

    /// Emission of the area lights a BRDF-sampled ray (density `p_bsdf`) crosses before
    /// `t_max`, MIS-weighted against their sampling in [`Tracer::direct`].
    /// `passed` is the distance from the vertex that sampled the ray to `origin`.
    fn lights_along(&self, origin: Vec3, dir: Vec3, t_max: f32, passed: f32, p_bsdf: f32) -> Vec3 {
        let mut l = Vec3::ZERO;
        for light in &self.scene.lights {
            let Some(t) = ray_quad(origin, dir, light.corner, light.edge_u, light.edge_v, t_max)
            else {
                continue;
            };
            let mut cos_l = -dir.dot(light.normal);
            if light.two_sided {
                cos_l = cos_l.abs();
            }
            if cos_l > 0.0 {
                let t = passed + t;
                let p_light = t * t / (cos_l * light.area);
                l += light.radiance * power(p_bsdf, p_light);
            }
        }
        l
    }

    /// One estimate of the diffuse exitant radiance at barycentrics `bary` of `triangle`
    /// (front side): its emission plus k_d/π × the irradiance from every path, the rest of
    /// each path through the full BRDFs.
    fn exitant_diffuse(&self, triangle: u32, bary: Vec2, back: bool, rng: &mut Rng) -> Vec3 {
        let tri = &self.scene.triangles[triangle as usize];
        let mat = &self.scene.materials[tri.material as usize];
        // A double-sided surface's back faces the other way and does not emit, as in
        // `trace`.
        let side = if back { -1.0 } else { 1.0 };
        let ng = side * tri.face_normal();
        let frame = Frame::from_normal(side * tri.shading_normal(bary));
        let shader = Shader::new(Brdf {
            kd: self.scene.albedo_at(triangle, bary),
            lobes: Vec::new(),
        });
        let p = tri.point(bary);
        let o = self.bvh.offset_origin(p, ng);
        // The diffuse BRDF does not depend on ω_o: any direction above the surface does.
        let wo = Vec3::Z;
        let emission = match mat.emissive_texture {
            _ if back => Vec3::ZERO,
            None => mat.emission,
            Some(_) => self.scene.emission_at(triangle, bary),
        };
        let mut l = emission + self.direct(&shader, &frame, wo, p, o, ng, rng);
        if let Some((d, pdf, weight)) = self.sample(&shader, &frame, wo, ng, rng) {
            l += self.trace(o, d, weight, Some(pdf), 1, rng);
        }
        l
    }

    /// Next-event estimation at a surface point: one point per area light and one emissive
    /// triangle point, each MIS-weighted against the BRDF.
    #[allow(clippy::too_many_arguments)]
    fn direct(
        &self,
        shader: &Shader,
        frame: &Frame,
        wo: Vec3,
        p: Vec3,
        origin: Vec3,
        ng: Vec3,
        rng: &mut Rng,
    ) -> Vec3 {
        let mut l = Vec3::ZERO;
        for light in &self.scene.lights {
            let u = rng.uniform2();
            let q = light.corner + light.edge_u * u.x + light.edge_v * u.y;
            let to = q - p;
            let dist2 = to.length_squared();
            let dist = dist2.sqrt();
            let d = to / dist;
            let mut cos_l = -d.dot(light.normal);
            if light.two_sided {
                cos_l = cos_l.abs();
            }
            if cos_l <= 0.0 || d.dot(ng) <= 0.0 {
                continue;
            }
            let wi = frame.to_local(d);
            let f = shader.brdf.eval(wo, wi);
            if f == Vec3::ZERO {
                continue;
            }
            let Some(tr) = self.transmittance(origin, d, dist * (1.0 - 1e-4)) else {
                continue;
            };
            // MIS against BRDF-sampled rays, which cross the quad in [`Tracer::lights_along`].
            let p_light = dist2 / (cos_l * light.area);
            let w = power(p_light, shader.pdf(wo, wi));
            l += f * light.radiance * tr * (wi.z * w / p_light);
        }
        if !self.emitters.tris.is_empty() {
            let t = self.emitters.pick(rng.uniform());
            let et = &self.scene.triangles[t as usize];
            let at = sample_triangle(rng.uniform2());
            let q = et.point(at);
            let to = q - p;
            let dist2 = to.length_squared();
            let dist = dist2.sqrt();
            let d = to / dist;
            let cos_l = -d.dot(et.face_normal());
            if cos_l > 0.0 && d.dot(ng) > 0.0 {
                let e = self.scene.materials[et.material as usize].emission;
                let wi = frame.to_local(d);
                let f = shader.brdf.eval(wo, wi);
                if f != Vec3::ZERO {
                    let p_light = self.emitters.area_pdf(e) * dist2 / cos_l;
                    let w = power(p_light, shader.pdf(wo, wi));
                    // Stop short of the emitter so that its own triangle does not occlude.
                    let reach = (dist - 4.0 * self.bvh.epsilon()).max(0.0);
                    if let Some(tr) = self.transmittance(origin, d, reach) {
                        l += f * self.scene.emission_at(t, at) * tr * (wi.z * w / p_light);
                    }
                }
            }
        }
        l
    }
}

/// Position in the pixel ([0, 1)²) of sample `s`: cell `s` of a `grid × grid` stratification
/// offset by `j` while `s < grid²`, `j` itself (uniform over the pixel) after that.
fn stratum(s: u32, grid: u32, j: Vec2) -> Vec2 {
    if s < grid * grid {
        Vec2::new(
            ((s % grid) as f32 + j.x) / grid as f32,
            ((s / grid) as f32 + j.y) / grid as f32,
        )
    } else {
        j
    }
}

/// Renders `scene` seen from `camera`. Progress is one unit per row; returns [`Cancelled`]
/// when the progress reporter asks to stop.
pub fn render(
    scene: &Scene,
    bvh: &Bvh,
    camera: &Camera,
    opts: &RenderOptions,
    progress: &dyn Progress,
) -> Result<Rendered, Cancelled> {
    let (w, h) = (opts.width.max(1), opts.height.max(1));
    let tracer = Tracer::new(scene, bvh, opts);
    let spp = opts.spp.max(1);
    let grid = (spp as f32).sqrt().floor().max(1.0) as u32;
    let aspect = w as f32 / h as f32;
    progress.phase("reference", h as u64);
    let rows: Vec<Option<Vec<(Vec3, f32)>>> = (0..h)
        .into_par_iter()
        .map(|y| {
            if progress.cancelled() {
                return None;
            }
            let row = (0..w)
                .map(|x| {
                    let pixel = y as u64 * w as u64 + x as u64;
                    let mut rng = Rng::new(opts.seed, pixel);
                    let (mut sum, mut lum, mut lum2) = ([0.0f64; 3], 0.0f64, 0.0f64);
                    for s in 0..spp {
                        let j = rng.uniform2();
                        let sub = stratum(s, grid, j);
                        let ndc = Vec2::new(
                            2.0 * (x as f32 + sub.x) / w as f32 - 1.0,
                            1.0 - 2.0 * (y as f32 + sub.y) / h as f32,
                        );
                        let dir = camera.ray_direction(ndc, aspect);
                        let v = tracer.radiance(camera.position, dir, &mut rng);
                        let v = if v.is_finite() { v } else { Vec3::ZERO };
                        for k in 0..3 {
                            sum[k] += v[k] as f64;
                        }
                        let y = luminance(v) as f64;
                        lum += y;
                        lum2 += y * y;
                    }
                    let n = spp as f64;
                    let mean = Vec3::new(
                        (sum[0] / n) as f32,
                        (sum[1] / n) as f32,
                        (sum[2] / n) as f32,
                    );
                    let var = if spp > 1 {
                        ((lum2 - lum * lum / n) / (n - 1.0)).max(0.0) / n
                    } else {
                        0.0
                    };
                    (mean, var as f32)
                })
                .collect();
            progress.advance(1);
            Some(row)
        })
        .collect();
    let mut rgb = Vec::with_capacity((w * h) as usize);
    let mut variance = Vec::with_capacity((w * h) as usize);
    for row in rows {
        for (c, v) in row.ok_or(Cancelled)? {
            rgb.push(c);
            variance.push(v);
        }
    }
    Ok(Rendered {
        image: Image {
            width: w as usize,
            height: h as usize,
            rgb,
        },
        variance,
    })
}

/// How D is path-traced at probes.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeTraceOptions {
    /// Paths per probe (each a full estimate of D there).
    pub paths: u32,
    /// Seed (probe `i` draws from stream `i`).
    pub seed: u64,
    /// Longest path in bounces.
    pub max_depth: u32,
    /// Bounce from which Russian roulette may end a path.
    pub rr_depth: u32,
    /// Radiance of rays that leave the scene.
    pub background: Vec3,
    /// Drop every glossy lobe (k_d only): diffuse transport only.
    pub diffuse_only: bool,
}

impl Default for ProbeTraceOptions {
    fn default() -> Self {
        ProbeTraceOptions {
            paths: 4096,
            seed: 1,
            max_depth: 256,
            rr_depth: 3,
            background: Vec3::ZERO,
            diffuse_only: false,
        }
    }
}

/// Path-traces D, the diffuse exitant radiance (emission + k_d/π × irradiance by every path),
/// at each probe's surface (found as [`super::probe::probe`] finds it), with its standard
/// error per channel. Deterministic for a seed, whatever the thread count.
pub fn trace_probes(
    scene: &Scene,
    bvh: &Bvh,
    points: &[ProbePoint],
    reach: f32,
    opts: &ProbeTraceOptions,
    progress: &dyn Progress,
) -> Result<Vec<ProbeValue>, TraceError> {
    probe::check(points, reach)?;
    let render = RenderOptions {
        max_depth: opts.max_depth,
        rr_depth: opts.rr_depth,
        background: opts.background,
        diffuse_only: opts.diffuse_only,
        ..RenderOptions::default()
    };
    let tracer = Tracer::new(scene, bvh, &render);
    let n = opts.paths.max(1);
    // The back sides a bake gives D of their own, so that a probe finds the surface it does
    // in the bake ([`probe::probe`]).
    let backs = crate::radiosity::back_sides::open_backs(scene, bvh);
    progress.phase("probes", points.len() as u64);
    let out: Vec<Option<ProbeValue>> = points
        .par_iter()
        .enumerate()
        .map(|(i, pt)| {
            if progress.cancelled() {
                return None;
            }
            let p = Vec3::from_array(pt.position);
            let surface = probe::find_surface(scene, bvh, p, probe::unit_normal(pt), reach, &backs);
            let mut se = None;
            let mut v = probe::answer(pt, surface, |s| {
                let mut rng = Rng::new(opts.seed, i as u64);
                let (mut sum, mut sum2) = ([0.0f64; 3], [0.0f64; 3]);
                for _ in 0..n {
                    let x = tracer.exitant_diffuse(s.triangle, s.bary, s.back, &mut rng);
                    let x = if x.is_finite() { x } else { Vec3::ZERO };
                    for k in 0..3 {
                        sum[k] += x[k] as f64;
                        sum2[k] += (x[k] as f64).powi(2);
                    }
                }
                let m = n as f64;
                let mean = sum.map(|s| s / m);
                let var = |k: usize| {
                    if n > 1 {
                        ((sum2[k] - sum[k] * sum[k] / m) / (m - 1.0)).max(0.0) / m
                    } else {
                        0.0
                    }
                };
                se = Some([
                    var(0).sqrt() as f32,
                    var(1).sqrt() as f32,
                    var(2).sqrt() as f32,
                ]);
                Vec3::new(mean[0] as f32, mean[1] as f32, mean[2] as f32)
            });
            v.std_error = se;
            progress.advance(1);
            Some(v)
        })
        .collect();
    out.into_iter()
        .collect::<Option<Vec<_>>>()
        .ok_or(TraceError::Cancelled(Cancelled))
}

/// Why probes cannot be traced.
#[derive(Debug, thiserror::Error)]
pub enum TraceError {
    /// A probe or the reach is unusable.
    #[error(transparent)]
    Probe(#[from] ProbeError),
    /// Ctrl-C.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}

/// What the viewer shows for a radiosity bake, rendered on the CPU: D (emission included)
/// looked up at the first hit of each camera ray, black on back faces and misses. Rays go
/// through the cell centres of a ⌊√spp⌋² grid over each pixel (a box filter, as in
/// [`render`]), so edges are antialiased alike.
pub fn render_radiosity(
    scene: &Scene,
    bvh: &Bvh,
    map: &crate::radiosity::RadiosityMap,
    camera: &Camera,
    width: u32,
    height: u32,
    spp: u32,
) -> Image {
    let (w, h) = (width.max(1), height.max(1));
    let spp = spp.max(1);
    let grid = (spp as f32).sqrt().floor().max(1.0) as u32;
    let aspect = w as f32 / h as f32;
    let rgb: Vec<Vec3> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let mut sum = [0.0f64; 3];
            for s in 0..grid * grid {
                let sub = stratum(s, grid, Vec2::splat(0.5));
                let ndc = Vec2::new(
                    2.0 * (x as f32 + sub.x) / w as f32 - 1.0,
                    1.0 - 2.0 * (y as f32 + sub.y) / h as f32,
                );
                let dir = camera.ray_direction(ndc, aspect);
                if let Some(hit) = bvh.closest_hit(camera.position, dir, f32::INFINITY) {
                    let tri = &scene.triangles[hit.triangle as usize];
                    if dir.dot(tri.face_normal()) < 0.0 {
                        let v = scene.d_at(
                            hit.triangle,
                            hit.bary,
                            map.radiance(hit.triangle, hit.bary),
                        );
                        for k in 0..3 {
                            sum[k] += v[k] as f64;
                        }
                    }
                }
            }
            let n = (grid * grid) as f64;
            Vec3::new(
                (sum[0] / n) as f32,
                (sum[1] / n) as f32,
                (sum[2] / n) as f32,
            )
        })
        .collect();
    Image {
        width: w as usize,
        height: h as usize,
        rgb,
    }
}

/// Exitant radiance everywhere in the white furnace: a closed box whose every surface emits
/// `emission` and reflects diffusely with `albedo` ρ converges to E / (1 − ρ) (the geometric
/// series E Σ ρᵏ of bounces).
pub fn furnace_radiance(emission: f32, albedo: f32) -> f32 {
    emission / (1.0 - albedo)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_heuristic_sums_to_one() {
        let (a, b) = (0.3, 1.7);
        assert!((power(a, b) + power(b, a) - 1.0).abs() < 1e-6);
        assert_eq!(power(0.0, 0.0), 0.0);
    }

    #[test]
    fn furnace_formula() {
        assert!((furnace_radiance(1.0, 0.5) - 2.0).abs() < 1e-6);
    }
}
