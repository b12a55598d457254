//! Reading the caller's pointer + length arguments, with every check a C caller can fail:
//! NULL with a non-zero length, misalignment, lengths whose byte size overflows, and strings
//! that are not UTF-8. Nothing here writes to caller memory.

use std::ffi::{c_char, CStr};

use super::guard::Failure;
use super::status::TC_NULL_POINTER;

/// The caller's array `ptr[0..len]`; `ptr` may be NULL when `len` is 0.
///
/// # Safety
/// When `ptr` is not NULL it must point to `len` readable, initialised values that the caller
/// does not modify during the call.
pub(crate) unsafe fn slice<'a, T>(ptr: *const T, len: usize, name: &str) -> Result<&'a [T], Failure> {
    if len == 0 {
        return Ok(&[]);
    }
    if ptr.is_null() {
        return Err(Failure::new(TC_NULL_POINTER, format!("`{name}` is NULL but its length is {len}")));
    }
    if !ptr.is_aligned() {
        return Err(Failure::invalid(format!("`{name}` is not aligned to {} bytes", std::mem::align_of::<T>())));
    }
    if len.checked_mul(std::mem::size_of::<T>()).is_none_or(|bytes| bytes > isize::MAX as usize) {
        return Err(Failure::invalid(format!("`{name}`: length {len} is too large")));
    }
    // SAFETY: non-null, aligned, size in range; validity of the memory is the caller's contract.
    Ok(unsafe { std::slice::from_raw_parts(ptr, len) })
}

/// `count × per` as a length, or an error naming `what` when it overflows.
pub(crate) fn times(count: usize, per: usize, what: &str) -> Result<usize, Failure> {
    count.checked_mul(per).ok_or_else(|| Failure::invalid(format!("{what}: count {count} is too large")))
}

/// Three values from the caller's `const double v[3]`.
///
/// # Safety
/// A non-NULL `ptr` must point to three readable doubles.
pub(crate) unsafe fn vec3(ptr: *const f64, name: &str) -> Result<[f64; 3], Failure> {
    if ptr.is_null() {
        return Err(Failure::new(TC_NULL_POINTER, format!("`{name}` is NULL")));
    }
    // SAFETY: forwarded to the caller's contract.
    let s = unsafe { slice(ptr, 3, name)? };
    Ok([s[0], s[1], s[2]])
}

/// The caller's NUL-terminated UTF-8 string.
///
/// # Safety
/// A non-NULL `ptr` must point to a NUL-terminated string that stays unchanged during the call.
pub(crate) unsafe fn utf8<'a>(ptr: *const c_char, name: &str) -> Result<&'a str, Failure> {
    if ptr.is_null() {
        return Err(Failure::new(TC_NULL_POINTER, format!("`{name}` is NULL")));
    }
    // SAFETY: forwarded to the caller's contract.
    let s = unsafe { CStr::from_ptr(ptr) };
    s.to_str().map_err(|e| Failure::invalid(format!("`{name}` is not valid UTF-8 ({e})")))
}

/// The caller's NUL-terminated file path: any bytes on Unix (as the operating system takes
/// them), UTF-8 elsewhere.
///
/// # Safety
/// As [`utf8`].
pub(crate) unsafe fn path<'a>(ptr: *const c_char, name: &str) -> Result<&'a std::path::Path, Failure> {
    if ptr.is_null() {
        return Err(Failure::new(TC_NULL_POINTER, format!("`{name}` is NULL")));
    }
    // SAFETY: forwarded to the caller's contract.
    let s = unsafe { CStr::from_ptr(ptr) };
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        Ok(std::path::Path::new(std::ffi::OsStr::from_bytes(s.to_bytes())))
    }
    #[cfg(not(unix))]
    {
        let s = s.to_str().map_err(|e| Failure::invalid(format!("`{name}` is not valid UTF-8 ({e})")))?;
        Ok(std::path::Path::new(s))
    }
}

/// Writes `value` to the caller's `*out` (checked for NULL before any work by the caller of
/// this function, so a failing call leaves it untouched).
///
/// # Safety
/// `out` must be non-NULL, aligned and writable.
pub(crate) unsafe fn write<T>(out: *mut T, value: T) {
    // SAFETY: the caller's contract; `write` does not read or drop the old value.
    unsafe { out.write(value) }
}
