//! Pinhole cameras and camera paths: poses interpolated between keyframes.
//! Right-handed, +Y up; a camera looks down its local −Z. The path types are scene.json's
//! `camera_paths` (the scene layer re-exports and checks them), defined here so that this
//! module imports nothing above it.

use glam::{Vec2, Vec3};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// A named camera path: keyframes interpolated in time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CameraPath {
    /// Name to pick the path with `--replay NAME`.
    pub name: String,
    /// Frames per second at which the path is replayed, in (0, 1000]; a path has at most
    /// 1,000,000 frames.
    #[serde(default = "default_fps")]
    pub fps: f32,
    /// At least one keyframe, times strictly increasing.
    pub keyframes: Vec<Keyframe>,
}

fn default_fps() -> f32 {
    30.0
}

/// One camera pose.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Keyframe {
    /// Seconds from the start of the path, within ±86400.
    pub time: f32,
    /// Eye position, world metres (each coordinate within ±1e6, as are `target` and `up`).
    pub position: [f32; 3],
    /// Point looked at.
    pub target: [f32; 3],
    /// Up vector (need not be orthogonal to the view direction).
    #[serde(default = "default_up")]
    pub up: [f32; 3],
    /// Vertical field of view in degrees, in [0.1, 179].
    pub fov_y_deg: f32,
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

/// A pinhole camera pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub position: Vec3,
    /// Unit view direction (the camera's −Z).
    pub forward: Vec3,
    /// Unit right vector (+X on screen).
    pub right: Vec3,
    /// Unit up vector (+Y on screen), orthogonal to `forward` and `right`.
    pub up: Vec3,
    /// Vertical field of view, radians.
    pub fov_y: f32,
}

impl Camera {
    /// The camera of a keyframe (validated by the scene loader: up not parallel to the view).
    pub fn from_keyframe(k: &Keyframe) -> Camera {
        Camera::look_at(
            k.position.into(),
            k.target.into(),
            k.up.into(),
            k.fov_y_deg.to_radians(),
        )
    }

    /// A camera at `eye` looking at `target`.
    pub fn look_at(eye: Vec3, target: Vec3, up: Vec3, fov_y: f32) -> Camera {
        let forward = (target - eye).normalize();
        let right = forward.cross(up).normalize();
        Camera {
            position: eye,
            forward,
            right,
            up: right.cross(forward),
            fov_y,
        }
    }

    /// Unit direction through a point of the image given in normalized device coordinates
    /// (x right, y up, both in [−1, 1]) for an image of `aspect` = width / height.
    pub fn ray_direction(&self, ndc: Vec2, aspect: f32) -> Vec3 {
        let h = (0.5 * self.fov_y).tan();
        (self.forward + self.right * (ndc.x * h * aspect) + self.up * (ndc.y * h)).normalize()
    }

    /// NDC of the centre of pixel (x, y) in a `width` × `height` image (row 0 at the top).
    pub fn pixel_ndc(x: u32, y: u32, width: u32, height: u32) -> Vec2 {
        Vec2::new(
            2.0 * (x as f32 + 0.5) / width as f32 - 1.0,
            1.0 - 2.0 * (y as f32 + 0.5) / height as f32,
        )
    }
}

/// Most frames a camera path may have when replayed ([`frame_count`]): over 9 hours at
/// 30 fps. The scene loader refuses longer paths, and a replay sizes its buffers only after
/// checking this.
pub const MAX_FRAMES: usize = 1_000_000;

/// Number of frames when replaying a path at its fps: one per 1/fps from the first
/// keyframe's time through the last's (at least one; saturating for absurd paths, which
/// the scene loader refuses, see [`MAX_FRAMES`]).
pub fn frame_count(path: &CameraPath) -> usize {
    let (t0, t1) = time_range(path);
    let span = (t1 as f64 - t0 as f64) * path.fps as f64;
    // `as` saturates (NaN gives 0).
    (span.floor() as usize).saturating_add(1)
}

/// The camera of frame `frame` of `path` at its fps, or why there is none (the frame is past
/// the path's end).
pub fn frame_camera(path: &CameraPath, frame: usize) -> Result<Camera, String> {
    let frames = frame_count(path);
    if frame >= frames {
        return Err(format!(
            "camera path `{}` has {frames} frames (0..={})",
            path.name,
            frames - 1
        ));
    }
    Ok(pose_at(path, frame_time(path, frame)))
}

/// Time of frame `i`.
pub fn frame_time(path: &CameraPath, i: usize) -> f32 {
    time_range(path).0 + i as f32 / path.fps
}

fn time_range(path: &CameraPath) -> (f32, f32) {
    let first = path.keyframes.first().map_or(0.0, |k| k.time);
    let last = path.keyframes.last().map_or(0.0, |k| k.time);
    (first, last)
}

