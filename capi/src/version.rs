//! The library's version, at run time (the header's `TRANSCUT_VERSION_*` macros give the
//! version it was generated for; a program can compare the two).

use std::ffi::c_char;

/// Parses a decimal version component at compile time.
const fn parse(s: &str) -> u32 {
    let bytes = s.as_bytes();
    let mut value = 0u32;
    let mut i = 0;
    while i < bytes.len() {
        value = value * 10 + (bytes[i] - b'0') as u32;
        i += 1;
    }
    value
}

pub(crate) const MAJOR: u32 = parse(env!("CARGO_PKG_VERSION_MAJOR"));
pub(crate) const MINOR: u32 = parse(env!("CARGO_PKG_VERSION_MINOR"));
pub(crate) const PATCH: u32 = parse(env!("CARGO_PKG_VERSION_PATCH"));

/// The library's version as `major << 16 | minor << 8 | patch` (compare with
/// `TRANSCUT_VERSION`).
#[no_mangle]
pub extern "C" fn tc_version() -> u32 {
    super::status::value(0, || (MAJOR << 16) | (MINOR << 8) | PATCH)
}

/// The library's version as a static string, e.g. "0.1.0". Never NULL; do not free it.
#[no_mangle]
pub extern "C" fn tc_version_string() -> *const c_char {
    const VERSION: &str = concat!(env!("CARGO_PKG_VERSION"), "\0");
    super::status::value(c"".as_ptr(), || VERSION.as_ptr().cast())
}
