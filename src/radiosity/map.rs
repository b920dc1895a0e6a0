//! D at any surface point: the baked radiosity textures looked up through the atlas.
//! Used by every stage that shades ray hits (radiance maps, environment maps, impostors)
//! and by the viewer's CPU reference.

use glam::{Vec2, Vec3};

use super::atlas::{Atlas, floor};
use super::format::{self, AtlasFormatError};
use crate::bundle::{Bundle, BundleError};
use crate::image_io::{self, ImageError};

/// Why the radiosity stage of a bundle cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum MapError {
    /// Reading an asset.
    #[error(transparent)]
    Bundle(#[from] BundleError),
    /// The atlas file.
    #[error("{path}: {source}")]
    Atlas {
        /// Asset path.
        path: String,
        /// Cause.
        source: AtlasFormatError,
    },
    /// A page image.
    #[error("{path}: {source}")]
    Page {
        /// Asset path.
        path: String,
        /// Cause.
        source: ImageError,
    },
    /// Assets disagree with each other.
    #[error("{0}")]
    Inconsistent(String),
}

/// The radiosity textures of a bundle with their atlas.
pub struct RadiosityMap {
    /// Per-triangle lightmap coordinates.
    pub atlas: Atlas,
    /// Exitant radiance per texel, one array per page (row-major, row 0 at the top).
    pub pages: Vec<Vec<Vec3>>,
}

impl RadiosityMap {
    /// Loads the bundle's radiosity stage; `Ok(None)` when the bundle has none.
    pub fn load(bundle: &Bundle) -> Result<Option<RadiosityMap>, MapError> {
        let Some(stage) = bundle.stage("radiosity") else {
            return Ok(None);
        };
        let atlas_rec = stage
            .assets
            .iter()
            .find(|a| a.kind == "atlas")
            .ok_or_else(|| {
                MapError::Inconsistent(format!(
                    "{}: radiosity stage has no atlas",
                    bundle.dir().display()
                ))
            })?;
        let atlas =
            format::decode(&bundle.read_asset(atlas_rec)?).map_err(|source| MapError::Atlas {
                path: atlas_rec.path.clone(),
                source,
            })?;
        let mut pages = Vec::new();
        for (i, rec) in stage
            .assets
            .iter()
            .filter(|a| a.kind == "radiosity-exr")
            .enumerate()
        {
            let img = image_io::decode_exr(&bundle.read_asset(rec)?).map_err(|source| {
                MapError::Page {
                    path: rec.path.clone(),
                    source,
                }
            })?;
            let size = atlas.pages.get(i).ok_or_else(|| {
                MapError::Inconsistent(format!("{}: more pages than the atlas lists", rec.path))
            })?;
            if (img.width, img.height) != (size.width as usize, size.height as usize) {
                return Err(MapError::Inconsistent(format!(
                    "{}: {}×{} texels, the atlas says {}×{}",
                    rec.path, img.width, img.height, size.width, size.height
                )));
            }
            pages.push(img.rgb().map_err(|source| MapError::Page {
                path: rec.path.clone(),
                source,
            })?);
        }
        if pages.len() != atlas.pages.len() {
            return Err(MapError::Inconsistent(format!(
                "{}: {} radiosity pages, the atlas lists {}",
                bundle.dir().display(),
                pages.len(),
                atlas.pages.len()
            )));
        }
        Ok(Some(RadiosityMap { atlas, pages }))
    }

    /// A map of a solution held in memory: `radiance` per global atlas texel, pages in order
    /// (what [`super::solve::solve`] returns), at full f32 precision.
    pub fn from_texels(atlas: Atlas, radiance: &[Vec3]) -> RadiosityMap {
        let mut offset = 0;
        let pages = atlas
            .pages
            .iter()
            .map(|p| {
                let n = (p.width * p.height) as usize;
                offset += n;
                radiance[offset - n..offset].to_vec()
            })
            .collect();
        RadiosityMap { atlas, pages }
    }

    /// D (exitant radiance) at barycentrics `bary` of `triangle`, bilinearly filtered.
    pub fn radiance(&self, triangle: u32, bary: Vec2) -> Vec3 {
        let t = triangle as usize;
        let page = self.atlas.tri_page[t] as usize;
        let c = &self.atlas.tri_coords[t];
        let p = c[0] * (1.0 - bary.x - bary.y) + c[1] * bary.x + c[2] * bary.y;
        bilinear(
            &self.pages[page],
            self.atlas.pages[page].width,
            self.atlas.pages[page].height,
            p,
        )
    }
}

/// Bilinear lookup at continuous texel coordinates (texel centres at i + 0.5), clamped.
pub fn bilinear(texels: &[Vec3], width: u32, height: u32, p: Vec2) -> Vec3 {
    let q = p - Vec2::splat(0.5);
    let (x0, y0) = (floor(q.x), floor(q.y));
    let (fx, fy) = (q.x - x0, q.y - y0);
    let at = |x: f32, y: f32| {
        let xi = (x as i64).clamp(0, width as i64 - 1) as usize;
        let yi = (y as i64).clamp(0, height as i64 - 1) as usize;
        texels[yi * width as usize + xi]
    };
    let top = at(x0, y0).lerp(at(x0 + 1.0, y0), fx);
    let bottom = at(x0, y0 + 1.0).lerp(at(x0 + 1.0, y0 + 1.0), fx);
    top.lerp(bottom, fy)
}

/// Cubic B-spline weights of the four texels around a sample whose fractional position past
/// the second texel's centre is `f` ∈ [0, 1]. They sum to 1 and are all ≥ 0. The viewer
/// reconstructs D with this filter (`view::bicubic`, `shaders/view.wgsl`).
pub fn bspline_weights(f: f32) -> [f32; 4] {
    let g = 1.0 - f;
    let (f2, f3) = (f * f, f * f * f);
    [
        g * g * g / 6.0,
        (4.0 - 6.0 * f2 + 3.0 * f3) / 6.0,
        (1.0 + 3.0 * f + 3.0 * f2 - 3.0 * f3) / 6.0,
        f3 / 6.0,
    ]
}
