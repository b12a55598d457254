//! `transcut acquire`: a heterogeneous material volume measured from images of a lit block
//! (inverse diffusion, J. Wang et al. 2008 §4), and `transcut acquire synth`, which writes a
//! synthetic data set (description and images) of a known volume to try it on.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context};
use clap::{Args, Subcommand, ValueEnum};
use glam::DVec3;
use transcut::inverse::description::{Face, OptimiserSettings, OutputSettings, PatternSet};
use transcut::inverse::{
    acquire, synthesize, to_voxel_grid, write_image, Acquired, Acquisition, CellMedia, Description, Pattern, StopReason,
    SynthOptions, VeinedBlock,
};
use transcut::volume::VoxelGrid;
use transcut::Progress;

use crate::progress::StageBar;

/// The largest description file read, in bytes.
const MAX_DESCRIPTION_BYTES: u64 = 1 << 20;

/// Arguments of `transcut acquire`.
#[derive(Args)]
#[command(
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true,
    after_help = "The description (TOML) names the grid, the observed face, the light patterns, one linear image \
                  per pattern (OpenEXR; pixel (x, y), rows from the top, is face node (x, y); paths relative to \
                  the description) and the optimiser:

  nodes = [40, 40, 12]     # grid nodes along x, y, z; the lit face is z = max
  spacing_mm = 0.5
  eta = 1.3
  observe = \"back\"         # \"front\" (the lit face; margin_mm = …) or \"back\"
  images = [\"m00.exr\", \"m01.exr\", …]
  [patterns]
  grid = 4                 # the paper's 4 × 4 regions, row by row; or [[patterns.rect]] rect = [x0, x1, y0, y1],
                           # q = [r, g, b]; or files = [\"p00.exr\", …] (q per lit-face node)
  [optimiser]
  method = \"lbfgs\"         # or \"paper\" (Polak–Ribière CG with golden-section search)
  lambda = 1e-4            # or discrepancy = { noise_rms = 0.01 }
  max_iterations = 40
  channels = \"rgb\"         # or \"grey\" (grey images: one channel fitted, copied to all three)
  coarse_levels = 0        # N ≥ 1: coarse to fine, blocks of 2^N, …, 2 cells first
  absorption_coarsening = 1  # F: σa on blocks F times wider than σ′s

The result is a TCVOX1 voxel grid (one voxel per cell: σa and σ′s per channel) that `bake`, `render`, the C ABI \
and the add-on load as a medium; it is written only when the fit has finished (an interrupted run leaves no file).

Examples:
  transcut acquire synth -o data/            # a veined marble block: data/acquisition.toml, 16 images
  transcut acquire data/acquisition.toml -o material.tcvox"
)]
pub struct AcquireArgs {
    #[command(subcommand)]
    pub command: Option<AcquireCommand>,
    /// The acquisition description (TOML).
    #[arg(required = true)]
    pub description: Option<PathBuf>,
    /// The voxel grid to write (TCVOX1).
    #[arg(short, long, required = true)]
    pub output: Option<PathBuf>,
    /// Print the fit as JSON on stdout (no progress bar).
    #[arg(long)]
    pub json: bool,
}

#[derive(Subcommand)]
pub enum AcquireCommand {
    /// Write a synthetic data set: the images of a known volume under the paper's 4 × 4
    /// patterns, rendered on an independent 2×-finer grid, with their description.
    #[command(after_help = "Writes DIR/acquisition.toml, DIR/mNN.exr (one per pattern) and DIR/truth.tcvox (the \
                            true volume on the fit's cells, to compare or render beside the result).

Example:
  transcut acquire synth --nodes 40,40,12 --spacing 0.5 -o data/")]
    Synth(SynthArgs),
}

