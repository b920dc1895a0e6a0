//! One element's gathering: its direct light (emitters sampled, MIS with the gathering rays),
//! the texels its cosine-distributed rays land on, the glossy paths they continue into
//! ([`super::transport`]), and the sample statistics its error estimate needs. Each ray draws
//! from its own random stream and is summed into its element in one place ([`assemble`]), so
//! that rays can be kept from an earlier bake ([`super::ray_cache`]).

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use super::atlas::{Atlas, TexelSample};
use super::emitters::{Emitters, luminance, power, spread_var_of_mean, var_of_mean};
use super::many_lights::{Choice, LIGHTS_SAMPLED_EACH, ManyLights, short_of_surface};
use super::mirror_lights::MirrorLights;
use super::next_event::{Arrival, At, NextEvent, Receiver, Source};
use super::ray_cache::{KeptBatch, LightPart, RayRecord};
use super::through_glass::{GatherCx, RayMis, RayOut, gather_ray};
use super::transmission::{Glass, drawn_visible, shadow};
use super::transport::{Glossy, Term};
use crate::geometry::Bvh;
use crate::sampling::{Rng, basis, r2, sample_cosine_hemisphere};
use crate::scene::Scene;

/// A sample is inside geometry when more than this fraction of its gathering rays hit back
/// faces (a floor texel under a wall sees the wall's inner faces) and fewer than
/// [`OPEN_LIMIT`] reach open space.
pub const BACKFACE_LIMIT: f32 = 0.25;

/// A sample whose gathering rays reach open space (a front face) at least this fraction of
/// the time, and whose nearest back face is at least half a texel away, is not inside
/// anything, however many back faces it sees. A wall behind a one-sided panel sees the
/// panel's back over most of its hemisphere, yet near the panel's rim it sees the room
/// through the gap: its light is its own (the panel's shadow), not the lit wall's beside
/// the panel. Where the gap is under half a texel, though, the texel cannot resolve the
/// shadow: its darkness would spread a texel or two over the lit wall beside the panel, so it
/// is filled from its neighbours (docs/tuning.md#open-limit). A sample inside a closed solid
/// sees no front face.
/// Misses do not count: below a floor, a box's face sees the floor's back and the void, and
/// is as hidden as one inside.
pub const OPEN_LIMIT: f32 = 0.25;

/// What gathering needs, shared by every element.
pub(super) struct Context<'a> {
    pub scene: &'a Scene,
    pub bvh: &'a Bvh,
    pub atlas: &'a Atlas,
    pub offsets: &'a [u32],
    /// Every triangle's face normal, kept: every gathering ray's hit reads one.
    pub normals: &'a [Vec3],
    pub emitters: &'a Emitters,
    pub glossy: Option<Glossy<'a>>,
    /// Emitters' images in near-mirror planar reflectors.
    pub mirrors: Option<&'a MirrorLights>,
    /// The emitters as one per-point distribution, when there are too many to sample each.
    pub many: Option<&'a ManyLights>,
    /// The scene's glass ([`Glass::of`]), which gathering and shadow rays pass.
    pub glass: Option<Glass<'a>>,
}

impl Context<'_> {
    fn next_event(&self) -> NextEvent<'_> {
        NextEvent {
            scene: self.scene,
            bvh: self.bvh,
            emitters: self.emitters,
            glass: self.glass,
        }
    }
}

/// Sums of one element's samples, for the variance of its estimate (luminance).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Moments {
    /// Variance of the emitter samples' part of `emitted` (of the mean).
    pub light_var: f64,
    /// Σ and Σ² over rays of the radiance each ray brings back that is not a texel's reflected
    /// radiance (emission hit, light through glossy paths).
    pub ray_const: f64,
    pub ray_const2: f64,
}

