//! Texture sampling as glTF 2.0 defines it: sRGB-encoded RGBA8 images (§3.8.4: base colour
//! and emissive textures are sRGB, alpha linear), sampler wrap modes (§3.8.3: REPEAT,
//! MIRRORED_REPEAT, CLAMP_TO_EDGE), bilinear filtering between texel centres, and the
//! `KHR_texture_transform` UV transform (offset · rotation · scale). Pure functions: the
//! images are decoded by `gltf_textures`.

pub mod mips;

use std::sync::LazyLock;

use glam::{Vec2, Vec4};

/// How texture coordinates outside [0, 1] are folded back (glTF sampler `wrapS`/`wrapT`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Wrap {
    /// The image repeats (glTF's default, 10497).
    #[default]
    Repeat,
    /// The image repeats, every other copy mirrored (33648).
    MirroredRepeat,
    /// Coordinates clamp to the edge texels (33071).
    ClampToEdge,
}

/// Magnification filter (glTF sampler `magFilter`): texels are interpolated bilinearly unless
/// the sampler asks for the nearest one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Filter {
    /// Bilinear between the four nearest texel centres (also when unspecified).
    #[default]
    Linear,
    /// The texel under the coordinate.
    Nearest,
}

/// A glTF sampler.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Sampler {
    /// Wrap along u (`wrapS`).
    pub wrap_u: Wrap,
    /// Wrap along v (`wrapT`).
    pub wrap_v: Wrap,
    /// Filter.
    pub filter: Filter,
}

/// `KHR_texture_transform`: uv' = offset + R(rotation) · (scale ⊙ uv), with the extension's
/// matrix R = [[cos r, sin r], [−sin r, cos r]] (rotation counter-clockwise in UV space, whose
/// v axis points down the image).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    /// Translation.
    pub offset: Vec2,
    /// Rotation in radians.
    pub rotation: f32,
    /// Scale.
    pub scale: Vec2,
}

impl Default for UvTransform {
    fn default() -> Self {
        UvTransform {
            offset: Vec2::ZERO,
            rotation: 0.0,
            scale: Vec2::ONE,
        }
    }
}

impl UvTransform {
    /// The transformed coordinate of `uv`.
    pub fn apply(&self, uv: Vec2) -> Vec2 {
        self.offset + self.linear(uv)
    }

    /// The linear part (no offset), for footprint edges.
    pub fn linear(&self, d: Vec2) -> Vec2 {
        let (s, c) = self.rotation.sin_cos();
        let q = d * self.scale;
        Vec2::new(c * q.x + s * q.y, -s * q.x + c * q.y)
    }

    /// Whether this is the identity.
    pub fn is_identity(&self) -> bool {
        *self == UvTransform::default()
    }
}

/// A decoded image: RGBA8 texels, row 0 at the top (v = 0), as stored in the file.
#[derive(Clone, PartialEq)]
pub struct Image {
    /// Width in texels (≥ 1).
    pub width: u32,
    /// Height in texels (≥ 1).
    pub height: u32,
    /// Row-major texels.
    pub texels: Vec<[u8; 4]>,
}

impl std::fmt::Debug for Image {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Image({}×{})", self.width, self.height)
    }
}

/// sRGB transfer function decoded to linear (IEC 61966-2-1), for the 256 byte values.
static SRGB_TO_LINEAR: LazyLock<[f32; 256]> = LazyLock::new(|| {
    let mut t = [0.0f32; 256];
    for (i, v) in t.iter_mut().enumerate() {
        *v = srgb_to_linear(i as f32 / 255.0);
    }
    t
});

/// The sRGB electro-optical transfer function: encoded value in [0, 1] → linear.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Folds integer texel index `i` into [0, n) by `wrap`.
pub fn wrap_index(i: i64, n: u32, wrap: Wrap) -> u32 {
    let n = n as i64;
    let j = match wrap {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::ClampToEdge => i.clamp(0, n - 1),
        Wrap::MirroredRepeat => {
            let m = i.rem_euclid(2 * n);
            if m < n { m } else { 2 * n - 1 - m }
        }
    };
    j as u32
}

