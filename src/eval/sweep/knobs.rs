//! The knob grammar of a sweep: `STAGE.FIELD=V1,V2,...`, every value checked against its
//! setting when parsed, and the point (bake settings and view) each value gives.

use serde::Serialize;

use super::SweepError;
use crate::bake::{BakeSettings, Stage};
use crate::settings::materials::MaterialsSettings;
use crate::settings::radiance::RadianceStageOverride;
use crate::settings::radiosity::RadiositySettings;
use crate::settings::srdm::SrdmSettings;
use crate::settings::{Quality, field_names};
use crate::view::options::{CurvedMode, ReflectionMode, Selection, ViewOptions};

/// Whether this build has the headless viewer (frame times, `view.*` knobs).
pub const VIEWER_BUILT: bool = cfg!(feature = "view");

/// The viewer's knobs (not a stage's settings), each with example values.
const VIEW_KNOBS: [(&str, &str); 8] = [
    ("reflections", "off,geometry,image"),
    ("maps", "1,2,4"),
    ("selection", "angle,distance"),
    ("recursion_depth", "0,1,2"),
    ("curved", "off,cubemap"),
    ("glossy_samples", "0,4,16"),
    ("impostors", "off,on"),
    ("terminal_cubemaps", "off,on"),
];

/// Each stage's knobs: the fields of the settings struct a sweep changes (the resolved
/// settings; for the radiance stage, scene.json's `bake.radiance`), in stage order.
fn stage_knobs() -> [(&'static str, Vec<String>); 4] {
    [
        ("radiosity", field_names::<RadiositySettings>()),
        ("materials", field_names::<MaterialsSettings>()),
        ("radiance", field_names::<RadianceStageOverride>()),
        ("srdm", field_names::<SrdmSettings>()),
    ]
}

/// Every knob name a sweep accepts, `STAGE.FIELD`, in stage order.
pub fn valid_knobs() -> Vec<String> {
    let stages = stage_knobs()
        .into_iter()
        .flat_map(|(stage, fields)| fields.into_iter().map(move |f| format!("{stage}.{f}")));
    let view = VIEW_KNOBS.iter().map(|(f, _)| format!("view.{f}"));
    stages.chain(view).collect()
}

/// The knobs as `glint-eval sweep --help` lists them: one line per stage, then the viewer's
/// with example values.
pub fn knobs_help() -> String {
    let mut out = String::from("Knobs (STAGE.FIELD):\n");
    for (stage, fields) in stage_knobs() {
        out += &format!("  {stage}.{}\n", fields.join("|"));
    }
    let view: Vec<String> = VIEW_KNOBS
        .iter()
        .map(|(f, v)| format!("view.{f}={v}"))
        .collect();
    for line in view.chunks(4) {
        out += &format!("  {}\n", line.join("  "));
    }
    out
}

fn json<T: Serialize>(v: &T) -> serde_json::Value {
    serde_json::to_value(v).expect("settings serialize")
}

/// One knob and the values it takes: `STAGE.FIELD=V1,V2,...`.
#[derive(Clone, Debug, PartialEq)]
pub struct Knob {
    /// Stage name (`radiosity`, `materials`, `radiance`, `srdm`) or `view`.
    pub stage: String,
    /// Settings field.
    pub field: String,
    /// Values, in the order given.
    pub values: Vec<serde_json::Value>,
}

impl Knob {
    /// `STAGE.FIELD`.
    pub fn name(&self) -> String {
        format!("{}.{}", self.stage, self.field)
    }

    /// The bake stage it changes (`None` for viewer knobs).
    pub fn bake_stage(&self) -> Option<Stage> {
        Some(match self.stage.as_str() {
            "radiosity" => Stage::Radiosity,
            "materials" => Stage::Materials,
            "radiance" => Stage::Radiance,
            "srdm" => Stage::Srdm,
            _ => return None,
        })
    }
}

/// Parses `STAGE.FIELD=V1,V2,...`: each value becomes a JSON number (or string) and is
/// checked now against the setting, so a typo fails before hours of baking. An unknown name
/// is an error listing every valid knob.
pub fn parse_knob(text: &str) -> Result<Knob, SweepError> {
    let err = |m: String| SweepError::Knob(text.to_string(), m);
    let (key, values) = text
        .split_once('=')
        .ok_or_else(|| err("expected STAGE.FIELD=V1,V2,...".into()))?;
    let valid = valid_knobs();
    let key = key.trim();
    if !valid.iter().any(|k| k == key) {
        return Err(err(format!(
            "unknown knob `{key}`; valid knobs: {}",
            valid.join(", ")
        )));
    }
    let (stage, field) = key.split_once('.').expect("valid knobs are STAGE.FIELD");
    let values = values
        .split(',')
        .map(|v| {
            let v = v.trim();
            serde_json::from_str::<serde_json::Value>(v)
                .unwrap_or_else(|_| serde_json::Value::String(v.to_string()))
        })
        .collect::<Vec<_>>();
    if values.iter().any(|v| v.as_str() == Some("")) {
        return Err(err("empty value".into()));
    }
    let knob = Knob {
        stage: stage.into(),
        field: field.into(),
        values,
    };
    let base = Point {
        bake: BakeSettings {
            quality: Quality::Draft,
            radiosity: RadiositySettings::preset(Quality::Draft),
            materials: MaterialsSettings::preset(Quality::Draft),
            srdm: SrdmSettings::preset(Quality::Draft),
        },
        radiance_scale: None,
        view: ViewOptions::default(),
    };
    for v in &knob.values {
        base.with(&knob, v, None)?;
    }
    Ok(knob)
}

/// Whether the sweep's view shows glossy reflections somewhere (then the reference must be
/// the full glossy scene, not the diffuse one a radiosity bake represents).
pub fn shows_reflections(base: &ViewOptions, knobs: &[Knob]) -> bool {
    base.shows_reflections()
        || knobs.iter().any(|k| {
            ["view.reflections", "view.curved", "view.impostors"].contains(&k.name().as_str())
        })
}

/// One point of a sweep: every stage's settings and the view.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Point {
    pub(super) bake: BakeSettings,
    /// `bake.radiance.resolution_scale` (`None`: the scene's).
    pub(super) radiance_scale: Option<f32>,
    pub(super) view: ViewOptions,
}

