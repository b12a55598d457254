//! The C ABI of libtranscut: `libtranscut.so` and `libtranscut.a`, declared in
//! `include/transcut.h`, which cbindgen generates from these sources (`capi/cbindgen.toml`;
//! `capi/tests/abi/header.rs` fails when the committed header is stale and rewrites it with
//! `TRANSCUT_BLESS=1`).
//!
//! Conventions (ARCHITECTURE.md, "The C ABI"):
//! - every function is `tc_*` and returns a `TcStatus` (0 = `TC_OK`); on failure
//!   `tc_last_error_message()` describes it (thread-local, UTF-8) and every output argument is
//!   left untouched;
//! - no panic crosses the boundary: every body runs inside `status::run` (catch_unwind →
//!   `TC_INTERNAL_ERROR`); pointer arguments are checked with `check_not_null!`, which names
//!   the argument;
//! - opaque handles (`TcScene`) are created and freed by the library; arrays are pointer +
//!   length, copied on input; outputs go to caller-owned buffers whose length is checked;
//! - option and statistics structs start with their own `size`.
//!
//! The modules are layers: `status` (the boundary), the leaves (`ptr`, `convert`, `options`,
//! `progress`), `handle` (the scene and its core [`transcut_core::Session`]), then the entry
//! points, which import only from those and never from each other (`core/tests/integration/layering.rs`
//! checks it). Every module is a direct child of this one and names its siblings `super::…`: the Rust
//! tests (`capi/tests/abi`) compile this file as a module of their own and call the
//! `extern "C"` functions with raw pointers, the way a foreign program does. (The library is
//! built only as a cdylib and a staticlib, so there is no rlib to link them against.)

#![deny(unsafe_op_in_unsafe_fn)]
#![allow(clippy::missing_safety_doc)] // the contract of each function is in its doc comment

#[macro_use]
mod status;
// Leaves: pointer reading, the core↔C conversions, the options, the progress callback.
mod convert;
mod options;
mod progress;
mod ptr;
// The scene handle and its session.
mod handle;
// Entry points: each imports only from the modules above.
mod acquire;
mod bake;
mod cut;
mod deform;
mod edit_stats;
mod light;
mod material;
mod medium;
mod method;
mod pieces;
mod prt;
mod relight;
mod scene;
mod test_hooks;
mod texture;
mod version;
mod volume;

pub use acquire::*;
pub use bake::*;
pub use convert::{TcArtistMedium, TcMedium, TC_ARTIST_DIPOLE, TC_ARTIST_RANDOM_WALK, TC_ARTIST_RANDOM_WALK_SKIN};
pub use cut::*;
pub use deform::*;
pub use edit_stats::*;
pub use handle::TcScene;
pub use light::*;
pub use material::*;
pub use medium::*;
pub use method::*;
pub use options::*;
pub use pieces::*;
pub use progress::TcProgressFn;
pub use prt::*;
pub use relight::*;
pub use scene::*;
pub use status::*;
pub use test_hooks::*;
pub use texture::*;
pub use version::*;
pub use volume::*;
