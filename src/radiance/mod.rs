//! Radiance maps with depth (Bastos et al. §8.1.3): what each glossy planar reflector sees,
//! sampled as images with depth from cameras on hemispheres behind it.

pub mod footprint;
pub mod index;
pub mod magnify;
pub mod normals;
pub mod quadtree;
pub mod reads;
pub mod sampling;
pub mod shading;

use std::borrow::Cow;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::geometry::{Bvh, Hit, Triangle};
use footprint::PixelRays;
pub use reads::Replay;
use reads::{Evaluated, Kept, MapReads, PixelWriter};
use sampling::MapCamera;

pub use crate::settings::radiance::{RadianceOverride, RadianceStageOverride};

/// One rendered map: per pixel (row-major), radiance, depth, scene point, the hit surface's
/// facet normal and whether the pixel's ray hit anything.
#[derive(Clone, Debug, PartialEq)]
pub struct RadianceMap {
    /// Linear radiance (D at the hit, emission included); zero for misses.
    pub rgb: Vec<Vec3>,
    /// Depth along the reflector normal from the centre of projection; zero for misses.
    pub depth: Vec<f32>,
    /// Scene points; zero for misses.
    pub points: Vec<Vec3>,
    /// Unit geometric (facet) normal of the hit triangle, either side; zero for misses. The
    /// viewer sizes a point's splat by the surface's slant from it.
    pub normals: Vec<Vec3>,
    /// Whether the pixel saw something.
    pub hit: Vec<bool>,
}

/// The map resolution from which a row's rays are traced in packets ([`Bvh::closest_hits`]).
/// Below it eight neighbouring pixels' rays diverge too much for packets to pay
/// (docs/tuning.md#packets-from).
const PACKETS_FROM: u32 = 64;

/// A rendered map, its records, and how many of its pixels were traced and shaded (the rest
/// were evaluated from kept records).
#[derive(Clone, Debug)]
pub struct Rendered<'a> {
    /// The map.
    pub map: RadianceMap,
    /// Its pixels' records.
    pub reads: MapReads<'a>,
    /// Pixels traced and shaded.
    pub shaded: u64,
}

/// Ray casts one map: a ray per pixel from the element through the scene (`bvh` built over
/// `triangles`); `shade` writes the record of the radiance leaving a hit against the ray's
/// unit direction, over the footprint of the pixel's rays ([`shading::exitant`]), and each
/// pixel's radiance is its record evaluated with D (`d`, the stored value at barycentrics of
/// a triangle). With `replay`, a pixel whose kept record is still valid is evaluated from it
/// without tracing. Deterministic; parallel over rows.
pub fn render<'a>(
    cam: &MapCamera,
    bvh: &Bvh,
    triangles: &[Triangle],
    normal_offset: f32,
    shade: &(dyn Fn(&Hit, Vec3, &PixelRays, &mut PixelWriter) + Sync),
    d: &(dyn Fn(u32, Vec2) -> Vec3 + Sync),
    replay: Option<Replay<'a>>,
) -> Rendered<'a> {
    let res = cam.resolution;
    // Records of another resolution are not this map's.
    let (old_rows, changed) = Replay::rows(replay, res as usize);
    type Pixel = (Vec3, f32, Vec3, Vec3, bool);
    let rows: Vec<(Vec<Pixel>, Cow<'a, [u8]>, u64)> = old_rows
        .into_par_iter()
        .zip(changed)
        .enumerate()
        // A row each task: rows that see a glossy surface cost many times the others.
        .with_max_len(1)
        .map(|(y, (old, changed))| {
            let changed = |t: u32| {
                let m = triangles[t as usize].material as usize;
                changed.get(m).copied().unwrap_or(true)
            };
            let y = y as u32;
            let mut origins = Vec::with_capacity(res as usize);
            let mut dirs = Vec::with_capacity(res as usize);
            for x in 0..res {
                let (q, d) = cam.pixel_ray(x, y);
                // Start just in front of the reflector (so it does not see itself), moving
                // along the ray so every point stays on the camera's line of sight.
                origins.push(q + d * (normal_offset / d.dot(cam.normal).max(1e-3)));
                dirs.push(d);
            }
            // The pixel of the record evaluated as `e`.
            let finish = |i: usize, e: Evaluated| -> Pixel {
                match e.hit {
                    Some((tri, t)) => {
                        let p = origins[i] + dirs[i] * t;
                        let n = triangles[tri as usize].face_normal();
                        (e.rgb, cam.depth(p), p, n, true)
                    }
                    None => (Vec3::ZERO, 0.0, Vec3::ZERO, Vec3::ZERO, false),
                }
            };
            // Shades pixel i's hit into `bytes` and evaluates its record.
            let traced = |i: usize, hit: Option<Hit>, bytes: &mut Vec<u8>| -> Pixel {
                let from = bytes.len();
                match hit {
                    Some(h) => {
                        let rays = cam.pixel_rays(i as u32, y);
                        shade(&h, dirs[i], &rays, &mut PixelWriter::hit(bytes, h.t));
                    }
                    None => reads::push_miss(bytes),
                }
                let e = reads::eval_pixel(&bytes[from..], triangles.len(), &|_| false, d)
                    .expect("a record just written is whole");
                finish(i, e)
            };
            if let Some(old) = old {
                let kept = |i: usize, at: &[u8]| {
                    reads::eval_pixel(at, triangles.len(), &changed, d).map(|e| Kept {
                        len: e.len,
                        stale: e.stale,
                        value: finish(i, e),
                    })
                };
                let again = |i: usize, out: &mut Vec<u8>| {
                    let hit = bvh.closest_hit(origins[i], dirs[i], f32::INFINITY);
                    traced(i, hit, out)
                };
                return reads::replay_row(old, res as usize, kept, again);
            }
            let mut row = Vec::with_capacity(res as usize);
            let mut bytes = Vec::new();
            if res < PACKETS_FROM {
                for i in 0..res as usize {
                    let hit = bvh.closest_hit(origins[i], dirs[i], f32::INFINITY);
                    row.push(traced(i, hit, &mut bytes));
                }
            } else {
                // A row's rays are coherent enough at PACKETS_FROM pixels and more: traced in
                // packets of eight (the same hits as one by one).
                bvh.closest_hits(&origins, &dirs, f32::INFINITY, |i, h| {
                    row.push(traced(i, h, &mut bytes))
                });
            }
            (row, Cow::Owned(bytes), res as u64)
        })
        .collect();
    let shaded = rows.iter().map(|r| r.2).sum();
    let mut px = Vec::with_capacity((res * res) as usize);
    let mut records = Vec::with_capacity(res as usize);
    for (row, bytes, _) in rows {
        px.extend(row);
        records.push(bytes);
    }
    Rendered {
        map: RadianceMap {
            rgb: px.iter().map(|p| p.0).collect(),
            depth: px.iter().map(|p| p.1).collect(),
            points: px.iter().map(|p| p.2).collect(),
            normals: px.iter().map(|p| p.3).collect(),
            hit: px.iter().map(|p| p.4).collect(),
        },
        reads: MapReads { rows: records },
        shaded,
    }
}

