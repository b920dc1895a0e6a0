//! Emitters seen in planar mirrors, sampled directly: the mirror images of the area lights and
//! emissive triangles behind each near-mirror planar reflector.
//!
//! A lamp's image in a mirror lights a room as a second lamp, but gathering finds it only when
//! a cosine ray happens to land where the mirror shows it (a rare event, so D is noisy and its
//! error estimate blind to it). Here each element samples the mirrored emitters like real
//! ones (Eq. of next-event estimation with the point q' = q reflected in the mirror's plane):
//! the ray towards q' must meet the mirror first, the reflected segment to q must be clear,
//! and the mirror's reflectance at that angle scales the light.
//!
//! The mirror is treated as perfect: its lobes' blur is ignored, which is why only lobes of
//! roughness ≤ [`MIRROR_ROUGHNESS`] qualify. Paths element → mirror → emitter are then this
//! technique's alone: glossy transport ([`super::transport`]) leaves out the emitters at a
//! gathering ray's first reflection when it lands on such a mirror.

use std::f32::consts::PI;

use glam::Vec3;

use super::emitters::{Emitters, luminance, spread_point, var_of_mean};
use super::many_lights::{Choice, LIGHTS_SAMPLED_EACH, ManyLights, best_cosine, box_corners};
use crate::brdf::Lobe;
use crate::geometry::Bvh;
use crate::sampling::{Rng, sample_triangle};
use crate::scene::{Plane, ReflectorKind, Scene};

/// Largest Beckmann roughness of a lobe that is treated as a mirror here.
pub const MIRROR_ROUGHNESS: f32 = 0.02;

/// Whether `m` reflects as a mirror here: it has lobes, all of roughness ≤
/// [`MIRROR_ROUGHNESS`].
pub fn is_mirror(m: &crate::scene::material::Material) -> bool {
    !m.lobes.is_empty() && m.lobes.iter().all(|l| l.mx.max(l.my) <= MIRROR_ROUGHNESS)
}

/// One near-mirror planar reflector.
struct Mirror {
    plane: Plane,
    lobes: Vec<Lobe>,
    /// Bounds of the mirror's triangles, widened a little: a ray that crosses the plane
    /// outside them cannot meet the mirror, and is not cast.
    lo: Vec3,
    hi: Vec3,
}

impl Mirror {
    /// Reflectance for a ray meeting the mirror at cos θ = `c` to the plane's normal:
    /// Σ k_s × each lobe's directional albedo in its mirror limit ([`Lobe::mirror_reflectance`]).
    fn reflectance(&self, c: f32) -> Vec3 {
        self.lobes
            .iter()
            .fold(Vec3::ZERO, |acc, l| acc + l.ks * l.mirror_reflectance(c))
    }

    /// Whether the segment from `origin` (in front of the plane) along `d` may meet the mirror:
    /// it crosses the plane inside the mirror's bounds.
    fn may_meet(&self, origin: Vec3, d: Vec3) -> bool {
        let n = self.plane.normal;
        let along = d.dot(n);
        if along >= 0.0 {
            return false;
        }
        let p = origin + d * ((self.plane.point - origin).dot(n) / along);
        p.cmpge(self.lo).all() && p.cmple(self.hi).all()
    }

    fn reflect_point(&self, q: Vec3) -> Vec3 {
        let n = self.plane.normal;
        q - n * (2.0 * (q - self.plane.point).dot(n))
    }

    /// The corners of the mirror's (widened) bounds.
    fn corners(&self) -> [Vec3; 8] {
        box_corners(self.lo, self.hi)
    }

