//! The edit loop: per kind of edit to a scene (a camera path, one albedo, one glossy
//! roughness, one light's power, a reflector added), what the plain `glint-bake` rebakes
//! ([`glint::bake::incremental`]) and its wall time (scene load included) against a full
//! bake, median of `--runs` runs. Each run starts from a copy of one baked bundle and its unit
//! cache, so no run pays for undoing the last.
//!
//! On glossy-room (the default), the light is the ceiling lamp's emissive material (the scene
//! has no area lights), and the reflector added is TableTop's (the run starts from a bundle
//! of the scene without it). Every glossy material of glossy-room belongs to a reflector, so
//! the `roughness` edit (a material that is no reflector's) is measured on a second scene,
//! stand-in (`--roughness-scene`), whose tiled floor `Tiles` is glossy and no reflector; its
//! row is against that scene's own full bake, printed as a row of its own.
//! `roughness-reflector` edits GlossyTable (TableTop's material) on the main scene.
//!
//! A full bake is also timed once stage by stage (`bake_all`, what the stage tools run) unless
//! `--no-per-stage`.
//!
//! `cargo bench --no-default-features --bench edit_loop [-- [--quality Q] [--runs N]
//! [--only EDIT,…] [--no-per-stage] [--phases] [--roughness-scene SCENE.json] [SCENE.json]]`
//! (edits: noop, camera, albedo, roughness, roughness-reflector, light, reflector). `--phases` prints, for every bake, the seconds of each progress phase
//! (gathering, refining, bouncing, radiance maps…) in order: where an edit's time goes.
//!
//! Each bake's CPU time (user + system, all threads) is given beside its wall time: on a
//! machine shared with other work, the wall time follows the load, the CPU time much less.

#[path = "common/cpu_time.rs"]
mod cpu_time;

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use glint::bake::BakeSettings;
use glint::bake::incremental::{Incremental, bake_incremental, cache_dir};
use glint::bundle::stats::format_table;
use glint::progress::{Progress, Silent};
use glint::scene::{Quality, Scene};
use serde_json::{Value, json};

/// One edit of scene.json.
struct Edit {
    name: &'static str,
    what: &'static str,
    apply: fn(&mut Value),
    /// Applied to the scene of the bundle each run starts from (`reflector`: without it).
    base: Option<fn(&mut Value)>,
    /// Measured on the `--roughness-scene` rather than the main scene.
    second_scene: bool,
}

fn edits() -> Vec<Edit> {
    vec![
        Edit {
            name: "noop",
            what: "nothing changed",
            apply: |_| {},
            base: None,
            second_scene: false,
        },
        Edit {
            name: "camera",
            what: "camera path `walkthrough`: keyframe 2 moved",
            apply: |v| v["camera_paths"][0]["keyframes"][2]["position"] = json!([-2.0, 1.5, 1.2]),
            base: None,
            second_scene: false,
        },
        Edit {
            name: "albedo",
            what: "GlossyFloor albedo",
            apply: |v| v["materials"]["GlossyFloor"]["albedo"] = json!([0.5, 0.4, 0.4]),
            base: None,
            second_scene: false,
        },
        Edit {
            name: "roughness",
            what: "second scene: Tiles (no reflector) GGX α 0.1225 → 0.16",
            // glTF roughness 0.35 → 0.4: the lobe glint maps the glTF material to, α = r².
            apply: |v| {
                v["materials"]["Tiles"] = json!({ "lobes": [{ "ks": [1.0, 1.0, 1.0], "r0": 0.04, "mx": 0.16, "my": 0.16 }] });
            },
            base: None,
            second_scene: true,
        },
        Edit {
            name: "roughness-reflector",
            what: "GlossyTable (TableTop reflector's) roughness 0.15 → 0.2",
            apply: |v| {
                let lobe = &mut v["materials"]["GlossyTable"]["lobes"][0];
                lobe["mx"] = 0.2.into();
                lobe["my"] = 0.2.into();
            },
            base: None,
            second_scene: false,
        },
        Edit {
            name: "light",
            what: "CeilingLight emission ×1.5",
            apply: |v| {
                v["materials"]["CeilingLight"] = json!({ "emission": [30.0, 28.5, 25.5] });
            },
            base: None,
            second_scene: false,
        },
        Edit {
            name: "reflector",
            what: "TableTop planar reflector added",
            apply: |_| {},
            base: Some(|v| {
                v["reflectors"]
                    .as_array_mut()
                    .expect("reflectors")
                    .retain(|r| r["mesh"] != "TableTop")
            }),
            second_scene: false,
        },
    ]
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let dest = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &dest);
        } else {
            std::fs::copy(e.path(), dest).unwrap();
        }
    }
}

