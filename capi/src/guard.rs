//! The boundary: every `extern "C"` body runs inside [`run`] (or [`value`]), which catches
//! panics (a panic must never unwind into C, where it would abort the host application) and turns
//! failures into a status code plus the thread's last-error message (metatensor's
//! `c_api/status.rs` does the same).

use std::any::Any;
use std::panic::{catch_unwind, AssertUnwindSafe};

use super::error::{clear_last_error, set_last_error};
use super::status::{TcStatus, TC_INTERNAL_ERROR, TC_INVALID_ARGUMENT, TC_OK};

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
    match catch_unwind(AssertUnwindSafe(body)) {
        Ok(Ok(())) => TC_OK,
        Ok(Err(failure)) => {
            set_last_error(&format!("{name}: {}", failure.message));
            failure.status
        }
        Err(payload) => {
            set_last_error(&format!("{name}: internal error (a bug in libtranscut): {}", panic_message(payload.as_ref())));
            TC_INTERNAL_ERROR
        }
    }
}

/// Runs the body of an entry point that returns a value instead of a status and cannot fail;
/// a panic (a bug) returns `fallback`. The last error is left alone.
pub(crate) fn value<T>(fallback: T, body: impl FnOnce() -> T) -> T {
    catch_unwind(AssertUnwindSafe(body)).unwrap_or(fallback)
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
                return Err(super::guard::Failure::new(
                    super::status::TC_NULL_POINTER,
                    concat!("`", stringify!($arg), "` is NULL"),
                ));
            }
            if !$arg.is_aligned() {
                return Err(super::guard::Failure::invalid(concat!("`", stringify!($arg), "` is not aligned for its type")));
            }
        )+
    };
}
