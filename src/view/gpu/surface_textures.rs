//! The scene's textures on the GPU, for the fragment shader's D(x) = Q · t(x) + E(x)
//! ([`crate::scene::texturing`]): every image in one `Rgba8UnormSrgb` 2D texture array (each
//! in its own layer at its own size from the corner, level 0 at full resolution, level k its
//! level k of [`crate::scene::texture::mips`] from the same corner), and one
//! [`MaterialRecord`] per material saying which layer its base colour and emissive textures
//! are, with their samplers and transforms. The shader filters by hand with `textureLoad`
//! (wrap modes and bilinear weights exactly as [`crate::scene::texture::Image::sample`] within
//! a level; anisotropic over the levels, as [`crate::scene::texture::mips::sample_anisotropic`]).

use bytemuck::{Pod, Zeroable};

use super::build::buffer_init;
use super::{Gpu, RenderError, error_scoped};
use crate::scene::Scene;
use crate::scene::material::{AlphaMode, TextureRef};
use crate::scene::texture::mips::{level_count, mip_chain};
use crate::scene::texture::{Filter, Image, Wrap};

/// Set to `0`, the textures are uploaded without their mip chains (level 0 alone: every
/// texture sampled at full resolution), to measure what the levels cost and change.
pub const TEXTURE_MIPS_ENV: &str = "GLINT_VIEW_TEXTURE_MIPS";

/// One texture slot of a material (48 bytes; `TexRef` in `shaders/view.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct TexRecord {
    /// Layer (−1: no texture), width, height, UV set.
    pub a: [f32; 4],
    /// Wrap u, wrap v (0 repeat, 1 mirrored repeat, 2 clamp), nearest (1) or linear (0),
    /// rotation in radians.
    pub b: [f32; 4],
    /// Offset u, v, scale u, v.
    pub c: [f32; 4],
}

/// A material as the shader sees it (128 bytes; `MaterialRecord` in `shaders/view.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct MaterialRecord {
    /// Base colour texture (none: D is drawn as stored).
    pub base: TexRecord,
    /// Emissive texture.
    pub emissive: TexRecord,
    /// Emission factor (RGB, w unused).
    pub emission: [f32; 4],
    /// Alpha MASK: cutoff (< 0: opaque), alpha factor, layer of the texture whose alpha
    /// counts (< 0: the factor alone), unused; the texture is `cutout`.
    pub alpha: [f32; 4],
    /// The base colour texture for the alpha test (also for a material whose D is stored
    /// as is).
    pub cutout: TexRecord,
}

const NONE: TexRecord = TexRecord {
    a: [-1.0, 1.0, 1.0, 0.0],
    b: [0.0; 4],
    c: [0.0, 0.0, 1.0, 1.0],
};

fn wrap(w: Wrap) -> f32 {
    match w {
        Wrap::Repeat => 0.0,
        Wrap::MirroredRepeat => 1.0,
        Wrap::ClampToEdge => 2.0,
    }
}

fn record(scene: &Scene, t: Option<&TextureRef>) -> TexRecord {
    let Some(t) = t else { return NONE };
    let img = &scene.textures[t.image as usize];
    TexRecord {
        a: [
            t.image as f32,
            img.width as f32,
            img.height as f32,
            t.tex_coord as f32,
        ],
        b: [
            wrap(t.sampler.wrap_u),
            wrap(t.sampler.wrap_v),
            if t.sampler.filter == Filter::Nearest {
                1.0
            } else {
                0.0
            },
            t.transform.rotation,
        ],
        c: [
            t.transform.offset.x,
            t.transform.offset.y,
            t.transform.scale.x,
            t.transform.scale.y,
        ],
    }
}

/// A material drawn as stored, opaque.
const PLAIN: MaterialRecord = MaterialRecord {
    base: NONE,
    emissive: NONE,
    emission: [0.0; 4],
    alpha: [-1.0, 1.0, -1.0, 0.0],
    cutout: NONE,
};

