//! The fuzz loop: mutated seeds fed to a target on a worker thread, each input under
//! `catch_unwind` and a watchdog that calls an input that runs past the time bound a hang.
//!
//! A loader rejecting an input (`Err`) is the expected outcome; a panic or a hang is a crash.
//! Crashes are told apart by where they panicked (file and line), so a bug found many times
//! counts once.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, Once};
use std::time::{Duration, Instant};

use super::mutate::{FuzzRng, mutate};
use super::{Target, TargetContext};

/// How long a run goes on and how it draws its inputs.
#[derive(Clone, Debug)]
pub struct RunConfig {
    /// Mutated inputs to run (the seeds themselves run first, unmutated, and are not counted).
    pub execs: u64,
    /// Stop early after this long (the executions done are reported).
    pub max_time: Duration,
    /// One input running longer than this is a hang.
    pub input_timeout: Duration,
    /// Seed of the mutation generator: the same seed gives the same inputs.
    pub seed: u64,
}

/// One distinct crash: the first input that hit it.
#[derive(Clone, Debug)]
pub struct Crash {
    /// Panic location and message, or `hang`.
    pub message: String,
    /// Where it panicked (`file:line`), or `hang`: what tells crashes apart.
    pub key: String,
    /// The input.
    pub input: Vec<u8>,
    /// How many inputs hit it.
    pub hits: u64,
}

/// What a run did.
#[derive(Clone, Debug)]
pub struct RunReport {
    /// Target name.
    pub target: &'static str,
    /// Inputs run (seeds and mutants).
    pub execs: u64,
    /// Inputs the target rejected with an error (the expected outcome of most mutants).
    pub rejected: u64,
    /// Distinct crashes.
    pub crashes: Vec<Crash>,
    /// Wall time.
    pub elapsed: Duration,
}

impl RunReport {
    /// Executions per second.
    pub fn execs_per_sec(&self) -> f64 {
        self.execs as f64 / self.elapsed.as_secs_f64().max(1e-9)
    }

    /// A multi-line description of every crash (with the input's first bytes) for a failing
    /// test's message.
    pub fn describe_crashes(&self) -> String {
        self.crashes
            .iter()
            .map(|c| {
                let head: String = c
                    .input
                    .iter()
                    .take(64)
                    .map(|b| format!("{b:02x}"))
                    .collect();
                format!(
                    "{}: {} ({} hits; input {} bytes: {head}…)",
                    self.target,
                    c.message,
                    c.hits,
                    c.input.len()
                )
            })
            .collect::<Vec<_>>()
            .join("\n")
    }
}

thread_local! {
    static QUIET: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    static LAST_PANIC: std::cell::RefCell<Option<(String, String)>> = const { std::cell::RefCell::new(None) };
}

/// Installs (once) a panic hook that, on fuzz worker threads, records the panic's location
/// and message instead of printing them; other threads get the default hook.
fn install_hook() {
    static HOOK: Once = Once::new();
    HOOK.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if QUIET.with(|q| q.get()) {
                let key = info
                    .location()
                    .map(|l| format!("{}:{}", l.file(), l.line()))
                    .unwrap_or_else(|| "unknown".into());
                let payload = info.payload();
                let msg = payload
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| payload.downcast_ref::<String>().cloned())
                    .unwrap_or_default();
                LAST_PANIC.with(|p| *p.borrow_mut() = Some((key, msg)));
            } else {
                default(info);
            }
        }));
    });
}

/// Runs `input` through `target` on this thread: `Ok(true)` accepted, `Ok(false)` rejected,
/// `Err((key, message))` a panic.
pub fn run_one(
    target: &Target,
    ctx: &TargetContext,
    input: &[u8],
) -> Result<bool, (String, String)> {
    install_hook();
    QUIET.with(|q| q.set(true));
    super::alloc_limit::set_current(target.name, input);
    let out = catch_unwind(AssertUnwindSafe(|| (target.run)(ctx, input)));
    super::alloc_limit::clear_current();
    QUIET.with(|q| q.set(false));
    match out {
        Ok(r) => Ok(r.is_ok()),
        Err(_) => Err(LAST_PANIC
            .with(|p| p.borrow_mut().take())
            .unwrap_or_else(|| ("unknown".into(), "panic".into()))),
    }
}

/// What the worker and the watchdog share.
struct Shared {
    /// Index of the input now running (`u64::MAX`: none).
    running: AtomicU64,
    /// When it started, in nanoseconds since `epoch`.
    started: AtomicU64,
    /// The input now running (kept for a hang report).
    current: Mutex<Vec<u8>>,
    /// Inputs finished.
    execs: AtomicU64,
    rejected: AtomicU64,
    crashes: Mutex<Vec<Crash>>,
    /// Set by the watchdog when it gives up on a hung worker; the worker exits if it ever
    /// returns.
    abandoned: AtomicBool,
    /// Set by the worker when it has run its last input.
    finished: AtomicBool,
}

fn record(crashes: &Mutex<Vec<Crash>>, key: String, message: String, input: &[u8]) {
    let mut c = crashes.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(known) = c.iter_mut().find(|k| k.key == key) {
        known.hits += 1;
        if input.len() < known.input.len() {
            known.input = input.to_vec();
        }
    } else {
        c.push(Crash {
            message,
            key,
            input: input.to_vec(),
            hits: 1,
        });
    }
}

