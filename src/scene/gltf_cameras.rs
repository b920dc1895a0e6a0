//! glTF camera nodes as camera paths: each perspective camera becomes a one-keyframe path
//! named after its node, so `glint-view --replay NAME` works without `camera_paths` in
//! scene.json. Paths of scene.json win on a name clash ([`merge`]).
//!
//! glTF 2.0 §3.10: a camera looks down its node's local −Z with +Y up; `yfov` is the vertical
//! field of view in radians; `aspectRatio` is optional and only a hint here (frames take the
//! aspect of their size). Orthographic cameras are skipped with a warning: glint's cameras
//! are perspective, and no field of view stands for an orthographic extent at every depth.

use glam::{Mat4, Vec3};

use super::desc::{CameraPath, Keyframe};
use super::{FOV_RANGE_DEG, MAX_CAMERA_COORD};

/// Frames per second of a path made from a glTF camera (one keyframe: one frame).
const GLTF_PATH_FPS: f32 = 30.0;

/// The name of a camera path from node `index`: its name, else its camera's, else `node<index>`.
pub fn path_name(node_name: Option<&str>, camera_name: Option<&str>, index: usize) -> String {
    node_name
        .filter(|n| !n.is_empty())
        .or(camera_name.filter(|n| !n.is_empty()))
        .map_or_else(|| format!("node{index}"), str::to_owned)
}

/// The one-keyframe path of a perspective camera at world transform `world` (scene.json's
/// scale included) with vertical field of view `yfov` radians; `Err(why)` when the pose or
/// the field of view cannot be a glint camera.
pub fn perspective_path(name: String, world: Mat4, yfov: f32) -> Result<CameraPath, String> {
    let fov_y_deg = yfov.to_degrees();
    let (lo, hi) = FOV_RANGE_DEG;
    if !(fov_y_deg >= lo && fov_y_deg <= hi) {
        return Err(format!(
            "yfov {yfov} rad ({fov_y_deg}°) is not in [{lo}, {hi}] degrees"
        ));
    }
    let position = world.transform_point3(Vec3::ZERO);
    let forward = world.transform_vector3(Vec3::NEG_Z).try_normalize();
    let up = world.transform_vector3(Vec3::Y).try_normalize();
    let (Some(forward), Some(up)) = (forward, up) else {
        return Err("its node's transform collapses the view or up direction".into());
    };
    if forward.cross(up).length() < 1e-4 {
        return Err("its node's transform makes the view and up directions parallel".into());
    }
    if !(position.is_finite() && position.abs().max_element() <= MAX_CAMERA_COORD - 1.0) {
        return Err(format!(
            "position {position} is not finite or lies beyond ±{MAX_CAMERA_COORD:e} m"
        ));
    }
    Ok(CameraPath {
        name,
        fps: GLTF_PATH_FPS,
        keyframes: vec![Keyframe {
            time: 0.0,
            position: position.to_array(),
            // One metre ahead: only the direction matters.
            target: (position + forward).to_array(),
            up: up.to_array(),
            fov_y_deg,
        }],
    })
}

/// Appends the glTF's camera paths to scene.json's `paths`; a glTF path whose name scene.json
/// already uses is left out, said in the log (`file` names the glTF). Returns how many were
/// added.
pub fn merge(paths: &mut Vec<CameraPath>, gltf: Vec<CameraPath>, file: &std::path::Path) -> usize {
    let mut added = 0;
    for p in gltf {
        if paths.iter().any(|q| q.name == p.name) {
            log::info!(
                "{}: camera {:?}: scene.json has a camera path of that name, which wins",
                file.display(),
                p.name
            );
            continue;
        }
        log::info!(
            "{}: camera {:?} read as a one-keyframe camera path",
            file.display(),
            p.name
        );
        paths.push(p);
        added += 1;
    }
    added
}

#[cfg(test)]
mod tests {
    use glam::Quat;

    use super::*;

    #[test]
    fn a_camera_looks_down_its_nodes_negative_z() {
        // Turned 90° about +Y (−Z becomes −X), moved to (1, 2, 3), scaled by 0.5.
        let world = Mat4::from_scale(Vec3::splat(0.5))
            * Mat4::from_rotation_translation(
                Quat::from_rotation_y(std::f32::consts::FRAC_PI_2),
                Vec3::new(1.0, 2.0, 3.0),
            );
        let p = perspective_path("cam".into(), world, 0.8).unwrap();
        let k = p.keyframes[0];
        assert_eq!(p.keyframes.len(), 1);
        let pos = Vec3::from(k.position);
        assert!((pos - Vec3::new(0.5, 1.0, 1.5)).length() < 1e-6, "{pos}");
        let dir = Vec3::from(k.target) - pos;
        assert!((dir - Vec3::NEG_X).length() < 1e-6, "{dir}");
        assert!((Vec3::from(k.up) - Vec3::Y).length() < 1e-6);
        assert!((k.fov_y_deg - 0.8f32.to_degrees()).abs() < 1e-4);
    }

    #[test]
    fn impossible_cameras_are_refused_with_the_reason() {
        let e = perspective_path("c".into(), Mat4::IDENTITY, 3.2).unwrap_err();
        assert!(e.contains("yfov"), "{e}");
        let flat = Mat4::from_scale(Vec3::new(1.0, 1.0, 0.0));
        let e = perspective_path("c".into(), flat, 1.0).unwrap_err();
        assert!(e.contains("collapses"), "{e}");
    }

    #[test]
    fn scene_json_paths_win_a_name_clash() {
        let path = |name: &str, x: f32| CameraPath {
            name: name.into(),
            fps: 30.0,
            keyframes: vec![Keyframe {
                time: 0.0,
                position: [x, 0.0, 0.0],
                target: [x, 0.0, -1.0],
                up: [0.0, 1.0, 0.0],
                fov_y_deg: 40.0,
            }],
        };
        let mut paths = vec![path("a", 1.0)];
        let added = merge(
            &mut paths,
            vec![path("a", 2.0), path("b", 3.0)],
            std::path::Path::new("x.glb"),
        );
        assert_eq!(added, 1);
        let names: Vec<&str> = paths.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(names, ["a", "b"]);
        assert_eq!(paths[0].keyframes[0].position[0], 1.0);
        assert_eq!(path_name(Some(""), Some("lens"), 4), "lens");
        assert_eq!(path_name(None, None, 4), "node4");
        assert_eq!(path_name(Some("N"), Some("lens"), 4), "N");
    }
}
