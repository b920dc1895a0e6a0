//! `glint-bundle export`: a bundle's scene as a binary glTF an engine loads, with the
//! radiosity stage's D as lightmaps on a second UV set (docs/export.md).
//!
//! [`lightmap`] decides what a texel holds and encodes it, [`gltf_out`] builds the glTF; this
//! module reads the bundle and writes the file (a temporary file renamed into place).

pub mod gltf_out;
pub mod lightmap;

use std::path::{Path, PathBuf};

use glam::Vec3;
use serde_json::Value;

use crate::bundle::scene_read::SceneReadError;
use crate::bundle::{Bundle, BundleError};
use crate::radiosity::RadiosityMap;
use crate::radiosity::map::MapError;
use crate::scene::Scene;
use gltf_out::{Binding, Embedded};
use lightmap::{LightmapFormat, TexelDivisor};

/// What `export` writes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ExportOptions {
    /// Largest lightmap page side in texels (0: the atlas's own): larger pages are
    /// box-filtered down, keeping their aspect.
    pub max_page: u32,
    /// The lightmap encoding.
    pub format: LightmapFormat,
}

/// What an export wrote.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ExportReport {
    /// The .glb written.
    pub out: PathBuf,
    /// Its size in bytes.
    pub bytes: u64,
    /// Lightmap pages (width, height) as written.
    pub pages: Vec<(u32, u32)>,
    /// Decoded texel × scale = L.
    pub scale: f32,
    /// The encoding's name.
    pub encoding: &'static str,
    /// glint-view's `auto` exposure, recorded for engines.
    pub exposure_ev: f32,
    /// Triangles exported.
    pub triangles: usize,
}

/// Why a bundle cannot be exported. Every message names the bundle or the file.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The manifest or an asset.
    #[error("bundle {}: {source}", bundle.display())]
    Bundle {
        /// The bundle.
        bundle: PathBuf,
        /// What failed.
        #[source]
        source: BundleError,
    },
    /// A stage export needs is missing.
    #[error("bundle {}: has no `{stage}` stage; bake it with `glint-bake SCENE.json --bundle {}`", bundle.display(), bundle.display())]
    MissingStage {
        /// The bundle.
        bundle: PathBuf,
        /// The stage.
        stage: &'static str,
    },
    /// The scene stage (its message names the bundle).
    #[error(transparent)]
    Scene(#[from] SceneReadError),
    /// The radiosity stage.
    #[error("bundle {}: {source}", bundle.display())]
    Radiosity {
        /// The bundle.
        bundle: PathBuf,
        /// What failed.
        #[source]
        source: MapError,
    },
    /// The stages disagree or the scene's glTF cannot be carried over.
    #[error("bundle {}: {message}", bundle.display())]
    Inconsistent {
        /// The bundle.
        bundle: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// Reading the glTF or writing the output.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        #[source]
        source: std::io::Error,
    },
}