/// What an element's gathering found.
pub(super) struct Gathered {
    /// Irradiance / π straight from the emitters: their samples (and their images in
    /// mirrors) and the emission the gathering rays hit, MIS-weighted against each other.
    pub emitted: Vec3,
    /// Irradiance / π the gathering rays bring back through glossy reflection (besides
    /// `terms`). With `emitted`, the direct light: L_r = ρ · (direct + mean incoming L_r).
    pub glossy: Vec3,
    /// Gathering rays cast (the length of `hits` as gathered).
    pub gathering_rays: u32,
    /// Per ray, the atlas texel hit on a front face (u32::MAX: miss or back face). The solve
    /// moves them into its resolved links and leaves this empty.
    pub hits: Vec<u32>,
    /// Texels reached through glossy reflection, with their weights (summed over the rays
    /// like `hits`; moved out like them).
    pub terms: Vec<Term>,
    pub inside: bool,
    /// Rays cast (gathering, shadow, glossy).
    pub rays: u64,
    /// The shadow rays among `rays`: those of the emitter samples and the mirror images.
    pub light_rays: u64,
    /// Emitter samples per light.
    pub light_samples: u32,
    pub moments: Moments,
}

impl Gathered {
    /// The direct light: irradiance / π from the emitters, straight or through glossy paths.
    pub fn direct(&self) -> Vec3 {
        self.emitted + self.glossy
    }

    /// Adds another batch of the same element's samples. Each batch's estimates are unbiased
    /// by themselves, and a refinement batch may hold emitter samples and rays in another
    /// ratio than the first, so each part is averaged with weights fixed by its own counts:
    /// `emitted` by the batches' emitter samples (in a batch they are MIS-weighted against
    /// its rays, so that batch's sum is what is unbiased, and it takes one weight), `glossy`
    /// by their gathering rays. The batches' `hits` and `terms` are the caller's to keep (the
    /// solve's links hold them).
    pub fn merge(&mut self, other: &Gathered) {
        let mix = |a: Vec3, b: Vec3, n1: f64, n2: f64| {
            let n = n1 + n2;
            if n == 0.0 {
                return a;
            }
            let m = |a: f32, b: f32| ((a as f64 * n1 + b as f64 * n2) / n) as f32;
            Vec3::new(m(a.x, b.x), m(a.y, b.y), m(a.z, b.z))
        };
        let (l1, l2) = (self.light_samples as f64, other.light_samples as f64);
        let (r1, r2) = (self.gathering_rays as f64, other.gathering_rays as f64);
        self.emitted = mix(self.emitted, other.emitted, l1, l2);
        self.glossy = mix(self.glossy, other.glossy, r1, r2);
        let l = l1 + l2;
        if l > 0.0 {
            self.moments.light_var =
                (l1 * l1 * self.moments.light_var + l2 * l2 * other.moments.light_var) / (l * l);
        }
        self.moments.ray_const += other.moments.ray_const;
        self.moments.ray_const2 += other.moments.ray_const2;
        self.gathering_rays += other.gathering_rays;
        self.rays += other.rays;
        self.light_rays += other.light_rays;
        self.light_samples += other.light_samples;
    }
}

/// Where an element's gathering rays come from: points `first`.. of its shifted R2 sequence
/// (the same shift in every batch, so the batches together are one prefix of it).
#[derive(Clone, Copy, Debug)]
pub(super) struct RaySequence {
    pub first: u32,
    pub shift: Vec2,
}

/// Mixed into the bake's seed for the gathering rays' own streams ([`ray_rng`]), so that they
/// never share a generator with an element's light samples.
const RAY_SEED_MIX: u64 = 0x9e37_79b9_7f4a_7c15;

/// The random stream of ray `ray` (its index in the element's sequence, over every batch) of
/// element `element`: each ray draws its glossy path from its own stream, so a ray whose path
/// changes moves no other ray's draws and can be followed again alone.
pub(super) fn ray_rng(seed: u64, element: u32, ray: u32) -> Rng {
    Rng::new(
        seed ^ RAY_SEED_MIX,
        (u64::from(element) << 32) | u64::from(ray),
    )
}

/// The per-element setup every gathering ray of one element shares.
pub(super) struct Element<'a> {
    /// The element's index (its rays' streams).
    pub index: u32,
    origin: Vec3,
    ng: Vec3,
    ns: Vec3,
    t: Vec3,
    b: Vec3,
    many: Option<(&'a ManyLights, Choice)>,
}

