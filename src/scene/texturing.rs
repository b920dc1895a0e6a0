//! Textured surfaces as every stage sees them: albedo, emission and alpha at a surface
//! point; a lightmap texel's albedo and emission averaged over its footprint; the quantity the
//! radiosity textures store for textured materials; and the cut-out test rays use.
//!
//! **What a lightmap texel stores.** For a material without a base colour texture a texel
//! holds D, the exitant radiance (emission + reflection; an emissive texture enters as its
//! mean over the texel's footprint). For a material with a base colour texture it holds the
//! reflected part of D divided by that texture's mean over the texel's footprint, t̄ (the
//! texture alone, not the factor):
//!
//! ```text
//! Q = (D − Ē) / t̄ = k_d factor × irradiance / π,      D(x) = Q · t(x) + E(x)
//! ```
//!
//! where t(x) is the base colour texture's linear RGB at x and E(x) the emission there
//! (factor × emissive texture). This is the "D / albedo" engines store (here D over the
//! texture's part of the albedo), so every stage that shades a hit multiplies by the
//! full-resolution texture and shows detail finer than the lightmap ([`Scene::d_at`]). It is
//! also exactly what a glint that ignored textures stored (k_d was the factor alone), so
//! bundles baked before textures were read stay valid. The solve itself uses t̄ (the texel's
//! albedo is the factor × t̄) and Ē (the footprint mean of E).

use std::sync::Arc;

use glam::{Mat2, Vec2, Vec3, Vec4};

use super::Scene;
use super::material::{AlphaMode, Material, TextureRef};
use super::texture::Image;
use super::texture::mips::{mip_chain, sample_anisotropic};
use crate::geometry::Triangle;

/// A texture's coordinate at barycentrics `b` of `tri` (its UV set, then its transform).
pub fn texture_uv(t: &TextureRef, tri: &Triangle, b: Vec2) -> Vec2 {
    let uv = match t.tex_coord {
        0 => tri.uv_at(b),
        _ => tri.uv1_at(b).unwrap_or(Vec2::ZERO),
    };
    t.transform.apply(uv)
}

/// The texture's UV set's vertex coordinates on `tri` (untransformed).
fn uv_set(t: &TextureRef, tri: &Triangle) -> [Vec2; 3] {
    match t.tex_coord {
        0 => tri.uv,
        _ => tri.uv1.unwrap_or([Vec2::ZERO; 3]),
    }
}

/// Linear RGBA of texture `t` at barycentrics `b` of `tri`.
pub fn sample_at(images: &[Image], t: &TextureRef, tri: &Triangle, b: Vec2) -> Vec4 {
    images[t.image as usize].sample(&t.sampler, texture_uv(t, tri, b))
}

/// The mean of texture `t` over the footprint of the lightmap texel at barycentrics `b` of
/// `tri`, whose vertices lie at `lm` in lightmap texel units: the texel's unit square mapped
/// to texture space through the triangle's affine map from lightmap to texture coordinates.
/// A triangle degenerate in either layout gives the value at the point.
pub fn footprint_mean(
    images: &[Image],
    t: &TextureRef,
    tri: &Triangle,
    lm: &[Vec2; 3],
    b: Vec2,
) -> Vec4 {
    let image = &images[t.image as usize];
    let centre = texture_uv(t, tri, b);
    let uv = uv_set(t, tri);
    let l = Mat2::from_cols(lm[1] - lm[0], lm[2] - lm[0]);
    let det = l.determinant();
    if !(det.is_finite() && det.abs() > 1e-12) {
        return image.sample(&t.sampler, centre);
    }
    let j = Mat2::from_cols(uv[1] - uv[0], uv[2] - uv[0]) * l.inverse();
    let a = t.transform.linear(j * Vec2::X);
    let c = t.transform.linear(j * Vec2::Y);
    if !(a.is_finite() && c.is_finite()) {
        return image.sample(&t.sampler, centre);
    }
    image.footprint_mean(&t.sampler, centre, a, c)
}

/// What the solve needs of one lightmap element.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TexelSurface {
    /// Diffuse albedo over the texel (factor × t̄).
    pub albedo: Vec3,
    /// Emission over the texel (factor × the emissive texture's footprint mean).
    pub emission: Vec3,
    /// t̄, the base colour texture's footprint mean, for a material with one; `None` for
    /// others (their texel stores D itself).
    pub modulation: Option<Vec3>,
}

impl Scene {
    /// The material of triangle `triangle`.
    pub fn material_of(&self, triangle: u32) -> &Material {
        &self.materials[self.triangles[triangle as usize].material as usize]
    }

