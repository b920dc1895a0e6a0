//! Near-mirrors at the end of geometry mode's recursion.
//!
//! Nielsen & Christensen's recursion (§3.1) stops at depth d: a reflector seen in a map of the
//! last level has no map of its own, so it shows its kd·D alone. For a mirror seen in a
//! glossy floor that is nearly black where the path tracer shows the room and the lamp the
//! mirror reflects (glossy-room's floor glow below the table). Here such a near-mirror gets
//! the treatment Nielsen gives curved reflectors (§3.2): a cube map taken once near its
//! centre, read with distance-corrected lookups ([`crate::view::curved::parallax_direction`]),
//! its specular term added to kd·D inside the map that sees it (the curved reflectors'
//! passes, [`CurvedReflections`], drawn with a keep-list per view). A reflector seen through
//! another one is small and blurred by that one's kernel, which is where a cube map from one
//! point is good enough; the recursion's own maps stay exact where they are drawn. A
//! departure from Nielsen, whose maps end in kd·D.
//!
//! Image mode uses the same cube maps. Its radiance maps hold one glossy bounce already
//! ([`crate::radiance::shading`]), but towards the map's camera: glossy-room's table, whose
//! cameras sit 20 cm behind it, showed the mirror panel's reflection as they saw it. So a
//! near-mirror's map points are left out of the splats and the mirror is drawn exactly
//! ([`super::exact`]), kd·D and this specular term (docs/tuning.md#terminal-cube-maps).

use super::PlanarReflector;
use crate::brdf::Lobe;
use crate::scene::Scene;
use crate::view::curved::gpu::CurvedReflections;
use crate::view::curved::{CurvedReflector, CurvedSettings, MAX_LOBES};
use crate::view::gpu::Gpu;
use crate::view::gpu::RenderError;
use crate::view::load::ViewData;
use crate::view::passes::renderer::Renderer;

/// How far in front of its plane a planar reflector's cube map is taken, as a fraction of
/// the scene's diagonal: off the plane, so its faces do not graze the wall the reflector
/// hangs on.
pub const CENTRE_OFFSET_FRACTION: f32 = 1e-3;

/// Each of `planar` as a cube-mapped reflector, index for index: its triangles, its
/// material's glossy lobes (at most [`MAX_LOBES`]) when it is a near-mirror
/// ([`crate::radiosity::is_mirror`]), else none (nothing is drawn), and its area-weighted
/// centroid moved [`CENTRE_OFFSET_FRACTION`] of the scene's diagonal along its normal.
///
/// Near-mirrors only: a rougher reflector seen through another one is blurred by both and
/// adds little there, while its fragments cost as much
/// (docs/tuning.md#terminal-near-mirrors-only).
pub fn terminal_reflectors(scene: &Scene, planar: &[PlanarReflector]) -> Vec<CurvedReflector> {
    let offset = scene.bounds.diagonal() * CENTRE_OFFSET_FRACTION;
    planar
        .iter()
        .map(|r| {
            let material = scene
                .materials
                .get(r.material as usize)
                .filter(|m| crate::radiosity::is_mirror(m));
            let mut lobes: Vec<Lobe> = material
                .map(|m| m.lobes.iter().map(Lobe::from).collect())
                .unwrap_or_default();
            lobes.retain(|l| l.ks.max_element() > 0.0);
            lobes.truncate(MAX_LOBES);
            let centroid = crate::materials::envmap::capture_centre(scene, &r.triangles);
            CurvedReflector {
                name: r.name.clone(),
                triangles: r.triangles.clone(),
                centre: centroid + r.plane.normal * offset,
                lobes,
            }
        })
        .collect()
}

/// The triangles of the near-mirrors `passes` ([`terminal_passes`]) draws (those with
/// lobes), in order: image mode draws them exactly instead of splatting their map points.
pub fn mirror_triangles(passes: &CurvedReflections) -> Vec<u32> {
    passes
        .reflectors()
        .filter(|r| !r.lobes.is_empty())
        .flat_map(|r| r.triangles.iter().copied())
        .collect()
}

/// The cube-map passes of `planar`'s near-mirrors ([`terminal_reflectors`], index for index)
/// with `settings`' face size, samples and parallax; one generation (no interreflection
/// between the cube-mapped mirrors: light already two reflections deep, and each generation
/// costs six renders of the scene per mirror when the passes are built) and no
/// self-reflection (a plane does not see itself). `None` without `settings`, when a reflector
/// is alone (it sees no other one) or when none of them is a near-mirror. Geometry mode (one
/// level or the recursion) and image mode build theirs here.
pub fn terminal_passes(
    gpu: &Gpu,
    renderer: &Renderer,
    data: &ViewData,
    settings: Option<CurvedSettings>,
    planar: &[PlanarReflector],
) -> Result<Option<CurvedReflections>, RenderError> {
    let Some(settings) = settings.filter(|_| planar.len() >= 2) else {
        return Ok(None);
    };
    let reflectors = terminal_reflectors(&data.scene, planar);
    if reflectors.iter().all(|r| r.lobes.is_empty()) {
        return Ok(None);
    }
    let settings = CurvedSettings {
        self_occlusion: false,
        generations: 1,
        ..settings
    };
    CurvedReflections::with_reflectors(gpu, renderer, data, settings, reflectors).map(Some)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_near_mirrors_get_lobes_and_centres_sit_in_front_of_their_plane() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/glossy-room/scene.json");
        let scene = Scene::load(path).unwrap_or_else(|e| panic!("{e}"));
        let planar = super::super::glossy_planar_reflectors(&scene);
        let terminal = terminal_reflectors(&scene, &planar);
        assert_eq!(terminal.len(), planar.len());
        let offset = scene.bounds.diagonal() * CENTRE_OFFSET_FRACTION;
        let mut mirrors = 0;
        for (t, p) in terminal.iter().zip(&planar) {
            assert_eq!((&t.name, &t.triangles), (&p.name, &p.triangles));
            let material = &scene.materials[p.material as usize];
            let mirror = crate::radiosity::is_mirror(material);
            mirrors += usize::from(mirror);
            // The floor and the table (rough) none; the mirror panel its lobe.
            assert_eq!(!t.lobes.is_empty(), mirror, "{}", p.name);
            let height = crate::view::reflections::signed_distance(&p.plane, t.centre);
            assert!(
                (height - offset).abs() < 1e-4,
                "{}: {height} vs {offset}",
                p.name
            );
            let inside = crate::materials::envmap::capture_centre(&scene, &p.triangles);
            assert!((t.centre - p.plane.normal * offset - inside).length() < 1e-5);
        }
        assert_eq!(mirrors, 1, "glossy-room has one near-mirror");
        assert!(planar.len() >= 3);
    }
}
