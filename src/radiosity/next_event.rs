//! Next-event estimation with each emitter sampled on its own: the light that reaches a point
//! straight from points drawn on every area light and on the emissive triangles. The solver
//! has two receivers of it: an element's direct light ([`super::gather`]) and a vertex of a
//! glossy path ([`super::transport`]). Above [`super::many_lights::LIGHTS_SAMPLED_EACH`]
//! emitters, points come from one per-point distribution over them all instead
//! ([`super::many_lights`]).
//!
//! Points are drawn with respect to area on the emitters: `n` uniform points on each area
//! light (density 1/A), a randomly shifted R2 set over it, and `n` points on the emissive
//! triangles, with density ∝ area × luminance ([`Emitters::area_pdf`]), drawn as one randomly shifted R2
//! set over that measure (each point uniform in it, the set evenly spread). At the receiver a
//! point's density per solid angle is p_ω = p_A · dist² / cos θ_l, and a point that faces the
//! receiver, lies above its surface and is not occluded contributes f · L_e · cos θ_i · w / p_ω
//! (the light-sampling half of Veach's direct-lighting estimator, thesis 1997 ch. 9, w the MIS
//! weight).
//!
//! The receiver supplies f, cos θ_i and w ([`Receiver`]): an element sums an area light's
//! samples before scaling them by its area and weights only the emissive triangles, which
//! its gathering rays can also hit; a glossy vertex divides each sample by p_ω.

use glam::{Vec2, Vec3};

use super::emitters::{Emitters, spread_point};
use super::transmission::{Glass, shadow};
use crate::geometry::Bvh;
use crate::sampling::{Rng, r2, sample_triangle};
use crate::scene::{AreaLight, Scene};

/// The emitters sampled one by one, and the geometry that shadows them.
pub(super) struct NextEvent<'a> {
    pub scene: &'a Scene,
    pub bvh: &'a Bvh,
    pub emitters: &'a Emitters,
    /// The scene's glass ([`Glass::of`]), which shadow rays pass.
    pub glass: Option<Glass<'a>>,
}

/// Where light is estimated.
pub(super) struct At {
    /// The point directions and distances to the emitters are measured from.
    pub from: Vec3,
    /// Where shadow rays leave (offset from the surface).
    pub origin: Vec3,
    /// Geometric normal: light from below the surface does not count.
    pub ng: Vec3,
}

/// The emitter a point was drawn on.
#[derive(Clone, Copy)]
pub(super) enum Source<'a> {
    Quad(&'a AreaLight),
    Triangles,
}

/// An unoccluded point on an emitter, seen from the receiver.
pub(super) struct Arrival {
    /// Radiance emitted towards the receiver.
    pub radiance: Vec3,
    /// Squared distance to the receiver.
    pub dist2: f32,
    /// Cosine at the emitter (> 0).
    pub cos_l: f32,
    /// Density of the point per solid angle at the receiver, p_A · dist² / cos θ_l.
    pub p_light: f32,
}

/// What a receiver makes of the points next-event estimation draws.
pub(super) trait Receiver {
    /// What the receiver keeps of a direction it reflects light from, for [`Receiver::add`].
    type Toward;
    /// How light from unit direction `d` (above the surface) is reflected; `None`: not at
    /// all, and no shadow ray is cast.
    fn toward(&self, d: Vec3) -> Option<Self::Toward>;
    /// Light from an unoccluded point on `source`.
    fn add(&mut self, source: Source, a: &Arrival, toward: Self::Toward);
    /// Called after the `n` points drawn on `source` (the emissive triangles only when the
    /// scene has some).
    fn end(&mut self, _source: Source, _n: u32) {}
}

