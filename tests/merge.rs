//! `glint-bundle merge` commits a whole bundle at once: killed at any step (a fault hook in a
//! child process, and a real SIGKILL at every rename, unlink and fsync under strace), raced by
//! another merge or read meanwhile, the bundle is the old one or the new one, whole. A merge
//! refuses a bundle of another scene without `--force`, and says what is wrong with a path
//! that is no shard.
//!
//! The shards are of a tiny plan made here (units `scene`, `radiosity`, and `radiance.Floor`
//! and `radiance.Wall`, which read D), with a few small files per stage whose bytes name the scene version, so
//! every test runs in well under a second per merge.

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use common::{copy_dir, skip};
use glint::bake::merge::{MergeOptions, merge};
use glint::bake::shard::{MARKER, MARKER_FORMAT, Marker};
use glint::bake::units::{PLAN_FORMAT, PLAN_VERSION, Unit, UnitPlan};
use glint::bundle::{Bundle, CommitStep, StageInfo, StageWriter};

/// One version of a scene: its name and a tag that stands for its content (its hash is the
/// tag's).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Version {
    name: &'static str,
    tag: &'static str,
}

const A: Version = Version {
    name: "glossy-room",
    tag: "a",
};
/// The same scene edited: another hash, the same name.
const B: Version = Version {
    name: "glossy-room",
    tag: "b",
};
/// Another scene.
const OTHER: Version = Version {
    name: "cornell-box",
    tag: "c",
};

fn hash(text: &str) -> String {
    blake3::hash(text.as_bytes()).to_hex().to_string()
}

impl Version {
    fn scene_hash(self) -> String {
        hash(&format!("{}/{}", self.name, self.tag))
    }

    /// The files unit `unit` bakes (path in its stage's folder, kind, bytes).
    fn files(self, unit: &str) -> Vec<(String, &'static str, Vec<u8>)> {
        let body = |f: &str| format!("{} {} {unit}/{f}\n", self.name, self.tag).repeat(200);
        let names: Vec<(String, &str)> = match unit {
            "scene" => vec![
                ("scene.json".into(), "scene-json"),
                ("scene.glb".into(), "gltf"),
            ],
            "radiosity" => vec![
                ("atlas.bin".into(), "atlas"),
                ("page0.exr".into(), "radiosity-exr"),
                ("page1.exr".into(), "radiosity-exr"),
            ],
            _ => {
                let item = unit.strip_prefix("radiance.").unwrap();
                vec![
                    (format!("{item}/cameras.json"), "radiance-cameras"),
                    (format!("{item}/map0.exr"), "radiance-exr"),
                ]
            }
        };
        // The scene stage's files are what readers check: scene.json names its glTF.
        let text = |f: &str| match f {
            "scene.json" => format!(
                r#"{{"version":1,"name":"{}","geometry":"scene.glb","note":{:?}}}"#,
                self.name,
                body(f)
            ),
            "scene.glb" => format!(
                r#"{{"asset":{{"version":"2.0"}},"extras":{{"note":{:?}}}}}"#,
                body(f)
            ),
            _ => body(f),
        };
        names
            .into_iter()
            .map(|(f, k)| {
                let bytes = text(&f).into_bytes();
                (f, k, bytes)
            })
            .collect()
    }

    fn plan(self) -> UnitPlan {
        let scene_hash = self.scene_hash();
        let unit = |id: &str, stage: &str, item: Option<&str>, deps: &[&str], wave| Unit {
            id: id.into(),
            stage: stage.into(),
            item: item.map(Into::into),
            inputs: BTreeMap::from([("scene".to_string(), scene_hash.clone())]),
            depends_on: deps.iter().map(|d| d.to_string()).collect(),
            key: hash(&format!("{id} {scene_hash}")),
            cost: 1.0,
            wave,
        };
        let units = vec![
            unit("scene", "scene", None, &[], 0),
            unit("radiosity", "radiosity", None, &[], 0),
            unit(
                "radiance.Floor",
                "radiance",
                Some("Floor"),
                &["radiosity"],
                1,
            ),
            unit("radiance.Wall", "radiance", Some("Wall"), &["radiosity"], 1),
        ];
        let ids: String = units
            .iter()
            .map(|u| format!("{} {};", u.id, u.key))
            .collect();
        UnitPlan {
            format: PLAN_FORMAT.into(),
            version: PLAN_VERSION,
            scene_name: self.name.into(),
            scene_hash,
            quality: "draft".into(),
            generator: "test".into(),
            plan_hash: hash(&ids),
            stages: BTreeMap::from([
                ("scene".to_string(), serde_json::json!({})),
                ("radiosity".to_string(), serde_json::json!({ "rays": 8 })),
                (
                    "radiance".to_string(),
                    serde_json::json!({ "resolution": 16, "d_source": "" }),
                ),
            ]),
            units,
        }
    }