impl<'a> Element<'a> {
    /// Element `index`, at sample `s`.
    pub fn new(cx: &Context<'a>, s: &TexelSample, index: u32) -> Element<'a> {
        let tri = &cx.scene.triangles[s.triangle as usize];
        let ng = tri.face_normal();
        let ns = tri.shading_normal(s.bary);
        let origin = cx.bvh.offset_origin(tri.point(s.bary), ng);
        let (t, b) = basis(ns);
        let many = cx.many.map(|m| {
            // Clear to a point on an emitter: a shadow ray stopping short of it, as an emitter
            // sample's does (through glass too).
            let sees = |q: Vec3| {
                let w = q - origin;
                let dist = w.length();
                let reach = short_of_surface(cx.bvh, dist);
                dist <= 0.0 || shadow(cx.glass.as_ref(), cx.bvh, origin, w / dist, reach).is_some()
            };
            (m, m.choose_seeing(origin, ns, sees))
        });
        Element {
            index,
            origin,
            ng,
            ns,
            t,
            b,
            many,
        }
    }
}

/// What a ray's first hit says about whether its element lies inside geometry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Facing {
    /// A back face, at this distance.
    Back(f32),
    /// Open space: a front face.
    Open,
    /// A miss, or a ray below the surface.
    Neither,
}

/// Follows ray `k` of `seq` (of a batch of `n_rays` rays and `n_light` emitter samples) from
/// element `el`, drawing from the ray's own stream of `seed`: pushes its glossy terms to
/// `terms` and returns its record.
#[allow(clippy::too_many_arguments)]
pub(super) fn trace_ray(
    cx: &Context,
    el: &Element,
    seed: u64,
    seq: RaySequence,
    k: u32,
    n_rays: u32,
    n_light: u32,
    terms: &mut Vec<Term>,
) -> (RayRecord, Facing) {
    let (scene, bvh) = (cx.scene, cx.bvh);
    let index = seq.first + k;
    let l = sample_cosine_hemisphere(r2(index, seq.shift));
    let d = el.t * l.x + el.b * l.y + el.ns * l.z;
    let mut rec = RayRecord {
        hit: u32::MAX,
        rays: 1,
        ..Default::default()
    };
    if d.dot(el.ng) <= 0.0 {
        return (rec, Facing::Neither);
    }
    let from = terms.len();
    let mut rays = 1u64;
    let mut rng = ray_rng(seed, el.index, index);
    let hit = bvh.closest_hit(el.origin, d, f32::INFINITY);
    let facing = if let Some(h) = hit
        && let Some(glass) = cx.glass.filter(|g| g.passes(h.triangle))
    {
        let gcx = GatherCx {
            glass,
            atlas: cx.atlas,
            offsets: cx.offsets,
            emitters: cx.emitters,
            glossy: cx.glossy.as_ref(),
        };
        let mis = RayMis {
            n_rays,
            p_bsdf: l.z / PI,
            n_light,
            many: &el.many,
        };
        let mut hits = Vec::with_capacity(1);
        let mut out = RayOut {
            hits: &mut hits,
            terms,
            emission: &mut rec.emission,
            via_glossy: &mut rec.glossy,
            rays: &mut rays,
            lobes_read: &mut rec.lobes_read,
            weighted: &mut rec.weighted,
        };
        gather_ray(&gcx, el.origin, d, h, &mis, &mut rng, &mut out);
        rec.hit = hits.first().copied().unwrap_or(u32::MAX);
        Facing::Open
    } else {
        match hit {
            Some(h) => {
                let ht = &scene.triangles[h.triangle as usize];
                let cos_l = -d.dot(cx.normals[h.triangle as usize]);
                if cos_l <= 0.0 {
                    // A double-sided surface's back reflects with its back side's texel
                    // (the front's, for a sheet whose back shares them).
                    if scene.material_of(h.triangle).double_sided {
                        let (t, b) = cx.atlas.side(h.triangle, h.bary, true);
                        rec.hit = cx.atlas.texel_at(cx.offsets, t, b);
                    }
                    Facing::Back(h.t)
                } else {
                    let e = scene.materials[ht.material as usize].emission;
                    if e.max_element() > 0.0 {
                        let pdf_e = e;
                        let e = scene.emission_at(h.triangle, h.bary);
                        // MIS against explicit emitter sampling (solid-angle densities).
                        let (area_pdf, n_e) = match &el.many {
                            None => (cx.emitters.area_pdf(pdf_e), n_light),
                            Some((m, choice)) => {
                                let k = m.emitter_of(h.triangle);
                                (
                                    choice.prob(k) * m.area_pdf_in_group(k, pdf_e),
                                    n_light * LIGHTS_SAMPLED_EACH as u32,
                                )
                            }
                        };
                        let p_light = area_pdf * h.t * h.t / cos_l;
                        let p_bsdf = l.z / PI;
                        let w = power(n_rays as f32, p_bsdf, n_e as f32, p_light);
                        // Irradiance/π from this ray: L · (cos/p_bsdf)/π/N = L/N.
                        rec.emission = e * w;
                        rec.weighted = true;
                    }
                    rec.hit = cx.atlas.texel_at(cx.offsets, h.triangle, h.bary);
                    if let Some(g) = &cx.glossy
                        && g.reflects(h.triangle)
                    {
                        rec.glossy =
                            g.follow(h, d, &mut rng, terms, &mut rays, &mut rec.lobes_read);
                    }
                    Facing::Open
                }
            }
            None => Facing::Neither,
        }
    };
    rec.rays = rays as u32;
    rec.terms = (terms.len() - from) as u32;
    (rec, facing)
}

