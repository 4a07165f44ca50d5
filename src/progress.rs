//! Progress on stderr: a spinner naming the current stage and bars for long loops, drawn
//! only on a terminal and only once a loop has run for a second; `--quiet` hides all.
//! A library caller (the Python module) may instead pass a [`Hook`] that is told each
//! stage and, at most every [`HOOK_INTERVAL_MS`] per bar, each bar's position.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A progress callback: `(stage, done, total)`; a stage that begins has `total` 0, a bar
/// that advances `done` of `total` steps. Called from any thread.
pub type Hook = Arc<dyn Fn(&str, u64, u64) + Send + Sync>;

/// The shortest interval between two calls of a [`Hook`] for one bar (its last step is
/// always reported).
pub const HOOK_INTERVAL_MS: u64 = 100;

/// The progress reporter of one command.
#[derive(Clone)]
pub struct Progress {
    quiet: bool,
    spinner: Option<ProgressBar>,
    hook: Option<Hook>,
}

impl Progress {
    /// A reporter that draws on stderr unless `quiet`.
    pub fn new(quiet: bool) -> Self {
        let spinner = (!quiet).then(|| {
            let s = ProgressBar::new_spinner();
            s.set_style(ProgressStyle::with_template("{spinner} [{elapsed}] {msg}").expect("static template"));
            s.enable_steady_tick(Duration::from_millis(120));
            s
        });
        Progress {
            quiet,
            spinner,
            hook: None,
        }
    }

    /// A reporter that shows nothing (library use, tests).
    pub fn hidden() -> Self {
        Progress {
            quiet: true,
            spinner: None,
            hook: None,
        }
    }

    /// A reporter that draws nothing and tells `hook` instead.
    pub fn with_hook(hook: Hook) -> Self {
        Progress {
            quiet: true,
            spinner: None,
            hook: Some(hook),
        }
    }

    /// Names the stage now running.
    pub fn stage(&self, msg: &str) {
        if let Some(s) = &self.spinner {
            s.set_message(msg.to_string());
        }
        if let Some(h) = &self.hook {
            h(msg, 0, 0);
        }
    }

    /// A bar over `len` steps, shown once it has run for a second.
    pub fn bar(&self, len: u64, msg: &str) -> Bar {
        let pb = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::hidden());
        pb.set_style(
            ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} ({eta} left)")
                .expect("static template")
                .progress_chars("=> "),
        );
        pb.set_message(msg.to_string());
        Bar {
            pb,
            start: Instant::now(),
            shown: Arc::new(AtomicBool::new(self.quiet)),
            hook: self.hook.clone().map(|h| {
                Arc::new(BarHook {
                    hook: h,
                    msg: msg.to_string(),
                    len,
                    done: AtomicU64::new(0),
                    last_ms: AtomicU64::new(0),
                })
            }),
        }
    }

    /// Clears the spinner.
    pub fn finish(&self) {
        if let Some(s) = &self.spinner {
            s.finish_and_clear();
        }
    }
}

/// A bar's [`Hook`]: its steps done and when it was last told (ms after the start).
struct BarHook {
    hook: Hook,
    msg: String,
    len: u64,
    done: AtomicU64,
    last_ms: AtomicU64,
}

/// A progress bar (cheap to clone, safe to advance from many threads).
#[derive(Clone)]
pub struct Bar {
    pb: ProgressBar,
    start: Instant,
    shown: Arc<AtomicBool>,
    hook: Option<Arc<BarHook>>,
}

impl Bar {
    pub fn inc(&self, n: u64) {
        self.pb.inc(n);
        if let Some(h) = &self.hook {
            let done = h.done.fetch_add(n, Ordering::Relaxed) + n;
            let now = self.start.elapsed().as_millis() as u64;
            let last = h.last_ms.load(Ordering::Relaxed);
            // One thread wins each interval; the last step is always told.
            let due = now >= last + HOOK_INTERVAL_MS
                && h.last_ms
                    .compare_exchange(last, now, Ordering::Relaxed, Ordering::Relaxed)
                    .is_ok();
            if due || done == h.len {
                (h.hook)(&h.msg, done, h.len);
            }
        }
        if !self.shown.load(Ordering::Relaxed) && self.start.elapsed() > Duration::from_secs(1) {
            self.shown.store(true, Ordering::Relaxed);
            self.pb.set_draw_target(ProgressDrawTarget::stderr());
        }
    }

    pub fn finish(&self) {
        self.pb.finish_and_clear();
    }
}