    /// The light reaching `origin` (shading normal `ns`, face normal `ng`) from emitter point
    /// `q` via this mirror (`id`): its reflectance, the cosine at the receiver, the distance²
    /// to q's image and the reflected direction at the emitter; `None` when blocked or
    /// outside the mirror. The segment to q stops `reach_short` before it.
    #[allow(clippy::too_many_arguments)]
    fn through(
        &self,
        id: u32,
        mirror_of: &[u32],
        scene: &Scene,
        bvh: &Bvh,
        origin: Vec3,
        ns: Vec3,
        ng: Vec3,
        q: Vec3,
        reach_short: f32,
        rays: &mut u64,
    ) -> Option<(Vec3, f32, f32, Vec3)> {
        let image = self.reflect_point(q);
        let w = image - origin;
        let dist2 = w.length_squared();
        let dist = dist2.sqrt();
        if dist.is_nan() || dist <= 0.0 {
            return None;
        }
        let d = w / dist;
        let cos_s = d.dot(ns);
        if cos_s <= 0.0 || d.dot(ng) <= 0.0 || !self.may_meet(origin, d) {
            return None;
        }
        *rays += 1;
        let h = bvh.closest_hit(origin, d, dist)?;
        let tri = &scene.triangles[h.triangle as usize];
        let c = -d.dot(self.plane.normal);
        if mirror_of[h.triangle as usize] != id || c <= 0.0 {
            return None;
        }
        if tri.face_normal().dot(d) >= 0.0 {
            return None;
        }
        let n = self.plane.normal;
        let r = d - n * (2.0 * d.dot(n));
        let at = bvh.offset_origin(origin + d * h.t, n);
        *rays += 1;
        let rest = (dist - h.t) - reach_short;
        if rest <= 0.0 || bvh.occluded(at, r, rest) {
            return None;
        }
        Some((self.reflectance(c), cos_s, dist2, r))
    }
}

/// The scene's near-mirror planar reflectors.
pub(super) struct MirrorLights {
    mirrors: Vec<Mirror>,
    /// Per triangle: its mirror's id (index + 1), 0 when it is not part of one.
    mirror_of: Vec<u32>,
    /// With many emitters: per mirror, the distribution over the emitters of a receiver at
    /// its centre (which emitters light the mirror, and how much).
    per_mirror: Vec<Choice>,
}

impl MirrorLights {
    /// `None` when the scene has no planar reflector whose material is a mirror. With `many`,
    /// the emitters are sampled from one distribution ([`MirrorLights::direct`]).
    pub fn new(scene: &Scene, many: Option<&ManyLights>) -> Option<MirrorLights> {
        let mut mirrors = Vec::new();
        let mut mirror_of = vec![0u32; scene.triangles.len()];
        for r in &scene.reflectors {
            let (ReflectorKind::Planar, Some(plane)) = (r.kind, r.plane) else {
                continue;
            };
            let m = &scene.materials[r.material as usize];
            if !is_mirror(m) {
                continue;
            }
            let id = mirrors.len() as u32 + 1;
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for &t in &r.triangles {
                // Only the mirror's own material reflects as the mirror.
                let tri = &scene.triangles[t as usize];
                if tri.material == r.material {
                    mirror_of[t as usize] = id;
                    for v in tri.p {
                        lo = lo.min(v);
                        hi = hi.max(v);
                    }
                }
            }
            // Widened by a thousandth of its size and 10 µm: rounding never culls a ray that
            // meets it.
            let pad = Vec3::splat((hi - lo).max_element() * 1e-3 + 1e-5);
            mirrors.push(Mirror {
                plane,
                lobes: m.lobes.iter().map(Lobe::from).collect(),
                lo: lo - pad,
                hi: hi + pad,
            });
        }
        let per_mirror = match many {
            None => Vec::new(),
            Some(ml) => mirrors
                .iter()
                .map(|m| ml.choose_for(m.plane.point, m.plane.normal, &m.corners()))
                .collect(),
        };
        (!mirrors.is_empty()).then_some(MirrorLights {
            mirrors,
            mirror_of,
            per_mirror,
        })
    }

    /// Whether `triangle` is part of a mirror whose emitter images are sampled here.
    pub fn is_mirror(&self, triangle: u32) -> bool {
        self.mirror_of[triangle as usize] != 0
    }

