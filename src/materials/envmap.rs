//! Environment maps for glossy curved objects (Luksch et al. §3): a cube map captured at the
//! object's centroid by ray casting, MIP pyramids built with a box 2×2, Gauss 4×4 or
//! Gauss 6×6 filter (Table 1), trilinear lookups, and the three estimators of a lobe's
//! reflected radiance that §8 compares (regular patterns, filtered importance sampling, and a
//! many-sample reference).
//!
//! # Cube-map conventions
//!
//! Faces in the order +X, −X, +Y, −Y, +Z, −Z, each `size`×`size` texels, row 0 at the top,
//! with the OpenGL/Vulkan/WebGPU orientation: for face coordinates s, t ∈ [−1, 1] (texel
//! (x, y) centre: s = 2(x+½)/size − 1, t = 2(y+½)/size − 1) the directions are
//! +X (1, −t, −s), −X (−1, −t, s), +Y (s, 1, t), −Y (s, −1, −t), +Z (s, −t, 1),
//! −Z (−s, −t, −1). Stored as a horizontal strip of the six faces (6·size × size).

use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;

use super::capture_reads as rec;
use crate::brdf::pattern::{Pattern, lobe_area_for, mip_level};
use crate::brdf::{Frame, Lobe, above, reflect};
use crate::geometry::{Bvh, Hit};
use crate::progress::{Cancelled, Progress};
use crate::radiance::reads::{MapReads, Replay};
use crate::radiosity::MAX_GLASS_LAYERS;
use crate::radiosity::sides::Sides;
use crate::sampling::Rng;
use crate::scene::{ReflectorKind, Scene};

/// The capture point of a reflector's environment map: the area-weighted centroid of its
/// triangles (f64 sums), where the materials stage captures and the viewer renders the cube.
pub fn capture_centre(scene: &Scene, triangles: &[u32]) -> Vec3 {
    let (mut sum, mut area) = (DVec3::ZERO, 0.0f64);
    for &t in triangles {
        let tri = &scene.triangles[t as usize];
        let a = tri.area() as f64;
        sum += (tri.p[0] + tri.p[1] + tri.p[2]).as_dvec3() * (a / 3.0);
        area += a;
    }
    if area > 0.0 {
        (sum / area).as_vec3()
    } else {
        Vec3::ZERO
    }
}

/// Face names in storage order.
pub const FACE_NAMES: [&str; 6] = ["+x", "-x", "+y", "-y", "+z", "-z"];

/// The (unnormalized) direction of face coordinates (s, t) on `face` (s, t may leave
/// [−1, 1]: the point then lies on the face's plane beyond its edge).
pub fn face_direction(face: usize, s: f32, t: f32) -> Vec3 {
    match face {
        0 => Vec3::new(1.0, -t, -s),
        1 => Vec3::new(-1.0, -t, s),
        2 => Vec3::new(s, 1.0, t),
        3 => Vec3::new(s, -1.0, -t),
        4 => Vec3::new(s, -t, 1.0),
        _ => Vec3::new(-s, -t, -1.0),
    }
}

/// The face and face coordinates (s, t) ∈ [−1, 1]² a direction points through.
/// Ties between axes go to x, then y (deterministic on edges and corners).
pub fn locate(d: Vec3) -> (usize, f32, f32) {
    let a = d.abs();
    if a.x >= a.y && a.x >= a.z {
        let m = a.x.max(f32::MIN_POSITIVE);
        if d.x >= 0.0 {
            (0, -d.z / m, -d.y / m)
        } else {
            (1, d.z / m, -d.y / m)
        }
    } else if a.y >= a.z {
        let m = a.y;
        if d.y >= 0.0 {
            (2, d.x / m, d.z / m)
        } else {
            (3, d.x / m, -d.z / m)
        }
    } else {
        let m = a.z;
        if d.z >= 0.0 {
            (4, d.x / m, -d.y / m)
        } else {
            (5, -d.x / m, -d.y / m)
        }
    }
}

/// A cube map of linear RGB radiance.
#[derive(Clone, Debug, PartialEq)]
pub struct CubeMap {
    /// Texels per face edge.
    pub size: usize,
    /// 6 faces × size² texels, face-major, each face row-major.
    pub texels: Vec<Vec3>,
}

