//! Progress reporting and cancellation, kept out of the kernels: a baker takes a
//! [`Progress`] and checks [`Progress::cancelled`] between work items; binaries supply a
//! terminal progress bar (or, where stderr is a pipe or a CI log, a progress line at most every
//! [`LOG_INTERVAL`]) and a Ctrl-C flag.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Mutex, Once};
use std::time::{Duration, Instant};

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

/// Work stopped at the user's request, saying exactly what was written: a binary that gets
/// this (or a [`Cancelled`]) in its error's causes exits 130, as a shell reports a program
/// stopped by Ctrl-C ([`crate::cli::exit_code`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("interrupted: {written}")]
pub struct Interrupted {
    /// What was written before the stop, in words.
    pub written: String,
}

/// Whether `e` is a stop at the user's request: a [`Cancelled`] or [`Interrupted`] among its
/// causes, or any error once Ctrl-C was pressed (work may fail rather than stop cleanly).
pub fn is_interruption(e: &anyhow::Error) -> bool {
    interrupted()
        || e.chain()
            .any(|c| c.is::<Cancelled>() || c.is::<Interrupted>())
}

/// Reports nothing and is never cancelled (tests, library use).
pub struct Silent;

impl Progress for Silent {
    fn phase(&self, _: &str, _: u64) {}
    fn advance(&self, _: u64) {}
}

/// How often a long phase prints a progress line where stderr is not a terminal.
pub const LOG_INTERVAL: Duration = Duration::from_secs(10);

/// The environment variable that sets [`LOG_INTERVAL`] otherwise, in seconds (tests use a
/// short one to see the lines of a bake that lasts a second).
pub const LOG_INTERVAL_VAR: &str = "GLINT_PROGRESS_SECONDS";

/// Set by the process's Ctrl-C handler ([`install_interrupt_handler`]).
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Turns Ctrl-C (SIGINT) into a request to stop that [`TerminalProgress::cancelled`] and
/// [`interrupted`] report, so that work stops between items and the binary can say what it
/// wrote and exit 130. Idempotent: every reporter calls it, and a binary may call it first
/// thing in `main` so that Ctrl-C during start-up is caught too.
pub fn install_interrupt_handler() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        if let Err(e) = ctrlc::set_handler(|| INTERRUPTED.store(true, Ordering::SeqCst)) {
            log::debug!("Ctrl-C handler not installed: {e}");
        }
    });
}

/// Whether Ctrl-C was pressed since [`install_interrupt_handler`].
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::Relaxed)
}

/// A progress bar with ETA on a terminal; elsewhere a log line per phase, then a line with
/// done/total, rate and ETA at most every [`LOG_INTERVAL`] and a last line when a phase that
/// printed such lines ends. Cancelled by Ctrl-C ([`install_interrupt_handler`]).
pub struct TerminalProgress {
    bar: indicatif::ProgressBar,
    lines: Option<LogLines>,
}

impl TerminalProgress {
    /// A reporter that also turns Ctrl-C into a cancellation request (a second Ctrl-C
    /// is not needed: bakers stop between work items within moments).
    pub fn new() -> TerminalProgress {
        install_interrupt_handler();
        if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
            let bar = indicatif::ProgressBar::new(0);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{msg:>16} [{bar:40}] {percent:>3}% ETA {eta}",
                )
                .expect("valid template")
                .progress_chars("=> "),
            );
            return TerminalProgress { bar, lines: None };
        }
        let interval = std::env::var(LOG_INTERVAL_VAR)
            .ok()
            .and_then(|s| s.trim().parse::<f64>().ok())
            .filter(|s| s.is_finite() && *s >= 0.0)
            .map_or(LOG_INTERVAL, Duration::from_secs_f64);
        TerminalProgress {
            bar: indicatif::ProgressBar::hidden(),
            lines: Some(LogLines::new(interval)),
        }
    }

    /// Removes the bar from the terminal; in a log, ends the last phase's lines.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
        if let Some(line) = self.lines.as_ref().and_then(LogLines::finish) {
            log::info!("{line}");
        }
    }
}

impl Default for TerminalProgress {
    fn default() -> Self {
        Self::new()
    }
}

impl Progress for TerminalProgress {
    fn phase(&self, name: &str, total: u64) {
        if let Some(lines) = &self.lines {
            for line in lines.phase(name, total) {
                log::info!("{line}");
            }
        }
        self.bar.set_message(name.to_owned());
        self.bar.set_length(total);
        self.bar.set_position(0);
    }

