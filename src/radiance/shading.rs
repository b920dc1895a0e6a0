//! What a radiance map's pixel holds: the radiance leaving the surface its ray meets, toward
//! the map's centre of projection.
//!
//! Bastos et al. §8.1.3 shade the maps with the view-independent diffuse light D. A glossy
//! surface seen in a reflector (glossy-room's copper teapot in the mirror panel, the panel in
//! the glossy floor) then shows only its k_d·D, black for a metal, where the path tracer shows
//! what it reflects. [`exitant`] adds that reflection, one bounce deep: each glossy lobe of the
//! surface sampled in [`GLOSSY_SAMPLES`] fixed directions (an R2 pattern: no random numbers, so
//! bakes stay byte-identical at any thread count), D read where each sampled ray lands:
//!
//! L(x → c) = D(x) + Σ_lobes k_s · (1/N) Σ_j w_j · D(x_j),
//!
//! the BRDF of Bastos Eq. 1 (f_r = k_d/π + Σ k_s f_lobe) with its k_d term already in D,
//! and w_j = f·cos θ_i / pdf of the lobe's own sampler ([`Lobe::sample_weight`]; exact for a
//! mirror-like lobe too). It is right toward the map's centre, and near it for the mirrored
//! eyes that select the map (the nearest ones, by angle or distance). Departure from the
//! paper, which keeps the maps view-independent; the viewer's geometry mode gets the same
//! light from its cube maps (curved reflectors) and its recursion (planar ones).

use glam::{Vec2, Vec3};

use super::footprint::PixelRays;
pub use super::reads::GLOSSY_SAMPLES;
use super::reads::{PixelWriter, Read};
use crate::brdf::{Frame, Lobe};
use crate::geometry::{Bvh, Hit};
use crate::radiosity::MAX_GLASS_LAYERS;
use crate::sampling::r2;
use crate::scene::Scene;
use crate::scene::texture::Image;
use crate::scene::texturing::{d_factors_at, d_factors_over};

/// Writes the record ([`super::reads`]) of the radiance leaving `hit` against the unit ray
/// direction `dir`: the read of D there, `seen(hit)` (as the maps held before), plus the
/// one-bounce reflection of its glossy lobes (module comment), D read by `d` where the lobes'
/// rays land. `seen` reads D where the pixel's own ray meets a surface (over the pixel's
/// footprint, textures included), `d` at a point; both are told whether the ray meets the
/// surface's back (a double-sided sheet's back may have texels of its own,
/// [`crate::radiosity::sides::Sides::side`]).
/// Back faces and surfaces without lobes get `seen(hit)` alone. Thin glass also passes what
/// lies behind it along `dir`, times its transmittance at the ray's angle, as the viewer's
/// frame draws it, through at most [`MAX_GLASS_LAYERS`] panes.
pub fn exitant(
    scene: &Scene,
    bvh: &Bvh,
    d: &(dyn Fn(&Hit, bool) -> Read + Sync),
    seen: &(dyn Fn(&Hit, bool) -> Read + Sync),
    hit: &Hit,
    dir: Vec3,
    out: &mut PixelWriter,
) {
    own_exitant(scene, bvh, d, seen, hit, dir, Vec3::ONE, out);
    let (mut hit, mut weight) = (*hit, Vec3::ONE);
    for _ in 0..MAX_GLASS_LAYERS {
        let tri = &scene.triangles[hit.triangle as usize];
        let material = &scene.materials[tri.material as usize];
        if !material.is_transmissive() {
            break;
        }
        let ng = tri.face_normal();
        let cos = dir.dot(ng);
        weight *= material.transmission.weight(cos);
        if weight == Vec3::ZERO {
            break;
        }
        let past = bvh.offset_origin(tri.point(hit.bary), ng * cos.signum());
        let Some(behind) = bvh.closest_hit(past, dir, f32::INFINITY) else {
            break;
        };
        own_exitant(scene, bvh, d, seen, &behind, dir, weight, out);
        hit = behind;
    }
}

/// The read of D where a map pixel's own ray meets a surface: a base colour texture read over
/// the footprint of the pixel's `rays` through `levels`
/// ([`crate::scene::texturing::texture_levels`]), as the viewer filters it on screen.
pub fn d_seen(scene: &Scene, levels: &[Vec<Image>], hit: &Hit, rays: &PixelRays) -> Read {
    let tri = &scene.triangles[hit.triangle as usize];
    let m = &scene.materials[tri.material as usize];
    // The footprint only matters to a texture.
    let factors = m
        .base_texture
        .as_ref()
        .and_then(|_| d_factors_over(levels, m, tri, hit.bary, rays.bary_steps(tri, hit.bary)));
    Read {
        triangle: hit.triangle,
        bary: hit.bary,
        factors,
    }
}

