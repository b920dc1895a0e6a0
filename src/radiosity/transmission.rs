//! Thin glass in the solve (glTF `KHR_materials_transmission`,
//! [`crate::scene::material::Transmission`]): a ray that
//! meets a transmissive surface, from either side, goes on straight through it with weight
//! tint × factor × (1 − F), at most [`MAX_LAYERS`] surfaces deep, without random choices.
//!
//! - Shadow rays ([`shadow`]): the light reaching a point is scaled by the product of the
//!   weights of the glass surfaces the segment crosses; an opaque surface blocks it.
//! - Gathering rays ([`super::through_glass`]): a ray whose first hit is glass reads the glass
//!   texel's D (as any hit) and, through it, the surfaces behind with the accumulated weight:
//!   their D as weighted terms, their emission MIS-weighted as the gathering of an
//!   unobstructed emitter is (the segment is straight, so the densities are those of the
//!   whole distance).
//!
//! D of a glass texel is its diffuse exitant radiance alone: k_d (already × (1 − factor)) ×
//! irradiance on its front side / π, plus emission. What it transmits depends on direction and
//! is not D: rays that reach the glass read the light behind it here, and the viewer draws the
//! frame behind it tinted. Its Fresnel reflection is its glossy lobe ([`super::transport`]).
//! Still opaque to glass: emitters' images in mirrors ([`super::mirror_lights`]), and a glossy
//! path's continuation rays and its shadow rays towards many-lights points
//! ([`super::transport`]); its shadow rays towards each emitter ([`super::next_event`]) pass.

use glam::Vec3;

use super::many_lights::Drawn;
use crate::geometry::{Bvh, Hit};
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

    /// The scene and BVH the rays are cast in.
    pub fn scene(&self) -> (&'a Scene, &'a Bvh) {
        (self.scene, self.bvh)
    }

    /// Whether rays pass through `triangle`.
    pub fn passes(&self, triangle: u32) -> bool {
        self.scene.material_of(triangle).is_transmissive()
    }

    /// The weight of crossing `hit` along `d`, and the point just past it to go on from.
    pub fn cross(&self, origin: Vec3, d: Vec3, hit: &Hit) -> (Vec3, Vec3) {
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