impl CubeMap {
    /// A black cube map.
    pub fn new(size: usize) -> CubeMap {
        let size = size.max(1);
        CubeMap {
            size,
            texels: vec![Vec3::ZERO; 6 * size * size],
        }
    }

    /// A cube map holding `f(direction)` at every texel centre.
    pub fn from_fn(size: usize, f: impl Fn(Vec3) -> Vec3 + Sync) -> CubeMap {
        let size = size.max(1);
        let texels = (0..6 * size * size)
            .into_par_iter()
            .map(|i| {
                let (face, rem) = (i / (size * size), i % (size * size));
                f(texel_direction(size, face, rem % size, rem / size))
            })
            .collect();
        CubeMap { size, texels }
    }

    /// Index of texel (x, y) of `face`.
    pub fn index(&self, face: usize, x: usize, y: usize) -> usize {
        (face * self.size + y) * self.size + x
    }

    /// One face's texels.
    pub fn face(&self, face: usize) -> &[Vec3] {
        let n = self.size * self.size;
        &self.texels[face * n..(face + 1) * n]
    }

    /// The texel at integer coordinates that may lie beyond the face's edges: those are
    /// found on the neighbouring faces through their direction (for filters near edges).
    pub fn fetch_extended(&self, face: usize, x: i64, y: i64) -> Vec3 {
        let n = self.size as i64;
        if (0..n).contains(&x) && (0..n).contains(&y) {
            return self.texels[self.index(face, x as usize, y as usize)];
        }
        let s = 2.0 * (x as f32 + 0.5) / n as f32 - 1.0;
        let t = 2.0 * (y as f32 + 0.5) / n as f32 - 1.0;
        let (f, s, t) = locate(face_direction(face, s, t));
        let tx = (((s + 1.0) * 0.5 * n as f32) as i64).clamp(0, n - 1) as usize;
        let ty = (((t + 1.0) * 0.5 * n as f32) as i64).clamp(0, n - 1) as usize;
        self.texels[self.index(f, tx, ty)]
    }

    /// Bilinear lookup in the face `d` points through (clamped at the face's edges).
    pub fn bilinear(&self, d: Vec3) -> Vec3 {
        let (face, s, t) = locate(d);
        let n = self.size as f32;
        let u = ((s + 1.0) * 0.5 * n - 0.5).clamp(0.0, n - 1.0);
        let v = ((t + 1.0) * 0.5 * n - 0.5).clamp(0.0, n - 1.0);
        let (x0, y0) = (u as usize, v as usize);
        let (x1, y1) = ((x0 + 1).min(self.size - 1), (y0 + 1).min(self.size - 1));
        let (fx, fy) = (u - x0 as f32, v - y0 as f32);
        let f = self.face(face);
        let row = |y: usize| f[y * self.size + x0] * (1.0 - fx) + f[y * self.size + x1] * fx;
        row(y0) * (1.0 - fy) + row(y1) * fy
    }

    /// The six faces side by side (6·size × size), as stored in EXR files.
    pub fn strip(&self) -> Vec<Vec3> {
        let n = self.size;
        let mut out = Vec::with_capacity(6 * n * n);
        for y in 0..n {
            for face in 0..6 {
                let start = self.index(face, 0, y);
                out.extend_from_slice(&self.texels[start..start + n]);
            }
        }
        out
    }

    /// The solid-angle-weighted mean over the sphere (f64 sums).
    pub fn mean(&self) -> Vec3 {
        let mut sum = glam::DVec3::ZERO;
        let mut weight = 0.0f64;
        for face in 0..6 {
            for y in 0..self.size {
                for x in 0..self.size {
                    let w = texel_solid_angle(self.size, x, y) as f64;
                    sum += self.texels[self.index(face, x, y)].as_dvec3() * w;
                    weight += w;
                }
            }
        }
        (sum / weight).as_vec3()
    }
}

