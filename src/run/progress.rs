//! Progress on stderr: a bar on a terminal; otherwise (CI logs) a timestamped line every few
//! seconds while runs finish, and at least one a minute while a long run computes.
//!
//! Counts are of the plan's runs, as `plan` and the run summary count them (runs that share a
//! content hash are computed once and counted each). The remaining time is estimated from the
//! planned cost of the runs still to compute (each run's compute time the last time it ran, else
//! its algorithm's mean then, else one unit) at the pace of the cost computed so far; cached runs
//! finish at once and do not count.

use crate::store::RunStatus;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// How often a plain progress line is printed while runs finish when stderr is not a terminal…
const PLAIN_INTERVAL: Duration = Duration::from_secs(5);
/// …and the longest silence, while a run computes.
const HEARTBEAT: Duration = Duration::from_secs(60);

struct Counts {
    study: String,
    total: usize,
    to_compute: usize,
    done: AtomicUsize,
    computed: AtomicUsize,
    /// Planned cost to compute, and computed so far (µs-scaled integers, for atomics).
    cost_total: u64,
    cost_done: AtomicUsize,
    cached: AtomicUsize,
    failed: AtomicUsize,
    /// When the first run began computing.
    /// When computing began (the ETA's pace is measured from here, not from the setup).
    start: Mutex<Instant>,
    last_line: Mutex<Instant>,
}

impl Counts {
    fn line(&self) -> String {
        let (done, computed) =
            (self.done.load(Ordering::Relaxed), self.computed.load(Ordering::Relaxed));
        format!(
            "{}: {done}/{} runs ({} computed of {}, {} cached, {} failed{})",
            self.study,
            self.total,
            computed,
            self.to_compute,
            self.cached.load(Ordering::Relaxed),
            self.failed.load(Ordering::Relaxed),
            eta(
                self.start.lock().expect("progress lock").elapsed(),
                self.cost_done.load(Ordering::Relaxed),
                self.cost_total as usize
            )
            .map_or(String::new(), |e| format!(", about {e} left"))
        )
    }
}

/// Remaining time at the pace so far: `elapsed / done × (total − done)`, in any unit of work
/// (planned cost, or runs).
pub fn eta(elapsed: Duration, computed: usize, to_compute: usize) -> Option<String> {
    if computed == 0 || computed >= to_compute {
        return None;
    }
    // A pace from the first few of very many runs is noise (one run of 10⁶ once said 6 828 h):
    // none before 1 % is done or ten seconds have passed.
    if computed.saturating_mul(100) < to_compute && elapsed < Duration::from_secs(10) {
        return None;
    }
    let left = elapsed.as_secs_f64() / computed as f64 * (to_compute - computed) as f64;
    let s = left.round() as u64;
    Some(if s >= 3600 {
        format!("{}h{:02}m", s / 3600, s / 60 % 60)
    } else if s >= 60 {
        format!("{}m{:02}s", s / 60, s % 60)
    } else {
        format!("{s}s")
    })
}

/// A planned cost [ms] as an integer count of 10 µs (atomics hold integers).
fn cost_units(ms: f64) -> u64 {
    (ms.max(0.0) * 100.0).round() as u64
}

/// UTC wall-clock time of day, HH:MM:SS, for plain progress lines.
fn clock() -> String {
    let s = SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs()) % 86_400;
    format!("{:02}:{:02}:{:02}Z", s / 3600, s / 60 % 60, s % 60)
}

pub struct Progress {
    counts: Arc<Counts>,
    bar: Option<ProgressBar>,
    plain: bool,
    stop: Arc<AtomicBool>,
    heartbeat: Option<std::thread::JoinHandle<()>>,
}

