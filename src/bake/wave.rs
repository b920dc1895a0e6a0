//! Running the work units of one wave side by side ([`run_wave`]).
//!
//! The units of a wave read only units of earlier waves, and each writes its own shard, so
//! they may run in any order or at once with the same bytes. Each is parallel inside, but
//! each also has stretches that keep one thread or none busy (loading D and its records,
//! hashing and writing files, the shard's flushes and renames): a second unit running beside
//! it fills them. [`UNITS_AT_ONCE`] bounds how many run together, and with them the memory
//! their records hold.

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::progress::Progress;

/// Most units of a wave baked at once. Two fill the serial stretches of each other on a
/// machine of any size, while the memory held is at most two units' (a unit's records and
/// D: up to about 1 GiB each on the largest scenes, docs/measurements.md#scale).
pub const UNITS_AT_ONCE: usize = 2;

/// How many units of a wave to bake at once: [`UNITS_AT_ONCE`], or one where the thread pool
/// has one thread (`RAYON_NUM_THREADS=1` asks for one core's work).
pub fn units_at_once() -> usize {
    UNITS_AT_ONCE.min(rayon::current_num_threads()).max(1)
}

/// Runs `bake(i, progress)` for every unit `i < costs.len()`, up to `at_once` at a time,
/// the costliest first (ties in order of `i`) as workers free up, so that the last unit to
/// start is a short one; returns the results in order of `i`. With one at a time (or one
/// unit) it runs on the calling thread. The progress reported is one unit's at a time: that
/// of the earliest started still running, its phase announced again when it takes over.
pub fn run_wave<T: Send>(
    costs: &[f64],
    at_once: usize,
    progress: &dyn Progress,
    bake: impl Fn(usize, &dyn Progress) -> T + Sync,
) -> Vec<T> {
    let n = costs.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| costs[b].total_cmp(&costs[a]));
    if n <= 1 || at_once <= 1 {
        let mut results: Vec<Option<T>> = (0..n).map(|_| None).collect();
        for &i in &order {
            results[i] = Some(bake(i, progress));
        }
        return results
            .into_iter()
            .map(|r| r.expect("every unit ran"))
            .collect();
    }
    let shown = Shown {
        outer: progress,
        state: Mutex::new(State::default()),
    };
    let next = AtomicUsize::new(0);
    let results: Vec<Mutex<Option<T>>> = (0..n).map(|_| Mutex::new(None)).collect();
    let work = || {
        loop {
            // Units are shown by their rank in `order`: the lowest running leads.
            let rank = next.fetch_add(1, Ordering::SeqCst);
            let Some(&i) = order.get(rank) else {
                break;
            };
            shown.start(rank);
            let unit = UnitProgress {
                shown: &shown,
                rank,
            };
            let r = bake(i, &unit);
            shown.end(rank);
            *results[i].lock().unwrap_or_else(|e| e.into_inner()) = Some(r);
        }
    };
    std::thread::scope(|s| {
        for _ in 1..n.min(at_once) {
            s.spawn(work);
        }
        work();
    });
    results
        .into_iter()
        .map(|r| {
            r.into_inner()
                .unwrap_or_else(|e| e.into_inner())
                .expect("every unit ran")
        })
        .collect()
}

/// A running unit's current phase: name, total, done.
type Phase = (String, u64, u64);

#[derive(Default)]
struct State {
    /// The units running, by their rank in the order they start, with their current phase.
    running: Vec<(usize, Option<Phase>)>,
}

impl State {
    fn lead(&self) -> Option<usize> {
        self.running.iter().map(|r| r.0).min()
    }
}

/// Shows the lowest running unit's progress on the wave's reporter.
struct Shown<'a> {
    outer: &'a dyn Progress,
    state: Mutex<State>,
}

impl Shown<'_> {
    fn lock(&self) -> std::sync::MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn start(&self, i: usize) {
        self.lock().running.push((i, None));
    }

    fn end(&self, i: usize) {
        let mut s = self.lock();
        let was = s.lead();
        s.running.retain(|r| r.0 != i);
        let now = s.lead();
        if was == Some(i)
            && let Some(lead) = now
            && let Some((_, Some((name, total, done)))) = s.running.iter().find(|r| r.0 == lead)
        {
            self.outer.phase(name, *total);
            if *done > 0 {
                self.outer.advance(*done);
            }
        }
    }
}

