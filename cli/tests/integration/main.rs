//! The CLI's integration tests, one module per command, linked into one test binary (one link
//! instead of one per file). Each runs the `transcut` binary the way a user or a script does.
//!
//! Run one command's tests by its module path:
//! `cargo test -p transcut-cli --test integration render::`.

mod acquire;
mod bench_edit;
mod bench_inverse;
mod bench_polygrid;
mod bench_radiosity;
mod bench_sphere;
mod cli;
mod dipole;
mod render;
