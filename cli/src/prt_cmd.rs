//! `transcut prt precompute|eval`: the PRT method's precompute saved to a `.tcprt` file once,
//! then any medium and lights evaluated from it in a fraction of the time.

use std::path::PathBuf;

use anyhow::{bail, Context};
use clap::{Args, Subcommand};
use transcut::prt::{io, PrtCache};
use transcut::{bake_with, BakeOptions, Method, Progress};

use crate::method_args::{MethodArgs, MethodDefaults};
use crate::object_args::{ObjectArgs, FORMS_HELP};
use crate::progress::StageBar;

/// Arguments of `transcut prt`.
#[derive(Args)]
pub struct PrtArgs {
    #[command(subcommand)]
    pub command: PrtCommand,
}

#[derive(Subcommand)]
pub enum PrtCommand {
    /// Precompute the PRT transfer of a mesh (the slow, light- and material-independent step)
    /// and save it as a .tcprt file.
    #[command(after_help = "The transfer depends on the surface, --scale and the PRT options only: `prt eval` then takes \
                            any medium (of the same η and g) and any lights. --medium is checked against what the \
                            samples resolve.

Example:
  transcut prt precompute bunny.obj --scale 40 --prt-samples 16 -o bunny.tcprt")]
    Precompute(Box<PrecomputeArgs>),
    /// Evaluate a saved transfer under a medium and lights, and write the radiance with the
    /// mesh (the same mesh and --scale as the precompute).
    #[command(after_help = format!("{FORMS_HELP}

Example:
  transcut prt eval bunny.tcprt bunny.obj --scale 40 --medium skin1 --light sun:dir=0,-1,-1,irradiance=3 -o bunny.ply"))]
    Eval(Box<EvalArgs>),
}

/// Arguments of `transcut prt precompute`.
#[derive(Args)]
pub struct PrecomputeArgs {
    /// Input surface mesh (.obj or .ply).
    pub input: PathBuf,
    #[command(flatten)]
    pub object: ObjectArgs,
    #[command(flatten)]
    pub method: MethodArgs,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// The .tcprt file to write.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Print statistics as JSON on stdout (no progress bar).
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `transcut prt eval`.
#[derive(Args)]
pub struct EvalArgs {
    /// The .tcprt file of `transcut prt precompute`.
    pub precompute: PathBuf,
    /// The mesh it was precomputed for (.obj or .ply).
    pub input: PathBuf,
    #[command(flatten)]
    pub object: ObjectArgs,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Output: .ply, .npy or .raw, as `transcut bake` writes them.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Print statistics as JSON on stdout (no progress bar).
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &PrtArgs) -> anyhow::Result<()> {
    match &args.command {
        PrtCommand::Precompute(a) => precompute(a),
        PrtCommand::Eval(a) => eval(a),
    }
}

fn precompute(args: &PrecomputeArgs) -> anyhow::Result<()> {
    if args.object.print_help(&args.method) {
        return Ok(());
    }
    let defaults = MethodDefaults { method: Some(transcut::methods::prt::NAME.into()), ..MethodDefaults::default() };
    let method = args.method.method(&defaults)?;
    let Method::Prt(prt) = method else {
        bail!("transcut prt precomputes the prt method's transfer; --method {} has none", method.name());
    };
    if prt.cache.is_some() {
        bail!("--prt-cache is for bakes; `prt precompute` writes the file given by -o");
    }
    let (mut scene, _) = args.object.load_scene(&args.input)?;
    // The transfer does not depend on the lights: none are evaluated.
    scene.lights.clear();
    let options = BakeOptions { method: Method::Prt(prt), threads: args.threads, ..BakeOptions::default() };
    let bar = StageBar::new(args.json);
    let callback = |stage: &str, f: f64| bar.update(stage, f);
    let result = bake_with(&scene, &options, Progress::new(&callback));
    bar.finish();
    let baked = result?;
    let object = &baked.objects[0];
    let state = object.prt().context("the bake holds no PRT state")?;
    state.save(&args.output)?;
    let t = state.transfer_stats();
    if args.json {
        let report = serde_json::json!({
            "input": args.input.display().to_string(),
            "output": args.output.display().to_string(),
            "key": state.key.to_string(),
            "samples": state.samples.len(),
            "vertices": state.transfer.vertices(),
            "precompute_ms": object.stats.assembly_ms,
            "total_ms": baked.total_ms,
            "transfer": t,
        });
        crate::output::print_json(&report)?;
        return Ok(());
    }
    println!(
        "{}: transfer of {} vertices from {} samples, {} terms ({:.1} MB; dropped energy {:.2e} mean, {:.2e} worst) in {:.0} ms",
        args.output.display(),
        state.transfer.vertices(),
        state.samples.len(),
        t.terms,
        t.bytes as f64 / 1e6,
        t.dropped_mean,
        t.dropped_max,
        object.stats.assembly_ms
    );
    Ok(())
}

fn eval(args: &EvalArgs) -> anyhow::Result<()> {
    if args.object.medium == "help" {
        println!("presets: {}", transcut::optics::PRESET_NAMES.join(", "));
        return Ok(());
    }
    // The file says which options its transfer was made with; the bake must use the same.
    let header = io::read_header(&args.precompute)?;
    let (scene, mesh) = args.object.load_scene(&args.input)?;
    let prt = transcut::prt::PrtOptions { cache: Some(PrtCache::File(args.precompute.clone())), ..header.options };
    let options = BakeOptions { method: Method::Prt(prt), threads: args.threads, ..BakeOptions::default() };
    let bar = StageBar::new(args.json);
    let callback = |stage: &str, f: f64| bar.update(stage, f);
    let result = bake_with(&scene, &options, Progress::new(&callback));
    bar.finish();
    let baked = result?;
    let object = &baked.objects[0];
    if !object.stats.precompute_loaded {
        // Cannot happen with a file that exists (a mismatch is an error); said rather than hidden.
        bail!("{} was not used: the transfer was computed again", args.precompute.display());
    }
    if let Some(path) = &args.output {
        crate::output::write_radiance(path, &mesh, &object.radiance).with_context(|| format!("writing {}", path.display()))?;
    }
    let s = &object.stats;
    if args.json {
        let report = serde_json::json!({
            "precompute": args.precompute.display().to_string(),
            "input": args.input.display().to_string(),
            "output": args.output.as_ref().map(|p| p.display().to_string()),
            "total_ms": baked.total_ms,
            "stats": s,
        });
        crate::output::print_json(&report)?;
        return Ok(());
    }
    println!(
        "{}: {} vertices from {} in {:.0} ms (read {:.0}, light {:.0}, combine {:.0})",
        args.input.display(),
        object.radiance.len(),
        args.precompute.display(),
        baked.total_ms,
        s.assembly_ms,
        s.source_ms,
        s.solve_ms
    );
    if s.clamped_vertices > 0 {
        println!("note: {} of your vertices had a negative radiance, clamped to 0", s.clamped_vertices);
    }
    Ok(())
}
