//! The bodies of libtranscut's fuzz targets, one plain function per target, so that the
//! stable-Rust smoke tests of the corpus (`core/tests/integration/fuzz_corpus.rs`,
//! `capi/tests/abi/fuzz_corpus.rs`, the CLI's `scene_file` tests) call exactly what the fuzzer
//! calls: they include the same files as modules.

// The core under its own name, for `core_targets.rs` (written as the core's tests write it).
extern crate transcut_core as transcut;

pub mod core_targets;

/// The CLI's scene-file schema (the CLI is a binary crate: its source is compiled in here).
#[allow(dead_code)]
#[path = "../../cli/src/scene_file/schema.rs"]
mod schema;
pub mod scene_target;

/// The C ABI (built only as C libraries: its source is compiled in here, as its tests do).
#[allow(dead_code, unused_imports)]
#[path = "../../capi/src/lib.rs"]
mod abi;
pub mod capi_target;
