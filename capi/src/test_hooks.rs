//! Entry points that exist only to test the boundary itself; not in the header.

use super::status::run;
use super::status::TcStatus;

/// Panics inside the guarded body, to prove that a panic comes back as `TC_INTERNAL_ERROR`
/// with a message instead of unwinding into (and aborting) the caller. Undocumented; tests
/// declare it themselves: `TcStatus tc_debug_panic(void);`.
///
/// cbindgen:ignore
#[doc(hidden)]
#[no_mangle]
pub extern "C" fn tc_debug_panic() -> TcStatus {
    run("tc_debug_panic", || panic!("deliberate panic from tc_debug_panic (a test of the C ABI's panic guard)"))
}
