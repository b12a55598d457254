//! The subsurface methods this library has, by number (`TcBakeOptions.method`) and name.

use std::ffi::c_char;

use transcut_core::Method;

use super::ptr;
use super::status::{run, value, Failure, TcStatus, TC_NOT_FOUND};

/// The method numbered `method`.
fn method(method: u32) -> Result<Method, Failure> {
    let names = Method::NAMES;
    names.get(method as usize).and_then(|name| Method::from_name(name)).ok_or_else(|| {
        Failure::new(TC_NOT_FOUND, format!("method {method} does not exist (the library has {} methods)", names.len()))
    })
}

/// The number of subsurface methods this library has: `TcBakeOptions.method` takes the values
/// 0 to `tc_method_count() - 1` (`TC_METHOD_TRANSCUT` = 0 first; new methods are appended).
#[no_mangle]
pub extern "C" fn tc_method_count() -> u32 {
    value(0, || u32::try_from(Method::NAMES.len()).unwrap_or(u32::MAX))
}

/// Copies the name of method `method` (e.g. "transcut"; the names the CLI, scene files and the
/// Blender add-on use) into `out` as a NUL-terminated UTF-8 string, as `tc_object_device`
/// copies its text: `out_len` is the size of `out` in bytes, `*out_needed` (nullable) the size
/// the name needs, NUL included; `out` = NULL with `out_len` = 0 asks for the size only.
/// `TC_NOT_FOUND` for a method number this library does not have; `TC_BUFFER_TOO_SHORT` when
/// the name does not fit. On failure nothing is written.
#[no_mangle]
pub unsafe extern "C" fn tc_method_name(method: u32, out: *mut c_char, out_len: usize, out_needed: *mut usize) -> TcStatus {
    run("tc_method_name", || {
        let m = self::method(method)?;
        // SAFETY: the caller's contract.
        unsafe { ptr::copy_text(m.name(), out, out_len, out_needed) }
    })
}

/// Copies a one-line description of method `method` into `out`, as `tc_method_name` copies the
/// name.
#[no_mangle]
pub unsafe extern "C" fn tc_method_description(
    method: u32,
    out: *mut c_char,
    out_len: usize,
    out_needed: *mut usize,
) -> TcStatus {
    run("tc_method_description", || {
        let m = self::method(method)?;
        // SAFETY: the caller's contract.
        unsafe { ptr::copy_text(m.description(), out, out_len, out_needed) }
    })
}

/// The number of the method called `name` (any case) into `*out_method`. `TC_NOT_FOUND`
/// listing the valid names for any other name; `*out_method` is then unchanged.
#[no_mangle]
pub unsafe extern "C" fn tc_method_from_name(name: *const c_char, out_method: *mut u32) -> TcStatus {
    run("tc_method_from_name", || {
        check_not_null!(out_method);
        // SAFETY: the caller's contract.
        let name = unsafe { ptr::utf8(name, "name")? };
        let wanted = Method::from_name(name).ok_or_else(|| Failure::new(TC_NOT_FOUND, Method::unknown(name)))?;
        let index = Method::NAMES
            .iter()
            .position(|n| *n == wanted.name())
            .ok_or_else(|| Failure::new(TC_NOT_FOUND, Method::unknown(name)))?;
        // SAFETY: checked above.
        unsafe { ptr::write(out_method, index as u32) };
        Ok(())
    })
}
