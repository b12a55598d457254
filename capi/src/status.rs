//! The boundary of every call: the status it returns, the thread's last-error message, and
//! the guard that runs every `extern "C"` body.
//!
//! - [`TcStatus`]: `TC_OK` (0) or a `TC_*` code, values fixed forever, new ones appended;
//! - the last error: a thread-local C string that every entry point clears when it starts and
//!   sets when it fails, so after a call it describes that call's failure (or is empty); it
//!   lives until the next call on the thread, the lifetime the header promises;
//! - [`run`] and [`value`]: every body runs inside `catch_unwind` (a panic must never unwind into
//!   C, where it would abort the host application) and a failure becomes a status plus the
//!   message (metatensor's `c_api/status.rs` does the same); `check_not_null!` names a NULL or
//!   misaligned pointer argument;
//! - the panic hook: a library must not write to its host's stderr, so a panic raised inside
//!   the guard (or on one of the library's worker threads) prints nothing: its message and
//!   location go into the last-error text instead. Panics anywhere else in the process reach
//!   the hook that was installed before (the host's, or Rust's default).

use std::any::Any;
use std::cell::{Cell, RefCell};
use std::ffi::{c_char, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe, PanicHookInfo};
use std::sync::{Mutex, Once, PoisonError};

/// The result of a call: `TC_OK` (0) on success, another `TC_*` code on failure, with a message
/// from `tc_last_error_message()`.
///
/// Values are fixed forever; new codes are only appended. Unknown codes must be treated as
/// failures.
#[repr(transparent)]
#[must_use]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct TcStatus(pub i32);

/// Success.
pub const TC_OK: TcStatus = TcStatus(0);
/// A pointer argument is NULL (the message names it).
pub const TC_NULL_POINTER: TcStatus = TcStatus(1);
/// An argument is out of range, not finite, or otherwise invalid (the message names it).
pub const TC_INVALID_ARGUMENT: TcStatus = TcStatus(2);
/// A handle is not valid, or an object index does not exist in the scene.
pub const TC_INVALID_HANDLE: TcStatus = TcStatus(3);
/// An output buffer is shorter than the result (the message gives both lengths); nothing was
/// written.
pub const TC_BUFFER_TOO_SHORT: TcStatus = TcStatus(4);
/// A triangle or tetrahedral mesh is invalid: empty, a NaN or infinite coordinate, an index out
/// of range, degenerate or non-manifold elements.
pub const TC_INVALID_MESH: TcStatus = TcStatus(5);
/// The surface could not be turned into tetrahedra (`TC_METHOD_POLYGRID`: into a polycube grid
/// that keeps its topology and does not fold).
pub const TC_MESHING_FAILED: TcStatus = TcStatus(6);
/// Assembling or solving the diffusion system failed (e.g. no convergence).
pub const TC_SOLVE_FAILED: TcStatus = TcStatus(7);
/// A named thing does not exist: an unknown medium preset, a missing file.
pub const TC_NOT_FOUND: TcStatus = TcStatus(8);
/// A file exists but could not be read or decoded.
pub const TC_IO_ERROR: TcStatus = TcStatus(9);
/// The progress callback asked to stop; the scene is unchanged and can be baked again.
pub const TC_CANCELLED: TcStatus = TcStatus(10);
/// Results were asked for before a successful bake (or after the scene was changed).
pub const TC_NOT_BAKED: TcStatus = TcStatus(11);
/// A bug in libtranscut (an internal panic, caught at the boundary); the message says where.
/// The scene is still valid but its last results may be gone.
pub const TC_INTERNAL_ERROR: TcStatus = TcStatus(12);
/// The scene is in use by another call that has not returned: from another thread, or a call
/// on the same scene from inside its progress callback. A `TcScene` serves one call at a time.
pub const TC_BUSY: TcStatus = TcStatus(13);
/// The GPU was required (`TC_BACKEND_GPU`, or `TRANSCUT_BACKEND=gpu` with `TC_BACKEND_DEFAULT`)
/// and could not be used: no adapter (no Vulkan/Metal/DX12 driver), the device could not be
/// created, the library was built without GPU support, or the device failed during the solve.
/// The message says which; `TC_BACKEND_AUTO` falls back to the CPU instead.
pub const TC_GPU_UNAVAILABLE: TcStatus = TcStatus(14);
/// A cut would remove every tetrahedron of the object; nothing changed.
pub const TC_NOTHING_LEFT: TcStatus = TcStatus(15);
/// The chosen method cannot do what was asked (bake this object, or this kind of edit); the
/// message names the method and the reason. Nothing changed.
pub const TC_UNSUPPORTED: TcStatus = TcStatus(16);
/// The method cannot resolve the object's medium at this mesh size (TransCut: σtr·h at the
/// surface above its bound), so its radiance would be wrong (too dark or zero): a bake, or a
/// medium edit or paint stroke that would put such a medium at the surface. The message names
/// the channel, σtr·h, the mesh spacing in mm and the tet count or object scale that would
/// resolve it. Nothing changed.
pub const TC_UNRESOLVED: TcStatus = TcStatus(17);