    /// Irradiance/π at a point (`origin` offset from it, shading normal `ns`, face normal `ng`)
    /// from the emitters' images in every mirror, `n_light` samples per emitter and mirror
    /// (with `many`: `n_light` × [`LIGHTS_SAMPLED_EACH`] samples over all mirrors and
    /// emitters); returns it with the variance of its luminance and counts the rays cast.
    #[allow(clippy::too_many_arguments)]
    pub fn direct(
        &self,
        scene: &Scene,
        bvh: &Bvh,
        emitters: &Emitters,
        many: Option<&ManyLights>,
        origin: Vec3,
        ns: Vec3,
        ng: Vec3,
        rng: &mut Rng,
        n_light: u32,
        rays: &mut u64,
    ) -> (Vec3, f64) {
        if let Some(ml) = many {
            let n = n_light * LIGHTS_SAMPLED_EACH as u32;
            return self.direct_many(scene, bvh, ml, origin, ns, ng, rng, n, rays);
        }
        let mut total = Vec3::ZERO;
        let mut var = 0.0f64;
        for (id, m) in (1u32..).zip(&self.mirrors) {
            if (origin - m.plane.point).dot(m.plane.normal) <= 0.0 {
                continue; // behind the mirror: it shows nothing here
            }
            let mut through = |q: Vec3, reach_short: f32| {
                m.through(
                    id,
                    &self.mirror_of,
                    scene,
                    bvh,
                    origin,
                    ns,
                    ng,
                    q,
                    reach_short,
                    rays,
                )
            };

            for light in &scene.lights {
                let shift = rng.uniform2();
                let (mut sum, mut y, mut y2) = (Vec3::ZERO, 0.0f64, 0.0f64);
                for k in 0..n_light {
                    let q = spread_point(light, k, shift);
                    let Some((refl, cos_s, dist2, r)) = through(q, 0.0) else {
                        continue;
                    };
                    let mut cos_l = -r.dot(light.normal);
                    if light.two_sided {
                        cos_l = cos_l.abs();
                    }
                    if cos_l <= 0.0 {
                        continue;
                    }
                    let c = light.radiance * refl * (cos_s * cos_l / dist2);
                    sum += c;
                    let v = luminance(c) as f64 * (light.area / PI) as f64;
                    y += v;
                    y2 += v * v;
                }
                total += sum * (light.area / n_light as f32) / PI;
                var += var_of_mean(y, y2, n_light);
            }

            if !emitters.tris.is_empty() {
                let (mut sum, mut y, mut y2) = (Vec3::ZERO, 0.0f64, 0.0f64);
                for _ in 0..n_light {
                    let picked = emitters.pick(rng.uniform());
                    let et = &scene.triangles[picked as usize];
                    let e = scene.materials[et.material as usize].emission;
                    let at = sample_triangle(rng.uniform2());
                    let q = et.point(at);
                    let Some((refl, cos_s, dist2, r)) = through(q, 2.0 * bvh.epsilon()) else {
                        continue;
                    };
                    let cos_l = -r.dot(et.face_normal());
                    if cos_l <= 0.0 {
                        continue;
                    }
                    let p_light = emitters.area_pdf(e) * dist2 / cos_l;
                    let c = scene.emission_at(picked, at) * refl * (cos_s / p_light);
                    sum += c;
                    let v = luminance(c) as f64 / PI as f64;
                    y += v;
                    y2 += v * v;
                }
                total += sum / (n_light as f32 * PI);
                var += var_of_mean(y, y2, n_light);
            }
        }
        (total, var)
    }

