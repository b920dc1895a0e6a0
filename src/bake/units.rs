//! Work units: a bake split into pieces that an existing job engine runs (a Slurm job array,
//! a Kubernetes Indexed Job, GNU parallel), each baking one item of one stage into its own
//! shard bundle; `glint-bundle merge` assembles the shards ([`super::merge`]).
//!
//! A unit's ID is `KIND[.NAME]`, file-name safe, so a shard is `ID.glint`:
//! - `scene`: the scene stage;
//! - `gather.K`: the first gathering batch of the radiosity elements' K-th run (of N, chosen
//!   from the cost: [`gather_units`]); elements are in atlas order, so a run is a range of
//!   charts on a range of pages. Its shard holds a `gather` stage that only the `radiosity`
//!   unit reads;
//! - `radiosity`: the radiosity stage from the gathering units' batches: the bounces, and
//!   the refinement rounds a target error asks for;
//! - `material.FOLDER`: one glossy material's lobes (kernel, reflectance, pattern);
//! - `probe.FOLDER`: one reflection probe's prefiltered cube map (reads D);
//! - `envmap.FOLDER`: one glossy curved reflector's environment map (reads D);
//! - `radiance.FOLDER`: one glossy planar reflector's radiance maps (reads D);
//! - `srdm.FOLDER`: one impostor's captures and SRDM tables (reads D when the scene has it).
//!
//! FOLDER is the item's folder in its stage. Each unit names its inputs by content hash
//! (geometry, the materials, lights, settings… that its output is a function of); its `key`
//! hashes those with the keys of the units it reads, so a unit whose key is unchanged is up
//! to date, whatever else in the scene changed. Units of `wave` 0 read no other unit; the
//! `radiosity` unit (wave 1) reads the gathering units' shards; the units of wave 2 read D,
//! the `radiosity` unit's shard.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::materials::{self, curved_glossy_reflectors, recorded_settings};
use super::part::Item;
use super::{BakeSettings, Stage, plan, radiance_stage, radiosity_stage, srdm_stage};
use crate::scene::Scene;

/// `format` of a plan.
pub const PLAN_FORMAT: &str = "glint-units";
/// Version of the plan format.
pub const PLAN_VERSION: u32 = 1;

/// What a scene's bake splits into.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct UnitPlan {
    /// Always `glint-units`.
    pub format: String,
    /// Plan format version, 1.
    pub version: u32,
    /// The scene's name.
    pub scene_name: String,
    /// The scene's content hash (scene.json, glTF, buffers).
    pub scene_hash: String,
    /// The quality preset.
    pub quality: String,
    /// The glint that made the plan.
    pub generator: String,
    /// BLAKE3 over every unit's ID and key: shards of one plan carry the same.
    pub plan_hash: String,
    /// Per stage, the settings the assembled stage records, without `d_source` (the merge
    /// adds the identity of the D it assembles).
    pub stages: BTreeMap<String, serde_json::Value>,
    /// The units, in the order the merge assembles them (stage order, then item order).
    pub units: Vec<Unit>,
}

/// One work unit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Unit {
    /// `KIND[.NAME]`, file-name safe.
    pub id: String,
    /// The stage the unit bakes part (or all) of.
    pub stage: String,
    /// The scene's name of the item (material, reflector, impostor); none for whole stages.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub item: Option<String>,
    /// Named inputs, each a BLAKE3 (hex) of what the unit reads.
    pub inputs: BTreeMap<String, String>,
    /// IDs of the units whose shards it reads.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub depends_on: Vec<String>,
    /// BLAKE3 over the inputs and the keys of `depends_on`: same key, same output.
    pub key: String,
    /// Estimated work, in ray casts (or the equivalent evaluations): for scheduling.
    pub cost: f64,
    /// 0: reads no unit; otherwise one more than the highest wave among the units it reads.
    pub wave: u32,
}

impl UnitPlan {
    /// The unit with `id`.
    pub fn unit(&self, id: &str) -> Option<&Unit> {
        self.units.iter().find(|u| u.id == id)
    }

    /// The units of `wave`, in plan order.
    pub fn wave(&self, wave: u32) -> impl Iterator<Item = &Unit> {
        self.units.iter().filter(move |u| u.wave == wave)
    }

