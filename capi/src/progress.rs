//! The caller's progress callback, made callable from the core's (possibly parallel) progress
//! reports: one call at a time, fractions that never go back, none after a cancel.

use std::ffi::{c_char, c_void, CString};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

/// Progress callback: `stage` is a short UTF-8 description (valid during the call only),
/// `fraction` in [0, 1] the part of the whole bake done (never decreasing from one call to the
/// next). Return 0 to continue, non-zero to
/// cancel the bake (`tc_scene_bake` then returns `TC_CANCELLED` soon after). It is called from
/// the baking thread or a worker thread, never from two threads at once, and not again after
/// it asked to cancel. It must not call functions on the scene being baked (they return
/// `TC_BUSY`).
pub type TcProgressFn = Option<unsafe extern "C" fn(user: *mut c_void, stage: *const c_char, fraction: f64) -> i32>;

/// A scene's callback for its edit calls (`tc_scene_set_progress`): none by default.
#[derive(Clone, Copy)]
pub(crate) struct Sink {
    pub function: TcProgressFn,
    pub user: *mut c_void,
}

impl Default for Sink {
    fn default() -> Self {
        Self { function: None, user: std::ptr::null_mut() }
    }
}

/// The caller's callback, wrapped.
pub(crate) struct Callback {
    function: unsafe extern "C" fn(*mut c_void, *const c_char, f64) -> i32,
    user: *mut c_void,
    /// Held during a call; holds the largest fraction reported so far.
    lock: Mutex<f64>,
    cancelled: AtomicBool,
}

// SAFETY: the user pointer is only passed back to the caller's function, under the lock; the
// header tells the caller the callback may run on a worker thread.
unsafe impl Sync for Callback {}

impl Callback {
    /// Runs `f` with a core progress sink that reports to the caller's `progress` (NULL: none).
    pub(crate) fn with<R>(progress: TcProgressFn, user: *mut c_void, f: impl FnOnce(transcut_core::Progress) -> R) -> R {
        let callback = Callback::new(progress, user);
        let report = |stage: &str, fraction: f64| callback.as_ref().is_none_or(|c| c.report(stage, fraction));
        f(transcut_core::Progress::new(&report))
    }

    /// The caller's function, if any, wrapped.
    fn new(progress: TcProgressFn, user: *mut c_void) -> Option<Self> {
        progress.map(|function| Callback { function, user, lock: Mutex::new(0.0), cancelled: AtomicBool::new(false) })
    }

    fn report(&self, stage: &str, fraction: f64) -> bool {
        if self.cancelled.load(Ordering::Acquire) {
            return false;
        }
        let mut done = self.lock.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if self.cancelled.load(Ordering::Acquire) {
            return false;
        }
        // The stages' own fractions can step back (a stage restarting a sub-step); a caller's
        // progress bar should not.
        *done = done.max(fraction);
        let stage = CString::new(stage.replace('\0', "?")).unwrap_or_default();
        // SAFETY: the caller's function and pointer, as the header documents.
        let keep_going = unsafe { (self.function)(self.user, stage.as_ptr(), *done) } == 0;
        if !keep_going {
            self.cancelled.store(true, Ordering::Release);
        }
        keep_going
    }
}