/// The reporter one unit of a wave is given.
struct UnitProgress<'a> {
    shown: &'a Shown<'a>,
    /// The unit's rank in the order units start.
    rank: usize,
}

impl Progress for UnitProgress<'_> {
    fn phase(&self, name: &str, total: u64) {
        let mut s = self.shown.lock();
        let lead = s.lead() == Some(self.rank);
        if let Some(r) = s.running.iter_mut().find(|r| r.0 == self.rank) {
            r.1 = Some((name.to_owned(), total, 0));
        }
        if lead {
            self.shown.outer.phase(name, total);
        }
    }

    fn advance(&self, n: u64) {
        let mut s = self.shown.lock();
        let lead = s.lead() == Some(self.rank);
        if let Some((_, Some(p))) = s.running.iter_mut().find(|r| r.0 == self.rank) {
            p.2 += n;
        }
        if lead {
            self.shown.outer.advance(n);
        }
    }

    fn cancelled(&self) -> bool {
        self.shown.outer.cancelled()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Records the phases and advances it is shown.
    #[derive(Default)]
    struct Log(Mutex<Vec<String>>);

    impl Progress for Log {
        fn phase(&self, name: &str, total: u64) {
            self.0.lock().unwrap().push(format!("{name}/{total}"));
        }
        fn advance(&self, n: u64) {
            self.0.lock().unwrap().push(format!("+{n}"));
        }
    }

    #[test]
    fn every_unit_runs_once_and_results_keep_their_order() {
        let log = Log::default();
        let ran = AtomicUsize::new(0);
        let out = run_wave(&[0.0; 7], 2, &log, |i, p| {
            ran.fetch_add(1, Ordering::SeqCst);
            p.phase("unit", 2);
            p.advance(1);
            p.advance(1);
            i * 10
        });
        assert_eq!(out, [0, 10, 20, 30, 40, 50, 60]);
        assert_eq!(ran.load(Ordering::SeqCst), 7);
        // Every unit's phase is shown once it leads, with what it had done by then.
        let log = log.0.into_inner().unwrap();
        let phases = log.iter().filter(|l| l.starts_with("unit/")).count();
        assert!((4..=7).contains(&phases), "{log:?}");
    }

    #[test]
    fn two_units_run_at_once() {
        // Each unit waits until the other has started: one at a time would never finish.
        let started = AtomicUsize::new(0);
        let out = run_wave(&[0.0; 2], 2, &crate::progress::Silent, |i, _| {
            started.fetch_add(1, Ordering::SeqCst);
            let t = std::time::Instant::now();
            while started.load(Ordering::SeqCst) < 2 {
                assert!(
                    t.elapsed().as_secs() < 60,
                    "the units ran one after another"
                );
                std::thread::yield_now();
            }
            i
        });
        assert_eq!(out, [0, 1]);
    }

    #[test]
    fn the_costliest_units_start_first_and_results_keep_their_order() {
        let costs = [1.0, 5.0, 3.0, 5.0, 0.0];
        for at_once in [1, 2] {
            let started = Mutex::new(Vec::new());
            let out = run_wave(&costs, at_once, &crate::progress::Silent, |i, _| {
                started.lock().unwrap().push(i);
                i * 10
            });
            assert_eq!(out, [0, 10, 20, 30, 40]);
            let mut started = started.into_inner().unwrap();
            if at_once == 1 {
                // Ties keep their order. (Two workers take units in this order too, but which
                // of two reaches `bake` first is a race.)
                assert_eq!(started, [1, 3, 2, 0, 4]);
            }
            started.sort();
            assert_eq!(started, [0, 1, 2, 3, 4]);
        }
    }

    #[test]
    fn a_follower_takes_over_the_shown_phase_with_its_progress() {
        let log = Log::default();
        let shown = Shown {
            outer: &log,
            state: Mutex::new(State::default()),
        };
        shown.start(0);
        shown.start(1);
        let (a, b) = (
            UnitProgress {
                shown: &shown,
                rank: 0,
            },
            UnitProgress {
                shown: &shown,
                rank: 1,
            },
        );
        a.phase("probe", 10);
        b.phase("maps", 5);
        b.advance(3);
        a.advance(2);
        shown.end(0);
        b.advance(1);
        assert_eq!(
            log.0.into_inner().unwrap(),
            ["probe/10", "+2", "maps/5", "+3", "+1"]
        );
    }
}
