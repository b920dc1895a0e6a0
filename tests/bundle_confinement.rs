//! Nothing outside a bundle folder is read, whatever the bundle holds: every field that names
//! a file (manifest asset paths, stage folders and names, scene.json's `geometry`, the glTF's
//! buffer and image `uri`s, the paths index files pass to `Bundle::read_stage_file`) is
//! pointed outside with `..`, an absolute path or a symbolic link, and `glint-bundle verify`,
//! `glint-bundle stats` and the viewer's loader must each refuse the bundle. The files
//! outside are FIFOs (opening one to read blocks, so a tool that opens it hangs and the test
//! sees the hang) or canaries that would load fine (so a tool that reads one accepts the
//! bundle and the test sees that).
#![cfg(all(unix, feature = "view"))]

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use glint::bundle::{Bundle, MANIFEST};
use glint::progress::Silent;
use glint::scene::Scene;
use serde_json::Value;

/// Longest a tool may take on these small bundles before it counts as blocked on a FIFO.
const HANG: Duration = Duration::from_secs(60);

/// A 1×1 PNG.
fn png() -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    image::RgbaImage::from_pixel(1, 1, image::Rgba([200, 100, 50, 255]))
        .write_to(&mut out, image::ImageFormat::Png)
        .unwrap();
    out.into_inner()
}

/// The room of `common::write_room` (a `.gltf` with the external buffer `room.bin`) plus an
/// external image `tex.png`, baked into a bundle with its scene and radiosity stages; baked
/// once per run, copied by each case.
fn baked() -> &'static Path {
    static BUNDLE: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    &BUNDLE
        .get_or_init(|| {
            let tmp = tempfile::tempdir().unwrap();
            let src = tmp.path().join("src");
            std::fs::create_dir(&src).unwrap();
            let gltf = common::write_room(&src);
            let scene_json =
                common::write_scene(&src, r#"{ "version": 1, "geometry": "room.gltf" }"#);
            let mut doc: Value = serde_json::from_slice(&std::fs::read(&gltf).unwrap()).unwrap();
            doc["images"] = serde_json::json!([{ "uri": "tex.png" }]);
            std::fs::write(&gltf, serde_json::to_vec_pretty(&doc).unwrap()).unwrap();
            std::fs::write(src.join("tex.png"), png()).unwrap();
            let scene = Scene::load(&scene_json).unwrap();
            let bundle = tmp.path().join("room.glint");
            glint::bake::scene_stage::bake(&scene, &bundle, false).unwrap();
            let settings = glint::scene::desc::RadiositySettings {
                texel_density: 2.0,
                ..common::quick_radiosity(1)
            };
            glint::bake::radiosity_stage::bake(&scene, &bundle, &settings, false, &Silent).unwrap();
            (tmp, bundle)
        })
        .1
}

/// A fresh copy of the baked bundle, and beside it (outside it) a folder `outside/` holding
/// a FIFO `fifo`, canaries `canary.png` and `canary.bin` (copies of the bundle's image and
/// buffer, so reading them would succeed) and `canary.gltf` (the glTF with absolute URIs to
/// the canaries).
struct Case {
    _tmp: tempfile::TempDir,
    bundle: PathBuf,
    outside: PathBuf,
}

impl Case {
    fn new() -> Case {
        let tmp = tempfile::tempdir().unwrap();
        let bundle = tmp.path().join("b.glint");
        common::copy_dir(baked(), &bundle);
        let outside = tmp.path().join("outside");
        std::fs::create_dir(&outside).unwrap();
        let fifo = std::ffi::CString::new(outside.join("fifo").to_str().unwrap()).unwrap();
        assert_eq!(unsafe { libc::mkfifo(fifo.as_ptr(), 0o644) }, 0);
        let case = Case {
            _tmp: tmp,
            bundle,
            outside,
        };
        std::fs::write(case.outside.join("canary.png"), case.stage_file("tex.png")).unwrap();
        std::fs::write(case.outside.join("canary.bin"), case.stage_file("room.bin")).unwrap();
        let mut doc: Value = serde_json::from_slice(&case.stage_file("room.gltf")).unwrap();
        doc["buffers"][0]["uri"] = case.out("canary.bin").into();
        doc["images"][0]["uri"] = case.out("canary.png").into();
        std::fs::write(
            case.outside.join("canary.gltf"),
            serde_json::to_vec(&doc).unwrap(),
        )
        .unwrap();
        case
    }

    /// The absolute path of `name` outside the bundle.
    fn out(&self, name: &str) -> String {
        self.outside.join(name).to_str().unwrap().to_string()
    }

    fn manifest(&self) -> Value {
        serde_json::from_slice(&std::fs::read(self.bundle.join(MANIFEST)).unwrap()).unwrap()
    }

