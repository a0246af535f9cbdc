//! Progress on stderr: a bar on a terminal, a plain line every few seconds otherwise (CI logs).

use crate::store::RunStatus;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How often a plain progress line is printed when stderr is not a terminal.
const PLAIN_INTERVAL: Duration = Duration::from_secs(5);

pub struct Progress {
    study: String,
    total: usize,
    bar: Option<ProgressBar>,
    plain: Option<Mutex<Instant>>,
    done: AtomicUsize,
    cached: AtomicUsize,
    failed: AtomicUsize,
}

impl Progress {
    pub fn new(study: &str, total: usize, enabled: bool) -> Self {
        let tty = std::io::stderr().is_terminal();
        let bar = (enabled && tty).then(|| {
            let bar = ProgressBar::new(total as u64);
            bar.set_style(ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} runs {msg} ({eta})").expect("valid template").progress_chars("=> "));
            bar.set_prefix(study.to_string());
            bar
        });
        let plain = (enabled && !tty).then(|| Mutex::new(Instant::now()));
        Self { study: study.to_string(), total, bar, plain, done: AtomicUsize::new(0), cached: AtomicUsize::new(0), failed: AtomicUsize::new(0) }
    }

    pub fn finished(&self, status: RunStatus, cached: bool) {
        let done = self.done.fetch_add(1, Ordering::Relaxed) + 1;
        if cached {
            self.cached.fetch_add(1, Ordering::Relaxed);
        }
        if status != RunStatus::Ok {
            self.failed.fetch_add(1, Ordering::Relaxed);
        }
        if let Some(bar) = &self.bar {
            bar.set_message(self.counts());
            bar.inc(1);
        }
        if let Some(last) = &self.plain {
            let mut last = last.lock().expect("progress lock");
            if last.elapsed() >= PLAIN_INTERVAL && done < self.total {
                eprintln!("{}: {done}/{} runs ({})", self.study, self.total, self.counts());
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

    fn counts(&self) -> String {
        format!("{} cached, {} failed", self.cached.load(Ordering::Relaxed), self.failed.load(Ordering::Relaxed))
    }

    pub fn done(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}
