//! The library's worker threads: a rayon pool that the library owns and joins.
//!
//! Every parallel loop of the core runs on the pool of the call that asked for it
//! ([`with_workers`]): the pool is started for the call and, when the call returns, dropped and
//! every one of its threads joined. Nothing of the library outlives a call — no idle threads,
//! no global pool — so a host that loads the library and exits (under valgrind or a leak
//! sanitizer, say) finds no thread and no thread-local storage left behind, and needs no
//! shutdown call. Starting the threads costs far less than any bake or edit that uses them.

use std::cell::Cell;
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;

/// The most worker threads a call may ask for. A fixed number, so that a C caller can check it;
/// far above the cores of any machine the library targets (more threads than cores only add
/// scheduling cost).
pub const MAX_THREADS: usize = 256;

/// Why the worker threads could not be started.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum WorkersError {
    /// More threads than [`MAX_THREADS`] were asked for.
    #[error("threads = {threads} is above the maximum of {max}")]
    TooMany { threads: usize, max: usize },
    /// The operating system refused to start a thread.
    #[error("cannot start {threads} threads: {message}")]
    Spawn { threads: usize, message: String },
}

thread_local! {
    static WORKER: Cell<bool> = const { Cell::new(false) };
}

/// Whether the calling thread is one of the library's worker threads (a panic hook uses this to
/// tell the library's panics from the host's).
#[must_use]
pub fn is_worker_thread() -> bool {
    WORKER.try_with(Cell::get).unwrap_or(false)
}

/// The number of threads a request for `threads` gets: `threads` itself, or one per core for 0.
///
/// # Errors
/// [`WorkersError::TooMany`] above [`MAX_THREADS`].
pub fn thread_count(threads: usize) -> Result<usize, WorkersError> {
    if threads > MAX_THREADS {
        return Err(WorkersError::TooMany { threads, max: MAX_THREADS });
    }
    Ok(if threads == 0 {
        std::thread::available_parallelism().map_or(1, std::num::NonZero::get).min(MAX_THREADS)
    } else {
        threads
    })
}

/// A started pool and the handles of its threads; dropping it stops and joins them all.
struct Workers {
    pool: Option<rayon::ThreadPool>,
    handles: Arc<Mutex<Vec<JoinHandle<()>>>>,
}

impl Workers {
    fn start(threads: usize) -> Result<Self, WorkersError> {
        let count = thread_count(threads)?;
        let handles = Arc::new(Mutex::new(Vec::with_capacity(count)));
        let keep = Arc::clone(&handles);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(count)
            .thread_name(|i| format!("transcut-{i}"))
            .spawn_handler(move |thread| {
                let mut builder = std::thread::Builder::new();
                if let Some(name) = thread.name() {
                    builder = builder.name(name.to_owned());
                }
                if let Some(size) = thread.stack_size() {
                    builder = builder.stack_size(size);
                }
                let handle = builder.spawn(move || {
                    WORKER.with(|w| w.set(true));
                    thread.run();
                })?;
                keep.lock().unwrap_or_else(PoisonError::into_inner).push(handle);
                Ok(())
            })
            .build()
            .map_err(|e| WorkersError::Spawn { threads: count, message: e.to_string() });
        // On a failed build, the threads it started have been told to stop: join them here.
        let mut workers = Self { pool: None, handles };
        workers.pool = Some(pool?);
        Ok(workers)
    }
}

impl Drop for Workers {
    fn drop(&mut self) {
        // Dropping the pool tells its threads to stop once their work is done; joining them
        // waits until they have.
        drop(self.pool.take());
        let handles = std::mem::take(&mut *self.handles.lock().unwrap_or_else(PoisonError::into_inner));
        for handle in handles {
            // A worker's panic was already passed to the call that ran the work.
            let _ = handle.join();
        }
        release_epoch_records();
    }
}

/// Lets crossbeam-epoch (the memory reclamation under rayon's work-stealing deques) free the
/// records of the threads that just ended. Each thread that used a deque has a record in the
/// collector's global list; an ended thread's record is only marked, and is unlinked and freed
/// when another thread next pins and collects. Without this the last pool's records stay
/// linked behind marked (tagged) pointers until the process exits, which a leak checker
/// reports as "possibly lost". A short-lived thread pins and flushes a few times (each flush
/// tries to advance the epoch, unlinks the marked records and frees what two epochs have
/// passed over); its own record is then the only one left, reachable from the list's head.
fn release_epoch_records() {
    let cleaner = std::thread::Builder::new().name("transcut-epoch".into()).spawn(|| {
        for _ in 0..4 {
            crossbeam_epoch::pin().flush();
        }
    });
    if let Ok(cleaner) = cleaner {
        let _ = cleaner.join();
    }
}

/// Runs `f` on a pool of `threads` worker threads (0: one per core) started for it, and joins
/// every thread of the pool before returning `f`'s result. Called from one of the library's
/// worker threads it runs `f` on the current pool, which the outer call joins.
///
/// # Errors
/// [`WorkersError`] when the count is above [`MAX_THREADS`] or a thread cannot be started.
pub fn with_workers<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> Result<R, WorkersError> {
    thread_count(threads)?;
    if is_worker_thread() {
        return Ok(f());
    }
    let workers = Workers::start(threads)?;
    let pool = workers.pool.as_ref().expect("a started pool");
    let result = pool.install(f);
    drop(workers);
    Ok(result)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    #[test]
    fn runs_on_the_asked_number_of_threads_and_marks_them() {
        let (n, marked, outside) = with_workers(3, || {
            let marked = (0..64).into_par_iter().all(|_| is_worker_thread());
            (rayon::current_num_threads(), marked, is_worker_thread())
        })
        .unwrap();
        assert_eq!(n, 3);
        assert!(marked);
        // `install` runs the closure itself on a worker too.
        assert!(outside);
        assert!(!is_worker_thread());
    }

    #[test]
    fn bounds_the_thread_count() {
        assert_eq!(thread_count(MAX_THREADS), Ok(256));
        assert_eq!(with_workers(MAX_THREADS + 1, || ()), Err(WorkersError::TooMany { threads: 257, max: 256 }));
        let message = WorkersError::TooMany { threads: 1000, max: MAX_THREADS }.to_string();
        assert_eq!(message, "threads = 1000 is above the maximum of 256");
        let cores = std::thread::available_parallelism().unwrap().get();
        assert_eq!(thread_count(0), Ok(cores.min(256)));
    }

    #[test]
    fn a_nested_call_uses_the_current_pool() {
        let inner = with_workers(2, || with_workers(5, rayon::current_num_threads).unwrap()).unwrap();
        assert_eq!(inner, 2);
    }

    /// The pool's threads are joined when the call returns: each worker's thread-local storage
    /// has been destroyed (which happens as a thread ends) by then, not some time later.
    #[test]
    fn every_worker_thread_has_ended_when_the_call_returns() {
        use std::sync::atomic::{AtomicUsize, Ordering};
        static ENDED: AtomicUsize = AtomicUsize::new(0);
        struct OnExit;
        impl Drop for OnExit {
            fn drop(&mut self) {
                ENDED.fetch_add(1, Ordering::SeqCst);
            }
        }
        thread_local! {
            static ON_EXIT: OnExit = const { OnExit };
        }
        let visited = with_workers(4, || rayon::broadcast(|_| ON_EXIT.with(|_| ())).len()).unwrap();
        assert_eq!(visited, 4);
        assert_eq!(ENDED.load(Ordering::SeqCst), 4);
    }
}