    /// Bakes every unit's shard into `dir` (`ID.glint`); returns their paths in plan order.
    fn shards(self, dir: &Path) -> Vec<PathBuf> {
        let plan = self.plan();
        let mut d = None;
        let mut out = Vec::new();
        for u in &plan.units {
            let shard = dir.join(format!("{}.glint", u.id));
            let mut w = StageWriter::begin(&shard, &u.stage).unwrap();
            for (rel, kind, bytes) in self.files(&u.id) {
                w.write(&rel, kind, &bytes).unwrap();
            }
            // Figures the merge sums (radiance) or keeps (the others' single unit).
            let stats = BTreeMap::from([
                ("maps".to_string(), serde_json::json!(2)),
                ("rays_cast".to_string(), serde_json::json!(1000)),
            ]);
            let record = w
                .commit(StageInfo {
                    scene_name: self.name.into(),
                    scene_hash: self.scene_hash(),
                    settings: plan.stages[&u.stage].clone(),
                    stats,
                    bake_seconds: 0.1,
                    force: true,
                })
                .unwrap();
            if u.id == "radiosity" {
                d = Some(record.identity());
            }
            let marker = Marker {
                format: MARKER_FORMAT.into(),
                version: 1,
                unit: u.id.clone(),
                key: u.key.clone(),
                stage: u.stage.clone(),
                stage_identity: record.identity(),
                read_d: (!u.depends_on.is_empty()).then(|| d.clone().unwrap()),
                plan: plan.clone(),
            };
            std::fs::write(
                shard.join(MARKER),
                serde_json::to_string_pretty(&marker).unwrap(),
            )
            .unwrap();
            out.push(shard);
        }
        out
    }
}

const STAGES: [&str; 3] = ["radiance", "radiosity", "scene"];

/// Which version the bundle at `dir` holds, whole: the manifest names every stage of it and
/// no other, and `verify` passes. Panics (naming `label`) on anything else.
fn whole(dir: &Path, label: &str) -> Version {
    let b = Bundle::open(dir).unwrap_or_else(|e| panic!("{label}: {e}"));
    let problems: Vec<String> = b.verify().iter().map(|e| e.to_string()).collect();
    assert!(problems.is_empty(), "{label}: verify: {problems:?}");
    let m = b.manifest();
    let stages: Vec<&str> = m.stages.keys().map(String::as_str).collect();
    assert_eq!(stages, STAGES, "{label}: stages");
    let v = [A, B, OTHER]
        .into_iter()
        .find(|v| v.scene_hash() == m.scene_hash && v.name == m.scene_name)
        .unwrap_or_else(|| panic!("{label}: unknown scene {} {}", m.scene_name, m.scene_hash));
    for stage in STAGES {
        assert_eq!(
            m.stages[stage].scene_hash, m.scene_hash,
            "{label}: stage {stage} of another version"
        );
    }
    let mut assets = 0;
    for u in &v.plan().units {
        for (rel, _, bytes) in v.files(&u.id) {
            assert_eq!(
                b.read_stage_file(&u.stage, &rel).unwrap(),
                bytes,
                "{label}: {}/{rel}",
                u.stage
            );
            assets += 1;
        }
    }
    assert_eq!(m.assets().count(), assets, "{label}: assets");
    assert_eq!(m.stages["radiance"].stats["rays_cast"], 2000, "{label}");
    v
}

fn glint_bundle(args: &[&Path]) -> (i32, String, String) {
    common::run_exe(env!("CARGO_BIN_EXE_glint-bundle"), args)
}

/// `glint-bundle merge OUT SHARD…` (with `extra` flags first).
fn merge_cli(out: &Path, shards: &[PathBuf], extra: &[&str]) -> (i32, String, String) {
    let mut args: Vec<&Path> = vec![Path::new("merge")];
    args.extend(extra.iter().map(Path::new));
    args.push(out);
    args.extend(shards.iter().map(PathBuf::as_path));
    glint_bundle(&args)
}

/// A folder with shards of `A`, `B` and `OTHER`, and `old.glint` merged from `A`'s.
struct Fixture {
    _tmp: tempfile::TempDir,
    root: PathBuf,
    shards: BTreeMap<&'static str, Vec<PathBuf>>,
}