/// Sharpest Beckmann roughness planned as a mirror: one map pixel is all a reflected ray sees.
pub const MIRROR_ROUGHNESS: f32 = 0.02;

/// Sampling chosen for a reflector from its material's glossiness (Bastos Table 1 ranges
/// from 32² to 128²): sharper lobes need finer maps, more elements and more cameras.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MapPlan {
    /// Reflector elements along the frame's two axes.
    pub elements: [u32; 2],
    /// Cameras per hemisphere.
    pub cameras: u32,
    /// Map resolution.
    pub resolution: u32,
}

impl MapPlan {
    /// The plan for a lobe of Beckmann roughness `m` on a reflector of `size` (metres along
    /// its two axes), scaled by the preset's `scale` (0.5 draft, 1 default, 2 high). The
    /// radiance stage doubles a mirror's resolution where the camera paths see its maps
    /// magnified ([`magnify`]).
    pub fn for_roughness(m: f32, size: glam::Vec2, scale: f32) -> MapPlan {
        // m ≤ 0.02: mirror; ≤ 0.1: glossy; rougher: blurry, coarse maps suffice.
        // A mirror shows whatever its best map saw, so its cameras are dense (25 a hemisphere:
        // the pole and rings at 27°, 53° and 80°), else the mirrored eye lies far from its
        // element's nearest camera and silhouettes come out ragged
        // (docs/tuning.md#mirror-map-cameras). The viewer splats 2 maps per element whatever
        // the count, so more cameras cost bake time, bytes and GPU memory, not frame time.
        let (res, long, cams) = if m <= MIRROR_ROUGHNESS {
            (128.0, 4.0, 25.0)
        } else if m <= 0.1 {
            (64.0, 3.0, 7.0)
        } else {
            (32.0, 2.0, 5.0)
        };
        let resolution = ((res * scale) as u32).clamp(16, 512).next_power_of_two();
        let aspect = (size.x.min(size.y) / size.x.max(size.y).max(1e-9)).clamp(0.0, 1.0);
        let short = ((long * aspect).round() as u32).max(1);
        let long = long as u32;
        let elements = if size.x >= size.y {
            [long, short]
        } else {
            [short, long]
        };
        MapPlan {
            elements,
            cameras: ((cams * scale.sqrt()).round() as u32).max(1),
            resolution,
        }
    }
}
