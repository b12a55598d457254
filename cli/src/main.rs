//! `transcut`: mesh, bake, render and benchmark translucent objects from the shell.

mod acquire_cmd;
mod animate_cmd;
mod bake_cmd;
mod bench;
mod mesh_cmd;
mod method_args;
mod object_args;
mod output;
mod progress;
mod prt_cmd;
mod render_cmd;
mod scene_file;
mod spec;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Subsurface scattering for translucent objects (marble, wax, milk, jade, skin), computed as
/// per-vertex radiance by solving the diffusion equation on a tetrahedral mesh.
#[derive(Parser)]
#[command(name = "transcut", version, about, long_about = None, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Fill a surface mesh (OBJ or PLY) with quality tetrahedra and write them as VTK.
    Mesh(mesh_cmd::MeshArgs),
    /// Bake per-vertex subsurface radiance of a mesh under lights and write it with the mesh.
    Bake(bake_cmd::BakeArgs),
    /// Bake every frame of a deforming mesh (one topology, moved vertices) and write the
    /// radiance of all frames as one .npy.
    Animate(animate_cmd::AnimateArgs),
    /// Bake a TOML scene file and render it to PNG or EXR.
    Render(render_cmd::RenderArgs),
    /// The PRT method's precompute saved once (`prt precompute`), then any medium and lights
    /// evaluated from it (`prt eval`).
    Prt(prt_cmd::PrtArgs),
    /// Measure a heterogeneous material volume from images of a lit block (inverse diffusion,
    /// J. Wang et al. 2008 §4) and write it as a voxel grid; `acquire synth` writes a synthetic
    /// data set to try it on.
    Acquire(acquire_cmd::AcquireArgs),
    /// Run benchmarks and print JSON.
    Bench(bench::BenchArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Mesh(args) => mesh_cmd::run(&args),
        Command::Bake(args) => bake_cmd::run(&args),
        Command::Animate(args) => animate_cmd::run(&args),
        Command::Render(args) => render_cmd::run(&args),
        Command::Prt(args) => prt_cmd::run(&args),
        Command::Acquire(args) => acquire_cmd::run(&args),
        Command::Bench(args) => bench::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("transcut: error: {}", cap_message(&error_chain(&e)));
            ExitCode::FAILURE
        }
    }
}

/// The longest error message printed, in bytes.
const MAX_MESSAGE_BYTES: usize = 1024;

/// `message` cut to at most [`MAX_MESSAGE_BYTES`] on a character boundary, ending in `…` and
/// the full length when cut: every part of a message quotes its input short already, so this
/// only bounds what several long parts add up to.
fn cap_message(message: &str) -> String {
    if message.len() <= MAX_MESSAGE_BYTES {
        return message.to_owned();
    }
    let suffix = format!("… ({} bytes)", message.len());
    let mut end = MAX_MESSAGE_BYTES - suffix.len();
    while !message.is_char_boundary(end) {
        end -= 1;
    }
    format!("{}{suffix}", &message[..end])
}

/// The error and its causes joined by ": ", skipping a cause whose text the previous message
/// already contains (the core's errors include their source in their own message).
fn error_chain(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if !out.contains(&text) {
            if !out.is_empty() {
                out.push_str(": ");
            }
            out.push_str(&text);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_are_capped_at_1_kib() {
        assert_eq!(cap_message("short"), "short");
        let long = "é".repeat(2000); // 4000 bytes
        let capped = cap_message(&long);
        assert!(capped.len() <= MAX_MESSAGE_BYTES, "{}", capped.len());
        assert!(capped.ends_with("… (4000 bytes)"), "{capped}");
        assert!(capped.len() > MAX_MESSAGE_BYTES - 20);
    }
}
