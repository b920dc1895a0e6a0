//! Many emitters: each point samples them in proportion to what each can give it.
//!
//! A room lit by a handful of emitters samples each of them (`light_samples` per area light and
//! as many for the emissive triangles): [`super::gather`]. In a building the emitters grow with
//! the floor area, and so would every element's shadow rays, most of them towards lamps rooms
//! away. Above [`LIGHTS_SAMPLED_EACH`] emitters, every point instead draws a fixed number of
//! samples from one distribution over all of them (next-event estimation with a per-point
//! light-selection pdf, as light trees do with their importance bound): an emitter is chosen
//! with probability ∝ its power × the best cosine it can make with the point's normal / (its
//! distance² + its radius²), then a point on it. The estimator divides by that probability,
//! so D stays unbiased whatever the weights, as long as no emitter that can light the point
//! gets weight 0 (an emitter wholly below the point's plane, or with the point behind its one
//! emitting side, cannot).
//!
//! The weights know no walls: in a building, half of an element's samples went to lamps in
//! other rooms and were blocked. So an element (not a glossy path's vertex, which draws one
//! sample) first casts a few rays at each emitter that holds more than [`TESTED_SHARE`] of its
//! weight: a quad's centre and four points near its corners, a group's first triangle's
//! centroid. Each blocked ray scales the emitter's weight down towards [`UNSEEN`] of it; an
//! emitter none of them reaches keeps that much, so a lamp seen only through a gap still gets
//! samples and D stays unbiased.
//!
//! An emitter is an area light of scene.json, or a group of emissive triangles that share
//! vertices (a lamp's panel, a window): within a group a triangle is chosen by area ×
//! luminance, as [`super::emitters::Emitters`] does for the whole scene.

use std::collections::HashMap;

use glam::Vec3;

use super::emitters::luminance;
use crate::geometry::Bvh;
use crate::sampling::{Rng, sample_triangle};
use crate::scene::Scene;

/// Emitters (area lights and groups of emissive triangles) up to which each is sampled on its
/// own; above, samples are drawn from a per-point distribution, `light_samples` × this many.
pub const LIGHTS_SAMPLED_EACH: usize = 8;

/// Floor of the emitter-side cosine in a weight: a point just off a lamp's plane still gets
/// samples.
const MIN_EMITTER_COS: f32 = 0.05;

/// What an emitter's weight keeps when none of an element's test rays reaches it.
const UNSEEN: f32 = 0.05;

/// An element tests the visibility of the emitters that hold more than this share of its
/// weights; the rest keep their weights untested.
const TESTED_SHARE: f32 = 0.02;

/// How far from its centre towards each corner a quad's test points lie.
const TEST_CORNER: f32 = 0.9;

/// What an emitter is made of.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Kind {
    /// Area light `index` of the scene.
    Quad(u32),
    /// Emissive triangles, chosen by area × luminance (cumulative sums).
    Group { tris: Vec<u32>, cdf: Vec<f64> },
}

/// One emitter with the bounds its weight needs.
#[derive(Clone, Debug)]
pub(super) struct Emitter {
    pub kind: Kind,
    /// Luminance × area (× π gives the power of a one-sided Lambertian emitter).
    power: f32,
    centre: Vec3,
    /// Squared half-diagonal of its bounds.
    radius2: f32,
    /// Points whose convex hull holds it: a quad's corners, a group's box corners.
    hull: Vec<Vec3>,
    /// A quad's emitting normal and whether it emits from both sides.
    facing: Option<(Vec3, bool)>,
    /// A point on it that an element's visibility test aims at: a quad's centre, a group's
    /// first triangle's centroid.
    aim: Vec3,
}

/// A point on an emitter.
pub(super) struct LightPoint {
    pub q: Vec3,
    /// Normal of the emitting side (a two-sided quad's: the side facing `from`).
    pub normal: Vec3,
    pub radiance: Vec3,
    /// Density per unit area of the point given its emitter.
    pub area_pdf: f32,
    /// The emissive triangle it lies on (`None`: an area light).
    pub triangle: Option<u32>,
}

/// A point drawn from a [`Choice`], seen from the receiver it was drawn for.
pub(super) struct Drawn {
    pub point: LightPoint,
    /// Unit direction from the receiver to the point, and the distance.
    pub d: Vec3,
    pub dist: f32,
    /// Density of the point per solid angle at the receiver: pick × area density × dist² / cos_l.
    pub p_light: f32,
}

