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
    check_between_keyframes(p)
}

/// Evenly spaced samples per pair of keyframes, besides its frames and closest approaches.
const SEGMENT_SAMPLES: usize = 256;

/// Largest distance from eye to target, relative to the keyframes', that counts as passing
/// through the target (the view turns around there).
const THROUGH_TARGET: f32 = 1e-4;

/// Checks the poses between keyframes, which are interpolated: the eye must not pass through
/// its target nor the view turn parallel to up, or the camera has no orientation there.
/// Samples every frame, [`SEGMENT_SAMPLES`] more per pair of keyframes, and the times where
/// the eye comes closest to its target and the view (eye to target) to each keyframe's up.
fn check_between_keyframes(p: &CameraPath) -> Result<(), (String, String)> {
    use crate::camera::{degenerate_pose, frame_time};
    let t0 = p.keyframes[0].time;
    let when = |k: usize, t: f32| {
        let x = (t - t0) as f64 * p.fps as f64;
        let frame = match x.round() as usize {
            f if frame_time(p, f) == t => format!("frame {f}"),
            _ => format!("between frames {0} and {1}", x as usize, x as usize + 1),
        };
        format!(
            "camera path {:?} between keyframes {k} and {} at t = {t} s ({frame} at {} fps)",
            p.name,
            k + 1,
            p.fps
        )
    };
    // The parameter in [0, 1] where the linear v0 → v1 comes nearest the origin.
    let nearest = |v0: Vec3, v1: Vec3| {
        let dv = v1 - v0;
        let len2 = dv.length_squared();
        if len2 > 0.0 {
            (-v0.dot(dv) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        }
    };
    for (k, w) in p.keyframes.windows(2).enumerate() {
        let (a, b) = (&w[0], &w[1]);
        let view = |f: &super::Keyframe| Vec3::from(f.target) - Vec3::from(f.position);
        let (d0, d1) = (view(a), view(b));
        let through = nearest(d0, d1);
        let closest = d0.lerp(d1, through);
        let at = |s: f32| a.time + (b.time - a.time) * s;
        let inside = through > 0.0 && through < 1.0;
        if inside && closest.length() <= THROUGH_TARGET * d0.length().max(d1.length()) {
            return Err((
                ".keyframes".into(),
                format!(
                    "{}: the camera passes through its target: no view direction there; move the target off the camera's way",
                    when(k, at(through))
                ),
            ));
        }
        let mut times: Vec<f32> = (1..SEGMENT_SAMPLES)
            .map(|i| at(i as f32 / SEGMENT_SAMPLES as f32))
            .collect();
        for up in [a.up, b.up].map(Vec3::from) {
            times.push(at(nearest(d0.cross(up), d1.cross(up))));
        }
        let first = ((a.time - t0) as f64 * p.fps as f64).floor() as usize;
        times.extend(
            (first..)
                .map(|f| frame_time(p, f))
                .take_while(|&t| t < b.time)
                .filter(|&t| t > a.time),
        );
        times.sort_by(f32::total_cmp);
        for t in times {
            if let Some(why) = degenerate_pose(p, t) {
                return Err((".keyframes".into(), format!("{}: {why}", when(k, t))));
            }
        }
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
