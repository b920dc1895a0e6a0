//! Recursive planar reflections (Nielsen & Christensen 2002 §3.1, Figure 4).
//!
//! Reflection maps are rendered while the frame is drawn, one render target per recursion
//! level (Figure 3): the view at level k renders each reflector it sees into map k, from the
//! view mirrored about that reflector, which in turn renders the reflectors *it* sees into
//! map k + 1, and so on to the depth d. A map is composited onto its reflector (ks·(M*K)·R,
//! the issue-9 composite with the material's kernel K, so glossy levels are filtered too) as
//! soon as it is complete, after which its target is free for the next reflector of that
//! level. Memory: d maps (+ depth buffers) of the frame's size, whatever the reflector count.
//!
//! The CPU half ([`plan`]) walks the reflection tree of a frame: per view, the reflectors
//! seen from their reflecting side, in front of the parent mirror, inside the view's
//! (mirrored) frustum, and whose accumulated specular weight (the product of max(ks·R) along
//! the path) stays above [`RecursionSettings::cutoff`] (Nielsen's suggested termination).
//! The GPU half ([`RecursiveReflections`]) records the passes of that tree depth first.
//!
//! Nothing behind a mirror leaks into its map: the scene pass of a mirrored view uses the
//! same per-fragment clip plane as the issue-9 geometry mode (`fs_mirror` discards fragments
//! at or behind the reflector's plane) rather than Lengyel's oblique near plane. The clip is
//! exact for any plane, and it leaves the reverse-Z infinite projection (and its depth
//! precision) untouched, which an oblique near plane would not (it tilts the near plane into
//! the depth range and needs a finite far plane).
//!
//! Thin glass in a mirrored view is drawn as the single mirror pass draws it
//! ([`crate::view::passes::glass::MirroredGlass`]), last: over the finished map, its children
//! composited, so that a mirror seen through a pane is tinted too.

use glam::{Vec3, Vec4};

use super::splats::frustum_planes;
use super::{PlanarReflector, mirror_camera, signed_distance};
use crate::camera::Camera;
use crate::view::passes::renderer::view_projection;

mod gpu;

pub use gpu::RecursiveReflections;

pub use crate::view::options::{
    DEFAULT_WEIGHT_CUTOFF, MAX_RECURSION_DEPTH, RecursionSettings, parse_depth,
};

/// Most reflection maps one frame renders (a guard against n^d blow-up; further branches are
/// counted in [`RecursionStats::truncated`]).
pub const MAX_MAPS: usize = 256;

/// One reflection map of a frame: `reflector` seen in its parent's view (or the camera's).
#[derive(Clone, Debug, PartialEq)]
pub struct Node {
    /// Index into the reflectors.
    pub reflector: usize,
    /// Recursion level = the map (render target) it is rendered into.
    pub level: usize,
    /// The node whose view sees this reflector (`None`: the camera's).
    pub parent: Option<usize>,
    /// The eye of the view it is seen in.
    pub eye: Vec3,
    /// The view mirrored about the reflector, rendered into map `level`.
    pub camera: Camera,
    /// Accumulated specular weight: the product of max(ks·R) along the path.
    pub weight: f32,
    /// The reflectors this view sees (their maps are at `level + 1`).
    pub children: Vec<usize>,
}

/// What [`plan`] generated and culled.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RecursionStats {
    /// Reflection maps rendered (tree nodes).
    pub maps: usize,
    /// Maps per recursion level.
    pub per_level: [usize; MAX_RECURSION_DEPTH as usize],
    /// Reflectors wholly outside the (mirrored) view frustum.
    pub culled_frustum: usize,
    /// Reflectors seen from behind, or wholly behind the parent mirror.
    pub culled_behind: usize,
    /// Branches stopped by the specular-weight cutoff.
    pub culled_weight: usize,
    /// Branches dropped at [`MAX_MAPS`].
    pub truncated: usize,
}

/// A frame's reflection tree, nodes in depth-first order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Plan {
    /// Every map of the frame.
    pub nodes: Vec<Node>,
    /// The reflectors the camera sees.
    pub roots: Vec<usize>,
    /// Counts.
    pub stats: RecursionStats,
}

/// The view geometry [`plan`] needs.
#[derive(Clone, Copy, Debug)]
pub struct ViewGeometry {
    /// Width / height.
    pub aspect: f32,
    /// Near plane distance.
    pub near: f32,
    /// Geometry within this distance of a mirror counts as behind it.
    pub clip: f32,
}

/// Whether the points lie wholly outside one of the `planes` (a·p + w < 0 outside).
pub fn outside(planes: &[Vec4], points: &[Vec3]) -> bool {
    planes
        .iter()
        .any(|p| points.iter().all(|v| p.truncate().dot(*v) + p.w < 0.0))
}