/// Whether an element lies inside geometry, from its first batch's rays' [`Facing`]s.
#[derive(Clone, Copy, Debug)]
pub(super) struct Exposure {
    backfaces: u32,
    open: u32,
    nearest_back: f32,
}

impl Default for Exposure {
    fn default() -> Self {
        Exposure {
            backfaces: 0,
            open: 0,
            nearest_back: f32::INFINITY,
        }
    }
}

impl Exposure {
    pub fn add(&mut self, f: Facing) {
        match f {
            Facing::Back(t) => {
                self.backfaces += 1;
                self.nearest_back = self.nearest_back.min(t);
            }
            Facing::Open => self.open += 1,
            Facing::Neither => {}
        }
    }

    /// [`BACKFACE_LIMIT`], [`OPEN_LIMIT`] over `n_rays` rays at sample `s`.
    pub fn inside(&self, cx: &Context, s: &TexelSample, n_rays: u32) -> bool {
        let tri = &cx.scene.triangles[s.triangle as usize];
        self.backfaces as f32 > BACKFACE_LIMIT * n_rays as f32
            && ((self.open as f32) < OPEN_LIMIT * n_rays as f32
                || self.nearest_back < 0.5 * cx.atlas.texel_spacing(s.triangle, tri))
    }
}

/// The element's emitter samples: `n_light` per emitter (or drawn from its many-lights
/// choice), then the emitters' images in mirrors, MIS-weighted against `n_rays` gathering
/// rays, from `rng`.
pub(super) fn sample_lights(
    cx: &Context,
    el: &Element,
    rng: &mut Rng,
    n_rays: u32,
    n_light: u32,
) -> LightPart {
    let mut part = LightPart::default();
    match &el.many {
        Some((m, choice)) => {
            let n_many = n_light * LIGHTS_SAMPLED_EACH as u32;
            let (light, var) = sample_many(
                cx,
                m,
                choice,
                el.origin,
                el.ns,
                el.ng,
                rng,
                n_many,
                n_rays,
                &mut part.rays,
            );
            part.direct += light;
            part.var += var;
        }
        None => {
            let at = At {
                from: el.origin,
                origin: el.origin,
                ng: el.ng,
            };
            let mut irradiance =
                Irradiance::new(el.ns, n_light, n_rays, &mut part.direct, &mut part.var);
            cx.next_event()
                .estimate(&at, n_light, rng, &mut part.rays, &mut irradiance);
        }
    }
    // The emitters' images in mirrors.
    if let Some(m) = cx.mirrors {
        let (light, var) = m.direct(
            cx.scene,
            cx.bvh,
            cx.emitters,
            cx.many,
            el.origin,
            el.ns,
            el.ng,
            rng,
            n_light,
            &mut part.rays,
        );
        part.direct += light;
        part.var += var;
    }
    part
}