    fn set_manifest(&self, m: &Value) {
        std::fs::write(
            self.bundle.join(MANIFEST),
            serde_json::to_vec_pretty(m).unwrap(),
        )
        .unwrap();
    }

    /// The folder of stage `stage`.
    fn folder(&self, stage: &str) -> PathBuf {
        self.bundle
            .join(self.manifest()["stages"][stage]["dir"].as_str().unwrap())
    }

    fn stage_file(&self, rel: &str) -> Vec<u8> {
        std::fs::read(self.folder("scene").join(rel)).unwrap()
    }

    /// Rewrites scene stage file `rel` with `edit` and records its new size and hash, as a
    /// forger would.
    fn forge_json(&self, rel: &str, edit: impl Fn(&mut Value)) {
        let mut doc: Value = serde_json::from_slice(&self.stage_file(rel)).unwrap();
        edit(&mut doc);
        let bytes = serde_json::to_vec_pretty(&doc).unwrap();
        std::fs::write(self.folder("scene").join(rel), &bytes).unwrap();
        let mut m = self.manifest();
        let logical = format!("scene/{rel}");
        for a in m["stages"]["scene"]["assets"].as_array_mut().unwrap() {
            if a["path"] == logical.as_str() {
                a["bytes"] = bytes.len().into();
                a["blake3"] = blake3::hash(&bytes).to_hex().to_string().into();
            }
        }
        self.set_manifest(&m);
    }

    /// Runs `glint-bundle SUB BUNDLE`: its exit code and output, or a panic when it hangs
    /// (it opened a FIFO outside the bundle).
    fn glint_bundle(&self, what: &str, sub: &str) -> (i32, String) {
        run(
            what,
            env!("CARGO_BIN_EXE_glint-bundle"),
            &[sub, self.bundle.to_str().unwrap()],
        )
    }