impl TcStatus {
    /// The constant's name, e.g. `"TC_NULL_POINTER"`, or `"unknown status"`.
    #[must_use]
    pub fn name(self) -> &'static CStr {
        match self.0 {
            0 => c"TC_OK",
            1 => c"TC_NULL_POINTER",
            2 => c"TC_INVALID_ARGUMENT",
            3 => c"TC_INVALID_HANDLE",
            4 => c"TC_BUFFER_TOO_SHORT",
            5 => c"TC_INVALID_MESH",
            6 => c"TC_MESHING_FAILED",
            7 => c"TC_SOLVE_FAILED",
            8 => c"TC_NOT_FOUND",
            9 => c"TC_IO_ERROR",
            10 => c"TC_CANCELLED",
            11 => c"TC_NOT_BAKED",
            12 => c"TC_INTERNAL_ERROR",
            13 => c"TC_BUSY",
            14 => c"TC_GPU_UNAVAILABLE",
            15 => c"TC_NOTHING_LEFT",
            16 => c"TC_UNSUPPORTED",
            17 => c"TC_UNRESOLVED",
            _ => c"unknown status",
        }
    }
}

/// The name of a status code, e.g. `"TC_NULL_POINTER"` for 1, or `"unknown status"` for a code
/// this library does not know. Never NULL; a static string the caller must not free.
#[no_mangle]
pub extern "C" fn tc_status_name(status: TcStatus) -> *const c_char {
    value(c"unknown status".as_ptr(), || status.name().as_ptr())
}

/// A failed call: the status to return and the message for `tc_last_error_message()`.
#[derive(Debug)]
pub(crate) struct Failure {
    pub status: TcStatus,
    pub message: String,
}

impl Failure {
    pub(crate) fn new(status: TcStatus, message: impl Into<String>) -> Self {
        Self { status, message: message.into() }
    }

    /// `TC_INVALID_ARGUMENT` with a message.
    pub(crate) fn invalid(message: impl Into<String>) -> Self {
        Self::new(TC_INVALID_ARGUMENT, message)
    }
}

/// Runs the body of entry point `name`: clears the last error, returns `TC_OK` on success, and
/// on failure (an `Err`, or a panic) sets the message, prefixed with `name`, and returns the
/// failure's status (`TC_INTERNAL_ERROR` for a panic).
pub(crate) fn run(name: &str, body: impl FnOnce() -> Result<(), Failure>) -> TcStatus {
    clear_last_error();
    match guarded(body) {
        Ok(Ok(())) => TC_OK,
        Ok(Err(failure)) => {
            set_last_error(&format!("{name}: {}", failure.message));
            failure.status
        }
        Err(panic) => {
            set_last_error(&format!("{name}: internal error (a bug in libtranscut): {panic}"));
            TC_INTERNAL_ERROR
        }
    }
}

/// As [`run`], with the body on the library's worker threads (one per core, joined before the
/// call returns), for entry points whose work is parallel outside a bake: without a pool of
/// the library's, rayon would start its global pool, whose threads are never joined.
pub(crate) fn run_on_workers(name: &str, body: impl FnOnce() -> Result<(), Failure>) -> TcStatus {
    /// Lets the body, which may hold the caller's raw pointers, run on a worker: the calling
    /// thread waits inside `with_workers` until it has returned, as with a scoped thread.
    struct OnWorker<F>(F);
    // SAFETY: see above; the pointers are only used while the caller is blocked in this call.
    unsafe impl<F> Send for OnWorker<F> {}
    impl<F> OnWorker<F> {
        /// Takes the whole wrapper into a closure (a closure would otherwise capture the field).
        fn into_inner(self) -> F {
            self.0
        }
    }
    let body = OnWorker(body);
    run(name, move || {
        transcut_core::workers::with_workers(0, move || OnWorker(body.into_inner()()))
            .map_err(|e| Failure::new(TC_INTERNAL_ERROR, e.to_string()))?
            .into_inner()
    })
}

/// Runs the body of an entry point that returns a value instead of a status and cannot fail;
/// a panic (a bug) returns `fallback`. The last error is left alone.
pub(crate) fn value<T>(fallback: T, body: impl FnOnce() -> T) -> T {
    guarded(body).unwrap_or(fallback)
}