/// The input of index `i`: seeds `0..seeds.len()` unmutated, then mutants of them.
fn input_of(seeds: &[Vec<u8>], i: u64, seed: u64) -> Vec<u8> {
    let n = seeds.len() as u64;
    if i < n {
        return seeds[i as usize].clone();
    }
    let mut rng = FuzzRng::new(seed, i);
    let mut data = seeds[rng.below(seeds.len())].clone();
    let other = &seeds[rng.below(seeds.len())];
    mutate(&mut data, other, &mut rng);
    data
}

/// Fuzzes `target`: every input of `seeds` (at least one: the corpus and the regression
/// inputs) runs first, unmutated, then `config.execs` mutants of them. `ctx` must come from
/// [`Target::prepare`].
pub fn run(
    target: &'static Target,
    ctx: Arc<TargetContext>,
    seeds: &[Vec<u8>],
    config: &RunConfig,
) -> RunReport {
    assert!(!seeds.is_empty(), "{}: no seed inputs", target.name);
    let epoch = Instant::now();
    let total = seeds.len() as u64 + config.execs;
    let seeds: Arc<Vec<Vec<u8>>> = Arc::new(seeds.to_vec());
    let mut next = 0u64;
    let mut crashes: Vec<Crash> = Vec::new();
    let (mut execs, mut rejected) = (0u64, 0u64);
    while next < total {
        let shared = Arc::new(Shared {
            running: AtomicU64::new(u64::MAX),
            started: AtomicU64::new(0),
            current: Mutex::new(Vec::new()),
            execs: AtomicU64::new(0),
            rejected: AtomicU64::new(0),
            crashes: Mutex::new(Vec::new()),
            abandoned: AtomicBool::new(false),
            finished: AtomicBool::new(false),
        });
        let (w, c, s) = (shared.clone(), ctx.clone(), seeds.clone());
        let (start, max_time, seed) = (next, config.max_time, config.seed);
        let worker = std::thread::Builder::new()
            .name(format!("fuzz-{}", target.name))
            .stack_size(64 << 20)
            .spawn(move || {
                for i in start..total {
                    if w.abandoned.load(Ordering::Relaxed) || epoch.elapsed() > max_time {
                        break;
                    }
                    let input = input_of(&s, i, seed);
                    *w.current.lock().unwrap_or_else(|e| e.into_inner()) = input.clone();
                    w.started
                        .store(epoch.elapsed().as_nanos() as u64, Ordering::Relaxed);
                    w.running.store(i, Ordering::Release);
                    let out = run_one(target, &c, &input);
                    w.running.store(u64::MAX, Ordering::Release);
                    if w.abandoned.load(Ordering::Relaxed) {
                        return;
                    }
                    match out {
                        Ok(true) => {}
                        Ok(false) => {
                            w.rejected.fetch_add(1, Ordering::Relaxed);
                        }
                        Err((key, msg)) => record(
                            &w.crashes,
                            key.clone(),
                            format!("panic at {key}: {msg}"),
                            &input,
                        ),
                    }
                    w.execs.fetch_add(1, Ordering::Relaxed);
                }
                w.finished.store(true, Ordering::Release);
            })
            .expect("spawn the fuzz worker");
        // Watchdog: poll until the worker finishes or an input overstays.
        let mut hung_at = None;
        loop {
            if shared.finished.load(Ordering::Acquire) || worker.is_finished() {
                break;
            }
            std::thread::sleep(Duration::from_millis(5));
            let i = shared.running.load(Ordering::Acquire);
            if i == u64::MAX {
                continue;
            }
            let started = Duration::from_nanos(shared.started.load(Ordering::Relaxed));
            if epoch.elapsed().saturating_sub(started) > config.input_timeout
                && shared.running.load(Ordering::Acquire) == i
            {
                shared.abandoned.store(true, Ordering::Relaxed);
                hung_at = Some(i);
                break;
            }
        }
        execs += shared.execs.load(Ordering::Relaxed);
        rejected += shared.rejected.load(Ordering::Relaxed);
        for c in shared
            .crashes
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .drain(..)
        {
            merge(&mut crashes, c);
        }
        match hung_at {
            Some(i) => {
                let input = shared
                    .current
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .clone();
                execs += 1;
                merge(
                    &mut crashes,
                    Crash {
                        message: format!("hang: an input ran past {:?}", config.input_timeout),
                        key: "hang".into(),
                        input,
                        hits: 1,
                    },
                );
                // The stuck worker is left behind; the next one goes on after its input.
                next = i + 1;
                if epoch.elapsed() > config.max_time {
                    break;
                }
            }
            None => {
                if let Err(p) = worker.join() {
                    std::panic::resume_unwind(p);
                }
                break;
            }
        }
    }
    RunReport {
        target: target.name,
        execs,
        rejected,
        crashes,
        elapsed: epoch.elapsed(),
    }
}

fn merge(crashes: &mut Vec<Crash>, c: Crash) {
    if let Some(known) = crashes.iter_mut().find(|k| k.key == c.key) {
        known.hits += c.hits;
        if c.input.len() < known.input.len() {
            known.input = c.input;
        }
    } else {
        crashes.push(c);
    }
}
