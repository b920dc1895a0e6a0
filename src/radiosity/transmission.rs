//! Thin glass in the solve (glTF `KHR_materials_transmission`, [`Transmission`]): a ray that
//! meets a transmissive surface, from either side, goes on straight through it with weight
//! tint × factor × (1 − F), at most [`MAX_LAYERS`] surfaces deep, without random choices.
//!
//! - Shadow rays ([`shadow`]): the light reaching a point is scaled by the product of the
//!   weights of the glass surfaces the segment crosses; an opaque surface blocks it.
//! - Gathering rays ([`gather_ray`]): a ray whose first hit is glass reads the glass texel's
//!   D (as any hit) and, through it, the surfaces behind with the accumulated weight: their
//!   D as weighted terms, their emission MIS-weighted as the gathering of an unobstructed
//!   emitter is (the segment is straight, so the densities are those of the whole distance).
//!
//! D of a glass texel is its diffuse exitant radiance alone: k_d (already × (1 − factor)) ×
//! irradiance on its front side / π, plus emission. What it transmits depends on direction and
//! is not D: rays that reach the glass read the light behind it here, and the viewer draws the
//! frame behind it tinted. Its Fresnel reflection is its glossy lobe ([`super::transport`]).
//! Emitters' images in mirrors ([`super::mirror_lights`]) and glossy paths' own rays still
//! treat glass as opaque.

use glam::Vec3;

use super::emitters::{luminance, power};
use super::gather::Context;
use super::many_lights::{Choice, Drawn, ManyLights};
use super::transport::Term;
use crate::geometry::{Bvh, Hit};
use crate::sampling::Rng;
use crate::scene::Scene;

/// Most transmissive surfaces one ray goes through; the light behind more is dropped.
pub const MAX_LAYERS: u32 = 8;

/// A scene's transmissive surfaces, for rays to pass through.
#[derive(Clone, Copy)]
pub(super) struct Glass<'a> {
    scene: &'a Scene,
    bvh: &'a Bvh,
}

impl<'a> Glass<'a> {
    /// `None` when no material transmits: every ray stops at its first hit, as without glass.
    pub fn of(scene: &'a Scene, bvh: &'a Bvh) -> Option<Glass<'a>> {
        scene
            .materials
            .iter()
            .any(|m| m.is_transmissive())
            .then_some(Glass { scene, bvh })
    }

    /// Whether rays pass through `triangle`.
    pub fn passes(&self, triangle: u32) -> bool {
        self.scene.material_of(triangle).is_transmissive()
    }

    /// The weight of crossing `hit` along `d`, and the point just past it to go on from.
    fn cross(&self, origin: Vec3, d: Vec3, hit: &Hit) -> (Vec3, Vec3) {
        let tri = &self.scene.triangles[hit.triangle as usize];
        let ng = tri.face_normal();
        let cos = d.dot(ng);
        let w = self
            .scene
            .material_of(hit.triangle)
            .transmission
            .weight(cos);
        let p = origin + d * hit.t;
        (w, self.bvh.offset_origin(p, ng * cos.signum()))
    }

    /// Transmittance of the segment from `origin` along `d` (unit) up to `reach`: the product
    /// of the glass surfaces' weights it crosses; `None` when something opaque, or more than
    /// [`MAX_LAYERS`] glass surfaces, block it.
    fn through(&self, origin: Vec3, d: Vec3, reach: f32) -> Option<Vec3> {
        let end = origin + d * reach;
        let (mut o, mut left, mut w) = (origin, reach, Vec3::ONE);
        for _ in 0..MAX_LAYERS {
            let Some(h) = self.bvh.closest_hit(o, d, left) else {
                return Some(w);
            };
            if !self.passes(h.triangle) {
                return None;
            }
            let (wt, next) = self.cross(o, d, &h);
            w *= wt;
            if w == Vec3::ZERO {
                return None;
            }
            o = next;
            left = (end - o).dot(d);
            if left <= 0.0 {
                return Some(w);
            }
        }
        (!self.bvh.occluded(o, d, left)).then_some(w)
    }
}

/// The fraction of light from `origin` along `d` up to `reach` that arrives: 1 where nothing
/// blocks the segment, the glass's transmittance where only glass does, `None` where
/// something opaque does. Without glass, one occlusion query.
pub(super) fn shadow(
    glass: Option<&Glass>,
    bvh: &Bvh,
    origin: Vec3,
    d: Vec3,
    reach: f32,
) -> Option<Vec3> {
    if !bvh.occluded(origin, d, reach) {
        return Some(Vec3::ONE);
    }
    glass?.through(origin, d, reach)
}

