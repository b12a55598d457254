//! The CLI's integration tests, one module per command, linked into one test binary (one link
//! instead of one per file). Each runs the `transcut` binary the way a user or a script does.
//!
//! Run one command's tests by its module path:
//! `cargo test -p transcut-cli --test integration render::`.

use std::process::Command;

/// `transcut bench ARGS` run to success: its JSON report.
fn bench_report(args: &[&str]) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_transcut")).arg("bench").args(args).output().unwrap();
    assert!(out.status.success(), "bench {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

mod acquire;
mod bench_edit;
mod bench_inverse;
mod bench_mesh;
mod bench_polygrid;
mod bench_radiosity;
mod bench_sphere;
mod cli;
mod dipole;
mod render;
