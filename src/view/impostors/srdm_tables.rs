//! The SRDM tables as the shaders read them (`shaders/srdm.wgsl`), and the per-reflector
//! parameters of the impostor reflections pass (`shaders/impostors.wgsl`). Pure: packing and
//! small math only; [`crate::view::impostors`] uploads them.
//!
//! Views of one impostor object are consecutive; `impostors[k]` holds object k's first view
//! and view count.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use crate::scene::Scene;
use crate::scene::desc::ReflectorKind;
use crate::srdm::{Domain, Srdm};
use crate::view::reflections::{MODULATION_SIZE, PlanarReflector};

/// One captured view as `srdm.wgsl` reads it (`SrdmView`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuView {
    /// xyz: eye position; w: tan(fov / 2).
    pub position: [f32; 4],
    /// xyz: right; w: hither distance.
    pub right: [f32; 4],
    /// xyz: up; w: yon distance.
    pub up: [f32; 4],
    /// xyz: forward; w: resolution w.
    pub forward: [f32; 4],
    /// n domains, m points per row, first point, first row.
    pub shape: [u32; 4],
    /// First domain, first colour texel, impostor index, 0.
    pub offsets: [u32; 4],
}

/// One view to pack: its SRDM (with camera) and its captured colour (w² texels, row-major).
pub struct ViewSource<'a> {
    /// Which impostor object it belongs to (views of one object must be consecutive).
    pub impostor: u32,
    /// The SRDM set.
    pub srdm: &'a Srdm,
    /// Linear colour per texel.
    pub colour: &'a [Vec3],
}

/// Every view's SRDM, packed for the GPU.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SrdmTables {
    /// Per view.
    pub views: Vec<GpuView>,
    /// All points (u, z).
    pub points: Vec<[f32; 2]>,
    /// Points in use per row.
    pub counts: Vec<u32>,
    /// Row direction per domain (cos θᵢ, sin θᵢ), from [`Domain::new`].
    pub domains: Vec<[f32; 2]>,
    /// Colour per texel (rgb, 1).
    pub colours: Vec<[f32; 4]>,
    /// Per impostor object: first view, view count, 0, 0.
    pub impostors: Vec<[u32; 4]>,
}

