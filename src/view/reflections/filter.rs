//! M*K at a cost that does not grow with K's width: K's taps gathered onto a regular sample
//! pattern (Luksch et al. §5), each pattern sample reading a MIP pyramid of M at the level
//! whose footprint covers its share of the kernel (§6). No wgpu here: the pure math, and the
//! CPU form of what `fs_composite` and `shaders/pyramid.wgsl` compute.
//!
//! # The pattern
//!
//! §5's spacing s₁ laid on K's image plane (K is a screen-space kernel, Bastos §8.2.1, so the
//! circles are flat): one sample at the centre, ring k (k = 1 … [`FILTER_RINGS`]) at radius
//! k·d with n_k = 6k samples (Eq. 13 with sin θ ∝ θ), d = R / (rings + ½) for K's support
//! radius R (in kernel texels). Every K tap goes to its nearest pattern sample; the sample
//! takes their weight W (the cell's mass), sits at their weighted centroid (so K's mean is
//! kept) and carries their per-axis variance v about it plus 1/12 for the texel's own extent.
//! Pattern samples with no mass are dropped. A kernel with no more taps than the pattern
//! (a near-mirror, or any kernel seen at small scale) keeps its taps as they are: the filter
//! then is M*K exactly, and K = I gives M at the pixel (the mirror limit is sharp).
//!
//! # The level (§6, Eq. 16's role)
//!
//! A texel of MIP level L spans b = 2^L pixels: a box of width b, read bilinearly (a tent of
//! half-width b), whose per-axis variance is b²/4. A sample of per-axis variance v (kernel
//! texels²) at `scale` pixels per kernel texel, plus the level-0 bilinear read's 1/6 that the
//! exact sum has too, is read at L = ½ log₂(4 (v·scale² + 1/6)) ([`level`]), clamped to
//! [0, top]: the filter's width follows the lobe's and goes to one texel as m → 0 or as
//! the reflected point nears the mirror (scale → 0).
//!
//! # Grazing views
//!
//! K is the lobe's footprint seen along the normal (Bastos's space-invariant kernel). Seen at
//! θ from the normal, a half vector tilted by δ across the plane of incidence turns the
//! reflected ray by 2δ cos θ, one tilted within it by 2δ (r = 2 (v·h) h − v, differentiated
//! at h = n): the lobe narrows across the plane of incidence by cos θ — the streaks a glossy
//! floor shows at grazing views — and, weighted by D G₂ (v·h) and cut at the horizon, leans
//! away from the horizon ([`super::lobe_shape`] measures both per view angle). Each pixel's
//! taps are therefore scaled along and across the plane of incidence's trace on screen (the
//! line through the pixel towards the normal's vanishing point; [`Grazing`]) and shifted along
//! it by the lean. The pyramid's footprint is isotropic, so a tap whose lobe share is k times
//! longer along the axis than across it is read n = ⌊√(3k² − 2)⌋ times (at most
//! [`MAX_READS`]) along the axis, a step 2σ apart, each read of σ² = max(V_across,
//! 3 V_along / (n² + 2)) ([`Grazing::footprint`]); one read is at the variance's geometric
//! mean over the two axes. At 80° on a GGX α = 0.04 floor (`tests/view_gltf_grazing.rs`,
//! relative RMSE against a 256-path reference, a lean of half the mean) at most 1 read gave
//! 0.071, 2 0.069, 3 0.058, 4 0.055, 6 0.049, 9 0.048: one read leaves bands of the pattern's
//! rings across the streaks.
//!
//! # Coverage
//!
//! The pyramid holds (rgb·c, c): c = 1 for a texel of M that holds a reflection (image
//! mode: a splat covered it), 0 for a hole; in geometry mode every texel counts (c = 1, an
//! empty texel reflects black). The filtered value is Σ W·rgb / Σ W·c, so holes neither
//! darken the blur nor need filling first.

use glam::{Mat4, Vec2, Vec3, Vec4};

use super::lobe_shape::LobeShape;
use super::material::Tap;

/// Rings of the regular pattern around its centre sample (1 + 6 + 12 + 18 = 37 samples).
pub const FILTER_RINGS: u32 = 3;

/// Most taps a filter has (the shader's `taps` array): the pattern's samples.
pub const MAX_FILTER_TAPS: usize = 64;

