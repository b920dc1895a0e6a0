//! Glossy planar reflections in the viewer, Bastos et al. 1999 Eq. 2:
//! L = kd·D + ks·(M*K)·R per glossy planar reflector, M the radiance reflected about the
//! reflector's plane, K the material's kernel, R its reflectance modulation, D the baked
//! radiosity (exitant radiance, kd already in it).
//!
//! Per reflector seen from its reflecting side and frame, two passes (`passes`; the
//! shader's inputs in `params`, M's target in `map_target`):
//! 1. M into an offscreen Rgba16Float texture in the reflected view (the viewpoint and its
//!    axes mirrored about the plane, [`mirror_camera`]), alpha = the fraction of the
//!    reflected ray beyond the plane (for K's scale), from one of two [`Source`]s:
//!    - geometry-based ([`ReflectionMode::Geometry`], Bastos §6's comparison baseline): the
//!      scene re-rendered, a clip plane discarding what lies behind the mirror;
//!    - image-based ([`ReflectionMode::Image`], §8.1.3): per reflector element, the `count`
//!      baked radiance maps closest to the mirrored eye ([`radiance_maps::select`],
//!      by angle or distance) reprojected as splats (quads of two triangles: WebGPU has no point
//!      size; the frame's kept points listed by index and drawn in one call per reflector),
//!      sized by Eq. 3 per quadtree node, culled per node, points skipped when
//!      minified ([`splats`], on the GPU in `splat_maps`). Texels no splat covered (gaps,
//!      and directions no selected map saw: at grazing views, beyond the maps' frusta) are
//!      filled in the composite from the nearest covered ones ([`splats::fill_hole`]);
//!      texels where a farther surface shows between rows of splats are closed from the
//!      nearer texels around them before anything reads M ([`gap_fill`]).
//! 2. The composite: the reflector drawn again over the frame, depth-tested against the scene
//!    pass (the mask), adding ks·R × (M*K) at the same pixel: the convolution with K (scaled
//!    per pixel, [`material`], and narrowed across the plane of incidence at grazing views,
//!    [`filter::Grazing`]) at a cost independent of K's width, a few taps of a regular
//!    pattern reading M's MIP pyramid ([`filter`], built per map by `pyramid`), R from the
//!    sphere map or the 1D map ([`ReflectanceLayout`]). In either mode a multisampled edge
//!    pixel whose centre lies off the reflector, where M continues the plane past its edge,
//!    reads M's nearest covered texels, as a hole does.
//!
//! [`cpu_reference`] is the same equation ray traced on the CPU, for the golden-image tests.
//!
//! [`recursive`]: the geometry mode to recursion depths 0–4 (Nielsen & Christensen
//! 2002 §3.1): reflectors seen in reflections get their own maps, one render target per level.

use glam::Vec3;

use super::load::ViewData;
use crate::camera::Camera;
use crate::scene::desc::ReflectorKind;
use crate::scene::{Plane, Scene};

mod cpu;
pub mod downsample;
pub mod exact;
pub mod filter;
pub mod gap_fill;
pub mod lobe_shape;
mod map_target;
pub mod material;
mod params;
mod passes;
mod pyramid;
pub mod radiance_maps;
pub mod recursive;
mod splat_maps;
pub mod splats;
pub mod terminal;

pub use cpu::{
    MkFilter, cpu_reference, cpu_reference_box, cpu_reference_filtered, reflector_pixels,
};
pub use material::{
    MODULATION_SIZE, Modulation, ReflectanceChannel, ReflectanceLayout, ScreenKernel,
    sample_modulation,
};
pub use params::{ReflectParams, shader_source};
pub use passes::{GeometryReflections, RESIDENT_SPLAT_BYTES, SkippedPasses};
pub use recursive::{RecursionSettings, RecursionStats, RecursiveReflections};
pub use splat_maps::FrameStats;
pub use splats::{SPLAT_OVERLAP, Splat};

/// WGSL of the reflection passes (appended to
/// [`crate::view::passes::renderer::SHADER_SOURCE`]).
pub const REFLECT_SHADER_SOURCE: &str = include_str!("../../../shaders/reflect.wgsl");

/// Clip distance of the mirrored view as a fraction of the scene's bounding-box diagonal:
/// geometry closer to the plane than this (the reflector itself) is not reflected; small, so
/// the walls' bottom millimetres stay in the mirrored view (docs/tuning.md#clip-fraction).
pub const CLIP_FRACTION: f32 = 1e-5;

pub use crate::view::options::{ReflectanceSettings, ReflectionMode};

