//! Where radiance maps are taken (Bastos et al. §8.1.3, Figure 4 left): the reflector is cut
//! into a grid of reflector elements; over each element, a hemisphere on the mirrored side
//! whose base circle passes through the element's corners; cameras at evenly spaced arc
//! lengths on it. Each camera's off-axis frustum has its centre of projection on the
//! hemisphere and the element as its near plane, and looks through the reflector.

use std::f32::consts::{FRAC_PI_2, TAU};

use glam::{Vec2, Vec3};

use super::footprint::PixelRays;
use crate::geometry::Triangle;
use crate::sampling::basis;
use crate::scene::{Plane, Reflector};

/// A planar reflector's frame: the plane's basis and the reflector's rectangle in it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReflectorFrame {
    /// Unit normal: the side the reflector faces (into the scene).
    pub normal: Vec3,
    /// In-plane axes.
    pub tangent: Vec3,
    /// Second in-plane axis (normal × tangent order as in [`basis`]).
    pub bitangent: Vec3,
    /// The rectangle's first corner (smallest tangent and bitangent coordinates).
    pub origin: Vec3,
    /// Its extent along tangent and bitangent.
    pub size: Vec2,
}

impl ReflectorFrame {
    /// The bounding rectangle of the reflector's triangles in its plane.
    pub fn new(plane: &Plane, reflector: &Reflector, triangles: &[Triangle]) -> ReflectorFrame {
        let n = plane.normal;
        let (t, b) = basis(n);
        let pts = reflector
            .triangles
            .iter()
            .flat_map(|&i| triangles[i as usize].p.iter());
        let (mut lo, mut hi) = (Vec2::INFINITY, Vec2::NEG_INFINITY);
        for p in pts {
            let q = Vec2::new((*p - plane.point).dot(t), (*p - plane.point).dot(b));
            lo = lo.min(q);
            hi = hi.max(q);
        }
        ReflectorFrame {
            normal: n,
            tangent: t,
            bitangent: b,
            origin: plane.point + t * lo.x + b * lo.y,
            size: hi - lo,
        }
    }

    /// Element (i, j) of an `nx × ny` grid: (corner, edge along tangent, edge along bitangent).
    pub fn element(&self, i: u32, j: u32, nx: u32, ny: u32) -> (Vec3, Vec3, Vec3) {
        let eu = self.tangent * (self.size.x / nx as f32);
        let ev = self.bitangent * (self.size.y / ny as f32);
        (self.origin + eu * i as f32 + ev * j as f32, eu, ev)
    }
}

/// One radiance map's camera: centre of projection behind the plane, and the element as its
/// image (near) plane. Pixel (x, y) covers element point corner + (x+½)/w·edge_u + (y+½)/h·edge_v.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MapCamera {
    /// Centre of projection (on the hemisphere, on the mirrored side).
    pub centre: Vec3,
    /// Element corner (pixel (0, 0) corner).
    pub corner: Vec3,
    /// Element edge along x.
    pub edge_u: Vec3,
    /// Element edge along y.
    pub edge_v: Vec3,
    /// Reflector normal (towards the scene).
    pub normal: Vec3,
    /// Map width and height in pixels.
    pub resolution: u32,
}

impl MapCamera {
    /// The point of the element at pixel coordinates (x, y) (continuous, pixel centres at +½).
    pub fn image_point(&self, x: f32, y: f32) -> Vec3 {
        let r = self.resolution as f32;
        self.corner + self.edge_u * (x / r) + self.edge_v * (y / r)
    }

    /// Ray through the centre of pixel (x, y): it starts on the element (the near plane) and
    /// leaves towards the scene. Returns (origin, unit direction).
    pub fn pixel_ray(&self, x: u32, y: u32) -> (Vec3, Vec3) {
        let q = self.image_point(x as f32 + 0.5, y as f32 + 0.5);
        (q, (q - self.centre).normalize())
    }

    /// The rays through pixel (x, y)'s centre and its neighbours' across and down, from the
    /// centre of projection.
    pub fn pixel_rays(&self, x: u32, y: u32) -> PixelRays {
        let r = self.resolution as f32;
        PixelRays {
            apex: self.centre,
            dir: self.image_point(x as f32 + 0.5, y as f32 + 0.5) - self.centre,
            du: self.edge_u / r,
            dv: self.edge_v / r,
        }
    }

    /// Depth of a point: its distance from the centre of projection along the normal.
    pub fn depth(&self, p: Vec3) -> f32 {
        (p - self.centre).dot(self.normal)
    }

    /// Projects a scene point into the map: continuous pixel coordinates and depth, or `None`
    /// when it lies on or behind the centre of projection's plane.
    pub fn project(&self, p: Vec3) -> Option<(Vec2, f32)> {
        let z = self.depth(p);
        let h = self.depth(self.corner); // distance of the image plane
        if z <= 0.0 || h <= 0.0 {
            return None;
        }
        let q = self.centre + (p - self.centre) * (h / z) - self.corner;
        let r = self.resolution as f32;
        let x = q.dot(self.edge_u) / self.edge_u.length_squared() * r;
        let y = q.dot(self.edge_v) / self.edge_v.length_squared() * r;
        Some((Vec2::new(x, y), z))
    }