fn remove(p: &Path) {
    if p.exists() {
        std::fs::remove_dir_all(p).unwrap();
    }
}

fn write_scene(path: &Path, original: &Value, f: impl FnOnce(&mut Value)) {
    let mut v = original.clone();
    f(&mut v);
    std::fs::write(path, serde_json::to_string_pretty(&v).unwrap()).unwrap();
}

/// Times the progress phases of one bake: each phase lasts until the next begins.
struct Phases {
    /// The bake's start, and the phases begun so far (name, seconds from the start).
    start: Instant,
    begun: Mutex<Vec<(String, f64)>>,
}

impl Phases {
    fn new() -> Phases {
        Phases {
            start: Instant::now(),
            begun: Mutex::new(vec![("until the first phase".into(), 0.0)]),
        }
    }

    /// `phase 1.23 s, phase 4.56 s, …`, the last phase lasting until now.
    fn report(&self) -> String {
        let end = self.start.elapsed().as_secs_f64();
        let begun = self.begun.lock().unwrap();
        let mut parts = Vec::new();
        for (i, (name, at)) in begun.iter().enumerate() {
            let until = begun.get(i + 1).map_or(end, |n| n.1);
            parts.push(format!("{name} {:.2} s", until - at));
        }
        parts.join(", ")
    }
}

impl Progress for Phases {
    fn phase(&self, name: &str, _: u64) {
        let at = self.start.elapsed().as_secs_f64();
        self.begun.lock().unwrap().push((name.into(), at));
    }
    fn advance(&self, _: u64) {}
}

/// A bake's wall and CPU seconds.
#[derive(Clone, Copy)]
struct Took {
    wall: f64,
    cpu: f64,
}

impl Took {
    fn since(start: Instant, cpu: f64) -> Took {
        Took {
            wall: start.elapsed().as_secs_f64(),
            cpu: cpu_time::cpu_seconds() - cpu,
        }
    }
}