/// Where the reflected image M comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// The mirrored scene re-rendered (geometry-based mode).
    Geometry,
    /// The baked radiance maps splatted into the reflected view (image-based mode): per
    /// element, the `count` maps closest to the mirrored eye by `selection`.
    Image {
        /// Angle (Bastos's default) or distance.
        selection: crate::view::reflections::radiance_maps::Selection,
        /// Maps per reflector element.
        count: usize,
    },
}

/// A glossy planar reflector as the viewer draws it.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanarReflector {
    /// Name from the scene.
    pub name: String,
    /// Its plane (normal: the reflecting side).
    pub plane: Plane,
    /// The plane's tangent frame (the sphere map's x and y axes).
    pub tangent: Vec3,
    /// Second in-plane axis.
    pub bitangent: Vec3,
    /// Its material (index into the scene's materials).
    pub material: u32,
    /// ks: the sum of its material's lobes' ks.
    pub ks: Vec3,
    /// ks·R per direction (R = 1 without a materials stage).
    pub modulation: Modulation,
    /// K (the identity without a materials stage).
    pub kernel: ScreenKernel,
    /// Its triangles (indices into the scene's triangles).
    pub triangles: Vec<u32>,
}

impl PlanarReflector {
    /// ks·R for a point `p` of the reflector seen from `eye`.
    pub fn modulation_at(&self, p: Vec3, eye: Vec3) -> Vec3 {
        let n = self.plane.normal;
        let v = (eye - p).normalize_or_zero();
        let r = mirror_direction(n, -v);
        self.modulation.at(Vec3::new(
            r.dot(self.tangent),
            r.dot(self.bitangent),
            r.dot(n),
        ))
    }
}

/// The scene's planar reflectors whose material has a glossy lobe, in scene order, with
/// K = identity and ks·R = Σ k_s · Schlick's F at the view angle ([`material::fresnel_table`]:
/// a coloured metal is tinted by its F₀, not the sum of its two lobes' k_s, about 1).
pub fn glossy_planar_reflectors(scene: &Scene) -> Vec<PlanarReflector> {
    scene
        .reflectors
        .iter()
        .filter(|r| r.kind == ReflectorKind::Planar)
        .filter_map(|r| {
            let plane = r.plane?;
            let material = scene.materials.get(r.material as usize)?;
            let ks = material
                .lobes
                .iter()
                .fold(Vec3::ZERO, |a, l| a + Vec3::from_array(l.ks));
            let (tangent, bitangent) = crate::sampling::basis(plane.normal);
            (ks.max_element() > 0.0).then(|| PlanarReflector {
                name: r.name.clone(),
                plane,
                tangent,
                bitangent,
                material: r.material,
                ks,
                modulation: Modulation::OneD(material::fresnel_table(&material.lobes)),
                kernel: ScreenKernel::identity(),
                triangles: r.triangles.clone(),
            })
        })
        .collect()
}

/// [`reflectors_with_materials`] with the default settings (1D map, albedo channel).
pub fn reflectors_with_reflectance(data: &ViewData) -> Vec<PlanarReflector> {
    reflectors_with_materials(data, ReflectanceSettings::default())
}

/// The scene's glossy planar reflectors with K and R from the bundle's `materials` stage when
/// it has one ([`material::load_material`]); problems reading it are logged and leave K = I,
/// R = 1 for that reflector.
pub fn reflectors_with_materials(
    data: &ViewData,
    settings: ReflectanceSettings,
) -> Vec<PlanarReflector> {
    let mut reflectors = glossy_planar_reflectors(&data.scene);
    if data.bundle.stage("materials").is_none() {
        log::info!("no materials stage: reflections use K = I, ks·R = Σ ks·Schlick F");
        return reflectors;
    }
    let index = match crate::materials::MaterialsIndex::load(&data.bundle) {
        Ok(Some(v)) => v,
        Ok(None) => return reflectors,
        Err(e) => {
            log::warn!("{e}; reflections use K = I, R = 1");
            return reflectors;
        }
    };
    // Read (and K's lobe shape measured) once per material: a building's reflectors share a
    // few materials.
    let mut loaded = std::collections::HashMap::new();
    for r in &mut reflectors {
        let got = loaded.entry(r.material).or_insert_with(|| {
            let name = &data.scene.materials[r.material as usize].name;
            material::load_material(
                &data.bundle,
                &index,
                name,
                settings.layout,
                settings.channel,
            )
        });
        match got {
            Ok((kernel, modulation)) => {
                r.kernel = kernel.clone();
                r.modulation = modulation.clone();
            }
            Err(e) => log::warn!("reflector {}: {e}; K = I, R = 1", r.name),
        }
    }
    reflectors
}

