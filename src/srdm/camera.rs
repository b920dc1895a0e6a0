//! The planar pinhole camera of a depth-map impostor (Popescu §4.1, "pphc").

use glam::{Vec2, Vec3};

use crate::camera::Camera;

/// A square pinhole camera whose hither and yon planes enclose the captured object.
///
/// Projection of a world point p (see the module docs for image coordinates):
/// eye coordinates (x, y, z) = ((p − o)·right, (p − o)·up, (p − o)·forward); with
/// h = tan(fov_y / 2), pixel = ((x / (z h) + 1) w / 2, (1 − y / (z h)) w / 2) and depth
/// d = (1/z − 1/yon) / (1/hither − 1/yon).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImpostorCamera {
    /// Pose and vertical field of view (the image is square, so it is also the horizontal one).
    pub view: Camera,
    /// Distance of the hither plane along `view.forward`, > 0.
    pub hither: f32,
    /// Distance of the yon plane, > hither.
    pub yon: f32,
    /// Image width and height in texels.
    pub resolution: u32,
}

impl ImpostorCamera {
    /// tan(fov_y / 2): the image's half extent at unit distance.
    pub fn tan_half_fov(&self) -> f32 {
        // The same expression as Camera::ray_direction, so capture rays and projection agree.
        (0.5 * self.view.fov_y).tan()
    }

    /// Eye coordinates (x right, y up, z along the view direction) of a world point.
    pub fn eye(&self, p: Vec3) -> Vec3 {
        let q = p - self.view.position;
        Vec3::new(
            q.dot(self.view.right),
            q.dot(self.view.up),
            q.dot(self.view.forward),
        )
    }

    /// Eye coordinates of a world direction.
    pub fn eye_dir(&self, d: Vec3) -> Vec3 {
        Vec3::new(
            d.dot(self.view.right),
            d.dot(self.view.up),
            d.dot(self.view.forward),
        )
    }

    /// Normalized 1/z (Figure 10): 1 on the hither plane, 0 on the yon plane.
    pub fn depth_of_z(&self, z: f32) -> f32 {
        let inv_yon = 1.0 / self.yon;
        (1.0 / z - inv_yon) / (1.0 / self.hither - inv_yon)
    }

    /// The distance z along the view direction of normalized depth `d`.
    pub fn z_of_depth(&self, d: f32) -> f32 {
        let inv_yon = 1.0 / self.yon;
        1.0 / (d * (1.0 / self.hither - inv_yon) + inv_yon)
    }

    /// (pixel x, pixel y, depth) of an eye-space point with z > 0.
    pub fn project_eye(&self, e: Vec3) -> Vec3 {
        let half = 0.5 * self.resolution as f32;
        let s = 1.0 / (e.z * self.tan_half_fov());
        Vec3::new(
            (e.x * s + 1.0) * half,
            (1.0 - e.y * s) * half,
            self.depth_of_z(e.z),
        )
    }

    /// (pixel x, pixel y, depth) of a world point, or `None` behind the eye.
    pub fn project(&self, p: Vec3) -> Option<Vec3> {
        let e = self.eye(p);
        (e.z > 0.0).then(|| self.project_eye(e))
    }

    /// The world point at image position `pixel` and normalized depth `d`.
    pub fn unproject(&self, pixel: Vec2, d: f32) -> Vec3 {
        let z = self.z_of_depth(d);
        let h = self.tan_half_fov();
        let half = 0.5 * self.resolution as f32;
        let ndc = Vec2::new(pixel.x / half - 1.0, 1.0 - pixel.y / half);
        self.view.position
            + z * (self.view.forward + self.view.right * (ndc.x * h) + self.view.up * (ndc.y * h))
    }

    /// Unit direction of the ray through the centre of texel (x, y).
    pub fn texel_ray(&self, x: u32, y: u32) -> Vec3 {
        let w = self.resolution;
        self.view.ray_direction(Camera::pixel_ndc(x, y, w, w), 1.0)
    }

    /// Clips the ray `origin + t dir`, t ∈ [t_min, t_max], to the six planes of the frustum
    /// (§4.3 step 2; Liang–Barsky in eye space). `None` when nothing is left.
    pub fn clip(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Option<(f32, f32)> {
        if !(origin.is_finite() && dir.is_finite()) || t_min.is_nan() || t_max.is_nan() {
            return None;
        }
        let o = self.eye(origin);
        let d = self.eye_dir(dir);
        let h = self.tan_half_fov();
        let (mut t0, mut t1) = (t_min, t_max);
        // Each plane as a + t b ≤ 0.
        let planes = [
            (self.hither - o.z, -d.z),
            (o.z - self.yon, d.z),
            (o.x - h * o.z, d.x - h * d.z),
            (-o.x - h * o.z, -d.x - h * d.z),
            (o.y - h * o.z, d.y - h * d.z),
            (-o.y - h * o.z, -d.y - h * d.z),
        ];
        for (a, b) in planes {
            if b == 0.0 {
                if a > 0.0 {
                    return None;
                }
            } else if b > 0.0 {
                t1 = t1.min(-a / b);
            } else {
                t0 = t0.max(-a / b);
            }
            if t0 > t1 {
                return None;
            }
        }
        Some((t0, t1))
    }

    /// Checks the camera is usable: finite, orthonormal enough, 0 < hither < yon, resolution ≥ 2.
    pub fn validate(&self) -> Result<(), String> {
        let c = &self.view;
        let finite = c.position.is_finite()
            && c.forward.is_finite()
            && c.right.is_finite()
            && c.up.is_finite()
            && c.fov_y.is_finite()
            && self.hither.is_finite()
            && self.yon.is_finite();
        if !finite {
            return Err("the impostor camera has a non-finite value".into());
        }
        if !(c.fov_y > 0.0 && c.fov_y < std::f32::consts::PI) {
            return Err(format!(
                "the impostor camera's field of view {} rad is not in (0, π)",
                c.fov_y
            ));
        }
        if !(self.hither > 0.0 && self.yon > self.hither) {
            return Err(format!(
                "the impostor camera needs 0 < hither < yon, got hither {} and yon {}",
                self.hither, self.yon
            ));
        }
        for (name, v) in [("forward", c.forward), ("right", c.right), ("up", c.up)] {
            if (v.length() - 1.0).abs() > 1e-3 {
                return Err(format!(
                    "the impostor camera's {name} vector {v} is not unit"
                ));
            }
        }
        if c.forward.dot(c.right).abs() > 1e-3
            || c.forward.dot(c.up).abs() > 1e-3
            || c.right.dot(c.up).abs() > 1e-3
        {
            return Err("the impostor camera's axes are not orthogonal".into());
        }
        if self.resolution < 2 {
            return Err(format!(
                "an impostor of {} texels across is too small (≥ 2)",
                self.resolution
            ));
        }
        Ok(())
    }
}
