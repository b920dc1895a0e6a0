//! The job-engine recipes under `deploy/` stay valid: the Kubernetes manifest parses (a YAML
//! subset reader below: block mappings and sequences, scalars, literal blocks) into the Jobs
//! the README describes, sized by the plan's waves, and its pod script bakes a unit when run
//! here; the Slurm array script bakes the unit of its task index with the CPUs granted, and
//! `submit.sh` chains the waves and the merge, asking for what a node can give (run with
//! stand-ins for `sbatch` and `sinfo`; `.ci/slurm.sh` runs it on a real cluster).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::repo;

/// A YAML node of the subset the manifests use.
#[derive(Clone, Debug, PartialEq)]
enum Yaml {
    Map(Vec<(String, Yaml)>),
    Seq(Vec<Yaml>),
    Str(String),
}

impl Yaml {
    fn get(&self, key: &str) -> &Yaml {
        match self {
            Yaml::Map(m) => m
                .iter()
                .find(|(k, _)| k == key)
                .map(|(_, v)| v)
                .unwrap_or_else(|| panic!("no key `{key}` in {self:?}")),
            _ => panic!("`{key}` asked of a non-mapping {self:?}"),
        }
    }
    fn at(&self, path: &str) -> &Yaml {
        path.split('.').fold(self, |n, k| match k.parse::<usize>() {
            Ok(i) => &n.seq()[i],
            Err(_) => n.get(k),
        })
    }
    fn str(&self) -> &str {
        match self {
            Yaml::Str(s) => s,
            _ => panic!("not a scalar: {self:?}"),
        }
    }
    fn seq(&self) -> &[Yaml] {
        match self {
            Yaml::Seq(s) => s,
            _ => panic!("not a sequence: {self:?}"),
        }
    }
}

/// Lines of one document: (indent, text), comments and blank lines kept for block scalars.
struct Reader {
    lines: Vec<(usize, String)>,
    i: usize,
}

impl Reader {
    fn skip_blank(&mut self) {
        while self.i < self.lines.len() {
            let t = self.lines[self.i].1.trim();
            if t.is_empty() || t.starts_with('#') {
                self.i += 1;
            } else {
                break;
            }
        }
    }

    fn block(&mut self, indent: usize) -> Yaml {
        self.skip_blank();
        let (ind, text) = self.lines[self.i].clone();
        assert!(
            ind >= indent,
            "line {}: indent {ind} < {indent}",
            self.i + 1
        );
        if text == "-" || text.starts_with("- ") {
            self.seq(ind)
        } else {
            self.map(ind)
        }
    }

    fn seq(&mut self, ind: usize) -> Yaml {
        let mut items = Vec::new();
        loop {
            self.skip_blank();
            if self.i >= self.lines.len() {
                break;
            }
            let (i2, text) = self.lines[self.i].clone();
            if i2 != ind || !(text == "-" || text.starts_with("- ")) {
                assert!(i2 <= ind, "line {}: unexpected indent", self.i + 1);
                break;
            }
            let rest = text[1..].trim_start().to_string();
            if rest == "|" {
                self.i += 1;
                items.push(self.literal(ind));
            } else if rest.is_empty() {
                self.i += 1;
                items.push(self.block(ind + 1));
            } else if rest.contains(": ") || rest.ends_with(':') {
                // `- key: value`: a mapping whose first line starts after the dash.
                self.lines[self.i] = (ind + 2, rest);
                items.push(self.map(ind + 2));
            } else {
                self.i += 1;
                items.push(Yaml::Str(scalar(&rest)));
            }
        }
        Yaml::Seq(items)
    }