/// The unit direction through the centre of texel (x, y) of `face` for faces of `size`.
pub fn texel_direction(size: usize, face: usize, x: usize, y: usize) -> Vec3 {
    let s = 2.0 * (x as f32 + 0.5) / size as f32 - 1.0;
    let t = 2.0 * (y as f32 + 0.5) / size as f32 - 1.0;
    face_direction(face, s, t).normalize()
}

/// Solid angle of texel (x, y) of a face of `size` texels: exact, from the solid angle
/// atan(s t / √(s² + t² + 1)) of the face rectangle [0, s] × [0, t].
pub fn texel_solid_angle(size: usize, x: usize, y: usize) -> f32 {
    let corner = |s: f64, t: f64| (s * t).atan2((s * s + t * t + 1.0).sqrt());
    let e = |i: usize| 2.0 * i as f64 / size as f64 - 1.0;
    let (s0, s1, t0, t1) = (e(x), e(x + 1), e(y), e(y + 1));
    (corner(s1, t1) - corner(s0, t1) - corner(s1, t0) + corner(s0, t0)) as f32
}

pub use crate::settings::materials::MipFilter;

/// A cube map with its MIP levels, level 0 the captured one, halving down to 1×1.
#[derive(Clone, Debug, PartialEq)]
pub struct MipPyramid {
    /// The filter that built it.
    pub filter: MipFilter,
    /// Levels, finest first.
    pub levels: Vec<CubeMap>,
}

/// One level down: `src` (size s) filtered and decimated to size ⌈s/2⌉.
pub fn downsample(src: &CubeMap, filter: MipFilter) -> CubeMap {
    let w = filter.weights();
    let taps = w.len();
    let pad = taps / 2 - 1;
    let s = src.size;
    let d = s.div_ceil(2).max(1);
    let faces: Vec<Vec<Vec3>> = (0..6)
        .into_par_iter()
        .map(|face| {
            // The face with `pad` texels borrowed from its neighbours on every side.
            let ps = 2 * d + 2 * pad;
            let mut p = vec![Vec3::ZERO; ps * ps];
            for y in 0..ps {
                let fy = y as i64 - pad as i64;
                let row = &mut p[y * ps..(y + 1) * ps];
                if (0..s as i64).contains(&fy) && 2 * d == s {
                    // Interior row: copy, then borrow only the borders.
                    let start = src.index(face, 0, fy as usize);
                    row[pad..pad + s].copy_from_slice(&src.texels[start..start + s]);
                    for x in (0..pad).chain(pad + s..ps) {
                        row[x] = src.fetch_extended(face, x as i64 - pad as i64, fy);
                    }
                } else {
                    for (x, v) in row.iter_mut().enumerate() {
                        *v = src.fetch_extended(face, x as i64 - pad as i64, fy);
                    }
                }
            }
            // Horizontal pass: ps rows × d columns.
            let mut h = vec![Vec3::ZERO; ps * d];
            for y in 0..ps {
                let row = &p[y * ps..(y + 1) * ps];
                for i in 0..d {
                    let taps_row = &row[2 * i..2 * i + taps];
                    h[y * d + i] = taps_row
                        .iter()
                        .zip(w)
                        .fold(Vec3::ZERO, |acc, (&v, &k)| acc + v * k);
                }
            }
            // Vertical pass.
            let mut out = vec![Vec3::ZERO; d * d];
            for j in 0..d {
                for (k, &wk) in w.iter().enumerate() {
                    let src_row = &h[(2 * j + k) * d..(2 * j + k + 1) * d];
                    for (o, &v) in out[j * d..(j + 1) * d].iter_mut().zip(src_row) {
                        *o += v * wk;
                    }
                }
            }
            out
        })
        .collect();
    CubeMap {
        size: d,
        texels: faces.concat(),
    }
}

impl MipPyramid {
    /// Builds every level from `base` down to 1×1 with `filter`.
    pub fn build(base: CubeMap, filter: MipFilter) -> MipPyramid {
        let mut levels = vec![base];
        while levels.last().is_some_and(|l| l.size > 1) {
            let next = downsample(levels.last().expect("not empty"), filter);
            levels.push(next);
        }
        MipPyramid { filter, levels }
    }

    /// Face size of level 0.
    pub fn base_size(&self) -> usize {
        self.levels[0].size
    }

