//! The C ABI of libtranscut: `libtranscut.so` and `libtranscut.a`, declared in
//! `include/transcut.h`, which cbindgen generates from these sources (`capi/cbindgen.toml`;
//! `capi/tests/header.rs` fails when the committed header is stale and rewrites it with
//! `TRANSCUT_BLESS=1`).
//!
//! Conventions (ARCHITECTURE.md, "The C ABI"):
//! - every function is `tc_*` and returns a `TcStatus` (0 = `TC_OK`); on failure
//!   `tc_last_error_message()` describes it (thread-local, UTF-8) and every output argument is
//!   left untouched;
//! - no panic crosses the boundary: every body runs inside `guard::run` (catch_unwind →
//!   `TC_INTERNAL_ERROR`); pointer arguments are checked with `check_not_null!`, which names
//!   the argument;
//! - opaque handles (`TcScene`) are created and freed by the library; arrays are pointer +
//!   length, copied on input; outputs go to caller-owned buffers whose length is checked;
//! - option and statistics structs start with their own `size`.
//!
//! Every module is a direct child of this one and names its siblings `super::…`: the Rust
//! tests (`capi/tests/abi`) compile this file as a module of their own and call the
//! `extern "C"` functions with raw pointers, the way a foreign program does. (The library is
//! built only as a cdylib and a staticlib, so there is no rlib to link them against.)

#![deny(unsafe_op_in_unsafe_fn)]
#![allow(clippy::missing_safety_doc)] // the contract of each function is in its doc comment

#[macro_use]
mod guard;
mod bake;
mod edit;
mod error;
mod handle;
mod light;
mod medium;
mod ptr;
mod scene;
mod status;
mod test_hooks;
mod version;
mod volume;

pub use bake::*;
pub use edit::*;
pub use error::*;
pub use handle::TcScene;
pub use light::*;
pub use medium::*;
pub use scene::*;
pub use status::*;
pub use test_hooks::*;
pub use version::*;
pub use volume::*;
