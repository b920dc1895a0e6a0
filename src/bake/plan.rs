//! Which stages a scene requires, and why: glint bakes only what a scene needs.

use serde::Serialize;

use crate::scene::{ReflectorKind, Scene};

/// A bake stage, in dependency order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Stage {
    /// The scene itself (scene.json and geometry), so a bundle is self-contained.
    Scene,
    /// Radiosity textures (D).
    Radiosity,
    /// Kernel and reflectance textures, sample patterns, environment maps.
    Materials,
    /// Radiance maps with depth for planar reflectors (M).
    Radiance,
    /// Depth-map impostors and SRDM tables.
    Srdm,
}

impl Stage {
    /// Every stage, in the order they must run.
    pub const ALL: [Stage; 5] = [
        Stage::Scene,
        Stage::Radiosity,
        Stage::Materials,
        Stage::Radiance,
        Stage::Srdm,
    ];

    /// The stage's folder and manifest key.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Scene => "scene",
            Stage::Radiosity => "radiosity",
            Stage::Materials => "materials",
            Stage::Radiance => "radiance",
            Stage::Srdm => "srdm",
        }
    }
}

/// Whether a scene needs a stage, with the reason in one line.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StagePlan {
    /// The stage.
    pub stage: Stage,
    /// Whether the scene requires it.
    pub needed: bool,
    /// Why (or why not), naming the materials, reflectors or objects concerned.
    pub reason: String,
}

/// The stages `scene` requires, in dependency order.
pub fn plan(scene: &Scene) -> Vec<StagePlan> {
    let used = |m: u32| scene.triangles.iter().any(|t| t.material == m);
    let glossy: Vec<&str> = scene
        .materials
        .iter()
        .enumerate()
        .filter(|(i, m)| m.is_glossy() && used(*i as u32))
        .map(|(_, m)| m.name.as_str())
        .collect();
    let glossy_planar: Vec<&str> = scene
        .reflectors
        .iter()
        .filter(|r| {
            r.kind == ReflectorKind::Planar && scene.materials[r.material as usize].is_glossy()
        })
        .map(|r| r.name.as_str())
        .collect();
    let impostors: Vec<&str> = scene.impostors.iter().map(|i| i.name.as_str()).collect();
    let list = |v: &[&str]| v.join(", ");
    Stage::ALL
        .iter()
        .map(|&stage| {
            let (needed, reason) = match stage {
                Stage::Scene => (true, "every bundle carries the scene it was baked from".to_string()),
                Stage::Radiosity if scene.has_emitters() => (true, "every lit scene needs its diffuse light D".into()),
                Stage::Radiosity => (false, "the scene has no emitters (no area lights, no emissive material): it would be black".into()),
                Stage::Materials if glossy.is_empty() => (false, "no material in use has a glossy lobe".into()),
                Stage::Materials => (true, format!("glossy materials: {}", list(&glossy))),
                Stage::Radiance if glossy_planar.is_empty() => (false, "no planar reflector has a glossy material".into()),
                Stage::Radiance => (true, format!("glossy planar reflectors: {}", list(&glossy_planar))),
                Stage::Srdm if impostors.is_empty() => (false, "no impostor objects declared".into()),
                Stage::Srdm => (true, format!("impostor objects: {}", list(&impostors))),
            };
            StagePlan { stage, needed, reason }
        })
        .collect()
}

/// A reflector or impostor scene.json declares that the bake leaves out or that nothing
/// shows, and why: glint-bake warns of each rather than skip it without a word.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Unused {
    /// Its entry in scene.json, e.g. `reflectors[3]`.
    pub field: String,
    /// Its name.
    pub name: String,
    /// What the bake does with it, why, and what to change.
    pub reason: String,
}

impl std::fmt::Display for Unused {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} ({}): {}", self.field, self.name, self.reason)
    }
}

/// Every declared reflector the bake skips and every impostor no reflector shows.
pub fn unused_declarations(scene: &Scene) -> Vec<Unused> {
    let glossy = |m: u32| scene.materials[m as usize].is_glossy();
    let mut out = Vec::new();
    for r in &scene.reflectors {
        let material = &scene.materials[r.material as usize].name;
        let (kind, maps) = match r.kind {
            ReflectorKind::Planar => ("planar", "radiance maps"),
            ReflectorKind::Curved => ("curved", "environment map"),
        };
        let reason = if !glossy(r.material) {
            format!(
                "skipped, no {maps}: its material {material:?} has no glossy lobe, so it is drawn diffuse (give {material:?} `lobes` in scene.json's `materials`, or remove the reflector)"
            )
        } else if r.kind == ReflectorKind::Curved && !scene.has_emitters() {
            "skipped, no environment map: the scene has no emitters, so no radiosity (D) lights it"
                .to_string()
        } else {
            continue;
        };
        out.push(Unused {
            field: format!("reflectors[{}]", r.index),
            name: r.name.clone(),
            reason: format!("{kind} reflector {reason}"),
        });
    }
    if !scene.reflectors.iter().any(|r| glossy(r.material)) {
        for (i, imp) in scene.impostors.iter().enumerate() {
            out.push(Unused {
                field: format!("impostors[{i}]"),
                name: imp.name.clone(),
                reason: "baked, but never drawn: impostors are drawn in reflections, and no reflector has a glossy material".into(),
            });
        }
    }
    out
}