    /// Runs `glint-eval probe BUNDLE --points P` (it loads the bundle's scene and D).
    fn glint_eval_probe(&self, what: &str) -> (i32, String) {
        let points = self.outside.parent().unwrap().join("points.json");
        std::fs::write(&points, r#"[{"position":[0,0.01,0],"normal":[0,1,0]}]"#).unwrap();
        run(
            what,
            env!("CARGO_BIN_EXE_glint-eval"),
            &[
                "probe",
                self.bundle.to_str().unwrap(),
                "--points",
                points.to_str().unwrap(),
            ],
        )
    }

    /// The viewer's loader on the bundle: its error, or a panic when it accepts the bundle or
    /// hangs. A hung loader is left blocked on the FIFO: the test has failed anyway.
    fn view_load(&self, what: &str) -> String {
        let (tx, rx) = std::sync::mpsc::channel();
        let bundle = self.bundle.clone();
        std::thread::spawn(move || {
            let _ = tx.send(glint::view::load::load(&bundle).map(|_| ()));
        });
        match rx.recv_timeout(HANG) {
            Ok(Ok(())) => panic!("{what}: the viewer loaded the bundle"),
            Ok(Err(e)) => e.to_string(),
            Err(_) => {
                panic!("{what}: the viewer's loader hung: it opened a file outside the bundle")
            }
        }
    }

    /// `verify`, `stats`, `glint-eval probe` and the viewer's loader each refuse the bundle,
    /// and each message holds every one of `expect`.
    fn refused(&self, what: &str, expect: &[&str]) {
        for sub in ["verify", "stats", "probe"] {
            let (code, text) = match sub {
                "probe" => self.glint_eval_probe(what),
                _ => self.glint_bundle(what, sub),
            };
            assert_ne!(code, 0, "{what}: `{sub}` accepted it:\n{text}");
            for e in expect {
                assert!(text.contains(e), "{what}: `{sub}` says:\n{text}");
            }
        }
        let e = self.view_load(what);
        for x in expect {
            assert!(e.contains(x), "{what}: the viewer says: {e}");
        }
    }
}

/// Runs `exe ARGS…`: its exit code and output, or a panic when it hangs (it opened a FIFO
/// outside the bundle).
fn run(what: &str, exe: &str, args: &[&str]) -> (i32, String) {
    let mut child = Command::new(exe)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > HANG {
            child.kill().unwrap();
            child.wait().unwrap();
            panic!("{what}: `{exe} {args:?}` hung: it opened a file outside the bundle");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = child.wait_with_output().unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    (out.status.code().unwrap_or(-1), text)
}

#[test]
fn the_unchanged_copy_is_accepted_by_every_tool() {
    let case = Case::new();
    for sub in ["verify", "stats"] {
        let (code, text) = case.glint_bundle("unchanged", sub);
        assert_eq!(code, 0, "{text}");
    }
    let (code, text) = case.glint_eval_probe("unchanged");
    assert_eq!(code, 0, "{text}");
    glint::view::load::load(&case.bundle).unwrap_or_else(|e| panic!("{e}"));
}

#[test]
fn gltf_uris_leaving_the_stage_or_naming_unlisted_files_are_refused() {
    for (field, uri) in [
        ("images[0].uri", "../../outside/canary.png"),
        ("images[0].uri", "%2E%2E/%2E%2E/outside/canary.png"),
        ("images[0].uri", "ABS:canary.png"),
        ("images[0].uri", "ABS:fifo"),
        ("buffers[0].uri", "../../outside/canary.bin"),
        ("buffers[0].uri", "ABS:canary.bin"),
        ("buffers[0].uri", "ABS:fifo"),
        ("images[0].uri", "unlisted.png"),
        ("buffers[0].uri", "tex.png"),
    ] {
        let case = Case::new();
        let uri = match uri.strip_prefix("ABS:") {
            Some(name) => case.out(name),
            None => uri.to_string(),
        };
        std::fs::write(case.folder("scene").join("unlisted.png"), png()).unwrap();
        let (array, _) = field.split_once('[').unwrap();
        case.forge_json("room.gltf", |d| d[array][0]["uri"] = uri.clone().into());
        case.refused(&format!("{field} = {uri}"), &["room.gltf", field, &uri]);
    }
}

#[test]
fn a_scene_json_geometry_outside_the_stage_is_refused() {
    for geometry in ["../../outside/canary.gltf", "ABS:canary.gltf", "ABS:fifo"] {
        let case = Case::new();
        let geometry = match geometry.strip_prefix("ABS:") {
            Some(name) => case.out(name),
            None => geometry.to_string(),
        };
        case.forge_json("scene.json", |d| d["geometry"] = geometry.clone().into());
        case.refused(
            &format!("geometry = {geometry}"),
            &["scene.json", "geometry", &geometry],
        );
    }
}

#[test]
fn manifest_paths_and_stage_folders_leaving_the_bundle_are_refused() {
    type Edit = fn(&Case, &mut Value);
    let cases: [(&str, Edit); 5] = [
        ("asset path with ..", |_, m| {
            m["stages"]["radiosity"]["assets"][0]["path"] = "radiosity/../../outside/fifo".into();
        }),
        ("absolute asset path", |c, m| {
            m["stages"]["radiosity"]["assets"][0]["path"] = c.out("fifo").into();
        }),
        ("stage dir with ..", |_, m| {
            m["stages"]["radiosity"]["dir"] = "../outside".into();
        }),
        ("absolute stage dir", |c, m| {
            m["stages"]["radiosity"]["dir"] = c.outside.to_str().unwrap().into();
        }),
        ("stage named ..", |_, m| {
            let mut s = m["stages"]["radiosity"].take();
            s.as_object_mut().unwrap().remove("dir");
            s["assets"][0]["path"] = "../outside/fifo".into();
            m["stages"].as_object_mut().unwrap().remove("radiosity");
            m["stages"][".."] = s;
        }),
    ];
    for (what, edit) in cases {
        let case = Case::new();
        let mut m = case.manifest();
        edit(&case, &mut m);
        case.set_manifest(&m);
        case.refused(what, &["manifest.json"]);
    }
}

#[test]
fn symbolic_links_out_of_the_bundle_are_refused_unfollowed() {
    // An asset file, a stage folder, a folder inside a stage and the manifest, each a link to
    // FIFOs outside (a folder of FIFOs for the folders).
    let fifos = |dir: &Path, like: &Path| {
        std::fs::create_dir_all(dir).unwrap();
        for e in std::fs::read_dir(like).unwrap() {
            let name = e.unwrap().file_name();
            let path = std::ffi::CString::new(dir.join(name).to_str().unwrap()).unwrap();
            assert_eq!(unsafe { libc::mkfifo(path.as_ptr(), 0o644) }, 0);
        }
    };
    let link = |target: &Path, at: &Path| {
        if at.is_dir() {
            std::fs::remove_dir_all(at).unwrap();
        } else {
            std::fs::remove_file(at).unwrap();
        }
        std::os::unix::fs::symlink(target, at).unwrap();
    };

    let case = Case::new();
    link(
        &case.outside.join("fifo"),
        &case.folder("scene").join("tex.png"),
    );
    case.refused("image file linked outside", &["tex.png", "symbolic link"]);

    let case = Case::new();
    let radiosity = case.folder("radiosity");
    let target = case.outside.join("radiosity");
    fifos(&target, &radiosity);
    link(&target, &radiosity);
    case.refused("stage folder linked outside", &["symbolic link"]);

    let case = Case::new();
    let sub = case.folder("scene").join("sub");
    fifos(&case.outside.join("sub"), &case.folder("scene"));
    std::os::unix::fs::symlink(case.outside.join("sub"), &sub).unwrap();
    let mut m = case.manifest();
    let assets = m["stages"]["scene"]["assets"].as_array_mut().unwrap();
    let mut extra = assets[0].clone();
    extra["path"] = "scene/sub/scene.json".into();
    assets.push(extra);
    case.set_manifest(&m);
    case.refused("folder inside a stage linked outside", &["symbolic link"]);

    let case = Case::new();
    link(&case.outside.join("fifo"), &case.bundle.join(MANIFEST));
    case.refused(
        "manifest linked outside",
        &["manifest.json", "symbolic link"],
    );
}

#[test]
fn paths_index_files_pass_to_the_bundle_stay_in_their_stage() {
    // materials/index.json, srdm/index.json and radiance cameras.json name their files by
    // paths inside the stage, read through `read_stage_file`, which reads only assets the
    // manifest lists (and their paths never leave the bundle).
    let case = Case::new();
    let b = Bundle::open(&case.bundle).unwrap();
    for rel in [
        "../../outside/fifo".to_string(),
        "../scene/scene.json".to_string(),
        case.out("fifo"),
        "sub/../../outside/fifo".into(),
    ] {
        let e = b
            .read_stage_file("radiosity", &rel)
            .unwrap_err()
            .to_string();
        assert!(e.contains("not listed"), "{rel}: {e}");
    }
    assert!(b.read_stage_file("radiosity", "atlas.bin").is_ok());
}

#[test]
fn a_shard_whose_unit_marker_links_outside_is_refused_unfollowed() {
    let case = Case::new();
    std::os::unix::fs::symlink(case.outside.join("fifo"), case.bundle.join("unit.json")).unwrap();
    let out = case.outside.parent().unwrap().join("merged.glint");
    let (code, text) = run(
        "unit.json linked outside",
        env!("CARGO_BIN_EXE_glint-bundle"),
        &[
            "merge",
            out.to_str().unwrap(),
            case.bundle.to_str().unwrap(),
        ],
    );
    assert_ne!(code, 0, "{text}");
    assert!(
        text.contains("unit.json") && text.contains("symbolic link"),
        "{text}"
    );
}

#[test]
fn index_file_references_outside_their_stage_are_refused_by_verify_and_the_reader() {
    let corpus = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus/srdm_index/index.json");
    let index: Value = serde_json::from_slice(&std::fs::read(corpus).unwrap()).unwrap();
    for reference in [
        "../../outside/fifo".to_string(),
        "ABS:fifo".into(),
        "../scene/scene.json".into(),
        "TableTop/unlisted.srdm".into(),
    ] {
        let case = Case::new();
        let reference = match reference.strip_prefix("ABS:") {
            Some(name) => case.out(name),
            None => reference,
        };
        // An SRDM stage whose index names `reference` for view 0's .srdm file.
        let mut ix = index.clone();
        ix["views"][0]["srdm"] = reference.clone().into();
        let files: [(&str, &str, Vec<u8>); 2] = [
            ("index.json", "srdm-index", serde_json::to_vec(&ix).unwrap()),
            ("TableTop/view0.exr", "impostor-exr", b"capture".to_vec()),
        ];
        let folder = case.bundle.join("srdm.1");
        std::fs::create_dir_all(folder.join("TableTop")).unwrap();
        std::fs::write(folder.join("TableTop/unlisted.srdm"), b"unlisted").unwrap();
        let mut m = case.manifest();
        let mut stage = m["stages"]["radiosity"].clone();
        stage["dir"] = "srdm.1".into();
        stage["assets"] = files
            .iter()
            .map(|(rel, kind, bytes)| {
                std::fs::write(folder.join(rel), bytes).unwrap();
                serde_json::json!({ "path": format!("srdm/{rel}"), "kind": kind,
                    "bytes": bytes.len(), "blake3": blake3::hash(bytes).to_hex().to_string() })
            })
            .collect();
        m["stages"]["srdm"] = stage;
        case.set_manifest(&m);

        let what = format!("views[0].srdm = {reference}");
        let (code, text) = case.glint_bundle(&what, "verify");
        assert_ne!(code, 0, "{what}: verify accepted it:\n{text}");
        assert!(
            text.contains("srdm/index.json")
                && text.contains("views[0].srdm")
                && text.contains(&reference),
            "{what}: verify says:\n{text}"
        );
        let b = Bundle::open(&case.bundle).unwrap();
        let e = match glint::srdm::index::load(&b) {
            Ok(_) => panic!("{what}: the SRDM reader accepted it"),
            Err(e) => e.to_string(),
        };
        assert!(e.contains("not listed"), "{what}: the SRDM reader says {e}");
    }
}
