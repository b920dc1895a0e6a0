//! Mip chains of texture images, for sampling a texture seen smaller than its texels without
//! aliasing (the viewer's anisotropic filter, `shaders/view.wgsl`'s `sample_surface`). Level
//! k + 1 halves level k (rounding down, at least one texel a side, as a GPU texture's levels
//! do); each of its texels is the area-weighted mean of the level-k texels it covers, in
//! linear space (RGB decoded from sRGB, alpha as stored), so every level keeps the image's
//! mean and odd sizes lose no row or column. A level's texels come from one copy of the
//! image only: wrap modes fold coordinates later, against each level's own size.

use glam::{Vec2, Vec4};

use super::{Filter, Image, Sampler};
use crate::image_io::linear_to_srgb;

/// Width and height of level `level` of a `width` × `height` image.
pub fn level_size(width: u32, height: u32, level: u32) -> (u32, u32) {
    (
        width.checked_shr(level).unwrap_or(0).max(1),
        height.checked_shr(level).unwrap_or(0).max(1),
    )
}

/// Levels in the full chain of a `width` × `height` image, down to 1 × 1.
pub fn level_count(width: u32, height: u32) -> u32 {
    u32::BITS - width.max(height).max(1).leading_zeros()
}

/// One level in linear RGBA.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearLevel {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Row-major texels, linear RGB and alpha.
    pub texels: Vec<Vec4>,
}

impl LinearLevel {
    /// `image` decoded to linear.
    pub fn of(image: &Image) -> LinearLevel {
        let mut texels = Vec::with_capacity(image.texels.len());
        for y in 0..image.height {
            for x in 0..image.width {
                texels.push(image.texel_linear(x, y));
            }
        }
        LinearLevel {
            width: image.width,
            height: image.height,
            texels,
        }
    }

    /// The next level: half the size (rounded down, at least 1), each texel the mean of the
    /// area it covers here.
    pub fn half(&self) -> LinearLevel {
        let (w, h) = level_size(self.width, self.height, 1);
        let across = weights(self.width, w);
        let down = weights(self.height, h);
        // Rows first (along x), then columns.
        let mut rows = vec![Vec4::ZERO; (w * self.height) as usize];
        for y in 0..self.height as usize {
            let src = &self.texels[y * self.width as usize..][..self.width as usize];
            for (i, taps) in across.iter().enumerate() {
                rows[y * w as usize + i] = taps.iter().map(|&(j, c)| src[j] * c).sum();
            }
        }
        let mut texels = vec![Vec4::ZERO; (w * h) as usize];
        for (k, taps) in down.iter().enumerate() {
            for i in 0..w as usize {
                texels[k * w as usize + i] = taps
                    .iter()
                    .map(|&(j, c)| rows[j * w as usize + i] * c)
                    .sum();
            }
        }
        LinearLevel {
            width: w,
            height: h,
            texels,
        }
    }

    /// This level encoded as an image (RGB to sRGB, alpha as is, both rounded to 8 bits).
    pub fn to_image(&self) -> Image {
        let byte = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        Image {
            width: self.width,
            height: self.height,
            texels: self
                .texels
                .iter()
                .map(|t| {
                    [
                        byte(linear_to_srgb(t.x)),
                        byte(linear_to_srgb(t.y)),
                        byte(linear_to_srgb(t.z)),
                        byte(t.w),
                    ]
                })
                .collect(),
        }
    }

    /// The mean texel.
    pub fn mean(&self) -> Vec4 {
        self.texels.iter().sum::<Vec4>() / self.texels.len() as f32
    }
}

/// For each of `m` destination texels along an axis of `n` source texels (m ≤ n), the
/// source texels it overlaps and their share of it: destination i spans [i·n/m, (i+1)·n/m)
/// in source texels, counted in integer units of 1/m so the shares are exact.
fn weights(n: u32, m: u32) -> Vec<Vec<(usize, f32)>> {
    let (n, m) = (n as u64, m as u64);
    (0..m)
        .map(|i| {
            let (lo, hi) = (i * n, (i + 1) * n);
            (lo / m..hi.div_ceil(m))
                .filter_map(|j| {
                    let overlap = hi.min((j + 1) * m) - lo.max(j * m);
                    (overlap > 0).then_some((j as usize, overlap as f32 / n as f32))
                })
                .collect()
        })
        .collect()
}

