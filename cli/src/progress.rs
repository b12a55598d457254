//! Progress bars for the core's progress callback (drawn on stderr, hidden when not a terminal
//! or when `--json` output is requested).

use std::sync::Mutex;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A progress bar that shows the core's current stage and fraction.
pub struct StageBar {
    bar: ProgressBar,
    stage: Mutex<String>,
}

impl StageBar {
    /// A bar on stderr, or a hidden one when `quiet`.
    pub fn new(quiet: bool) -> Self {
        let bar = ProgressBar::with_draw_target(
            Some(1000),
            if quiet { ProgressDrawTarget::hidden() } else { ProgressDrawTarget::stderr() },
        );
        bar.set_style(
            ProgressStyle::with_template("{spinner} {msg:<18} [{bar:40}] {percent:>3}% {elapsed}")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        Self { bar, stage: Mutex::new(String::new()) }
    }

    /// The callback to hand to `transcut::Progress::new`: never cancels.
    pub fn update(&self, stage: &str, fraction: f64) -> bool {
        if let Ok(mut s) = self.stage.lock() {
            if *s != stage {
                *s = stage.to_string();
                self.bar.set_message(stage.to_string());
            }
        }
        self.bar.set_position((fraction * 1000.0) as u64);
        true
    }

    /// Runs `f` (which writes to stderr) with the bar hidden, then draws it again.
    pub fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        self.bar.suspend(f)
    }

    /// Removes the bar from the terminal.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
