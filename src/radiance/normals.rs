//! Surface normals stored with radiance maps: octahedral encoding (Cigolle et al. 2014,
//! "A Survey of Efficient Representations for Independent Unit Vectors", §3.1), two numbers
//! in [−1, 1] per unit vector, and their 2 × 16-bit snorm packing, the layout of WGSL's
//! `pack2x16snorm` / `unpack2x16snorm`.

use glam::{Vec2, Vec3};

/// The octahedral coordinates of unit vector `n` (each in [−1, 1]); a zero or non-finite `n`
/// gives (0, 0), the +z pole.
pub fn encode(n: Vec3) -> Vec2 {
    let l1 = n.x.abs() + n.y.abs() + n.z.abs();
    if !(l1 > 0.0 && l1.is_finite()) {
        return Vec2::ZERO;
    }
    let p = Vec2::new(n.x, n.y) / l1;
    if n.z >= 0.0 {
        p
    } else {
        // The lower half folded over the diagonals.
        (Vec2::ONE - Vec2::new(p.y.abs(), p.x.abs())) * sign_not_zero(p)
    }
}

/// The unit vector of octahedral coordinates `e` (inverse of [`encode`]).
pub fn decode(e: Vec2) -> Vec3 {
    let e = e.clamp(Vec2::NEG_ONE, Vec2::ONE);
    let z = 1.0 - e.x.abs() - e.y.abs();
    let xy = if z >= 0.0 {
        e
    } else {
        (Vec2::ONE - Vec2::new(e.y.abs(), e.x.abs())) * sign_not_zero(e)
    };
    Vec3::new(xy.x, xy.y, z).normalize()
}

fn sign_not_zero(v: Vec2) -> Vec2 {
    Vec2::new(
        if v.x >= 0.0 { 1.0 } else { -1.0 },
        if v.y >= 0.0 { 1.0 } else { -1.0 },
    )
}

/// `e` as WGSL's `pack2x16snorm`: x in the low 16 bits, each round(clamp(c, −1, 1) · 32767).
pub fn pack_snorm2x16(e: Vec2) -> u32 {
    let q = |c: f32| ((c.clamp(-1.0, 1.0) * 32767.0).round() as i16) as u16 as u32;
    q(e.x) | (q(e.y) << 16)
}

/// WGSL's `unpack2x16snorm`: the inverse of [`pack_snorm2x16`] up to its rounding.
pub fn unpack_snorm2x16(bits: u32) -> Vec2 {
    let c = |b: u32| ((b as u16 as i16) as f32 / 32767.0).max(-1.0);
    Vec2::new(c(bits & 0xffff), c(bits >> 16))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_over_the_sphere_and_at_the_folds() {
        let mut worst: f32 = 0.0;
        let mut check = |n: Vec3| {
            let n = n.normalize();
            let back = decode(encode(n));
            worst = worst.max((back - n).length());
            // Through 16-bit snorm: within 1e-4 (a few 1 / 32767 steps of the octahedron).
            let packed = decode(unpack_snorm2x16(pack_snorm2x16(encode(n))));
            assert!((packed - n).length() < 1e-4, "{n} -> {packed}");
        };
        // The axes, the diagonals and the fold lines (z = 0, x = 0, y = 0 on the lower half).
        for n in [
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            -Vec3::X,
            -Vec3::Y,
            -Vec3::Z,
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, -1e-7),
            Vec3::new(0.0, -1.0, -1.0),
            Vec3::new(1.0, -1.0, -1.0),
        ] {
            check(n);
        }
        // A Fibonacci sphere.
        let count = 2000;
        for i in 0..count {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / count as f32;
            let phi = i as f32 * 2.399_963;
            let r = (1.0 - z * z).sqrt();
            check(Vec3::new(r * phi.cos(), r * phi.sin(), z));
        }
        assert!(worst < 1e-5, "float round trip off by {worst}");
        assert_eq!(encode(Vec3::ZERO), Vec2::ZERO);
        assert_eq!(decode(Vec2::ZERO), Vec3::Z);
    }

    #[test]
    fn snorm_packing_is_wgsls() {
        // pack2x16snorm(vec2(1, -1)) = 0x8001_7fff; 0.25 · 32767 = 8191.75 rounds to 0x2000.
        assert_eq!(pack_snorm2x16(Vec2::new(1.0, -1.0)), 0x8001_7fff);
        assert_eq!(pack_snorm2x16(Vec2::new(0.25, 0.0)), 0x0000_2000);
        assert_eq!(
            unpack_snorm2x16(0x8000_7fff),
            Vec2::new(1.0, -1.0),
            "−32768 clamps to −1"
        );
    }
}
