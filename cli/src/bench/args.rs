//! The arguments of `transcut bench`.

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use transcut::diffusion::{Discretization, SolverKind};

use crate::method_args::solver_kind;

/// Which benchmark to run.
#[derive(Clone, Copy, ValueEnum)]
pub enum Suite {
    /// Tetrahedralise a mesh at several sizes: time and quality.
    Mesh,
    /// Bake a mesh (60 mm across, marble, one sun) at several sizes: meshing, assembly, light,
    /// solve (iterations), total and peak memory.
    Bake,
    /// The diffusion solve alone (60 mm, marble, one sun) on the CPU and on the `--backend`
    /// (GPU: upload, assembly, solve with read-back), their agreement and the device name.
    Solve,
    /// TransCut Fig. 7: relative error against time for the single-level solvers (Jacobi PCG,
    /// SSOR-PCG), the multiresolution cascade and multigrid-preconditioned CG (on the paper's
    /// hierarchy and on a smoothed aggregation), and the warm start after moving the sun 5°.
    Multires,
    /// Interactive edits (TransCut §5) on the bunny: the cold bake, a relight after moving the
    /// sun 5° (warm start against a cold solve of the same system), a paint stroke, and the
    /// Fig. 7 curve with its time-to-1% ratio.
    Edit,
    /// The hierarchical dipole on geodesic spheres (R = 25 mm, marble at η 1.3, one sun):
    /// on-the-fly, render and incremental (after a Perlin deformation) at --subdivisions, the
    /// error against the O(n²) sum for several oracles, and the paper's 98k-leaf case.
    Dipole,
    /// PRT (R. Wang et al. 2008) on --input (60 mm, marble, a shadowed sun) at --prt-samples:
    /// the precompute (time, transfer bytes, dropped energy, peak memory), a relight after
    /// turning the sun 5°, a whole-object material edit and a scale change, and the TransCut
    /// editor's same edit at the first --tets for the ratio.
    Prt,
    /// Translucent radiosity at --patch-sizes: the radiosity stage on an opaque Cornell box
    /// (200 mm, a diffuse 60 × 60 × 120 mm block, a point light: patches, nonzeros and memory of
    /// the form factors, their time, Jacobi against Gauss–Seidel to 1e-3), then the --scene
    /// (a marble block in the box) through the bake and its session: each stage's time,
    /// memory, Jacobi against Gauss–Seidel, a relight after turning the light 5°, a change of
    /// its colour, of the translucency and of an albedo.
    Radiosity,
    /// The polygrid's relaxation (J. Wang et al. 2008 §5.2–5.3): Fig. 15 (error against node
    /// updates and time for single-level Gauss–Seidel, the hierarchical cascade and the adaptive
    /// scheme, with each stencil, the paper's own included) on a marble ball at
    /// --polygrid-resolution and on a block, then the diffusion pass
    /// (cold and warm) of PCG and the relaxation at --polygrid-nodes, each to 1% RMS, on the
    /// ball and with --polygrid-object on that surface's polygrid.
    Polygrid,
    /// Inverse diffusion (J. Wang et al. 2008 §4): the synthetic acquisition of a veined marble
    /// block (--inverse-nodes at 0.5 mm, 16 images, back-lit unless --inverse-front-lit, three
    /// channels) by the default optimiser and by paper mode, each to the paper's 1% RMS misfit:
    /// time, iterations, forward and adjoint solves and their ratio, the cost per iteration and
    /// the marble-scale (256 × 256 × 20 nodes) time it implies against the paper's 11 hours;
    /// each fit's κ and μ errors by depth and its held-out appearance error. One run each;
    /// --inverse-sweep adds the pattern-count sweep and the 1%-noise repeat.
    Inverse,
    /// The uniformly lit sphere (R = 10 mm) against its closed form: Lo's RMS and mean error
    /// per channel for every --presets medium, --discretizations assembly and --grading at
    /// each --tets, with σtr·h and the times.
    Sphere,
}

