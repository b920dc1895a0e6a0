//! World-space triangles and ray casting.

pub mod bvh;
pub mod quad;

use glam::{Vec2, Vec3};

pub use bvh::{Bvh, Hit};
pub use quad::ray_quad;

/// One world-space triangle with its shading attributes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    /// Vertex positions, metres.
    pub p: [Vec3; 3],
    /// Unit vertex normals (the face normal when the glTF has none).
    pub n: [Vec3; 3],
    /// First UV set (zero when absent).
    pub uv: [Vec2; 3],
    /// Second UV set (`TEXCOORD_1`), the lightmap UVs when the glTF has them.
    pub uv1: Option<[Vec2; 3]>,
    /// Index into the scene's materials.
    pub material: u32,
    /// Index into the scene's objects (glTF node instances).
    pub object: u32,
}

impl Triangle {
    /// Unnormalized geometric normal (v1 − v0) × (v2 − v0); its length is twice the area.
    pub fn cross(&self) -> Vec3 {
        (self.p[1] - self.p[0]).cross(self.p[2] - self.p[0])
    }

    /// Area in square metres.
    pub fn area(&self) -> f32 {
        0.5 * self.cross().length()
    }

    /// Unit geometric normal (counter-clockwise winding).
    pub fn face_normal(&self) -> Vec3 {
        self.cross().normalize_or_zero()
    }

    /// Point at barycentrics (u, v): (1 − u − v)·p0 + u·p1 + v·p2.
    pub fn point(&self, b: Vec2) -> Vec3 {
        interpolate(&self.p, b)
    }

    /// Interpolated unit shading normal at barycentrics (u, v).
    pub fn normal(&self, b: Vec2) -> Vec3 {
        interpolate(&self.n, b).normalize_or(self.face_normal())
    }

    /// The shading normal at barycentrics (u, v): [`Triangle::normal`], or the face normal
    /// where that leans behind the face.
    pub fn shading_normal(&self, b: Vec2) -> Vec3 {
        let (ng, ns) = (self.face_normal(), self.normal(b));
        if ns.dot(ng) <= 0.0 { ng } else { ns }
    }

    /// Interpolated UV at barycentrics (u, v).
    pub fn uv_at(&self, b: Vec2) -> Vec2 {
        interpolate(&self.uv, b)
    }

    /// Interpolated lightmap UV (set 1) at barycentrics (u, v), if the triangle has one.
    pub fn uv1_at(&self, b: Vec2) -> Option<Vec2> {
        self.uv1.map(|uv| interpolate(&uv, b))
    }

    /// Whether the triangle has finite positions and a non-zero area relative to its size.
    pub fn is_valid(&self) -> bool {
        if !self.p.iter().all(|p| p.is_finite()) {
            return false;
        }
        let longest = (self.p[1] - self.p[0])
            .length_squared()
            .max((self.p[2] - self.p[1]).length_squared())
            .max((self.p[0] - self.p[2]).length_squared());
        // Twice the area against the squared longest edge: a needle whose height is below
        // ~1e-7 of its length carries no area that a ray can hit reliably.
        let cross = self.cross().length();
        longest > 0.0 && cross.is_finite() && cross > 1e-7 * longest
    }
}

fn interpolate<T>(v: &[T; 3], b: Vec2) -> T
where
    T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>,
{
    v[0] * (1.0 - b.x - b.y) + v[1] * b.x + v[2] * b.y
}

/// Axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box (min = +∞, max = −∞), the identity of [`Aabb::grow`].
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::INFINITY,
        max: Vec3::NEG_INFINITY,
    };

    /// The box of a set of points.
    pub fn from_points<'a>(points: impl IntoIterator<Item = &'a Vec3>) -> Aabb {
        points.into_iter().fold(Aabb::EMPTY, |b, p| b.grow(*p))
    }

    /// The box grown to contain `p`.
    pub fn grow(self, p: Vec3) -> Aabb {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// Length of the diagonal (0 for an empty box).
    pub fn diagonal(&self) -> f32 {
        if self.min.cmple(self.max).all() {
            (self.max - self.min).length()
        } else {
            0.0
        }
    }

    /// Length of the longest side (0 for an empty box).
    pub fn longest_side(&self) -> f32 {
        if self.min.cmple(self.max).all() {
            (self.max - self.min).max_element()
        } else {
            0.0
        }
    }

    /// Centre point.
    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri(p: [Vec3; 3]) -> Triangle {
        Triangle {
            p,
            n: [Vec3::Z; 3],
            uv: [Vec2::ZERO; 3],
            uv1: None,
            material: 0,
            object: 0,
        }
    }

    #[test]
    fn area_and_normal_of_a_right_triangle() {
        let t = tri([Vec3::ZERO, Vec3::X, Vec3::Y]);
        assert_eq!(t.area(), 0.5);
        assert_eq!(t.face_normal(), Vec3::Z);
        assert_eq!(t.point(Vec2::new(0.5, 0.5)), Vec3::new(0.5, 0.5, 0.0));
    }

    #[test]
    fn degenerate_and_non_finite_triangles_are_invalid() {
        assert!(!tri([Vec3::ZERO, Vec3::X, 2.0 * Vec3::X]).is_valid());
        assert!(!tri([Vec3::ZERO, Vec3::ZERO, Vec3::ZERO]).is_valid());
        assert!(!tri([Vec3::ZERO, Vec3::X, Vec3::new(f32::NAN, 0.0, 0.0)]).is_valid());
        assert!(!tri([Vec3::ZERO, Vec3::X, Vec3::new(0.0, f32::INFINITY, 0.0)]).is_valid());
        // Tiny but well shaped: valid at any scale.
        let s = 1e-6;
        assert!(tri([Vec3::ZERO, Vec3::X * s, Vec3::Y * s]).is_valid());
        let s = 1e6;
        assert!(tri([Vec3::ZERO, Vec3::X * s, Vec3::Y * s]).is_valid());
    }

    #[test]
    fn aabb_diagonal() {
        let b = Aabb::from_points(&[Vec3::ZERO, Vec3::new(3.0, 4.0, 0.0)]);
        assert_eq!(b.diagonal(), 5.0);
        assert_eq!(Aabb::EMPTY.diagonal(), 0.0);
    }
}