/// Signed distance of `p` from `plane` (positive on the normal's side).
pub fn signed_distance(plane: &Plane, p: Vec3) -> f32 {
    plane.normal.dot(p - plane.point)
}

/// `p` mirrored about `plane`.
pub fn mirror_point(plane: &Plane, p: Vec3) -> Vec3 {
    p - 2.0 * signed_distance(plane, p) * plane.normal
}

/// Direction `d` mirrored about a plane of unit normal `n`.
pub fn mirror_direction(n: Vec3, d: Vec3) -> Vec3 {
    d - 2.0 * n.dot(d) * n
}

/// The reflected view: position and all three axes mirrored about `plane`. The mirrored frame
/// is left-handed, which makes pixel (x, y) of the mirrored view show what the real view sees
/// at (x, y) in the mirror: a point P projects in the mirrored view where its mirror image
/// projects in the real one.
pub fn mirror_camera(camera: &Camera, plane: &Plane) -> Camera {
    let n = plane.normal;
    Camera {
        position: mirror_point(plane, camera.position),
        forward: mirror_direction(n, camera.forward),
        right: mirror_direction(n, camera.right),
        up: mirror_direction(n, camera.up),
        fov_y: camera.fov_y,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reflect_params_match_the_wgsl_struct() {
        crate::assert_wgsl_layout!(
            shader_source(),
            "ReflectParams",
            ReflectParams {
                plane,
                ks,
                eye,
                tangent,
                bitangent,
                kernel,
                parent,
                modulation,
                taps,
                shape
            }
        );
    }

    #[test]
    fn mirrored_camera_sees_the_mirror_image_at_the_same_pixel() {
        let plane = Plane {
            normal: Vec3::new(0.2, 1.0, -0.1).normalize(),
            point: Vec3::new(0.1, -0.3, 0.2),
        };
        let cam = Camera::look_at(
            Vec3::new(0.3, 1.2, 4.0),
            Vec3::new(-0.2, 0.0, 0.0),
            Vec3::Y,
            50f32.to_radians(),
        );
        let m = mirror_camera(&cam, &plane);
        let (w, h) = (64.0f32, 48.0f32);
        let a = crate::view::passes::renderer::view_projection(&cam, w / h, 1e-3);
        let b = crate::view::passes::renderer::view_projection(&m, w / h, 1e-3);
        for p in [
            Vec3::new(0.5, 1.0, -1.0),
            Vec3::new(-1.0, 2.0, 0.5),
            Vec3::new(0.0, 0.3, -3.0),
        ] {
            let ca = a * mirror_point(&plane, p).extend(1.0);
            let cb = b * p.extend(1.0);
            assert!(((ca / ca.w) - (cb / cb.w)).length() < 1e-4, "{ca} vs {cb}");
        }
        assert!(
            (mirror_point(&plane, mirror_point(&plane, cam.position)) - cam.position).length()
                < 1e-5
        );
    }

    #[test]
    fn modes_parse() {
        assert_eq!("geometry".parse(), Ok(ReflectionMode::Geometry));
        assert_eq!("off".parse(), Ok(ReflectionMode::Off));
        assert!("mirror".parse::<ReflectionMode>().is_err());
    }

    #[test]
    fn modulation_is_indexed_by_the_reflected_direction() {
        let plane = Plane {
            normal: Vec3::Y,
            point: Vec3::ZERO,
        };
        let (tangent, bitangent) = crate::sampling::basis(Vec3::Y);
        // A 1D table growing towards normal incidence.
        let table: Vec<Vec3> = (0..MODULATION_SIZE)
            .map(|k| Vec3::splat(k as f32))
            .collect();
        let r = PlanarReflector {
            name: "F".into(),
            plane,
            tangent,
            bitangent,
            material: 0,
            ks: Vec3::ONE,
            modulation: Modulation::OneD(table),
            kernel: ScreenKernel::identity(),
            triangles: vec![],
        };
        let above = r.modulation_at(Vec3::ZERO, Vec3::new(0.0, 2.0, 0.0));
        let grazing = r.modulation_at(Vec3::ZERO, Vec3::new(5.0, 0.2, 0.0));
        assert!((above.x - (MODULATION_SIZE - 1) as f32).abs() < 1e-3);
        assert!(grazing.x < 0.5 * above.x);
    }
}