/// One sample of the filter: where it reads, with what weight, over how wide a footprint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterTap {
    /// Offset in kernel texels (x right, y up).
    pub offset: Vec2,
    /// Weight (the taps sum to 1).
    pub weight: f32,
    /// Per-axis variance of the kernel mass it stands for, about `offset` (kernel texels²).
    pub variance: f32,
}

/// How K's footprint is turned and shaped on screen at a grazing view (see the module
/// documentation and [`super::lobe_shape`]): the unit screen direction of the plane of
/// incidence's trace at the pixel, and the lobe's shape at the pixel's view angle. The
/// identity at normal incidence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grazing {
    /// Unit screen direction of the plane of incidence (pixels, y down), towards the normal's
    /// side (a reflected ray of higher elevation reads M further the other way).
    pub axis: Vec2,
    /// K's scale along the axis.
    pub along: f32,
    /// K's scale across the axis.
    pub across: f32,
    /// K's shift along −axis (towards higher elevation of the reflected ray), kernel texels.
    pub shift: f32,
}

impl Grazing {
    /// No change (the kernel as baked).
    pub const NONE: Grazing = Grazing {
        axis: Vec2::X,
        along: 1.0,
        across: 1.0,
        shift: 0.0,
    };

    /// At world point `p` of a reflector of unit normal `n` seen from `eye` through
    /// `view_proj` (world to clip) on a `size` (pixels) target: the normal's direction on
    /// screen at `p`'s pixel (the derivative of its pixel position along n), and `shape` at
    /// |n·v| with its lean in kernel texels of `texel_angle` radians (0: no lean). The
    /// shader's `grazing_axis` and `lobe_shape` are the same.
    pub fn at(
        view_proj: Mat4,
        p: Vec3,
        n: Vec3,
        eye: Vec3,
        size: Vec2,
        shape: &LobeShape,
        texel_angle: f32,
    ) -> Grazing {
        let c = view_proj * p.extend(1.0);
        let dc = view_proj * n.extend(0.0);
        let d = (dc.truncate().truncate() * c.w - c.truncate().truncate() * dc.w) / (c.w * c.w);
        let along = Vec2::new(d.x * size.x, -d.y * size.y);
        let axis = if along.length_squared() > 1e-12 {
            along.normalize()
        } else {
            Vec2::X
        };
        let cos = n.dot((eye - p).normalize_or_zero()).abs().clamp(1e-3, 1.0);
        let s = shape.at(cos);
        Grazing {
            axis,
            along: s.along,
            across: s.across,
            shift: if texel_angle > 0.0 {
                s.lean / texel_angle
            } else {
                0.0
            },
        }
    }

    /// A screen offset (pixels, y down) of K at `scale` pixels per kernel texel, scaled
    /// along and across the axis and shifted along it.
    pub fn offset(&self, o: Vec2, scale: f32) -> Vec2 {
        let a = o.dot(self.axis);
        let across = o - self.axis * a;
        self.axis * (a * self.along - self.shift * scale) + across * self.across
    }

    /// A per-axis variance as the isotropic pyramid reads it in one read: the geometric mean
    /// of the two axes' variances, v·along·across.
    pub fn variance(&self, v: f32) -> f32 {
        v * self.along * self.across
    }

    /// Reads per filter tap: n = ⌊√(3k² − 2)⌋ for k = along/across, in [1, [`MAX_READS`]]
    /// (n reads a step 2σ apart, each of footprint σ, span k σ: see [`Grazing::footprint`]).
    pub fn reads(&self) -> u32 {
        let k2 = (self.along / self.across.max(1e-6)).powi(2);
        if k2 <= 1.0 {
            return 1;
        }
        ((3.0 * k2 - 2.0).sqrt().floor() as u32).clamp(1, MAX_READS)
    }