/// Loads the scene and bakes it into `bundle` as `glint-bake` does: (time, what it did).
/// With `phases`, prints the seconds of each progress phase.
fn bake(
    scene_json: &Path,
    bundle: &Path,
    quality: Option<Quality>,
    phases: bool,
) -> (Took, Incremental) {
    let timed = Phases::new();
    let progress: &dyn Progress = if phases { &timed } else { &Silent };
    let (start, cpu) = (Instant::now(), cpu_time::cpu_seconds());
    let scene = Scene::load(scene_json).unwrap_or_else(|e| panic!("{e}"));
    let settings = BakeSettings::resolve(&scene, quality.unwrap_or(scene.desc.bake.quality))
        .unwrap_or_else(|e| panic!("{e}"));
    let done = bake_incremental(&scene, bundle, &settings, false, progress)
        .unwrap_or_else(|e| panic!("{e:#}"));
    let t = Took::since(start, cpu);
    if phases {
        eprintln!("  phases: {}", timed.report());
        for u in done.baked() {
            eprintln!("  unit {}: {:.2} s", u.unit, u.seconds);
        }
    }
    (t, done)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Medians of the wall and CPU times.
fn medians(v: &[Took]) -> Took {
    Took {
        wall: median(v.iter().map(|t| t.wall).collect()),
        cpu: median(v.iter().map(|t| t.cpu).collect()),
    }
}

/// Copies `bundle` and its unit cache to `to` (and its cache).
fn copy_bundle(bundle: &Path, to: &Path) {
    remove(to);
    remove(&cache_dir(to));
    copy_dir(bundle, to);
    copy_dir(&cache_dir(bundle), &cache_dir(to));
}

/// A scene copied into the work folder, and its full bakes: the bundle each edit starts from
/// and the median time.
struct Baseline {
    /// The scene's own folder, and its copy's scene.json, which the edits rewrite.
    dir: PathBuf,
    json: PathBuf,
    original: Value,
    base: PathBuf,
    full: Took,
}

/// Copies the scene of `dir` to `work/name` and bakes it `runs` times from scratch, each
/// into a new bundle with an empty cache; the first is every run's start.
fn baseline(
    dir: &Path,
    work: &Path,
    name: &str,
    runs: usize,
    quality: Option<Quality>,
    phases: bool,
) -> Baseline {
    let copy = work.join(name);
    copy_dir(dir, &copy);
    let json = copy.join("scene.json");
    let original: Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let base = work.join(format!("{name}-base.glint"));
    let mut full = Vec::new();
    for r in 0..runs {
        let bundle = if r == 0 {
            base.clone()
        } else {
            work.join(format!("{name}-full{r}.glint"))
        };
        let (t, _) = bake(&json, &bundle, quality, phases);
        eprintln!(
            "{name}: full bake {}: {:.2} s, CPU {:.2} s",
            r + 1,
            t.wall,
            t.cpu
        );
        full.push(t);
        if r > 0 {
            remove(&bundle);
            remove(&cache_dir(&bundle));
        }
    }
    Baseline {
        dir: dir.to_owned(),
        json,
        original,
        base,
        full: medians(&full),
    }
}

/// A row's wall and CPU columns: seconds and share of `full`.
fn of_full(t: Took, full: Took) -> [String; 4] {
    [
        format!("{:.2}", t.wall),
        format!("{:.1}%", 100.0 * t.wall / full.wall),
        format!("{:.2}", t.cpu),
        format!("{:.1}%", 100.0 * t.cpu / full.cpu),
    ]
}

fn main() {
    let mut args = std::env::args().skip(1).filter(|a| a != "--bench");
    let (mut quality, mut runs, mut only) = (None, 3usize, None::<Vec<String>>);
    let (mut no_per_stage, mut phases) = (false, false);
    let mut scene_dir = glint_repo().join("scenes/glossy-room");
    let mut second_dir = glint_repo().join("scenes/stand-in");
    let dir_of = |p: String| PathBuf::from(p).parent().unwrap().to_owned();
    while let Some(a) = args.next() {
        match a.as_str() {
            "--quality" => {
                let q = args.next().expect("--quality Q");
                let found = Quality::ALL.into_iter().find(|p| p.name() == q);
                quality = Some(found.unwrap_or_else(|| panic!("--quality {q}: no such preset")));
            }
            "--no-per-stage" => no_per_stage = true,
            "--phases" => phases = true,
            "--runs" => runs = args.next().expect("--runs N").parse().unwrap(),
            "--only" => {
                only = Some(
                    args.next()
                        .expect("--only EDIT,…")
                        .split(',')
                        .map(String::from)
                        .collect(),
                )
            }
            "--roughness-scene" => {
                second_dir = dir_of(args.next().expect("--roughness-scene SCENE.json"))
            }
            _ => scene_dir = dir_of(a),
        }
    }
    let chosen: Vec<Edit> = edits()
        .into_iter()
        .filter(|e| only.as_ref().is_none_or(|o| o.iter().any(|n| n == e.name)))
        .collect();
    let work = tempfile::tempdir().unwrap();
    // The main scene is baked only for an edit of its own or the stage-by-stage row: the
    // `roughness` row alone needs the second scene.
    let main = (!no_per_stage || chosen.iter().any(|e| !e.second_scene))
        .then(|| baseline(&scene_dir, work.path(), "main", runs, quality, phases));
    // The same scene baked stage by stage (`bake_all`, no unit cache), once: what the units'
    // route costs a bake from scratch.
    let per_stage = main.as_ref().filter(|_| !no_per_stage).map(|main| {
        let bundle = work.path().join("per-stage.glint");
        let (start, cpu) = (Instant::now(), cpu_time::cpu_seconds());
        let scene = Scene::load(&main.json).unwrap_or_else(|e| panic!("{e}"));
        let settings = BakeSettings::resolve(&scene, quality.unwrap_or(scene.desc.bake.quality))
            .unwrap_or_else(|e| panic!("{e}"));
        let timed = Phases::new();
        let progress: &dyn Progress = if phases { &timed } else { &Silent };
        glint::bake::bake_all(&scene, &bundle, &settings, false, progress)
            .unwrap_or_else(|e| panic!("{e}"));
        let t = Took::since(start, cpu);
        eprintln!("per-stage bake: {:.2} s, CPU {:.2} s", t.wall, t.cpu);
        if phases {
            eprintln!("  phases: {}", timed.report());
        }
        remove(&bundle);
        t
    });
    let second = chosen
        .iter()
        .any(|e| e.second_scene)
        .then(|| baseline(&second_dir, work.path(), "second", runs, quality, phases));

    let mut rows = vec![[
        "edit".to_string(),
        "what changed".into(),
        "units rebaked".into(),
        "median s".into(),
        "vs full".into(),
        "CPU s".into(),
        "CPU vs full".into(),
    ]];
    if let Some(main) = &main {
        let [w, wp, c, cp] = of_full(main.full, main.full);
        rows.push([
            "full".into(),
            "bake from scratch".into(),
            "all".into(),
            w,
            wp,
            c,
            cp,
        ]);
    }
    if let (Some(t), Some(main)) = (per_stage, &main) {
        let [w, wp, c, cp] = of_full(t, main.full);
        rows.push([
            "full/stages".into(),
            "from scratch, stage by stage (bake_all), 1 run".into(),
            "all".into(),
            w,
            wp,
            c,
            cp,
        ]);
    }
    if let Some(b) = &second {
        let [w, wp, c, cp] = of_full(b.full, b.full);
        let name = b.dir.file_name().unwrap().to_string_lossy();
        rows.push([
            "full/second".into(),
            format!("second scene ({name}) from scratch"),
            "all".into(),
            w,
            wp,
            c,
            cp,
        ]);
    }
    for e in chosen {
        let at = if e.second_scene {
            second.as_ref().expect("the second scene is baked")
        } else {
            main.as_ref().expect("the main scene is baked")
        };
        let start_from = match e.base {
            None => at.base.clone(),
            Some(f) => {
                let b = work.path().join(format!("base-{}.glint", e.name));
                write_scene(&at.json, &at.original, f);
                bake(&at.json, &b, quality, false);
                b
            }
        };
        let mut times = Vec::new();
        let mut rebaked = String::new();
        for r in 0..runs {
            let bundle = work.path().join("edited.glint");
            copy_bundle(&start_from, &bundle);
            // Nothing changed: scene.json as it was, byte for byte.
            if e.name == "noop" {
                std::fs::copy(at.dir.join("scene.json"), &at.json).unwrap();
            } else {
                write_scene(&at.json, &at.original, e.apply);
            }
            let (t, done) = bake(&at.json, &bundle, quality, phases);
            eprintln!("{} {}: {:.2} s, CPU {:.2} s", e.name, r + 1, t.wall, t.cpu);
            times.push(t);
            // The gathering units as one entry: there are many at higher presets.
            let gathers: Vec<f64> = done
                .baked()
                .filter(|u| u.stage == "gather")
                .map(|u| u.seconds)
                .collect();
            let mut units: Vec<String> = Vec::new();
            if !gathers.is_empty() {
                let t: f64 = gathers.iter().sum();
                units.push(format!("gather ×{} ({t:.1} s)", gathers.len()));
            }
            units.extend(
                done.baked()
                    .filter(|u| u.stage != "gather")
                    .map(|u| format!("{} ({:.1} s)", u.unit, u.seconds)),
            );
            rebaked = if units.is_empty() {
                "none".into()
            } else {
                units.join(", ")
            };
        }
        let [w, wp, c, cp] = of_full(medians(&times), at.full);
        rows.push([e.name.into(), e.what.into(), rebaked, w, wp, c, cp]);
    }
    println!(
        "edit loop: {} at {}, median of {runs}{}",
        scene_dir.display(),
        quality.map_or("its own quality".into(), |q: Quality| q.name().to_string()),
        second.as_ref().map_or(String::new(), |b| format!(
            "; `roughness` on {}, against its own full bake (full/second)",
            b.dir.display()
        ))
    );
    print!(
        "{}",
        format_table(&rows, &[false, false, false, true, true, true, true])
    );
}

/// The repository root (benches run there).
fn glint_repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}