/// An element's gathering from its rays' records (in ray order, with their terms in the same
/// order) and its emitter samples: the one place rays are summed, so that rays kept from an
/// earlier bake and rays followed now give the bytes of a full gathering.
pub(super) fn assemble(
    records: &[RayRecord],
    terms: Vec<Term>,
    lights: &LightPart,
    inside: bool,
    n_light: u32,
) -> Gathered {
    let n_rays = records.len() as u32;
    let n = n_rays.max(1) as f32;
    let mut emitted = Vec3::ZERO;
    // Radiance the rays bring back through glossy reflection (besides `terms`).
    let mut via_glossy = Vec3::ZERO;
    let mut moments = Moments::default();
    let mut rays = 0u64;
    let mut hits = Vec::with_capacity(records.len());
    for r in records {
        hits.push(r.hit);
        emitted += r.emission / n;
        via_glossy += r.glossy;
        let c = luminance(r.emission) as f64 + luminance(r.glossy) as f64;
        moments.ray_const += c;
        moments.ray_const2 += c * c;
        rays += u64::from(r.rays);
    }
    // Mean incoming radiance over the cosine-distributed rays is irradiance/π.
    let glossy = via_glossy / n;
    emitted += lights.direct;
    moments.light_var += lights.var;
    rays += lights.rays;
    let mut terms = terms;
    // Held until the solve packs them: no growth slack.
    terms.shrink_to_fit();
    Gathered {
        emitted,
        glossy,
        gathering_rays: n_rays,
        hits,
        terms,
        inside,
        rays,
        light_rays: lights.rays,
        light_samples: n_light,
        moments,
    }
}

/// An earlier bake's batches of one element ([`super::ray_cache`]) and the materials whose
/// lobes changed since (bits `material % 64`).
#[derive(Clone, Copy)]
pub(super) struct Prior<'a> {
    pub batches: &'a [KeptBatch],
    pub changed: u64,
}

/// What gathering one batch of an element gives.
pub(super) struct GatherOut {
    pub gathered: Gathered,
    /// The batch as the ray cache keeps it (when asked).
    pub kept: Option<KeptBatch>,
    /// Rays kept from the prior bake rather than followed.
    pub reused: u32,
}

/// A prior batch unpacked, with where each ray's terms start.
struct Unpacked<'a> {
    batch: &'a KeptBatch,
    records: Vec<RayRecord>,
    terms: Vec<Term>,
    term_at: Vec<usize>,
}