    /// Trilinear lookup: bilinear in the two levels around `lod`, blended (lod clamped to
    /// [0, levels − 1]).
    pub fn sample(&self, d: Vec3, lod: f32) -> Vec3 {
        let top = (self.levels.len() - 1) as f32;
        let lod = if lod.is_nan() {
            0.0
        } else {
            lod.clamp(0.0, top)
        };
        let l0 = lod.floor() as usize;
        let f = lod - l0 as f32;
        let a = self.levels[l0].bilinear(d);
        if f == 0.0 || l0 + 1 >= self.levels.len() {
            return a;
        }
        a * (1.0 - f) + self.levels[l0 + 1].bilinear(d) * f
    }
}

/// How a cube map is captured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CaptureSettings {
    /// Texels per face edge.
    pub face_size: usize,
    /// Rays per texel and axis: k² fixed points per texel (deterministic).
    pub supersample: u32,
    /// Reflections in near-mirror planar reflectors a ray follows, at most (0: a mirror is
    /// its own D, as the viewer's live cube maps draw it; the materials stage bakes with
    /// [`MAX_MIRROR_BOUNCES`]).
    pub mirror_bounces: u32,
    /// Lobe samples per ray at a glossy surface that is not followed as a mirror: what it
    /// reflects of D towards the capture point is added to its D (0: D alone, as the
    /// viewer's live cube maps draw it; the materials stage bakes with
    /// [`ENV_GLOSSY_SAMPLES`]).
    pub glossy_samples: u32,
}

/// Lobe samples per capture ray at glossy surfaces in the materials stage's environment maps.
pub const ENV_GLOSSY_SAMPLES: u32 = 16;

/// Surfaces crossed from inside before giving up on a ray (a closed object around the
/// capture point is seen through; this bounds the number of its layers).
const MAX_SKIPS: usize = 64;

/// Reflections in near-mirror planar reflectors the materials stage's capture rays follow.
pub const MAX_MIRROR_BOUNCES: u32 = 4;

/// Per triangle, the lobes of the near-mirror planar reflector it belongs to (the
/// reflector's own material only; [`crate::radiosity::is_mirror`]), else
/// `None`.
fn mirror_lobes(scene: &Scene) -> Vec<Option<std::sync::Arc<[Lobe]>>> {
    let mut of = vec![None; scene.triangles.len()];
    for r in &scene.reflectors {
        let m = &scene.materials[r.material as usize];
        if r.kind != ReflectorKind::Planar || !crate::radiosity::is_mirror(m) {
            continue;
        }
        let lobes: std::sync::Arc<[Lobe]> = m.lobes.iter().map(Lobe::from).collect();
        for &t in &r.triangles {
            if scene.triangles[t as usize].material == r.material {
                of[t as usize] = Some(lobes.clone());
            }
        }
    }
    of
}

/// The `j`-th of `n` lobe samples of capture ray `seed`: a Hammersley point shifted by the
/// ray's own point of the R2 sequence ([`crate::sampling::r2`]; a Cranley–Patterson
/// rotation), so that neighbouring texels do not share one pattern's error, and nothing
/// depends on threads.
fn lobe_sample_point(j: u32, n: u32, seed: u32) -> Vec2 {
    crate::sampling::r2(seed, hammersley(j, n))
}