    /// Diffuse albedo at barycentrics `b` of `triangle`: the material's, times its base colour
    /// texture's RGB there.
    pub fn albedo_at(&self, triangle: u32, b: Vec2) -> Vec3 {
        let tri = &self.triangles[triangle as usize];
        let m = &self.materials[tri.material as usize];
        match &m.base_texture {
            None => m.albedo,
            Some(t) => m.albedo * sample_at(&self.textures, t, tri, b).truncate(),
        }
    }

    /// Emitted radiance at barycentrics `b` of `triangle`: the material's, times its emissive
    /// texture's RGB there.
    pub fn emission_at(&self, triangle: u32, b: Vec2) -> Vec3 {
        let tri = &self.triangles[triangle as usize];
        let m = &self.materials[tri.material as usize];
        match &m.emissive_texture {
            None => m.emission,
            Some(t) => m.emission * sample_at(&self.textures, t, tri, b).truncate(),
        }
    }

    /// Whether a ray meeting `triangle` at `b` passes through it (alpha MASK below cutoff).
    pub fn is_cut_out(&self, triangle: u32, b: Vec2) -> bool {
        let tri = &self.triangles[triangle as usize];
        cut_out(
            &self.textures,
            &self.materials[tri.material as usize],
            tri,
            b,
        )
    }

    /// D at barycentrics `b` of `triangle` from `stored`, the radiosity texture's value
    /// there: `stored` itself for a material without a base colour texture, else
    /// stored · t(x) + E(x) (see the module comment).
    pub fn d_at(&self, triangle: u32, b: Vec2, stored: Vec3) -> Vec3 {
        let tri = &self.triangles[triangle as usize];
        reconstruct_d(
            &self.textures,
            &self.materials[tri.material as usize],
            tri,
            b,
            stored,
        )
    }

    /// The albedo, emission and modulation of the lightmap element at barycentrics `bary` of
    /// `triangle`, whose vertices lie at `lm` in lightmap texel units.
    pub fn texel_surface(&self, triangle: u32, lm: &[Vec2; 3], bary: Vec2) -> TexelSurface {
        let tri = &self.triangles[triangle as usize];
        let m = &self.materials[tri.material as usize];
        if !m.is_textured() {
            return TexelSurface {
                albedo: m.albedo,
                emission: m.emission,
                modulation: None,
            };
        }
        let mean = |t: &TextureRef| footprint_mean(&self.textures, t, tri, lm, bary).truncate();
        let t_mean = m.base_texture.as_ref().map(mean);
        let e_mean = m.emissive_texture.as_ref().map_or(Vec3::ONE, mean);
        TexelSurface {
            albedo: m.albedo * t_mean.unwrap_or(Vec3::ONE),
            emission: m.emission * e_mean,
            modulation: t_mean,
        }
    }

    /// The textured and cut-out triangles with what sampling them needs, owned (for
    /// closures that outlive the scene); `None` when no material is textured or masked.
    pub fn textured_surfaces(&self) -> Option<Arc<TexturedSurfaces>> {
        let special: Vec<bool> = self
            .materials
            .iter()
            .map(|m| m.is_textured() || m.has_cutouts())
            .collect();
        if !special.iter().any(|&m| m) {
            return None;
        }
        Some(Arc::new(TexturedSurfaces {
            triangles: self
                .triangles
                .iter()
                .map(|t| special[t.material as usize].then_some(*t))
                .collect(),
            materials: self.materials.clone(),
            textures: Arc::clone(&self.textures),
        }))
    }

    /// The hit filter rays use in this scene, `None` when no material has cut-outs.
    pub fn cutout_filter(&self) -> Option<crate::geometry::bvh::HitFilter> {
        if !self.materials.iter().any(Material::has_cutouts) {
            return None;
        }
        let surfaces = self.textured_surfaces()?;
        Some(Arc::new(move |triangle: u32, b: Vec2| {
            !surfaces.is_cut_out(triangle, b)
        }))
    }
}

/// The scene's textured and cut-out triangles (others `None`), its materials and images:
/// [`Scene::d_at`] and [`Scene::is_cut_out`] for closures that own their data.
pub struct TexturedSurfaces {
    triangles: Vec<Option<Triangle>>,
    materials: Vec<Material>,
    textures: Arc<Vec<Image>>,
}