impl SrdmTables {
    /// Packs `views` in order. Panics if an object's views are not consecutive or a colour
    /// array is not w² long (both are the caller's invariants).
    pub fn pack(views: &[ViewSource<'_>]) -> SrdmTables {
        let mut t = SrdmTables::default();
        for (vi, v) in views.iter().enumerate() {
            let s = v.srdm;
            let cam = s.camera();
            let w = s.resolution();
            assert_eq!(v.colour.len(), (w * w) as usize, "colour is w² texels");
            let gv = GpuView {
                position: cam.view.position.extend(cam.tan_half_fov()).to_array(),
                right: cam.view.right.extend(cam.hither).to_array(),
                up: cam.view.up.extend(cam.yon).to_array(),
                forward: cam.view.forward.extend(w as f32).to_array(),
                shape: [
                    s.domains(),
                    s.points_per_row(),
                    t.points.len() as u32,
                    t.counts.len() as u32,
                ],
                offsets: [
                    t.domains.len() as u32,
                    t.colours.len() as u32,
                    v.impostor,
                    0,
                ],
            };
            t.views.push(gv);
            t.points.extend_from_slice(s.points());
            t.counts.extend(s.counts().iter().map(|&c| u32::from(c)));
            t.domains
                .extend((0..s.domains()).map(|i| Domain::new(i, s.domains(), w).e.to_array()));
            t.colours
                .extend(v.colour.iter().map(|c| c.extend(1.0).to_array()));
            match t.impostors.last_mut() {
                Some(last) if last[2] == v.impostor => last[1] += 1,
                _ => {
                    assert!(
                        t.impostors.iter().all(|o| o[2] != v.impostor),
                        "views of an impostor must be consecutive"
                    );
                    // [2] keeps the object id while packing; cleared below.
                    t.impostors.push([vi as u32, 1, v.impostor, 0]);
                }
            }
        }
        for o in &mut t.impostors {
            o[2] = 0;
        }
        t
    }

    /// The view of impostor object `k` searched for a ray of direction `dir`: the one whose
    /// camera looks most nearly along the ray (`srdm_pick_view`).
    pub fn pick_view(&self, k: usize, dir: Vec3) -> usize {
        let [first, count, ..] = self.impostors[k];
        let mut best = (first as usize, -2.0f32);
        for i in first..first + count {
            let f = self.views[i as usize].forward;
            let d = dir.dot(Vec3::new(f[0], f[1], f[2]));
            if d > best.1 {
                best = (i as usize, d);
            }
        }
        best.0
    }
}

/// The captured colour at image position `pixel` of a `w × w` capture (nearest texel, as
/// `srdm_colour`).
pub fn colour_at(colour: &[Vec3], w: u32, pixel: glam::Vec2) -> Vec3 {
    let x = (pixel.x.max(0.0) as u32).min(w - 1);
    let y = (pixel.y.max(0.0) as u32).min(w - 1);
    colour[(y * w + x) as usize]
}

/// Figure 15 (left): the weight of a reflection whose reflected ray travelled `t`,
/// exp(−t / distance); 1 with no distance (`impostor_attenuation`).
pub fn attenuation(t: f32, distance: Option<f32>) -> f32 {
    match distance {
        Some(d) if d > 0.0 => (-t / d).exp(),
        _ => 1.0,
    }
}

/// A reflector the impostor pass draws: its triangles and how its pixels reflect.
#[derive(Clone, Debug, PartialEq)]
pub struct ImpostorReflector {
    /// Name from the scene.
    pub name: String,
    /// Its triangles (indices into the scene's triangles).
    pub triangles: Vec<u32>,
    /// The plane's normal for a planar reflector; `None`: per-pixel normals (curved).
    pub normal: Option<Vec3>,
    /// ks·R per view cosine ([`PlanarReflector::modulation`]).
    pub modulation: Vec<Vec3>,
}

/// The scene's reflectors with a glossy lobe: planar ones as the planar passes see them (R from
/// the materials stage, given in `planar`), curved ones with ks·R = Σ k_s · Schlick's F at the
/// view angle ([`crate::view::reflections::material::fresnel_table`]).
pub fn impostor_reflectors(scene: &Scene, planar: &[PlanarReflector]) -> Vec<ImpostorReflector> {
    let mut out: Vec<ImpostorReflector> = planar
        .iter()
        .map(|r| ImpostorReflector {
            name: r.name.clone(),
            triangles: r.triangles.clone(),
            normal: Some(r.plane.normal),
            modulation: r.modulation.table_1d(),
        })
        .collect();
    for r in scene
        .reflectors
        .iter()
        .filter(|r| r.kind != ReflectorKind::Planar)
    {
        let Some(m) = scene.materials.get(r.material as usize) else {
            continue;
        };
        let ks = m
            .lobes
            .iter()
            .fold(Vec3::ZERO, |a, l| a + Vec3::from_array(l.ks));
        if ks.max_element() > 0.0 {
            out.push(ImpostorReflector {
                name: r.name.clone(),
                triangles: r.triangles.clone(),
                normal: None,
                modulation: crate::view::reflections::material::fresnel_table(&m.lobes),
            });
        }
    }
    out
}

/// `ImpostorParams` of `shaders/impostors.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct ImpostorParams {
    /// xyz: normal; w: 1 to use it, 0 for per-pixel normals.
    pub normal: [f32; 4],
    /// xyz: eye; w: the 1D map's grazing bound C.
    pub eye: [f32; 4],
    /// 1 / attenuation distance (0: off), impostor objects, t_max, 0.
    pub settings: [f32; 4],
    /// ks·R per 1D-map cosine.
    pub modulation: [[f32; 4]; MODULATION_SIZE],
}

/// Longest reflected ray searched (metres): far beyond any scene the viewer draws.
pub const T_MAX: f32 = 1e6;