/// Captures the scene around `centre` into a cube map by ray casting. Rays pass through the
/// triangles listed in `see_through` (the object whose environment this is: its centroid is
/// usually inside it); the first other surface hit is shaded by `shade`; misses are black.
/// A ray that meets the front of a near-mirror planar reflector adds what `shade` gives
/// there and goes on in the mirror direction, weighted by the mirror's reflectance
/// (Σ k_s × [`Lobe::mirror_reflectance`]), for up to `settings.mirror_bounces` reflections:
/// a mirror's D is (nearly) nothing, and what it shows is the room. At any other surface
/// with glossy lobes it adds, besides D, what the lobes reflect of the room's D towards the
/// ray (`settings.glossy_samples` samples of each lobe, Σ k_s · f cos θ_i / p; one bounce:
/// the sampled rays see `shade` alone): a glossy table shows the lamp's highlight. Thin
/// glass (transmissive materials) adds the same and lets the ray on straight through,
/// weighted by its transmittance at the ray's angle, through at most [`MAX_GLASS_LAYERS`]
/// panes. Every ray, from the centre or sampled at a glossy surface, also collects the
/// scene's area lights it crosses before its hit ([`Scene::lights_along`]; they are not
/// geometry): a window light seen in a chrome chair base.
/// Rows are independent work items, so the result does not depend on the thread count.
/// Advances `progress` by one per face row.
pub fn capture_cube(
    scene: &Scene,
    bvh: &Bvh,
    centre: Vec3,
    settings: &CaptureSettings,
    see_through: &[u32],
    shade: &(dyn Fn(&Hit) -> Vec3 + Sync),
    progress: &dyn Progress,
) -> Result<CubeMap, Cancelled> {
    let c = capture(
        scene,
        bvh,
        (centre, see_through),
        settings,
        shade,
        (&Sides::default(), None),
        progress,
    )?;
    Ok(c.cube)
}

/// A capture with its texels' records ([`super::capture_reads`]), one row of bytes per face
/// row, and how many texels were traced (the rest were evaluated from kept records).
#[derive(Clone, Debug)]
pub struct Captured<'a> {
    /// The cube map.
    pub cube: CubeMap,
    /// Its texels' records.
    pub reads: MapReads<'a>,
    /// Texels traced.
    pub traced: u64,
}

/// [`capture_cube`] shading with D at a point (`d`: the stored value at barycentrics of an
/// atlas triangle, through any texture; a ray meeting the back of a triangle with a back side
/// reads its twin, `sides`), each texel given by its record evaluated
/// ([`super::capture_reads::eval_texel`]), so that a cube evaluated from its kept records has
/// the bytes of one captured again. With `replay`, a texel whose kept record is still valid
/// (no surface its rays met has a changed material) is evaluated without tracing.
#[allow(clippy::too_many_arguments)]
pub fn capture_recorded<'a>(
    scene: &Scene,
    bvh: &Bvh,
    centre: Vec3,
    settings: &CaptureSettings,
    see_through: &[u32],
    (sides, d): (&Sides, &(dyn Fn(u32, Vec2) -> Vec3 + Sync)),
    replay: Option<Replay<'a>>,
    progress: &dyn Progress,
) -> Result<Captured<'a>, Cancelled> {
    // The texels' values come from their records: the trace's own sum is not needed.
    let zero = |_: &Hit| Vec3::ZERO;
    let recorded = Some((d, replay));
    capture(
        scene,
        bvh,
        (centre, see_through),
        settings,
        &zero,
        (sides, recorded),
        progress,
    )
}