impl Drawn {
    /// Whether nothing blocks the segment from `origin` to the point (stopping short of an
    /// emissive triangle, which must not occlude itself); counts the ray.
    pub fn visible(&self, bvh: &Bvh, origin: Vec3, rays: &mut u64) -> bool {
        *rays += 1;
        !bvh.occluded(origin, self.d, self.reach(bvh))
    }

    /// How far a shadow ray towards the point goes.
    pub fn reach(&self, bvh: &Bvh) -> f32 {
        match self.point.triangle {
            None => self.dist * (1.0 - 1e-5),
            Some(_) => short_of_surface(bvh, self.dist),
        }
    }
}

/// How far a shadow ray towards a point on a surface `dist` away goes: short of it, so that
/// the surface does not occlude itself.
pub(super) fn short_of_surface(bvh: &Bvh, dist: f32) -> f32 {
    dist - 2.0 * bvh.epsilon().max(dist * 1e-5)
}

/// The 8 corners of the box `lo`–`hi`.
pub(super) fn box_corners(lo: Vec3, hi: Vec3) -> [Vec3; 8] {
    std::array::from_fn(|c| {
        Vec3::new(
            if c & 1 == 0 { lo.x } else { hi.x },
            if c & 2 == 0 { lo.y } else { hi.y },
            if c & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

/// The largest cosine a direction from `at` to one of `points` makes with the unit normal
/// `n`, at least 0: 0 when every point (so their whole convex hull) lies on or below `at`'s
/// plane.
pub(super) fn best_cosine(points: &[Vec3], at: Vec3, n: Vec3) -> f32 {
    points.iter().fold(0.0f32, |best, &c| {
        let w = c - at;
        let len = w.length();
        best.max(if len > 0.0 { w.dot(n) / len } else { 1.0 })
    })
}

impl Emitter {
    /// Weight of this emitter for a receiver at `at` with unit normal `n`; `facing_from` are
    /// the receiver's points (one point, or a mirror's corners) tested against a quad's
    /// emitting side.
    fn weight(&self, at: Vec3, n: Vec3, facing_from: &[Vec3]) -> f32 {
        // The best cosine at the receiver: 0 when the whole emitter lies on or below its plane.
        let cos_r = best_cosine(&self.hull, at, n);
        if cos_r <= 0.0 {
            return 0.0;
        }
        let to = at - self.centre;
        let d2 = to.length_squared();
        let cos_e = match self.facing {
            None => 1.0,
            Some((normal, two_sided)) => {
                let side = |p: Vec3| {
                    let h = (p - self.centre).dot(normal);
                    if two_sided { h.abs() } else { h }
                };
                if !facing_from.iter().any(|&p| side(p) > 0.0) {
                    return 0.0;
                }
                (side(at).max(0.0) / d2.sqrt().max(f32::MIN_POSITIVE)).max(MIN_EMITTER_COS)
            }
        };
        self.power * cos_r * cos_e / (d2 + self.radius2)
    }
}

/// The scene's emitters, sampled per point when there are more than [`LIGHTS_SAMPLED_EACH`].
pub(super) struct ManyLights {
    pub emitters: Vec<Emitter>,
    /// Per triangle: the emitter (group) it belongs to, `u32::MAX` when not emissive.
    group_of: Vec<u32>,
}

/// One point's distribution over the emitters.
pub(super) struct Choice {
    /// Cumulative weights.
    cdf: Vec<f32>,
}

impl Choice {
    /// The distribution ∝ `weights` (each ≥ 0).
    pub fn from_weights(weights: impl Iterator<Item = f32>) -> Choice {
        let mut total = 0.0f32;
        let cdf = weights
            .map(|w| {
                total += w;
                total
            })
            .collect();
        Choice { cdf }
    }

    /// Σ weights.
    pub fn total(&self) -> f32 {
        self.cdf.last().copied().unwrap_or(0.0)
    }

    /// Whether no emitter can light the point.
    pub fn is_empty(&self) -> bool {
        self.total() <= 0.0
    }

    /// The emitter for `u` in [0, 1) and its probability. The choice must not be empty.
    pub fn pick(&self, u: f32) -> (usize, f32) {
        let x = u * self.total();
        let k = self
            .cdf
            .partition_point(|&c| c <= x)
            .min(self.cdf.len() - 1);
        (k, self.prob(k))
    }

    /// Probability of emitter `k`.
    pub fn prob(&self, k: usize) -> f32 {
        let before = if k == 0 { 0.0 } else { self.cdf[k - 1] };
        (self.cdf[k] - before) / self.total()
    }
}

impl ManyLights {
    /// `None` when the scene has at most `limit` emitters (each is then sampled on its own).
    pub fn new(scene: &Scene, limit: usize) -> Option<ManyLights> {
        let mut emitters = Vec::new();
        for (i, l) in scene.lights.iter().enumerate() {
            let hull = vec![
                l.corner,
                l.corner + l.edge_u,
                l.corner + l.edge_u + l.edge_v,
                l.corner + l.edge_v,
            ];
            emitters.push(Emitter {
                kind: Kind::Quad(i as u32),
                power: luminance(l.radiance) * l.area,
                centre: l.corner + 0.5 * (l.edge_u + l.edge_v),
                radius2: 0.25 * (l.edge_u + l.edge_v).length_squared(),
                hull,
                facing: Some((l.normal, l.two_sided)),
                aim: l.corner + 0.5 * (l.edge_u + l.edge_v),
            });
        }
        let groups = emissive_groups(scene);
        if emitters.len() + groups.len() <= limit {
            return None;
        }
        let mut group_of = vec![u32::MAX; scene.triangles.len()];
        for tris in groups {
            let id = emitters.len() as u32;
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            let mut cdf = Vec::with_capacity(tris.len());
            let mut total = 0.0f64;
            for &t in &tris {
                group_of[t as usize] = id;
                let tri = &scene.triangles[t as usize];
                for v in tri.p {
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
                let e = scene.materials[tri.material as usize].emission;
                total += tri.area() as f64 * luminance(e) as f64;
                cdf.push(total);
            }
            let hull = box_corners(lo, hi).to_vec();
            let first = &scene.triangles[tris[0] as usize];
            let aim = (first.p[0] + first.p[1] + first.p[2]) / 3.0;
            emitters.push(Emitter {
                kind: Kind::Group { tris, cdf },
                power: total as f32,
                centre: 0.5 * (lo + hi),
                radius2: 0.25 * (hi - lo).length_squared(),
                hull,
                facing: None,
                aim,
            });
        }
        Some(ManyLights { emitters, group_of })
    }

    /// The distribution of a receiver at `at` with unit normal `n`.
    pub fn choose(&self, at: Vec3, n: Vec3) -> Choice {
        self.choose_for(at, n, &[at])
    }

    /// [`ManyLights::choose`] for an element, each emitter's weight scaled by the share of
    /// its test points that `sees` (is the segment from the receiver to this point clear?)
    /// reports clear, kept at least [`UNSEEN`] of it (module doc). Its rays are not counted
    /// among the element's: they do not grow with its samples, and counted as the emitter
    /// samples' they made those look dearer to the refinement than they are.
    pub fn choose_seeing(&self, at: Vec3, n: Vec3, mut sees: impl FnMut(Vec3) -> bool) -> Choice {
        let mut weights: Vec<f32> = self
            .emitters
            .iter()
            .map(|e| e.weight(at, n, &[at]))
            .collect();
        let total: f32 = weights.iter().sum();
        for (e, w) in self.emitters.iter().zip(weights.iter_mut()) {
            if *w <= TESTED_SHARE * total {
                continue;
            }
            let corners = if e.facing.is_some() { &e.hull[..] } else { &[] };
            let points = std::iter::once(e.aim)
                .chain(corners.iter().map(|&c| e.aim + TEST_CORNER * (c - e.aim)));
            let (mut seen, mut tested) = (0u32, 0u32);
            for q in points {
                tested += 1;
                seen += sees(q) as u32;
            }
            *w *= UNSEEN + (1.0 - UNSEEN) * seen as f32 / tested as f32;
        }
        Choice::from_weights(weights.into_iter())
    }

    /// [`ManyLights::choose`] with the receiver's points for the emitters' facing test.
    pub fn choose_for(&self, at: Vec3, n: Vec3, facing_from: &[Vec3]) -> Choice {
        Choice::from_weights(self.emitters.iter().map(|e| e.weight(at, n, facing_from)))
    }

    /// A point drawn from `choice` (`u` picks the emitter) for a receiver at `origin`, with
    /// its direction and densities; `None` when it coincides with the receiver or faces away.
    pub fn draw_towards(
        &self,
        scene: &Scene,
        choice: &Choice,
        u: f32,
        origin: Vec3,
        rng: &mut Rng,
    ) -> Option<Drawn> {
        let (k, p_pick) = choice.pick(u);
        let point = self.sample(scene, k, origin, rng);
        let w = point.q - origin;
        let dist2 = w.length_squared();
        let dist = dist2.sqrt();
        if dist.is_nan() || dist <= 0.0 {
            return None;
        }
        let d = w / dist;
        let cos_l = -d.dot(point.normal);
        if cos_l <= 0.0 {
            return None;
        }
        let p_light = p_pick * point.area_pdf * dist2 / cos_l;
        Some(Drawn {
            point,
            d,
            dist,
            p_light,
        })
    }

    /// The emitter an emissive triangle belongs to.
    pub fn emitter_of(&self, triangle: u32) -> usize {
        self.group_of[triangle as usize] as usize
    }

    /// Density per unit area of a point on emissive triangle `triangle` (base emission `e`)
    /// given its emitter was chosen.
    pub fn area_pdf_in_group(&self, k: usize, e: Vec3) -> f32 {
        (luminance(e) as f64 / self.emitters[k].power as f64) as f32
    }

    /// A point on emitter `k`, seen from `from`.
    pub fn sample(&self, scene: &Scene, k: usize, from: Vec3, rng: &mut Rng) -> LightPoint {
        match &self.emitters[k].kind {
            Kind::Quad(i) => {
                let l = &scene.lights[*i as usize];
                let u = rng.uniform2();
                let q = l.corner + l.edge_u * u.x + l.edge_v * u.y;
                let normal = if l.two_sided && (from - q).dot(l.normal) < 0.0 {
                    -l.normal
                } else {
                    l.normal
                };
                LightPoint {
                    q,
                    normal,
                    radiance: l.radiance,
                    area_pdf: 1.0 / l.area,
                    triangle: None,
                }
            }
            Kind::Group { tris, cdf } => {
                let total = *cdf.last().unwrap();
                let x = rng.uniform() as f64 * total;
                let j = cdf.partition_point(|&c| c <= x).min(tris.len() - 1);
                let t = tris[j];
                let tri = &scene.triangles[t as usize];
                let b = sample_triangle(rng.uniform2());
                let e = scene.materials[tri.material as usize].emission;
                LightPoint {
                    q: tri.point(b),
                    normal: tri.face_normal(),
                    radiance: scene.emission_at(t, b),
                    area_pdf: self.area_pdf_in_group(k, e),
                    triangle: Some(t),
                }
            }
        }
    }
}

/// The emissive triangles in groups that share vertices (exact positions), each group in
/// increasing triangle order, groups ordered by their first triangle.
fn emissive_groups(scene: &Scene) -> Vec<Vec<u32>> {
    let emissive: Vec<u32> = (0..scene.triangles.len() as u32)
        .filter(|&t| {
            let tri = &scene.triangles[t as usize];
            let e = scene.materials[tri.material as usize].emission;
            tri.area() > 0.0 && luminance(e) > 0.0
        })
        .collect();
    // The smaller index becomes the root: groups come out in triangle order.
    let mut sets = super::disjoint::Sets::new(emissive.len());
    let mut first_at: HashMap<[u32; 3], usize> = HashMap::new();
    for (i, &t) in emissive.iter().enumerate() {
        for v in scene.triangles[t as usize].p {
            let key = v.to_array().map(f32::to_bits);
            let j = *first_at.entry(key).or_insert(i);
            sets.join(i, j);
        }
    }
    let mut index_of_root: HashMap<usize, usize> = HashMap::new();
    let mut groups: Vec<Vec<u32>> = Vec::new();
    for (i, &t) in emissive.iter().enumerate() {
        let r = sets.root(i);
        let g = *index_of_root.entry(r).or_insert_with(|| {
            groups.push(Vec::new());
            groups.len() - 1
        });
        groups[g].push(t);
    }
    groups
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::{Choice, Emitter, Kind};

    /// A 0.2 m square lamp at height 1 facing down (−y), of unit power per m².
    fn lamp(two_sided: bool) -> Emitter {
        let corner = Vec3::new(-0.1, 1.0, -0.1);
        let (u, v) = (Vec3::new(0.2, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.2));
        Emitter {
            kind: Kind::Quad(0),
            power: 0.04,
            centre: corner + 0.5 * (u + v),
            radius2: 0.25 * (u + v).length_squared(),
            hull: vec![corner, corner + u, corner + u + v, corner + v],
            facing: Some((Vec3::NEG_Y, two_sided)),
            aim: corner + 0.5 * (u + v),
        }
    }

    #[test]
    fn an_emitter_that_cannot_light_a_point_weighs_nothing_and_every_other_does() {
        let l = lamp(false);
        let w = |at: Vec3, n: Vec3| l.weight(at, n, &[at]);
        // Below, facing up: lit.
        assert!(w(Vec3::ZERO, Vec3::Y) > 0.0);
        // Facing down: the lamp is wholly below the point's plane.
        assert_eq!(w(Vec3::ZERO, Vec3::NEG_Y), 0.0);
        // Above the lamp: behind its one emitting side.
        assert_eq!(w(Vec3::new(0.0, 2.0, 0.0), Vec3::NEG_Y), 0.0);
        // A wall beside the lamp that sees only one corner's edge still gets samples.
        let side = Vec3::new(0.5, 0.5, 0.0);
        assert!(w(side, Vec3::new(-1.0, 1.0, 0.0).normalize()) > 0.0);
        // Grazing: in the lamp's plane nothing arrives; just below it, something does.
        assert_eq!(w(Vec3::new(0.5, 1.0, 0.0), Vec3::NEG_X), 0.0);
        assert!(w(Vec3::new(0.5, 0.999, 0.0), Vec3::NEG_X) > 0.0);
        // A two-sided lamp lights the point above it too.
        let both = lamp(true);
        assert!(
            both.weight(
                Vec3::new(0.0, 2.0, 0.0),
                Vec3::NEG_Y,
                &[Vec3::new(0.0, 2.0, 0.0)]
            ) > 0.0
        );
        // Nearer weighs more (distance² + radius²).
        assert!(w(Vec3::new(0.0, 0.5, 0.0), Vec3::Y) > 3.0 * w(Vec3::ZERO, Vec3::Y));
        // A mirror's corners: one in front of the lamp's side is enough.
        let behind = Vec3::new(0.0, 1.5, 0.0);
        assert_eq!(l.weight(behind, Vec3::NEG_Y, &[behind]), 0.0);
        assert!(l.weight(behind, Vec3::NEG_Y, &[behind, Vec3::new(3.0, 0.5, 0.0)]) > 0.0);
    }

    #[test]
    fn a_choice_picks_each_emitter_as_often_as_its_probability_says() {
        let c = Choice {
            cdf: vec![1.0, 1.0, 4.0, 8.0],
        };
        let probs: Vec<f32> = (0..4).map(|k| c.prob(k)).collect();
        assert_eq!(probs, [0.125, 0.0, 0.375, 0.5]);
        let n = 8000;
        let mut count = [0u32; 4];
        for i in 0..n {
            let (k, p) = c.pick((i as f32 + 0.5) / n as f32);
            assert_eq!(p, probs[k]);
            count[k] += 1;
        }
        assert_eq!(count, [1000, 0, 3000, 4000]);
        assert!(
            Choice {
                cdf: vec![0.0, 0.0]
            }
            .is_empty()
        );
    }

    #[test]
    fn an_elements_blocked_emitters_keep_a_floor_of_their_weight() {
        use super::{ManyLights, UNSEEN};
        // Two equal lamps side by side above the origin and a faint one far off.
        let at = |x: f32| {
            let mut l = lamp(false);
            for p in l.hull.iter_mut().chain([&mut l.centre, &mut l.aim]) {
                p.x += x;
            }
            l
        };
        let mut faint = at(10.0);
        faint.power *= 0.05;
        let many = ManyLights {
            emitters: vec![at(-0.2), at(0.2), faint],
            group_of: Vec::new(),
        };
        let open = many.choose(Vec3::ZERO, Vec3::Y);
        let (p0, p1) = (open.prob(0), open.prob(1));
        assert!(
            (p0 - p1).abs() < 1e-6 && open.prob(2) > 0.0,
            "{p0} {p1} {}",
            open.prob(2)
        );

        // Lamp 1 wholly blocked, lamp 0 clear: lamp 1 keeps UNSEEN of its weight; the faint
        // lamp (under the tested share) is not tested. A quad has five test points.
        let mut asked = Vec::new();
        let c = many.choose_seeing(Vec3::ZERO, Vec3::Y, |q| {
            asked.push(q);
            q.x < 0.0
        });
        assert_eq!(asked.len(), 10);
        assert!(asked.iter().all(|q| q.x.abs() < 1.0));
        assert!((c.prob(1) / c.prob(0) - UNSEEN).abs() < 1e-5);
        assert!(c.prob(2) > 0.0);

        // Two of lamp 1's five test points clear (the corners on its far side): its weight
        // falls between.
        let c = many.choose_seeing(Vec3::ZERO, Vec3::Y, |q| q.x < 0.0 || q.x > 0.25);
        let r = c.prob(1) / c.prob(0);
        let expected = UNSEEN + (1.0 - UNSEEN) * 2.0 / 5.0;
        assert!((r - expected).abs() < 1e-5, "{r} vs {expected}");

        // Nothing clear: the tested lamps are scaled alike, and the untested faint one, which
        // may be all the point sees, gains.
        let c = many.choose_seeing(Vec3::ZERO, Vec3::Y, |_| false);
        assert!((c.prob(0) - c.prob(1)).abs() < 1e-6);
        assert!(c.prob(2) > 10.0 * open.prob(2));
    }
}