impl NextEvent<'_> {
    /// Draws `n` points on each area light, then `n` on the emissive triangles, and hands those
    /// that reach `at` to `receiver`; counts the shadow rays cast.
    pub fn estimate<R: Receiver>(
        &self,
        at: &At,
        n: u32,
        rng: &mut Rng,
        rays: &mut u64,
        receiver: &mut R,
    ) {
        let (scene, bvh) = (self.scene, self.bvh);
        let glass = self.glass;
        for light in &scene.lights {
            let shift = rng.uniform2();
            for k in 0..n {
                let q = spread_point(light, k, shift);
                let Some((d, dist, dist2)) = towards(at.from, q) else {
                    continue;
                };
                let mut cos_l = -d.dot(light.normal);
                if light.two_sided {
                    cos_l = cos_l.abs();
                }
                if cos_l <= 0.0 || d.dot(at.ng) <= 0.0 {
                    continue;
                }
                let Some(toward) = receiver.toward(d) else {
                    continue;
                };
                *rays += 1;
                let Some(tr) = shadow(glass.as_ref(), bvh, at.origin, d, dist * (1.0 - 1e-5))
                else {
                    continue;
                };
                let a = Arrival {
                    radiance: light.radiance * tr,
                    dist2,
                    cos_l,
                    p_light: dist2 / (cos_l * light.area),
                };
                receiver.add(Source::Quad(light), &a, toward);
            }
            receiver.end(Source::Quad(light), n);
        }

        if self.emitters.tris.is_empty() {
            return;
        }
        // A shifted low-discrepancy set over the emitters' area × luminance: each point is
        // still uniform in it, and together they leave no part of a panel unsampled.
        let shift = rng.uniform2();
        for k in 0..n {
            let u = r2(k, shift);
            let (slot, along) = self.emitters.pick_spread(u.x);
            let picked = self.emitters.tris[slot];
            let et = &scene.triangles[picked as usize];
            let b = sample_triangle(Vec2::new(along, u.y));
            let Some((d, dist, dist2)) = towards(at.from, et.point(b)) else {
                continue;
            };
            let cos_l = -d.dot(self.emitters.normals[slot]);
            if cos_l <= 0.0 || d.dot(at.ng) <= 0.0 {
                continue;
            }
            let Some(toward) = receiver.toward(d) else {
                continue;
            };
            *rays += 1;
            // Stop short of the emitter: it must not occlude itself.
            let reach = dist - 2.0 * bvh.epsilon().max(dist * 1e-5);
            let Some(tr) = shadow(glass.as_ref(), bvh, at.origin, d, reach) else {
                continue;
            };
            let e = scene.materials[et.material as usize].emission;
            let a = Arrival {
                radiance: scene.emission_at(picked, b) * tr,
                dist2,
                cos_l,
                p_light: self.emitters.area_pdf(e) * dist2 / cos_l,
            };
            receiver.add(Source::Triangles, &a, toward);
        }
        receiver.end(Source::Triangles, n);
    }
}

/// Unit direction, distance and squared distance from `from` to `q`; `None` when they
/// coincide.
fn towards(from: Vec3, q: Vec3) -> Option<(Vec3, f32, f32)> {
    let w = q - from;
    let dist2 = w.length_squared();
    let dist = dist2.sqrt();
    // Also false for NaN.
    (dist > 0.0).then(|| (w / dist, dist, dist2))
}

#[cfg(test)]
mod tests {
    use std::f32::consts::PI;

    use glam::{Vec2, Vec3};

    use super::{Arrival, At, NextEvent, Receiver, Source};
    use crate::geometry::Bvh;
    use crate::radiosity::emitters::{Emitters, spread_var_of_mean};
    use crate::sampling::Rng;
    use crate::scene::{AreaLight, Scene};

    /// Irradiance/π at a receiver facing +y, with the light drawn on quads and on the
    /// triangles kept apart: Σ L · cos θ_i / p_ω / n per emitter.
    #[derive(Default)]
    struct Up {
        quads: f64,
        triangles: f64,
    }

    impl Receiver for Up {
        type Toward = f32;

        fn toward(&self, d: Vec3) -> Option<f32> {
            (d.y > 0.0).then_some(d.y)
        }

        fn add(&mut self, source: Source, a: &Arrival, cos: f32) {
            let v = (a.radiance.x * cos / a.p_light / PI) as f64;
            match source {
                Source::Quad(_) => self.quads += v,
                Source::Triangles => self.triangles += v,
            }
        }
    }

    /// The emissive triangles' points are spread as one low-discrepancy set: under the Cornell
    /// box's panel 256 points give the analytic irradiance within a relative RMS of 3.5·10⁻³
    /// over seeds (the bound asserted).
    #[test]
    fn few_points_on_the_emissive_triangles_are_spread_over_the_panel() {
        let scene = cornell_box();
        let emitters = Emitters::new(&scene);
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for &t in &emitters.tris {
            for p in scene.triangles[t as usize].p {
                (lo, hi) = (lo.min(p), hi.max(p));
            }
        }
        let panel_l = scene.materials[scene.triangles[emitters.tris[0] as usize].material as usize]
            .emission
            .x;
        let bvh = scene.build_bvh();
        let ne = unglazed(&scene, &bvh, &emitters);
        let (size, below) = (hi - lo, 0.6);
        let p = Vec3::new(0.5 * (lo.x + hi.x), hi.y - below, 0.5 * (lo.z + hi.z));
        let at = At {
            from: p,
            origin: p,
            ng: Vec3::Y,
        };
        let want = panel_l as f64 * form_factor(size.x, size.z, below);
        // Independent points fail this bound.
        let n = 256;
        let rms = ((0..16)
            .map(|seed| {
                let (mut up, mut rays) = (Up::default(), 0);
                ne.estimate(&at, n, &mut Rng::new(seed, 3), &mut rays, &mut up);
                (up.triangles / n as f64 / want - 1.0).powi(2)
            })
            .sum::<f64>()
            / 16.0)
            .sqrt();
        assert!(rms < 3.5e-3, "{rms}");
    }