/// Exports the bundle at `bundle` to the binary glTF `out`.
pub fn export(
    bundle: &Path,
    out: &Path,
    opts: &ExportOptions,
) -> Result<ExportReport, ExportError> {
    let b = Bundle::open(bundle).map_err(|source| ExportError::Bundle {
        bundle: bundle.to_owned(),
        source,
    })?;
    let inconsistent = |message: String| ExportError::Inconsistent {
        bundle: bundle.to_owned(),
        message,
    };
    for stage in ["scene", "radiosity"] {
        if b.stage(stage).is_none() {
            return Err(ExportError::MissingStage {
                bundle: bundle.to_owned(),
                stage,
            });
        }
    }
    if let Some(e) = b.verify_stages(&["radiosity"]).into_iter().next() {
        return Err(ExportError::Bundle {
            bundle: bundle.to_owned(),
            source: e,
        });
    }
    let scene = b.load_scene()?;
    let scene_path = scene.path.clone();
    let map = RadiosityMap::load(&b)
        .map_err(|source| ExportError::Radiosity {
            bundle: bundle.to_owned(),
            source,
        })?
        .expect("checked above");
    if map.atlas.scene_triangles() != scene.triangles.len() {
        return Err(inconsistent(format!(
            "the atlas covers {} triangles, the scene has {}: re-bake the radiosity stage",
            map.atlas.scene_triangles(),
            scene.triangles.len()
        )));
    }

    // The scene's glTF: its JSON, binary chunk and images.
    let gltf_path = scene_path
        .parent()
        .unwrap_or(Path::new("."))
        .join(&scene.desc.geometry);
    let io = |path: &Path| {
        let path = path.to_owned();
        move |source| ExportError::Io { path, source }
    };
    let bytes = std::fs::read(&gltf_path).map_err(io(&gltf_path))?;
    let gltf = gltf::Gltf::from_slice(&bytes)
        .map_err(|e| inconsistent(format!("{}: {e}", gltf_path.display())))?;
    let source = serde_json::to_value(gltf.document.as_json())
        .map_err(|e| inconsistent(format!("{}: {e}", gltf_path.display())))?;
    let images = read_images(&gltf_path, &gltf, &source).map_err(&inconsistent)?;
    let mut materials: Vec<Value> = source
        .get("materials")
        .and_then(Value::as_array)
        .cloned()
        .unwrap_or_default();
    if scene.materials.len() > materials.len() {
        materials.push(gltf_out::default_material());
    }
    let factors: Vec<Vec3> = materials.iter().map(gltf_out::base_colour_factor).collect();

    // L per texel, then the pages encoded.
    let lm = lightmap_pages(&scene, &map, &factors);
    let mut sizes = Vec::new();
    let mut scaled = Vec::new();
    for (p, rgb) in lm.into_iter().enumerate() {
        let s = map.atlas.pages[p];
        let (w, h) = (s.width as usize, s.height as usize);
        let (nw, nh) = fit(w, h, opts.max_page as usize);
        scaled.push(if (nw, nh) == (w, h) {
            rgb
        } else {
            crate::image_io::downsample(&rgb, w, h, nw, nh)
        });
        sizes.push((nw as u32, nh as u32));
    }
    let scale = lightmap::scale_for(&scaled, opts.format.range());
    let mut pngs = Vec::new();
    for (rgb, &(w, h)) in scaled.iter().zip(&sizes) {
        let png = match opts.format {
            LightmapFormat::Rgbd => {
                let px: Vec<u8> = rgb
                    .iter()
                    .flat_map(|&c| lightmap::encode_rgbd(c / scale))
                    .collect();
                crate::image_io::encode_png(w, h, &px, true)
            }
            LightmapFormat::Srgb => {
                let px: Vec<u8> = rgb
                    .iter()
                    .flat_map(|&c| lightmap::encode_srgb(c / scale))
                    .collect();
                crate::image_io::encode_png(w, h, &px, false)
            }
        }
        .map_err(|e| inconsistent(format!("encoding a lightmap page: {e}")))?;
        pngs.push(png);
    }
    let binding = Binding {
        encoding: opts.format.name(),
        scale,
        exposure_ev: crate::view::exposure::auto_ev(&scene.triangles, &map),
    };
    let (json, bin) = gltf_out::build(
        &scene, &map.atlas, &source, &materials, images, &pngs, &binding,
    );
    let glb = gltf_out::glb(&json, &bin);
    write_atomically(out, &glb).map_err(io(out))?;
    Ok(ExportReport {
        out: out.to_owned(),
        bytes: glb.len() as u64,
        pages: sizes,
        scale,
        encoding: binding.encoding,
        exposure_ev: binding.exposure_ev,
        triangles: scene.triangles.len(),
    })
}

/// A page of `w` × `h` fitted within `max` on its longer side, aspect kept (0: unchanged).
fn fit(w: usize, h: usize, max: usize) -> (usize, usize) {
    let long = w.max(h);
    if max == 0 || long <= max {
        return (w, h);
    }
    ((w * max / long).max(1), (h * max / long).max(1))
}