    fn map(&mut self, ind: usize) -> Yaml {
        let mut entries: Vec<(String, Yaml)> = Vec::new();
        loop {
            self.skip_blank();
            if self.i >= self.lines.len() {
                break;
            }
            let (i2, text) = self.lines[self.i].clone();
            if i2 < ind {
                break;
            }
            assert!(
                i2 == ind && !text.starts_with("- "),
                "line {}: bad indent or item: {text}",
                self.i + 1
            );
            let (key, rest) = match text.split_once(": ") {
                Some((k, r)) => (k.to_string(), r.trim().to_string()),
                None => (
                    text.strip_suffix(':')
                        .unwrap_or_else(|| panic!("line {}: not `key: value`: {text}", self.i + 1))
                        .to_string(),
                    String::new(),
                ),
            };
            assert!(
                !entries.iter().any(|(k, _)| *k == key),
                "line {}: key `{key}` twice",
                self.i + 1
            );
            self.i += 1;
            let value = if rest == "|" {
                self.literal(ind)
            } else if rest.is_empty() {
                self.skip_blank();
                let next = self.lines.get(self.i).cloned();
                match next {
                    Some((n, t)) if n > ind || (n == ind && t.starts_with("- ")) => self.block(n),
                    _ => Yaml::Str(String::new()),
                }
            } else {
                Yaml::Str(scalar(&rest))
            };
            entries.push((key, value));
        }
        Yaml::Map(entries)
    }

    /// A `|` block: the following lines indented deeper than `ind`, less the first's indent.
    fn literal(&mut self, ind: usize) -> Yaml {
        let mut out = String::new();
        let mut base = None;
        while self.i < self.lines.len() {
            let (n, t) = &self.lines[self.i];
            if !t.is_empty() && *n <= ind {
                break;
            }
            let b = *base.get_or_insert(*n);
            out += &" ".repeat(n.saturating_sub(b));
            out += t;
            out.push('\n');
            self.i += 1;
        }
        Yaml::Str(out)
    }
}

fn scalar(s: &str) -> String {
    let s = s.trim();
    for q in ['"', '\''] {
        if s.len() >= 2 && s.starts_with(q) && s.ends_with(q) {
            return s[1..s.len() - 1].to_string();
        }
    }
    assert!(
        !s.starts_with(['[', '{', '&', '*', '!']),
        "unsupported YAML: {s}"
    );
    s.to_string()
}

fn parse_yaml(text: &str) -> Vec<Yaml> {
    assert!(!text.contains('\t'), "tabs are not YAML indentation");
    text.split("\n---\n")
        .map(|doc| {
            let lines = doc
                .lines()
                .map(|l| {
                    let t = l.trim_start();
                    (l.len() - t.len(), t.trim_end().to_string())
                })
                .collect();
            let mut r = Reader { lines, i: 0 };
            let y = r.block(0);
            r.skip_blank();
            assert_eq!(r.i, r.lines.len(), "unparsed lines after {}", r.i);
            y
        })
        .collect()
}

#[test]
fn the_yaml_reader_reads_what_it_claims() {
    let docs = parse_yaml(
        "# c\na: 1\nb:\n  - |\n    lit\n  - x\n  - k: \"v\"\n    l: w\nc:\n- y\nd: |\n  one\n    two\ne: ''\n---\nf: g\n",
    );
    let s = |v: &str| Yaml::Str(v.into());
    assert_eq!(
        docs[0],
        Yaml::Map(vec![
            ("a".into(), s("1")),
            (
                "b".into(),
                Yaml::Seq(vec![
                    s("lit\n"),
                    s("x"),
                    Yaml::Map(vec![("k".into(), s("v")), ("l".into(), s("w"))])
                ])
            ),
            ("c".into(), Yaml::Seq(vec![s("y")])),
            ("d".into(), s("one\n  two\n")),
            ("e".into(), s("")),
        ])
    );
    assert_eq!(docs[1], Yaml::Map(vec![("f".into(), s("g"))]));
    for bad in ["a: 1\na: 2\n", "a:\n   b: 1\n  c: 2\n", "a: [1, 2]\n"] {
        assert!(
            std::panic::catch_unwind(|| parse_yaml(bad)).is_err(),
            "{bad}"
        );
    }
}