impl Fixture {
    fn new() -> Fixture {
        let tmp = tempfile::tempdir().unwrap();
        let root = tmp.path().to_owned();
        let shards = [A, B, OTHER]
            .into_iter()
            .map(|v| (v.tag, v.shards(&root.join(v.tag))))
            .collect();
        let f = Fixture {
            _tmp: tmp,
            root,
            shards,
        };
        let (code, out, err) = merge_cli(&f.old(), f.of(A), &[]);
        assert_eq!(code, 0, "{out}{err}");
        assert_eq!(whole(&f.old(), "A merged"), A);
        f
    }

    fn of(&self, v: Version) -> &[PathBuf] {
        &self.shards[v.tag]
    }

    /// The bundle merged from `A`'s shards.
    fn old(&self) -> PathBuf {
        self.root.join("old.glint")
    }

    /// A fresh copy of [`Fixture::old`] at `name`.
    fn copy_of_old(&self, name: &str) -> PathBuf {
        let dir = self.root.join(name);
        let _ = std::fs::remove_dir_all(&dir);
        copy_dir(&self.old(), &dir);
        dir
    }
}

#[test]
fn a_remerge_of_an_edited_scene_replaces_the_bundle_whole() {
    let f = Fixture::new();
    let dir = f.copy_of_old("re.glint");
    let (code, out, err) = merge_cli(&dir, f.of(B), &[]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("3 stages"), "{out}");
    assert_eq!(whole(&dir, "B over A"), B);
    // The old version's folders are collected.
    let mut entries: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    entries.sort();
    assert_eq!(
        entries,
        [
            ".lock",
            "manifest.json",
            "radiance.2",
            "radiosity.2",
            "scene.2"
        ]
    );
}

/// The steps of a clean merge of `B` over `A`, as the fault hook sees them.
fn merge_steps(f: &Fixture) -> Vec<CommitStep> {
    let dir = f.copy_of_old("steps.glint");
    let steps = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let seen = steps.clone();
    let options = MergeOptions {
        force: false,
        fault_hook: Some(Box::new(move |s| {
            seen.lock().unwrap().push(s);
            Ok(())
        })),
    };
    merge(&dir, f.of(B), options).unwrap();
    assert_eq!(whole(&dir, "clean merge"), B);
    std::mem::take(&mut *steps.lock().unwrap())
}

#[test]
fn a_merge_failing_or_killed_at_any_commit_step_leaves_the_old_bundle_or_the_new_one() {
    const STEP: &str = "GLINT_TEST_MERGE_CRASH_STEP";
    // The child: merge B's shards and abort the process at step K (no unwinding, no
    // clean-up: what a kill -9 leaves).
    if let Ok(k) = std::env::var(STEP) {
        let k: usize = k.parse().unwrap();
        let dir = PathBuf::from(std::env::var("GLINT_TEST_MERGE_DIR").unwrap());
        let shards: Vec<PathBuf> = std::env::var("GLINT_TEST_MERGE_SHARDS")
            .unwrap()
            .split('\n')
            .map(PathBuf::from)
            .collect();
        let mut n = 0;
        let options = MergeOptions {
            force: false,
            fault_hook: Some(Box::new(move |_| {
                n += 1;
                if n == k + 1 {
                    std::process::abort();
                }
                Ok(())
            })),
        };
        let _ = merge(&dir, &shards, options);
        std::process::exit(0);
    }
    let f = Fixture::new();
    let steps = merge_steps(&f);
    // One commit: every stage's folder is renamed into place before the one manifest rename.
    let count = |s| steps.iter().filter(|x| **x == s).count();
    assert_eq!(count(CommitStep::Lock), 1, "{steps:?}");
    assert_eq!(count(CommitStep::RenameStage), 3, "{steps:?}");
    assert_eq!(count(CommitStep::RenameManifest), 1, "{steps:?}");
    assert!(count(CommitStep::Collect) >= 3, "{steps:?}");
    let commit_at = steps
        .iter()
        .position(|s| *s == CommitStep::RenameManifest)
        .unwrap();
    let shards: Vec<&str> = f.of(B).iter().map(|p| p.to_str().unwrap()).collect();
    let exe = std::env::current_exe().unwrap();
    for (k, &step) in steps.iter().enumerate() {
        // An error at step K: the merge fails (or, past the commit, only collection does).
        let dir = f.copy_of_old(&format!("fault{k}.glint"));
        let mut n = 0;
        let options = MergeOptions {
            force: false,
            fault_hook: Some(Box::new(move |_| {
                n += 1;
                if n == k + 1 {
                    Err(std::io::Error::other("injected fault"))
                } else {
                    Ok(())
                }
            })),
        };
        let result = merge(&dir, f.of(B), options);
        let label = format!("fault at step {k} ({step:?})");
        let want = if k > commit_at { B } else { A };
        assert_eq!(whole(&dir, &label), want, "{label}");
        match step {
            CommitStep::Collect => {
                result.unwrap();
            }
            _ => assert!(
                result.unwrap_err().to_string().contains("injected fault"),
                "{label}"
            ),
        }

        // The process killed at step K.
        let dir = f.copy_of_old(&format!("kill{k}.glint"));
        let status = Command::new(&exe)
            .args([
                "--exact",
                "a_merge_failing_or_killed_at_any_commit_step_leaves_the_old_bundle_or_the_new_one",
                "--nocapture",
            ])
            .env(STEP, k.to_string())
            .env("GLINT_TEST_MERGE_DIR", &dir)
            .env("GLINT_TEST_MERGE_SHARDS", shards.join("\n"))
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .status()
            .unwrap();
        let label = format!("killed at step {k} ({step:?})");
        assert!(!status.success(), "{label}: the child was not killed");
        assert_eq!(whole(&dir, &label), want, "{label}");
        // The next merge completes and collects what the killed one left.
        let (code, out, err) = merge_cli(&dir, f.of(B), &[]);
        assert_eq!(code, 0, "{label}: {out}{err}");
        assert_eq!(whole(&dir, &label), B, "{label}");
        let left: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n != ".lock" && n != "manifest.json")
            .collect();
        assert_eq!(left.len(), 3, "{label}: left behind {left:?}");
    }
}