/// The pose at time `t`: positions, targets, up vectors and field of view interpolated
/// linearly between the surrounding keyframes, clamped to the first and last.
pub fn pose_at(path: &CameraPath, t: f32) -> Camera {
    let p = interpolate(path, t);
    Camera::look_at(p.eye, p.target, p.up, p.fov_y_deg.to_radians())
}

/// Why the pose at time `t` has no orientation ([`pose_at`] would give NaN): the eye on its
/// target, or the view along the up vector (the same test as the scene loader's for a
/// keyframe). `None` for a sound pose.
pub fn degenerate_pose(path: &CameraPath, t: f32) -> Option<String> {
    let p = interpolate(path, t);
    let dir = p.target - p.eye;
    if dir.length_squared() == 0.0 || !dir.normalize().is_finite() {
        return Some(format!(
            "the camera is at its target {}: no view direction",
            p.target
        ));
    }
    if dir.normalize().cross(p.up.normalize_or_zero()).length() < 1e-4 {
        return Some(format!(
            "the view direction {} is parallel to up {}",
            dir.normalize(),
            p.up
        ));
    }
    None
}

/// A pose before [`Camera::look_at`].
struct Interpolated {
    eye: Vec3,
    target: Vec3,
    up: Vec3,
    fov_y_deg: f32,
}

/// [`pose_at`]'s eye, target, up and field of view at time `t`.
fn interpolate(path: &CameraPath, t: f32) -> Interpolated {
    let k = &path.keyframes;
    let i = k.partition_point(|f| f.time <= t);
    let key = |f: &Keyframe| Interpolated {
        eye: f.position.into(),
        target: f.target.into(),
        up: f.up.into(),
        fov_y_deg: f.fov_y_deg,
    };
    if i == 0 {
        return key(&k[0]);
    }
    if i == k.len() {
        return key(&k[k.len() - 1]);
    }
    let (a, b) = (&k[i - 1], &k[i]);
    let s = (t - a.time) / (b.time - a.time);
    let lerp = |x: [f32; 3], y: [f32; 3]| Vec3::from(x).lerp(Vec3::from(y), s);
    let mut up = lerp(a.up, b.up);
    let (eye, target) = (lerp(a.position, b.position), lerp(a.target, b.target));
    if (target - eye).normalize_or_zero().cross(up).length() < 1e-4 {
        up = a.up.into(); // interpolated up parallel to the view: keep the keyframe's
    }
    Interpolated {
        eye,
        target,
        up,
        fov_y_deg: a.fov_y_deg + (b.fov_y_deg - a.fov_y_deg) * s,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(time: f32, x: f32) -> Keyframe {
        Keyframe {
            time,
            position: [x, 1.0, 5.0],
            target: [x, 1.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_y_deg: 60.0,
        }
    }

    #[test]
    fn centre_ray_is_forward_and_corners_span_the_fov() {
        let c = Camera::from_keyframe(&key(0.0, 0.0));
        assert!((c.forward - (-Vec3::Z)).length() < 1e-6);
        assert!((c.right - Vec3::X).length() < 1e-6 && (c.up - Vec3::Y).length() < 1e-6);
        let top = c.ray_direction(Vec2::new(0.0, 1.0), 1.0);
        let angle = top.angle_between(c.forward);
        assert!((angle - 30f32.to_radians()).abs() < 1e-5);
        assert_eq!(Camera::pixel_ndc(0, 0, 2, 2), Vec2::new(-0.5, 0.5));
    }

    #[test]
    fn path_interpolates_and_clamps() {
        let path = CameraPath {
            name: "p".into(),
            fps: 10.0,
            keyframes: vec![key(0.0, 0.0), key(1.0, 2.0)],
        };
        assert_eq!(frame_count(&path), 11);
        assert_eq!(pose_at(&path, 0.5).position, Vec3::new(1.0, 1.0, 5.0));
        assert_eq!(pose_at(&path, -1.0).position.x, 0.0);
        assert_eq!(pose_at(&path, 9.0).position.x, 2.0);
        assert!((frame_time(&path, 10) - 1.0).abs() < 1e-6);
        assert_eq!(frame_camera(&path, 10).unwrap().position.x, 2.0);
        assert!(
            frame_camera(&path, 11)
                .unwrap_err()
                .contains("has 11 frames")
        );
    }

    #[test]
    fn frame_count_saturates_instead_of_overflowing() {
        let mut path = CameraPath {
            name: "p".into(),
            fps: f32::MAX,
            keyframes: vec![key(0.0, 0.0), key(f32::MAX, 2.0)],
        };
        assert_eq!(frame_count(&path), usize::MAX);
        path.fps = f32::NAN;
        assert_eq!(frame_count(&path), 1);
    }
}