    /// Where and how wide a tap of per-axis `variance` (kernel texels²) at `scale` pixels per
    /// kernel texel reads with `reads` reads along the axis: (MIP level, step in pixels
    /// between the reads). One read: the level of [`Grazing::variance`]. n reads at step δ
    /// (positions' variance δ²(n² − 1)/12), each of variance σ² = max(V_across, 3 V_along /
    /// (n² + 2)) (so that δ ≈ 2σ leaves no gaps), add up to the tap's variance along the
    /// axis, V_along = σ² + δ²(n² − 1)/12, and keep at least its variance across.
    pub fn footprint(&self, variance: f32, scale: f32, reads: u32) -> (f32, f32) {
        if reads <= 1 {
            return (level(self.variance(variance), scale), 0.0);
        }
        let s2 = scale * scale;
        let along = variance * self.along * self.along * s2;
        let across = variance * self.across * self.across * s2;
        let n2 = (reads * reads) as f32;
        let own = across.max(3.0 * along / (n2 + 2.0));
        let step = (12.0 * (along - own).max(0.0) / (n2 - 1.0)).sqrt();
        (level(own, 1.0), step)
    }
}

/// Most reads of the pyramid per filter tap along the plane of incidence at grazing views.
pub const MAX_READS: u32 = 6;

/// Samples of a pattern with `rings` rings: 1 + 3·rings·(rings + 1).
pub fn pattern_len(rings: u32) -> usize {
    1 + 3 * (rings as usize) * (rings as usize + 1)
}

/// The regular pattern (§5, spacing s₁ on a plane): the centre, then ring k = 1 … `rings` at
/// radius k·`spacing` with 6k samples from φ = 0.
pub fn regular_pattern(rings: u32, spacing: f32) -> Vec<Vec2> {
    let mut p = vec![Vec2::ZERO];
    for k in 1..=rings {
        let n = 6 * k;
        for i in 0..n {
            let phi = std::f32::consts::TAU * i as f32 / n as f32;
            p.push(Vec2::new(phi.cos(), phi.sin()) * (k as f32 * spacing));
        }
    }
    p
}

/// K's taps (offsets in kernel texels, weights summing to about 1) gathered onto the regular
/// pattern of `rings` rings (see the module documentation); a kernel with no more taps than
/// the pattern keeps them, with variance 0.
pub fn filter_taps(taps: &[Tap], rings: u32) -> Vec<FilterTap> {
    let exact = |taps: &[Tap]| -> Vec<FilterTap> {
        taps.iter()
            .map(|t| FilterTap {
                offset: t.offset,
                weight: t.weight,
                variance: 0.0,
            })
            .collect()
    };
    let n = pattern_len(rings).min(MAX_FILTER_TAPS);
    if taps.len() <= n {
        return exact(taps);
    }
    let support = taps
        .iter()
        .map(|t| t.offset.length())
        .fold(0.0f32, f32::max)
        + 0.5;
    let pattern = regular_pattern(rings, support / (rings as f32 + 0.5));
    // Per pattern sample: Σw, Σw·o, Σw·|o|².
    let mut cells = vec![(0.0f64, [0.0f64; 2], 0.0f64); pattern.len()];
    for t in taps {
        let nearest = pattern
            .iter()
            .enumerate()
            .min_by(|a, b| {
                a.1.distance_squared(t.offset)
                    .total_cmp(&b.1.distance_squared(t.offset))
            })
            .map_or(0, |(i, _)| i);
        let (w, o) = (t.weight as f64, t.offset.as_dvec2());
        let c = &mut cells[nearest];
        c.0 += w;
        c.1[0] += w * o.x;
        c.1[1] += w * o.y;
        c.2 += w * o.length_squared();
    }
    let total: f64 = cells.iter().map(|c| c.0).sum();
    if total <= 0.0 {
        return exact(&taps[..1]);
    }
    cells
        .iter()
        .filter(|c| c.0 > 0.0)
        .map(|&(w, s, s2)| {
            let c = Vec2::new((s[0] / w) as f32, (s[1] / w) as f32);
            let spread = (s2 / w - (c.as_dvec2()).length_squared()).max(0.0);
            FilterTap {
                offset: c,
                weight: (w / total) as f32,
                // Half the 2D second moment per axis, plus the texel's box (1/12).
                variance: (0.5 * spread) as f32 + 1.0 / 12.0,
            }
        })
        .collect()
}

/// The MIP level a filter tap of per-axis `variance` (kernel texels²) reads at `scale`
/// pixels per kernel texel: ½ log₂(4 (variance·scale² + 1/6)), at least 0.
pub fn level(variance: f32, scale: f32) -> f32 {
    (0.5 * (4.0 * (variance * scale * scale + 1.0 / 6.0)).log2()).max(0.0)
}