#[cfg(unix)]
#[test]
fn a_merge_stopped_by_ctrl_c_exits_130_and_leaves_the_bundle_as_it_was() {
    const CHILD: &str = "GLINT_TEST_MERGE_SIGINT";
    // The child: Ctrl-C (a real SIGINT, to itself) reaches the shared handler, then the merge
    // runs and its result becomes the exit code as every binary's does.
    if std::env::var_os(CHILD).is_some() {
        glint::progress::install_interrupt_handler();
        let me = std::process::id().to_string();
        assert!(
            Command::new("kill")
                .args(["-INT", &me])
                .status()
                .unwrap()
                .success()
        );
        let start = std::time::Instant::now();
        while !glint::progress::interrupted() {
            assert!(start.elapsed().as_secs() < 10, "SIGINT never arrived");
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        let dir = PathBuf::from(std::env::var("GLINT_TEST_MERGE_DIR").unwrap());
        let shards: Vec<PathBuf> = std::env::var("GLINT_TEST_MERGE_SHARDS")
            .unwrap()
            .split('\n')
            .map(PathBuf::from)
            .collect();
        let result = merge(&dir, &shards, MergeOptions::default())
            .map(|_| std::process::ExitCode::SUCCESS)
            .map_err(anyhow::Error::from);
        std::process::exit(match glint::cli::exit_code(result) {
            c if c == std::process::ExitCode::from(130) => 130,
            c if c == std::process::ExitCode::SUCCESS => 0,
            _ => 1,
        });
    }
    let f = Fixture::new();
    let dir = f.copy_of_old("stopped.glint");
    let shards: Vec<&str> = f.of(B).iter().map(|p| p.to_str().unwrap()).collect();
    let out = Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "a_merge_stopped_by_ctrl_c_exits_130_and_leaves_the_bundle_as_it_was",
            "--nocapture",
        ])
        .env(CHILD, "1")
        .env("GLINT_TEST_MERGE_DIR", &dir)
        .env("GLINT_TEST_MERGE_SHARDS", shards.join("\n"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(
        err.contains("interrupted: nothing was written;")
            && err.contains("stopped.glint is as it was"),
        "{err}"
    );
    assert_eq!(whole(&dir, "stopped by Ctrl-C"), A);
}

fn strace() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join("strace"))
        .find(|p| p.is_file())
}

