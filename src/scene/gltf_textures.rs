//! Reads a glTF material's textures and alpha settings: `baseColorTexture` and
//! `emissiveTexture` (sampler, `texCoord`, `KHR_texture_transform`), `alphaMode`,
//! `alphaCutoff` and `doubleSided`. Images are decoded once each (PNG or JPEG, by the `image`
//! crate) into [`Image`]s that materials refer to by index.

use std::collections::HashMap;
use std::path::Path;

use glam::Vec2;

use super::gltf_uri::uri_path;
use super::material::{AlphaMode, Material, TextureRef};
use super::texture::{Filter, Image, Sampler, UvTransform, Wrap};

/// Largest image side read (16384: what GPUs can hold in one texture).
pub const MAX_IMAGE_SIDE: u32 = 16384;

/// The images materials use, decoded, and how each glTF image maps to them.
#[derive(Default)]
pub struct Textures {
    /// Decoded images, in order of first use.
    pub images: Vec<Image>,
    /// glTF image index → index in `images`.
    by_gltf: HashMap<usize, u32>,
    /// Image files read (external URIs), for the content hash.
    pub hashed_bytes: Vec<Vec<u8>>,
    /// Whether a BLEND material was read as MASK (said once).
    blend_noted: bool,
}

/// `material 3 "Name"` for messages.
fn material_label(m: &gltf::Material) -> String {
    match (m.index(), m.name()) {
        (Some(i), Some(n)) => format!("material {i} \"{n}\""),
        (Some(i), None) => format!("material {i}"),
        (None, _) => "the default material".into(),
    }
}

impl Textures {
    /// Sets the texture, alpha and double-sided fields of `out` from glTF material `m`;
    /// `buffers` are the file's buffers and `dir` the glTF file's folder. Errors name the
    /// material, the texture slot, the texture and the image.
    pub fn read_material(
        &mut self,
        path: &Path,
        dir: &Path,
        buffers: &[Vec<u8>],
        m: &gltf::Material,
        out: &mut Material,
    ) -> Result<(), String> {
        let label = material_label(m);
        if let Some(info) = m.pbr_metallic_roughness().base_color_texture() {
            out.base_texture = Some(
                self.texture_ref(dir, buffers, &info)
                    .map_err(|e| format!("{label}: baseColorTexture: {e}"))?,
            );
        }
        if let Some(info) = m.emissive_texture() {
            out.emissive_texture = Some(
                self.texture_ref(dir, buffers, &info)
                    .map_err(|e| format!("{label}: emissiveTexture: {e}"))?,
            );
        }
        out.double_sided = m.double_sided();
        out.alpha_mode = match m.alpha_mode() {
            gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            gltf::material::AlphaMode::Mask => {
                let cutoff = m.alpha_cutoff().unwrap_or(0.5);
                if !(cutoff.is_finite() && cutoff >= 0.0) {
                    return Err(format!(
                        "{label}: alphaCutoff {cutoff} is not a finite number ≥ 0"
                    ));
                }
                AlphaMode::Mask { cutoff }
            }
            gltf::material::AlphaMode::Blend => {
                if !std::mem::replace(&mut self.blend_noted, true) {
                    log::info!(
                        "{}: alphaMode BLEND ({label} and any others) is read as MASK with cutoff 0.5: rays pass where alpha < 0.5, glint has no partial transparency",
                        path.display()
                    );
                }
                AlphaMode::Mask { cutoff: 0.5 }
            }
        };
        Ok(())
    }

    /// The [`TextureRef`] of a material's texture slot, decoding its image on first use.
    fn texture_ref(
        &mut self,
        dir: &Path,
        buffers: &[Vec<u8>],
        info: &gltf::texture::Info,
    ) -> Result<TextureRef, String> {
        let texture = info.texture();
        let t_label = format!("texture {}", texture.index());
        let transform = info.texture_transform();
        let tex_coord = transform
            .as_ref()
            .and_then(|t| t.tex_coord())
            .unwrap_or(info.tex_coord());
        if tex_coord > 1 {
            return Err(format!(
                "{t_label}: texCoord {tex_coord}: glint reads TEXCOORD_0 and TEXCOORD_1 only"
            ));
        }
        let transform = match transform {
            Some(t) => {
                let tr = UvTransform {
                    offset: Vec2::from(t.offset()),
                    rotation: t.rotation(),
                    scale: Vec2::from(t.scale()),
                };
                if !(tr.offset.is_finite() && tr.rotation.is_finite() && tr.scale.is_finite()) {
                    return Err(format!(
                        "{t_label}: KHR_texture_transform has a value that is not finite"
                    ));
                }
                tr
            }
            None => UvTransform::default(),
        };
        let s = texture.sampler();
        let wrap = |w: gltf::texture::WrappingMode| match w {
            gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
            gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
            gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        };
        let sampler = Sampler {
            wrap_u: wrap(s.wrap_s()),
            wrap_v: wrap(s.wrap_t()),
            filter: match s.mag_filter() {
                Some(gltf::texture::MagFilter::Nearest) => Filter::Nearest,
                _ => Filter::Linear,
            },
        };
        let image = texture.source();
        let index = match self.by_gltf.get(&image.index()) {
            Some(&i) => i,
            None => {
                let decoded = self
                    .decode(dir, buffers, &image)
                    .map_err(|e| format!("{t_label}: {e}"))?;
                let i = self.images.len() as u32;
                self.images.push(decoded);
                self.by_gltf.insert(image.index(), i);
                i
            }
        };
        Ok(TextureRef {
            image: index,
            sampler,
            tex_coord,
            transform,
        })
    }

