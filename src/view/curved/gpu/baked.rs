//! The materials stage's outputs the curved passes read: a reflector's baked MIP pyramid
//! and the patterns' ξ₀.

use super::super::DEFAULT_XI0;
use crate::materials::MaterialsIndex;
use crate::materials::envmap::MipPyramid;
use crate::view::load::ViewData;

/// Reads the baked MIP pyramid of `reflector` from the bundle's materials stage, if any.
pub fn load_baked_pyramid(data: &ViewData, reflector: &str) -> Result<Option<MipPyramid>, String> {
    MaterialsIndex::load(&data.bundle)
        .and_then(|index| match index {
            Some(index) => index.read_env_pyramid(&data.bundle, reflector),
            None => Ok(None),
        })
        .map_err(|e| e.to_string())
}

/// ξ₀ of the bundle's materials stage (its patterns' threshold), else [`DEFAULT_XI0`].
pub(super) fn baked_xi0(data: &ViewData) -> f32 {
    MaterialsIndex::load(&data.bundle)
        .ok()
        .flatten()
        .map_or(DEFAULT_XI0, |index| index.settings.xi0)
}