#[test]
fn glint_bundle_merge_killed_at_every_rename_unlink_and_fsync_leaves_the_old_or_the_new_bundle() {
    use std::os::unix::process::ExitStatusExt;
    let Some(strace) = strace() else {
        assert!(
            std::env::var_os("CI").is_none(),
            "strace is needed (Debian: strace, installed by .ci/run)"
        );
        return skip("no strace");
    };
    let traced = Command::new(&strace)
        .args(["-f", "-qq", "-o", "/dev/null", "true"])
        .status()
        .unwrap();
    if !traced.success() {
        return skip("strace cannot trace here (ptrace is not permitted)");
    }
    let f = Fixture::new();
    let mut kills: BTreeMap<&str, usize> = BTreeMap::new();
    let mut outcomes: BTreeMap<&str, usize> = BTreeMap::new();
    // Every system call that renames, removes or flushes, whichever of them the C library
    // uses (`?`: one this architecture lacks is passed over).
    for syscall in [
        "rename",
        "renameat",
        "renameat2",
        "unlink",
        "unlinkat",
        "rmdir",
        "fsync",
        "fdatasync",
    ] {
        for n in 1.. {
            let dir = f.copy_of_old("k.glint");
            let status = Command::new(&strace)
                .args(["-f", "-qq", "-o", "/dev/null", "-e"])
                .arg(format!("inject=?{syscall}:signal=KILL:when={n}"))
                .arg(env!("CARGO_BIN_EXE_glint-bundle"))
                .arg("merge")
                .arg(&dir)
                .args(f.of(B))
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::null())
                .status()
                .unwrap();
            let label = format!("killed at {syscall} #{n}");
            let v = whole(&dir, &label);
            if status.success() {
                // Fewer than N calls: the merge ran to its end.
                assert_eq!(v, B, "{label}");
                break;
            }
            assert_eq!(status.signal(), Some(9), "{label}: {status:?}");
            *kills.entry(syscall).or_default() += 1;
            *outcomes
                .entry(if v == A { "old" } else { "new" })
                .or_default() += 1;
            assert!(n < 10_000, "{label}: the merge never ends");
        }
    }
    let family = |names: &[&str]| names.iter().map(|s| kills.get(s).unwrap_or(&0)).sum();
    let (renames, unlinks, fsyncs): (usize, usize, usize) = (
        family(&["rename", "renameat", "renameat2"]),
        family(&["unlink", "unlinkat", "rmdir"]),
        family(&["fsync", "fdatasync"]),
    );
    // Three stage folders and the manifest renamed; the old version's files removed;
    // every new file and folder flushed.
    eprintln!("kills: {kills:?}, outcomes: {outcomes:?}");
    assert!(renames >= 4, "{kills:?}");
    assert!(unlinks >= 9, "{kills:?}");
    assert!(fsyncs >= 9, "{kills:?}");
    assert!(
        outcomes.contains_key("old") && outcomes.contains_key("new"),
        "{outcomes:?}"
    );
}

#[test]
fn concurrent_merges_leave_one_whole_merge() {
    let f = Fixture::new();
    for i in 0..8 {
        let dir = f.copy_of_old(&format!("race{i}.glint"));
        let spawn = |v: Version| {
            let mut c = Command::new(env!("CARGO_BIN_EXE_glint-bundle"));
            c.arg("merge").arg(&dir).args(f.of(v));
            c.stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        };
        let (a, b) = (spawn(A), spawn(B));
        let (a, b) = (a.wait_with_output().unwrap(), b.wait_with_output().unwrap());
        let label = format!(
            "run {i}: A {:?} {}, B {:?} {}",
            a.status.code(),
            String::from_utf8_lossy(&a.stderr),
            b.status.code(),
            String::from_utf8_lossy(&b.stderr)
        );
        assert!(a.status.success() && b.status.success(), "{label}");
        whole(&dir, &label);
    }
}

#[test]
fn readers_during_merges_see_the_old_bundle_or_the_new_one() {
    let f = Fixture::new();
    let dir = f.copy_of_old("read.glint");
    let done = std::sync::atomic::AtomicBool::new(false);
    let reads = std::thread::scope(|s| {
        let reader = s.spawn(|| {
            let mut reads = 0;
            while !done.load(std::sync::atomic::Ordering::Relaxed) {
                whole(&dir, &format!("read {reads}"));
                reads += 1;
            }
            reads
        });
        for i in 0..12 {
            let v = if i % 2 == 0 { B } else { A };
            let (code, out, err) = merge_cli(&dir, f.of(v), &[]);
            assert_eq!(code, 0, "{out}{err}");
        }
        done.store(true, std::sync::atomic::Ordering::Relaxed);
        reader.join().unwrap()
    });
    assert!(reads >= 5, "only {reads} reads overlapped the merges");
}

