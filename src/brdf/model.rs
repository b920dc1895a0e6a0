//! Which reflection model a glossy lobe uses: scene.json's `model` of a lobe (the scene layer
//! re-exports it), defined here with the models so that `brdf` imports nothing above it.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// The reflection model of a glossy lobe.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum LobeModel {
    /// Kurt et al. 2010 as the regular-sampling paper writes it (Luksch et al. Eq. 2):
    /// Beckmann D, shadowing exponent `alpha`, Schlick F. Named in scene.json when wanted.
    Kurt,
    /// The glTF 2.0 specular lobe (specification Appendix B): GGX D with α = `mx`, `my`,
    /// height-correlated Smith G, Schlick F. glTF materials map to it; scene.json's default.
    #[default]
    Ggx,
    /// Cook–Torrance with Beckmann D (m = `mx`, `my`), Smith G and Schlick F.
    Beckmann,
}

/// Read by hand so that a wrong name is an error naming the field and every choice.
impl<'de> Deserialize<'de> for LobeModel {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<LobeModel, D::Error> {
        let name = String::deserialize(d)?;
        LobeModel::ALL
            .into_iter()
            .find(|m| m.name() == name)
            .ok_or_else(|| {
                serde::de::Error::custom(format!(
                    "lobe `model` {name:?} is unknown: expected one of `kurt`, `ggx`, `beckmann`"
                ))
            })
    }
}

impl LobeModel {
    /// Every model.
    pub const ALL: [LobeModel; 3] = [LobeModel::Kurt, LobeModel::Ggx, LobeModel::Beckmann];

    /// Whether this is `kurt`, the model the bundle's materials index leaves out (its format
    /// predates the other models, so an absent `model` there means `kurt`).
    pub fn is_kurt(&self) -> bool {
        *self == LobeModel::Kurt
    }

    /// Whether this is scene.json's default model (`ggx`, glTF's lobe): scene.json leaves it
    /// out.
    pub fn is_ggx(&self) -> bool {
        *self == LobeModel::Ggx
    }

    /// The name scene.json uses.
    pub fn name(self) -> &'static str {
        match self {
            LobeModel::Kurt => "kurt",
            LobeModel::Ggx => "ggx",
            LobeModel::Beckmann => "beckmann",
        }
    }
}