/// Gathers element `index` at sample `s` in refinement round `round` (0: the first batch)
/// with `n_rays` cosine-distributed rays (directions from `seq`, each ray's glossy path from
/// its own stream of `seed`) and `n_light` samples per emitter, drawn from `rng` (the
/// element's stream of the round). With `prior`, the rays of an earlier bake whose paths read
/// no changed lobes are kept rather than followed (module [`super::ray_cache`]); `keep`
/// returns the batch as the ray cache keeps it.
#[allow(clippy::too_many_arguments)]
pub(super) fn gather(
    cx: &Context,
    s: &TexelSample,
    index: u32,
    seed: u64,
    round: u32,
    rng: &mut Rng,
    seq: RaySequence,
    n_rays: u32,
    n_light: u32,
    prior: Option<Prior>,
    keep: bool,
) -> GatherOut {
    let n_rays = n_rays.max(1);
    let n_light = n_light.max(1);
    let el = Element::new(cx, s, index);
    let batches = prior.map_or(&[][..], |p| p.batches);
    let changed = prior.map_or(0, |p| p.changed);
    // The first batch's rays also say whether the element is inside geometry: its rays are
    // kept only when the prior first batch is this one (a ray's facing reads no lobe).
    let same_first = batches
        .iter()
        .find(|b| b.round == 0)
        .filter(|b| b.first == seq.first && b.n_rays == n_rays);
    let usable = round != 0 || same_first.is_some();
    let end = seq.first + n_rays;
    let unpacked: Vec<Unpacked> = batches
        .iter()
        .filter(|b| usable && b.first < end && seq.first < b.first + b.n_rays)
        .filter_map(|b| {
            let (records, terms) = b.unpack()?;
            let mut term_at = Vec::with_capacity(records.len() + 1);
            term_at.push(0);
            for r in &records {
                term_at.push(term_at.last().copied().unwrap_or(0) + r.terms as usize);
            }
            (term_at.last() == Some(&terms.len())).then_some(Unpacked {
                batch: b,
                records,
                terms,
                term_at,
            })
        })
        .collect();

    // Gathering rays (cosine-distributed about the shading normal), from a low-discrepancy
    // sequence: the incoming radiance is smooth over most of the hemisphere.
    let mut records = Vec::with_capacity(n_rays as usize);
    let mut terms = Vec::new();
    let mut exposure = Exposure::default();
    let mut reused = 0u32;
    // The prior batch every ray was kept from, while there is one.
    let mut source = unpacked.first().map(|_| 0usize);
    for k in 0..n_rays {
        let j = seq.first + k;
        let old = unpacked.iter().enumerate().find_map(|(i, u)| {
            let at = j.checked_sub(u.batch.first)? as usize;
            let r = u.records.get(at)?;
            let counts_same = u.batch.n_rays == n_rays && u.batch.n_light == n_light;
            (r.lobes_read & changed == 0 && (!r.weighted || counts_same))
                .then(|| (i, r, &u.terms[u.term_at[at]..u.term_at[at + 1]]))
        });
        match old {
            Some((i, r, t)) => {
                records.push(*r);
                terms.extend_from_slice(t);
                reused += 1;
                source = source.filter(|&s| s == i);
            }
            None => {
                let (rec, facing) = trace_ray(cx, &el, seed, seq, k, n_rays, n_light, &mut terms);
                records.push(rec);
                exposure.add(facing);
                source = None;
            }
        }
    }
    // Every ray kept, in order, from one prior batch of the same rays: its packed bytes are
    // what packing them again gives.
    let same_rays = source
        .map(|i| unpacked[i].batch)
        .filter(|b| b.first == seq.first && b.n_rays == n_rays);
    let lights = batches
        .iter()
        .find(|b| {
            b.round == round && b.first == seq.first && b.n_rays == n_rays && b.n_light == n_light
        })
        .map_or_else(
            || sample_lights(cx, &el, rng, n_rays, n_light),
            |b| b.lights,
        );
    // A refinement batch's own inside flag is not read (an element's is its first batch's).
    let inside = match (round, same_first) {
        (0, Some(b)) => b.inside,
        (0, None) => exposure.inside(cx, s, n_rays),
        _ => false,
    };
    let kept = keep.then(|| KeptBatch {
        round,
        first: seq.first,
        n_rays,
        n_light,
        inside,
        lights,
        rays: same_rays.map_or_else(|| KeptBatch::pack(&records, &terms), |b| b.rays.clone()),
    });
    GatherOut {
        gathered: assemble(&records, terms, &lights, inside, n_light),
        kept,
        reused,
    }
}

/// Irradiance/π at a point with shading normal `ns`, from [`NextEvent::estimate`]'s `n_light`
/// points per emitter, added to `direct` emitter by emitter with its variance (luminance)
/// added to `var`. Emissive triangles are MIS-weighted against `n_rays` cosine-distributed
/// gathering rays; area lights, which are not geometry, are found by light samples only.
struct Irradiance<'a> {
    ns: Vec3,
    n_light: u32,
    n_rays: u32,
    direct: &'a mut Vec3,
    var: &'a mut f64,
    /// The current emitter's Σ of samples, and Σ, Σ² of their luminance.
    sum: Vec3,
    y: f64,
    y2: f64,
}