/// [`capture_cube`], and with `recorded` [`capture_recorded`].
fn capture<'a>(
    scene: &Scene,
    bvh: &Bvh,
    (centre, see_through): (Vec3, &[u32]),
    settings: &CaptureSettings,
    shade: &(dyn Fn(&Hit) -> Vec3 + Sync),
    (sides, recorded): (&Sides, Option<rec::Recorded<'_, 'a>>),
    progress: &dyn Progress,
) -> Result<Captured<'a>, Cancelled> {
    // Where a ray meets a surface, D is read on the side it meets ([`Sides::side`]).
    let sided = |hit: &Hit, dir: Vec3| {
        if sides.backs.is_empty() {
            return *hit;
        }
        let n = scene.triangles[hit.triangle as usize].face_normal();
        let (triangle, bary) = sides.side(hit.triangle, hit.bary, dir.dot(n) > 0.0);
        Hit {
            triangle,
            bary,
            ..*hit
        }
    };
    let mut skip = vec![false; scene.triangles.len()];
    for &t in see_through {
        if let Some(s) = skip.get_mut(t as usize) {
            *s = true;
        }
    }
    let size = settings.face_size.max(1);
    let k = settings.supersample.max(1);
    // k² points per texel from the R2 sequence (Roberts 2018): stratified, and never on the
    // face diagonals s = ±t, along which rays would run exactly over the shared edges of
    // axis-aligned quads (where a non-watertight ray–triangle test can miss both).
    let offsets: Vec<Vec2> = (0..k * k)
        .map(|i| {
            let i = i as f64 + 0.5;
            Vec2::new(
                (i * 0.754_877_666_246_692_7).fract() as f32,
                (i * 0.569_840_290_998_053_3).fract() as f32,
            )
        })
        .collect();
    let mirrors = mirror_lobes(scene);
    // Per material, its glossy lobes (none: not sampled).
    let glossy: Vec<Vec<Lobe>> = scene
        .materials
        .iter()
        .map(|m| m.lobes.iter().map(Lobe::from).collect())
        .collect();
    // The first hit along a ray that is not on `see_through`: the hit, the origin its `t`
    // counts from, and the distance travelled to that origin.
    let first_hit = |mut origin: Vec3, dir: Vec3| -> Option<(Hit, Vec3, f32)> {
        let mut travelled = 0.0f32;
        for _ in 0..MAX_SKIPS {
            let hit = bvh.closest_hit(origin, dir, f32::MAX)?;
            if !skip.get(hit.triangle as usize).copied().unwrap_or(false) {
                return Some((hit, origin, travelled));
            }
            let next = bvh.offset_origin(origin + dir * hit.t, dir);
            travelled += (next - origin).length();
            origin = next;
        }
        None
    };
    // The area lights a ray from `origin` crosses before the hit `first_hit` found there (all
    // of them along it where it found none): lights are not geometry, so the ray also goes on
    // to the surface behind, as the path tracer's rays do.
    let lights_before = |origin: Vec3, dir: Vec3, found: Option<&(Hit, Vec3, f32)>| -> Vec3 {
        if scene.lights.is_empty() {
            return Vec3::ZERO;
        }
        let reach = found.map_or(f32::INFINITY, |(hit, _, skipped)| skipped + hit.t);
        scene.lights_along(origin, dir, reach)
    };
    // What the lobes of a glossy surface at `p` (face normal `n`, either side) reflect of
    // `shade` towards −`dir`, recorded into `out`.
    let glossy_term =
        |lobes: &[Lobe], p: Vec3, n: Vec3, dir: Vec3, seed: u32, out: &mut Vec<u8>| -> Vec3 {
            let frame = Frame::from_normal(if n.dot(dir) < 0.0 { n } else { -n });
            let wo = frame.to_local(-dir);
            let count = settings.glossy_samples;
            let mut sum = Vec3::ZERO;
            rec::push_glossy(out, lobes.len());
            for lobe in lobes {
                let count_at = rec::push_lobe(out, lobe.ks);
                let mut lobe_sum = Vec3::ZERO;
                for j in 0..count {
                    let Some(wi) = lobe.sample(wo, lobe_sample_point(j, count, seed)) else {
                        continue;
                    };
                    let w = frame.to_world(wi);
                    let origin = bvh.offset_origin(p, w);
                    let found = first_hit(origin, w);
                    let mut seen = lights_before(origin, w, found.as_ref());
                    let lights = seen;
                    let found = found.map(|(hit, _, travelled)| Hit {
                        t: travelled + hit.t,
                        ..sided(&hit, w)
                    });
                    if let Some(hit) = &found {
                        seen += shade(hit);
                    } else if seen == Vec3::ZERO {
                        continue;
                    }
                    let weight = lobe.sample_weight(wo, wi);
                    let lands = found.map(|hit| (hit.triangle, hit.bary));
                    rec::push_sample(out, count_at, weight, lights, lands);
                    lobe_sum += seen * weight;
                }
                sum += lobe.ks * lobe_sum / count as f32;
            }
            sum
        };
    // One ray from the centre: each surface it meets adds its D, a mirror sends it on (up
    // to `mirror_bounces` times), glass lets it through (up to MAX_GLASS_LAYERS panes), any
    // other glossy surface adds its reflection and ends it.
    // Records its reads into `out`.
    let trace = |dir: Vec3, seed: u32, out: &mut Vec<u8>| -> Vec3 {
        let (mut origin, mut dir) = (centre, dir);
        let mut travelled = 0.0f32;
        let (mut sum, mut weight) = (Vec3::ZERO, Vec3::ONE);
        let (mut bounces, mut panes) = (0u32, 0u32);
        loop {
            let found = first_hit(origin, dir);
            let lights = lights_before(origin, dir, found.as_ref());
            if lights != Vec3::ZERO {
                rec::push_lights(out, weight * lights);
                sum += weight * lights;
            }
            let Some((hit, at, skipped)) = found else {
                break;
            };
            travelled += skipped;
            let seen = sided(&hit, dir);
            rec::push_surface(out, weight, seen.triangle, seen.bary);
            sum += weight
                * shade(&Hit {
                    t: travelled + hit.t,
                    ..seen
                });
            let tri = &scene.triangles[hit.triangle as usize];
            let n = tri.face_normal();
            let c = -dir.dot(n);
            let p = at + dir * hit.t;
            match &mirrors[hit.triangle as usize] {
                Some(lobes) if bounces < settings.mirror_bounces && c > 0.0 => {
                    bounces += 1;
                    weight *= lobes
                        .iter()
                        .fold(Vec3::ZERO, |acc, l| acc + l.ks * l.mirror_reflectance(c));
                    dir = reflect(-dir, n);
                    let next = bvh.offset_origin(p, dir);
                    travelled += (next - at).length();
                    origin = next;
                }
                _ => {
                    let lobes = &glossy[tri.material as usize];
                    if settings.glossy_samples > 0 && !lobes.is_empty() {
                        sum += weight * glossy_term(lobes, p, n, dir, seed, out);
                    }
                    // Thin glass: what lies behind shows through, as in the viewer's frame.
                    let m = &scene.materials[tri.material as usize];
                    if !m.is_transmissive() || panes == MAX_GLASS_LAYERS {
                        break;
                    }
                    panes += 1;
                    weight *= m.transmission.weight(c);
                    let next = bvh.offset_origin(p, dir);
                    travelled += (next - at).length();
                    origin = next;
                }
            }
        }
        rec::push_end(out);
        sum
    };
    let rays = offsets.len();
    // Texel (x, y) of `face`: the mean of its rays, recorded into `out`.
    let texel = |face: usize, x: usize, y: usize, out: &mut Vec<u8>| -> Vec3 {
        let mut sum = Vec3::ZERO;
        let index = ((face * size + y) * size + x) as u64;
        for (i, &o) in offsets.iter().enumerate() {
            let s = 2.0 * (x as f32 + o.x) / size as f32 - 1.0;
            let t = 2.0 * (y as f32 + o.y) / size as f32 - 1.0;
            // Wraps past 2³² rays: any distinct-enough index will do.
            let seed = (index * rays as u64 + i as u64) as u32;
            sum += trace(face_direction(face, s, t).normalize(), seed, out);
        }
        sum / rays as f32
    };
    let shape = rec::CubeShape {
        size,
        rays,
        glossy_samples: settings.glossy_samples,
    };
    // Records name the atlas's triangles, twins included.
    let triangles = sides.sided(&scene.triangles);
    let rows = rec::texel_rows(&shape, &triangles, &texel, recorded, progress);
    let (texels, reads, traced) = rows.ok_or(Cancelled)?;
    Ok(Captured {
        cube: CubeMap { size, texels },
        reads,
        traced,
    })
}