/// Arguments of `transcut acquire synth`.
#[derive(Args)]
pub struct SynthArgs {
    /// The folder to write into (created if missing).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Grid nodes along x, y, z (the lit face is z = max).
    #[arg(long, value_delimiter = ',', default_values_t = [40usize, 40, 12])]
    pub nodes: Vec<usize>,
    /// Node spacing, mm.
    #[arg(long, default_value_t = 0.5)]
    pub spacing: f64,
    /// The sample's refractive index.
    #[arg(long, default_value_t = 1.3)]
    pub eta: f64,
    /// The observed face.
    #[arg(long, value_enum, default_value = "back")]
    pub observe: FaceArg,
    /// Front-lit only: the margin around lit pixels, mm.
    #[arg(long, default_value_t = 1.0)]
    pub margin: f64,
    /// n: the patterns are the n × n regions of the lit face (the paper's 4).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=32))]
    pub grid: u32,
    /// The true volume: `veined` (marble with a diagonal vein of 5× σa and a 1 mm skin of
    /// 1.5× σ′s) or a TCVOX1 file, sampled in mm with the block's corner at its origin.
    #[arg(long, default_value = "veined")]
    pub truth: String,
    /// Fine cells per fit cell edge of the synthetic grid (2: the independent 2× finer grid).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=4))]
    pub refine: u32,
    /// The optimiser's iteration cap per channel, written into the description.
    #[arg(long, default_value_t = 40)]
    pub max_iterations: usize,
    /// λ, written into the description.
    #[arg(long, default_value_t = 1e-4)]
    pub lambda: f64,
    /// Print what was written as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

/// The observed face on the command line.
#[derive(Clone, Copy, ValueEnum)]
pub enum FaceArg {
    /// The lit face.
    Front,
    /// The face opposite the light.
    Back,
}

pub fn run(args: &AcquireArgs) -> anyhow::Result<()> {
    if let Some(AcquireCommand::Synth(s)) = &args.command {
        return synth(s);
    }
    let (Some(description), Some(output)) = (&args.description, &args.output) else {
        bail!("transcut acquire needs a DESCRIPTION and -o OUTPUT (see --help)");
    };
    run_acquire(description, output, args.json)
}

/// Reads a description file (TOML).
fn read_description(path: &Path) -> anyhow::Result<Description> {
    let meta = std::fs::metadata(path).with_context(|| format!("{}", path.display()))?;
    if !meta.is_file() || meta.len() > MAX_DESCRIPTION_BYTES {
        bail!("{}: not a regular file of at most {MAX_DESCRIPTION_BYTES} bytes", path.display());
    }
    let text = std::fs::read_to_string(path).with_context(|| format!("{}", path.display()))?;
    toml::from_str(&text).with_context(|| format!("{}", path.display()))
}

fn run_acquire(description: &Path, output: &Path, json: bool) -> anyhow::Result<()> {
    let start = Instant::now();
    let d = read_description(description)?;
    // Refuse an output that cannot be written before minutes of fitting.
    let folder = output.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    if !folder.is_dir() {
        bail!("{}: the output's folder {} does not exist", output.display(), folder.display());
    }
    if output.is_dir() {
        bail!("{}: the output is a folder", output.display());
    }
    let base = description.parent().unwrap_or(Path::new("."));
    let loaded = d.load(base).with_context(|| format!("{}", description.display()))?;
    let images = loaded.images.len();
    let mut model = Acquisition::new(loaded.setup.clone(), &loaded.patterns, loaded.images, loaded.masks)?;
    let bar = StageBar::new(json);
    let callback = |stage: &str, f: f64| bar.update(stage, f);
    let fit = acquire(&mut model, &loaded.options, &Progress::new(&callback));
    bar.finish();
    let fit = fit?;
    let OutputSettings { origin, units_per_mm } = d.output;
    let grid = to_voxel_grid(model.grid(), &fit.media, DVec3::from_array(origin), units_per_mm)?;
    grid.write(output)?;
    let seconds = start.elapsed().as_secs_f64();
    if json {
        println!("{}", serde_json::to_string_pretty(&report(&fit, &model, output, images, seconds))?);
    } else {
        let m = fit.evaluation.misfit_rms();
        println!(
            "wrote {} ({} × {} × {} voxels): misfit {:.3}/{:.3}/{:.3}% RMS (R/G/B), {} iterations, {} forward + {} adjoint solves, {seconds:.1} s",
            output.display(),
            grid.dims()[0],
            grid.dims()[1],
            grid.dims()[2],
            100.0 * m[0],
            100.0 * m[1],
            100.0 * m[2],
            iterations(&fit),
            fit.counts.forward_solves,
            fit.counts.adjoint_solves,
        );
    }
    Ok(())
}

/// Iterations taken (every fit's, start rows excluded).
fn iterations(fit: &Acquired) -> usize {
    fit.history.iter().filter(|r| r.iteration > 0).count()
}

fn stop_name(s: StopReason) -> &'static str {
    match s {
        StopReason::Misfit => "misfit",
        StopReason::RelativeDecrease => "relative-decrease",
        StopReason::Gradient => "gradient",
        StopReason::IterationCap => "iteration-cap",
        StopReason::LineSearch => "line-search",
    }
}