    /// The stage item a unit bakes.
    pub fn item(&self, unit: &Unit) -> Item {
        let k = self
            .units
            .iter()
            .filter(|u| u.stage == unit.stage && kind(&u.id) == kind(&unit.id))
            .position(|u| u.id == unit.id)
            .unwrap_or(0);
        match kind(&unit.id) {
            "material" => Item::Material(k),
            "envmap" => Item::EnvMap(k),
            "probe" => Item::Probe(k),
            "radiance" => Item::Reflector(k),
            "srdm" => Item::Impostor(k),
            _ => Item::All,
        }
    }

    /// For a gathering unit, its run: (K, N) of [`crate::bake::radiosity_stage::gather_range`].
    pub fn gather_part(&self, unit: &Unit) -> Option<(usize, usize)> {
        if kind(&unit.id) != GATHER {
            return None;
        }
        let gathers: Vec<&Unit> = self
            .units
            .iter()
            .filter(|u| kind(&u.id) == GATHER)
            .collect();
        let k = gathers.iter().position(|u| u.id == unit.id)?;
        Some((k, gathers.len()))
    }
}

/// Kind (and stage name in its shard) of the gathering units.
pub const GATHER: &str = "gather";

/// Estimated ray casts one gathering unit is given (some tens of seconds on one core).
pub const GATHER_UNIT_COST: f64 = 3.2e7;

/// Most gathering units of a plan.
pub const MAX_GATHER_UNITS: usize = 4096;

/// How many gathering units share radiosity work of `cost` ray casts: one per
/// [`GATHER_UNIT_COST`], at least two (so that every plan splits its gathering, and the
/// `radiosity` unit only bounces and refines), at most [`MAX_GATHER_UNITS`].
pub fn gather_units(cost: f64) -> usize {
    ((cost / GATHER_UNIT_COST).ceil() as usize).clamp(2, MAX_GATHER_UNITS)
}

/// The kind of a unit ID: what precedes its first `.`.
pub fn kind(id: &str) -> &str {
    id.split_once('.').map_or(id, |(k, _)| k)
}

/// BLAKE3 (hex) of a value's JSON.
fn hash_json(v: &impl Serialize) -> String {
    let bytes = serde_json::to_vec(v).expect("plan inputs serialize");
    blake3::hash(&bytes).to_hex().to_string()
}

fn hash_str(s: &str) -> String {
    blake3::hash(s.as_bytes()).to_hex().to_string()
}