/// [`Drawn::visible`] through glass: the fraction of the drawn point's light that reaches
/// `origin` (counts the ray).
pub(super) fn drawn_visible(
    glass: Option<&Glass>,
    bvh: &Bvh,
    dr: &Drawn,
    origin: Vec3,
    rays: &mut u64,
) -> Option<Vec3> {
    match glass {
        None => dr.visible(bvh, origin, rays).then_some(Vec3::ONE),
        Some(g) => {
            *rays += 1;
            shadow(Some(g), bvh, origin, dr.d, dr.reach(bvh))
        }
    }
}

/// How the gathering element samples emitters, for the MIS weight of a gathering ray that
/// reaches one through glass.
pub(super) struct RayMis<'a, 'b> {
    /// Gathering rays per element, and the density of this one (cos θ / π).
    pub n_rays: u32,
    pub p_bsdf: f32,
    /// Samples per emitter (or drawn from `many`).
    pub n_light: u32,
    pub many: &'a Option<(&'b ManyLights, Choice)>,
}

/// What one gathering ray through glass adds to its element.
pub(super) struct RayOut<'a> {
    pub hits: &'a mut Vec<u32>,
    pub terms: &'a mut Vec<Term>,
    /// Irradiance/π from emitters (already divided by the ray count).
    pub direct: &'a mut Vec3,
    /// Radiance brought back through glossy reflection (summed over rays).
    pub via_glossy: &'a mut Vec3,
    pub rays: &'a mut u64,
}

/// Follows a gathering ray from `origin` along `d` whose first hit `first` is transmissive:
/// pushes its one entry to `hits` (the glass texel; none for a one-sided glass's back), the
/// surfaces seen through it as terms, and adds their emission; returns the luminance of what
/// it brought back that is not a texel's D (for the element's error estimate).
#[allow(clippy::too_many_arguments)]
pub(super) fn gather_ray(
    cx: &Context,
    origin: Vec3,
    d: Vec3,
    first: Hit,
    mis: &RayMis,
    rng: &mut Rng,
    out: &mut RayOut,
) -> f64 {
    let (scene, bvh) = (cx.scene, cx.bvh);
    let glass = Glass { scene, bvh };
    let (mut hit, mut o, mut w) = (first, origin, Vec3::ONE);
    // Distance from the element along the (straight) ray to the current hit.
    let mut travelled = 0.0f32;
    let mut constant = 0.0f64;
    for layer in 0..=MAX_LAYERS {
        let t_total = travelled + hit.t;
        let tri = &scene.triangles[hit.triangle as usize];
        let cos_l = -d.dot(tri.face_normal());
        let m = scene.material_of(hit.triangle);
        let texel = if cos_l > 0.0 || m.double_sided {
            cx.atlas.texel_at(cx.offsets, hit.triangle, hit.bary)
        } else {
            u32::MAX
        };
        if layer == 0 {
            out.hits.push(texel);
        } else if texel != u32::MAX {
            out.terms.push(Term { texel, weight: w });
        }
        if cos_l > 0.0 {
            if m.emission.max_element() > 0.0 {
                let e = scene.emission_at(hit.triangle, hit.bary);
                let (area_pdf, n_e) = match mis.many {
                    None => (cx.emitters.area_pdf(m.emission), mis.n_light),
                    Some((many, choice)) => {
                        let k = many.emitter_of(hit.triangle);
                        (
                            choice.prob(k) * many.area_pdf_in_group(k, m.emission),
                            mis.n_light * super::many_lights::LIGHTS_SAMPLED_EACH as u32,
                        )
                    }
                };
                let p_light = area_pdf * t_total * t_total / cos_l;
                let wgt = power(mis.n_rays as f32, mis.p_bsdf, n_e as f32, p_light);
                let c = w * e * wgt;
                *out.direct += c / mis.n_rays as f32;
                constant += luminance(c) as f64;
            }
            if let Some(g) = &cx.glossy
                && g.reflects(hit.triangle)
            {
                let from = out.terms.len();
                let v = w * g.follow(hit, d, rng, out.terms, out.rays);
                for t in &mut out.terms[from..] {
                    t.weight *= w;
                }
                *out.via_glossy += v;
                constant += luminance(v) as f64;
            }
        }
        if !m.is_transmissive() || layer == MAX_LAYERS {
            break;
        }
        let (wt, next) = glass.cross(o, d, &hit);
        w *= wt;
        if w == Vec3::ZERO {
            break;
        }
        travelled += (next - o).dot(d);
        o = next;
        *out.rays += 1;
        match bvh.closest_hit(o, d, f32::INFINITY) {
            Some(h) => hit = h,
            None => break,
        }
    }
    constant
}
