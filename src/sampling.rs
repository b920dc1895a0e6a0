//! Random numbers and warps shared by the bakers, the reference renderer and the benchmarks.
//!
//! Samplers come in threes (`sample_*`, `*_pdf`, `invert_*`) with the random numbers passed
//! in, so every stage is deterministic for a seed whatever the thread count: each work item
//! seeds its own [`Rng`] from (seed, item index).

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

/// PCG32 (O'Neill 2014, XSH-RR output): small, fast, and statistically good enough for
/// Monte Carlo; one stream per work item.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    inc: u64,
}

impl Rng {
    /// A generator for stream `stream` of seed `seed` (e.g. seed = bake seed, stream = texel).
    pub fn new(seed: u64, stream: u64) -> Rng {
        let mut r = Rng {
            state: 0,
            inc: (stream << 1) | 1,
        };
        r.next_u32();
        r.state = r.state.wrapping_add(seed);
        r.next_u32();
        r
    }

    /// Next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(6364136223846793005).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }

    /// Uniform in [0, 1): 24 random mantissa bits, so 1.0 is never returned.
    pub fn uniform(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// Two uniforms in [0, 1)².
    pub fn uniform2(&mut self) -> Vec2 {
        Vec2::new(self.uniform(), self.uniform())
    }
}

/// Point `k` of the R2 sequence (Roberts 2018, the Kronecker sequence of the plastic
/// number), shifted by `shift` modulo 1. Every prefix of it covers the unit square evenly, so
/// an estimate over its first N points has far less variance than over N independent points
/// when the integrand is smooth; the random shift (Cranley–Patterson rotation) makes each
/// point uniform, so such an estimate stays unbiased.
pub fn r2(k: u32, shift: Vec2) -> Vec2 {
    // 1/g and 1/g² for g the plastic number, the root of x³ = x + 1.
    const A: [f64; 2] = [0.754_877_666_246_692_7, 0.569_840_290_998_053_2];
    let below_one = 1.0 - f32::EPSILON / 2.0;
    let at = |i: usize, s: f32| {
        let x = (s as f64 + (k as f64 + 1.0) * A[i]).fract();
        (x as f32).min(below_one)
    };
    Vec2::new(at(0, shift.x), at(1, shift.y))
}

/// An orthonormal basis (t, b) completing unit `n` to a right-handed frame
/// (Duff et al. 2017, "Building an Orthonormal Basis, Revisited": no branch on |n.z|).
pub fn basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Cosine-weighted direction on the hemisphere around +Z (Malley's method: a uniform disk
/// point lifted to the hemisphere).
pub fn sample_cosine_hemisphere(u: Vec2) -> Vec3 {
    let r = u.x.sqrt();
    let phi = 2.0 * PI * u.y;
    let z = (1.0 - u.x).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Density of [`sample_cosine_hemisphere`] w.r.t. solid angle: cos θ / π (0 below the horizon).
pub fn cosine_hemisphere_pdf(d: Vec3) -> f32 {
    d.z.max(0.0) / PI
}

/// The random numbers that [`sample_cosine_hemisphere`] maps to `d`.
pub fn invert_cosine_hemisphere(d: Vec3) -> Vec2 {
    let u1 = (d.x * d.x + d.y * d.y).min(1.0);
    let mut phi = d.y.atan2(d.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    Vec2::new(u1, (phi / (2.0 * PI)).min(1.0 - f32::EPSILON))
}

/// A uniform point on a triangle, as barycentrics (u, v) (Heitz 2019's low-distortion map
/// would also do; the square-root map is exact and simple).
pub fn sample_triangle(u: Vec2) -> Vec2 {
    let su = u.x.sqrt();
    Vec2::new(1.0 - su, u.y * su)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn r2_prefixes_cover_the_square_evenly_and_integrate_well() {
        let shift = Vec2::new(0.3, 0.8);
        // 256 points in an 8 × 8 grid: 4 per cell on average; independent points leave
        // some cell with 0 or 1 or 9+ nearly always.
        let mut cells = [0u32; 64];
        for k in 0..256 {
            let u = r2(k, shift);
            assert!(
                (0.0..1.0).contains(&u.x) && (0.0..1.0).contains(&u.y),
                "{u}"
            );
            cells[(u.x * 8.0) as usize + 8 * (u.y * 8.0) as usize] += 1;
        }
        assert!(cells.iter().all(|&c| (2..=6).contains(&c)), "{cells:?}");
        // ∫∫ x y = 1/4: an independent 1024-point estimate errs by ~0.007 (1 σ).
        let est: f64 = (0..1024)
            .map(|k| {
                let u = r2(k, shift);
                (u.x * u.y) as f64
            })
            .sum::<f64>()
            / 1024.0;
        assert!((est - 0.25).abs() < 1e-3, "{est}");
        // A point never reaches 1, whatever the shift.
        assert!(r2(0, Vec2::splat(1.0 - f32::EPSILON)).max_element() < 1.0);
    }

    #[test]
    fn rng_is_deterministic_and_streams_differ() {
        let a: Vec<u32> = (0..4)
            .map({
                let mut r = Rng::new(7, 1);
                move |_| r.next_u32()
            })
            .collect();
        let b: Vec<u32> = (0..4)
            .map({
                let mut r = Rng::new(7, 1);
                move |_| r.next_u32()
            })
            .collect();
        let c: Vec<u32> = (0..4)
            .map({
                let mut r = Rng::new(7, 2);
                move |_| r.next_u32()
            })
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn uniform_mean_and_range() {
        let mut r = Rng::new(1, 0);
        let n = 100_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let u = r.uniform();
            assert!((0.0..1.0).contains(&u));
            sum += u as f64;
        }
        // Standard error of the mean: 1/sqrt(12 n) ≈ 0.0009; allow 5 sigma.
        assert!((sum / n as f64 - 0.5).abs() < 0.005);
    }

    #[test]
    fn basis_is_orthonormal_for_every_axis_including_negative_z() {
        for n in [
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(1.0, 2.0, -3.0).normalize(),
            Vec3::new(0.0, 1e-8, -1.0).normalize(),
        ] {
            let (t, b) = basis(n);
            assert!(
                (t.length() - 1.0).abs() < 1e-5 && (b.length() - 1.0).abs() < 1e-5,
                "{n}"
            );
            assert!(
                t.dot(b).abs() < 1e-5 && t.dot(n).abs() < 1e-5 && b.dot(n).abs() < 1e-5,
                "{n}"
            );
            assert!((t.cross(b) - n).length() < 1e-5, "right-handed for {n}");
        }
    }

    #[test]
    fn cosine_hemisphere_round_trip_and_pdf_integral() {
        for i in 0..16 {
            for j in 0..16 {
                let u = Vec2::new((i as f32 + 0.5) / 16.0, (j as f32 + 0.5) / 16.0);
                let d = sample_cosine_hemisphere(u);
                assert!((d.length() - 1.0).abs() < 1e-5 && d.z >= 0.0);
                let back = invert_cosine_hemisphere(d);
                assert!(
                    (back - u).abs().max_element() < 1e-4,
                    "{u} -> {d} -> {back}"
                );
            }
        }
        // Monte Carlo with this pdf: ∫ cos²θ dω over the hemisphere = 2π/3.
        let mut r = Rng::new(3, 0);
        let n = 200_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let d = sample_cosine_hemisphere(r.uniform2());
            sum += (d.z * d.z / cosine_hemisphere_pdf(d)) as f64;
        }
        let est = sum / n as f64;
        let exact = 2.0 * std::f64::consts::PI / 3.0;
        // Standard deviation of π·cosθ under this pdf is ≈ 0.74; 5 sigma of the mean is 0.008.
        assert!((est - exact).abs() < 0.01, "{est} vs {exact}");
    }

    #[test]
    fn triangle_samples_are_inside_and_uniform() {
        let mut r = Rng::new(5, 0);
        let n = 100_000;
        let mut in_first_half = 0;
        for _ in 0..n {
            let b = sample_triangle(r.uniform2());
            assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
            // The sub-triangle with u > 0.5 holds a quarter of the area.
            if b.x > 0.5 {
                in_first_half += 1;
            }
        }
        let frac = in_first_half as f64 / n as f64;
        assert!((frac - 0.25).abs() < 0.01, "{frac}");
    }
}