impl TexturedSurfaces {
    /// [`Scene::is_cut_out`].
    pub fn is_cut_out(&self, triangle: u32, b: Vec2) -> bool {
        match self.triangles.get(triangle as usize) {
            Some(Some(tri)) => cut_out(
                &self.textures,
                &self.materials[tri.material as usize],
                tri,
                b,
            ),
            _ => false,
        }
    }

    /// [`Scene::d_at`].
    pub fn d_at(&self, triangle: u32, b: Vec2, stored: Vec3) -> Vec3 {
        match self.triangles.get(triangle as usize) {
            Some(Some(tri)) => reconstruct_d(
                &self.textures,
                &self.materials[tri.material as usize],
                tri,
                b,
                stored,
            ),
            _ => stored,
        }
    }
}

/// D at `b` of `tri` (material `m`) from the stored texel value (module comment).
pub fn reconstruct_d(
    images: &[Image],
    m: &Material,
    tri: &Triangle,
    b: Vec2,
    stored: Vec3,
) -> Vec3 {
    d_from(m, stored, |t| sample_at(images, t, tri, b))
}

/// D of material `m` from the stored texel value, its textures read by `read`.
fn d_from(m: &Material, stored: Vec3, read: impl Fn(&TextureRef) -> Vec4) -> Vec3 {
    apply_d_factors(stored, d_factors(m, read))
}

/// What D of a textured material multiplies the stored texel value by and adds to it (base
/// colour, emission), its textures read by `read`; `None` untextured (D is the stored value).
fn d_factors(m: &Material, read: impl Fn(&TextureRef) -> Vec4) -> Option<(Vec3, Vec3)> {
    let t = read(m.base_texture.as_ref()?).truncate();
    let e = m
        .emissive_texture
        .as_ref()
        .map_or(m.emission, |t| m.emission * read(t).truncate());
    Some((t, e))
}

/// D from the stored texel value and [`d_factors_at`] or [`d_factors_over`]: the float
/// operations of [`reconstruct_d`] and [`d_over`], so that D-independent factors kept from a
/// bake give its values again for another D.
pub fn apply_d_factors(stored: Vec3, factors: Option<(Vec3, Vec3)>) -> Vec3 {
    match factors {
        Some((t, e)) => stored * t + e,
        None => stored,
    }
}

/// The factors [`reconstruct_d`] applies at `b` of `tri` (material `m`).
pub fn d_factors_at(
    images: &[Image],
    m: &Material,
    tri: &Triangle,
    b: Vec2,
) -> Option<(Vec3, Vec3)> {
    d_factors(m, |t| sample_at(images, t, tri, b))
}

/// Every scene image's mip chain, level 0 first ([`super::texture::mips::mip_chain`]): what
/// [`d_over`] filters a footprint with, as the viewer does.
pub fn texture_levels(images: &[Image]) -> Vec<Vec<Image>> {
    images
        .iter()
        .map(|image| {
            std::iter::once(image.clone())
                .chain(mip_chain(image))
                .collect()
        })
        .collect()
}

/// [`reconstruct_d`] over a footprint: the textures read by the viewer's anisotropic filter
/// ([`sample_anisotropic`]) over `db`, the barycentric steps from `b` to the neighbouring
/// pixels' points across and down; `levels` from [`texture_levels`].
pub fn d_over(
    levels: &[Vec<Image>],
    m: &Material,
    tri: &Triangle,
    b: Vec2,
    db: [Vec2; 2],
    stored: Vec3,
) -> Vec3 {
    apply_d_factors(stored, d_factors_over(levels, m, tri, b, db))
}

/// The factors [`d_over`] applies.
pub fn d_factors_over(
    levels: &[Vec<Image>],
    m: &Material,
    tri: &Triangle,
    b: Vec2,
    db: [Vec2; 2],
) -> Option<(Vec3, Vec3)> {
    d_factors(m, |t| {
        let chain = &levels[t.image as usize];
        let size = Vec2::new(chain[0].width as f32, chain[0].height as f32);
        let uv = uv_set(t, tri);
        // In level-0 texels. A ray grazing its plane gives a step too long to square: it is
        // shortened to a million texels (the coarsest level); one that is not finite reads
        // the point itself.
        let step = |d: Vec2| {
            let s = t
                .transform
                .linear((uv[1] - uv[0]) * d.x + (uv[2] - uv[0]) * d.y)
                * size;
            let longest = s.abs().max_element();
            if !longest.is_finite() {
                Vec2::ZERO
            } else if longest > 1e6 {
                s * (1e6 / longest)
            } else {
                s
            }
        };
        sample_anisotropic(
            chain,
            &t.sampler,
            texture_uv(t, tri, b),
            step(db[0]),
            step(db[1]),
        )
    })
}

