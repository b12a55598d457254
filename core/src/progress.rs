//! Progress reporting and cooperative cancellation for long work.
//!
//! The core never draws progress bars: it calls a user callback with a stage name and a fraction in
//! `[0, 1]`. The callback returns `true` to continue and `false` to cancel; the running stage then
//! stops at its next check and returns [`Cancelled`].

use std::fmt;
use std::time::Instant;

/// Milliseconds since `start`: the unit of every stage timing in the statistics.
pub(crate) fn ms(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

/// The fraction of a solve done at relative residual `residual` (per channel): the worst
/// channel's way from 1 down to `tolerance`, in decades, in `[0, 1]`.
pub(crate) fn solve_fraction(residual: [f64; 3], tolerance: f64) -> f64 {
    let decades = -tolerance.log10();
    let worst = residual.iter().fold(0.0f64, |m, &r| m.max(r)).max(tolerance);
    (-worst.log10() / decades).clamp(0.0, 1.0)
}

/// A progress callback: `(stage, fraction) -> keep going?`, callable from several threads.
pub type ProgressFn<'a> = dyn Fn(&str, f64) -> bool + Sync + 'a;

/// A progress sink: `report(stage, fraction) -> keep going?`.
///
/// `Progress::none()` ignores reports and never cancels. The callback may be called from several
/// threads, hence `Sync`.
#[derive(Clone, Copy)]
pub struct Progress<'a> {
    callback: Option<&'a ProgressFn<'a>>,
}

/// The user cancelled the work through the progress callback.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("cancelled by the progress callback")]
pub struct Cancelled;

impl<'a> Progress<'a> {
    /// A sink that ignores reports and never cancels.
    #[must_use]
    pub fn none() -> Self {
        Self { callback: None }
    }

    /// Wraps a callback `(stage, fraction) -> continue?`.
    #[must_use]
    pub fn new(callback: &'a ProgressFn<'a>) -> Self {
        Self { callback: Some(callback) }
    }

    /// Reports `fraction` (clamped to `[0, 1]`) of `stage` done.
    ///
    /// # Errors
    /// [`Cancelled`] when the callback asked to stop.
    pub fn report(&self, stage: &str, fraction: f64) -> Result<(), Cancelled> {
        match self.callback {
            Some(cb) if !cb(stage, fraction.clamp(0.0, 1.0)) => Err(Cancelled),
            _ => Ok(()),
        }
    }
}

/// Counts the items that parallel tasks finish and reports `done / total` of one stage, counting
/// and reporting under one lock, so that the callback never sees the fraction go back (two
/// tasks that counted in one order could otherwise report in the other).
pub struct ProgressCounter<'p, 'a> {
    progress: &'p Progress<'a>,
    stage: &'static str,
    total: usize,
    done: std::sync::Mutex<usize>,
}

impl<'p, 'a> ProgressCounter<'p, 'a> {
    /// A counter of `total` items of `stage`, reporting to `progress`.
    #[must_use]
    pub fn new(progress: &'p Progress<'a>, stage: &'static str, total: usize) -> Self {
        Self { progress, stage, total: total.max(1), done: std::sync::Mutex::new(0) }
    }

    /// Counts `n` more items done and reports the new fraction.
    ///
    /// # Errors
    /// [`Cancelled`] when the callback asked to stop.
    pub fn add(&self, n: usize) -> Result<(), Cancelled> {
        let mut done = self.done.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        *done += n;
        #[allow(clippy::cast_precision_loss)]
        self.progress.report(self.stage, *done as f64 / self.total as f64)
    }
}

impl Default for Progress<'_> {
    fn default() -> Self {
        Self::none()
    }
}

impl fmt::Debug for Progress<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Progress").field("callback", &self.callback.is_some()).finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    #[test]
    fn solve_fraction_counts_decades_down_to_the_tolerance() {
        assert_eq!(solve_fraction([1.0; 3], 1e-6), 0.0);
        assert!((solve_fraction([1e-3, 1e-2, 1e-4], 1e-6) - 2.0 / 6.0).abs() < 1e-12);
        assert_eq!(solve_fraction([1e-9, 0.0, 1e-7], 1e-6), 1.0);
    }

    #[test]
    fn counter_reports_never_go_back_under_parallel_adds() {
        use rayon::prelude::*;
        let seen = std::sync::Mutex::new(Vec::new());
        let cb = |_: &str, f: f64| {
            seen.lock().unwrap().push(f);
            true
        };
        let p = Progress::new(&cb);
        let counter = ProgressCounter::new(&p, "items", 10_000);
        (0..10_000).into_par_iter().for_each(|_| counter.add(1).unwrap());
        let seen = seen.into_inner().unwrap();
        assert_eq!(seen.len(), 10_000);
        assert!(seen.windows(2).all(|w| w[1] > w[0]));
        assert_eq!(*seen.last().unwrap(), 1.0);
    }

    #[test]
    fn callback_can_cancel_after_some_reports() {
        let calls = AtomicUsize::new(0);
        let cb = |_: &str, _: f64| calls.fetch_add(1, Ordering::SeqCst) < 2;
        let p = Progress::new(&cb);
        assert!(p.report("a", 0.1).is_ok());
        assert!(p.report("a", 0.2).is_ok());
        assert_eq!(p.report("a", 0.3), Err(Cancelled));
        assert!(Progress::none().report("x", 2.0).is_ok());
    }
}