/// Levels 1, 2, … of `image`'s chain down to 1 × 1 (level 0 is the image itself), each
/// halved from the previous one in linear floating point and only then encoded.
pub fn mip_chain(image: &Image) -> Vec<Image> {
    let mut level = LinearLevel::of(image);
    let mut out = Vec::new();
    for _ in 1..level_count(image.width, image.height) {
        level = level.half();
        out.push(level.to_image());
    }
    out
}

/// A texture's value at `uv` (after any transform) and level of detail `lod`, as the viewer
/// filters it: [`Image::sample`] in levels ⌊lod⌋ and ⌊lod⌋ + 1 of `levels` (level 0 first,
/// then [`mip_chain`]), blended linearly; a nearest sampler reads level 0 alone.
pub fn sample_trilinear(levels: &[Image], sampler: &Sampler, uv: Vec2, lod: f32) -> Vec4 {
    if sampler.filter == Filter::Nearest {
        return levels[0].sample(sampler, uv);
    }
    let lod = lod.clamp(0.0, (levels.len() - 1) as f32);
    let k = lod.floor() as usize;
    let f = lod - k as f32;
    let a = levels[k].sample(sampler, uv);
    if f <= 0.0 {
        return a;
    }
    a * (1.0 - f) + levels[k + 1].sample(sampler, uv) * f
}

/// Most trilinear taps [`sample_anisotropic`] takes along a footprint's longer axis: a
/// longer footprint raises the level of detail instead.
pub const MAX_ANISOTROPY: f32 = 16.0;

/// How the viewer filters a screen footprint whose steps to the next pixel across and down
/// are `dx` and `dy`, in level-0 texels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Footprint {
    /// Level of detail: log2 of the shorter step, raised where the ratio of the steps
    /// exceeds [`MAX_ANISOTROPY`], clamped to [0, top].
    pub lod: f32,
    /// Trilinear taps along the longer step: the ratio of the steps, rounded up.
    pub taps: u32,
    /// The longer step, in level-0 texels; the taps spread evenly across it.
    pub axis: Vec2,
}

/// The [`Footprint`] of steps `dx` and `dy` (level-0 texels) on an image with levels 0 to
/// `top`, as `shaders/view.wgsl`'s `sample_surface` computes it.
pub fn footprint(dx: Vec2, dy: Vec2, top: u32) -> Footprint {
    let (lx, ly) = (dx.length_squared(), dy.length_squared());
    let axis = if lx >= ly { dx } else { dy };
    let (major2, minor2) = (lx.max(ly), lx.min(ly));
    let ratio = (major2 / minor2.max(1e-20))
        .sqrt()
        .clamp(1.0, MAX_ANISOTROPY);
    let lod = 0.5 * (major2 / (ratio * ratio)).log2();
    Footprint {
        lod: if lod.is_nan() {
            0.0
        } else {
            lod.clamp(0.0, top as f32)
        },
        taps: ratio.ceil() as u32,
        axis,
    }
}

