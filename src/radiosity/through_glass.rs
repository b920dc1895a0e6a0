//! One gathering ray through thin glass ([`super::transmission`]): the texels and emitters it
//! reads on the glass and behind it, for [`super::gather`].

use glam::Vec3;

use super::atlas::Atlas;
use super::emitters::{Emitters, power};
use super::many_lights::{Choice, LIGHTS_SAMPLED_EACH, ManyLights};
use super::transmission::{Glass, MAX_LAYERS};
use super::transport::{Glossy, Term};
use crate::geometry::Hit;
use crate::sampling::Rng;

/// What gathering through glass reads: the element's gathering context's parts.
pub(super) struct GatherCx<'a> {
    pub glass: Glass<'a>,
    pub atlas: &'a Atlas,
    pub offsets: &'a [u32],
    pub emitters: &'a Emitters,
    pub glossy: Option<&'a Glossy<'a>>,
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
    /// Emission reached, MIS-weighted (not yet over the ray count).
    pub emission: &'a mut Vec3,
    /// Radiance brought back through glossy reflection (summed over rays).
    pub via_glossy: &'a mut Vec3,
    pub rays: &'a mut u64,
    /// The materials whose lobes its glossy paths evaluated (bits `material % 64`).
    pub lobes_read: &'a mut u64,
    /// Set when an emission carries MIS weights (they depend on the batch's counts).
    pub weighted: &'a mut bool,
}

/// Follows a gathering ray from `origin` along `d` whose first hit `first` is transmissive:
/// pushes its one entry to `hits` (the glass texel; none for a one-sided glass's back), the
/// surfaces seen through it as terms, and adds their emission and glossy light to `out`.
#[allow(clippy::too_many_arguments)]
pub(super) fn gather_ray(
    cx: &GatherCx,
    origin: Vec3,
    d: Vec3,
    first: Hit,
    mis: &RayMis,
    rng: &mut Rng,
    out: &mut RayOut,
) {
    let glass = cx.glass;
    let (scene, bvh) = glass.scene();
    let (mut hit, mut o, mut w) = (first, origin, Vec3::ONE);
    // Distance from the element along the (straight) ray to the current hit.
    let mut travelled = 0.0f32;
    for layer in 0..=MAX_LAYERS {
        let t_total = travelled + hit.t;
        let tri = &scene.triangles[hit.triangle as usize];
        let cos_l = -d.dot(tri.face_normal());
        let m = scene.material_of(hit.triangle);
        let texel = if cos_l > 0.0 || m.double_sided {
            let (t, b) = cx.atlas.side(hit.triangle, hit.bary, cos_l <= 0.0);
            cx.atlas.texel_at(cx.offsets, t, b)
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
                            mis.n_light * LIGHTS_SAMPLED_EACH as u32,
                        )
                    }
                };
                let p_light = area_pdf * t_total * t_total / cos_l;
                let wgt = power(mis.n_rays as f32, mis.p_bsdf, n_e as f32, p_light);
                *out.emission += w * e * wgt;
                *out.weighted = true;
            }
            if let Some(g) = cx.glossy
                && g.reflects(hit.triangle)
            {
                let from = out.terms.len();
                let v = w * g.follow(hit, d, rng, out.terms, out.rays, out.lobes_read);
                for t in &mut out.terms[from..] {
                    t.weight *= w;
                }
                *out.via_glossy += v;
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
}