thread_local! {
    /// How many guarded bodies this thread is inside (a callback may call into the library).
    static GUARD_DEPTH: Cell<u32> = const { Cell::new(0) };
    /// Where the last panic inside the guard on this thread was raised (`file:line:column`).
    static PANIC_LOCATION: RefCell<Option<String>> = const { RefCell::new(None) };
}

/// Where the last panic on one of the library's worker threads was raised: the hook runs on the
/// panicking thread, and the guard that catches the panic on the calling thread reads it.
static WORKER_PANIC_LOCATION: Mutex<Option<String>> = Mutex::new(None);

/// Runs `body` with the silent panic hook in place and this thread marked as inside the guard;
/// a panic comes back as its text: the message and, when known, where it was raised.
fn guarded<T>(body: impl FnOnce() -> T) -> Result<T, String> {
    install_panic_hook();
    let _ = PANIC_LOCATION.try_with(|l| l.borrow_mut().take());
    let _ = GUARD_DEPTH.try_with(|d| d.set(d.get() + 1));
    let result = catch_unwind(AssertUnwindSafe(body));
    let _ = GUARD_DEPTH.try_with(|d| d.set(d.get().saturating_sub(1)));
    result.map_err(|payload| {
        let location = PANIC_LOCATION
            .try_with(|l| l.borrow_mut().take())
            .ok()
            .flatten()
            .or_else(|| WORKER_PANIC_LOCATION.lock().unwrap_or_else(PoisonError::into_inner).take());
        panic_text(panic_message(payload.as_ref()), location.as_deref())
    })
}

/// A panic's message followed by where it was raised, when that is known.
fn panic_text(message: &str, location: Option<&str>) -> String {
    match location {
        Some(at) => format!("{message} (at {at})"),
        None => message.to_owned(),
    }
}

/// Installs, once per process, the hook that keeps the library's panics off the host's stderr:
/// silent while the panicking thread is inside the guard or is one of the library's worker
/// threads (recording the location for the guard's message), the previous hook otherwise.
fn install_panic_hook() {
    static INSTALL: Once = Once::new();
    INSTALL.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info: &PanicHookInfo<'_>| {
            let location = info.location().map(|l| format!("{}:{}:{}", l.file(), l.line(), l.column()));
            if GUARD_DEPTH.try_with(Cell::get).unwrap_or(0) > 0 {
                let _ = PANIC_LOCATION.try_with(|l| *l.borrow_mut() = location);
            } else if transcut_core::workers::is_worker_thread() {
                *WORKER_PANIC_LOCATION.lock().unwrap_or_else(PoisonError::into_inner) = location;
            } else {
                previous(info);
            }
        }));
    });
}

/// The text of a panic payload (`panic!` gives a `&str` or a `String`).
fn panic_message(payload: &(dyn Any + Send)) -> &str {
    if let Some(s) = payload.downcast_ref::<&str>() {
        s
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s
    } else {
        "a panic without a message"
    }
}

/// Checks pointer arguments before any work: `return Err(TC_NULL_POINTER)` naming the argument
/// when one is NULL, `Err(TC_INVALID_ARGUMENT)` when one is not aligned for its type.
macro_rules! check_not_null {
    ($($arg:ident),+ $(,)?) => {
        $(
            if $arg.is_null() {
                return Err(super::status::Failure::new(
                    super::status::TC_NULL_POINTER,
                    concat!("`", stringify!($arg), "` is NULL"),
                ));
            }
            if !$arg.is_aligned() {
                return Err(super::status::Failure::invalid(concat!("`", stringify!($arg), "` is not aligned for its type")));
            }
        )+
    };
}

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

/// Replaces the thread's message. Interior NUL bytes (which a C string cannot hold) become `?`.
fn set_last_error(message: &str) {
    let bytes: Vec<u8> = message.bytes().map(|b| if b == 0 { b'?' } else { b }).collect();
    // Cannot fail: no NUL is left. Ignored if the thread is being torn down.
    let message = CString::new(bytes).unwrap_or_default();
    let _ = LAST_ERROR.try_with(|slot| *slot.borrow_mut() = message);
}

/// Empties the thread's message.
fn clear_last_error() {
    let _ = LAST_ERROR.try_with(|slot| {
        let mut slot = slot.borrow_mut();
        if !slot.as_bytes().is_empty() {
            *slot = CString::default();
        }
    });
}

/// The message of the last call on this thread that failed, as UTF-8; the empty string when
/// that call succeeded. Never NULL. The string belongs to the library and stays valid until the
/// next `tc_*` call on the same thread (copy it to keep it).
#[no_mangle]
pub extern "C" fn tc_last_error_message() -> *const c_char {
    value(c"".as_ptr(), || LAST_ERROR.try_with(|slot| slot.borrow().as_ptr()).unwrap_or(c"".as_ptr()))
}
