//! What every glint binary shares: logging set-up and turning a result into an exit code.

use std::io::Write;
use std::process::ExitCode;

/// Logs to stderr at `info` (or `RUST_LOG`), without timestamps when stderr is not a terminal.
pub fn init_logging() {
    let env = env_logger::Env::default().default_filter_or("info");
    let _ = env_logger::Builder::from_env(env)
        .format_timestamp(None)
        .format_target(false)
        .try_init();
}

/// Keeps GPU start-up quiet where no Wayland session exists. Mesa's Vulkan device-select
/// layer (an implicit layer, on with every Mesa driver, lavapipe included) connects to a
/// Wayland compositor to find the default GPU; without `XDG_RUNTIME_DIR`, libwayland prints
/// "error: XDG_RUNTIME_DIR is invalid or not set in the environment." on stderr, although
/// nothing fails. There is no compositor to ask then, so the layer is turned off
/// (`NODEVICE_SELECT=1`, Mesa's own switch) unless the user set that variable. Call it first in
/// `main`, before any thread starts (it sets an environment variable).
pub fn quiet_gpu_probe() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none()
        && std::env::var_os("NODEVICE_SELECT").is_none()
    {
        // SAFETY: called at the start of `main`, before any other thread exists, so nothing
        // reads the environment concurrently.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}

/// Sizes rayon's global pool to the CPUs Slurm granted the task (`SLURM_CPUS_PER_TASK`), since
/// without CPU binding the task sees every CPU of the node. `RAYON_NUM_THREADS`, when set, wins
/// (rayon reads it itself). Call it in `main` before any parallel work.
pub fn init_threads() {
    let rayon = std::env::var("RAYON_NUM_THREADS").ok();
    let slurm = std::env::var("SLURM_CPUS_PER_TASK").ok();
    if let Some(n) = threads_granted(rayon.as_deref(), slurm.as_deref()) {
        match rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
        {
            Ok(()) => log::info!("threads: {n} (SLURM_CPUS_PER_TASK)"),
            Err(e) => log::warn!("SLURM_CPUS_PER_TASK={n} not applied: {e}"),
        }
    }
}

/// The thread count Slurm's grant asks for: `SLURM_CPUS_PER_TASK` when it is a positive count
/// and `RAYON_NUM_THREADS` is unset or empty; `None` leaves rayon's own choice.
fn threads_granted(rayon: Option<&str>, slurm: Option<&str>) -> Option<usize> {
    if rayon.is_some_and(|r| !r.trim().is_empty()) {
        return None;
    }
    slurm?.trim().parse().ok().filter(|&n| n > 0)
}

/// The exit code of a program stopped by Ctrl-C: 128 + SIGINT, what a shell reports.
pub const INTERRUPTED: u8 = 130;

/// Maps a binary's result to its exit code: 0 on success, [`INTERRUPTED`] when Ctrl-C stopped
/// it ([`crate::progress::is_interruption`]), 1 on another error (each printed with its whole
/// chain of causes). A closed pipe (`glint-bundle ls | head`) is not an error.
pub fn exit_code(result: anyhow::Result<ExitCode>) -> ExitCode {
    match result {
        Ok(code) => code,
        Err(e) if is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) if crate::progress::is_interruption(&e) => {
            let _ = writeln!(std::io::stderr(), "error: {}", chain_message(&e));
            ExitCode::from(INTERRUPTED)
        }
        Err(e) => {
            let _ = writeln!(std::io::stderr(), "error: {}", chain_message(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes joined by ": ", leaving out a cause whose text the message
/// already holds (library errors often print their source themselves).
fn chain_message(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if out.contains(&text) {
            continue;
        }
        if !out.is_empty() {
            out += ": ";
        }
        out += &text;
    }
    out
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// What every bake tool takes besides `--bundle`: the scene and how to bake it. Flattened
/// into [`BakeArgs`] and [`GlintBakeArgs`], after their `--bundle` (so `--help` lists
/// `--bundle` first).
#[derive(clap::Args, Debug, Clone)]
pub struct BakeOptions {
    /// The scene description (scene.json).
    #[arg(value_name = "SCENE.json")]
    pub scene: std::path::PathBuf,
    /// Quality preset; default: the scene's `bake.quality`, else `default`.
    #[arg(long, value_parser = parse_quality)]
    pub quality: Option<crate::settings::Quality>,
    /// Replace stages the bundle holds from another scene.
    #[arg(long)]
    pub force: bool,
    /// Print a JSON report on stdout instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Options every bake tool takes (`#[command(flatten)]`).
#[derive(clap::Args, Debug, Clone)]
pub struct BakeArgs {
    /// The bundle folder to write into (created if missing), e.g. out/cornell-box.glint.
    #[arg(long, value_name = "OUT.glint")]
    pub bundle: std::path::PathBuf,
    #[command(flatten)]
    pub options: BakeOptions,
}

/// `glint-bake`'s options: [`BakeOptions`], `--bundle` (needed only for a bake), and the
/// work-unit modes (`--plan`, `--unit`, `--units`).
#[derive(clap::Args, Debug, Clone)]
pub struct GlintBakeArgs {
    /// The bundle folder to write into (created if missing), e.g. out/cornell-box.glint; with
    /// `--unit`, the unit's shard (e.g. shards/radiosity.glint); with `--units`, where the
    /// shards are merged.
    #[arg(long, value_name = "OUT.glint", required_unless_present_any = ["plan", "units"])]
    pub bundle: Option<std::path::PathBuf>,
    #[command(flatten)]
    pub options: BakeOptions,
    /// Print the work units the bake splits into (ID, wave, inputs' hashes, cost estimate)
    /// instead of baking; with --json the whole plan.
    #[arg(long, conflicts_with_all = ["unit", "units"])]
    pub plan: bool,
    /// With --plan: print only the IDs of the units of wave W (0: they read no other unit;
    /// 1: they read the `radiosity` unit's shard), one a line.
    #[arg(long, value_name = "W", requires = "plan")]
    pub wave: Option<u32>,
    /// Bake one work unit into the shard --bundle names (up to date: nothing is baked).
    #[arg(long, value_name = "ID", conflicts_with = "units")]
    pub unit: Option<String>,
    /// With --unit: the `radiosity` unit's shard to read D from (default: `radiosity.glint`
    /// beside the shard).
    #[arg(long, value_name = "SHARD.glint", requires = "unit")]
    pub d_shard: Option<std::path::PathBuf>,
    /// Bake every work unit into DIR/ID.glint, one after another, leaving up-to-date units
    /// alone; then merge them into --bundle when given.
    #[arg(long, value_name = "DIR")]
    pub units: Option<std::path::PathBuf>,
}

/// Parses an image size `WIDTHxHEIGHT` (e.g. `720x486`), each side 1..=16384: the one
/// `--size` parser of every tool.
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("{s:?} is not WIDTHxHEIGHT, e.g. 720x486");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if !(1..=16384).contains(&w) || !(1..=16384).contains(&h) {
        return Err(format!("{s:?}: each side must be 1..=16384 pixels"));
    }
    Ok((w, h))
}

/// Parses a preset name (`draft`, `default`, `high`): the one `--quality` parser.
pub fn parse_quality(s: &str) -> Result<crate::settings::Quality, String> {
    crate::settings::Quality::ALL
        .into_iter()
        .find(|q| q.name() == s)
        .ok_or_else(|| format!("{s:?} is not a preset: use draft, default or high"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slurm_cpus_set_the_thread_count_unless_rayon_num_threads_does() {
        assert_eq!(threads_granted(None, Some("2")), Some(2));
        assert_eq!(threads_granted(Some(""), Some(" 3 ")), Some(3));
        assert_eq!(threads_granted(Some("8"), Some("2")), None);
        assert_eq!(threads_granted(None, None), None);
        assert_eq!(threads_granted(None, Some("0")), None);
        assert_eq!(threads_granted(None, Some("2(x3)")), None);
    }

    #[test]
    fn size_parses_and_names_the_problem() {
        assert_eq!(parse_size("720x486"), Ok((720, 486)));
        assert_eq!(parse_size("64X48"), Ok((64, 48)));
        assert!(parse_size("720").unwrap_err().contains("WIDTHxHEIGHT"));
        assert!(parse_size("0x10").unwrap_err().contains("1..=16384"));
        assert!(parse_size("axb").is_err());
    }
}