impl ImpostorParams {
    /// The parameters of `r` for an eye at `eye` with `objects` impostor objects.
    pub fn new(
        r: &ImpostorReflector,
        eye: Vec3,
        objects: usize,
        attenuation_distance: Option<f32>,
    ) -> ImpostorParams {
        let mut modulation = [[0.0f32; 4]; MODULATION_SIZE];
        for (m, v) in modulation.iter_mut().zip(&r.modulation) {
            *m = v.extend(0.0).to_array();
        }
        let inv = match attenuation_distance {
            Some(d) if d > 0.0 => 1.0 / d,
            _ => 0.0,
        };
        ImpostorParams {
            normal: match r.normal {
                Some(n) => n.extend(1.0).to_array(),
                None => [0.0; 4],
            },
            eye: eye
                .extend(crate::materials::reflectance::C_GRAZING)
                .to_array(),
            settings: [inv, objects as f32, T_MAX, 0.0],
            modulation,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;
    use crate::progress::Silent;
    use crate::srdm::{DepthMap, ImpostorCamera, SrdmParams};

    fn srdm(eye: Vec3, w: u32, n: u32, m: u32) -> Srdm {
        let camera = ImpostorCamera {
            view: Camera::look_at(eye, Vec3::ZERO, Vec3::Y, 0.5),
            hither: 1.0,
            yon: 3.0,
            resolution: w,
        };
        let map = DepthMap::from_fn(w, |x, _| (x > 1).then_some(0.5)).unwrap();
        Srdm::build(
            &map,
            camera,
            SrdmParams {
                domains: n,
                points: m,
            },
            &Silent,
        )
        .unwrap()
    }

    #[test]
    fn views_are_packed_one_after_another() {
        let a = srdm(Vec3::Z * 2.0, 8, 3, 4);
        let b = srdm(Vec3::X * 2.0, 6, 5, 2);
        let (ca, cb) = (vec![Vec3::ONE; 64], vec![Vec3::X; 36]);
        let t = SrdmTables::pack(&[
            ViewSource {
                impostor: 0,
                srdm: &a,
                colour: &ca,
            },
            ViewSource {
                impostor: 1,
                srdm: &b,
                colour: &cb,
            },
        ]);
        assert_eq!(t.views[1].shape, [5, 2, 3 * 8 * 4, 3 * 8]);
        assert_eq!(t.views[1].offsets, [3, 64, 1, 0]);
        assert_eq!(t.points.len(), 3 * 8 * 4 + 5 * 6 * 2);
        assert_eq!(t.counts.len(), 3 * 8 + 5 * 6);
        assert_eq!(t.domains.len(), 8);
        assert_eq!(t.impostors, vec![[0, 1, 0, 0], [1, 1, 0, 0]]);
        assert_eq!(&t.points[24 * 4..], b.points());
        assert_eq!(t.colours[64], [1.0, 0.0, 0.0, 1.0]);
    }

    #[test]
    fn the_view_looking_along_the_ray_is_picked() {
        let a = srdm(Vec3::Z * 2.0, 4, 1, 2);
        let b = srdm(Vec3::X * 2.0, 4, 1, 2);
        let c = vec![Vec3::ZERO; 16];
        let t = SrdmTables::pack(&[
            ViewSource {
                impostor: 0,
                srdm: &a,
                colour: &c,
            },
            ViewSource {
                impostor: 0,
                srdm: &b,
                colour: &c,
            },
        ]);
        assert_eq!(t.impostors, vec![[0, 2, 0, 0]]);
        // a looks along −Z, b along −X.
        assert_eq!(t.pick_view(0, -Vec3::Z), 0);
        assert_eq!(t.pick_view(0, Vec3::new(-1.0, 0.0, -0.2)), 1);
    }

    #[test]
    fn attenuation_falls_with_distance_only_when_set() {
        assert_eq!(attenuation(5.0, None), 1.0);
        assert!((attenuation(2.0, Some(2.0)) - (-1.0f32).exp()).abs() < 1e-6);
        assert!(attenuation(1.0, Some(0.5)) < attenuation(0.5, Some(0.5)));
    }
}