    fn advance(&self, n: u64) {
        self.bar.inc(n);
        if let Some(line) = self.lines.as_ref().and_then(|l| l.advance(n)) {
            log::info!("{line}");
        }
    }

    fn cancelled(&self) -> bool {
        interrupted()
    }
}

/// The progress lines of a log (stderr not a terminal): which to print, decided from the
/// counts and the time since the phase began, so that a test can drive it with its own
/// interval. Thread-safe: bakers advance it from every worker.
pub struct LogLines {
    interval: Duration,
    epoch: Instant,
    phase: Mutex<LogPhase>,
    total: AtomicU64,
    done: AtomicU64,
    /// When the next line is due, nanoseconds after `epoch`.
    next_ns: AtomicU64,
}

struct LogPhase {
    name: String,
    started: Duration,
    /// Whether a progress line was printed: the phase then gets a last line too.
    reported: bool,
}

impl LogLines {
    /// Lines at most every `interval` per phase.
    pub fn new(interval: Duration) -> LogLines {
        LogLines {
            interval,
            epoch: Instant::now(),
            phase: Mutex::new(LogPhase {
                name: String::new(),
                started: Duration::ZERO,
                reported: false,
            }),
            total: AtomicU64::new(0),
            done: AtomicU64::new(0),
            next_ns: AtomicU64::new(u64::MAX),
        }
    }

    /// A phase of `total` items begins: its first line, after the previous phase's last line
    /// where that one printed progress and did not reach its total.
    pub fn phase(&self, name: &str, total: u64) -> Vec<String> {
        let now = self.epoch.elapsed();
        let mut lines: Vec<String> = self.end_phase(now).into_iter().collect();
        let mut p = self.phase.lock().unwrap_or_else(|e| e.into_inner());
        *p = LogPhase {
            name: name.to_owned(),
            started: now,
            reported: false,
        };
        self.total.store(total, Ordering::SeqCst);
        self.done.store(0, Ordering::SeqCst);
        self.next_ns
            .store(nanos(now + self.interval), Ordering::SeqCst);
        lines.push(format!("{name} ({total} items)"));
        lines
    }

    /// `n` more items are done: a progress line when one is due, the last line when the
    /// phase reaches its total after printing progress.
    pub fn advance(&self, n: u64) -> Option<String> {
        let before = self.done.fetch_add(n, Ordering::Relaxed);
        let done = before + n;
        let total = self.total.load(Ordering::Relaxed);
        let now = self.epoch.elapsed();
        if before < total && done >= total {
            // Exactly one call crosses the total.
            self.next_ns.store(u64::MAX, Ordering::Relaxed);
            let p = self.phase.lock().unwrap_or_else(|e| e.into_inner());
            return p
                .reported
                .then(|| last_line(&p.name, total, now - p.started));
        }
        let due = self.next_ns.load(Ordering::Relaxed);
        // Workers call this per item: only the one that claims a due line takes the lock.
        if nanos(now) < due
            || done >= total
            || self
                .next_ns
                .compare_exchange(
                    due,
                    nanos(now + self.interval),
                    Ordering::Relaxed,
                    Ordering::Relaxed,
                )
                .is_err()
        {
            return None;
        }
        let mut p = self.phase.lock().unwrap_or_else(|e| e.into_inner());
        p.reported = true;
        Some(progress_line(&p.name, done, total, now - p.started))
    }

    /// The work ends: the last phase's last line, if it printed progress and did not reach
    /// its total.
    pub fn finish(&self) -> Option<String> {
        self.end_phase(self.epoch.elapsed())
    }

    fn end_phase(&self, now: Duration) -> Option<String> {
        let mut p = self.phase.lock().unwrap_or_else(|e| e.into_inner());
        let done = self.done.load(Ordering::SeqCst);
        let total = self.total.load(Ordering::SeqCst);
        let line = (p.reported && done < total).then(|| {
            format!(
                "{}: stopped at {done}/{total} after {}",
                p.name,
                duration_words(now - p.started)
            )
        });
        p.reported = false;
        self.next_ns.store(u64::MAX, Ordering::SeqCst);
        line
    }
}

fn nanos(d: Duration) -> u64 {
    u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)
}

