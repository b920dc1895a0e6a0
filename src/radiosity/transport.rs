//! Light that reaches an element through glossy and mirror reflection.
//!
//! Bastos et al. (§7) gather diffuse interreflection only. A gathering ray from element x that
//! lands on a front face at y brings back
//!
//!   L_o(y → x) = L_e(y) + L_d(y) + L_g(y → x)
//!
//! - L_e, emission: counted by the solver's direct term (MIS with emitter sampling);
//! - L_d, y's diffuse reflected radiance k_d/π·E(y): the unknown of the Jacobi iteration, read
//!   from y's texel;
//! - L_g = ∫ Σ_k k_s,k f_k(ω_o, ω_i) L_i cos θ_i dω_i, the glossy reflection (Kurt et al. Eq. 1
//!   without its diffuse term): estimated here by a path that samples the lobes (a one-sample
//!   mixture chosen by k_s luminance; the lobe sampling of Eq. 6–10), bounded in depth and
//!   ended early by Russian roulette.
//!
//! At every glossy vertex the area lights and emissive triangles are sampled through the lobes
//! (next-event estimation, [`super::next_event`]) and combined with the lobe-sampled rays that
//! reach them by the power heuristic: area lights, which are not geometry, are intersected by
//! those rays here, so a lamp's image in a mirror is found by lobe sampling and on rough lobes
//! mostly by light sampling. Every vertex the path reaches adds its texel's L_d with the path's
//! throughput as weight, so the estimate stays linear in the unknowns: a constant (joins the
//! element's direct term) plus Σ w·L_d(texel) (joins its hit list).

use glam::Vec3;

use super::atlas::Atlas;
use super::emitters::{Emitters, luminance, power};
use super::many_lights::{Choice, ManyLights};
use super::mirror_lights::MirrorLights;
use super::next_event::{Arrival, At, NextEvent, Receiver, Source};
use super::transmission::Glass;
use crate::brdf::Frame;
use crate::brdf::Lobe;
use crate::geometry::{Bvh, Hit, ray_quad};
use crate::sampling::Rng;
use crate::scene::Scene;
use crate::scene::material::Material;

/// One term of an element's gathering: `weight` × the diffuse reflected radiance of `texel`
/// (a global atlas texel until the solver resolves it to an element).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Term {
    pub texel: u32,
    pub weight: Vec3,
}

/// A material's glossy lobes (k_s included) and the probabilities of choosing each to sample.
pub(super) struct Lobes {
    lobes: Vec<Lobe>,
    select: Vec<f32>,
}

impl Lobes {
    /// `None` when the material reflects nothing glossily.
    fn new(m: &Material) -> Option<Lobes> {
        let lobes: Vec<Lobe> = m
            .lobes
            .iter()
            .map(Lobe::from)
            .filter(|l| luminance(l.ks) > 0.0)
            .collect();
        let total: f32 = lobes.iter().map(|l| luminance(l.ks)).sum();
        if lobes.is_empty() || total.is_nan() || total <= 0.0 {
            return None;
        }
        let select = lobes.iter().map(|l| luminance(l.ks) / total).collect();
        Some(Lobes { lobes, select })
    }

    /// Σ k_s f_lobe(ω_o, ω_i), per steradian.
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.lobes
            .iter()
            .fold(Vec3::ZERO, |acc, l| acc + l.ks * l.eval(wo, wi))
    }

    /// Density of [`Lobes::sample`] w.r.t. solid angle.
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.lobes
            .iter()
            .zip(&self.select)
            .map(|(l, s)| s * l.pdf(wo, wi))
            .sum()
    }

    /// A local incident direction: a lobe chosen by `u_pick`, sampled with `u`.
    fn sample(&self, wo: Vec3, u_pick: f32, u: glam::Vec2) -> Option<Vec3> {
        let mut acc = 0.0;
        for (i, s) in self.select.iter().enumerate() {
            acc += s;
            if u_pick < acc || i + 1 == self.select.len() {
                return self.lobes[i].sample(wo, u);
            }
        }
        None
    }
}

/// Whether `m` reflects glossily (gathering rays that hit it follow its lobes).
pub(super) fn is_glossy(m: &Material) -> bool {
    Lobes::new(m).is_some()
}

/// What following glossy reflection needs, shared by every element.
pub(super) struct Glossy<'a> {
    scene: &'a Scene,
    bvh: &'a Bvh,
    atlas: &'a Atlas,
    offsets: &'a [u32],
    emitters: &'a Emitters,
    /// Per material.
    lobes: Vec<Option<Lobes>>,
    /// Largest number of glossy reflections followed from a gathering hit.
    depth: u32,
    /// Mirrors whose emitter images the solver samples directly: at a gathering ray's first
    /// reflection on one of them, emitters are left out (they would be counted twice).
    mirrors: Option<&'a MirrorLights>,
    /// The emitters as one per-point distribution, when there are too many to sample each.
    many: Option<&'a ManyLights>,
    /// The scene's glass, which the vertices' shadow rays towards each emitter pass.
    glass: Option<Glass<'a>>,
}

