//! Progress on stderr: a spinner naming the current stage and bars for long loops, drawn
//! only on a terminal and only once a loop has run for a second; `--quiet` hides all.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// The progress reporter of one command.
#[derive(Clone)]
pub struct Progress {
    quiet: bool,
    spinner: Option<ProgressBar>,
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
        Progress { quiet, spinner }
    }

    /// A reporter that shows nothing (library use, tests).
    pub fn hidden() -> Self {
        Progress {
            quiet: true,
            spinner: None,
        }
    }

    /// Names the stage now running.
    pub fn stage(&self, msg: &str) {
        if let Some(s) = &self.spinner {
            s.set_message(msg.to_string());
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
        }
    }

    /// Clears the spinner.
    pub fn finish(&self) {
        if let Some(s) = &self.spinner {
            s.finish_and_clear();
        }
    }
}

/// A progress bar (cheap to clone, safe to advance from many threads).
#[derive(Clone)]
pub struct Bar {
    pb: ProgressBar,
    start: Instant,
    shown: Arc<AtomicBool>,
}

impl Bar {
    pub fn inc(&self, n: u64) {
        self.pb.inc(n);
        if !self.shown.load(Ordering::Relaxed) && self.start.elapsed() > Duration::from_secs(1) {
            self.shown.store(true, Ordering::Relaxed);
            self.pb.set_draw_target(ProgressDrawTarget::stderr());
        }
    }

    pub fn finish(&self) {
        self.pb.finish_and_clear();
    }
}