/// PATH with the built binaries first.
fn path_with_binaries(extra: Option<&Path>) -> String {
    let bin = Path::new(env!("CARGO_BIN_EXE_glint-bake"))
        .parent()
        .unwrap();
    let mut dirs: Vec<PathBuf> = extra.into_iter().map(Path::to_owned).collect();
    dirs.push(bin.to_owned());
    dirs.extend(std::env::split_paths(
        &std::env::var_os("PATH").unwrap_or_default(),
    ));
    std::env::join_paths(dirs).unwrap().into_string().unwrap()
}

fn wave_ids(scene: &Path, wave: u32) -> Vec<String> {
    let out = Command::new(env!("CARGO_BIN_EXE_glint-bake"))
        .args([
            scene.to_str().unwrap(),
            "--quality",
            "draft",
            "--plan",
            "--wave",
            &wave.to_string(),
        ])
        .output()
        .unwrap();
    assert!(out.status.success());
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(String::from)
        .collect()
}

/// Checks that a script run succeeded and left a complete shard of wave 0's first unit.
fn assert_baked_first_unit(out: &std::process::Output, scene: &Path, shards: &Path) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let first = &wave_ids(scene, 0)[0];
    let marker = shards.join(format!("{first}.glint/unit.json"));
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(marker).unwrap()).unwrap();
    assert_eq!(v["unit"], first.as_str());
}

#[test]
fn the_kubernetes_indexed_jobs_parse_match_the_plan_and_their_pods_bake_a_unit() {
    let text = std::fs::read_to_string(repo("deploy/k8s/glint-units.yaml")).unwrap();
    let docs = parse_yaml(&text);
    let names: Vec<&str> = docs.iter().map(|d| d.at("metadata.name").str()).collect();
    assert_eq!(
        names,
        [
            "glint-wave-0",
            "glint-wave-1",
            "glint-wave-2",
            "glint-merge"
        ]
    );
    let scene = repo("scenes/glossy-room/scene.json");
    let tmp = tempfile::tempdir().unwrap();
    for (w, job) in docs.iter().enumerate() {
        assert_eq!(job.get("apiVersion").str(), "batch/v1");
        assert_eq!(job.get("kind").str(), "Job");
        let step = job.at("metadata.labels.glint/step").str();
        assert_eq!(
            job.at("spec.template.metadata.labels.glint/step").str(),
            step
        );
        let pod = job.at("spec.template.spec");
        assert_eq!(pod.get("restartPolicy").str(), "Never");
        let volumes: Vec<&str> = pod
            .get("volumes")
            .seq()
            .iter()
            .map(|v| v.get("name").str())
            .collect();
        let container = pod.at("containers.0");
        for m in container.get("volumeMounts").seq() {
            assert!(volumes.contains(&m.get("name").str()), "{m:?}");
        }
        let env: Vec<(String, String)> = container
            .get("env")
            .seq()
            .iter()
            .map(|e| {
                (
                    e.get("name").str().to_string(),
                    e.get("value").str().to_string(),
                )
            })
            .collect();
        let command: Vec<&str> = container
            .get("command")
            .seq()
            .iter()
            .map(Yaml::str)
            .collect();
        assert_eq!(command, ["bash", "-c"]);
        let script = container.at("args.0").str();
        if step == "merge" {
            assert!(
                script.contains("glint-bundle merge \"$OUT\" \"$SHARDS\"/*.glint"),
                "{script}"
            );
            continue;
        }
        // A wave: one pod per unit of the wave, each picking its unit by completion index.
        assert_eq!(step, format!("wave-{w}"));
        // Fits a 2-CPU node, and the CPU limit (which glint's thread count follows) is the request.
        let cpu = container.at("resources.requests.cpu").str();
        assert_eq!(cpu, "2", "{step}");
        assert_eq!(container.at("resources.limits.cpu").str(), cpu, "{step}");
        assert_eq!(job.at("spec.completionMode").str(), "Indexed");
        let completions: usize = job.at("spec.completions").str().parse().unwrap();
        assert_eq!(
            completions,
            wave_ids(&scene, w as u32).len(),
            "{step}: completions"
        );
        let parallelism: usize = job.at("spec.parallelism").str().parse().unwrap();
        assert!((1..=completions).contains(&parallelism));
        assert!(env.contains(&("WAVE".into(), w.to_string())), "{env:?}");
        assert!(
            script.contains("JOB_COMPLETION_INDEX") && script.contains("--unit"),
            "{script}"
        );
        if w == 0 {
            // The pod's script, run here with the scene and shards at local paths.
            let shards = tmp.path().join("shards");
            let mut cmd = Command::new("bash");
            cmd.args(["-c", script]);
            for (k, v) in &env {
                cmd.env(k, v);
            }
            let out = cmd
                .env("SCENE", &scene)
                .env("SHARDS", &shards)
                .env("JOB_COMPLETION_INDEX", "0")
                .env("PATH", path_with_binaries(None))
                .output()
                .unwrap();
            assert_baked_first_unit(&out, &scene, &shards);
        }
    }
}

