//! The window's camera tools, pure and tested without a window: the fly camera, path
//! recording and playback, the starting view and free output names.

use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::camera::{Camera, pose_at};
use crate::scene::{CameraPath, Keyframe};
use crate::view::load::ViewData;

/// Seconds between the keyframes of a recorded path.
pub const RECORD_INTERVAL: f32 = 0.25;

/// Frames per second written into recorded paths.
pub const RECORD_FPS: f32 = 30.0;

/// Radians of turn per pixel of mouse drag.
const LOOK_SENSITIVITY: f32 = 0.003;

/// Largest pitch, radians: keeps the view off the vertical so the world's up stays usable.
const MAX_PITCH: f32 = 89f32 * std::f32::consts::PI / 180.0;

/// A free-flying camera: position, yaw about +Y (0 looks down −Z, positive turns right)
/// and pitch (positive looks up).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlyCamera {
    /// Eye position.
    pub position: Vec3,
    /// Radians.
    pub yaw: f32,
    /// Radians, within ±89°.
    pub pitch: f32,
    /// Vertical field of view, radians.
    pub fov_y: f32,
}

impl FlyCamera {
    /// The fly camera looking where `camera` looks.
    pub fn from_camera(camera: &Camera) -> FlyCamera {
        let f = camera.forward.normalize_or(-Vec3::Z);
        FlyCamera {
            position: camera.position,
            yaw: f.x.atan2(-f.z),
            pitch: f.y.clamp(-1.0, 1.0).asin().clamp(-MAX_PITCH, MAX_PITCH),
            fov_y: camera.fov_y,
        }
    }

    /// Unit view direction.
    pub fn forward(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        Vec3::new(cp * sy, sp, -cp * cy)
    }

    /// The camera (world +Y up).
    pub fn camera(&self) -> Camera {
        Camera::look_at(
            self.position,
            self.position + self.forward(),
            Vec3::Y,
            self.fov_y,
        )
    }

    /// Moves by `local` = (right, up, forward) metres: forward along the view, up along +Y.
    pub fn translate(&mut self, local: Vec3) {
        let forward = self.forward();
        let right = forward.cross(Vec3::Y).normalize_or(Vec3::X);
        self.position += right * local.x + Vec3::Y * local.y + forward * local.z;
    }

    /// Turns by a mouse drag of (`dx`, `dy`) pixels (right and down positive).
    pub fn look(&mut self, dx: f32, dy: f32) {
        self.yaw += dx * LOOK_SENSITIVITY;
        self.pitch = (self.pitch - dy * LOOK_SENSITIVITY).clamp(-MAX_PITCH, MAX_PITCH);
    }
}

/// Records the camera's pose at regular times into a camera path.
#[derive(Clone, Debug, Default)]
pub struct PathRecorder {
    keyframes: Vec<Keyframe>,
}

impl PathRecorder {
    /// An empty recording.
    pub fn new() -> PathRecorder {
        PathRecorder::default()
    }

    /// Offers the pose at recording time `t` (seconds); kept when it is the first or at least
    /// [`RECORD_INTERVAL`] after the last kept one. Returns whether it was kept.
    pub fn offer(&mut self, t: f32, camera: &Camera) -> bool {
        if let Some(last) = self.keyframes.last()
            && t < last.time + RECORD_INTERVAL
        {
            return false;
        }
        self.push(t, camera);
        true
    }

    fn push(&mut self, t: f32, camera: &Camera) {
        let target = camera.position + camera.forward;
        self.keyframes.push(Keyframe {
            time: t,
            position: camera.position.to_array(),
            target: target.to_array(),
            up: [0.0, 1.0, 0.0],
            fov_y_deg: camera.fov_y.to_degrees(),
        });
    }

    /// Number of keyframes so far.
    pub fn len(&self) -> usize {
        self.keyframes.len()
    }

    /// Whether nothing was recorded.
    pub fn is_empty(&self) -> bool {
        self.keyframes.is_empty()
    }

    /// The recording as a camera path named `name`, ending with the pose at time `t` (added
    /// when later than the last keyframe); `None` when nothing was recorded.
    pub fn finish(mut self, name: &str, t: f32, camera: &Camera) -> Option<CameraPath> {
        let last = self.keyframes.last()?.time;
        if t > last {
            self.push(t, camera);
        }
        Some(CameraPath {
            name: name.to_owned(),
            fps: RECORD_FPS,
            keyframes: self.keyframes,
        })
    }
}

/// Playing one of the scene's camera paths.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Playback {
    /// Index into the scene's camera paths.
    pub path: usize,
    /// Seconds since the path's first keyframe.
    pub elapsed: f32,
    /// Whether time stands still.
    pub paused: bool,
}

impl Playback {
    /// Advances by `dt` seconds unless paused; returns the pose and whether the path has ended.
    pub fn advance(&mut self, path: &CameraPath, dt: f32) -> (Camera, bool) {
        if !self.paused {
            self.elapsed += dt;
        }
        let start = path.keyframes.first().map_or(0.0, |k| k.time);
        let end = path.keyframes.last().map_or(0.0, |k| k.time);
        let t = (start + self.elapsed).min(end);
        (
            pose_at(path, t),
            start + self.elapsed >= end && !self.paused,
        )
    }
}