/// One progress line: the phase, done/total with its percentage, the rate and the time left.
pub fn progress_line(name: &str, done: u64, total: u64, elapsed: Duration) -> String {
    let secs = elapsed.as_secs_f64();
    let rate = if secs > 0.0 { done as f64 / secs } else { 0.0 };
    let percent = if total > 0 {
        (done as f64 / total as f64 * 100.0).floor()
    } else {
        100.0
    };
    let eta = if rate > 0.0 {
        duration_words(Duration::from_secs_f64(
            (total.saturating_sub(done)) as f64 / rate,
        ))
    } else {
        "unknown".to_owned()
    };
    format!(
        "{name}: {done}/{total} ({percent:.0}%), {}/s, ETA {eta}",
        rate_words(rate)
    )
}

/// `gathering: 100399/100399 in 2 min 3 s, 816/s`.
pub fn last_line(name: &str, total: u64, elapsed: Duration) -> String {
    let secs = elapsed.as_secs_f64();
    let rate = if secs > 0.0 { total as f64 / secs } else { 0.0 };
    format!(
        "{name}: {total}/{total} in {}, {}/s",
        duration_words(elapsed),
        rate_words(rate)
    )
}

/// Three significant figures at most: `0.25`, `12.5`, `686`, `41200`.
fn rate_words(rate: f64) -> String {
    if rate >= 100.0 {
        format!("{rate:.0}")
    } else if rate >= 10.0 {
        format!("{rate:.1}")
    } else {
        format!("{rate:.2}")
    }
}

/// `0.4 s`, `12 s`, `1 min 26 s`, `2 h 5 min`.
fn duration_words(d: Duration) -> String {
    let s = d.as_secs_f64();
    if s < 10.0 {
        format!("{s:.1} s")
    } else if s < 60.0 {
        format!("{s:.0} s")
    } else if s < 3600.0 {
        let s = s.round() as u64;
        format!("{} min {} s", s / 60, s % 60)
    } else {
        let m = (s / 60.0).round() as u64;
        format!("{} h {} min", m / 60, m % 60)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_phase_prints_progress_at_most_once_an_interval_then_a_last_line() {
        let lines = LogLines::new(Duration::from_millis(30));
        assert_eq!(lines.phase("gathering", 10), ["gathering (10 items)"]);
        // Before the interval has passed, nothing.
        assert_eq!(lines.advance(1), None);
        std::thread::sleep(Duration::from_millis(40));
        let line = lines.advance(1).expect("a line is due");
        assert!(line.starts_with("gathering: 2/10 (20%), "), "{line}");
        assert!(line.contains("/s, ETA "), "{line}");
        // The next one waits another interval.
        assert_eq!(lines.advance(1), None);
        std::thread::sleep(Duration::from_millis(40));
        assert!(lines.advance(1).unwrap().starts_with("gathering: 4/10"));
        let last = lines.advance(6).expect("the last line");
        assert!(last.starts_with("gathering: 10/10 in "), "{last}");
        assert_eq!(lines.finish(), None);
    }

    #[test]
    fn a_short_phase_prints_only_its_first_line() {
        let lines = LogLines::new(Duration::from_secs(3600));
        assert_eq!(lines.phase("bouncing", 2), ["bouncing (2 items)"]);
        assert_eq!(lines.advance(1), None);
        assert_eq!(lines.advance(1), None);
        assert_eq!(lines.phase("refining", 5), ["refining (5 items)"]);
        assert_eq!(lines.finish(), None);
    }

    #[test]
    fn a_phase_that_stops_early_says_where() {
        let lines = LogLines::new(Duration::ZERO);
        lines.phase("radiance maps", 8);
        assert!(lines.advance(3).unwrap().starts_with("radiance maps: 3/8"));
        let next = lines.phase("capture Bunny", 4);
        assert!(
            next[0].starts_with("radiance maps: stopped at 3/8 after "),
            "{next:?}"
        );
        assert_eq!(next[1], "capture Bunny (4 items)");
    }

    #[test]
    fn lines_give_rate_and_eta_in_words() {
        let l = progress_line("gathering", 41200, 100399, Duration::from_secs(60));
        assert_eq!(l, "gathering: 41200/100399 (41%), 687/s, ETA 1 min 26 s");
        assert_eq!(
            last_line("gathering", 100399, Duration::from_secs(123)),
            "gathering: 100399/100399 in 2 min 3 s, 816/s"
        );
        assert_eq!(duration_words(Duration::from_secs(7530)), "2 h 6 min");
        assert!(progress_line("x", 0, 5, Duration::ZERO).ends_with("ETA unknown"));
    }
}
