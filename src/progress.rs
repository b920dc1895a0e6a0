//! Progress reporting and cancellation, kept out of the kernels: a baker takes a
//! [`Progress`] and checks [`Progress::cancelled`] between work items; binaries supply a
//! terminal progress bar (or quiet logs) and a Ctrl-C flag.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// Receives progress from long work. Implementations must be cheap and thread-safe.
pub trait Progress: Sync {
    /// A new phase of `total` units begins (e.g. "bounce 2", texel count).
    fn phase(&self, name: &str, total: u64);
    /// `n` more units of the current phase are done.
    fn advance(&self, n: u64);
    /// Whether the user asked to stop (Ctrl-C): work should return [`Cancelled`] soon.
    fn cancelled(&self) -> bool {
        false
    }
}

/// Work stopped at the user's request; nothing was written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("interrupted: nothing was written")]
pub struct Cancelled;

/// Reports nothing and is never cancelled (tests, library use).
pub struct Silent;

impl Progress for Silent {
    fn phase(&self, _: &str, _: u64) {}
    fn advance(&self, _: u64) {}
}

/// A progress bar with ETA on a terminal, a log line per phase otherwise; cancelled by
/// Ctrl-C once [`TerminalProgress::new`] has installed the handler.
pub struct TerminalProgress {
    bar: indicatif::ProgressBar,
    stop: Arc<AtomicBool>,
}

impl TerminalProgress {
    /// A reporter that also turns Ctrl-C into a cancellation request (a second Ctrl-C
    /// is not needed: bakers stop between work items within moments). Make one per process:
    /// only the first one's Ctrl-C handler is installed, so a later one is never cancelled.
    pub fn new() -> TerminalProgress {
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        if let Err(e) = ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst)) {
            log::debug!("Ctrl-C handler not installed: {e}");
        }
        let bar = if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
            let bar = indicatif::ProgressBar::new(0);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{msg:>16} [{bar:40}] {percent:>3}% ETA {eta}",
                )
                .expect("valid template")
                .progress_chars("=> "),
            );
            bar
        } else {
            indicatif::ProgressBar::hidden()
        };
        TerminalProgress { bar, stop }
    }

    /// Removes the bar from the terminal.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

impl Default for TerminalProgress {
    fn default() -> Self {
        Self::new()
    }
}

impl Progress for TerminalProgress {
    fn phase(&self, name: &str, total: u64) {
        if self.bar.is_hidden() {
            log::info!("{name} ({total} items)");
        }
        self.bar.set_message(name.to_owned());
        self.bar.set_length(total);
        self.bar.set_position(0);
    }

    fn advance(&self, n: u64) {
        self.bar.inc(n);
    }

    fn cancelled(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }
}