/// The reflection tree of a frame seen by `camera` (Figure 4's recursion, unrolled on the
/// CPU): `vertices[i]` are reflector i's vertices (for culling).
pub fn plan(
    camera: &Camera,
    view: ViewGeometry,
    reflectors: &[PlanarReflector],
    vertices: &[Vec<Vec3>],
    settings: RecursionSettings,
) -> Plan {
    let mut plan = Plan::default();
    let depth = settings.depth.min(MAX_RECURSION_DEPTH) as usize;
    plan.roots = visit(
        &mut plan, camera, None, 0, 1.0, view, reflectors, vertices, depth, settings,
    );
    plan
}

#[allow(clippy::too_many_arguments)]
fn visit(
    plan: &mut Plan,
    camera: &Camera,
    parent: Option<usize>,
    level: usize,
    weight: f32,
    view: ViewGeometry,
    reflectors: &[PlanarReflector],
    vertices: &[Vec<Vec3>],
    depth: usize,
    settings: RecursionSettings,
) -> Vec<usize> {
    if level >= depth {
        return Vec::new();
    }
    let planes = frustum_planes(&view_projection(camera, view.aspect, view.near));
    let mirror = parent.map(|p| plan.nodes[p].reflector);
    let mut seen = Vec::new();
    for (i, (r, verts)) in reflectors.iter().zip(vertices).enumerate() {
        // A planar mirror never sees itself (its mirrored eye is behind it).
        if Some(i) == mirror || verts.is_empty() {
            continue;
        }
        let behind_parent = mirror.is_some_and(|m| {
            verts
                .iter()
                .all(|&v| signed_distance(&reflectors[m].plane, v) <= view.clip)
        });
        if signed_distance(&r.plane, camera.position) <= 0.0 || behind_parent {
            plan.stats.culled_behind += 1;
            continue;
        }
        if outside(&planes, verts) {
            plan.stats.culled_frustum += 1;
            continue;
        }
        let centre = verts.iter().copied().sum::<Vec3>() / verts.len() as f32;
        let w = weight * r.modulation_at(centre, camera.position).max_element();
        if w < settings.cutoff {
            plan.stats.culled_weight += 1;
            continue;
        }
        if plan.nodes.len() >= MAX_MAPS {
            plan.stats.truncated += 1;
            continue;
        }
        let id = plan.nodes.len();
        let mirrored = mirror_camera(camera, &r.plane);
        plan.nodes.push(Node {
            reflector: i,
            level,
            parent,
            eye: camera.position,
            camera: mirrored,
            weight: w,
            children: Vec::new(),
        });
        plan.stats.maps += 1;
        plan.stats.per_level[level] += 1;
        let children = visit(
            plan,
            &mirrored,
            Some(id),
            level + 1,
            w,
            view,
            reflectors,
            vertices,
            depth,
            settings,
        );
        plan.nodes[id].children = children;
        seen.push(id);
    }
    seen
}

