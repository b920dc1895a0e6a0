//! Camera paths: the bounds a path of scene.json must keep, their checks, and the lookup of a
//! path by name.

use glam::Vec3;

use super::{CameraPath, Scene, SceneError, list};

/// Largest |time| of a keyframe, seconds (a day).
pub const MAX_KEYFRAME_TIME: f32 = 86_400.0;

/// Largest replay rate of a camera path, frames per second.
pub const MAX_FPS: f32 = 1000.0;

/// Largest |coordinate| of a keyframe's position, target or up, metres.
pub const MAX_CAMERA_COORD: f32 = 1e6;

/// Smallest and largest vertical field of view of a keyframe, degrees.
pub const FOV_RANGE_DEG: (f32, f32) = (0.1, 179.0);

/// Checks a camera path against sane bounds, so that replaying it cannot ask for absurd
/// frame counts ([`crate::camera::MAX_FRAMES`]) or degenerate projections. `Err((field, why))`
/// with the field relative to the path.
fn check_path(p: &CameraPath) -> Result<(), (String, String)> {
    if p.keyframes.is_empty() {
        return Err((".keyframes".into(), "needs at least one keyframe".into()));
    }
    if !(p.fps.is_finite() && p.fps > 0.0 && p.fps <= MAX_FPS) {
        return Err((
            ".fps".into(),
            format!("{} is not a frame rate in (0, {MAX_FPS}]", p.fps),
        ));
    }
    let mut last = f32::NEG_INFINITY;
    for (k, f) in p.keyframes.iter().enumerate() {
        let at = |s: &str| format!(".keyframes[{k}].{s}");
        if !(f.time.is_finite() && f.time.abs() <= MAX_KEYFRAME_TIME) {
            return Err((
                at("time"),
                format!(
                    "{} is not a time in seconds within ±{MAX_KEYFRAME_TIME}",
                    f.time
                ),
            ));
        }
        if f.time <= last {
            return Err((
                at("time"),
                format!(
                    "{} is not after the previous keyframe's {last}: times must increase",
                    f.time
                ),
            ));
        }
        last = f.time;
        let (lo, hi) = FOV_RANGE_DEG;
        if !(f.fov_y_deg >= lo && f.fov_y_deg <= hi) {
            return Err((
                at("fov_y_deg"),
                format!("{} is not in [{lo}, {hi}] degrees", f.fov_y_deg),
            ));
        }
        for (name, v) in [("position", f.position), ("target", f.target), ("up", f.up)] {
            if !v
                .iter()
                .all(|c| c.is_finite() && c.abs() <= MAX_CAMERA_COORD)
            {
                return Err((
                    at(name),
                    format!(
                        "[{}, {}, {}] is not finite or lies beyond ±{MAX_CAMERA_COORD:e} m",
                        v[0], v[1], v[2]
                    ),
                ));
            }
        }
        let (eye, target, up) = (
            Vec3::from(f.position),
            Vec3::from(f.target),
            Vec3::from(f.up),
        );
        let dir = target - eye;
        if dir.length_squared() == 0.0 {
            return Err((
                at("target"),
                "equals the position: no view direction".into(),
            ));
        }
        if dir.normalize().cross(up.normalize_or_zero()).length() < 1e-4 {
            return Err((
                at("up"),
                format!("{up} is zero or parallel to the view direction"),
            ));
        }
    }
    let frames = crate::camera::frame_count(p);
    if frames > crate::camera::MAX_FRAMES {
        return Err((
            ".fps".into(),
            format!(
                "{} fps over {} s of keyframes gives {frames} frames; a path may have at most {}",
                p.fps,
                last - p.keyframes[0].time,
                crate::camera::MAX_FRAMES
            ),
        ));
    }
    Ok(())
}

/// Checks scene.json's `camera_paths`: unique names, each path within bounds
/// ([`check_path`]). `Err((field, why))` with the field from the scene's root.
pub(super) fn check_paths(paths: &[CameraPath]) -> Result<(), (String, String)> {
    let mut names = std::collections::BTreeSet::new();
    for (i, p) in paths.iter().enumerate() {
        if !names.insert(p.name.as_str()) {
            return Err((
                format!("camera_paths[{i}].name"),
                format!("{:?} is used by an earlier path", p.name),
            ));
        }
        check_path(p).map_err(|(f, m)| (format!("camera_paths[{i}]{f}"), m))?;
    }
    Ok(())
}

impl Scene {
    /// The named camera path (scene.json's or a glTF camera's), or the first one when `name`
    /// is `None`.
    pub fn camera_path(&self, name: Option<&str>) -> Option<&CameraPath> {
        match name {
            Some(n) => self.camera_paths.iter().find(|p| p.name == n),
            None => self.camera_paths.first(),
        }
    }

    /// [`Scene::camera_path`], or an error naming scene.json and the paths it has.
    pub fn find_camera_path(&self, name: Option<&str>) -> Result<&CameraPath, SceneError> {
        self.camera_path(name).ok_or_else(|| SceneError::Field {
            path: self.path.clone(),
            field: "camera_paths".into(),
            message: match (name, self.camera_paths.is_empty()) {
                (_, true) => "the scene has no camera paths; add one to scene.json".into(),
                (Some(n), false) => format!(
                    "no path is named {n:?}; the scene has {}",
                    list(self.camera_paths.iter().map(|p| p.name.as_str()))
                ),
                (None, false) => unreachable!("the first path exists"),
            },
        })
    }
}