    /// [`MirrorLights::direct`] with many emitters: `n` samples, each a mirror chosen by what
    /// it can reflect towards the point (its emitters' weight at its centre, the best cosine
    /// it makes with `ns`, over distance² + its radius²), then an emitter from the mirror's
    /// distribution, then a point on it.
    ///
    /// In a building most points see no mirror at all (it hangs in another room), and the
    /// weights cannot know it: every sample would cast a ray to find a wall. So a pilot of
    /// `n / PILOT_DIVISOR` samples goes first; when none of them reaches an emitter, the `n`
    /// samples are drawn only with probability [`UNSEEN_KEEP`] and then count 1/[`UNSEEN_KEEP`]
    /// (Russian roulette: the estimate stays unbiased, and a point that sees no mirror pays
    /// about a quarter of the rays). The pilot is not part of the estimate.
    #[allow(clippy::too_many_arguments)]
    fn direct_many(
        &self,
        scene: &Scene,
        bvh: &Bvh,
        many: &ManyLights,
        origin: Vec3,
        ns: Vec3,
        ng: Vec3,
        rng: &mut Rng,
        n: u32,
        rays: &mut u64,
    ) -> (Vec3, f64) {
        let mirrors = Choice::from_weights(
            self.mirrors
                .iter()
                .zip(&self.per_mirror)
                .map(|(m, choice)| mirror_weight(m, choice, origin, ns)),
        );
        if mirrors.is_empty() {
            return (Vec3::ZERO, 0.0);
        }
        let at = Receiving {
            scene,
            bvh,
            many,
            mirrors: &mirrors,
            origin,
            ns,
            ng,
        };
        let pilot = (n / PILOT_DIVISOR).max(1);
        let seen = (0..pilot).any(|k| {
            let u = (k as f32 + rng.uniform()) / pilot as f32;
            self.sample(&at, u, rng, rays).is_some()
        });
        let scale = if seen {
            1.0
        } else if rng.uniform() < UNSEEN_KEEP {
            1.0 / UNSEEN_KEEP
        } else {
            return (Vec3::ZERO, 0.0);
        };
        let (mut sum, mut y, mut y2) = (Vec3::ZERO, 0.0f64, 0.0f64);
        for k in 0..n {
            let u = (k as f32 + rng.uniform()) / n as f32;
            let Some(c) = self.sample(&at, u, rng, rays) else {
                continue;
            };
            let c = c * scale;
            sum += c;
            let v = luminance(c) as f64 / PI as f64;
            y += v;
            y2 += v * v;
        }
        (sum / (n as f32 * PI), var_of_mean(y, y2, n))
    }

    /// One sample of [`MirrorLights::direct_many`]: `u` picks the mirror; the light it brings
    /// over its density (before 1/π), `None` when it brings none.
    fn sample(&self, at: &Receiving, u: f32, rng: &mut Rng, rays: &mut u64) -> Option<Vec3> {
        let (i, p_mirror) = at.mirrors.pick(u);
        let (m, choice) = (&self.mirrors[i], &self.per_mirror[i]);
        let (e, p_emitter) = choice.pick(rng.uniform());
        let lp = at.many.sample(at.scene, e, m.reflect_point(at.origin), rng);
        let reach_short = if lp.triangle.is_some() {
            2.0 * at.bvh.epsilon()
        } else {
            0.0
        };
        let (refl, cos_s, dist2, r) = m.through(
            i as u32 + 1,
            &self.mirror_of,
            at.scene,
            at.bvh,
            at.origin,
            at.ns,
            at.ng,
            lp.q,
            reach_short,
            rays,
        )?;
        let cos_l = -r.dot(lp.normal);
        if cos_l <= 0.0 {
            return None;
        }
        let p = p_mirror * p_emitter * lp.area_pdf;
        Some(lp.radiance * refl * (cos_s * cos_l / (dist2 * p)))
    }
}

/// A pilot's samples per [`MirrorLights::direct_many`] sample: 1 in this many.
const PILOT_DIVISOR: u32 = 8;

/// Chance that [`MirrorLights::direct_many`] draws its samples at a point where its pilot
/// reached no emitter through any mirror.
const UNSEEN_KEEP: f32 = 0.125;

/// A receiving point of [`MirrorLights::direct_many`] and what its samples read.
struct Receiving<'a> {
    scene: &'a Scene,
    bvh: &'a Bvh,
    many: &'a ManyLights,
    mirrors: &'a Choice,
    origin: Vec3,
    ns: Vec3,
    ng: Vec3,
}

/// Weight of mirror `m` (with its emitters' distribution `choice`) for a receiver at `origin`
/// with normal `ns`: 0 when the receiver is behind it or it lies wholly below the receiver's
/// plane.
fn mirror_weight(m: &Mirror, choice: &Choice, origin: Vec3, ns: Vec3) -> f32 {
    if choice.is_empty() || (origin - m.plane.point).dot(m.plane.normal) <= 0.0 {
        return 0.0;
    }
    let (lo, hi) = (m.lo, m.hi);
    let cos_r = best_cosine(&m.corners(), origin, ns);
    if cos_r <= 0.0 {
        return 0.0;
    }
    let centre = 0.5 * (lo + hi);
    choice.total() * cos_r
        / ((origin - centre).length_squared() + 0.25 * (hi - lo).length_squared())
}