    /// Decodes glTF image `image` (from a buffer view or an external file) to RGBA8.
    fn decode(
        &mut self,
        dir: &Path,
        buffers: &[Vec<u8>],
        image: &gltf::image::Image,
    ) -> Result<Image, String> {
        let i_label = match image.name() {
            Some(n) => format!("image {} \"{n}\"", image.index()),
            None => format!("image {}", image.index()),
        };
        let bytes: Vec<u8> = match image.source() {
            gltf::image::Source::View { view, .. } => {
                let data = &buffers[view.buffer().index()];
                let end = view.offset() + view.length();
                data.get(view.offset()..end)
                    .ok_or_else(|| {
                        format!(
                            "{i_label}: buffer view {} lies beyond its buffer",
                            view.index()
                        )
                    })?
                    .to_vec()
            }
            gltf::image::Source::Uri { uri, .. } if uri.starts_with("data:") => {
                return Err(format!(
                    "{i_label} is an embedded data: URI; glint reads images from a .glb's buffer views or external files"
                ));
            }
            gltf::image::Source::Uri { uri, .. } => {
                let file = dir.join(uri_path(uri));
                let meta = std::fs::metadata(&file)
                    .map_err(|e| format!("{i_label}: {}: {e}", file.display()))?;
                if !meta.is_file() {
                    return Err(format!("{i_label}: {} is not a file", file.display()));
                }
                let data = std::fs::read(&file)
                    .map_err(|e| format!("{i_label}: {}: {e}", file.display()))?;
                self.hashed_bytes.push(data.clone());
                data
            }
        };
        decode_image(&bytes).map_err(|e| format!("{i_label}: {e}"))
    }
}

/// Decodes PNG or JPEG bytes to RGBA8 (16-bit channels are rounded to 8 bits; grey and
/// grey-alpha images are expanded).
pub fn decode_image(bytes: &[u8]) -> Result<Image, String> {
    let format = image::guess_format(bytes)
        .map_err(|_| "not a PNG or JPEG image (glint decodes these two)".to_string())?;
    if !matches!(format, image::ImageFormat::Png | image::ImageFormat::Jpeg) {
        return Err(format!(
            "a {format:?} image; glint decodes PNG and JPEG (KTX2/WebP extensions are not read)"
        ));
    }
    let mut reader = image::ImageReader::with_format(std::io::Cursor::new(bytes), format);
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIDE);
    limits.max_image_height = Some(MAX_IMAGE_SIDE);
    reader.limits(limits);
    let img = reader.decode().map_err(|e| e.to_string())?.to_rgba8();
    let (width, height) = img.dimensions();
    if width == 0 || height == 0 {
        return Err("the image is empty".into());
    }
    let texels = img.pixels().map(|p| p.0).collect();
    Ok(Image {
        width,
        height,
        texels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn png(width: u32, height: u32, texels: &[[u8; 4]]) -> Vec<u8> {
        let mut img = image::RgbaImage::new(width, height);
        for (p, t) in img.pixels_mut().zip(texels) {
            p.0 = *t;
        }
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Png).unwrap();
        out.into_inner()
    }

    #[test]
    fn png_decodes_to_its_texels() {
        let texels = [[1, 2, 3, 4], [250, 128, 0, 255]];
        let img = decode_image(&png(2, 1, &texels)).unwrap();
        assert_eq!((img.width, img.height), (2, 1));
        assert_eq!(img.texels, texels.to_vec());
    }

    #[test]
    fn garbage_is_an_error_that_says_what_is_read() {
        let e = decode_image(b"not an image at all").unwrap_err();
        assert!(e.contains("PNG or JPEG"), "{e}");
        let mut bad = png(2, 2, &[[0; 4]; 4]);
        bad.truncate(40);
        assert!(decode_image(&bad).is_err());
    }
}
