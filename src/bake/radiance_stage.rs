//! The `radiance` stage: radiance maps with depth and their quadtrees for every planar
//! reflector with a glossy (or mirror) material.
//!
//! Writes, per reflector `NAME`:
//! - `radiance/NAME/e{i}_{j}_c{k}.exr`: map k of element (i, j): R, G, B (half, linear
//!   radiance = D at the hit), Z (float, depth along the reflector normal from the map's
//!   centre of projection), A (half: 1 where the pixel's ray hit the scene, 0 where it saw
//!   nothing) and NX, NY (half: the hit triangle's facet normal, octahedral,
//!   [`crate::radiance::normals`]; 0 for misses). Row 0 is the element's edge at its corner.
//! - `radiance/NAME/e{i}_{j}_c{k}.qtree`: its quadtree ([`crate::radiance::quadtree`]).
//! - `radiance/NAME/cameras.json`: every map's file stem, element, camera index and
//!   [`MapCamera`] (centre of projection, element corner and edges, normal, resolution):
//!   [`crate::radiance::index`], which also holds the reader.
//!
//! `NAME` is [`crate::radiance::index::reflector_folder`] of the reflector's name.

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use crate::bundle::{Bundle, BundleError, StageInfo, StageRecord, StageWriter};
use crate::camera::Camera;
use crate::image_io::{self, ChannelData, ExrCompression, ImageError, Precision};
use crate::progress::{Cancelled, Progress};
use crate::radiance::footprint::PixelRays;
use crate::radiance::index::{CamerasFile, MapEntry, cameras_path, reflector_folder};
use crate::radiance::magnify::{self, Look};
use crate::radiance::quadtree::{self, QuadtreeLimits};
use crate::radiance::reads::{PixelWriter, Read};
use crate::radiance::sampling::{MapCamera, ReflectorFrame, hemisphere_cameras};
use crate::radiance::shading::{d_point, d_seen, exitant};
use crate::radiance::{MIRROR_ROUGHNESS, MapPlan, RadianceMap, Rendered, Replay, render};
use crate::radiosity::RadiosityMap;
use crate::radiosity::map::MapError;
use crate::scene::texturing::texture_levels;
use crate::scene::{Quality, ReflectorKind, Scene};
use crate::settings::radiance::MAX_RADIANCE_RESOLUTION;

use super::part::{Item, Part};
use super::read_cache::{self, HeldReads, HeldRows, MaterialPrints};
use super::{Stage, read_cache::map_key};

