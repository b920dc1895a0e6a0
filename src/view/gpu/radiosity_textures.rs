//! D on the GPU: the atlas pages of a radiosity map in one `Rgba16Float` 2D texture array,
//! every layer the size of the largest page; smaller pages are padded by repeating their edge
//! texels, so the clamp-to-edge sampler behaves at a page's edge exactly as the CPU's clamped
//! lookups do.

use exr::prelude::f16;
use glam::Vec3;

use super::surface_textures::SurfaceTextures;
use super::target::HDR_FORMAT;
use crate::radiosity::RadiosityMap;
use crate::scene::Scene;

use super::{Gpu, RenderError, check_array_size, error_scoped};

/// The radiosity pages on the GPU: a texture array with its sampler.
pub struct RadiosityTextures {
    /// The `Rgba16Float` texture array, one layer per page.
    pub texture: wgpu::Texture,
    pub(crate) view: wgpu::TextureView,
    pub(crate) sampler: wgpu::Sampler,
    /// Layer size in texels (the largest page's width and height).
    pub layer_size: [u32; 2],
    /// The scene's textures and material records (a placeholder without a scene).
    pub(crate) surfaces: SurfaceTextures,
}

impl RadiosityTextures {
    /// Uploads every page of `map`, padded to the largest page by repeating edge texels; no
    /// surface textures (D is drawn as stored).
    pub fn upload(gpu: &Gpu, map: &RadiosityMap) -> Result<RadiosityTextures, RenderError> {
        Self::upload_for(gpu, map, None)
    }

    /// [`RadiosityTextures::upload`] with `scene`'s textures, which the scene pass multiplies
    /// in at full resolution ([`super::surface_textures`]).
    pub fn upload_for(
        gpu: &Gpu,
        map: &RadiosityMap,
        scene: Option<&Scene>,
    ) -> Result<RadiosityTextures, RenderError> {
        let surfaces = SurfaceTextures::upload(gpu, scene)?;
        let pages = &map.atlas.pages;
        let width = pages.iter().map(|p| p.width).max().unwrap_or(1).max(1);
        let height = pages.iter().map(|p| p.height).max().unwrap_or(1).max(1);
        let layers = (pages.len() as u32).max(1);
        check_array_size(gpu, width, height, layers)?;
        let textures = error_scoped(&gpu.device, "uploading the radiosity textures", || {
            let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("glint radiosity pages"),
                size: wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: layers,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: HDR_FORMAT,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            });
            for (layer, (size, texels)) in pages.iter().zip(&map.pages).enumerate() {
                let bytes = padded_layer(texels, size.width, size.height, width, height);
                gpu.queue.write_texture(
                    wgpu::TexelCopyTextureInfo {
                        texture: &texture,
                        mip_level: 0,
                        origin: wgpu::Origin3d {
                            x: 0,
                            y: 0,
                            z: layer as u32,
                        },
                        aspect: wgpu::TextureAspect::All,
                    },
                    bytemuck::cast_slice(&bytes),
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(width * 8),
                        rows_per_image: Some(height),
                    },
                    wgpu::Extent3d {
                        width,
                        height,
                        depth_or_array_layers: 1,
                    },
                );
            }
            let view = texture.create_view(&wgpu::TextureViewDescriptor {
                label: Some("glint radiosity pages view"),
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                ..Default::default()
            });
            let sampler = gpu.device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("glint radiosity sampler"),
                address_mode_u: wgpu::AddressMode::ClampToEdge,
                address_mode_v: wgpu::AddressMode::ClampToEdge,
                address_mode_w: wgpu::AddressMode::ClampToEdge,
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                mipmap_filter: wgpu::MipmapFilterMode::Nearest,
                ..Default::default()
            });
            RadiosityTextures {
                texture,
                view,
                sampler,
                layer_size: [width, height],
                surfaces,
            }
        })?;
        Ok(textures)
    }
}

/// A page as half-float RGBA texels, `layer_w` × `layer_h`, edge texels repeated beyond the
/// page. An empty or short page gives black.
fn padded_layer(texels: &[Vec3], w: u32, h: u32, layer_w: u32, layer_h: u32) -> Vec<u16> {
    let mut out = Vec::with_capacity((layer_w * layer_h * 4) as usize);
    let one = f16::from_f32(1.0).to_bits();
    for y in 0..layer_h {
        for x in 0..layer_w {
            let v = if w == 0 || h == 0 {
                Vec3::ZERO
            } else {
                let (xi, yi) = (x.min(w - 1) as usize, y.min(h - 1) as usize);
                texels
                    .get(yi * w as usize + xi)
                    .copied()
                    .unwrap_or(Vec3::ZERO)
            };
            out.extend(v.to_array().map(|c| f16::from_f32(c).to_bits()));
            out.push(one);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layers_are_padded_by_repeating_edges() {
        let texels = [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(3.0, 0.0, 0.0),
            Vec3::new(4.0, 0.0, 0.0),
        ];
        let out = padded_layer(&texels, 2, 2, 3, 3);
        let red: Vec<f32> = out
            .chunks(4)
            .map(|t| f16::from_bits(t[0]).to_f32())
            .collect();
        assert_eq!(red, [1.0, 2.0, 2.0, 3.0, 4.0, 4.0, 3.0, 4.0, 4.0]);
    }
}