/// L ([`lightmap`]) of every texel of every page.
fn lightmap_pages(scene: &Scene, map: &RadiosityMap, factors: &[Vec3]) -> Vec<Vec<Vec3>> {
    let atlas = &map.atlas;
    (0..atlas.pages.len())
        .map(|p| {
            let (w, h) = (
                atlas.pages[p].width as usize,
                atlas.pages[p].height as usize,
            );
            let factor = |t: u32| {
                let m = scene.triangles[t as usize].material as usize;
                factors.get(m).copied().unwrap_or(Vec3::ONE)
            };
            let owners = lightmap::texel_owners(atlas, p, &|t| factor(t).max_element() > 0.0);
            let stored = lightmap::bspline_at_centres(&map.pages[p], w, h);
            owners
                .iter()
                .enumerate()
                .map(|(i, &t)| {
                    if t == u32::MAX {
                        return Vec3::ZERO;
                    }
                    let c = atlas.tri_coords[t as usize];
                    let bary = lightmap::texel_bary(c, i % w, i / w);
                    let surface = scene.texel_surface(t, &c, bary);
                    let divisor = TexelDivisor {
                        factor: factor(t),
                        emission: if surface.modulation.is_some() {
                            Vec3::ZERO
                        } else {
                            surface.emission
                        },
                    };
                    divisor.lightmap(stored[i])
                })
                .collect()
        })
        .collect()
}

/// The bytes and MIME type of every image of the glTF at `path`, in order: from a buffer
/// view or from the file its URI names.
fn read_images(path: &Path, gltf: &gltf::Gltf, source: &Value) -> Result<Vec<Embedded>, String> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut buffers: Vec<Vec<u8>> = Vec::new();
    for buffer in gltf.document.buffers() {
        buffers.push(match buffer.source() {
            gltf::buffer::Source::Bin => gltf.blob.clone().unwrap_or_default(),
            gltf::buffer::Source::Uri(uri) => {
                let f = dir.join(crate::scene::gltf_uri::uri_path(uri));
                std::fs::read(&f).map_err(|e| format!("{}: {e}", f.display()))?
            }
        });
    }
    let mut out = Vec::new();
    for (i, image) in gltf.document.images().enumerate() {
        let declared = source
            .pointer(&format!("/images/{i}/mimeType"))
            .and_then(Value::as_str)
            .map(str::to_owned);
        let (bytes, name) = match image.source() {
            gltf::image::Source::View { view, .. } => {
                let data = &buffers[view.buffer().index()];
                let bytes = data
                    .get(view.offset()..view.offset() + view.length())
                    .ok_or_else(|| {
                        format!(
                            "{}: image {i}'s buffer view lies beyond its buffer",
                            path.display()
                        )
                    })?
                    .to_vec();
                (bytes, String::new())
            }
            gltf::image::Source::Uri { uri, .. } => {
                let f = dir.join(crate::scene::gltf_uri::uri_path(uri));
                let bytes = std::fs::read(&f).map_err(|e| format!("{}: {e}", f.display()))?;
                (bytes, uri.to_ascii_lowercase())
            }
        };
        let mime = match declared {
            Some(m) => m,
            None if bytes.starts_with(b"\x89PNG") || name.ends_with(".png") => "image/png".into(),
            None => "image/jpeg".into(),
        };
        out.push(Embedded { bytes, mime });
    }
    Ok(out)
}

/// Writes `bytes` to `path` through a temporary file beside it renamed into place.
fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "export.glb".into());
    let tmp = path.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
    std::fs::write(&tmp, bytes)
        .and_then(|()| std::fs::rename(&tmp, path))
        .inspect_err(|_| {
            let _ = std::fs::remove_file(&tmp);
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pages_fit_their_longer_side() {
        assert_eq!(fit(1024, 512, 0), (1024, 512));
        assert_eq!(fit(1024, 512, 256), (256, 128));
        assert_eq!(fit(100, 50, 256), (100, 50));
    }
}
