//! What a bundle was baked for, as the viewer's default reflection modes need it
//! ([`crate::view::options::Defaults`]): radiance maps for its glossy planar reflectors,
//! glossy curved reflectors, impostor depth maps.

use super::curved::curved_reflectors;
use super::load::ViewData;
use super::options::Baked;
use super::reflections::glossy_planar_reflectors;

/// What `data`'s bundle holds for the viewer's reflection modes: the modes `glint-view`
/// turns on when its command line leaves them unset.
pub fn baked(data: &ViewData) -> Baked {
    let has = |stage: &str| {
        data.bundle
            .stage(stage)
            .is_some_and(|s| !s.assets.is_empty())
    };
    let index = crate::materials::MaterialsIndex::load(&data.bundle)
        .ok()
        .flatten();
    Baked {
        radiance_maps: has("radiance") && !glossy_planar_reflectors(&data.scene).is_empty(),
        curved_reflectors: curved_reflectors(&data.scene).len(),
        impostor_captures: has("srdm") && !data.scene.impostors.is_empty(),
        probes: index.as_ref().map_or(0, |index| index.probes.len()),
        glossy_samples: index
            .filter(|index| !index.env_maps.is_empty())
            .map(|index| index.settings.sample_budget),
    }
}