/// Reflected radiance ∫ L f_lobe cos θ_i dω_i (k_s left out) at a point with shading frame
/// `frame`, viewed from world direction `wo`, by a regular pattern (Luksch §7): Eq. 9 with
/// the density of Eq. 17–18, each sample looked up at its Eq. 16 MIP level plus `bias`
/// (0: the equation as published; §8 tunes it per scene).
pub fn specular_regular(
    env: &MipPyramid,
    lobe: &Lobe,
    pattern: &Pattern,
    frame: &Frame,
    wo: Vec3,
    bias: f32,
) -> Vec3 {
    let wo_l = frame.to_local(wo);
    if !above(wo_l.z) || pattern.is_empty() {
        return Vec3::ZERO;
    }
    let n = pattern.len() as u32;
    let area = lobe_area_for(pattern.ndf, pattern.mx, pattern.my, pattern.xi0, wo_l); // Eq. 14–15
    let face = env.base_size() as u32;
    let mut sum = Vec3::ZERO;
    for &h in &pattern.half_vectors {
        let wi = crate::brdf::reflect(wo_l, h);
        if !above(wi.z) {
            continue;
        }
        let wi_world = frame.to_world(wi);
        let lod = mip_level(area, face, n, wi_world, frame.to_world(h)) + bias; // Eq. 16
        let f = lobe.eval(wo_l, wi);
        let pdf = pattern.incident_pdf(h, wi); // Eq. 17
        if pdf > 0.0 {
            sum += env.sample(wi_world, lod) * (f * wi.z / pdf);
        }
    }
    sum / n as f32
}