/// Writes an executable stand-in command `name` into `dir`.
fn stand_in(dir: &Path, name: &str, script: &str) {
    use std::os::unix::fs::PermissionsExt;
    let path = dir.join(name);
    std::fs::write(&path, format!("#!/usr/bin/env bash\n{script}")).unwrap();
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
}

#[test]
fn the_slurm_array_script_bakes_its_tasks_unit_with_the_cpus_granted() {
    let sbatch = repo("deploy/slurm/glint-unit.sbatch");
    let text = std::fs::read_to_string(&sbatch).unwrap();
    let directives: Vec<&str> = text
        .lines()
        .filter_map(|l| l.strip_prefix("#SBATCH "))
        .collect();
    assert!(directives.len() >= 4, "{directives:?}");
    for d in &directives {
        let (flag, value) = d
            .split_once('=')
            .unwrap_or_else(|| panic!("#SBATCH {d}: not --flag=value"));
        assert!(flag.starts_with("--") && !value.is_empty(), "#SBATCH {d}");
    }
    // A direct `sbatch` must fit a small node: 2 CPUs, a few GB.
    assert!(directives.contains(&"--cpus-per-task=2"), "{directives:?}");
    assert!(directives.contains(&"--mem=2G"), "{directives:?}");
    for script in ["deploy/slurm/glint-unit.sbatch", "deploy/slurm/submit.sh"] {
        let ok = Command::new("bash")
            .args(["-n", repo(script).to_str().unwrap()])
            .status()
            .unwrap();
        assert!(ok.success(), "{script}: bash syntax");
    }
    let scene = repo("scenes/glossy-room/scene.json");
    let tmp = tempfile::tempdir().unwrap();
    let shards = tmp.path().join("shards");
    let task = |k: &str| {
        Command::new("bash")
            .arg(&sbatch)
            .env("SCENE", &scene)
            .env("SHARDS", &shards)
            .env("QUALITY", "draft")
            .env("WAVE", "0")
            .env("SLURM_ARRAY_TASK_ID", k)
            .env("SLURM_CPUS_PER_TASK", "1")
            .env_remove("RAYON_NUM_THREADS")
            .env("PATH", path_with_binaries(None))
            .output()
            .unwrap()
    };
    let out = task("0");
    assert_baked_first_unit(&out, &scene, &shards);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("threads: 1 (SLURM_CPUS_PER_TASK)"),
        "{stderr}"
    );
    let out = task("99");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("wave 0 has no unit 99"));
}