impl<'a> Irradiance<'a> {
    fn new(ns: Vec3, n_light: u32, n_rays: u32, direct: &'a mut Vec3, var: &'a mut f64) -> Self {
        Irradiance {
            ns,
            n_light,
            n_rays,
            direct,
            var,
            sum: Vec3::ZERO,
            y: 0.0,
            y2: 0.0,
        }
    }
}

impl Receiver for Irradiance<'_> {
    /// cos θ at the receiver.
    type Toward = f32;

    fn toward(&self, d: Vec3) -> Option<f32> {
        let cos_s = d.dot(self.ns);
        (cos_s > 0.0).then_some(cos_s)
    }

    fn add(&mut self, source: Source, a: &Arrival, cos_s: f32) {
        let (c, v) = match source {
            Source::Quad(light) => {
                let c = a.radiance * (cos_s * a.cos_l / a.dist2);
                (c, luminance(c) as f64 * (light.area / PI) as f64)
            }
            Source::Triangles => {
                let p_bsdf = cos_s / PI;
                let wgt = power(self.n_light as f32, a.p_light, self.n_rays as f32, p_bsdf);
                let c = a.radiance * (wgt * cos_s / a.p_light);
                (c, luminance(c) as f64 / PI as f64)
            }
        };
        self.sum += c;
        self.y += v;
        self.y2 += v * v;
    }

    fn end(&mut self, source: Source, n: u32) {
        *self.direct += match source {
            Source::Quad(light) => self.sum * (light.area / n as f32) / PI,
            Source::Triangles => self.sum / (n as f32 * PI),
        };
        *self.var += match source {
            Source::Quad(_) => var_of_mean(self.y, self.y2, n),
            // One low-discrepancy set (`NextEvent::estimate`).
            Source::Triangles => spread_var_of_mean(self.y, self.y2, n),
        };
        (self.sum, self.y, self.y2) = (Vec3::ZERO, 0.0, 0.0);
    }
}

/// Irradiance/π at a point from `n` samples of the emitters drawn from `choice` (stratified
/// in the choice's variable), MIS-weighted against `n_rays` cosine-distributed gathering rays
/// for emissive triangles; returns it with its variance (luminance) and counts the rays cast.
#[allow(clippy::too_many_arguments)]
fn sample_many(
    cx: &Context,
    many: &ManyLights,
    choice: &Choice,
    origin: Vec3,
    ns: Vec3,
    ng: Vec3,
    rng: &mut Rng,
    n: u32,
    n_rays: u32,
    rays: &mut u64,
) -> (Vec3, f64) {
    if choice.is_empty() {
        return (Vec3::ZERO, 0.0);
    }
    let (scene, bvh) = (cx.scene, cx.bvh);
    let glass = cx.glass;
    let mut sum = Vec3::ZERO;
    let (mut y, mut y2) = (0.0f64, 0.0f64);
    for k in 0..n {
        let u = (k as f32 + rng.uniform()) / n as f32;
        let Some(dr) = many.draw_towards(scene, choice, u, origin, rng) else {
            continue;
        };
        let cos_s = dr.d.dot(ns);
        if cos_s <= 0.0 || dr.d.dot(ng) <= 0.0 {
            continue;
        }
        let Some(tr) = drawn_visible(glass.as_ref(), bvh, &dr, origin, rays) else {
            continue;
        };
        let p_light = dr.p_light;
        // Gathering rays find emissive triangles too; area lights are not geometry.
        let wgt = match dr.point.triangle {
            None => 1.0,
            Some(_) => power(n as f32, p_light, n_rays as f32, cos_s / PI),
        };
        let c = dr.point.radiance * tr * (wgt * cos_s / p_light);
        sum += c;
        let v = luminance(c) as f64 / PI as f64;
        y += v;
        y2 += v * v;
    }
    (sum / (n as f32 * PI), var_of_mean(y, y2, n))
}