    /// Each point's luminance-free value for [`spread_var_of_mean`].
    #[derive(Default)]
    struct Points(Vec<f64>);

    impl Receiver for Points {
        type Toward = f32;

        fn toward(&self, d: Vec3) -> Option<f32> {
            (d.y > 0.0).then_some(d.y)
        }

        fn add(&mut self, _: Source, a: &Arrival, cos: f32) {
            self.0.push((a.radiance.x * cos / a.p_light) as f64);
        }
    }

    /// Over the Cornell box's floor (lit, shadowed by the boxes and in their penumbrae), the
    /// variance the spread points' estimate reads is at the median point no more than 1.5 times
    /// below their mean's real variance over seeds (nor 4 times above it), and no more than 2
    /// times below it at nine points in ten.
    #[test]
    fn the_spread_points_variance_estimate_follows_their_real_spread() {
        let scene = cornell_box();
        let emitters = Emitters::new(&scene);
        let bvh = scene.build_bvh();
        let b = bvh.bounds();
        let ne = unglazed(&scene, &bvh, &emitters);
        let seeds = 48u64;
        for n in [32u32, 128, 512] {
            // Real over estimated variance, per lit point.
            let mut ratios = Vec::new();
            for i in 0..100 {
                let (x, z) = ((i % 10) as f32 + 0.5, (i / 10) as f32 + 0.5);
                let p = Vec3::new(
                    b.min.x + (b.max.x - b.min.x) * x / 10.0,
                    b.min.y + 0.01,
                    b.min.z + (b.max.z - b.min.z) * z / 10.0,
                );
                let at = At {
                    from: p,
                    origin: p,
                    ng: Vec3::Y,
                };
                let (mut s, mut s2, mut estimated) = (0.0, 0.0, 0.0);
                for seed in 0..seeds {
                    let (mut points, mut rays) = (Points::default(), 0);
                    ne.estimate(&at, n, &mut Rng::new(seed, 9), &mut rays, &mut points);
                    let sum: f64 = points.0.iter().sum();
                    let sq: f64 = points.0.iter().map(|v| v * v).sum();
                    let mean = sum / n as f64;
                    (s, s2) = (s + mean, s2 + mean * mean);
                    estimated += spread_var_of_mean(sum, sq, n);
                }
                let k = seeds as f64;
                if s > 0.0 {
                    ratios.push((s2 / k - (s / k).powi(2)) * k / (k - 1.0) / (estimated / k));
                }
            }
            ratios.sort_by(f64::total_cmp);
            let at = |q: f64| ratios[((ratios.len() - 1) as f64 * q).round() as usize];
            let (median, q90) = (at(0.5), at(0.9));
            assert!(ratios.len() > 50, "{} lit points", ratios.len());
            assert!((0.25..1.5).contains(&median), "{n} points: median {median}");
            assert!(q90 < 2.0, "{n} points: 90th percentile {q90}");
        }
    }

    /// Any number of points on an area light gives its irradiance without bias: 128 points (no
    /// square) under a light 0.5 m wide, 0.1 m and 0.3 m below it, average to the analytic
    /// value within a relative 5·10⁻³ over seeds (the bound asserted).
    #[test]
    fn any_number_of_points_on_an_area_light_is_unbiased() {
        let mut scene = cornell_box();
        let emitters = Emitters::new(&scene);
        let (side, height) = (0.5, 1.85);
        let corner = Vec3::new(-0.5 * side, height, -0.5 * side);
        scene
            .lights
            .push(light_facing_down(corner, Vec2::new(side, side), 1.0));
        let bvh = scene.build_bvh();
        let ne = unglazed(&scene, &bvh, &emitters);
        let (n, seeds) = (128, 64);
        for below in [0.1f32, 0.3] {
            let p = Vec3::new(0.0, height - below, 0.0);
            let at = At {
                from: p,
                origin: p,
                ng: Vec3::Y,
            };
            let mean = (0..seeds)
                .map(|seed| {
                    let (mut up, mut rays) = (Up::default(), 0);
                    ne.estimate(&at, n, &mut Rng::new(seed, 1), &mut rays, &mut up);
                    up.quads / n as f64
                })
                .sum::<f64>()
                / seeds as f64;
            let want = form_factor(side, side, below);
            assert!(
                (mean / want - 1.0).abs() < 5e-3,
                "{below} m below: {mean} vs {want}"
            );
        }
    }