/// The read of D at a point ([`Scene::d_at`]).
pub fn d_point(scene: &Scene, hit: &Hit) -> Read {
    let tri = &scene.triangles[hit.triangle as usize];
    let m = &scene.materials[tri.material as usize];
    Read {
        triangle: hit.triangle,
        bary: hit.bary,
        factors: d_factors_at(&scene.textures, m, tri, hit.bary),
    }
}

/// [`exitant`] of the surface at `hit` alone, a layer of transmittance `weight`: D plus its
/// glossy lobes' reflection.
#[allow(clippy::too_many_arguments)]
fn own_exitant(
    scene: &Scene,
    bvh: &Bvh,
    d: &(dyn Fn(&Hit, bool) -> Read + Sync),
    seen: &(dyn Fn(&Hit, bool) -> Read + Sync),
    hit: &Hit,
    dir: Vec3,
    weight: Vec3,
    out: &mut PixelWriter,
) {
    let tri = &scene.triangles[hit.triangle as usize];
    let material = &scene.materials[tri.material as usize];
    let ng = tri.face_normal();
    out.layer(weight, &seen(hit, dir.dot(ng) >= 0.0));
    if material.lobes.is_empty() || dir.dot(ng) >= 0.0 {
        return out.d_alone();
    }
    let frame = Frame::from_normal(tri.shading_normal(hit.bary));
    let wo = frame.to_local(-dir);
    if wo.z <= 0.0 {
        return out.d_alone();
    }
    let origin = bvh.offset_origin(tri.point(hit.bary), ng);
    out.lobes(material.lobes.len());
    // Each lobe's samples: the direction and what it reads, or `None` for no light. A lobe
    // whose sampler is an earlier lobe's (same model and widths; k_s, r0 and α only weight the
    // samples) draws the same directions, so it takes that lobe's instead of tracing them again.
    type Samples = [Option<(Vec3, Read)>; GLOSSY_SAMPLES as usize];
    let mut drawn: Vec<(Lobe, Samples)> = Vec::new();
    for desc in &material.lobes {
        let lobe = Lobe::from(desc);
        out.lobe(lobe.ks);
        let same = |l: &Lobe| l.model == lobe.model && l.mx == lobe.mx && l.my == lobe.my;
        let samples: Samples = match drawn.iter().find(|(l, _)| same(l)) {
            Some((_, samples)) => *samples,
            None => std::array::from_fn(|k| {
                let wi = lobe.sample(wo, r2(k as u32, Vec2::ZERO))?;
                let w = frame.to_world(wi);
                // Below the face (a shading normal leaning away): no light.
                if w.dot(ng) <= 0.0 {
                    return None;
                }
                let h = bvh.closest_hit(origin, w, f32::INFINITY)?;
                // A back face is black, as in the radiosity solver and the path tracer (a
                // double-sided one shows its back side's texels, or the shared ones).
                let back = w.dot(scene.triangles[h.triangle as usize].face_normal()) >= 0.0;
                if back && !scene.material_of(h.triangle).double_sided {
                    return None;
                }
                Some((wi, d(&h, back)))
            }),
        };
        for (wi, read) in samples.iter().flatten() {
            out.sample(lobe.sample_weight(wo, *wi), read);
        }
        if material.lobes.len() > 1 {
            drawn.push((lobe, samples));
        }
    }
}

/// The radiance [`exitant`] gives at `hit` against `dir`, D read by `d` at each read's
/// triangle and barycentrics, untextured: a map pixel's shading without a map.
pub fn exitant_with(
    scene: &Scene,
    bvh: &Bvh,
    d: &(dyn Fn(u32, Vec2) -> Vec3 + Sync),
    hit: &Hit,
    dir: Vec3,
) -> Vec3 {
    let at = |h: &Hit, _back: bool| Read {
        triangle: h.triangle,
        bary: h.bary,
        factors: None,
    };
    let mut bytes = Vec::new();
    exitant(
        scene,
        bvh,
        &at,
        &at,
        hit,
        dir,
        &mut PixelWriter::hit(&mut bytes, hit.t),
    );
    super::reads::eval_pixel(&bytes, scene.triangles.len(), &|_| false, d)
        .expect("a record just written is whole")
        .rgb
}