impl Image {
    /// Texel (x, y) with RGB decoded from sRGB to linear and alpha as stored, in [0, 1].
    pub fn texel_linear(&self, x: u32, y: u32) -> Vec4 {
        let [r, g, b, a] = self.texels[(y * self.width + x) as usize];
        let t = &*SRGB_TO_LINEAR;
        Vec4::new(
            t[r as usize],
            t[g as usize],
            t[b as usize],
            a as f32 / 255.0,
        )
    }

    /// Linear RGBA at texture coordinate `uv` (after any transform), filtered and wrapped by
    /// `sampler`. Texel (i, j) has its centre at ((i + ½)/width, (j + ½)/height).
    pub fn sample(&self, sampler: &Sampler, uv: Vec2) -> Vec4 {
        let x = uv.x as f64 * self.width as f64 - 0.5;
        let y = uv.y as f64 * self.height as f64 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return self.texel_linear(0, 0);
        }
        // Far outside the image, repeat the coordinate into range first (f64 keeps the
        // fraction exact enough up to ±1e9 texels).
        let (xu, yv) = (x.clamp(-1e9, 1e9), y.clamp(-1e9, 1e9));
        match sampler.filter {
            Filter::Nearest => {
                let i = wrap_index((xu + 0.5).floor() as i64, self.width, sampler.wrap_u);
                let j = wrap_index((yv + 0.5).floor() as i64, self.height, sampler.wrap_v);
                self.texel_linear(i, j)
            }
            Filter::Linear => {
                let (x0, y0) = (xu.floor(), yv.floor());
                let (fx, fy) = ((xu - x0) as f32, (yv - y0) as f32);
                let (x0, y0) = (x0 as i64, y0 as i64);
                let i0 = wrap_index(x0, self.width, sampler.wrap_u);
                let i1 = wrap_index(x0 + 1, self.width, sampler.wrap_u);
                let j0 = wrap_index(y0, self.height, sampler.wrap_v);
                let j1 = wrap_index(y0 + 1, self.height, sampler.wrap_v);
                let top = self.texel_linear(i0, j0) * (1.0 - fx) + self.texel_linear(i1, j0) * fx;
                let bottom =
                    self.texel_linear(i0, j1) * (1.0 - fx) + self.texel_linear(i1, j1) * fx;
                top * (1.0 - fy) + bottom * fy
            }
        }
    }

    /// The mean of [`Image::sample`] over the parallelogram `centre + s·a + t·b`,
    /// s, t ∈ [−½, ½] (a lightmap texel's footprint in texture space): a midpoint grid with
    /// about two samples per image texel along each edge (at most [`MAX_FOOTPRINT_SAMPLES`]).
    pub fn footprint_mean(&self, sampler: &Sampler, centre: Vec2, a: Vec2, b: Vec2) -> Vec4 {
        let size = Vec2::new(self.width as f32, self.height as f32);
        let count = |e: Vec2| -> u32 {
            let texels = (e * size).abs().max_element();
            if texels.is_finite() {
                ((2.0 * texels).ceil() as u32).clamp(1, MAX_FOOTPRINT_SAMPLES)
            } else {
                1
            }
        };
        let (na, nb) = (count(a), count(b));
        let mut sum = Vec4::ZERO;
        for j in 0..nb {
            let t = (j as f32 + 0.5) / nb as f32 - 0.5;
            for i in 0..na {
                let s = (i as f32 + 0.5) / na as f32 - 0.5;
                sum += self.sample(sampler, centre + a * s + b * t);
            }
        }
        sum / (na * nb) as f32
    }
}

/// Most samples along one edge of a footprint in [`Image::footprint_mean`].
pub const MAX_FOOTPRINT_SAMPLES: u32 = 32;

#[cfg(test)]
mod tests {
    use super::*;