/// A unit before its key is computed.
struct Draft {
    id: String,
    stage: &'static str,
    item: Option<String>,
    inputs: Vec<(&'static str, String)>,
    /// The units whose shards it reads (planned before it).
    reads: Vec<String>,
    cost: f64,
}

/// The work units of `scene` baked with `settings`: one per stage item the whole bake
/// (`glint-bake`) would write, with the same stages skipped. Two items whose folders clash
/// are refused (the whole bake refuses them too).
pub fn plan_units(scene: &Scene, settings: &BakeSettings) -> Result<UnitPlan, String> {
    let needed = |s: Stage| plan(scene).iter().any(|p| p.stage == s && p.needed);
    let generator = hash_str(&crate::bundle::manifest::generator());
    let geometry = scene.geometry_hash.clone();
    let all_materials = hash_json(&scene.materials);
    let has_d = needed(Stage::Radiosity);
    let reads_d = |reads: bool| {
        if reads && has_d {
            vec!["radiosity".to_string()]
        } else {
            Vec::new()
        }
    };
    let mut drafts = vec![Draft {
        id: "scene".into(),
        stage: Stage::Scene.name(),
        item: None,
        inputs: vec![("scene_files", scene.content_hash.clone())],
        reads: Vec::new(),
        cost: 1.0,
    }];
    let mut stages = BTreeMap::from([("scene".to_string(), serde_json::json!({}))]);

    if has_d {
        let s = &settings.radiosity;
        // Mirror lights read the reflectors (not their radiance-map overrides).
        let reflectors: Vec<_> = scene
            .desc
            .reflectors
            .iter()
            .map(|r| {
                let mut r = r.clone();
                r.radiance = None;
                r
            })
            .collect();
        // A scene `max_elements` refuses fails in its units; its cost is estimated as asked.
        let texels = match radiosity_stage::density_rule(scene, s) {
            Ok(density) => density.texels(),
            Err(_) => crate::radiosity::atlas::estimate_texels(
                &scene.triangles,
                radiosity_stage::base_rule(s, scene.bounds.longest_side()),
            ),
        } * radiosity_stage::contact_texel_factor(s);
        let recorded = radiosity_stage::settings_json(s);
        let inputs = vec![
            ("geometry", geometry.clone()),
            ("materials", all_materials.clone()),
            ("lights", hash_json(&scene.desc.lights)),
            ("reflectors", hash_json(&reflectors)),
            ("settings", hash_json(&recorded)),
            ("generator", generator.clone()),
        ];
        let gather_cost = texels * (s.rays + s.light_samples) as f64;
        let n = gather_units(gather_cost);
        let gathers: Vec<String> = (0..n).map(|k| format!("{GATHER}.{k}")).collect();
        for (k, id) in gathers.iter().enumerate() {
            let mut inputs = inputs.clone();
            inputs.push(("part", hash_str(&format!("{k}/{n}"))));
            drafts.push(Draft {
                id: id.clone(),
                stage: GATHER,
                item: None,
                inputs,
                reads: Vec::new(),
                cost: (gather_cost / n as f64).ceil(),
            });
        }
        drafts.push(Draft {
            id: "radiosity".into(),
            stage: Stage::Radiosity.name(),
            item: None,
            inputs,
            reads: gathers,
            // Each bounce reads every cached hit once, about a hundredth of a ray cast.
            cost: texels * s.rays as f64 * s.bounces.max(1) as f64 / 100.0,
        });
        stages.insert("radiosity".into(), recorded);
    }

    if needed(Stage::Materials) {
        let s = &settings.materials;
        let chosen = materials::chosen_materials(scene);
        let folders =
            crate::bundle::unique_folders(chosen.iter().map(|&i| scene.materials[i].name.as_str()));
        let settings_hash = hash_json(s);
        for (&m, folder) in chosen.iter().zip(&folders) {
            let mat = &scene.materials[m];
            let per_lobe =
                (s.sphere_map_size as f64).powi(2) * s.albedo_steps as f64 + s.sample_budget as f64;
            drafts.push(Draft {
                id: format!("material.{folder}"),
                stage: Stage::Materials.name(),
                item: Some(mat.name.clone()),
                inputs: vec![
                    ("material", hash_json(mat)),
                    ("folder", hash_str(folder)),
                    ("settings", settings_hash.clone()),
                    ("generator", generator.clone()),
                ],
                reads: Vec::new(),
                cost: per_lobe * mat.lobes.len() as f64,
            });
        }
        if has_d {
            // A probe's capture reads every triangle and material, and its place comes from
            // the glossy groups and scene.json's `probes`.
            let probes = crate::materials::probes::scene_probes(scene);
            for (p, folder) in probes.iter().zip(materials::probe_folders(scene)) {
                drafts.push(Draft {
                    id: format!("probe.{folder}"),
                    stage: Stage::Materials.name(),
                    item: Some(p.name.clone()),
                    inputs: vec![
                        ("geometry", geometry.clone()),
                        ("materials", all_materials.clone()),
                        (
                            "probe",
                            hash_json(&(p.position.to_array(), p.radius.to_bits())),
                        ),
                        ("folder", hash_str(&folder)),
                        ("settings", settings_hash.clone()),
                        ("generator", generator.clone()),
                    ],
                    reads: reads_d(true),
                    cost: 6.0 * (s.env_map_size as f64 * s.env_supersample as f64).powi(2),
                });
            }
            let curved = curved_glossy_reflectors(scene);
            let env_folders = crate::bundle::unique_folders(
                curved.iter().map(|&r| scene.reflectors[r].name.as_str()),
            );
            for (&r, folder) in curved.iter().zip(&env_folders) {
                let refl = &scene.reflectors[r];
                drafts.push(Draft {
                    id: format!("envmap.{folder}"),
                    stage: Stage::Materials.name(),
                    item: Some(refl.name.clone()),
                    inputs: vec![
                        ("geometry", geometry.clone()),
                        ("materials", all_materials.clone()),
                        ("reflector", hash_json(&scene.desc.reflectors[refl.index])),
                        ("folder", hash_str(folder)),
                        ("settings", settings_hash.clone()),
                        ("generator", generator.clone()),
                    ],
                    reads: reads_d(true),
                    cost: 6.0 * (s.env_map_size as f64 * s.env_supersample as f64).powi(2),
                });
            }
        }
        stages.insert("materials".into(), recorded_settings(s, None));
    }

    if needed(Stage::Radiance) {
        let quadtree = hash_json(&radiance_stage::quadtree_limits(scene));
        for (ri, _, p) in radiance_stage::plans(scene, settings.quality) {
            let refl = &scene.reflectors[ri];
            drafts.push(Draft {
                id: format!(
                    "radiance.{}",
                    crate::radiance::index::reflector_folder(&refl.name)
                ),
                stage: Stage::Radiance.name(),
                item: Some(refl.name.clone()),
                inputs: vec![
                    ("geometry", geometry.clone()),
                    ("reflector", hash_json(&scene.desc.reflectors[refl.index])),
                    (
                        "material",
                        hash_json(&scene.materials[refl.material as usize]),
                    ),
                    ("plan", hash_json(&p)),
                    ("quadtree", quadtree.clone()),
                    ("generator", generator.clone()),
                ],
                reads: reads_d(true),
                cost: (p.elements[0] * p.elements[1] * p.cameras) as f64
                    * (p.resolution as f64).powi(2),
            });
        }
        stages.insert(
            "radiance".into(),
            radiance_stage::settings_json(scene, settings.quality, None),
        );
    }

    if needed(Stage::Srdm) {
        let s = &settings.srdm;
        // The views face the scene's first camera keyframe; without D, captures show albedo.
        let first_key = scene
            .camera_paths
            .first()
            .and_then(|p| p.keyframes.first())
            .map(|k| k.position);
        let folders = srdm_stage::impostor_folders(scene);
        for ((imp, desc), folder) in scene
            .impostors
            .iter()
            .zip(&scene.desc.impostors)
            .zip(&folders)
        {
            let mut inputs = vec![
                ("geometry", geometry.clone()),
                ("impostor", hash_json(desc)),
                ("folder", hash_str(folder)),
                ("first_camera", hash_json(&first_key)),
                ("settings", hash_json(s)),
                ("generator", generator.clone()),
            ];
            if !has_d {
                inputs.push(("materials", all_materials.clone()));
            }
            drafts.push(Draft {
                id: format!("srdm.{folder}"),
                stage: Stage::Srdm.name(),
                item: Some(imp.name.clone()),
                inputs,
                reads: reads_d(has_d),
                cost: imp.views as f64 * (s.resolution as f64).powi(2),
            });
        }
        let colour = if has_d { "radiosity" } else { "albedo" };
        stages.insert("srdm".into(), srdm_stage::settings_json(s, colour, None));
    }

    let mut units: Vec<Unit> = Vec::new();
    for d in drafts {
        if units.iter().any(|u| u.id == d.id) {
            return Err(format!(
                "{}: two items of stage `{}` share the folder of unit `{}`: rename one",
                scene.path.display(),
                d.stage,
                d.id
            ));
        }
        let mut h = blake3::Hasher::new();
        h.update(d.id.as_bytes());
        for (name, value) in &d.inputs {
            h.update(format!("\n{name}={value}").as_bytes());
        }
        let mut wave = 0;
        for dep in &d.reads {
            let u = units
                .iter()
                .find(|u| u.id == *dep)
                .expect("a unit's inputs are planned before it");
            h.update(format!("\n{dep}:{}", u.key).as_bytes());
            wave = wave.max(u.wave + 1);
        }
        units.push(Unit {
            wave,
            id: d.id,
            stage: d.stage.into(),
            item: d.item,
            inputs: d.inputs.into_iter().map(|(k, v)| (k.into(), v)).collect(),
            depends_on: d.reads,
            key: h.finalize().to_hex().to_string(),
            cost: d.cost.round(),
        });
    }
    let mut h = blake3::Hasher::new();
    for u in &units {
        h.update(format!("{} {}\n", u.id, u.key).as_bytes());
    }
    h.update(hash_json(&stages).as_bytes());
    Ok(UnitPlan {
        format: PLAN_FORMAT.into(),
        version: PLAN_VERSION,
        scene_name: scene.name.clone(),
        scene_hash: scene.content_hash.clone(),
        quality: settings.quality.name().into(),
        generator: crate::bundle::manifest::generator(),
        plan_hash: h.finalize().to_hex().to_string(),
        stages,
        units,
    })
}