/// The weight of a read at `q` (pixels) of level `level` in a `size` frame: 1 inside, 0 beyond,
/// linear over one footprint 2^level centred on the frame's edge. M holds nothing beyond the
/// frame, so such reads are left out of Σ W·c; cut at the edge, each of the filter's reads that
/// crosses it as the pixel moves changes the sum at once, a step across the whole row (bands
/// in a highlight whose kernel reaches past the frame).
pub fn edge_fade(q: Vec2, size: Vec2, level: f32) -> f32 {
    let inside = q.min(size - q).min_element();
    (inside / level.exp2() + 0.5).clamp(0.0, 1.0)
}

/// The finest detail of M, in pixels, that the filter `taps` keep at `scale` pixels per
/// kernel texel: 2^⌊L⌋ for the lowest level L read by a tap of at least half the mean
/// weight (1 when such a tap reads level 0, as every tap of an ungathered kernel does; the
/// lighter ones, single texels at the rim, carry too little weight to show detail). The
/// filter averages finer detail away, so M may be drawn at this pitch: image mode thins its
/// splats to it (Eq. 3's step).
pub fn detail_pixels(taps: &[FilterTap], scale: f32) -> f32 {
    let heavy = 0.5 / taps.len().max(1) as f32;
    let v = taps
        .iter()
        .filter(|t| t.weight >= heavy)
        .map(|t| t.variance)
        .fold(f32::INFINITY, f32::min);
    if !v.is_finite() {
        return 1.0;
    }
    level(v, scale).floor().exp2()
}

/// A MIP pyramid of an image on the CPU, built and read as the GPU does: level k is
/// max(1, ⌊w / 2^k⌋) × max(1, ⌊h / 2^k⌋), each texel the bilinear read of the level below at
/// its centre (a 2×2 box where the sizes halve exactly), down to 1×1.
#[derive(Clone, Debug, PartialEq)]
pub struct Pyramid {
    /// Per level: width, height, row-major texels (row 0 at the top).
    pub levels: Vec<(u32, u32, Vec<Vec4>)>,
}

/// Levels of a full MIP chain for a `width` × `height` base (as wgpu counts them).
pub fn level_count(width: u32, height: u32) -> u32 {
    32 - width.max(height).max(1).leading_zeros()
}

/// Bilinear read of a `width` × `height` image at `uv` ∈ [0, 1]² (texel centres at
/// (i + ½)/width), clamped to the edge.
pub fn bilinear(width: u32, height: u32, texels: &[Vec4], uv: Vec2) -> Vec4 {
    let q = uv * Vec2::new(width as f32, height as f32) - 0.5;
    let (x0, y0) = (q.x.floor(), q.y.floor());
    let (fx, fy) = (q.x - x0, q.y - y0);
    let at = |x: i64, y: i64| {
        let x = x.clamp(0, width as i64 - 1) as usize;
        let y = y.clamp(0, height as i64 - 1) as usize;
        texels[y * width as usize + x]
    };
    let (x0, y0) = (x0 as i64, y0 as i64);
    (at(x0, y0) * (1.0 - fx) + at(x0 + 1, y0) * fx) * (1.0 - fy)
        + (at(x0, y0 + 1) * (1.0 - fx) + at(x0 + 1, y0 + 1) * fx) * fy
}

