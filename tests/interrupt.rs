//! The bake tools in a pipe or a CI log and under Ctrl-C: progress lines with done/total, rate
//! and ETA where stderr is not a terminal, and a real SIGINT that stops `glint-bake` with exit
//! 130 and a message that says which stages it wrote.

mod common;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

use common::{lit_floor, write_scene};
use glint::bundle::Bundle;

/// [`lit_floor`] with `density` texels per metre and `rays` gathering rays per texel: a
/// radiosity stage as long as wanted, in as many work items as wanted.
fn lit_floor_with(dir: &Path, density: u32, rays: u32) -> PathBuf {
    lit_floor(dir);
    write_scene(
        dir,
        &format!(
            r#"{{ "version": 1, "geometry": "box.gltf",
                  "bake": {{ "quality": "draft",
                             "radiosity": {{ "texel_density": {density}, "rays": {rays}, "target_error": 0 }} }} }}"#
        ),
    )
}

#[test]
fn a_bake_in_a_log_prints_progress_lines_with_rate_and_eta() {
    let dir = tempfile::tempdir().unwrap();
    let scene = lit_floor_with(dir.path(), 16, 512);
    let bundle = dir.path().join("log.glint");
    // stderr is a pipe here, as in CI; a short interval stands in for the 10 s.
    let out = Command::new(env!("CARGO_BIN_EXE_glint-bake"))
        .arg(&scene)
        .arg("--bundle")
        .arg(&bundle)
        .env(glint::progress::LOG_INTERVAL_VAR, "0.001")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let lines: Vec<&str> = err.lines().collect();
    let first = lines
        .iter()
        .position(|l| l.contains("gathering ("))
        .unwrap_or_else(|| panic!("no gathering phase:\n{err}"));
    let progress: Vec<&&str> = lines[first..]
        .iter()
        .take_while(|l| !l.contains("bouncing ("))
        .filter(|l| l.contains("gathering: ") && l.contains("/s, ETA "))
        .collect();
    assert!(!progress.is_empty(), "no progress line:\n{err}");
    // done/total (percent), rate, ETA.
    let p = progress[0];
    let counts = p.split("gathering: ").nth(1).unwrap();
    let (done, rest) = counts.split_once('/').unwrap();
    let total = rest.split_once(' ').unwrap().0;
    let (done, total): (u64, u64) = (done.parse().unwrap(), total.parse().unwrap());
    assert!(done < total, "{p}");
    assert!(
        lines
            .iter()
            .any(|l| l.contains(&format!("gathering: {total}/{total} in "))),
        "no last line:\n{err}"
    );
}

/// Runs `exe` (a bake tool) on a long radiosity bake into `bundle`, sends it SIGINT part-way
/// through gathering, and returns its exit code and stderr.
#[cfg(unix)]
fn interrupted_mid_gathering(exe: &str, scene: &Path, bundle: &Path) -> (Option<i32>, String) {
    let mut child = Command::new(exe)
        .arg(scene)
        .arg("--bundle")
        .arg(bundle)
        .env(glint::progress::LOG_INTERVAL_VAR, "0.1")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (tx, rx) = mpsc::channel();
    let stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut all = String::new();
        for line in BufReader::new(stderr).lines() {
            let line = line.unwrap();
            let _ = tx.send(line.clone());
            all += &line;
            all.push('\n');
        }
        all
    });
    // Wait until the radiosity stage is part-way through gathering (a progress line comes
    // only before the total): the scene stage is committed by then.
    loop {
        match rx.recv_timeout(Duration::from_secs(300)) {
            Ok(line) if line.contains("gathering: ") => break,
            Ok(_) => {}
            Err(e) => {
                let _ = child.kill();
                panic!("{exe} never gathered: {e}");
            }
        }
    }
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let status = child.wait().unwrap();
    (status.code(), reader.join().unwrap())
}

#[cfg(unix)]
#[test]
fn sigint_stops_glint_bake_with_130_and_says_which_stages_it_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let scene = lit_floor_with(dir.path(), 128, 1024);
    let bundle = dir.path().join("stopped.glint");
    let (code, err) = interrupted_mid_gathering(env!("CARGO_BIN_EXE_glint-bake"), &scene, &bundle);
    assert_eq!(code, Some(130), "{err}");
    // glint-bake bakes through its unit cache and assembles the bundle last: stopped while
    // gathering, it wrote no bundle, and the finished scene unit is kept in the cache.
    let last = err.lines().last().unwrap_or_default();
    assert!(
        last.starts_with("error: interrupted: nothing was written; ")
            && last.contains("stopped.glint is as before")
            && last.contains("finished work unit(s) scene kept in ")
            && last.contains("stopped.glint.units"),
        "{err}"
    );
    // What it says is what the disk holds: no stage in the bundle; the scene unit's shard, complete.
    assert!(Bundle::open(&bundle).map_or(true, |b| b.manifest().stages.is_empty()));
    let cache = dir.path().join("stopped.glint.units");
    let shard = Bundle::open(cache.join("scene.glint")).unwrap();
    assert!(shard.stage("scene").is_some());
    assert!(cache.join("scene.glint/unit.json").is_file());
    assert!(!cache.join("radiosity.glint/unit.json").exists());
}

#[cfg(unix)]
#[test]
fn sigint_stops_a_single_stage_tool_the_same_way() {
    let dir = tempfile::tempdir().unwrap();
    let scene = lit_floor_with(dir.path(), 128, 1024);
    let bundle = dir.path().join("radiosity.glint");
    let (code, err) =
        interrupted_mid_gathering(env!("CARGO_BIN_EXE_glint-radiosity"), &scene, &bundle);
    assert_eq!(code, Some(130), "{err}");
    // The tool writes the scene stage before its own: that much was written.
    let last = err.lines().last().unwrap_or_default();
    assert!(
        last.starts_with("error: interrupted: wrote stage scene of ")
            && last.contains("radiosity.glint (complete)"),
        "{err}"
    );
    let b = Bundle::open(&bundle).unwrap();
    assert!(b.stage("radiosity").is_none());
    assert!(b.verify().is_empty(), "{:?}", b.verify());
}