/// Arguments of `transcut bench`.
#[derive(Args)]
pub struct BenchArgs {
    /// The benchmark suite.
    #[arg(value_enum, default_value = "mesh")]
    pub suite: Suite,
    /// Input surface mesh (default: the shared Stanford bunny).
    #[arg(long, default_value = "assets/meshes/stanford-bunny.obj")]
    pub input: PathBuf,
    /// Target tet counts, comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [100_000usize, 500_000, 1_000_000])]
    pub tets: Vec<usize>,
    /// Gradings of the `mesh`, `edit` and `sphere` suites, comma-separated: 0 one spacing
    /// everywhere, N ≥ 1 graded with N cubes of each size (as `transcut mesh --grading`).
    /// Default: 0 for `mesh` and `edit`; 0, 1, 2 and 4 for `sphere`.
    #[arg(long, value_delimiter = ',', value_parser = clap::value_parser!(u32).range(0..=64))]
    pub grading: Vec<u32>,
    /// Media of the `sphere` suite (preset names), comma-separated.
    #[arg(long, value_delimiter = ',', default_values = transcut::optics::PRESET_NAMES)]
    pub presets: Vec<String>,
    /// The `sphere` suite's radius, mm.
    #[arg(long, default_value_t = 10.0)]
    pub radius_mm: f64,
    /// Assemblies of the `sphere` suite, comma-separated: transcut, fitted, fitted-layer,
    /// consistent-fem.
    #[arg(long, value_delimiter = ',', value_parser = crate::method_args::discretization, default_values = ["transcut", "fitted", "fitted-layer"])]
    pub discretizations: Vec<Discretization>,
    /// Runs per size; the median is reported.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
    pub runs: u32,
    /// Backend of the `solve`, `dipole` and `prt` suites (prt: its relight product): cpu, gpu
    /// (fails without an adapter) or auto.
    #[arg(long, default_value = "auto")]
    pub backend: transcut::gpu::Backend,
    /// Solver of the `edit` suite's updates: pcg, ssor-pcg, cascade, mg-pcg or sa-pcg
    /// (default: the editor's own, sa-pcg).
    #[arg(long, value_parser = solver_kind)]
    pub solver: Option<SolverKind>,
    /// Icosphere subdivisions of the `dipole` suite's scaling table, comma-separated (20·4ⁿ
    /// triangles: 4 is 5,120, 7 is 327,680).
    #[arg(long, value_delimiter = ',', default_values_t = [4u32, 5, 6, 7], value_parser = clap::value_parser!(u32).range(0..=8))]
    pub subdivisions: Vec<u32>,
    /// The `dipole` suite's accuracy table: the largest of the --subdivisions spheres (in
    /// triangles) the O(n²) reference is summed on.
    #[arg(long, default_value_t = 20_480)]
    pub reference_triangles: usize,
    /// The `dipole` suite without the paper's 98k-leaf case (81,920 triangles).
    #[arg(long)]
    pub no_paper_case: bool,
    /// The `radiosity` suite's patch sizes (the longest edge the surfaces are refined to, mm),
    /// comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [6.0f64, 3.0])]
    pub patch_sizes: Vec<f64>,
    /// The `radiosity` suite's coupled scene: a scene file whose `[bake] method` is radiosity.
    #[arg(long, default_value = "examples/cornell_marble.toml")]
    pub scene: PathBuf,
    /// The `radiosity` suite's tets per translucent object (default: the scene file's).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=20_000_000))]
    pub radiosity_tets: Option<u64>,
    /// The `prt` suite's irradiance samples, log₂.
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(4..=18))]
    pub prt_samples: u32,
    /// The `prt` suite's Haar coefficients kept per vertex (default: the library's).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=1_048_576))]
    pub prt_terms: Option<u64>,
    /// The `prt` suite's precompute cache folder: a transfer found there is read instead of
    /// computed (`precompute_loaded` in the report), one computed is written there, so that
    /// repeated runs measure the relight and the edits without the minutes of precompute.
    #[arg(long, value_name = "DIR")]
    pub prt_cache: Option<PathBuf>,
    /// The `polygrid` suite's Fig. 15: cells per edge of the cubed-sphere ball (a multiple of
    /// 16; the block gets a quarter of it per 40 mm cube, the same spacing).
    #[arg(long, default_value_t = 48, value_parser = clap::value_parser!(u32).range(16..=256))]
    pub polygrid_resolution: u32,
    /// The `polygrid` suite's diffusion pass also on this surface (OBJ, PLY, …), scaled to the
    /// ball's 160 mm and mapped at 4 cells per cube with about --polygrid-nodes nodes (Table
    /// III on an object); a map or coarse level that folds is reported as skipped.
    #[arg(long, value_name = "MESH")]
    pub polygrid_object: Option<PathBuf>,
    /// The `polygrid` suite's diffusion pass: about this many nodes on the ball (and on
    /// --polygrid-object).
    #[arg(long, default_value_t = 250_000, value_parser = clap::value_parser!(u64).range(125..=20_000_000))]
    pub polygrid_nodes: u64,
    /// The `inverse` suite's grid nodes along x, y, z (8,8,4 is a seconds-long smoke run).
    #[arg(long, value_delimiter = ',', default_values_t = [40usize, 40, 12])]
    pub inverse_nodes: Vec<usize>,
    /// The `inverse` suite's iteration cap per channel of the per-cell fit.
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u64).range(1..=10_000))]
    pub inverse_iterations: u64,
    /// The `inverse` suite also fits M = 1, 4, 9, 16, 25 and 64 patterns (n × n regions) and
    /// the 16 images with 1% noise (λ by the discrepancy principle), each judged as the main
    /// runs are: seven fits more (the 16-pattern one is the default run's).
    #[arg(long)]
    pub inverse_sweep: bool,
    /// The `inverse` suite observes the lit face (front-lit), masking the pixels within this
    /// many millimetres of a pattern's lit region, instead of the opposite face (back-lit, the
    /// default).
    #[arg(long, value_name = "MARGIN_MM", value_parser = front_lit_margin)]
    pub inverse_front_lit: Option<f64>,
    /// The `inverse` suite's fits go coarse to fine: per-cell media are first fitted on blocks
    /// of 2^N cells a side, then 2^(N−1), …, 2, then per cell.
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=8))]
    pub inverse_coarse_levels: u32,
    /// The `inverse` suite fits σa on blocks this many times wider than σ′s (1: per cell).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub inverse_absorption_coarsening: u32,
    /// The `inverse` suite's tets for TransCut's rendering of the recovered and true blocks.
    #[arg(long, default_value_t = 60_000, value_parser = clap::value_parser!(u64).range(1_000..=2_000_000))]
    pub inverse_render_tets: u64,
}

impl BenchArgs {
    /// The suite's gradings: `--grading` as given, or `default` when it was not.
    pub fn gradings_or(&self, default: &[u32]) -> Vec<u32> {
        if self.grading.is_empty() {
            default.to_vec()
        } else {
            self.grading.clone()
        }
    }
}

/// `--inverse-front-lit`: a finite margin of at least 0 mm.
fn front_lit_margin(text: &str) -> Result<f64, String> {
    let margin: f64 = text.parse().map_err(|e| format!("{text:?} is not a number: {e}"))?;
    if margin.is_finite() && margin >= 0.0 {
        Ok(margin)
    } else {
        Err(format!("the margin {margin} mm is not a finite number ≥ 0"))
    }
}