    fn cornell_box() -> Scene {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box/scene.json");
        Scene::load(path).unwrap_or_else(|e| panic!("{e}"))
    }

    /// Next-event estimation in `scene` with no glass in the way.
    fn unglazed<'a>(scene: &'a Scene, bvh: &'a Bvh, emitters: &'a Emitters) -> NextEvent<'a> {
        NextEvent {
            scene,
            bvh,
            emitters,
            glass: None,
        }
    }

    /// A one-sided `size.x` × `size.y` light of grey `radiance` in the plane y = `corner.y`,
    /// spanning +x and +z from `corner` and facing down.
    fn light_facing_down(corner: Vec3, size: Vec2, radiance: f32) -> AreaLight {
        AreaLight {
            name: "facing down".into(),
            corner,
            edge_u: Vec3::new(size.x, 0.0, 0.0),
            edge_v: Vec3::new(0.0, 0.0, size.y),
            normal: Vec3::NEG_Y,
            area: size.x * size.y,
            radiance: Vec3::splat(radiance),
            two_sided: false,
        }
    }

    /// Form factor from a point to a parallel rectangle `a` × `b` centred above it at height
    /// `c`: four of Howell's element-to-parallel-rectangle factors, each with its normal through
    /// a corner.
    fn form_factor(a: f32, b: f32, c: f32) -> f64 {
        let (x, y) = ((a / 2.0 / c) as f64, (b / 2.0 / c) as f64);
        let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
        4.0 / (2.0 * std::f64::consts::PI) * (x / sx * (y / sx).atan() + y / sy * (x / sy).atan())
    }

    /// Both densities are per solid angle at the receiver: under the Cornell box's ceiling
    /// panel (emissive triangles) and under an area light of the panel's size hung 5 cm below
    /// it, the estimates match the analytic irradiance/π = L · F of a parallel rectangle, and
    /// the panel's triangles do not shadow their own points.
    #[test]
    fn light_samples_give_the_irradiance_of_a_parallel_rectangle() {
        let mut scene = cornell_box();
        let emitters = Emitters::new(&scene);
        assert!(!emitters.tris.is_empty());
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for &t in &emitters.tris {
            let tri = &scene.triangles[t as usize];
            assert_eq!(tri.face_normal(), Vec3::NEG_Y, "the panel faces down");
            let m = &scene.materials[tri.material as usize];
            assert!(m.emissive_texture.is_none() && m.emission.x > 0.0);
            for k in 0..3 {
                (lo, hi) = (lo.min(tri.p[k]), hi.max(tri.p[k]));
            }
        }
        let panel_l = scene.materials[scene.triangles[emitters.tris[0] as usize].material as usize]
            .emission
            .x;
        let (size, ceiling) = (hi - lo, hi.y);
        let drop = 0.05;
        let corner = Vec3::new(lo.x, ceiling - drop, lo.z);
        scene
            .lights
            .push(light_facing_down(corner, Vec2::new(size.x, size.z), 2.0));
        let bvh = scene.build_bvh();
        let ne = NextEvent {
            scene: &scene,
            bvh: &bvh,
            emitters: &emitters,
            glass: super::super::transmission::Glass::of(&scene, &bvh),
        };
        let below = 0.6;
        let p = Vec3::new(0.5 * (lo.x + hi.x), ceiling - below, 0.5 * (lo.z + hi.z));
        let at = At {
            from: p,
            origin: p,
            ng: Vec3::Y,
        };
        let n = 64 * 64;
        let (mut up, mut rays) = (Up::default(), 0);
        ne.estimate(&at, n, &mut Rng::new(7, 0), &mut rays, &mut up);
        assert_eq!(rays, 2 * n as u64, "every point faces the receiver");
        let quad = up.quads / n as f64;
        let tris = up.triangles / n as f64;
        let want_quad = 2.0 * form_factor(size.x, size.z, below - drop);
        let want_tris = panel_l as f64 * form_factor(size.x, size.z, below);
        assert!(
            (quad / want_quad - 1.0).abs() < 1e-3,
            "{quad} vs {want_quad}"
        );
        assert!(
            (tris / want_tris - 1.0).abs() < 1e-2,
            "{tris} vs {want_tris}"
        );
    }
}