#[test]
fn a_merge_refuses_a_bundle_of_another_scene_without_force() {
    let f = Fixture::new();
    let dir = f.copy_of_old("other.glint");
    let before = std::fs::read(dir.join("manifest.json")).unwrap();
    let (code, out, err) = merge_cli(&dir, f.of(OTHER), &[]);
    assert_eq!(code, 1, "{out}{err}");
    for want in [
        format!("{}: holds scene `glossy-room`", dir.display()),
        format!("(hash {}…)", &A.scene_hash()[..12]),
        format!("not `cornell-box` (hash {}…)", &OTHER.scene_hash()[..12]),
        "--force".to_string(),
    ] {
        assert!(err.contains(&want), "{want:?} not in {err}");
    }
    assert_eq!(std::fs::read(dir.join("manifest.json")).unwrap(), before);
    assert_eq!(whole(&dir, "refused"), A);
    // Nothing of the refused merge is left in the bundle.
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 5);

    let (code, out, err) = merge_cli(&dir, f.of(OTHER), &["--force"]);
    assert_eq!(code, 0, "{out}{err}");
    assert_eq!(whole(&dir, "forced"), OTHER);
}

#[test]
fn a_missing_path_or_a_whole_bundle_is_named_for_what_it_is() {
    let f = Fixture::new();
    let out = f.root.join("out.glint");
    let mut shards = f.of(A).to_vec();
    let missing = f.root.join("nope.glint");
    shards.push(missing.clone());
    let (code, _, err) = merge_cli(&out, &shards, &[]);
    assert_eq!(code, 1);
    assert!(
        err.contains(&format!(
            "{}: no shard there: the path does not exist",
            missing.display()
        )),
        "{err}"
    );
    assert!(
        !err.contains("--unit nope") && !err.contains("killed"),
        "{err}"
    );

    // The merged bundle given as a shard: a whole bundle, not a unit's.
    let mut shards = f.of(A).to_vec();
    shards.push(f.old());
    let (code, _, err) = merge_cli(&out, &shards, &[]);
    assert_eq!(code, 1);
    assert!(
        err.contains(&format!(
            "{}: a whole bundle (stages radiance, radiosity, scene), not a unit shard",
            f.old().display()
        )),
        "{err}"
    );
    assert!(
        !err.contains("--unit old") && !err.contains("killed"),
        "{err}"
    );

    // A shard whose unit never wrote its marker is still called incomplete.
    let shard = &f.of(A)[1];
    std::fs::remove_file(shard.join(MARKER)).unwrap();
    let (code, _, err) = merge_cli(&out, f.of(A), &[]);
    assert_eq!(code, 1);
    assert!(
        err.contains(&format!("{}: incomplete shard", shard.display()))
            && err.contains("--unit radiosity"),
        "{err}"
    );
    assert!(!out.exists(), "nothing is written");
}

#[test]
fn a_shard_holding_another_stage_than_its_unit_is_refused() {
    let f = Fixture::new();
    // The radiosity unit's shard replaced by a copy of the scene shard whose marker names the
    // radiosity unit (its key), and the units that read D marked as reading none.
    let root = f.root.join("forged");
    copy_dir(&f.root.join(A.tag), &root);
    let shard = root.join("radiosity.glint");
    std::fs::remove_dir_all(&shard).unwrap();
    copy_dir(&root.join("scene.glint"), &shard);
    let plan = A.plan();
    let edit = |path: &Path, f: &dyn Fn(&mut Marker)| {
        let mut m: Marker = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
        f(&mut m);
        std::fs::write(path, serde_json::to_string_pretty(&m).unwrap()).unwrap();
    };
    edit(&shard.join(MARKER), &|m| {
        m.unit = "radiosity".into();
        m.key = plan.unit("radiosity").unwrap().key.clone();
    });
    for u in ["radiance.Floor", "radiance.Wall"] {
        edit(&root.join(format!("{u}.glint")).join(MARKER), &|m| {
            m.read_d = None
        });
    }
    let shards: Vec<PathBuf> = plan
        .units
        .iter()
        .map(|u| root.join(format!("{}.glint", u.id)))
        .collect();
    let out = f.root.join("forged.glint");
    let (code, _, err) = merge_cli(&out, &shards, &[]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains(&format!(
            "{}: unit `radiosity` holds stage `scene`, but the plan gives it stage `radiosity`",
            shard.display()
        )),
        "{err}"
    );
    assert!(!out.exists(), "nothing is written");
}
