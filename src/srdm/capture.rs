//! Impostor captures (Popescu §4: "depth map impostors are constructed the same way … as
//! billboards … the texture is extended with a z channel"): the views' cameras, one ray per
//! texel against the impostor's own triangles, and the capture EXR the `srdm` stage writes
//! (R G B A half, Z float) and the viewer reads back.
//!
//! The captures' colour is [`ColourSource`]: D when the bundle's D is current
//! ([`crate::radiosity::current`]), else the diffuse albedo.

use std::path::Path;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::{BACKGROUND, DepthMap, ImpostorCamera, MIN_DEPTH, SrdmError};
use crate::bundle::BundleError;
use crate::camera::Camera;
use crate::image_io::{self, ChannelData, ExrCompression, ImageError, Precision};
use crate::progress::{Cancelled, Progress};
use crate::radiosity::RadiosityMap;
use crate::radiosity::map::MapError;
use crate::scene::{Impostor, Scene};

/// Why a capture, or the srdm stage's assets, cannot be made or read. Messages name the view
/// or asset.
#[derive(Debug, thiserror::Error)]
pub enum SrdmAssetError {
    /// Building or reading an SRDM.
    #[error("{path}: {source}")]
    Srdm {
        /// The view (or asset path) concerned.
        path: String,
        /// Cause.
        source: SrdmError,
    },
    /// Encoding or decoding a capture.
    #[error("{path}: {source}")]
    Image {
        /// The view (or asset path) concerned.
        path: String,
        /// Cause.
        source: ImageError,
    },
    /// The bundle's index or assets disagree.
    #[error("{0}")]
    Inconsistent(String),
    /// Reading the radiosity stage for colour.
    #[error(transparent)]
    Radiosity(#[from] MapError),
    /// Reading the bundle (missing asset, or one whose hash differs from the manifest's).
    #[error(transparent)]
    Bundle(#[from] BundleError),
    /// Ctrl-C.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}

/// Where the impostors' colour comes from.
pub enum ColourSource {
    /// The diffuse albedo of the hit material: unlit, used when the bundle has no D.
    Albedo,
    /// D, the baked radiosity (exitant diffuse radiance) at the hit.
    Radiosity(Box<RadiosityMap>),
}

impl ColourSource {
    /// The name recorded in the manifest (`colour`).
    pub fn name(&self) -> &'static str {
        match self {
            ColourSource::Albedo => "albedo",
            ColourSource::Radiosity(_) => "radiosity",
        }
    }

    /// The colour at barycentrics `bary` of scene triangle `triangle`, seen from its front
    /// or (`back`) from behind: D of a double-sided sheet's back is its back side's
    /// ([`crate::radiosity::sides::Sides::side`]).
    pub fn colour(&self, scene: &Scene, triangle: u32, bary: Vec2, back: bool) -> Vec3 {
        match self {
            ColourSource::Albedo => scene.albedo_at(triangle, bary),
            ColourSource::Radiosity(d) => {
                let (t, b) = d.atlas.side(triangle, bary, back);
                scene.d_at(triangle, bary, d.radiance(t, b))
            }
        }
    }
}

/// THE place the impostor colour is chosen: D when the bundle's D is current for this scene
/// ([`crate::radiosity::current_d`]), else the albedo. The choice is recorded as `colour` in
/// the stage's settings.
pub fn colour_source(bundle: &Path, scene: &Scene) -> Result<ColourSource, SrdmAssetError> {
    Ok(colour_source_read(bundle, scene)?.0)
}

/// [`colour_source`] with the identity of the D it read (none for the albedo), from the one
/// manifest the map was loaded through: a stage records it and checks it again at its commit.
pub fn colour_source_read(
    bundle: &Path,
    scene: &Scene,
) -> Result<(ColourSource, Option<String>), SrdmAssetError> {
    let current = crate::radiosity::current_d(bundle, &scene.content_hash)?;
    Ok(match current.load()? {
        Some((map, identity)) => (ColourSource::Radiosity(Box::new(map)), Some(identity)),
        None => (ColourSource::Albedo, None),
    })
}

/// The scene triangles of an impostor, in object order.
pub fn impostor_triangles(scene: &Scene, impostor: &Impostor) -> Vec<u32> {
    impostor
        .objects
        .iter()
        .flat_map(|&o| scene.objects[o as usize].triangles.clone())
        .collect()
}

/// The capture camera of view `view` of an impostor.
///
/// Views are spread evenly around the world's up axis, starting from the direction of the
/// scene's first camera keyframe as seen from the object (else +Z, glTF's front), with that
/// direction's elevation clamped to ±60°. The eye is 3 half-diagonals of the object's bounding
/// box from its centre; the field of view is the smallest that holds every vertex's projection
/// in the image's inscribed circle (so every rotated domain covers the object) plus a texel;
/// hither and yon enclose the bounding box with 1% of its depth range to spare, so every
/// foreground depth is ≥ ~0.01 (§4.1: "hither and yon planes that encompass the bounding box").
pub fn view_camera(
    scene: &Scene,
    impostor: &Impostor,
    view: u32,
    resolution: u32,
) -> ImpostorCamera {
    let b = impostor.bounds;
    let centre = b.center();
    let radius = (0.5 * b.diagonal()).max(1e-6);
    let reference = scene
        .camera_paths
        .first()
        .and_then(|p| p.keyframes.first())
        .map(|k| Vec3::from(k.position) - centre)
        .and_then(|d| d.try_normalize())
        .unwrap_or(Vec3::Z);
    let max_el = 60f32.to_radians();
    let elevation = reference.y.clamp(-1.0, 1.0).asin().clamp(-max_el, max_el);
    let azimuth = if reference.x.abs() + reference.z.abs() > 1e-6 {
        reference.x.atan2(reference.z)
    } else {
        0.0
    };
    let az = azimuth + std::f32::consts::TAU * view as f32 / impostor.views.max(1) as f32;
    let dir = Vec3::new(
        elevation.cos() * az.sin(),
        elevation.sin(),
        elevation.cos() * az.cos(),
    );
    let eye = centre + dir * (3.0 * radius);
    let mut view_cam = Camera::look_at(eye, centre, Vec3::Y, 1.0);
    let mut tan = 0.0f32;
    for &t in &impostor_triangles(scene, impostor) {
        for p in scene.triangles[t as usize].p {
            let q = p - eye;
            let z = q.dot(view_cam.forward);
            let r = Vec2::new(q.dot(view_cam.right), q.dot(view_cam.up)).length();
            tan = tan.max(r / z);
        }
    }
    let tan = tan.max(1e-6) * (1.0 + 2.0 / resolution as f32);
    view_cam.fov_y = 2.0 * tan.atan();
    let (mut z0, mut z1) = (f32::INFINITY, f32::NEG_INFINITY);
    for k in 0..8 {
        let corner = Vec3::new(
            if k & 1 == 0 { b.min.x } else { b.max.x },
            if k & 2 == 0 { b.min.y } else { b.max.y },
            if k & 4 == 0 { b.min.z } else { b.max.z },
        );
        let z = (corner - eye).dot(view_cam.forward);
        z0 = z0.min(z);
        z1 = z1.max(z);
    }
    let margin = 0.01 * (z1 - z0).max(1e-3 * radius);
    ImpostorCamera {
        view: view_cam,
        hither: z0 - margin,
        yon: z1 + margin,
        resolution,
    }
}

/// A captured view: the depth map and the colour per texel (black on background).
#[derive(Clone, Debug, PartialEq)]
pub struct Capture {
    /// The camera.
    pub camera: ImpostorCamera,
    /// Normalized 1/z per texel.
    pub depth: DepthMap,
    /// Linear colour per texel, row-major.
    pub colour: Vec<Vec3>,
}

/// Captures an impostor (§4: "depth map impostors are constructed the same way … as
/// billboards … the texture is extended with a z channel") by casting one ray through each
/// texel centre against the impostor's own triangles. Rows in parallel; deterministic.
pub fn capture(
    scene: &Scene,
    impostor: &Impostor,
    camera: &ImpostorCamera,
    colour: &ColourSource,
    progress: &dyn Progress,
) -> Result<Capture, SrdmAssetError> {
    let ids = impostor_triangles(scene, impostor);
    let bvh = scene.build_bvh_of(&ids);
    let w = camera.resolution as usize;
    let mut depth = vec![BACKGROUND; w * w];
    let mut rgb = vec![Vec3::ZERO; w * w];
    progress.phase(&format!("capture {}", impostor.name), w as u64);
    depth
        .par_chunks_mut(w)
        .zip(rgb.par_chunks_mut(w))
        .enumerate()
        .try_for_each(|(y, (drow, crow))| {
            if progress.cancelled() {
                return Err(Cancelled);
            }
            for x in 0..w {
                let dir = camera.texel_ray(x as u32, y as u32);
                if let Some(hit) = bvh.closest_hit(camera.view.position, dir, f32::INFINITY) {
                    let z = hit.t * dir.dot(camera.view.forward);
                    drow[x] = camera.depth_of_z(z).clamp(MIN_DEPTH, 1.0);
                    let t = ids[hit.triangle as usize];
                    let back = dir.dot(scene.triangles[t as usize].face_normal()) > 0.0;
                    crow[x] = colour.colour(scene, t, hit.bary, back);
                }
            }
            progress.advance(1);
            Ok(())
        })?;
    let depth = DepthMap::new(camera.resolution, depth).map_err(|source| SrdmAssetError::Srdm {
        path: impostor.name.clone(),
        source,
    })?;
    Ok(Capture {
        camera: *camera,
        depth,
        colour: rgb,
    })
}

/// The capture as an EXR: R G B A half, Z float (see the module docs).
pub fn encode_capture(c: &Capture) -> Result<Vec<u8>, ImageError> {
    let w = c.camera.resolution as usize;
    let split = |k: usize| c.colour.iter().map(|v| v[k]).collect::<Vec<f32>>();
    let (r, g, b) = (split(0), split(1), split(2));
    let texels = c.depth.texels();
    let a: Vec<f32> = texels.iter().map(|d| f32::from(*d >= 0.0)).collect();
    let z: Vec<f32> = texels.iter().map(|d| d.max(0.0)).collect();
    let ch = |name, precision, samples| ChannelData {
        name,
        precision,
        samples,
    };
    image_io::encode_exr(
        w,
        w,
        &[
            ch("R", Precision::Half, &r),
            ch("G", Precision::Half, &g),
            ch("B", Precision::Half, &b),
            ch("A", Precision::Half, &a),
            ch("Z", Precision::Float, &z),
        ],
        ExrCompression::Zip16,
    )
}

/// Reads a capture written by [`encode_capture`]; `camera` comes from the view's `.srdm`.
pub fn decode_capture(bytes: &[u8], camera: ImpostorCamera) -> Result<Capture, SrdmAssetError> {
    let img = image_io::decode_exr(bytes).map_err(|source| SrdmAssetError::Image {
        path: "capture".into(),
        source,
    })?;
    let w = camera.resolution as usize;
    if (img.width, img.height) != (w, w) {
        return Err(SrdmAssetError::Inconsistent(format!(
            "the capture is {}×{} texels, its SRDM {w}×{w}",
            img.width, img.height
        )));
    }
    let shape = |source| SrdmAssetError::Image {
        path: "capture".into(),
        source,
    };
    let colour = img.rgb().map_err(shape)?;
    let (a, z) = (
        img.channel("A").map_err(shape)?,
        img.channel("Z").map_err(shape)?,
    );
    let depth = a
        .iter()
        .zip(z)
        .map(|(a, z)| if *a > 0.5 { *z } else { BACKGROUND })
        .collect();
    let depth = DepthMap::new(camera.resolution, depth).map_err(|source| SrdmAssetError::Srdm {
        path: "capture".into(),
        source,
    })?;
    Ok(Capture {
        camera,
        depth,
        colour,
    })
}
