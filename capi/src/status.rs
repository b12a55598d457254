//! The status every call returns.

use std::ffi::{c_char, CStr};

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
/// The surface could not be turned into tetrahedra.
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
            _ => c"unknown status",
        }
    }
}

/// The name of a status code, e.g. `"TC_NULL_POINTER"` for 1, or `"unknown status"` for a code
/// this library does not know. Never NULL; a static string the caller must not free.
#[no_mangle]
pub extern "C" fn tc_status_name(status: TcStatus) -> *const c_char {
    super::guard::value(c"unknown status".as_ptr(), || status.name().as_ptr())
}
