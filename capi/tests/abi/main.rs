//! The C ABI called the way a foreign program calls it: raw pointers, status codes, the
//! thread-local message, caller-owned buffers. The ABI sources are compiled into this test as
//! the module `abi` (the library itself is only a cdylib/staticlib); nothing here uses Rust
//! types of the library other than its `#[repr(C)]` structs and `extern "C"` functions.

#[allow(dead_code, unused_imports)]
#[path = "../../src/lib.rs"]
mod abi;

mod common;

mod acquire;
mod backend;
mod bake;
mod concurrency;
mod edit;
mod fuzz_corpus;
mod header;
mod kept_meshes;
mod method;
mod misuse;
mod objects;
mod polygrid;
mod prt;
mod radiosity;
mod tets;
mod texture;