impl Point {
    /// This point with `knob` set to `value`, every value range-checked.
    /// This point with `knob` set to `value`, checked by the settings' own `check` (with the
    /// scene's size, when known, for the radiosity density).
    pub(super) fn with(
        &self,
        knob: &Knob,
        value: &serde_json::Value,
        scene_size: Option<f32>,
    ) -> Result<Point, SweepError> {
        let err = |m: String| SweepError::Knob(format!("{}={value}", knob.name()), m);
        let mut p = self.clone();
        let number = || {
            value
                .as_f64()
                .filter(|v| v.is_finite())
                .ok_or_else(|| err("expected a number".into()))
        };
        // A whole number ≥ 0; anything else becomes u32::MAX, which the setting's own check
        // refuses (its message then quotes the value as given).
        let integer = |v: f64| -> u32 {
            if v.fract() == 0.0 && (0.0..=u32::MAX as f64).contains(&v) {
                v as u32
            } else {
                u32::MAX
            }
        };
        let word = |choices: &[&str]| -> Result<String, SweepError> {
            match value.as_str() {
                Some(s) if choices.contains(&s) => Ok(s.to_string()),
                _ => Err(err(format!("expected one of {}", choices.join(", ")))),
            }
        };
        match knob.stage.as_str() {
            "radiosity" => {
                p.bake.radiosity = set_field(&p.bake.radiosity, &knob.field, value).map_err(err)?;
                p.bake
                    .radiosity
                    .check(scene_size)
                    .map_err(|e| err(e.message))?;
            }
            "materials" => {
                p.bake.materials = set_field(&p.bake.materials, &knob.field, value).map_err(err)?;
                p.bake.materials.check().map_err(|e| err(e.message))?;
            }
            "srdm" => {
                p.bake.srdm = set_field(&p.bake.srdm, &knob.field, value).map_err(err)?;
                p.bake.srdm.check().map_err(|e| err(e.message))?;
            }
            "radiance" => {
                let v = number()? as f32;
                let over = RadianceStageOverride {
                    resolution_scale: Some(v),
                };
                over.check().map_err(|e| err(e.message))?;
                p.radiance_scale = Some(v);
            }
            "view" => {
                if !VIEWER_BUILT {
                    return Err(err(
                        "view knobs need the headless viewer: this glint-eval was built \
                         without the `view` feature"
                            .into(),
                    ));
                }
                match knob.field.as_str() {
                    "reflections" => {
                        p.view.reflections =
                            parse_word::<ReflectionMode>(word(&["off", "geometry", "image"])?)
                    }
                    "selection" => {
                        p.view.selection = parse_word::<Selection>(word(&["angle", "distance"])?)
                    }
                    "recursion_depth" => {
                        p.view.recursion.depth = u8::try_from(integer(number()?)).unwrap_or(u8::MAX)
                    }
                    "curved" => {
                        p.view.curved = parse_word::<CurvedMode>(word(&["off", "cubemap"])?)
                    }
                    "impostors" => p.view.impostors = word(&["off", "on"])? == "on",
                    "terminal_cubemaps" => {
                        p.view.recursion.terminal = word(&["off", "on"])? == "on"
                    }
                    "glossy_samples" => p.view.curved_settings.glossy_samples = integer(number()?),
                    _ => p.view.maps = integer(number()?) as usize,
                }
                // The viewer's own check; its message's first word names the option, which
                // the knob already names: quote the value as given instead.
                p.view.check().map_err(|m| match m.split_once(" is ") {
                    Some((_, rest)) => err(format!("{value} is {rest}")),
                    None => err(m),
                })?;
            }
            other => unreachable!("parse_knob admits no stage `{other}`"),
        }
        Ok(p)
    }
}

/// A word `word` admitted (one of the mode's names) as the mode.
fn parse_word<T: std::str::FromStr<Err = String>>(word: String) -> T {
    word.parse()
        .unwrap_or_else(|e| unreachable!("a checked word parses: {e}"))
}

/// `base` with `field` set to `value`, through its JSON form (so names and types are the
/// struct's own).
fn set_field<T: Serialize + serde::de::DeserializeOwned>(
    base: &T,
    field: &str,
    value: &serde_json::Value,
) -> Result<T, String> {
    let mut v = json(base);
    v.as_object_mut()
        .expect("settings are objects")
        .insert(field.to_string(), value.clone());
    serde_json::from_value(v).map_err(|e| e.to_string())
}
