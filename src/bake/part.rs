//! Which part of a stage one bake writes: the whole stage (`glint-bake`, the stage tools), or
//! one work unit's item of it ([`super::units`]), reading D from the radiosity unit's shard
//! instead of the bundle written.

use std::path::Path;

use crate::bundle::{Bundle, BundleError};
use crate::radiosity::RadiosityMap;
use crate::radiosity::map::MapError;

/// One item of a stage, by its index in the list the stage itself makes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Item {
    /// Everything the stage bakes.
    #[default]
    All,
    /// A planar reflector's radiance maps: index into [`super::radiance_stage::plans`].
    Reflector(usize),
    /// An impostor's views: index into the scene's impostors.
    Impostor(usize),
    /// A glossy material's lobes: index into [`super::materials::chosen_materials`].
    Material(usize),
    /// A curved reflector's environment map: index into
    /// [`super::materials::curved_glossy_reflectors`].
    EnvMap(usize),
    /// A reflection probe: index into [`crate::materials::probes::scene_probes`].
    Probe(usize),
}

impl Item {
    /// Whether this selection bakes the item `of` (everything does).
    pub fn takes(self, of: Item) -> bool {
        self == Item::All || self == of
    }
}

/// The part of a stage a bake writes, and where it reads D.
#[derive(Clone, Copy, Debug, Default)]
pub struct Part<'a> {
    /// The item.
    pub item: Item,
    /// A bundle to read D from (a radiosity unit's shard) instead of the bundle written. Its
    /// scene hash is not compared with the scene's: the unit's key says which D is wanted,
    /// and the merge checks that every unit read the D it assembles.
    pub d_from: Option<&'a Path>,
    /// A folder of records to evaluate and keep ([`super::read_cache`]): a reflector unit's
    /// radiance maps', a probe's or an environment map's capture's, beside its shard. None:
    /// every map and cube is traced and nothing is kept.
    pub reads: Option<&'a Path>,
}

impl Part<'_> {
    /// The whole stage, reading D from the bundle written.
    pub fn whole() -> Part<'static> {
        Part::default()
    }

    /// Whether this is a whole-stage bake.
    pub fn is_whole(&self) -> bool {
        self.item == Item::All && self.d_from.is_none()
    }
}

/// Reads D and its identity ([`crate::bundle::StageRecord::identity`]) from the bundle at
/// `dir`, whatever scene it records; `Ok(None)` when it has no radiosity stage.
pub fn read_d(dir: &Path) -> Result<Option<(RadiosityMap, String)>, MapError> {
    let bundle = Bundle::open(dir)?;
    let Some(identity) = bundle
        .stage(crate::radiosity::current::STAGE)
        .map(|s| s.identity())
    else {
        return Ok(None);
    };
    Ok(RadiosityMap::load(&bundle)?.map(|m| (m, identity)))
}

/// [`read_d`], where a missing radiosity stage is an error naming the bundle.
pub fn require_d(dir: &Path) -> Result<(RadiosityMap, String), MapError> {
    read_d(dir)?.ok_or_else(|| {
        MapError::Bundle(BundleError::Asset {
            path: dir.to_owned(),
            problem: "has no `radiosity` stage: bake the `radiosity` unit into it first".into(),
        })
    })
}
