//! The thread-local message of the last failed call.
//!
//! Every entry point clears it when it starts and sets it when it fails, so after a call it
//! describes that call's failure, or is empty after a success. The C string lives in this
//! thread's slot and is replaced by the next call on the thread, which is the lifetime the
//! header promises.

use std::cell::RefCell;
use std::ffi::{c_char, CString};

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

/// Replaces the thread's message. Interior NUL bytes (which a C string cannot hold) become `?`.
pub(crate) fn set_last_error(message: &str) {
    let bytes: Vec<u8> = message.bytes().map(|b| if b == 0 { b'?' } else { b }).collect();
    // Cannot fail: no NUL is left. Ignored if the thread is being torn down.
    let message = CString::new(bytes).unwrap_or_default();
    let _ = LAST_ERROR.try_with(|slot| *slot.borrow_mut() = message);
}

/// Empties the thread's message.
pub(crate) fn clear_last_error() {
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
    super::guard::value(c"".as_ptr(), || LAST_ERROR.try_with(|slot| slot.borrow().as_ptr()).unwrap_or(c"".as_ptr()))
}
