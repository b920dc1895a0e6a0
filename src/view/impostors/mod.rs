//! Reflections of depth-map impostors (Popescu et al. 2006 §3.1, §4.3) in the viewer.
//!
//! - [`SrdmBuffers`]: a bundle's SRDM tables ([`SrdmTables`]) in GPU storage buffers, bind
//!   group 1 of `shaders/srdm.wgsl`.
//! - [`SrdmProbe`]: a compute pass intersecting a batch of rays with them (`cs_srdm_probe`),
//!   what the tests hold to the CPU intersection ([`crate::srdm::Srdm::intersect`]).
//! - [`ImpostorReflections`]: the per-pixel pass (`shaders/impostors.wgsl`): for every visible
//!   pixel of every glossy reflector, the reflected ray against each impostor object's SRDM
//!   rows, the nearest hit's captured colour × ks·R(θ) (the Fresnel modulation) × the
//!   distance attenuation of Figure 15, added to the frame like the planar composite.
//!
//! - With [`ImpostorKind::Billboard`], the same pass intersects reflected billboards instead
//!   (§3.1, `shaders/billboards.wgsl`, tables from [`billboard_tables`], made at load
//!   time): second-order reflections through reflective billboards, the §3.2 morph for
//!   billboards connected to the environment, and misses reading the reflector's baked MIP
//!   environment map (level 0, materials stage) where the bundle has one.
//! - [`BillboardProbe`]: a compute pass tracing a batch of rays through `bb_trace`, held to
//!   [`BillboardTables::trace`] by the tests.
//!
//! With depth maps a ray that misses every impostor adds nothing (no environment lookup).

pub mod billboard_tables;
mod pass;
mod probes;
pub mod srdm_tables;
mod tables_gpu;

pub use pass::ImpostorReflections;
pub use probes::{BillboardProbe, BillboardProbeHit, BillboardRay, ProbeHit, ProbeRay, SrdmProbe};
pub use tables_gpu::{BillboardBuffers, SrdmBuffers};

use super::gpu::Gpu;
use super::load::ViewData;
use crate::view::passes::renderer::Renderer;
use billboard_tables::BillboardTables;
use srdm_tables::{ImpostorReflector, SrdmTables, ViewSource};

/// WGSL of the SRDM intersection.
pub const SRDM_SHADER_SOURCE: &str = include_str!("../../../shaders/srdm.wgsl");
/// WGSL of the ray-batch compute entry (appended to [`SRDM_SHADER_SOURCE`]).
pub const SRDM_PROBE_SHADER_SOURCE: &str = include_str!("../../../shaders/srdm_probe.wgsl");
/// WGSL of the reflections pass (appended to the view and SRDM shaders).
pub const IMPOSTOR_SHADER_SOURCE: &str = include_str!("../../../shaders/impostors.wgsl");
/// WGSL of the billboard tables and `bb_trace` (§3.1, §3.2).
pub const BILLBOARD_SHADER_SOURCE: &str = include_str!("../../../shaders/billboards.wgsl");
/// WGSL of the billboard fragment entry (appended after [`BILLBOARD_SHADER_SOURCE`]).
pub const BILLBOARD_REFLECT_SHADER_SOURCE: &str =
    include_str!("../../../shaders/billboard_reflect.wgsl");
/// WGSL of the billboard ray-batch compute entry.
pub const BILLBOARD_PROBE_SHADER_SOURCE: &str =
    include_str!("../../../shaders/billboard_probe.wgsl");

/// Reads the bundle's `srdm` stage and packs every view, objects in scene order. `Ok(None)`
/// when the bundle has no such stage.
pub fn load_tables(data: &ViewData) -> Result<Option<SrdmTables>, String> {
    let loaded = crate::srdm::index::load(&data.bundle)
        .map_err(|e| format!("bundle {}: {e}", data.bundle.dir().display()))?;
    let Some((_, views)) = loaded else {
        return Ok(None);
    };
    let mut names: Vec<&str> = Vec::new();
    let sources: Vec<ViewSource<'_>> = views
        .iter()
        .map(|v| {
            let k = match names.iter().position(|n| *n == v.entry.impostor) {
                Some(k) => k,
                None => {
                    names.push(&v.entry.impostor);
                    names.len() - 1
                }
            };
            ViewSource {
                impostor: k as u32,
                srdm: &v.srdm,
                colour: &v.capture.colour,
            }
        })
        .collect();
    Ok(Some(SrdmTables::pack(&sources)))
}

pub use crate::view::options::ImpostorKind;

/// Which reflectors the pass draws.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ReflectorSet {
    /// Every glossy reflector.
    #[default]
    All,
    /// Planar reflectors only (`--impostors on`).
    Planar,
    /// Curved reflectors only (`--curved impostor`).
    Curved,
}

/// Settings of the impostor reflections pass.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImpostorSettings {
    /// Figure 15's attenuation with distance: reflections fade as exp(−t / distance) with the
    /// reflected ray's length t (metres); `None` (the default, as the reference has no such
    /// term): off.
    pub attenuation_distance: Option<f32>,
    /// Depth maps or billboards.
    pub kind: ImpostorKind,
    /// Which reflectors.
    pub reflectors: ReflectorSet,
    /// Billboard resolution (0: [`billboard_tables::DEFAULT_RESOLUTION`]).
    pub billboard_resolution: u32,
}

/// The impostor pass for `set` of reflectors with `kind` (`--impostors on` draws the planar
/// ones, `--curved impostor` the curved ones).
pub fn impostor_pass(
    gpu: &Gpu,
    renderer: &Renderer,
    data: &ViewData,
    kind: ImpostorKind,
    set: ReflectorSet,
) -> Result<ImpostorReflections, crate::view::gpu::RenderError> {
    ImpostorReflections::new(
        gpu,
        renderer,
        data,
        ImpostorSettings {
            kind,
            reflectors: set,
            ..ImpostorSettings::default()
        },
    )
}

/// The billboards of `data`'s impostor objects for `reflectors` (§3), with each reflector's
/// baked MIP environment map (level 0) where the materials stage has one.
pub fn build_billboards(
    data: &ViewData,
    reflectors: &[ImpostorReflector],
    resolution: u32,
) -> Result<BillboardTables, String> {
    // D where the bundle's radiosity stage was baked from this scene, as the SRDM stage's
    // captures (the one place that choice is made); the albedo otherwise.
    let colour = crate::srdm::capture::colour_source(data.bundle.dir(), &data.scene)
        .map_err(|e| format!("billboard colour: {e}"))?;
    let mut env = Vec::new();
    for r in reflectors {
        let map = super::curved::gpu::load_baked_pyramid(data, &r.name)?;
        let tris: Vec<_> = r
            .triangles
            .iter()
            .map(|&t| data.scene.triangles[t as usize])
            .collect();
        env.push(
            map.and_then(|p| p.levels.into_iter().next())
                .map(|m| (m, crate::srdm::billboard::centroid(&tris))),
        );
    }
    let w = if resolution == 0 {
        billboard_tables::DEFAULT_RESOLUTION
    } else {
        resolution
    };
    Ok(billboard_tables::build(
        &data.scene,
        reflectors,
        w,
        &colour,
        &env,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_parse_and_print() {
        assert_eq!("srdm".parse(), Ok(ImpostorKind::Srdm));
        assert_eq!("billboard".parse(), Ok(ImpostorKind::Billboard));
        assert!("depth".parse::<ImpostorKind>().is_err());
        assert_eq!(ImpostorKind::Billboard.to_string(), "billboard");
        assert_eq!(ImpostorSettings::default().reflectors, ReflectorSet::All);
    }
}