/// Why the radiance stage failed.
#[derive(Debug, thiserror::Error)]
pub enum RadianceError {
    /// D is needed to shade the maps.
    #[error("{}: has no radiosity stage; the radiance maps are shaded with D: run glint-radiosity (or glint-bake) first", dir.display())]
    NoRadiosity {
        /// The bundle.
        dir: std::path::PathBuf,
    },
    /// Reading D.
    #[error(transparent)]
    Map(#[from] MapError),
    /// Encoding a map.
    #[error(transparent)]
    Image(#[from] ImageError),
    /// Writing the bundle.
    #[error(transparent)]
    Bundle(#[from] BundleError),
    /// Ctrl-C.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}

pub use crate::settings::radiance::quality_scale;

/// Quadtree limits: a leaf's depths lie within 10% of its nearest depth (its points' Eq. 3
/// sizes within 10%), or it holds fewer than 64 points. Relative, so scale does not matter.
pub fn quadtree_limits(_scene: &Scene) -> QuadtreeLimits {
    QuadtreeLimits {
        relative_depth_range: 0.1,
        min_points: 64,
    }
}

/// The plan of each reflector that needs maps: (reflector index, frame, plan).
pub fn plans(scene: &Scene, quality: Quality) -> Vec<(usize, ReflectorFrame, MapPlan)> {
    plans_with(scene, quality, &std::sync::OnceLock::new())
}

/// [`plans`] with the scene's BVH, built into `bvh` only where a mirror's maps are sized from
/// the camera paths' looks into it (a bake that already holds one passes it in).
fn plans_with(
    scene: &Scene,
    quality: Quality,
    bvh: &std::sync::OnceLock<crate::geometry::Bvh>,
) -> Vec<(usize, ReflectorFrame, MapPlan)> {
    let scale = scene.desc.bake.radiance.scale(quality);
    scene
        .reflectors
        .iter()
        .enumerate()
        .filter(|(_, r)| r.kind == ReflectorKind::Planar)
        .filter_map(|(i, r)| {
            let m = scene.materials[r.material as usize].sharpest_roughness()?;
            let frame = ReflectorFrame::new(r.plane.as_ref()?, r, &scene.triangles);
            let mut plan = MapPlan::for_roughness(m, frame.size, scale);
            if m <= MIRROR_ROUGHNESS {
                // Decided at the default preset's resolution so that every preset refines the
                // same mirrors (docs/tuning.md#mirror-map-resolution).
                let bvh = bvh.get_or_init(|| scene.build_bvh());
                let looks = looks(scene, bvh, r, &frame);
                let default = MapPlan::for_roughness(m, frame.size, 1.0).resolution;
                let (eu, ev) = (
                    frame.size.x / plan.elements[0] as f32,
                    frame.size.y / plan.elements[1] as f32,
                );
                let f = magnify::factor(&looks, eu, ev, default);
                plan.resolution = (plan.resolution * f).min(MAX_RADIANCE_RESOLUTION);
            }
            if let Some(o) = &scene.desc.reflectors[r.index].radiance {
                if let Some(e) = o.elements {
                    plan.elements = [e[0].max(1), e[1].max(1)];
                }
                if let Some(c) = o.cameras_per_hemisphere {
                    plan.cameras = c.max(1);
                }
                if let Some(res) = o.resolution {
                    plan.resolution = res.clamp(1, MAX_RADIANCE_RESOLUTION);
                }
            }
            Some((i, frame, plan))
        })
        .collect()
}

/// Eye rays a camera pose casts at the mirror, across by down (the viewer's default aspect).
const LOOK_GRID: (u32, u32) = (48, 32);

/// The looks into planar reflector `reflector` (frame `frame`) from the scene's camera paths,
/// at each keyframe and halfway between keyframes: eye rays on a [`LOOK_GRID`] whose first
/// hit lies on the reflector and whose mirrored ray meets the scene.
fn looks(
    scene: &Scene,
    bvh: &crate::geometry::Bvh,
    reflector: &crate::scene::Reflector,
    frame: &ReflectorFrame,
) -> Vec<Look> {
    let mut on_mirror = reflector.triangles.clone();
    on_mirror.sort_unstable();
    let n = frame.normal;
    let (w, h) = LOOK_GRID;
    let aspect = w as f32 / h as f32;
    let mut out = Vec::new();
    for path in &scene.camera_paths {
        let times = path.keyframes.iter().map(|k| k.time);
        let halves = path
            .keyframes
            .windows(2)
            .map(|k| 0.5 * (k[0].time + k[1].time));
        for t in times.chain(halves) {
            if crate::camera::degenerate_pose(path, t).is_some() {
                continue;
            }
            let cam = crate::camera::pose_at(path, t);
            let eye_pixel = cam.fov_y / magnify::EYE_HEIGHT;
            for y in 0..h {
                for x in 0..w {
                    let dir = cam.ray_direction(Camera::pixel_ndc(x, y, w, h), aspect);
                    let Some(hit) = bvh.closest_hit(cam.position, dir, f32::INFINITY) else {
                        continue;
                    };
                    if on_mirror.binary_search(&hit.triangle).is_err() || dir.dot(n) >= 0.0 {
                        continue;
                    }
                    let p = cam.position + dir * hit.t;
                    let r = dir - 2.0 * dir.dot(n) * n;
                    // Off the mirror by a fraction of the eye's distance: scale-free.
                    let q = p + n * (1e-4 * hit.t);
                    if let Some(m) = bvh.closest_hit(q, r, f32::INFINITY) {
                        out.push(Look {
                            to_mirror: hit.t,
                            beyond: m.t,
                            eye_pixel,
                        });
                    }
                }
            }
        }
    }
    out
}

/// Version of what a map holds, recorded in the stage's settings so that maps baked before
/// it are re-baked: 2 added the facet normals (NX, NY).
pub const MAP_FORMAT: u32 = 2;

/// Encodes a map as EXR: RGB half, Z float, A half (hit mask), NX and NY half (facet normal,
/// octahedral).
pub fn encode_map(
    res: u32,
    map: &RadianceMap,
    compression: ExrCompression,
    depth: Precision,
) -> Result<Vec<u8>, ImageError> {
    let a: Vec<f32> = map.hit.iter().map(|&h| if h { 1.0 } else { 0.0 }).collect();
    // A miss's normal is zero, which encodes as (0, 0).
    let (nx, ny): (Vec<f32>, Vec<f32>) = map
        .normals
        .iter()
        .map(|&n| crate::radiance::normals::encode(n).into())
        .unzip();
    image_io::encode_rgb_exr_with(
        res as usize,
        res as usize,
        &map.rgb,
        &[
            ChannelData {
                name: "A",
                precision: Precision::Half,
                samples: &a,
            },
            ChannelData {
                name: "Z",
                precision: depth,
                samples: &map.depth,
            },
            ChannelData {
                name: "NX",
                precision: Precision::Half,
                samples: &nx,
            },
            ChannelData {
                name: "NY",
                precision: Precision::Half,
                samples: &ny,
            },
        ],
        compression,
    )
}

/// Bakes the radiance maps of every glossy planar reflector into the bundle at `dir`.
pub fn bake(
    scene: &Scene,
    dir: &Path,
    quality: Quality,
    force: bool,
    progress: &dyn Progress,
) -> Result<StageRecord, RadianceError> {
    bake_part(scene, dir, quality, force, Part::whole(), progress)
}

/// [`bake`] of `part`: every reflector, or one ([`Item::Reflector`]), shaded with D from
/// the bundle written or from `part.d_from`.
pub fn bake_part(
    scene: &Scene,
    dir: &Path,
    quality: Quality,
    force: bool,
    part: Part<'_>,
    progress: &dyn Progress,
) -> Result<StageRecord, RadianceError> {
    let start = Instant::now();
    crate::bundle::check_scene(dir, &scene.name, &scene.content_hash, force)?;
    let no_radiosity = || RadianceError::NoRadiosity {
        dir: dir.to_owned(),
    };
    let (d, d_read, d_source) = match part.d_from {
        Some(from) => {
            let (d, identity) = super::part::require_d(from)?;
            (d, None, Some(identity))
        }
        None => {
            let bundle = match Bundle::open(dir) {
                Ok(b) => b,
                Err(BundleError::MissingManifest { .. }) => return Err(no_radiosity()),
                Err(e) => return Err(e.into()),
            };
            // D as read, from this one manifest: recorded in the settings, and checked again
            // at the commit so maps shaded with this D are never labelled with another.
            let d_record = bundle
                .stage(Stage::Radiosity.name())
                .ok_or_else(no_radiosity)?;
            let d_read = d_record.identity();
            let d_source = (d_record.scene_hash == scene.content_hash).then(|| d_read.clone());
            let d = RadiosityMap::load(&bundle)?.ok_or_else(no_radiosity)?;
            (d, Some(d_read), d_source)
        }
    };
    // Before the compute: a bundle that cannot be written fails now.
    let mut w = StageWriter::begin(dir, Stage::Radiance.name())?;
    if let Some(d_read) = &d_read {
        w.read_from(Stage::Radiosity.name(), d_read);
    }
    let built = std::sync::OnceLock::from(scene.build_bvh());
    let bvh = built.get().expect("built above");
    // A read of a double-sided sheet's back reads its back side's texels (the atlas's
    // twin, after the scene's triangles), its texture still read on the scene's triangle.
    let sides = d.atlas.sides();
    let sided = |r: Read, back: bool| {
        let (triangle, bary) = sides.side(r.triangle, r.bary, back);
        Read {
            triangle,
            bary,
            ..r
        }
    };
    let d_at = |h: &crate::geometry::Hit, back: bool| sided(d_point(scene, h), back);
    let levels = texture_levels(&scene.textures);
    let shade = |h: &crate::geometry::Hit, dir: Vec3, rays: &PixelRays, out: &mut PixelWriter| {
        let seen = |h: &crate::geometry::Hit, back| sided(d_seen(scene, &levels, h, rays), back);
        exitant(scene, bvh, &d_at, &seen, h, dir, out)
    };
    let stored = |t: u32, b: glam::Vec2| d.radiance(t, b);
    // Records name the atlas's triangles: the twins' materials are their fronts'.
    let triangles = sides.sided(&scene.triangles);
    let normal_offset = 4.0 * bvh.epsilon();
    let scene_key = read_cache::scene_key(scene, normal_offset);
    let prints = MaterialPrints::of(&scene.materials);
    let (mut shaded, mut kept_bytes, mut trees_kept) = (0u64, 0u64, 0u64);
    // Wall seconds of reading records, rendering (the last record written meanwhile), counting
    // and hashing records, and encoding, summed.
    let mut steps = [0f64; 4];
    let limits = quadtree_limits(scene);
    let plans: Vec<_> = plans_with(scene, quality, &built)
        .into_iter()
        .enumerate()
        .filter(|(k, _)| part.item.takes(Item::Reflector(*k)))
        .map(|(_, p)| p)
        .collect();
    let total: u64 = plans
        .iter()
        .map(|(_, _, p)| (p.elements[0] * p.elements[1] * p.cameras) as u64)
        .sum();
    progress.phase("radiance maps", total);

    let mut table = Vec::new();
    let mut rays = 0u64;
    for (ri, frame, plan) in &plans {
        let reflector = &scene.reflectors[*ri];
        let folder = reflector_folder(&reflector.name);
        // The unit's records, while within their budget.
        let mut reads_dir = part.reads;
        let mut cameras = Vec::new();
        let mut bytes = 0u64;
        let mut files: Vec<(String, &str, Vec<u8>)> = Vec::new();
        // An element's maps, rendered: (camera, file stem, camera, map, its quadtree's file
        // and key where its records are kept, the quadtree kept with them).
        type Tree = Option<(String, [u8; 32])>;
        type Done = (usize, String, MapCamera, RadianceMap, Tree, Option<Vec<u8>>);
        let mut maps: Vec<Done> = Vec::new();
        // The last map's record, counted against the budget and hashed (its quadtree's key
        // needs the sum), written while the next map renders: (folder, name, key, sum,
        // records).
        type Held<'p> = Option<(&'p Path, String, [u8; 32], [u8; 32], HeldReads)>;
        let mut pending: Held = None;
        let write_pending = |p: Held| match p {
            Some((dir, record, key, sum, held)) => {
                read_cache::write_record(dir, &record, &key, &sum, &prints, &held.reads())
            }
            None => Ok(()),
        };
        for j in 0..plan.elements[1] {
            for i in 0..plan.elements[0] {
                let (corner, eu, ev) = frame.element(i, j, plan.elements[0], plan.elements[1]);
                for (k, c) in hemisphere_cameras(corner, eu, ev, frame.normal, plan.cameras)
                    .into_iter()
                    .enumerate()
                {
                    if progress.cancelled() {
                        return Err(Cancelled.into());
                    }
                    let cam = MapCamera {
                        centre: c,
                        corner,
                        edge_u: eu,
                        edge_v: ev,
                        normal: frame.normal,
                        resolution: plan.resolution,
                    };
                    let stem = format!("e{i}_{j}_c{k}");
                    let record = format!("{folder}.{stem}.reads");
                    let key = map_key(&scene_key, &cam);
                    let mut lap = Instant::now();
                    let mut clock = |step: usize| {
                        steps[step] += lap.elapsed().as_secs_f64();
                        lap = Instant::now();
                    };
                    let (reads, changed) = read_cache::kept(reads_dir, &record, &key, &prints);
                    let kept_sum = reads.as_ref().map(|f| f.sum());
                    let replay = reads.as_ref().map(|f| Replay::of(f.reads(), &changed));
                    clock(0);
                    let (rendered, written) = rayon::join(
                        || {
                            render(
                                &cam,
                                bvh,
                                &triangles,
                                normal_offset,
                                &shade,
                                &stored,
                                replay,
                            )
                        },
                        || write_pending(pending.take()),
                    );
                    written?;
                    clock(1);
                    // The map apart from its records, which borrow the file read.
                    let Rendered {
                        map,
                        reads: fresh,
                        shaded: traced,
                    } = rendered;
                    shaded += traced;
                    // Records of which no pixel was traced again are still right: kept as they are
                    // (prints older than the materials only trace more next time), and counted
                    // against the unit's budget as a record written is.
                    let mut sum = None;
                    if let Some(dir) = reads_dir {
                        let within = if traced > 0 {
                            let within = read_cache::charge_record(
                                dir,
                                &record,
                                &prints,
                                &fresh,
                                &mut kept_bytes,
                            )?;
                            if within {
                                let s = read_cache::record_sum(&prints, &fresh);
                                sum = Some(s);
                                let rows = HeldRows::of(reads.as_ref(), fresh);
                                pending = Some((dir, record.clone(), key, s, rows.with(reads)));
                            }
                            within
                        } else {
                            sum = kept_sum;
                            kept_sum.is_none()
                                || read_cache::count_kept(dir, &record, &mut kept_bytes)?
                        };
                        if !within {
                            reads_dir = None;
                        }
                    }
                    // The quadtree of records kept as they are is the one kept with them, built
                    // from the same hits.
                    let tree_name = read_cache::quadtree_name(&record);
                    let tree_key = reads_dir
                        .zip(sum)
                        .map(|(_, sum)| read_cache::quadtree_key(&key, &sum, &limits));
                    let mut tree = None;
                    if let (Some(dir), Some(k), 0) = (reads_dir, tree_key, traced) {
                        tree = read_cache::read_quadtree(dir, &tree_name, &k);
                        if tree.is_some()
                            && !read_cache::count_kept(dir, &tree_name, &mut kept_bytes)?
                        {
                            reads_dir = None;
                        }
                    }
                    clock(2);
                    rays += (plan.resolution * plan.resolution) as u64;
                    let tree_keep = tree_key.map(|k| (tree_name, k));
                    maps.push((k, stem, cam, map, tree_keep, tree));
                    progress.advance(1);
                }
                // An element's maps are encoded on every thread, and written at once: their
                // flushes overlap.
                let lap = Instant::now();
                let encoded: Vec<_> = maps
                    .par_iter()
                    .map(|(_, _, _, map, _, kept)| {
                        let exr = encode_map(
                            plan.resolution,
                            map,
                            ExrCompression::Zip16,
                            Precision::Float,
                        );
                        // (the tree's bytes, its node count, whether it was built now)
                        let tree = match kept.as_ref().and_then(|t| Some((t, node_count(t)?))) {
                            Some((t, nodes)) => (t.clone(), nodes, false),
                            None => {
                                let tree = quadtree::build(
                                    plan.resolution,
                                    &map.points,
                                    &map.depth,
                                    &map.hit,
                                    &limits,
                                );
                                (quadtree::encode(plan.resolution, &tree), tree.len(), true)
                            }
                        };
                        (exr, tree)
                    })
                    .collect();
                for ((k, stem, cam, _, tree_keep, _), (exr, (qt, nodes, built))) in
                    maps.drain(..).zip(encoded)
                {
                    let exr = exr?;
                    trees_kept += u64::from(!built);
                    if let (Some(dir), Some((name, key)), true) = (reads_dir, &tree_keep, built)
                        && !read_cache::keep_quadtree(dir, name, key, &qt, &mut kept_bytes)?
                    {
                        // The folder is gone: the record held is not written either.
                        reads_dir = None;
                        pending = None;
                    }
                    bytes += (exr.len() + qt.len()) as u64;
                    files.push((format!("{folder}/{stem}.exr"), "radiance-exr", exr));
                    files.push((format!("{folder}/{stem}.qtree"), "quadtree", qt));
                    cameras.push(MapEntry {
                        file: stem,
                        element: [i, j],
                        camera: k as u32,
                        nodes,
                        view: cam,
                    });
                }
                steps[3] += lap.elapsed().as_secs_f64();
                w.write_many(&files)?;
                files.clear();
            }
        }
        let lap = Instant::now();
        write_pending(pending.take())?;
        steps[2] += lap.elapsed().as_secs_f64();
        let json = CamerasFile {
            reflector: reflector.name.clone(),
            plan: *plan,
            maps: cameras,
        }
        .to_bytes();
        bytes += json.len() as u64;
        w.write(&cameras_path(&reflector.name), "radiance-cameras", &json)?;
        table.push(serde_json::json!({
            "reflector": reflector.name,
            "hemispheres": plan.elements[0] * plan.elements[1],
            "maps_per_hemisphere": plan.cameras,
            "resolution": format!("{0}x{0}", plan.resolution),
            "bytes": bytes,
        }));
    }
    if part.reads.is_some() {
        log::info!(
            "radiance maps: {shaded} of {rays} pixels traced and shaded, the rest evaluated from their records ({kept_bytes} bytes of records kept; {trees_kept} of {total} quadtrees kept with them; reading records {:.2} s, rendering {:.2} s, writing records {:.2} s, encoding {:.2} s)",
            steps[0],
            steps[1],
            steps[2],
            steps[3]
        );
    }
    let stats = BTreeMap::from([
        ("reflectors".to_string(), serde_json::Value::Array(table)),
        ("maps".into(), total.into()),
        ("rays_cast".into(), rays.into()),
    ]);
    Ok(w.commit(StageInfo {
        scene_name: scene.name.clone(),
        scene_hash: scene.content_hash.clone(),
        settings: settings_json(scene, quality, d_source.as_deref()),
        stats,
        bake_seconds: start.elapsed().as_secs_f64(),
        force,
    })?)
}

/// The node count of a quadtree file's bytes ([`quadtree::encode`]): its head's, where the
/// bytes hold that many nodes.
fn node_count(tree: &[u8]) -> Option<usize> {
    let n = u32::from_le_bytes(tree.get(12..16)?.try_into().ok()?) as usize;
    (tree.len() == 20 + 72 * n).then_some(n)
}

/// Settings as recorded in the manifest, with `d_source`: the identity of the D the maps were
/// shaded with ([`crate::bundle::StageRecord::identity`] of the radiosity stage read; for an
/// up-to-date check [`crate::radiosity::d_identity`]), so a re-baked D makes them stale.
pub fn settings_json(scene: &Scene, quality: Quality, d_source: Option<&str>) -> serde_json::Value {
    let plans: Vec<_> = plans(scene, quality)
        .iter()
        .map(|(i, _, p)| serde_json::json!({ "reflector": scene.reflectors[*i].name, "plan": p }))
        .collect();
    // `glossy_samples`: maps shaded before glossy surfaces' reflections were added hold D
    // alone, and read as stale.
    serde_json::json!({ "quality": quality.name(), "map_format": MAP_FORMAT, "quadtree": quadtree_limits(scene), "reflectors": plans, "d_source": d_source, "glossy_samples": crate::radiance::shading::GLOSSY_SAMPLES })
}

/// Mean radiance of a map's hit pixels (for reports and tests).
pub fn mean_radiance(map: &RadianceMap) -> Vec3 {
    let n = map.hit.iter().filter(|&&h| h).count().max(1);
    map.rgb
        .iter()
        .zip(&map.hit)
        .filter(|(_, h)| **h)
        .map(|(c, _)| *c)
        .sum::<Vec3>()
        / n as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The map resolution planned for each named reflector of a shipped scene at `quality`.
    fn resolutions(scene: &str, quality: Quality) -> Vec<(String, u32)> {
        let path = format!("{}/scenes/{scene}/scene.json", env!("CARGO_MANIFEST_DIR"));
        let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        plans(&scene, quality)
            .into_iter()
            .map(|(i, _, p)| (scene.reflectors[i].name.clone(), p.resolution))
            .collect()
    }

    fn resolution_of(scene: &str, reflector: &str, quality: Quality) -> u32 {
        let all = resolutions(scene, quality);
        all.iter()
            .find(|(n, _)| n == reflector)
            .unwrap_or_else(|| panic!("{scene} has no planned reflector {reflector}: {all:?}"))
            .1
    }

    /// Mirror floors seen from a little above them get maps twice as fine at every preset;
    /// mirrors seen from across a room keep the resolution from glossiness.
    #[test]
    fn mirrors_seen_magnified_get_finer_maps() {
        for scene in ["bunny-mirror", "stand-in"] {
            assert_eq!(resolution_of(scene, "MirrorFloor", Quality::Draft), 128);
            assert_eq!(resolution_of(scene, "MirrorFloor", Quality::Default), 256);
        }
        assert_eq!(
            resolution_of("glossy-room", "MirrorPanel", Quality::Default),
            128
        );
        assert_eq!(
            resolution_of("glossy-room", "MirrorPanel", Quality::Draft),
            64
        );
        assert_eq!(
            resolution_of("textured-room", "Mirror", Quality::Default),
            128
        );
    }
}