    /// The scene point seen at pixel (x, y) at depth `z` (the inverse of [`MapCamera::project`]).
    pub fn unproject(&self, x: f32, y: f32, z: f32) -> Vec3 {
        let q = self.image_point(x, y);
        self.centre + (q - self.centre) * (z / self.depth(q))
    }
}

/// Largest polar angle of a camera from the hemisphere's pole: short of the rim, where the
/// element would be seen edge-on and the frustum would collapse.
pub const MAX_POLAR_DEG: f32 = 80.0;

/// Centres of projection for `count` cameras over an element: the pole, then rings at evenly
/// spaced polar angles up to [`MAX_POLAR_DEG`], each ring holding cameras in proportion to its
/// circumference so arc lengths between neighbours stay even. Deterministic.
pub fn hemisphere_cameras(
    corner: Vec3,
    edge_u: Vec3,
    edge_v: Vec3,
    normal: Vec3,
    count: u32,
) -> Vec<Vec3> {
    let centre = corner + 0.5 * (edge_u + edge_v);
    let radius = 0.5 * (edge_u + edge_v).length(); // the base circle passes through the corners
    let (t, b) = (edge_u.normalize(), edge_v.normalize());
    let down = -normal;
    let mut out = vec![centre + down * radius];
    if count <= 1 {
        return out;
    }
    // Choose the ring count whose cameras (∝ sin θ) add up closest to count − 1.
    let max_polar = MAX_POLAR_DEG.to_radians();
    let rings_for = |rings: u32| -> Vec<u32> {
        let want = (count - 1) as f32;
        let sines: Vec<f32> = (1..=rings)
            .map(|k| (max_polar * k as f32 / rings as f32).sin())
            .collect();
        let weight: f32 = sines.iter().sum();
        let exact: Vec<f32> = sines.iter().map(|s| want * s / weight).collect();
        let mut per: Vec<u32> = exact.iter().map(|e| (e.floor() as u32).max(1)).collect();
        // Largest remainders first (ties to the outer ring), until the total is exact.
        let mut order: Vec<usize> = (0..per.len()).collect();
        order.sort_by(|&a, &b| {
            (exact[b] - exact[b].floor())
                .total_cmp(&(exact[a] - exact[a].floor()))
                .then(b.cmp(&a))
        });
        let mut total: u32 = per.iter().sum();
        for &k in order.iter().cycle().take(4 * per.len()) {
            if total < count - 1 {
                per[k] += 1;
                total += 1;
            }
        }
        while total > count - 1 {
            let k = (0..per.len()).max_by_key(|&k| per[k]).expect("rings");
            per[k] -= 1;
            total -= 1;
        }
        per
    };
    // Rings spaced like the cameras on them: about √(count/2) rings.
    let rings = (((count - 1) as f32 / 2.0).sqrt().round() as u32).clamp(1, count - 1);
    let per = rings_for(rings);
    for (k, &n) in per.iter().enumerate() {
        let theta = max_polar * (k + 1) as f32 / rings as f32;
        // Offset alternate rings by half a step so cameras don't line up radially.
        let phase = if k % 2 == 1 { 0.5 } else { 0.0 };
        for m in 0..n {
            let phi = TAU * (m as f32 + phase) / n as f32;
            let dir = down * theta.cos() + (t * phi.cos() + b * phi.sin()) * theta.sin();
            out.push(centre + dir * radius);
        }
    }
    debug_assert!(max_polar < FRAC_PI_2);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cameras_lie_on_the_hemisphere_behind_the_element() {
        let (corner, eu, ev, n) = (
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::X * 2.0,
            Vec3::Z * 2.0,
            Vec3::Y,
        );
        for count in [1u32, 2, 5, 9, 23, 67] {
            let cams = hemisphere_cameras(corner, eu, ev, n, count);
            assert_eq!(cams.len() as u32, count);
            let centre = corner + 0.5 * (eu + ev);
            let r = 2f32.sqrt();
            for c in &cams {
                assert!(((*c - centre).length() - r).abs() < 1e-4, "{c}");
                // Behind the plane, and not at the rim.
                let polar = (-(*c - centre).normalize().dot(n)).acos().to_degrees();
                assert!(
                    polar <= MAX_POLAR_DEG + 1e-3 && c.y < 0.0,
                    "{c} at {polar}°"
                );
            }
        }
    }

    #[test]
    fn project_inverts_unproject_even_for_grazing_cameras() {
        let (corner, eu, ev, n) = (
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::X * 2.0,
            Vec3::Z * 2.0,
            Vec3::Y,
        );
        for c in hemisphere_cameras(corner, eu, ev, n, 23) {
            let cam = MapCamera {
                centre: c,
                corner,
                edge_u: eu,
                edge_v: ev,
                normal: n,
                resolution: 64,
            };
            for (x, y, z) in [(0.5, 0.5, 3.0), (63.5, 10.5, 0.9), (20.25, 63.75, 40.0)] {
                let p = cam.unproject(x, y, z);
                let (q, d) = cam.project(p).unwrap();
                assert!(
                    (q - Vec2::new(x, y)).length() < 1e-2 && (d - z).abs() < 1e-3 * z,
                    "{c}: {q} {d}"
                );
            }
            let (o, d) = cam.pixel_ray(0, 0);
            assert!(d.is_finite() && d.dot(n) > 0.0 && o.y.abs() < 1e-6);
        }
    }
}