fn report(fit: &Acquired, model: &Acquisition, output: &Path, images: usize, seconds: f64) -> serde_json::Value {
    let history: Vec<serde_json::Value> = fit
        .history
        .iter()
        .map(|r| {
            serde_json::json!({
                "stage": r.stage,
                "block_cells": r.block_cells,
                "channel": r.channel,
                "lambda": r.lambda,
                "iteration": r.iteration,
                "objective": r.sample.value,
                "misfit_rms": r.sample.misfit_rms,
                "forward_solves": r.forward_solves,
            })
        })
        .collect();
    serde_json::json!({
        "output": output.display().to_string(),
        "nodes": model.grid().dims(),
        "cells": model.grid().cell_count(),
        "images": images,
        "homogeneous": { "sigma_a": fit.homogeneous.0, "sigma_s_prime": fit.homogeneous.1 },
        "lambda": fit.lambda,
        "misfit_rms": fit.evaluation.misfit_rms(),
        "regulariser": fit.evaluation.regulariser,
        "stop": fit.stop.map(stop_name),
        "iterations": iterations(fit),
        "forward_solves": fit.counts.forward_solves,
        "adjoint_solves": fit.counts.adjoint_solves,
        "pcg_iterations": fit.counts.pcg_iterations,
        "seconds": seconds,
        "history": history,
    })
}

/// A medium as a function of the point (mm from the block's corner): (σa, σ′s).
type MediumFn = dyn Fn(DVec3) -> ([f64; 3], [f64; 3]) + Sync;

fn synth(args: &SynthArgs) -> anyhow::Result<()> {
    let nodes: [usize; 3] = args.nodes.as_slice().try_into().context("--nodes takes three counts")?;
    let description = Description {
        nodes,
        spacing_mm: args.spacing,
        eta: args.eta,
        observe: match args.observe {
            FaceArg::Front => Face::Front,
            FaceArg::Back => Face::Back,
        },
        margin_mm: if matches!(args.observe, FaceArg::Front) { args.margin } else { 0.0 },
        images: (0..args.grid * args.grid).map(|m| PathBuf::from(format!("m{m:02}.exr"))).collect(),
        masks: Vec::new(),
        patterns: PatternSet { grid: Some(args.grid as usize), q: [1.0; 3], rect: Vec::new(), files: Vec::new() },
        optimiser: OptimiserSettings {
            lambda: Some(args.lambda),
            max_iterations: args.max_iterations,
            ..OptimiserSettings::default()
        },
        output: OutputSettings::default(),
    };
    // The same checks an acquisition makes, before the synthesis.
    let setup = description.setup()?;
    description.options()?;
    let block = transcut::inverse::BlockGrid::new(setup.dims, setup.spacing_mm)?;
    let patterns = Pattern::grid_all(args.grid as usize, setup.face_size_mm(), [1.0; 3]);
    let medium: Box<MediumFn> = if args.truth == "veined" {
        let v = VeinedBlock::marble(&setup);
        Box::new(move |p| v.medium(p))
    } else {
        let grid = VoxelGrid::read(&args.truth)?;
        Box::new(move |p| {
            let c = grid.sample(grid.origin() + p);
            (c.sigma_a, c.sigma_s_prime)
        })
    };
    let start = Instant::now();
    let images = synthesize(&setup, &patterns, &*medium, SynthOptions { refine: args.refine, ..SynthOptions::default() })?;
    std::fs::create_dir_all(&args.output).with_context(|| format!("{}", args.output.display()))?;
    let [nx, ny, _] = setup.dims;
    for (path, img) in description.images.iter().zip(&images) {
        write_image(&args.output.join(path), nx, ny, img)?;
    }
    // The truth on the fit's cells (each cell's centre), for comparing and rendering.
    let (sigma_a, sigma_s_prime) = (0..block.cell_count()).map(|c| medium(DVec3::from_array(block.cell_centre(c)))).unzip();
    let truth = to_voxel_grid(&block, &CellMedia { sigma_a, sigma_s_prime }, DVec3::ZERO, 1.0)?;
    truth.write(args.output.join("truth.tcvox"))?;
    let toml_path = args.output.join("acquisition.toml");
    let text = toml::to_string(&description).context("encoding the description")?;
    transcut::output::write_atomically(&toml_path, |out| std::io::Write::write_all(out, text.as_bytes()))
        .with_context(|| format!("{}", toml_path.display()))?;
    let seconds = start.elapsed().as_secs_f64();
    if args.json {
        let report = serde_json::json!({
            "description": toml_path.display().to_string(),
            "images": description.images.len(),
            "nodes": nodes,
            "truth": args.truth,
            "seconds": seconds,
        });
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!(
            "wrote {} with {} images of {} × {} pixels and truth.tcvox ({seconds:.1} s)",
            toml_path.display(),
            description.images.len(),
            nx,
            ny
        );
    }
    Ok(())
}