/// A texture's value at `uv` (after any transform) over the screen footprint whose steps
/// are `dx` and `dy` in level-0 texels, as the viewer filters it: the [`footprint`]'s taps
/// at `uv` + axis · ((i + ½)/taps − ½), each [`sample_trilinear`] at its level of detail,
/// averaged; a nearest sampler reads level 0 alone.
pub fn sample_anisotropic(
    levels: &[Image],
    sampler: &Sampler,
    uv: Vec2,
    dx: Vec2,
    dy: Vec2,
) -> Vec4 {
    if sampler.filter == Filter::Nearest {
        return levels[0].sample(sampler, uv);
    }
    let f = footprint(dx, dy, (levels.len() - 1) as u32);
    let size = Vec2::new(levels[0].width as f32, levels[0].height as f32);
    let axis = f.axis / size;
    let sum: Vec4 = (0..f.taps)
        .map(|i| {
            let k = (i as f32 + 0.5) / f.taps as f32 - 0.5;
            sample_trilinear(levels, sampler, uv + axis * k, f.lod)
        })
        .sum();
    sum / f.taps as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::texture::Wrap;

    fn checker(width: u32, height: u32, a: [u8; 4], b: [u8; 4]) -> Image {
        Image {
            width,
            height,
            texels: (0..width * height)
                .map(|i| {
                    if (i % width + i / width).is_multiple_of(2) {
                        a
                    } else {
                        b
                    }
                })
                .collect(),
        }
    }

    fn close(a: Vec4, b: Vec4, tol: f32) -> bool {
        (a - b).abs().max_element() <= tol
    }

    #[test]
    fn sizes_halve_down_to_one_texel() {
        assert_eq!(level_count(1, 1), 1);
        assert_eq!(level_count(8, 8), 4);
        assert_eq!(level_count(9, 2), 4);
        assert_eq!(level_size(9, 2, 1), (4, 1));
        assert_eq!(level_size(9, 2, 3), (1, 1));
        assert_eq!(level_size(5, 3, 40), (1, 1));
        let sizes: Vec<(u32, u32)> = mip_chain(&checker(9, 2, [0; 4], [255; 4]))
            .iter()
            .map(|l| (l.width, l.height))
            .collect();
        assert_eq!(sizes, vec![(4, 1), (2, 1), (1, 1)]);
    }

    /// A black and white checker's levels are uniform grey at its linear mean (½, not the
    /// sRGB byte 128's 0.216): averaged in linear space.
    #[test]
    fn a_checkers_levels_average_to_its_mean() {
        let img = checker(16, 16, [0, 0, 0, 255], [255, 255, 255, 255]);
        let chain = mip_chain(&img);
        assert_eq!(chain.len(), 4);
        for level in &chain {
            for t in &level.texels {
                assert!(t[..3].iter().all(|&c| c.abs_diff(188) <= 1), "{level:?}");
                assert_eq!(t[3], 255);
            }
        }
        let one = LinearLevel::of(&chain[3]);
        assert!(close(one.texels[0], Vec4::new(0.5, 0.5, 0.5, 1.0), 0.003));
    }

    /// Odd sizes: every level keeps the image's mean (no row or column dropped), and a
    /// 3-wide level's one texel weighs its three columns ⅓ each.
    #[test]
    fn odd_sizes_keep_the_mean() {
        let img = Image {
            width: 7,
            height: 5,
            texels: (0..35u32)
                .map(|i| {
                    [
                        (i * 37 % 256) as u8,
                        (i * 91 % 256) as u8,
                        (i * 13) as u8,
                        255,
                    ]
                })
                .collect(),
        };
        let mut level = LinearLevel::of(&img);
        let mean = level.mean();
        for _ in 1..level_count(7, 5) {
            level = level.half();
            assert!(close(level.mean(), mean, 1e-5), "{level:?}");
        }
        assert_eq!((level.width, level.height), (1, 1));
        let row = LinearLevel {
            width: 3,
            height: 1,
            texels: vec![Vec4::ZERO, Vec4::splat(0.3), Vec4::splat(0.9)],
        };
        assert!(close(row.half().texels[0], Vec4::splat(0.4), 1e-6));
        // 5 → 2: [0, 2.5) and [2.5, 5).
        assert_eq!(
            weights(5, 2),
            vec![
                vec![(0, 0.4), (1, 0.4), (2, 0.2)],
                vec![(2, 0.2), (3, 0.4), (4, 0.4)]
            ]
        );
    }

    /// A level's edge texels average their own side of the image only, whatever the
    /// sampler's wrap mode: repeat and mirror fold coordinates against each level's size,
    /// so a level sampled with either wraps as the image does.
    #[test]
    fn levels_do_not_mix_opposite_edges_and_wrap_by_their_own_size() {
        // Left half black, right half white, 6 wide: level 1 is 3 wide.
        let img = Image {
            width: 6,
            height: 2,
            texels: (0..12)
                .map(|i| if i % 6 < 3 { [0, 0, 0, 255] } else { [255; 4] })
                .collect(),
        };
        let l1 = LinearLevel::of(&mip_chain(&img)[0]);
        assert_eq!((l1.width, l1.height), (3, 1));
        assert!(close(l1.texels[0], Vec4::new(0.0, 0.0, 0.0, 1.0), 1e-6));
        assert!(close(l1.texels[2], Vec4::ONE, 1e-6));
        let level = mip_chain(&img)[0].clone();
        for wrap in [Wrap::Repeat, Wrap::MirroredRepeat, Wrap::ClampToEdge] {
            let s = Sampler {
                wrap_u: wrap,
                wrap_v: wrap,
                filter: Filter::Nearest,
            };
            // One level-1 texel left of u = 0: the right edge (repeat), the left (mirror,
            // clamp).
            let t = level.sample(&s, Vec2::new(-1.0 / 6.0, 0.5));
            let want = if wrap == Wrap::Repeat { 1.0 } else { 0.0 };
            assert!((t.x - want).abs() < 1e-6, "{wrap:?}: {t}");
        }
    }

    /// Level 0 up close, the chain's levels at whole levels of detail, a blend between, the
    /// last level beyond; a 4-texel step is level 2, a nearest sampler level 0 always.
    #[test]
    fn trilinear_blends_the_two_levels_around_the_level_of_detail() {
        let img = checker(8, 8, [0, 0, 0, 255], [255, 255, 255, 255]);
        let mut levels = vec![img.clone()];
        levels.extend(mip_chain(&img));
        let s = Sampler::default();
        let uv = Vec2::new(0.3, 0.55);
        assert_eq!(sample_trilinear(&levels, &s, uv, 0.0), img.sample(&s, uv));
        assert_eq!(
            sample_trilinear(&levels, &s, uv, 2.0),
            levels[2].sample(&s, uv)
        );
        let half = sample_trilinear(&levels, &s, uv, 0.25);
        let want = img.sample(&s, uv) * 0.75 + levels[1].sample(&s, uv) * 0.25;
        assert!(close(half, want, 1e-6), "{half} {want}");
        assert_eq!(
            sample_trilinear(&levels, &s, uv, 9.0),
            levels[3].texel_linear(0, 0)
        );
        let nearest = Sampler {
            filter: Filter::Nearest,
            ..s
        };
        assert_eq!(
            sample_trilinear(&levels, &nearest, uv, 3.0),
            img.sample(&nearest, uv)
        );
    }

    #[test]
    fn the_shorter_step_picks_the_level_and_the_longer_carries_the_taps() {
        let f = footprint(Vec2::new(0.0, 1.0), Vec2::new(4.0, 0.0), 5);
        assert_eq!((f.lod, f.taps, f.axis), (0.0, 4, Vec2::new(4.0, 0.0)));
        // Equal steps: one tap at the longer step's level, as isotropic trilinear.
        let f = footprint(Vec2::new(3.0, 4.0), Vec2::new(4.0, -3.0), 5);
        assert_eq!((f.taps, f.lod), (1, 5f32.log2()));
        // A ratio past the maximum raises the level: 64 / 16 texels per tap.
        let f = footprint(Vec2::new(64.0, 0.0), Vec2::new(0.0, 1.0), 5);
        assert_eq!((f.lod, f.taps), (2.0, 16));
        assert_eq!(
            footprint(Vec2::new(64.0, 0.0), Vec2::new(0.0, 8.0), 1).lod,
            1.0
        );
        assert_eq!(footprint(Vec2::ZERO, Vec2::ZERO, 5).lod, 0.0);
        assert_eq!(footprint(Vec2::ZERO, Vec2::ZERO, 5).taps, 1);
        assert_eq!(footprint(Vec2::splat(0.5), Vec2::ZERO, 5).lod, 0.0);
    }

    #[test]
    fn anisotropic_taps_average_trilinear_lookups_along_the_longer_step() {
        let img = checker(8, 8, [250, 250, 250, 255], [10, 10, 10, 255]);
        let mut levels = vec![img.clone()];
        levels.extend(mip_chain(&img));
        let s = Sampler::default();
        let uv = Vec2::new(0.3, 0.55);
        // One texel across, four along u: level 0, taps 1 texel apart at -1.5..1.5.
        let got = sample_anisotropic(&levels, &s, uv, Vec2::new(4.0, 0.0), Vec2::new(0.0, 1.0));
        let want = [-1.5f32, -0.5, 0.5, 1.5]
            .iter()
            .map(|&k| img.sample(&s, uv + Vec2::new(k / 8.0, 0.0)))
            .sum::<Vec4>()
            / 4.0;
        assert!(close(got, want, 1e-6), "{got} {want}");
        // Isotropic: the trilinear lookup itself.
        let (dx, dy) = (Vec2::new(2.0, 0.0), Vec2::new(0.0, 2.0));
        assert_eq!(
            sample_anisotropic(&levels, &s, uv, dx, dy),
            sample_trilinear(&levels, &s, uv, 1.0)
        );
    }
}