impl Pyramid {
    /// The pyramid of a `width` × `height` base (row-major, row 0 at the top).
    pub fn new(width: u32, height: u32, base: Vec<Vec4>) -> Pyramid {
        let mut levels = vec![(width, height, base)];
        for _ in 1..level_count(width, height) {
            let (pw, ph, prev) = levels.last().expect("the base");
            let (w, h) = ((pw / 2).max(1), (ph / 2).max(1));
            let mut next = Vec::with_capacity((w * h) as usize);
            for y in 0..h {
                for x in 0..w {
                    let uv = Vec2::new((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
                    next.push(bilinear(*pw, *ph, prev, uv));
                }
            }
            levels.push((w, h, next));
        }
        Pyramid { levels }
    }

    /// The pyramid of the reflected image M (`rgb`, and its `covered` flags: false for a
    /// hole, which counts for nothing), texels (rgb·c, c).
    pub fn of_image(width: u32, height: u32, rgb: &[Vec3], covered: &[bool]) -> Pyramid {
        let base = rgb
            .iter()
            .zip(covered)
            .map(|(v, &c)| if c { v.extend(1.0) } else { Vec4::ZERO })
            .collect();
        Pyramid::new(width, height, base)
    }

    /// Trilinear read at `uv`, `level` clamped to the pyramid's levels.
    pub fn sample(&self, uv: Vec2, level: f32) -> Vec4 {
        let top = (self.levels.len() - 1) as f32;
        let l = level.clamp(0.0, top);
        let (k, f) = (l.floor() as usize, l.fract());
        let read = |k: usize| {
            let (w, h, t) = &self.levels[k];
            bilinear(*w, *h, t, uv)
        };
        if f > 0.0 && k + 1 < self.levels.len() {
            read(k) * (1.0 - f) + read(k + 1) * f
        } else {
            read(k)
        }
    }

    /// M*K at continuous pixel `pixel` (centres at +½) with `scale` pixels per kernel texel,
    /// the filter `taps` reading the pyramid (`fs_composite`'s gather): Σ W·rgb / Σ W·c over
    /// the reads within the frame, or `None` when no tap finds a covered texel; the taps
    /// squeezed as `grazing` says.
    pub fn filtered(
        &self,
        pixel: Vec2,
        scale: f32,
        taps: &[FilterTap],
        grazing: &Grazing,
    ) -> Option<Vec3> {
        let (w, h, _) = &self.levels[0];
        let size = Vec2::new(*w as f32, *h as f32);
        let reads = grazing.reads();
        let sum: Vec4 = taps
            .iter()
            .map(|t| {
                let p = pixel + grazing.offset(Vec2::new(t.offset.x, -t.offset.y) * scale, scale);
                let (l, step) = grazing.footprint(t.variance, scale, reads);
                (0..reads)
                    .map(|j| {
                        let q = p + grazing.axis * step * (j as f32 - 0.5 * (reads - 1) as f32);
                        // Beyond the frame M holds nothing: the read fades out across it.
                        let fade = edge_fade(q, size, l);
                        if fade > 0.0 {
                            self.sample(q / size, l) * fade
                        } else {
                            Vec4::ZERO
                        }
                    })
                    .sum::<Vec4>()
                    * (t.weight / reads as f32)
            })
            .sum();
        (sum.w > 1e-4).then(|| sum.truncate() / sum.w)
    }
}

/// The exact M*K of the equation: K's `taps` at `pixel` + offset·`scale` (y up), each a
/// bilinear read of the `width` × `height` image `m` (row 0 at the top) clamped to its edge.
/// With `continuous`, each kernel texel is the box it stands for: ⌈scale⌉² reads spread over
/// its scale × scale pixels (point taps spaced wider than a pixel alias thin features: the
/// blocky pattern of a rough lobe seen at a wide scale). Offsets squeezed as `grazing` says.
#[allow(clippy::too_many_arguments)]
pub fn exact(
    width: u32,
    height: u32,
    m: &[Vec4],
    pixel: Vec2,
    scale: f32,
    taps: &[Tap],
    continuous: bool,
    grazing: &Grazing,
) -> Vec3 {
    let size = Vec2::new(width as f32, height as f32);
    let n = if continuous {
        scale.ceil().max(1.0) as u32
    } else {
        1
    };
    let sub: Vec<Vec2> = (0..n * n)
        .map(|k| {
            let (i, j) = ((k % n) as f32, (k / n) as f32);
            (Vec2::new(i, j) + 0.5) / n as f32 - 0.5
        })
        .collect();
    taps.iter()
        .map(|t| {
            let centre = Vec2::new(t.offset.x, -t.offset.y) * scale;
            let sum: Vec3 = sub
                .iter()
                .map(|s| {
                    let p = pixel + grazing.offset(centre + *s * scale, scale);
                    bilinear(width, height, m, p / size).truncate()
                })
                .sum();
            t.weight * sum / sub.len() as f32
        })
        .sum()
}

#[cfg(test)]
mod tests;