/// Bytes of the per-level targets for `depth` levels of `width` × `height`: an Rgba16Float
/// map and a Depth32Float buffer each.
pub fn texture_bytes(depth: u8, width: u32, height: u32) -> u64 {
    u64::from(depth) * u64::from(width) * u64::from(height) * (8 + 4)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Plane;
    use crate::view::reflections::{Modulation, ScreenKernel};

    fn mirror(name: &str, normal: Vec3, point: Vec3, ks: f32) -> PlanarReflector {
        let (tangent, bitangent) = crate::sampling::basis(normal);
        PlanarReflector {
            name: name.into(),
            plane: Plane { normal, point },
            tangent,
            bitangent,
            material: 0,
            ks: Vec3::splat(ks),
            modulation: Modulation::constant(Vec3::splat(ks)),
            kernel: ScreenKernel::identity(),
            triangles: vec![],
        }
    }

    /// A square of half size `h` in the plane x = `x`.
    fn square_x(x: f32, h: f32) -> Vec<Vec3> {
        vec![
            Vec3::new(x, -h, -h),
            Vec3::new(x, h, -h),
            Vec3::new(x, h, h),
            Vec3::new(x, -h, h),
        ]
    }

    const VIEW: ViewGeometry = ViewGeometry {
        aspect: 1.5,
        near: 0.01,
        clip: 1e-3,
    };

    /// Two facing mirrors at x = ∓1, the camera between them looking at the one at x = −1.
    fn corridor(ks: f32) -> (Camera, Vec<PlanarReflector>, Vec<Vec<Vec3>>) {
        let a = mirror("A", Vec3::X, Vec3::new(-1.0, 0.0, 0.0), ks);
        let b = mirror("B", -Vec3::X, Vec3::new(1.0, 0.0, 0.0), ks);
        let cam = Camera::look_at(
            Vec3::new(0.6, 0.3, 0.0),
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::Y,
            60f32.to_radians(),
        );
        (
            cam,
            vec![a, b],
            vec![square_x(-1.0, 1.0), square_x(1.0, 1.0)],
        )
    }

    #[test]
    fn facing_mirrors_alternate_down_the_tree() {
        let (cam, r, v) = corridor(1.0);
        for depth in 0..=MAX_RECURSION_DEPTH {
            let p = plan(
                &cam,
                VIEW,
                &r,
                &v,
                RecursionSettings {
                    depth,
                    cutoff: DEFAULT_WEIGHT_CUTOFF,
                    ..RecursionSettings::default()
                },
            );
            // B is behind the camera: only A at level 0, then B, A, B… one map per level.
            assert_eq!(p.stats.maps, depth as usize, "depth {depth}");
            for (k, n) in p.nodes.iter().enumerate() {
                assert_eq!(n.level, k);
                assert_eq!(n.reflector, k % 2);
                assert_eq!(n.parent, k.checked_sub(1));
            }
            if depth > 0 {
                assert_eq!(p.stats.culled_frustum, 1, "B behind the camera is culled");
                assert_eq!(p.roots, vec![0]);
            }
        }
    }

    #[test]
    fn weight_cutoff_stops_the_branch() {
        let (cam, r, v) = corridor(0.3);
        // Weights 0.3, 0.09, 0.027, 0.0081: a 0.05 cutoff keeps two levels of four.
        let p = plan(
            &cam,
            VIEW,
            &r,
            &v,
            RecursionSettings {
                depth: 4,
                cutoff: 0.05,
                ..RecursionSettings::default()
            },
        );
        assert_eq!(p.stats.maps, 2);
        assert_eq!(p.stats.culled_weight, 1);
        assert!((p.nodes[1].weight - 0.09).abs() < 1e-6);
        let all = plan(
            &cam,
            VIEW,
            &r,
            &v,
            RecursionSettings {
                depth: 4,
                cutoff: 0.0,
                ..RecursionSettings::default()
            },
        );
        assert_eq!(all.stats.maps, 4);
    }

    #[test]
    fn reflector_outside_the_mirrored_frustum_is_culled() {
        let (cam, mut r, mut v) = corridor(1.0);
        // C: a mirror on the floor far to the side, seen by neither the camera nor A's view.
        r.push(mirror("C", Vec3::Y, Vec3::new(0.0, -1.0, 20.0), 1.0));
        v.push(vec![
            Vec3::new(-0.5, -1.0, 19.5),
            Vec3::new(0.5, -1.0, 19.5),
            Vec3::new(0.5, -1.0, 20.5),
            Vec3::new(-0.5, -1.0, 20.5),
        ]);
        let settings = RecursionSettings {
            depth: 2,
            cutoff: DEFAULT_WEIGHT_CUTOFF,
            ..RecursionSettings::default()
        };
        let p = plan(&cam, VIEW, &r, &v, settings);
        assert_eq!(p.stats.maps, 2);
        // Level 0: B and C; level 1 (A's mirrored view): C.
        assert_eq!(p.stats.culled_frustum, 3);
        assert!(p.nodes.iter().all(|n| n.reflector != 2));
        // Widen the view: C comes in.
        let mut wide = cam;
        wide.forward = (Vec3::new(-0.2, -0.5, 1.0)).normalize();
        wide.right = wide.forward.cross(Vec3::Y).normalize();
        wide.up = wide.right.cross(wide.forward);
        let p = plan(&wide, VIEW, &r, &v, settings);
        assert!(p.nodes.iter().any(|n| n.reflector == 2));
    }

    #[test]
    fn reflector_behind_the_parent_mirror_is_culled() {
        let (cam, mut r, mut v) = corridor(1.0);
        // D behind A (x < −1), facing +x: A's mirrored view must not draw it.
        r.push(mirror("D", Vec3::X, Vec3::new(-3.0, 0.0, 0.0), 1.0));
        v.push(square_x(-3.0, 1.0));
        let p = plan(
            &cam,
            VIEW,
            &r,
            &v,
            RecursionSettings {
                depth: 2,
                cutoff: 0.0,
                ..RecursionSettings::default()
            },
        );
        assert!(
            p.nodes
                .iter()
                .all(|n| n.reflector != 2 || n.parent.is_none())
        );
        assert!(p.stats.culled_behind > 0);
    }

    #[test]
    fn depths_parse_and_bound_memory() {
        assert_eq!(parse_depth("0"), Ok(0));
        assert_eq!(parse_depth("4"), Ok(4));
        assert!(parse_depth("5").is_err());
        assert!(parse_depth("-1").is_err());
        assert!(parse_depth("two").is_err());
        assert_eq!(texture_bytes(2, 10, 10), 2 * 100 * 12);
    }
}