impl Progress {
    /// `total`: the plan's runs; `to_compute`: those that will be computed (not cached);
    /// `cost`: their planned cost [ms].
    pub fn new(study: &str, total: usize, to_compute: usize, cost: f64, enabled: bool) -> Self {
        let tty = std::io::stderr().is_terminal();
        let counts = Arc::new(Counts {
            study: study.to_string(),
            total,
            to_compute,
            done: AtomicUsize::new(0),
            computed: AtomicUsize::new(0),
            cost_total: cost_units(cost),
            cost_done: AtomicUsize::new(0),
            cached: AtomicUsize::new(0),
            failed: AtomicUsize::new(0),
            start: Mutex::new(Instant::now()),
            last_line: Mutex::new(Instant::now()),
        });
        let bar = (enabled && tty).then(|| {
            let bar = ProgressBar::new(total as u64);
            bar.set_style(
                ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} runs {msg}")
                    .expect("valid template")
                    .progress_chars("=> "),
            );
            bar.set_prefix(study.to_string());
            bar
        });
        let plain = enabled && !tty;
        let stop = Arc::new(AtomicBool::new(false));
        // a line at least once a minute in a log, even while one long run computes
        let heartbeat = (plain && to_compute > 0).then(|| {
            let (counts, stop) = (Arc::clone(&counts), Arc::clone(&stop));
            std::thread::spawn(move || {
                while !stop.load(Ordering::Relaxed) {
                    std::thread::sleep(Duration::from_millis(250));
                    let mut last = counts.last_line.lock().expect("progress lock");
                    if last.elapsed() >= HEARTBEAT && !stop.load(Ordering::Relaxed) {
                        eprintln!("{} {}", clock(), counts.line());
                        *last = Instant::now();
                    }
                }
            })
        });
        Self { counts, bar, plain, stop, heartbeat }
    }

    /// `runs` runs finished (a content hash shared by several runs of the plan counts for each);
    /// `cost`: the planned cost [ms] of what was computed (0 when cached).
    /// Computing begins now: the ETA's pace is measured from here (looking up a large plan's
    /// cache entries takes a while and is no run's time).
    pub fn computing(&self) {
        *self.counts.start.lock().expect("progress lock") = Instant::now();
    }

    pub fn finished(&self, status: RunStatus, cached: bool, runs: usize, cost: f64) {
        let c = &self.counts;
        let done = c.done.fetch_add(runs, Ordering::Relaxed) + runs;
        if cached {
            c.cached.fetch_add(runs, Ordering::Relaxed);
        } else {
            c.computed.fetch_add(runs, Ordering::Relaxed);
            c.cost_done.fetch_add(cost_units(cost) as usize, Ordering::Relaxed);
        }
        if status != RunStatus::Ok {
            c.failed.fetch_add(runs, Ordering::Relaxed);
        }
        if let Some(bar) = &self.bar {
            let computed = c.cost_done.load(Ordering::Relaxed);
            bar.set_message(format!(
                "({} cached, {} failed{})",
                c.cached.load(Ordering::Relaxed),
                c.failed.load(Ordering::Relaxed),
                eta(
                    c.start.lock().expect("progress lock").elapsed(),
                    computed,
                    c.cost_total as usize,
                )
                .map_or(String::new(), |e| format!("; about {e} left"))
            ));
            bar.inc(runs as u64);
        }
        if self.plain {
            let mut last = c.last_line.lock().expect("progress lock");
            if last.elapsed() >= PLAIN_INTERVAL && done < c.total {
                eprintln!("{} {}", clock(), c.line());
                *last = Instant::now();
            }
        }
    }

    pub fn warn(&self, message: &str) {
        match &self.bar {
            Some(bar) => bar.println(format!("warning: {message}")),
            None => eprintln!("warning: {message}"),
        }
    }

    pub fn done(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(h) = self.heartbeat.take() {
            let _ = h.join();
        }
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_remaining_time_comes_from_the_computed_runs_only() {
        // 10 computed in 20 s, 30 to compute: 40 s left, whatever number of cached runs went by
        assert_eq!(eta(Duration::from_secs(20), 10, 30).as_deref(), Some("40s"));
        assert_eq!(eta(Duration::from_secs(60), 1, 100).as_deref(), Some("1h39m"));
        assert_eq!(eta(Duration::from_secs(90), 3, 5).as_deref(), Some("1m00s"));
        // nothing computed yet, or nothing left: no estimate
        assert_eq!(eta(Duration::from_secs(5), 0, 10), None);
        // the first runs of a large plan give no pace yet
        assert_eq!(eta(Duration::from_millis(50), 1, 1_000_000), None);
        assert!(eta(Duration::from_secs(12), 1_000, 1_000_000).is_some());
        assert_eq!(eta(Duration::from_secs(5), 10, 10), None);
        assert!(clock().ends_with('Z') && clock().len() == 9);
    }
}