/// Whether material `m` lets a ray through at `b` of `tri`: alpha (factor × base colour
/// texture alpha) below the MASK cutoff.
pub fn cut_out(images: &[Image], m: &Material, tri: &Triangle, b: Vec2) -> bool {
    let AlphaMode::Mask { cutoff } = m.alpha_mode else {
        return false;
    };
    let a = match &m.base_texture {
        None => m.alpha_factor,
        Some(t) => m.alpha_factor * sample_at(images, t, tri, b).w,
    };
    a < cutoff
}

/// The value a texel of a base-colour-textured material stores, Q = (D − Ē)/t̄ =
/// reflected / t̄ (channels where t̄ is 0 reflect nothing and store 0); any other texel stores
/// `emission + reflected`.
pub fn stored_radiance(surface: &TexelSurface, reflected: Vec3) -> Vec3 {
    match surface.modulation {
        None => surface.emission + reflected,
        Some(t) => Vec3::select(t.cmpgt(Vec3::splat(1e-6)), reflected / t, Vec3::ZERO),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`d_over`] at no step is [`reconstruct_d`] (one bilinear read); over a footprint many
    /// texels wide it is the texture's mean, even for a step too long to square; a step that
    /// is not finite reads the point; an untextured material gives the stored value.
    #[test]
    fn d_over_a_footprint_spans_the_point_to_the_mean() {
        let checker = Image {
            width: 8,
            height: 8,
            texels: (0..64)
                .map(|i| {
                    if (i % 8 + i / 8) % 2 == 0 {
                        [255; 4]
                    } else {
                        [0, 0, 0, 255]
                    }
                })
                .collect(),
        };
        let images = vec![checker];
        let levels = texture_levels(&images);
        let plain = Material::from_gltf("m", [0.8, 0.8, 0.8, 1.0], 0.0, 1.0, [0.0; 3], 1.0);
        let m = Material {
            base_texture: Some(TextureRef {
                image: 0,
                sampler: Default::default(),
                tex_coord: 0,
                transform: Default::default(),
            }),
            ..plain.clone()
        };
        let tri = Triangle {
            p: [Vec3::ZERO, Vec3::X, Vec3::Y],
            n: [Vec3::Z; 3],
            uv: [Vec2::ZERO, Vec2::X, Vec2::Y],
            uv1: None,
            material: 0,
            object: 0,
        };
        let (b, stored) = (Vec2::new(0.3, 0.45), Vec3::splat(2.0));
        let at = |db: [Vec2; 2]| d_over(&levels, &m, &tri, b, db, stored);
        assert_eq!(
            at([Vec2::ZERO; 2]),
            reconstruct_d(&images, &m, &tri, b, stored)
        );
        // Four texels a step along each axis, and a grazing step of 1e30 texels: the mean, ½.
        for db in [[Vec2::X * 0.5, Vec2::Y * 0.5], [Vec2::X * 1e30, Vec2::ZERO]] {
            assert!(
                (at(db) - Vec3::ONE).abs().max_element() < 0.01,
                "{db:?}: {}",
                at(db)
            );
        }
        let nan = [Vec2::splat(f32::NAN), Vec2::ZERO];
        assert_eq!(at(nan), at([Vec2::ZERO; 2]));
        assert_eq!(d_over(&levels, &plain, &tri, b, nan, stored), stored);
    }

    #[test]
    fn stored_radiance_round_trips_through_d_at_a_texel_of_constant_texture() {
        let s = TexelSurface {
            albedo: Vec3::new(0.4, 0.2, 0.1),
            emission: Vec3::new(1.0, 0.0, 0.0),
            modulation: Some(Vec3::new(0.5, 0.25, 0.0)),
        };
        let reflected = Vec3::new(0.3, 0.1, 0.0);
        let q = stored_radiance(&s, reflected);
        assert_eq!(q, Vec3::new(0.6, 0.4, 0.0));
        // Where t(x) = t̄ and E(x) = Ē, D(x) = Q t(x) + E(x) is the texel's D.
        let d = q * s.modulation.unwrap() + s.emission;
        assert!((d - (reflected + s.emission)).abs().max_element() < 1e-7);
        // Untextured: D itself, as the solve computes it.
        let plain = TexelSurface {
            modulation: None,
            ..s
        };
        assert_eq!(stored_radiance(&plain, reflected), s.emission + reflected);
    }
}
