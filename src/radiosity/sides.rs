//! Which texels a ray meeting a surface reads, where some of the scene's triangles have back
//! sides of their own ([`super::back_sides`]): the atlas numbers each back side's *twin* after
//! the scene's triangles. Pure lookups and geometry, shared by the solve, the atlas and every
//! stage that reads D after it.

use glam::Vec2;

use crate::geometry::Triangle;

/// The atlas triangle holding the back side of scene triangle `triangle` (`backs`: the
/// triangles with back sides, ascending, their twins numbered from `scene_triangles`).
pub fn back_in(backs: &[u32], scene_triangles: usize, triangle: u32) -> Option<u32> {
    backs
        .binary_search(&triangle)
        .ok()
        .map(|k| (scene_triangles + k) as u32)
}

/// Where to read D for point `bary` of scene triangle `triangle`, seen from its front or
/// (`back`) from behind: the triangle itself, or the twin of its back side ([`back_in`]),
/// whose barycentrics are swapped ([`twin`]).
pub fn side_in(
    backs: &[u32],
    scene_triangles: usize,
    (triangle, bary): (u32, Vec2),
    back: bool,
) -> (u32, Vec2) {
    match back
        .then(|| back_in(backs, scene_triangles, triangle))
        .flatten()
    {
        Some(twin) => (twin, Vec2::new(bary.y, bary.x)),
        None => (triangle, bary),
    }
}

/// Which texels a ray meeting a scene triangle reads: the triangle's own, or, at the back of
/// a triangle with a back side, its twin's. What the stages that read D after the solve
/// (radiance maps, environment maps and probes) need of the atlas ([`Atlas::sides`]).
///
/// [`Atlas::sides`]: super::atlas::Atlas::sides
#[derive(Clone, Debug, Default)]
pub struct Sides {
    /// The scene's triangle count: the twin of `backs[k]` is atlas triangle
    /// `scene_triangles + k`.
    pub scene_triangles: usize,
    /// The scene triangles with back sides, ascending.
    pub backs: Vec<u32>,
}

impl Sides {
    /// Where to read D for point `bary` of scene triangle `triangle`, seen from its front or
    /// (`back`) from behind ([`side_in`]).
    pub fn side(&self, triangle: u32, bary: Vec2, back: bool) -> (u32, Vec2) {
        side_in(&self.backs, self.scene_triangles, (triangle, bary), back)
    }

    /// The scene triangle and its barycentrics of atlas triangle `triangle`'s point `bary`
    /// ([`Sides::side`] undone): where its texture is read.
    pub fn front_of(&self, triangle: u32, bary: Vec2) -> (u32, Vec2) {
        let k = (triangle as usize).wrapping_sub(self.scene_triangles);
        match self.backs.get(k) {
            Some(&front) => (front, Vec2::new(bary.y, bary.x)),
            None => (triangle, bary),
        }
    }

    /// The atlas's triangles: the scene's `triangles` followed by the twins, borrowed where
    /// there are none. A twin's material is its front's.
    pub fn sided<'a>(&self, triangles: &'a [Triangle]) -> std::borrow::Cow<'a, [Triangle]> {
        if self.backs.is_empty() {
            std::borrow::Cow::Borrowed(triangles)
        } else {
            std::borrow::Cow::Owned(with_twins(triangles, &self.backs))
        }
    }
}

/// Triangle `t` seen from behind: the same points wound the other way, normals reversed.
/// Barycentrics (u, v) on `t` are (v, u) on its twin.
pub fn twin(t: &Triangle) -> Triangle {
    let swap = |a: [Vec2; 3]| [a[0], a[2], a[1]];
    Triangle {
        p: [t.p[0], t.p[2], t.p[1]],
        n: [-t.n[0], -t.n[2], -t.n[1]],
        uv: swap(t.uv),
        uv1: t.uv1.map(swap),
        material: t.material,
        object: t.object,
    }
}

/// `scene`'s triangles followed by the twins of `backs`, in that order: what the atlas and
/// the solve work on.
pub fn with_twins(triangles: &[Triangle], backs: &[u32]) -> Vec<Triangle> {
    let mut out = Vec::with_capacity(triangles.len() + backs.len());
    out.extend_from_slice(triangles);
    out.extend(backs.iter().map(|&t| twin(&triangles[t as usize])));
    out
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use glam::Vec3;

    /// A flat triangle of `material` through `p` (also the back sides' tests').
    pub(in crate::radiosity) fn tri(p: [Vec3; 3], material: u32) -> Triangle {
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
        Triangle {
            p,
            n: [n; 3],
            uv: [Vec2::ZERO, Vec2::X, Vec2::Y],
            uv1: None,
            material,
            object: 0,
        }
    }

    #[test]
    fn a_twin_is_the_same_point_with_barycentrics_swapped_and_faces_away() {
        let t = tri([Vec3::ZERO, Vec3::X, Vec3::Z * 2.0], 3);
        let w = twin(&t);
        assert_eq!(w.face_normal(), -t.face_normal());
        assert_eq!(
            w.normal(Vec2::new(0.2, 0.3)),
            -t.normal(Vec2::new(0.2, 0.3))
        );
        for b in [Vec2::new(0.1, 0.7), Vec2::new(0.5, 0.25), Vec2::ZERO] {
            assert!(t.point(b).distance(w.point(Vec2::new(b.y, b.x))) < 1e-6);
        }
        assert_eq!(w.material, 3);
        let all = with_twins(&[t, t], &[1]);
        assert_eq!(all.len(), 3);
        assert_eq!(all[2].p, w.p);
    }

    #[test]
    fn sides_map_a_back_to_its_twin_and_back() {
        let sides = Sides {
            scene_triangles: 5,
            backs: vec![1, 3],
        };
        let b = Vec2::new(0.2, 0.7);
        assert_eq!(sides.side(3, b, true), (6, Vec2::new(0.7, 0.2)));
        assert_eq!(sides.side(3, b, false), (3, b));
        assert_eq!(sides.side(2, b, true), (2, b));
        assert_eq!(sides.front_of(6, Vec2::new(0.7, 0.2)), (3, b));
        assert_eq!(sides.front_of(5, b), (1, Vec2::new(0.7, 0.2)));
        assert_eq!(sides.front_of(4, b), (4, b));
        assert_eq!(sides.front_of(7, b), (7, b));
        let none = Sides::default();
        assert_eq!(none.side(3, b, true), (3, b));
        assert_eq!(none.front_of(3, b), (3, b));
    }
}
