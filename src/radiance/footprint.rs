//! A map pixel's footprint on the surface its ray meets, so the bake reads textures over
//! the area a pixel covers: a texture finer than a map pixel read at one point per pixel
//! aliases into moiré. All of a map's rays leave its centre of projection, so the rays
//! through the neighbouring pixels' centres meet the hit triangle's plane at first order
//! where these ray differentials (Igehy 1999) say.

use glam::{Vec2, Vec3};

use crate::geometry::Triangle;

/// The rays through one map pixel and its neighbours: all from `apex`, along `dir`
/// (unnormalized) through the pixel's centre and along `dir + du`, `dir + dv` through the
/// next pixels' centres across and down.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelRays {
    /// The common origin (the map's centre of projection).
    pub apex: Vec3,
    /// Direction through the pixel's centre, unnormalized.
    pub dir: Vec3,
    /// Change of `dir` to the next pixel across.
    pub du: Vec3,
    /// Change of `dir` to the next pixel down.
    pub dv: Vec3,
}

impl PixelRays {
    /// The steps from `p`, where the pixel's ray meets the plane through `p` with normal `n`
    /// (any length), to where the neighbouring rays across and down meet it, to first order.
    pub fn plane_steps(&self, p: Vec3, n: Vec3) -> [Vec3; 2] {
        let dn = self.dir.dot(n);
        let s = (p - self.apex).dot(n) / dn;
        let step = |d: Vec3| (d - self.dir * (d.dot(n) / dn)) * s;
        [step(self.du), step(self.dv)]
    }

    /// [`PixelRays::plane_steps`] on `tri` at barycentrics `b`, as barycentric steps.
    pub fn bary_steps(&self, tri: &Triangle, b: Vec2) -> [Vec2; 2] {
        let n = tri.cross();
        let (e1, e2) = (tri.p[1] - tri.p[0], tri.p[2] - tri.p[0]);
        let nn = n.length_squared();
        // d = u·e1 + v·e2 in the plane: d × e2 = u·n and e1 × d = v·n.
        let bary = |d: Vec3| Vec2::new(d.cross(e2).dot(n), e1.cross(d).dot(n)) / nn;
        self.plane_steps(tri.point(b), n).map(bary)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On a tilted triangle, the barycentric steps lead to where the neighbouring rays
    /// really meet its plane (exactly: the surface is flat and the steps small).
    #[test]
    fn steps_land_where_the_neighbouring_rays_meet_the_plane() {
        let tri = Triangle {
            p: [
                Vec3::new(-2.0, 0.0, 3.0),
                Vec3::new(3.0, 0.5, 4.0),
                Vec3::new(0.0, 3.0, 5.5),
            ],
            n: [Vec3::Z; 3],
            uv: [Vec2::ZERO; 3],
            uv1: None,
            material: 0,
            object: 0,
        };
        let rays = PixelRays {
            apex: Vec3::new(0.2, 0.1, -1.0),
            dir: Vec3::new(0.05, 0.2, 1.0),
            du: Vec3::new(1e-3, 0.0, 0.0),
            dv: Vec3::new(0.0, 1e-3, 0.0),
        };
        let n = tri.face_normal();
        let meet = |d: Vec3| rays.apex + d * ((tri.p[0] - rays.apex).dot(n) / d.dot(n));
        let p = meet(rays.dir);
        // p's barycentrics.
        let (e1, e2) = (tri.p[1] - tri.p[0], tri.p[2] - tri.p[0]);
        let c = tri.cross();
        let b = Vec2::new(
            (p - tri.p[0]).cross(e2).dot(c),
            e1.cross(p - tri.p[0]).dot(c),
        ) / c.length_squared();
        assert!((tri.point(b) - p).length() < 1e-5);
        let [bu, bv] = rays.bary_steps(&tri, b);
        for (db, d) in [(bu, rays.du), (bv, rays.dv)] {
            let want = meet(rays.dir + d);
            let got = tri.point(b + db);
            assert!(
                (got - want).length() < 1e-3 * (want - p).length(),
                "{got} against {want}"
            );
        }
    }
}
