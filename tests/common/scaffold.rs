//! Scaffolding every test and bench shares: paths in the repository, the headless adapter,
//! announced skips and the one golden-update switch. Benches include this file by path.

use std::io::Write;
use std::path::{Path, PathBuf};

/// `rel` under the repository root.
pub fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// The headless adapter (a hardware GPU when there is one, else Mesa's lavapipe), with
/// timestamp queries when it has them. Without an adapter the test fails with the `GpuError`
/// message: a GPU test never passes without having run.
#[cfg(feature = "view")]
pub fn gpu() -> glint::view::gpu::Gpu {
    let _ = env_logger::builder().is_test(true).try_init();
    glint::view::gpu::Gpu::headless_with_features(wgpu::Features::TIMESTAMP_QUERY)
        .unwrap_or_else(|e| panic!("{e}"))
}

/// Announces that the running test is skipped and why, on the process's stderr directly (past
/// libtest's output capture, so a plain `cargo test` shows it), naming the test (libtest runs
/// each test on a thread named after it). Call it right before the early `return`.
pub fn skip(why: &str) {
    let thread = std::thread::current();
    let test = thread.name().unwrap_or("<unnamed test>");
    let _ = writeln!(std::io::stderr(), "SKIPPED {test}: {why}");
}

/// The environment variable that makes tests rewrite what they compare against (the golden
/// images in `tests/golden/`, the JSON schemas in `schemas/`, the teapot's comparison images)
/// instead of comparing: `GLINT_UPDATE_GOLDENS=1 cargo test --test NAME`.
pub const UPDATE_GOLDENS: &str = "GLINT_UPDATE_GOLDENS";

/// Whether [`UPDATE_GOLDENS`] is set to `1`.
pub fn update_goldens() -> bool {
    std::env::var_os(UPDATE_GOLDENS).is_some_and(|v| v == "1")
}

/// `target/golden-failures/NAME/`, created: where a failing image comparison writes its images.
pub fn failure_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .parent()
        .expect("CARGO_TARGET_TMPDIR lies in the target folder")
        .join("golden-failures")
        .join(name);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