    fn image(width: u32, height: u32, texels: &[[u8; 4]]) -> Image {
        Image {
            width,
            height,
            texels: texels.to_vec(),
        }
    }

    fn close(a: Vec4, b: Vec4, tol: f32) -> bool {
        (a - b).abs().max_element() <= tol
    }

    #[test]
    fn srgb_decoding_matches_the_standard() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        // The linear segment and the power segment meet at 0.04045.
        assert!((srgb_to_linear(0.04045) - 0.04045 / 12.92).abs() < 1e-7);
        // 188/255 encodes ≈ 0.5029 linear.
        let img = image(1, 1, &[[188, 0, 255, 128]]);
        let t = img.texel_linear(0, 0);
        assert!((t.x - 0.502_886).abs() < 1e-4, "{t}");
        assert_eq!((t.y, t.z), (0.0, 1.0));
        assert!((t.w - 128.0 / 255.0).abs() < 1e-7, "alpha is linear");
    }

    #[test]
    fn bilinear_between_texel_centres_is_the_linear_mean() {
        let img = image(2, 1, &[[0, 0, 0, 0], [255, 255, 255, 255]]);
        let s = Sampler {
            wrap_u: Wrap::ClampToEdge,
            ..Default::default()
        };
        // Centres at u = 0.25 and 0.75.
        assert!(close(
            img.sample(&s, Vec2::new(0.25, 0.5)),
            Vec4::ZERO,
            1e-6
        ));
        assert!(close(img.sample(&s, Vec2::new(0.75, 0.5)), Vec4::ONE, 1e-6));
        assert!(close(
            img.sample(&s, Vec2::new(0.5, 0.5)),
            Vec4::splat(0.5),
            1e-6
        ));
        assert!(close(
            img.sample(&s, Vec2::new(0.375, 0.5)),
            Vec4::splat(0.25),
            1e-6
        ));
        // Clamped beyond the centres.
        assert!(close(img.sample(&s, Vec2::new(0.1, 0.5)), Vec4::ZERO, 1e-6));
        assert!(close(
            img.sample(&s, Vec2::new(-7.0, 0.5)),
            Vec4::ZERO,
            1e-6
        ));
        assert!(close(img.sample(&s, Vec2::new(9.0, 0.5)), Vec4::ONE, 1e-6));
    }

    #[test]
    fn wrap_modes_fold_indices_as_gltf_defines() {
        // REPEAT: period n.
        assert_eq!(
            (-1..5)
                .map(|i| wrap_index(i, 3, Wrap::Repeat))
                .collect::<Vec<_>>(),
            vec![2, 0, 1, 2, 0, 1]
        );
        // MIRRORED_REPEAT: 0 1 2 2 1 0 0 1 …, and −1 mirrors to 0.
        assert_eq!(
            (-2..7)
                .map(|i| wrap_index(i, 3, Wrap::MirroredRepeat))
                .collect::<Vec<_>>(),
            vec![1, 0, 0, 1, 2, 2, 1, 0, 0]
        );
        assert_eq!(
            (-2..5)
                .map(|i| wrap_index(i, 3, Wrap::ClampToEdge))
                .collect::<Vec<_>>(),
            vec![0, 0, 0, 1, 2, 2, 2]
        );
    }

    #[test]
    fn repeat_and_mirror_are_periodic_in_uv() {
        let img = image(
            3,
            2,
            &[
                [10, 20, 30, 255],
                [200, 100, 0, 255],
                [50, 250, 90, 0],
                [0, 0, 0, 255],
                [255, 255, 255, 255],
                [128, 64, 32, 100],
            ],
        );
        let repeat = Sampler::default();
        let mirror = Sampler {
            wrap_u: Wrap::MirroredRepeat,
            wrap_v: Wrap::MirroredRepeat,
            filter: Filter::Linear,
        };
        for uv in [
            Vec2::new(0.1, 0.2),
            Vec2::new(0.77, 0.9),
            Vec2::new(0.5, 0.5),
        ] {
            let a = img.sample(&repeat, uv);
            assert!(close(
                img.sample(&repeat, uv + Vec2::new(1.0, -3.0)),
                a,
                1e-5
            ));
            // Mirrored: u → −u and u → 2 − u give the same value.
            let m = img.sample(&mirror, uv);
            assert!(close(img.sample(&mirror, -uv), m, 1e-5));
            assert!(close(img.sample(&mirror, Vec2::splat(2.0) - uv), m, 1e-5));
        }
    }

    #[test]
    fn nearest_filter_takes_the_texel_under_the_point() {
        let img = image(2, 1, &[[0, 0, 0, 0], [255, 255, 255, 255]]);
        let s = Sampler {
            filter: Filter::Nearest,
            ..Default::default()
        };
        assert_eq!(img.sample(&s, Vec2::new(0.49, 0.5)), Vec4::ZERO);
        assert_eq!(img.sample(&s, Vec2::new(0.51, 0.5)), Vec4::ONE);
        assert_eq!(img.sample(&s, Vec2::new(1.2, 0.5)), Vec4::ZERO, "repeats");
    }

    #[test]
    fn texture_transform_is_offset_rotation_scale() {
        let t = UvTransform {
            offset: Vec2::new(0.5, 0.25),
            rotation: std::f32::consts::FRAC_PI_2,
            scale: Vec2::new(2.0, 3.0),
        };
        // (1, 0) scaled to (2, 0), rotated by R = [[0, 1], [−1, 0]] to (0, −2), offset.
        let p = t.apply(Vec2::new(1.0, 0.0));
        assert!((p - Vec2::new(0.5, -1.75)).length() < 1e-6, "{p}");
        // (0, 1) scaled to (0, 3), rotated to (3, 0).
        let q = t.apply(Vec2::new(0.0, 1.0));
        assert!((q - Vec2::new(3.5, 0.25)).length() < 1e-6, "{q}");
        assert!(UvTransform::default().is_identity());
        assert_eq!(
            UvTransform::default().apply(Vec2::new(0.3, 0.7)),
            Vec2::new(0.3, 0.7)
        );
    }

    #[test]
    fn footprint_means_match_analytic_averages() {
        // A 2×2 checker of linear 0 and 1: over any whole number of periods the mean is ½.
        let checker = image(
            2,
            2,
            &[
                [0, 0, 0, 255],
                [255, 255, 255, 255],
                [255, 255, 255, 255],
                [0, 0, 0, 255],
            ],
        );
        let s = Sampler::default();
        let m = checker.footprint_mean(&s, Vec2::new(0.3, 0.6), Vec2::X * 2.0, Vec2::Y * 3.0);
        assert!((m.x - 0.5).abs() < 1e-5, "{m}");
        // A footprint inside one texel's flat neighbourhood of a nearest-filtered image is
        // that texel's value.
        let near = Sampler {
            filter: Filter::Nearest,
            ..Default::default()
        };
        let m = checker.footprint_mean(&near, Vec2::new(0.25, 0.25), Vec2::X * 0.2, Vec2::Y * 0.2);
        assert_eq!(m.x, 0.0);
        // A linear ramp (clamped, sampled between its first and last centre): the mean over a
        // symmetric footprint is the value at its centre.
        let ramp: Vec<[u8; 4]> = (0..5u8).map(|i| [0, 0, 0, i * 60]).collect();
        let ramp = image(5, 1, &ramp);
        let clamp = Sampler {
            wrap_u: Wrap::ClampToEdge,
            wrap_v: Wrap::ClampToEdge,
            filter: Filter::Linear,
        };
        let c = Vec2::new(0.5, 0.5);
        let m = ramp.footprint_mean(&clamp, c, Vec2::new(0.3, 0.1), Vec2::new(0.1, 0.2));
        assert!((m.w - ramp.sample(&clamp, c).w).abs() < 1e-5, "{m}");
        assert!((m.w - 120.0 / 255.0).abs() < 1e-5);
    }
}