/// Runs submit.sh with stand-ins for `sbatch` (records its arguments, answers a job id) and
/// `sinfo` (one node of `cpus` CPUs and `mb` MB); returns its calls of sbatch.
fn submit_calls(cpus: u32, mb: u32, env: &[(&str, &str)], extra: &[&str]) -> Vec<String> {
    let scene = repo("scenes/glossy-room/scene.json");
    let tmp = tempfile::tempdir().unwrap();
    let fake = tmp.path().join("bin");
    std::fs::create_dir_all(&fake).unwrap();
    let log = tmp.path().join("sbatch.log");
    let log = log.display();
    stand_in(
        &fake,
        "sbatch",
        &format!("echo \"$*\" >> '{log}'\nwc -l < '{log}'\n"),
    );
    stand_in(
        &fake,
        "sinfo",
        &format!("case \"$*\" in *%c*) echo {cpus} ;; *%m*) echo {mb} ;; esac\n"),
    );
    let shards = tmp.path().join("shards");
    let out_glint = tmp.path().join("out.glint");
    let mut cmd = Command::new("bash");
    cmd.arg(repo("deploy/slurm/submit.sh"))
        .args([&scene, &shards, &out_glint])
        .arg("draft")
        .args(extra)
        .env("PATH", path_with_binaries(Some(&fake)));
    for k in ["GLINT_CPUS", "GLINT_MEM", "GLINT_RADIOSITY_MEM"] {
        cmd.env_remove(k);
    }
    for (k, v) in env {
        cmd.env(k, v);
    }
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::read_to_string(tmp.path().join("sbatch.log"))
        .unwrap()
        .lines()
        .map(String::from)
        .collect()
}

#[test]
fn submit_chains_the_waves_and_asks_what_a_node_can_give() {
    let scene = repo("scenes/glossy-room/scene.json");
    // A large node: the documented defaults, and options after `--` last on every call.
    let calls = submit_calls(64, 256_000, &[], &["--", "--partition=p", "--mem=3G"]);
    assert_eq!(calls.len(), 4, "{calls:?}");
    // Each wave's array after the one before, sized by the plan's wave.
    for (w, call) in calls[..3].iter().enumerate() {
        let n = wave_ids(&scene, w as u32).len();
        assert!(
            call.contains(&format!("--array=0-{}", n - 1)) && call.contains(&format!("WAVE={w}")),
            "{call}"
        );
        if w == 0 {
            assert!(!call.contains("--dependency"), "{call}");
        } else {
            assert!(
                call.contains(&format!("--dependency=afterok:{w}")),
                "{call}"
            );
        }
        let mem = if w == 1 { "8192M" } else { "2048M" };
        assert!(
            call.contains(&format!(
                "--cpus-per-task=2 --mem={mem} --partition=p --mem=3G "
            )),
            "{call}"
        );
        assert!(call.ends_with("glint-unit.sbatch"), "{call}");
    }
    assert!(
        calls[3].contains("--dependency=afterok:3")
            && calls[3].contains("--cpus-per-task=1 --mem=2048M --partition=p --mem=3G ")
            && calls[3].contains("glint-bundle merge"),
        "{}",
        calls[3]
    );
    // A node of 1 CPU and 1000 MB: no default asks for more, so no job waits forever.
    let calls = submit_calls(1, 1000, &[], &[]);
    for call in &calls[..3] {
        assert!(call.contains("--cpus-per-task=1 --mem=1000M "), "{call}");
    }
    // The user's own sizes are taken as given.
    let env = [
        ("GLINT_CPUS", "3"),
        ("GLINT_MEM", "5G"),
        ("GLINT_RADIOSITY_MEM", "20G"),
    ];
    let calls = submit_calls(1, 1000, &env, &[]);
    assert!(
        calls[0].contains("--cpus-per-task=3 --mem=5G "),
        "{}",
        calls[0]
    );
    assert!(
        calls[1].contains("--cpus-per-task=3 --mem=20G "),
        "{}",
        calls[1]
    );
}
