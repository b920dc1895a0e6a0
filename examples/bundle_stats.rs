//! Opens a bundle and lists its stages, each with its assets: the smallest program that reads
//! a bundle through the library.
//!
//! ```sh
//! cargo run --example bundle_stats -- out/glossy-room.glint
//! ```
//!
//! Prints `scene NAME (format VERSION)`, then per stage a line `STAGE: N assets, BYTES bytes,
//! baked in SECONDS s` and one indented line per asset: its logical path, kind and size.
//! Exit code 2 on a wrong command line, 1 when the bundle cannot be read.

use std::path::PathBuf;
use std::process::ExitCode;

use glint::bundle::Bundle;

fn main() -> ExitCode {
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    let [dir] = args.as_slice() else {
        eprintln!("usage: bundle_stats BUNDLE");
        return ExitCode::from(2);
    };
    // Opening reads and checks the manifest and holds its stage folders while it lives.
    let bundle = match Bundle::open(dir) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let manifest = bundle.manifest();
    println!(
        "scene {} (format {})",
        manifest.scene_name, manifest.format_version
    );
    for (name, stage) in &manifest.stages {
        let bytes: u64 = stage.assets.iter().map(|a| a.bytes).sum();
        println!(
            "{name}: {} assets, {bytes} bytes, baked in {:.2} s",
            stage.assets.len(),
            stage.bake_seconds
        );
        for asset in &stage.assets {
            println!("  {} {} {}", asset.path, asset.kind, asset.bytes);
        }
    }
    ExitCode::SUCCESS
}
