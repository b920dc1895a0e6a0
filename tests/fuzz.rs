//! The short fuzz run of CI: every target's corpus and regression inputs, then a few
//! thousand mutants each (a few seconds per target). The long run is
//! `cargo bench --bench fuzz -- [TARGET] [--execs N]`.

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use glint::fuzz::{RunConfig, Target, TargetContext, driver};

#[global_allocator]
static ALLOC: glint::fuzz::LimitAlloc = glint::fuzz::LimitAlloc;

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Runs `name` briefly; fails with every distinct crash (message and input).
fn short_run(name: &str) {
    let target = glint::fuzz::target(name).unwrap_or_else(|| panic!("no fuzz target {name}"));
    let scratch = tempfile::tempdir().unwrap();
    let ctx = (target.prepare)(repo(), scratch.path()).unwrap();
    let seeds = glint::fuzz::seeds(repo(), target).unwrap();
    // The corpus must hold files the loader accepts, or mutants only explore its errors.
    let accepted = seeds
        .iter()
        .filter(|s| driver::run_one(target, &ctx, s) == Ok(true))
        .count();
    assert!(accepted > 0, "{name}: no seed of the corpus is accepted");
    let config = RunConfig {
        execs: 2000,
        max_time: Duration::from_secs(4),
        input_timeout: Duration::from_secs(20),
        seed: 0x5eed,
    };
    let report = driver::run(target, Arc::new(ctx), &seeds, &config);
    assert!(
        report.crashes.is_empty(),
        "{} crashes:\n{}",
        report.crashes.len(),
        report.describe_crashes()
    );
    assert!(
        report.execs >= seeds.len() as u64,
        "{name}: only {} of the {} seeds ran",
        report.execs,
        seeds.len()
    );
}

macro_rules! targets {
    ($($name:ident),* $(,)?) => {
        $(#[test] fn $name() { short_run(stringify!($name)); })*

        #[test]
        fn every_target_has_a_short_run() {
            let tested = [$(stringify!($name),)* "cameras_json", "materials_index"];
            for t in glint::fuzz::TARGETS {
                assert!(tested.contains(&t.name), "target {} has no test here", t.name);
            }
        }
    };
}

targets!(
    scene_json, gltf, manifest, merge, atlas, qtree, srdm, pattern, exr, srdm_index,
);

#[cfg(feature = "view")]
#[test]
fn cameras_json() {
    short_run("cameras_json");
}

#[cfg(feature = "view")]
#[test]
fn materials_index() {
    short_run("materials_index");
}

/// Releases the hung input of [`faulty`] once the test has seen the hang.
static RELEASE: AtomicBool = AtomicBool::new(false);

/// A target that panics on inputs starting with `P` and hangs on inputs starting with `H`
/// (until [`RELEASE`]).
fn faulty(_: &TargetContext, input: &[u8]) -> Result<(), String> {
    match input.first() {
        Some(b'P') => panic!("planted"),
        Some(b'H') => {
            while !RELEASE.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(10));
            }
            Err("released".into())
        }
        _ => Err("rejected".into()),
    }
}

static FAULTY: Target = Target {
    name: "faulty",
    about: "the harness's own test",
    prepare: |_, s| {
        Ok(TargetContext {
            scratch: s.to_owned(),
            ..Default::default()
        })
    },
    run: faulty,
};

#[test]
fn the_driver_reports_panics_and_hangs_once_each_and_goes_on() {
    let seeds = vec![
        b"P1".to_vec(),
        b"H".to_vec(),
        b"ok".to_vec(),
        b"P2".to_vec(),
    ];
    let ctx = Arc::new(TargetContext::default());
    let config = RunConfig {
        execs: 0,
        max_time: Duration::from_secs(30),
        input_timeout: Duration::from_millis(200),
        seed: 1,
    };
    let report = driver::run(&FAULTY, ctx, &seeds, &config);
    RELEASE.store(true, Ordering::Relaxed);
    assert_eq!(report.execs, 4, "every seed ran, past the hang");
    assert_eq!(report.rejected, 1);
    let mut keys: Vec<&str> = report.crashes.iter().map(|c| c.message.as_str()).collect();
    keys.sort();
    assert_eq!(keys.len(), 2, "{keys:?}");
    assert!(keys[0].starts_with("hang"), "{keys:?}");
    assert!(keys[1].contains("planted"), "{keys:?}");
    let panic = report.crashes.iter().find(|c| c.key != "hang").unwrap();
    assert_eq!(panic.hits, 2, "both P inputs hit the one panic");
    let hang = report.crashes.iter().find(|c| c.key == "hang").unwrap();
    assert_eq!(hang.input, b"H");
}