/// The MIP level of filtered importance sampling (Colbert & Křivánek 2007): half the log₂
/// of the ratio of the solid angle a sample stands for, 1/(n p), to a texel's solid angle at
/// that direction, (2/size)² / d³ with d = ‖ω/‖ω‖_∞‖, plus `bias` (their choice: 1).
pub fn importance_mip_level(
    pdf: f32,
    samples: usize,
    face_size: usize,
    wi: Vec3,
    bias: f32,
) -> f32 {
    let omega_s = 1.0 / (samples.max(1) as f32 * pdf.max(f32::MIN_POSITIVE));
    let d = wi.length() / wi.abs().max_element().max(f32::MIN_POSITIVE);
    let omega_p = 4.0 / (face_size as f32 * face_size as f32 * d * d * d);
    (0.5 * (omega_s / omega_p).log2() + bias).max(0.0)
}

/// The i-th of n Hammersley points ((i + ½)/n, radical inverse of i in base 2).
pub fn hammersley(i: u32, n: u32) -> Vec2 {
    Vec2::new(
        (i as f32 + 0.5) / n.max(1) as f32,
        i.reverse_bits() as f32 * (1.0 / 4_294_967_296.0),
    )
}

/// Reflected radiance (as [`specular_regular`]) by filtered importance sampling: the lobe
/// sampled at the points `us` (Eq. 6–7), each looked up at [`importance_mip_level`].
pub fn specular_importance(
    env: &MipPyramid,
    lobe: &Lobe,
    frame: &Frame,
    wo: Vec3,
    us: &[Vec2],
    bias: f32,
) -> Vec3 {
    let wo_l = frame.to_local(wo);
    if !above(wo_l.z) || us.is_empty() {
        return Vec3::ZERO;
    }
    let face = env.base_size();
    let mut sum = Vec3::ZERO;
    for &u in us {
        let Some(wi) = lobe.sample(wo_l, u) else {
            continue;
        };
        let pdf = lobe.pdf(wo_l, wi); // Eq. 10
        let wi_world = frame.to_world(wi);
        let lod = importance_mip_level(pdf, us.len(), face, wi_world, bias);
        sum += env.sample(wi_world, lod) * lobe.sample_weight(wo_l, wi);
    }
    sum / us.len() as f32
}

/// Reference reflected radiance: `k`×`k` jittered stratified importance samples of the lobe,
/// looked up bilinearly in level 0 (unfiltered). Accumulated in f64.
pub fn specular_reference(
    env: &CubeMap,
    lobe: &Lobe,
    frame: &Frame,
    wo: Vec3,
    k: u32,
    rng: &mut Rng,
) -> Vec3 {
    let wo_l = frame.to_local(wo);
    if !above(wo_l.z) {
        return Vec3::ZERO;
    }
    let k = k.max(1);
    let mut sum = glam::DVec3::ZERO;
    for j in 0..k {
        for i in 0..k {
            let j2 = rng.uniform2();
            let u = Vec2::new(
                ((i as f32 + j2.x) / k as f32).min(1.0 - f32::EPSILON),
                ((j as f32 + j2.y) / k as f32).min(1.0 - f32::EPSILON),
            );
            if let Some(wi) = lobe.sample(wo_l, u) {
                let w = lobe.sample_weight(wo_l, wi) as f64;
                sum += env.bilinear(frame.to_world(wi)).as_dvec3() * w;
            }
        }
    }
    (sum / (k as f64 * k as f64)).as_vec3()
}
