//! What the scene's camera paths see of sets of triangles (the probe groups,
//! `super::probes::Group`): the bake gives a side of a material a probe of its own only where
//! a camera sees it (docs/tuning.md#probe-sides).

use glam::Vec3;
use rayon::prelude::*;

use crate::camera::{Camera, CameraPath, degenerate_pose, pose_at};
use crate::geometry::{Bvh, Triangle};

/// Eye rays a camera pose casts, across by down (the viewer's default aspect).
pub const SIGHT_GRID: (u32, u32) = (48, 32);

/// Poses per stretch between two keyframes: a side seen only while the camera moves counts.
pub const SIGHT_STEPS: u32 = 4;

/// The eye rays (origin, unit direction) of `paths`: at each keyframe and at [`SIGHT_STEPS`]
/// even steps between keyframes, one through the centre of each cell of a [`SIGHT_GRID`].
pub fn eye_rays(paths: &[CameraPath]) -> Vec<(Vec3, Vec3)> {
    let (w, h) = SIGHT_GRID;
    let aspect = w as f32 / h as f32;
    let mut rays = Vec::new();
    for path in paths {
        let between = path.keyframes.windows(2).flat_map(|k| {
            let (a, b) = (k[0].time, k[1].time);
            (0..SIGHT_STEPS).map(move |i| a + (b - a) * i as f32 / SIGHT_STEPS as f32)
        });
        let last = path.keyframes.last().map(|k| k.time);
        for t in between.chain(last) {
            if degenerate_pose(path, t).is_some() {
                continue;
            }
            let cam = pose_at(path, t);
            for y in 0..h {
                for x in 0..w {
                    let dir = cam.ray_direction(Camera::pixel_ndc(x, y, w, h), aspect);
                    rays.push((cam.position, dir));
                }
            }
        }
    }
    rays
}

/// Per set of `sets` (indices into `triangles`, which `bvh` holds in the same order; no
/// triangle in two sets), how many of the eye `rays` meet one of its triangles first.
pub fn sights(
    triangles: &[Triangle],
    sets: &[&[u32]],
    bvh: &Bvh,
    rays: &[(Vec3, Vec3)],
) -> Vec<u32> {
    let mut owner = vec![u32::MAX; triangles.len()];
    for (k, set) in sets.iter().enumerate() {
        for &t in *set {
            owner[t as usize] = k as u32;
        }
    }
    let hits: Vec<u32> = rays
        .par_iter()
        .filter_map(|&(o, d)| {
            let h = bvh.closest_hit(o, d, f32::INFINITY)?;
            owner
                .get(h.triangle as usize)
                .copied()
                .filter(|&k| k != u32::MAX)
        })
        .collect();
    let mut seen = vec![0u32; sets.len()];
    for k in hits {
        seen[k as usize] += 1;
    }
    seen
}

#[cfg(test)]
mod tests {
    use glam::Vec2;

    use super::*;
    use crate::camera::Keyframe;

    /// A unit square at height `y` over x, z in [0, 1], its normal up or down.
    fn square(y: f32, up: bool) -> [Triangle; 2] {
        let p = [
            Vec3::new(0.0, y, 0.0),
            Vec3::new(1.0, y, 0.0),
            Vec3::new(1.0, y, 1.0),
            Vec3::new(0.0, y, 1.0),
        ];
        let tri = |a: usize, b: usize, c: usize| {
            let (b, c) = if up { (c, b) } else { (b, c) };
            Triangle {
                p: [p[a], p[b], p[c]],
                n: [Vec3::ZERO; 3],
                uv: [Vec2::ZERO; 3],
                uv1: None,
                material: 0,
                object: 0,
            }
        };
        [tri(0, 1, 2), tri(0, 2, 3)]
    }

    #[test]
    fn each_pose_casts_one_ray_per_grid_cell() {
        let key = |time: f32| Keyframe {
            time,
            position: [0.0, 1.0, 3.0],
            target: [0.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_y_deg: 50.0,
        };
        let path = CameraPath {
            name: "p".into(),
            fps: 30.0,
            keyframes: vec![key(0.0), key(1.0), key(2.0)],
        };
        // Each of the two stretches from its start in SIGHT_STEPS steps, and the last keyframe.
        let rays = eye_rays(std::slice::from_ref(&path));
        let poses = 2 * SIGHT_STEPS as usize + 1;
        assert_eq!(rays.len(), poses * (SIGHT_GRID.0 * SIGHT_GRID.1) as usize);
        assert!(
            rays.iter()
                .all(|(o, d)| *o == Vec3::new(0.0, 1.0, 3.0) && (d.length() - 1.0).abs() < 1e-5)
        );
        assert!(eye_rays(&[]).is_empty());
    }

    #[test]
    fn a_face_hidden_behind_another_is_not_seen() {
        // A top at y = 0.2 over a bottom at y = 0 (its normal down), seen from above: every
        // ray meets the top first.
        let mut tris: Vec<Triangle> = square(0.2, true).into();
        tris.extend(square(0.0, false));
        let bvh = Bvh::build(&tris);
        let sets: [&[u32]; 2] = [&[0, 1], &[2, 3]];
        let rays: Vec<(Vec3, Vec3)> = (1..10)
            .flat_map(|i| (1..10).map(move |j| (i as f32 / 10.0, j as f32 / 10.0)))
            .map(|(x, z)| (Vec3::new(x, 2.0, z), Vec3::NEG_Y))
            .collect();
        let seen = sights(&tris, &sets, &bvh, &rays);
        assert_eq!(seen, [81, 0]);
        // From below only the bottom is seen.
        let below: Vec<(Vec3, Vec3)> = rays
            .iter()
            .map(|&(o, _)| (Vec3::new(o.x, -1.0, o.z), Vec3::Y))
            .collect();
        assert_eq!(sights(&tris, &sets, &bvh, &below), [0, 81]);
    }
}