/// The next `prefix-N.ext` in `dir` that does not exist yet (N from 1, four digits).
pub fn next_free_name(dir: &Path, prefix: &str, ext: &str) -> PathBuf {
    (1u32..)
        .map(|n| dir.join(format!("{prefix}-{n:04}.{ext}")))
        .find(|p| !p.exists())
        .expect("some index is free")
}

/// A starting view: the first path's first pose, else the bounding box from its +Z side.
pub fn initial_camera(data: &ViewData) -> Camera {
    if let Some(path) = data.scene.camera_paths.first() {
        return pose_at(path, path.keyframes.first().map_or(0.0, |k| k.time));
    }
    let b = data.scene.bounds;
    let centre = b.center();
    let eye = centre + Vec3::new(0.0, 0.0, (b.max.z - centre.z) + b.diagonal() * 0.6);
    Camera::look_at(eye, centre, Vec3::Y, 50f32.to_radians())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fly_camera_round_trips_a_camera() {
        let cam = Camera::look_at(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(-1.0, 1.0, -2.0),
            Vec3::Y,
            0.7,
        );
        let fly = FlyCamera::from_camera(&cam);
        let back = fly.camera();
        assert!((back.forward - cam.forward).length() < 1e-5);
        assert!((back.position - cam.position).length() < 1e-6);
        assert_eq!(back.fov_y, 0.7);
        // Yaw 0 looks down −Z.
        let f = FlyCamera {
            position: Vec3::ZERO,
            yaw: 0.0,
            pitch: 0.0,
            fov_y: 1.0,
        };
        assert!((f.forward() - (-Vec3::Z)).length() < 1e-6);
    }

    #[test]
    fn fly_camera_moves_in_view_space_and_clamps_pitch() {
        let mut f = FlyCamera {
            position: Vec3::ZERO,
            yaw: 0.0,
            pitch: 0.0,
            fov_y: 1.0,
        };
        f.translate(Vec3::new(1.0, 2.0, 3.0));
        assert!((f.position - Vec3::new(1.0, 2.0, -3.0)).length() < 1e-6);
        f.look(0.0, -1e6);
        assert!((f.pitch - MAX_PITCH).abs() < 1e-6);
        assert!(f.camera().up.is_finite());
        f.look(100.0, 0.0);
        assert!((f.yaw - 0.3).abs() < 1e-6, "dragging right turns right");
    }

    #[test]
    fn recorder_keeps_poses_at_the_interval_and_makes_a_valid_path() {
        let cam = |x: f32| Camera::look_at(Vec3::new(x, 1.0, 4.0), Vec3::ZERO, Vec3::Y, 0.8);
        let mut rec = PathRecorder::new();
        assert!(rec.offer(0.0, &cam(0.0)));
        assert!(!rec.offer(0.1, &cam(0.1)));
        assert!(rec.offer(0.3, &cam(0.3)));
        let path = rec.finish("take", 0.4, &cam(0.4)).unwrap();
        assert_eq!(path.keyframes.len(), 3);
        assert!(path.keyframes.windows(2).all(|w| w[0].time < w[1].time));
        assert!((path.keyframes[2].position[0] - 0.4).abs() < 1e-6);
        // scene.json accepts it: it parses as a camera_paths entry.
        let json = serde_json::to_string(&path).unwrap();
        let again: CameraPath = serde_json::from_str(&json).unwrap();
        assert_eq!(again, path);
        assert!(PathRecorder::new().finish("x", 1.0, &cam(0.0)).is_none());
    }

    #[test]
    fn playback_pauses_and_ends() {
        let key = |time: f32, x: f32| Keyframe {
            time,
            position: [x, 1.0, 5.0],
            target: [x, 1.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_y_deg: 50.0,
        };
        let path = CameraPath {
            name: "p".into(),
            fps: 30.0,
            keyframes: vec![key(1.0, 0.0), key(2.0, 1.0)],
        };
        let mut p = Playback {
            path: 0,
            elapsed: 0.0,
            paused: false,
        };
        let (c, ended) = p.advance(&path, 0.5);
        assert!(!ended && (c.position.x - 0.5).abs() < 1e-5);
        p.paused = true;
        let (c, ended) = p.advance(&path, 5.0);
        assert!(!ended && (c.position.x - 0.5).abs() < 1e-5);
        p.paused = false;
        let (c, ended) = p.advance(&path, 0.6);
        assert!(ended && (c.position.x - 1.0).abs() < 1e-5);
    }

    #[test]
    fn free_names_count_up() {
        let dir = std::env::temp_dir().join(format!("glint-names-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let a = next_free_name(&dir, "screenshot", "png");
        assert!(a.ends_with("screenshot-0001.png"));
        std::fs::write(&a, b"x").unwrap();
        assert!(next_free_name(&dir, "screenshot", "png").ends_with("screenshot-0002.png"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
