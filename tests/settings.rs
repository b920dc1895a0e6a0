//! Stage settings: every count has an upper bound with its reason, whether it comes from
//! scene.json or a flag; each setting is one field that the flags, scene.json and the
//! sweep's knobs all name the same.

mod common;

use clap::{CommandFactory, Parser};
use common::*;
use glint::scene::Scene;

fn load_err(bake: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    write_room(dir.path());
    let path = write_scene(
        dir.path(),
        &format!(r#"{{ "version": 1, "geometry": "room.gltf", "bake": {bake} }}"#),
    );
    match Scene::load(&path) {
        Ok(_) => panic!("scene with `bake`: {bake} loaded"),
        Err(e) => e.to_string(),
    }
}

/// Issue 48, item 8: `bounces` had no upper limit (4·10⁹ bounces would run for years), nor
/// had the other counts of the radiosity stage.
#[test]
fn scene_json_refuses_every_unbounded_radiosity_count_with_its_reason() {
    for field in [
        "bounces",
        "rays",
        "light_samples",
        "min_chart_texels",
        "min_scene_texels",
        "cache_budget_mib",
        "max_elements",
    ] {
        let e = load_err(&format!(
            r#"{{ "radiosity": {{ "{field}": 4000000000 }} }}"#
        ));
        assert!(
            e.contains("scene.json") && e.contains(&format!("bake.radiosity.{field}")),
            "{field}: {e}"
        );
        assert!(
            e.contains("4000000000 is more than") && e.contains(" ("),
            "{field}: the bound and its reason: {e}"
        );
    }
    // The presets' own values, and a fixed count of bounces, are accepted.
    let dir = tempfile::tempdir().unwrap();
    write_room(dir.path());
    let path = write_scene(
        dir.path(),
        r#"{ "version": 1, "geometry": "room.gltf",
             "bake": { "radiosity": { "bounces": 256, "tolerance": 0 } } }"#,
    );
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
}

/// `glint-radiosity`'s flags: the radiosity override struct flattened, as the binary does.
#[derive(Parser)]
struct RadiosityFlags {
    #[command(flatten)]
    radiosity: glint::settings::radiosity::RadiosityOverride,
}

/// `glint-srdm`'s flags.
#[derive(Parser)]
struct SrdmFlags {
    #[command(flatten)]
    srdm: glint::settings::srdm::SrdmOverride,
}

/// The long flags of a command, as written in scene.json (`--texel-density` →
/// `texel_density`).
fn flags_as_fields(cmd: clap::Command) -> Vec<String> {
    cmd.get_arguments()
        .filter_map(|a| a.get_long())
        .filter(|l| *l != "help")
        .map(|l| l.replace('-', "_"))
        .collect()
}

#[test]
fn each_setting_is_one_flag_one_scene_field_and_one_knob() {
    use glint::settings::field_names;
    use glint::settings::radiosity::{RadiosityOverride, RadiositySettings};
    use glint::settings::srdm::{SrdmOverride, SrdmSettings};
    let radiosity = field_names::<RadiosityOverride>();
    assert_eq!(radiosity.len(), 14, "{radiosity:?}");
    assert_eq!(flags_as_fields(RadiosityFlags::command()), radiosity);
    assert_eq!(field_names::<RadiositySettings>(), radiosity);
    let srdm = field_names::<SrdmOverride>();
    assert_eq!(flags_as_fields(SrdmFlags::command()), srdm);
    assert_eq!(field_names::<SrdmSettings>(), srdm);
    // Every settings field is a sweep knob, and `--help` lists them.
    let knobs = glint::eval::sweep::valid_knobs();
    let help = glint::eval::sweep::knobs_help();
    for field in &radiosity {
        assert!(knobs.contains(&format!("radiosity.{field}")), "{field}");
        assert!(help.contains(field.as_str()), "{field}");
    }
    assert!(knobs.contains(&"radiance.resolution_scale".to_string()));
    assert!(knobs.contains(&"materials.xi0".to_string()));
    assert!(knobs.contains(&"srdm.points".to_string()));
}

#[test]
fn a_flag_beyond_its_bound_is_refused_before_parsing_the_scene_further() {
    let flags = RadiosityFlags::try_parse_from(["glint-radiosity", "--bounces", "4000000000"])
        .unwrap()
        .radiosity;
    let e = glint::settings::radiosity::RadiositySettings::resolve(
        glint::settings::Quality::Draft,
        &[&flags],
        None,
    )
    .unwrap_err();
    assert_eq!(e.flag(), "--bounces");
    assert!(e.message.contains("is more than 256 ("), "{e}");
}