/// The records of `scene`'s materials, in material order. A material without a base colour
/// texture gets none for either colour slot: its texels hold D itself (see
/// `scene::texturing`); a MASK material's cut-out test reads its base colour alpha.
pub fn material_records(scene: &Scene) -> Vec<MaterialRecord> {
    let mut out: Vec<MaterialRecord> = scene
        .materials
        .iter()
        .map(|m| {
            let mut r = match &m.base_texture {
                None => PLAIN,
                Some(base) => MaterialRecord {
                    base: record(scene, Some(base)),
                    emissive: record(scene, m.emissive_texture.as_ref()),
                    emission: m.emission.extend(0.0).to_array(),
                    ..PLAIN
                },
            };
            if let AlphaMode::Mask { cutoff } = m.alpha_mode {
                r.cutout = record(scene, m.base_texture.as_ref());
                r.alpha = [cutoff, m.alpha_factor, r.cutout.a[0], 0.0];
            }
            r
        })
        .collect();
    if out.is_empty() {
        out.push(PLAIN);
    }
    out
}

/// The textures and material records on the GPU.
pub struct SurfaceTextures {
    pub(crate) view: wgpu::TextureView,
    pub(crate) materials: wgpu::Buffer,
}

impl SurfaceTextures {
    /// Uploads `scene`'s images and material records (`None`: a placeholder, every material
    /// untextured).
    pub fn upload(gpu: &Gpu, scene: Option<&Scene>) -> Result<SurfaceTextures, RenderError> {
        let images = scene.map_or(&[][..], |s| s.textures.as_slice());
        let width = images.iter().map(|i| i.width).max().unwrap_or(1);
        let height = images.iter().map(|i| i.height).max().unwrap_or(1);
        let layers = (images.len() as u32).max(1);
        super::check_array_size(gpu, width, height, layers).map_err(|e| match e {
            RenderError::AtlasTooLarge {
                width,
                height,
                layers,
                max_side,
                max_layers,
            } => RenderError::TexturesTooLarge {
                width,
                height,
                layers,
                max_side,
                max_layers,
            },
            e => e,
        })?;
        let records = match scene {
            Some(s) => material_records(s),
            None => vec![PLAIN],
        };
        let mips = std::env::var_os(TEXTURE_MIPS_ENV).is_none_or(|v| v != "0");
        let level_count = if mips { level_count(width, height) } else { 1 };
        let chains: Vec<Vec<Image>> = if mips {
            images.iter().map(mip_chain).collect()
        } else {
            vec![Vec::new(); images.len()]
        };
        error_scoped(&gpu.device, "uploading the scene's textures", || {
            let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("glint surface textures"),
                size: wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: layers,
                },
                mip_level_count: level_count,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Rgba8UnormSrgb,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            });
            let levels =
                images
                    .iter()
                    .zip(&chains)
                    .enumerate()
                    .flat_map(|(layer, (img, chain))| {
                        std::iter::once(img)
                            .chain(chain)
                            .enumerate()
                            .map(move |(level, img)| (layer, level as u32, img))
                    });
            for (layer, level, img) in levels {
                gpu.queue.write_texture(
                    wgpu::TexelCopyTextureInfo {
                        texture: &texture,
                        mip_level: level,
                        origin: wgpu::Origin3d {
                            x: 0,
                            y: 0,
                            z: layer as u32,
                        },
                        aspect: wgpu::TextureAspect::All,
                    },
                    bytemuck::cast_slice(&img.texels),
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(img.width * 4),
                        rows_per_image: Some(img.height),
                    },
                    wgpu::Extent3d {
                        width: img.width,
                        height: img.height,
                        depth_or_array_layers: 1,
                    },
                );
            }
            let view = texture.create_view(&wgpu::TextureViewDescriptor {
                label: Some("glint surface textures view"),
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                ..Default::default()
            });
            let materials = buffer_init(
                gpu,
                "glint material records",
                wgpu::BufferUsages::STORAGE,
                bytemuck::cast_slice(&records),
                std::mem::size_of::<MaterialRecord>() as u64,
            );
            SurfaceTextures { view, materials }
        })
        .map_err(RenderError::from)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::view::passes::renderer::SHADER_SOURCE;

    #[test]
    fn records_match_the_wgsl_structs() {
        crate::assert_wgsl_layout!(SHADER_SOURCE, "TexRef", TexRecord { a, b, c });
        crate::assert_wgsl_layout!(
            SHADER_SOURCE,
            "MaterialRecord",
            MaterialRecord {
                base,
                emissive,
                emission,
                alpha,
                cutout
            }
        );
    }
}
