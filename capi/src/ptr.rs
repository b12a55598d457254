//! Reading the caller's pointer + length arguments, with every check a C caller can fail:
//! NULL with a non-zero length, misalignment, lengths whose byte size overflows, and strings
//! that are not UTF-8; and writing into the caller's buffers once every check has passed.

use std::ffi::{c_char, CStr};

use glam::DVec3;

use super::status::{Failure, TC_BUFFER_TOO_SHORT, TC_NULL_POINTER};

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
        return Err(Failure::invalid(format!("`{name}` is not aligned to {} bytes", align_of::<T>())));
    }
    if len.checked_mul(size_of::<T>()).is_none_or(|bytes| bytes > isize::MAX as usize) {
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

/// Points from the caller's `xyz` array of `count` points (3 doubles each).
///
/// # Safety
/// `ptr` must point to `3 × count` readable doubles when `count > 0`.
pub(crate) unsafe fn points(ptr: *const f64, count: usize, name: &str) -> Result<Vec<DVec3>, Failure> {
    let len = times(count, 3, name)?;
    // SAFETY: forwarded.
    let xyz = unsafe { slice(ptr, len, name)? };
    Ok(xyz.chunks_exact(3).map(|p| DVec3::new(p[0], p[1], p[2])).collect())
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

/// The caller's optional NUL-terminated file path ([`path`]): `None` for NULL; an empty string
/// is refused by name.
///
/// # Safety
/// As [`utf8`].
pub(crate) unsafe fn optional_path<'a>(ptr: *const c_char, name: &str) -> Result<Option<&'a std::path::Path>, Failure> {
    if ptr.is_null() {
        return Ok(None);
    }
    // SAFETY: forwarded to the caller's contract.
    let path = unsafe { path(ptr, name)? };
    if path.as_os_str().is_empty() {
        return Err(Failure::invalid(format!("`{name}` is an empty path (NULL means none)")));
    }
    Ok(Some(path))
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

/// Copies `text` and its NUL into the caller's `out[0..out_len]` and its size (bytes with the
/// NUL) into `*out_needed` (when not NULL). `out` may be NULL when `out_len` is 0: only the size
/// is returned. Nothing is written on failure.
///
/// # Safety
/// `out` NULL or `out_len` writable bytes; `out_needed` NULL or writable.
pub(crate) unsafe fn copy_text(text: &str, out: *mut c_char, out_len: usize, out_needed: *mut usize) -> Result<(), Failure> {
    if !out_needed.is_null() && !out_needed.is_aligned() {
        return Err(Failure::invalid("`out_needed` is not aligned for its type"));
    }
    let needed = text.len() + 1;
    if out.is_null() {
        if out_len != 0 {
            return Err(Failure::new(TC_NULL_POINTER, format!("`out` is NULL but out_len is {out_len}")));
        }
    } else if out_len < needed {
        return Err(Failure::new(
            TC_BUFFER_TOO_SHORT,
            format!("out_len = {out_len} bytes, but the text needs {needed} (with its NUL)"),
        ));
    } else {
        // SAFETY: `needed ≤ out_len` writable bytes (caller's contract); the text has no NUL
        // (the core's strings come from Rust, a NUL would only truncate it for C).
        unsafe {
            std::ptr::copy_nonoverlapping(text.as_ptr(), out.cast::<u8>(), text.len());
            out.add(text.len()).write(0);
        }
    }
    if !out_needed.is_null() {
        // SAFETY: checked above.
        unsafe { write(out_needed, needed) };
    }
    Ok(())
}

/// Writes the first `written` bytes of `value` over the caller's size-prefixed struct `out`
/// (a caller built against an older, shorter struct gets the fields it knows).
///
/// # Safety
/// `out` must be non-NULL and have at least `written` writable bytes; `written` must not exceed
/// the size of `T`.
pub(crate) unsafe fn write_prefix<T>(out: *mut T, value: &T, written: usize) {
    debug_assert!(written <= size_of::<T>());
    // SAFETY: the caller's contract. A byte copy of a prefix (padding included) of a built value.
    unsafe { std::ptr::copy_nonoverlapping(std::ptr::from_ref(value).cast::<u8>(), out.cast::<u8>(), written) };
}