impl<'a> Glossy<'a> {
    /// `None` when there is nothing to follow (depth 0 or no glossy material).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        scene: &'a Scene,
        bvh: &'a Bvh,
        atlas: &'a Atlas,
        offsets: &'a [u32],
        emitters: &'a Emitters,
        depth: u32,
        mirrors: Option<&'a MirrorLights>,
        many: Option<&'a ManyLights>,
    ) -> Option<Glossy<'a>> {
        let lobes: Vec<Option<Lobes>> = scene.materials.iter().map(Lobes::new).collect();
        (depth > 0 && lobes.iter().any(Option::is_some)).then_some(Glossy {
            scene,
            bvh,
            atlas,
            offsets,
            emitters,
            lobes,
            depth,
            mirrors,
            many,
            glass: Glass::of(scene, bvh),
        })
    }

    /// Whether a hit on `triangle` reflects glossily.
    pub fn reflects(&self, triangle: u32) -> bool {
        self.lobes[self.scene.triangles[triangle as usize].material as usize].is_some()
    }

    /// L_g towards the origin of a ray travelling along `dir` (unit) that hit the front face
    /// of a glossy triangle at `hit`: returns the constant part and pushes the L_d terms;
    /// sets bit `material % 64` of `lobes_read` for every material whose lobes it evaluates.
    pub fn follow(
        &self,
        mut hit: Hit,
        mut dir: Vec3,
        rng: &mut Rng,
        terms: &mut Vec<Term>,
        rays: &mut u64,
        lobes_read: &mut u64,
    ) -> Vec3 {
        let scene = self.scene;
        let mut out = Vec3::ZERO;
        let mut beta = Vec3::ONE;
        for depth in 0..self.depth {
            let tri = &scene.triangles[hit.triangle as usize];
            let Some(lobes) = &self.lobes[tri.material as usize] else {
                break;
            };
            *lobes_read |= 1 << (tri.material % 64);
            let ng = tri.face_normal();
            let ns = tri.shading_normal(hit.bary);
            let frame = Frame::from_normal(ns);
            let wo = frame.to_local(-dir);
            if wo.z <= 0.0 {
                break;
            }
            let p = tri.point(hit.bary);
            let origin = self.bvh.offset_origin(p, ng);
            // Emitters seen in a mirror from the gathering element: sampled by MirrorLights.
            let emitters_here =
                depth > 0 || !self.mirrors.is_some_and(|m| m.is_mirror(hit.triangle));
            // With many emitters, this vertex's distribution over them.
            let choice = match self.many {
                Some(m) if emitters_here => Some(m.choose(origin, ns)),
                _ => None,
            };
            if emitters_here {
                out += beta
                    * match &choice {
                        None => self.next_event(lobes, &frame, wo, p, origin, ng, rng, rays),
                        Some(c) => {
                            self.next_event_many(lobes, &frame, wo, origin, ng, c, rng, rays)
                        }
                    };
            }

            let u_pick = rng.uniform();
            let Some(wi) = lobes.sample(wo, u_pick, rng.uniform2()) else {
                break;
            };
            let pdf = lobes.pdf(wo, wi);
            let d = frame.to_world(wi).normalize();
            if pdf.is_nan() || pdf <= 0.0 || d.dot(ng) <= 0.0 {
                break;
            }
            beta *= lobes.eval(wo, wi) * (wi.z / pdf);
            if depth >= 1 {
                let q = beta.max_element().min(0.95);
                if q.is_nan() || q <= 0.0 || rng.uniform() >= q {
                    break;
                }
                beta /= q;
            }
            if !beta.is_finite() {
                break;
            }
            *rays += 1;
            let next = self.bvh.closest_hit(origin, d, f32::INFINITY);
            if emitters_here {
                let t_max = next.map_or(f32::INFINITY, |h| h.t);
                out += beta * self.lights_along(origin, d, t_max, pdf, choice.as_ref());
            }
            let Some(h) = next else {
                break;
            };
            let ht = &scene.triangles[h.triangle as usize];
            let cos_l = -d.dot(ht.face_normal());
            let m = &scene.materials[ht.material as usize];
            if cos_l <= 0.0 {
                // A back face is black, as for gathering rays; a double-sided one reflects
                // with its back side's texel.
                if m.double_sided && m.albedo.max_element() > 0.0 {
                    let (t, b) = self.atlas.side(h.triangle, h.bary, true);
                    terms.push(Term {
                        texel: self.atlas.texel_at(self.offsets, t, b),
                        weight: beta,
                    });
                }
                break;
            }
            if emitters_here && m.emission.max_element() > 0.0 {
                let area_pdf = match (self.many, &choice) {
                    (Some(many), Some(c)) => {
                        let k = many.emitter_of(h.triangle);
                        c.prob(k) * many.area_pdf_in_group(k, m.emission)
                    }
                    _ => self.emitters.area_pdf(m.emission),
                };
                let p_light = area_pdf * h.t * h.t / cos_l;
                out += beta * scene.emission_at(h.triangle, h.bary) * power(1.0, pdf, 1.0, p_light);
            }
            if m.albedo.max_element() > 0.0 {
                terms.push(Term {
                    texel: self.atlas.texel_at(self.offsets, h.triangle, h.bary),
                    weight: beta,
                });
            }
            hit = h;
            dir = d;
        }
        out
    }

    /// Emission of the area lights a lobe-sampled ray (density `pdf`) crosses before `t_max`,
    /// MIS-weighted against their sampling in [`Glossy::next_event`] (or, with many emitters,
    /// in [`Glossy::next_event_many`] from `choice`).
    fn lights_along(
        &self,
        origin: Vec3,
        d: Vec3,
        t_max: f32,
        pdf: f32,
        choice: Option<&Choice>,
    ) -> Vec3 {
        let mut sum = Vec3::ZERO;
        for (i, light) in self.scene.lights.iter().enumerate() {
            let Some(t) = ray_quad(origin, d, light.corner, light.edge_u, light.edge_v, t_max)
            else {
                continue;
            };
            let mut cos_l = -d.dot(light.normal);
            if light.two_sided {
                cos_l = cos_l.abs();
            }
            if cos_l <= 0.0 {
                continue;
            }
            // Area lights come first among the many emitters.
            let pick = choice.map_or(1.0, |c| c.prob(i));
            let p_light = pick * t * t / (cos_l * light.area);
            sum += light.radiance * power(1.0, pdf, 1.0, p_light);
        }
        sum
    }

    /// Light reflected by the lobes from one point on the emitters drawn from `choice`,
    /// MIS-weighted against lobe sampling.
    #[allow(clippy::too_many_arguments)]
    fn next_event_many(
        &self,
        lobes: &Lobes,
        frame: &Frame,
        wo: Vec3,
        origin: Vec3,
        ng: Vec3,
        choice: &Choice,
        rng: &mut Rng,
        rays: &mut u64,
    ) -> Vec3 {
        let Some(many) = self.many else {
            return Vec3::ZERO;
        };
        if choice.is_empty() {
            return Vec3::ZERO;
        }
        let Some(dr) = many.draw_towards(self.scene, choice, rng.uniform(), origin, rng) else {
            return Vec3::ZERO;
        };
        if dr.d.dot(ng) <= 0.0 {
            return Vec3::ZERO;
        }
        let wi = frame.to_local(dr.d);
        let f = lobes.eval(wo, wi);
        if f == Vec3::ZERO || !dr.visible(self.bvh, origin, rays) {
            return Vec3::ZERO;
        }
        let p_light = dr.p_light;
        let w = power(1.0, p_light, 1.0, lobes.pdf(wo, wi));
        f * dr.point.radiance * (wi.z * w / p_light)
    }

    /// Light reflected by the lobes at `p` from one point on each area light and one on the
    /// emissive triangles, MIS-weighted against lobe sampling.
    #[allow(clippy::too_many_arguments)]
    fn next_event(
        &self,
        lobes: &Lobes,
        frame: &Frame,
        wo: Vec3,
        p: Vec3,
        origin: Vec3,
        ng: Vec3,
        rng: &mut Rng,
        rays: &mut u64,
    ) -> Vec3 {
        let at = At {
            from: p,
            origin,
            ng,
        };
        let mut vertex = Vertex {
            lobes,
            frame,
            wo,
            l: Vec3::ZERO,
        };
        NextEvent {
            scene: self.scene,
            bvh: self.bvh,
            emitters: self.emitters,
            glass: self.glass,
        }
        .estimate(&at, 1, rng, rays, &mut vertex);
        vertex.l
    }
}

/// Light reflected towards `wo` by a glossy path vertex's lobes, summed in `l`, each point
/// MIS-weighted against lobe sampling (which also reaches area lights, in
/// [`Glossy::lights_along`]).
struct Vertex<'a> {
    lobes: &'a Lobes,
    frame: &'a Frame,
    wo: Vec3,
    l: Vec3,
}

impl Receiver for Vertex<'_> {
    /// The local incident direction and Σ k_s f there.
    type Toward = (Vec3, Vec3);

    fn toward(&self, d: Vec3) -> Option<(Vec3, Vec3)> {
        let wi = self.frame.to_local(d);
        let f = self.lobes.eval(self.wo, wi);
        (f != Vec3::ZERO).then_some((wi, f))
    }

    fn add(&mut self, _: Source, a: &Arrival, (wi, f): (Vec3, Vec3)) {
        let w = power(1.0, a.p_light, 1.0, self.lobes.pdf(self.wo, wi));
        self.l += f * a.radiance * (wi.z * w / a.p_light);
    }
}
