//! `--method` and the method options that `bake`, `render` and `animate` share.
//!
//! Every option belongs to one method (its help says which); an option of one method given
//! with another is refused, naming both, rather than silently ignored.

use anyhow::{anyhow, bail};
use clap::{Args, ValueEnum};
use transcut::diffusion::{Discretization, SolverKind};
use transcut::gpu::Backend;
use transcut::hierarchy::{DipoleOptions, EvalMode, Oracle, Receivers};
use transcut::input::quote;
use transcut::mesher::Grading;
use transcut::optics::EdgeRule;
use transcut::prt::{BasisSize, PrtCache, PrtOptions};
use transcut::radiosity::{FormFactorOptions, HetRule, Iteration, SolveOptions};
use transcut::{
    GradingChoice, Method, OpticalDistance, PolygridOptions, ProfileKind, ProfileScatteringOptions, RadiosityOptions, Stencil,
    TransCutOptions, TranslucentScattering,
};

/// The names of the methods whose options are here ([`Method::NAMES`]).
const TRANSCUT: &str = "transcut";
const DIPOLE: &str = transcut::methods::hierarchical_dipole::NAME;
const RADIOSITY: &str = "radiosity";
const PRT: &str = transcut::methods::prt::NAME;
const POLYGRID: &str = "polygrid";

/// The methods that solve TransCut's diffusion on tets they mesh (radiosity through its
/// translucent objects): those that take `--tets`.
const DIFFUSION: &[&str] = &[TRANSCUT, RADIOSITY];

/// The methods whose diffusion solves take `--tolerance`, `--solver` and `--backend` (the
/// polygrid's on its grid, [`PolygridOptions::solve`]).
const SOLVES: &[&str] = &[TRANSCUT, RADIOSITY, POLYGRID];

/// θ of `--oracle opening-angle` without `--theta`: the core's default ([`Oracle::default`]).
const DEFAULT_THETA: f64 = 0.4;

/// The mode without `--mode` (nor a command's default): the core's ([`EvalMode::default`]).
const DEFAULT_MODE: ModeName = ModeName::OnTheFly;

/// The paper oracle's ε₁ and ε₂ when not given: the paper publishes none; pbrt-v2 and Blender
/// 2.4x default to 0.05 (design/hierarchical-dipole.md §1.6).
const PAPER_EPS: f64 = 0.05;

/// The hierarchical dipole's refinement oracle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum OracleName {
    /// Link two clusters when their radii sum below θ × their distance (--theta).
    OpeningAngle,
    /// Mertens et al. 2003's solid-angle test (--eps1, --eps2), for reproduction: on sun-lit
    /// spheres of 5k-20k triangles 0.5-5.5% RMS against the O(n²) sum, opening-angle θ 0.4's
    /// 0.04% (`transcut bench dipole`).
    Paper,
}

/// The edge rule of the near field's analytic triangle form factor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RuleName {
    /// 3-point Gauss–Legendre per edge segment: within 1.2e-4 of brute-force cubature.
    Gl3,
    /// The paper's midpoint rule (eq. 17, L/r₀ < 2/5): 3–17% off away from the receiver.
    Paper,
}

/// Where the hierarchical dipole evaluates the radiance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ReceiverName {
    /// At every vertex, along its area-weighted normal.
    Vertices,
    /// At every triangle's centroid (the paper's), averaged onto the vertices by area.
    Faces,
}

/// When the hierarchical dipole makes its links.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ModeName {
    /// Traverse the cluster trees afresh at every update, storing no links (least memory).
    OnTheFly,
    /// Keep the links and their form factors: a relight only gathers; a deformation relinks
    /// everything.
    Render,
    /// Keep the links; after a deformation relink only what moved (--budget caps the form
    /// factors per update).
    Incremental,
}

/// Translucent radiosity's iteration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum IterationName {
    /// Every patch from the last sweep (Sheng et al.'s; parallel): sweep k adds bounce k + 1.
    Jacobi,
    /// Opaque patches in place, then each translucent object (about half the sweeps).
    GaussSeidel,
    /// BiCGSTAB on the coupled system, stopped by a bound on the error (two scatterings an
    /// iteration, few iterations).
    Bicgstab,
}

impl IterationName {
    fn iteration(self) -> Iteration {
        match self {
            Self::Jacobi => Iteration::Jacobi,
            Self::GaussSeidel => Iteration::GaussSeidel,
            Self::Bicgstab => Iteration::BiCgStab,
        }
    }
}

/// The scattering operator S of radiosity's translucent objects.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ScatteringName {
    /// Each object's TransCut diffusion solve on its tets: exact with respect to TransCut,
    /// heterogeneous media and concavities included (the accuracy default).
    Diffusion,
    /// A profile matrix of TransCut's half-space Green's function on the object's surface: no
    /// tets; homogeneous media, layers, voxels or veins; 8% under the diffusion S on a 10 mm marble
    /// sphere, 1% at 100 mm.
    HalfSpace,
    /// A profile matrix of the classical dipole (Sheng et al.'s): no tets; homogeneous media,
    /// layers, voxels or veins.
    Dipole,
}

/// How the profile S measures the distance between two patches of an object.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DistanceName {
    /// The straight chord (exact on convex objects).
    Chord,
    /// The shortest path inside the object (the chord where it stays inside, else a voxel graph
    /// of a quarter of the smallest diffusion length).
    Interior,
}

impl ScatteringName {
    /// The core's choice, with `distance` and `het` for a profile.
    fn scattering(self, distance: Option<DistanceName>, het: Option<HetName>) -> anyhow::Result<TranslucentScattering> {
        let profile = match self {
            Self::Diffusion if distance.is_some() => {
                bail!("the profile distance is an option of --scattering half-space or dipole, not of diffusion")
            }
            Self::Diffusion if het.is_some() => {
                bail!("the profile's heterogeneous rule is an option of --scattering half-space or dipole, not of diffusion")
            }
            Self::Diffusion => return Ok(TranslucentScattering::Diffusion),
            Self::HalfSpace => ProfileKind::HalfSpace,
            Self::Dipole => ProfileKind::Dipole,
        };
        let distance = match distance.unwrap_or(DistanceName::Chord) {
            DistanceName::Chord => OpticalDistance::Chord,
            DistanceName::Interior => OpticalDistance::INTERIOR,
        };
        let het = het.map_or(HetRule::Consistent, HetName::rule);
        Ok(TranslucentScattering::Profile(ProfileScatteringOptions {
            profile,
            distance,
            het,
            ..ProfileScatteringOptions::default()
        }))
    }
}

/// How the profile S values a path through several media of a heterogeneous object.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum HetName {
    /// The length-weighted geometric mean of the media's profiles, Π R_m(r)^{r_m/r}: exact for
    /// identical media, any profile (the default).
    Consistent,
    /// Sheng et al. 2014 eq. 16 (the paper's heuristic; needs the dipole profile).
    Sheng2014,
}

impl HetName {
    fn rule(self) -> HetRule {
        match self {
            Self::Consistent => HetRule::Consistent,
            Self::Sheng2014 => HetRule::Sheng2014,
        }
    }
}

/// The subsurface method and its options.
#[derive(Args, Debug, Clone, Default)]
pub struct MethodArgs {
    /// The subsurface method: transcut, hierarchical-dipole, radiosity, prt or polygrid (the default is the
    /// command's: transcut for bake and render, hierarchical-dipole for animate). `--method
    /// help` lists every method with one line each.
    #[arg(long, value_name = "NAME")]
    pub method: Option<String>,
    /// transcut, radiosity: target number of tetrahedra per (translucent) object
    /// [default: 200000; a scene file's [bake] tets]
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=50_000_000), help_heading = "TransCut options")]
    pub tets: Option<u64>,
    /// transcut, radiosity: how the tet sizes vary: auto grades (1) an object whose medium has
    /// a boundary layer thinner than two uniform spacings at --tets (skin's blue, ketchup) and
    /// keeps the others uniform; 0 keeps one spacing everywhere; N ≥ 1 grades every object, the
    /// finest spacing near the surface, cube sizes doubling inwards after N cubes of each size
    /// (1 is the most accurate for every preset medium at a given count, but a cut exposes the
    /// coarser interior) [default: auto; a scene file's [bake] grading]
    #[arg(long, value_parser = grading_choice, help_heading = "TransCut options")]
    pub grading: Option<GradingChoice>,
    /// transcut, radiosity: the assembly of the diffusion system: fitted-layer (each edge's
    /// stiffness exponentially fitted to the boundary layer, and each surface vertex's absorption
    /// taken from the layer under it: the most accurate at usual tet counts, e.g. skin's blue
    /// within 1% on a 10 mm sphere at 300k graded tets), fitted (the stiffness fitting alone:
    /// less accurate up to a few million tets, but second order in the spacing), transcut (the
    /// paper's) or consistent-fem (the P1 reference) [default: fitted-layer; a scene file's
    /// [bake] discretization]
    #[arg(long, value_parser = discretization, help_heading = "TransCut options")]
    pub discretization: Option<Discretization>,
    /// transcut, radiosity, polygrid: relative residual ‖b − Mφ‖/‖b‖ at which the diffusion
    /// solver stops, in (0, 1) [default: 1e-6]
    #[arg(long, help_heading = "TransCut options")]
    pub tolerance: Option<f64>,
    /// transcut, radiosity, polygrid: the bake's diffusion solver on the CPU: pcg, ssor-pcg (default), cascade,
    /// mg-pcg or sa-pcg (on the GPU the single-level solvers run Jacobi PCG; the polygrid's
    /// finite-volume stencil runs SSOR-PCG on the CPU or Jacobi PCG on the GPU, the paper's
    /// Jacobi-BiCGSTAB on the CPU)
    #[arg(long, value_parser = solver_kind, help_heading = "TransCut options")]
    pub solver: Option<SolverKind>,
    /// transcut, radiosity, polygrid: where the diffusion solve runs: cpu, gpu (an error without a GPU) or auto (a hardware
    /// GPU when there is one, else the CPU); for radiosity also its iteration's gathers F·B
    /// (Jacobi, BiCGSTAB; Gauss–Seidel stays on the CPU). Default: the TRANSCUT_BACKEND
    /// environment variable, else auto.
    #[arg(long, help_heading = "TransCut options")]
    pub backend: Option<Backend>,
    /// hierarchical-dipole: the opening-angle oracle's θ in (0, 1]: a far link joins two
    /// clusters whose bounding radii sum below θ × their distance. Smaller is more accurate and
    /// slower: 0.6 fast (0.09% RMS against the O(n²) sum on a sun-lit sphere), 0.4 the default
    /// (0.04%), 0.3 accurate (0.01%).
    #[arg(long, value_name = "F", help_heading = "Hierarchical-dipole options")]
    pub theta: Option<f64>,
    /// hierarchical-dipole: the refinement oracle that decides where links are made
    /// [default: opening-angle]
    #[arg(long, value_enum, value_name = "ORACLE", help_heading = "Hierarchical-dipole options")]
    pub oracle: Option<OracleName>,
    /// hierarchical-dipole, --oracle paper: ε₁, how far (in solid angle) a receiver cluster's
    /// children may see an emitter differently from the cluster before it is opened
    /// [default: 0.05]
    #[arg(long, value_name = "F", help_heading = "Hierarchical-dipole options")]
    pub eps1: Option<f64>,
    /// hierarchical-dipole, --oracle paper: ε₂, the largest solid angle A/d² under which an
    /// emitter cluster is linked whole [default: 0.05]
    #[arg(long, value_name = "F", help_heading = "Hierarchical-dipole options")]
    pub eps2: Option<f64>,
    /// hierarchical-dipole: the edge rule of the near field's analytic triangle form factor
    /// [default: gl3]
    #[arg(long, value_enum, value_name = "RULE", help_heading = "Hierarchical-dipole options")]
    pub rule: Option<RuleName>,
    /// hierarchical-dipole: where the radiance is evaluated [default: vertices]
    #[arg(long, value_enum, value_name = "AT", help_heading = "Hierarchical-dipole options")]
    pub receivers: Option<ReceiverName>,
    /// hierarchical-dipole: when links are made [default: on-the-fly; incremental for animate]
    #[arg(long, value_enum, value_name = "MODE", help_heading = "Hierarchical-dipole options")]
    pub mode: Option<ModeName>,
    /// hierarchical-dipole, --mode incremental: relink at most about N links per update,
    /// oldest first, keeping the others as they were (the error decays once motion stops)
    /// [default: no cap]
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..), help_heading = "Hierarchical-dipole options")]
    pub budget: Option<u64>,
    /// radiosity: the longest patch edge on diffuse objects in mm; their meshes are refined to
    /// it so that a two-triangle wall can carry colour bleeding (translucent objects' patches
    /// are their tets' boundary vertices) [default: the scene's diagonal / 80]
    #[arg(long, value_name = "MM", help_heading = "Radiosity options")]
    pub patch_size: Option<f64>,
    /// radiosity: form-factor rays per patch; the noise of a factor F is about √(F(1 − F)/N)
    /// [default: 512]
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=16_777_216), help_heading = "Radiosity options")]
    pub rays: Option<u64>,
    /// radiosity: the iteration [default: jacobi]
    #[arg(long, value_enum, value_name = "NAME", help_heading = "Radiosity options")]
    pub iteration: Option<IterationName>,
    /// radiosity: the estimated relative error in power at which the iteration stops, in (0, 1)
    /// [default: 1e-3]
    #[arg(long, value_name = "F", help_heading = "Radiosity options")]
    pub radiosity_tolerance: Option<f64>,
    /// radiosity: exactly N bounces of light (1: the direct light only), whatever the
    /// tolerance; needs the Jacobi iteration [default: until the tolerance]
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=10_000), help_heading = "Radiosity options")]
    pub bounces: Option<u64>,
    /// radiosity: the translucent objects' scattering: their diffusion solve on tets, or a
    /// half-space or dipole profile matrix on their surface refined to --patch-size (no tets;
    /// no material tables or per-tet media) [default: diffusion]
    #[arg(long, value_enum, value_name = "S", help_heading = "Radiosity options")]
    pub scattering: Option<ScatteringName>,
    /// radiosity, --scattering half-space or dipole: the distance between two patches of an
    /// object [default: chord]
    #[arg(long, value_enum, value_name = "D", help_heading = "Radiosity options")]
    pub profile_distance: Option<DistanceName>,
    /// radiosity, --scattering half-space or dipole: how a path through several media of a
    /// heterogeneous object (layers, voxels, veins) is valued: the consistent rule, or Sheng et
    /// al. 2014 eq. 16 (dipole only) [default: consistent]
    #[arg(long, value_enum, value_name = "RULE", help_heading = "Radiosity options")]
    pub profile_het: Option<HetName>,
    /// prt: log₂ of the irradiance samples, 4 to 18; more resolve denser media (σ′t up to 3
    /// over the spacing √(area/N)) and shadows better, the precompute and the transfer grow
    /// with them [default: 16]
    #[arg(long, value_name = "LOG2", value_parser = clap::value_parser!(u32).range(4..=18), help_heading = "PRT options")]
    pub prt_samples: Option<u32>,
    /// prt: Haar coefficients kept per vertex over all its basis rows (about 3 bytes each);
    /// fewer are faster to relight and less accurate under sharp light [default: 1024]
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(12..=1_048_576), help_heading = "PRT options")]
    pub prt_terms: Option<u64>,
    /// prt: the PCA basis of the dipole profile: 16 functions, or the paper's 12 [default: 16]
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u32).range(12..=16), help_heading = "PRT options")]
    pub prt_basis: Option<u32>,
    /// prt: a folder of saved precomputes: a bake reads the transfer of this surface, scale and
    /// these options from it when there (named by its key), and otherwise precomputes and
    /// writes it there, so the next bake of the same object is fast [default: none]
    #[arg(long, value_name = "DIR", help_heading = "PRT options")]
    pub prt_cache: Option<std::path::PathBuf>,
    /// polygrid: target grid nodes per object, 8 to 4000000; with --polygrid-resolution it sets
    /// the polycube's cube size (unless --polygrid-cube) [default: 200000]
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(8..=4_000_000), help_heading = "Polygrid options")]
    pub polygrid_nodes: Option<u64>,
    /// polygrid: the polycube's cube edge in mm, finite and > 0; a cube at which the polycube
    /// changes the surface's topology or the grid folds is made smaller at the same node
    /// spacing [default: from --polygrid-nodes]
    #[arg(long, value_name = "MM", help_heading = "Polygrid options")]
    pub polygrid_cube: Option<f64>,
    /// polygrid: grid cells per cube edge, 1 to 256 [default: 8]
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=256), help_heading = "Polygrid options")]
    pub polygrid_resolution: Option<u32>,
    /// polygrid: the discretisation on the grid: fem (P1 on the cells' tets, TransCut's
    /// assembly; second order on skewed cells, relight and edits) or finite-volume (two-point
    /// fluxes, exactly conservative; no edits after the bake) or paper-lsq (the paper's App. B
    /// least-squares weights and ψ = κφ form, for comparison: biased at κ interfaces, not
    /// consistent on skewed cells; no edits after the bake) [default: fem]
    #[arg(long, value_name = "STENCIL", value_parser = stencil, help_heading = "Polygrid options")]
    pub polygrid_stencil: Option<Stencil>,
}

/// The defaults under the command line: what a scene file's `[bake]` table says, or a
/// command's own (animate's method and mode).
#[derive(Debug, Clone, Default)]
pub struct MethodDefaults {
    /// Whether these are a scene file's (whose options are checked against its method).
    pub from_file: bool,
    pub method: Option<String>,
    pub tets: Option<u64>,
    pub grading: Option<GradingChoice>,
    pub discretization: Option<String>,
    pub tolerance: Option<f64>,
    pub solver: Option<String>,
    /// The hierarchical dipole's mode when `--mode` is not given.
    pub mode: Option<ModeName>,
    /// The hierarchical dipole's opening angle when `--theta` is not given (a scene file's).
    pub theta: Option<f64>,
    /// The dipole's oracle when neither `--oracle` nor `--theta` is given (a scene file's).
    pub oracle: Option<OracleName>,
    /// The paper oracle's ε₁ when `--eps1` is not given (a scene file's).
    pub eps1: Option<f64>,
    /// The paper oracle's ε₂ when `--eps2` is not given (a scene file's).
    pub eps2: Option<f64>,
    /// The near field's edge rule when `--rule` is not given (a scene file's).
    pub rule: Option<RuleName>,
    /// Where the radiance is evaluated when `--receivers` is not given (a scene file's).
    pub receivers: Option<ReceiverName>,
    /// The incremental mode's budget when `--budget` is not given (a scene file's).
    pub budget: Option<u64>,
    /// Radiosity's options when their flags are not given (a scene file's).
    pub patch_size: Option<f64>,
    pub rays: Option<u64>,
    pub iteration: Option<IterationName>,
    pub radiosity_tolerance: Option<f64>,
    pub bounces: Option<u64>,
    pub scattering: Option<ScatteringName>,
    pub profile_distance: Option<DistanceName>,
    pub profile_het: Option<HetName>,
    /// PRT's options when their flags are not given (a scene file's; the cache folder resolved
    /// against the file's folder).
    pub prt_samples: Option<u32>,
    pub prt_terms: Option<u64>,
    pub prt_basis: Option<u32>,
    pub prt_cache: Option<std::path::PathBuf>,
    /// The polygrid's options when their flags are not given (a scene file's).
    pub polygrid_nodes: Option<u64>,
    pub polygrid_cube: Option<f64>,
    pub polygrid_resolution: Option<u32>,
    pub polygrid_stencil: Option<Stencil>,
}

/// A scene file's `[bake]` table as written (names not yet parsed): the keys that choose the
/// method and its options, named as the command line's flags.
#[derive(Debug, Clone, Default)]
pub struct BakeTable {
    pub method: Option<String>,
    pub tets: Option<u64>,
    /// `auto` or a layer count, as written.
    pub grading: Option<String>,
    pub discretization: Option<String>,
    pub tolerance: Option<f64>,
    pub solver: Option<String>,
    pub theta: Option<f64>,
    pub oracle: Option<String>,
    pub eps1: Option<f64>,
    pub eps2: Option<f64>,
    pub rule: Option<String>,
    pub receivers: Option<String>,
    pub mode: Option<String>,
    pub budget: Option<u64>,
    pub patch_size: Option<f64>,
    pub rays: Option<u64>,
    pub iteration: Option<String>,
    pub radiosity_tolerance: Option<f64>,
    pub bounces: Option<u64>,
    pub prt_samples: Option<u32>,
    pub prt_terms: Option<u64>,
    pub prt_basis: Option<u32>,
    pub prt_cache: Option<std::path::PathBuf>,
    pub polygrid_nodes: Option<u64>,
    pub polygrid_cube: Option<f64>,
    pub polygrid_resolution: Option<u32>,
    pub polygrid_stencil: Option<String>,
}

/// The value of `[bake] key` among the names of `T` (any case).
///
/// # Errors
/// An unknown name, listing the valid ones (`what` and `plural`: "an oracle", "the oracles").
fn bake_name<T: ValueEnum>(key: &str, value: Option<&str>, what: &str, plural: &str) -> anyhow::Result<Option<T>> {
    value
        .map(|v| {
            T::from_str(v, true).map_err(|_| {
                let names: Vec<String> =
                    T::value_variants().iter().filter_map(|n| n.to_possible_value().map(|p| p.get_name().to_owned())).collect();
                anyhow!("[bake] {key}: unknown {what} {} (the {plural} are: {})", quote(v), names.join(", "))
            })
        })
        .transpose()
}

/// The command-line name of a value of `T`.
fn value_name<T: ValueEnum>(value: T) -> String {
    value.to_possible_value().map(|v| v.get_name().to_owned()).unwrap_or_default()
}

impl MethodDefaults {
    /// The defaults of a scene file's `[bake]` table: its method, TransCut's `tets`,
    /// `tolerance` and `solver`, the dipole's `theta`, `oracle`, `eps1`, `eps2`, `rule`,
    /// `receivers`, `mode` and `budget`, radiosity's, PRT's and the polygrid's (the names and
    /// values of the command line's flags).
    ///
    /// # Errors
    /// An unknown oracle, rule, receivers, mode, iteration or stencil name, listing the valid
    /// ones; a budget of 0 (as `--budget`, at least 1).
    pub fn from_bake_table(table: BakeTable) -> anyhow::Result<Self> {
        let oracle = bake_name::<OracleName>("oracle", table.oracle.as_deref(), "oracle", "oracles")?;
        let rule = bake_name::<RuleName>("rule", table.rule.as_deref(), "rule", "rules")?;
        let receivers = bake_name::<ReceiverName>("receivers", table.receivers.as_deref(), "receivers", "receivers")?;
        let mode = bake_name::<ModeName>("mode", table.mode.as_deref(), "mode", "modes")?;
        let iteration = bake_name::<IterationName>("iteration", table.iteration.as_deref(), "iteration", "iterations")?;
        let polygrid_stencil = table
            .polygrid_stencil
            .as_deref()
            .map(|name| stencil(name).map_err(|e| anyhow!("[bake] polygrid_stencil: {e}")))
            .transpose()?;
        if table.bounces == Some(0) {
            bail!(
                "[bake] bounces = 0: the bounces are at least 1 (the direct light's; leave bounces out to stop at the tolerance)"
            );
        }
        if table.rays == Some(0) {
            bail!("[bake] rays = 0: each patch casts at least 1 ray");
        }
        if table.budget == Some(0) {
            bail!("[bake] budget = 0: the links an incremental update may make are at least 1 (leave budget out for no cap)");
        }
        Ok(Self {
            from_file: true,
            method: table.method,
            tets: table.tets,
            grading: table.grading.as_deref().map(grading_choice).transpose().map_err(|e| anyhow!("[bake] grading: {e}"))?,
            discretization: table.discretization,
            tolerance: table.tolerance,
            solver: table.solver,
            mode,
            theta: table.theta,
            oracle,
            eps1: table.eps1,
            eps2: table.eps2,
            rule,
            receivers,
            budget: table.budget,
            patch_size: table.patch_size,
            rays: table.rays,
            iteration,
            radiosity_tolerance: table.radiosity_tolerance,
            bounces: table.bounces,
            scattering: None,
            profile_distance: None,
            profile_het: None,
            prt_samples: table.prt_samples,
            prt_terms: table.prt_terms,
            prt_basis: table.prt_basis,
            prt_cache: table.prt_cache,
            polygrid_nodes: table.polygrid_nodes,
            polygrid_cube: table.polygrid_cube,
            polygrid_resolution: table.polygrid_resolution,
            polygrid_stencil,
        })
    }

    /// These defaults with a scene file's radiosity `[bake] scattering` (`diffusion`,
    /// `half-space`, `dipole`) and `profile_distance` (`chord`, `interior`).
    ///
    /// # Errors
    /// An unknown scattering or distance name, listing the valid ones.
    pub fn with_scattering(self, scattering: Option<&str>, profile_distance: Option<&str>) -> anyhow::Result<Self> {
        let scattering = bake_name::<ScatteringName>("scattering", scattering, "scattering", "scatterings")?;
        let profile_distance = bake_name::<DistanceName>("profile_distance", profile_distance, "distance", "distances")?;
        Ok(Self { scattering, profile_distance, ..self })
    }

    /// These defaults with a scene file's radiosity `[bake] profile_het` (`consistent`,
    /// `sheng2014`).
    ///
    /// # Errors
    /// An unknown rule name, listing the valid ones.
    pub fn with_profile_het(self, profile_het: Option<&str>) -> anyhow::Result<Self> {
        let profile_het = bake_name::<HetName>("profile_het", profile_het, "rule", "rules")?;
        Ok(Self { profile_het, ..self })
    }
}

/// Parses a solver name ([`SolverKind::from_name`]).
///
/// # Errors
/// The valid names.
pub fn solver_kind(name: &str) -> Result<SolverKind, String> {
    SolverKind::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = SolverKind::ALL.iter().map(|k| k.name()).collect();
        format!("unknown solver '{name}' (the solvers are: {})", names.join(", "))
    })
}

/// Parses a discretisation name ([`Discretization::from_name`]).
///
/// # Errors
/// The valid names.
pub fn discretization(name: &str) -> Result<Discretization, String> {
    Discretization::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = Discretization::ALL.iter().map(|d| d.name()).collect();
        format!("unknown discretization '{name}' (the discretizations are: {})", names.join(", "))
    })
}

/// Parses a grading: `auto` ([`GradingChoice::Auto`]), 0 (uniform) or a number of cubes of each
/// size up to [`TransCutOptions::MAX_GRADING_LAYERS`].
///
/// # Errors
/// What is accepted.
pub fn grading_choice(text: &str) -> Result<GradingChoice, String> {
    if text.eq_ignore_ascii_case("auto") {
        return Ok(GradingChoice::Auto);
    }
    match text.parse::<u32>() {
        Ok(layers) if layers <= TransCutOptions::MAX_GRADING_LAYERS => Ok(Grading::from_layers(layers).into()),
        _ => Err(format!("'{text}': auto, 0 (uniform) or 1 to {} cubes of each size", TransCutOptions::MAX_GRADING_LAYERS)),
    }
}

/// Parses a polygrid stencil name ([`Stencil::from_name`]).
///
/// # Errors
/// The valid names.
pub fn stencil(name: &str) -> Result<Stencil, String> {
    Stencil::from_name(name)
        .ok_or_else(|| format!("unknown stencil {} (the stencils are: {})", quote(name), Stencil::NAMES.join(", ")))
}

/// The text of `--method help`: every method, one line each.
#[must_use]
pub fn method_help() -> String {
    let methods = Method::all();
    let width = methods.iter().map(|m| m.name().len()).max().unwrap_or(0);
    let mut out = String::from("methods (--method NAME):\n");
    for m in &methods {
        out.push_str(&format!("  {:width$}  {}\n", m.name(), m.description()));
    }
    out
}

/// An option: whether it was given, its flag or key, and the methods it belongs to.
type OptionOwner = (bool, &'static str, &'static [&'static str]);

/// The first of `options` that was given and is not of `method`, with its methods' names.
/// ("the transcut method", "the transcut and radiosity methods", "the transcut, radiosity and
/// polygrid methods").
fn foreign(options: &[OptionOwner], method: &str) -> Option<(&'static str, String)> {
    options.iter().find(|(given, _, owners)| *given && !owners.contains(&method)).map(|&(_, name, owners)| {
        let names = match owners {
            [.., last] if owners.len() > 1 => format!("{} and {last} methods", owners[..owners.len() - 1].join(", ")),
            _ => format!("{} method", owners.join("")),
        };
        (name, names)
    })
}

impl MethodArgs {
    /// Whether `--method help` was given.
    #[must_use]
    pub fn wants_help(&self) -> bool {
        self.method.as_deref().is_some_and(|m| m.trim().eq_ignore_ascii_case("help"))
    }

    /// Every method option: whether it was given, its flag and its method.
    fn options(&self) -> [OptionOwner; 30] {
        [
            (self.tets.is_some(), "--tets", DIFFUSION),
            (self.grading.is_some(), "--grading", DIFFUSION),
            (self.discretization.is_some(), "--discretization", DIFFUSION),
            (self.tolerance.is_some(), "--tolerance", SOLVES),
            (self.solver.is_some(), "--solver", SOLVES),
            (self.backend.is_some(), "--backend", SOLVES),
            (self.theta.is_some(), "--theta", &[DIPOLE]),
            (self.oracle.is_some(), "--oracle", &[DIPOLE]),
            (self.eps1.is_some(), "--eps1", &[DIPOLE]),
            (self.eps2.is_some(), "--eps2", &[DIPOLE]),
            (self.rule.is_some(), "--rule", &[DIPOLE]),
            (self.receivers.is_some(), "--receivers", &[DIPOLE]),
            (self.mode.is_some(), "--mode", &[DIPOLE]),
            (self.budget.is_some(), "--budget", &[DIPOLE]),
            (self.patch_size.is_some(), "--patch-size", &[RADIOSITY]),
            (self.rays.is_some(), "--rays", &[RADIOSITY]),
            (self.iteration.is_some(), "--iteration", &[RADIOSITY]),
            (self.radiosity_tolerance.is_some(), "--radiosity-tolerance", &[RADIOSITY]),
            (self.bounces.is_some(), "--bounces", &[RADIOSITY]),
            (self.scattering.is_some(), "--scattering", &[RADIOSITY]),
            (self.profile_distance.is_some(), "--profile-distance", &[RADIOSITY]),
            (self.profile_het.is_some(), "--profile-het", &[RADIOSITY]),
            (self.prt_samples.is_some(), "--prt-samples", &[PRT]),
            (self.prt_terms.is_some(), "--prt-terms", &[PRT]),
            (self.prt_basis.is_some(), "--prt-basis", &[PRT]),
            (self.prt_cache.is_some(), "--prt-cache", &[PRT]),
            (self.polygrid_nodes.is_some(), "--polygrid-nodes", &[POLYGRID]),
            (self.polygrid_cube.is_some(), "--polygrid-cube", &[POLYGRID]),
            (self.polygrid_resolution.is_some(), "--polygrid-resolution", &[POLYGRID]),
            (self.polygrid_stencil.is_some(), "--polygrid-stencil", &[POLYGRID]),
        ]
    }

    /// The method these arguments choose, over `defaults` (a scene file's or the command's):
    /// its name, then its options.
    ///
    /// # Errors
    /// An unknown method or solver name (listing the valid ones); an option of another method
    /// than the one chosen (naming both); options that contradict each other; options out of
    /// range ([`Method::validate`]).
    pub fn method(&self, defaults: &MethodDefaults) -> anyhow::Result<Method> {
        let name = self.method.as_deref().or(defaults.method.as_deref()).unwrap_or(TRANSCUT);
        let method = Method::from_name(name).ok_or_else(|| anyhow!("{}", Method::unknown(name)))?;
        if let Some((option, owner)) = foreign(&self.options(), method.name()) {
            bail!("{option} is an option of the {owner}, not of {} (the method chosen)", method.name());
        }
        // A scene file's TransCut options, when the file itself chose another method: written
        // for nothing. (When the command line chose the method, they were for the file's.)
        if self.method.is_none() && defaults.from_file {
            let file: [OptionOwner; 29] = [
                (defaults.tets.is_some(), "tets", DIFFUSION),
                (defaults.grading.is_some(), "grading", DIFFUSION),
                (defaults.discretization.is_some(), "discretization", DIFFUSION),
                (defaults.tolerance.is_some(), "tolerance", SOLVES),
                (defaults.solver.is_some(), "solver", SOLVES),
                (defaults.theta.is_some(), "theta", &[DIPOLE]),
                (defaults.oracle.is_some(), "oracle", &[DIPOLE]),
                (defaults.eps1.is_some(), "eps1", &[DIPOLE]),
                (defaults.eps2.is_some(), "eps2", &[DIPOLE]),
                (defaults.rule.is_some(), "rule", &[DIPOLE]),
                (defaults.receivers.is_some(), "receivers", &[DIPOLE]),
                (defaults.mode.is_some(), "mode", &[DIPOLE]),
                (defaults.budget.is_some(), "budget", &[DIPOLE]),
                (defaults.patch_size.is_some(), "patch_size", &[RADIOSITY]),
                (defaults.rays.is_some(), "rays", &[RADIOSITY]),
                (defaults.iteration.is_some(), "iteration", &[RADIOSITY]),
                (defaults.radiosity_tolerance.is_some(), "radiosity_tolerance", &[RADIOSITY]),
                (defaults.bounces.is_some(), "bounces", &[RADIOSITY]),
                (defaults.scattering.is_some(), "scattering", &[RADIOSITY]),
                (defaults.profile_distance.is_some(), "profile_distance", &[RADIOSITY]),
                (defaults.profile_het.is_some(), "profile_het", &[RADIOSITY]),
                (defaults.prt_samples.is_some(), "prt_samples", &[PRT]),
                (defaults.prt_terms.is_some(), "prt_terms", &[PRT]),
                (defaults.prt_basis.is_some(), "prt_basis", &[PRT]),
                (defaults.prt_cache.is_some(), "prt_cache", &[PRT]),
                (defaults.polygrid_nodes.is_some(), "polygrid_nodes", &[POLYGRID]),
                (defaults.polygrid_cube.is_some(), "polygrid_cube", &[POLYGRID]),
                (defaults.polygrid_resolution.is_some(), "polygrid_resolution", &[POLYGRID]),
                (defaults.polygrid_stencil.is_some(), "polygrid_stencil", &[POLYGRID]),
            ];
            if let Some((option, owner)) = foreign(&file, method.name()) {
                bail!("[bake] {option} is an option of the {owner}, not of {} (the file's method)", method.name());
            }
        }
        let method = match method {
            Method::TransCut(d) => Method::TransCut(self.transcut(d, defaults)?),
            Method::HierarchicalDipole(d) => Method::HierarchicalDipole(self.dipole(d, defaults)?),
            Method::Radiosity(d) => {
                let bounces = self.bounces.or(defaults.bounces).map(usize::try_from).transpose()?;
                let rays = self.rays.or(defaults.rays).map_or(Ok(d.form_factors.rays_per_patch), usize::try_from)?;
                Method::Radiosity(RadiosityOptions {
                    patch_size_mm: self.patch_size.or(defaults.patch_size),
                    form_factors: FormFactorOptions { rays_per_patch: rays, ..d.form_factors },
                    solve: SolveOptions {
                        iteration: self.iteration.or(defaults.iteration).map_or(d.solve.iteration, IterationName::iteration),
                        tolerance: self.radiosity_tolerance.or(defaults.radiosity_tolerance).unwrap_or(d.solve.tolerance),
                        bounces,
                        ..d.solve
                    },
                    transcut: self.transcut(d.transcut, defaults)?,
                    scattering: self.scattering(defaults)?.unwrap_or(d.scattering),
                    backend: self.backend.or(d.backend),
                })
            }
            Method::Prt(d) => Method::Prt(PrtOptions {
                samples_log2: self.prt_samples.or(defaults.prt_samples).unwrap_or(d.samples_log2),
                terms_per_vertex: self.prt_terms.or(defaults.prt_terms).map_or(Ok(d.terms_per_vertex), usize::try_from)?,
                basis: match self.prt_basis.or(defaults.prt_basis) {
                    None => d.basis,
                    Some(12) => BasisSize::K12,
                    Some(16) => BasisSize::K16,
                    Some(k) => bail!("--prt-basis {k}: the bases have 12 or 16 functions"),
                },
                cache: self.prt_cache.clone().or_else(|| defaults.prt_cache.clone()).map(PrtCache::Folder).or(d.cache),
                ..d
            }),
            Method::Polygrid(d) => Method::Polygrid(PolygridOptions {
                nodes: self.polygrid_nodes.or(defaults.polygrid_nodes).map_or(Ok(d.nodes), usize::try_from)?,
                cube_mm: self.polygrid_cube.or(defaults.polygrid_cube).or(d.cube_mm),
                resolution: self.polygrid_resolution.or(defaults.polygrid_resolution).unwrap_or(d.resolution),
                stencil: self.polygrid_stencil.or(defaults.polygrid_stencil).unwrap_or(d.stencil),
                // The solves as TransCut's, on the grid's nodes (no tets to ask for).
                solve: TransCutOptions { tets: d.solve.tets, ..self.transcut(d.solve.clone(), defaults)? },
            }),
            _ => bail!("{}", Method::unknown(name)),
        };
        method.validate().map_err(|e| anyhow!(e))?;
        Ok(method)
    }

    /// Radiosity's scattering S from `--scattering`, `--profile-distance` and `--profile-het`
    /// over a scene file's `scattering`, `profile_distance` and `profile_het`; `None` when none
    /// is given.
    fn scattering(&self, defaults: &MethodDefaults) -> anyhow::Result<Option<TranslucentScattering>> {
        let distance = self.profile_distance.or(defaults.profile_distance);
        let het = self.profile_het.or(defaults.profile_het);
        match self.scattering.or(defaults.scattering) {
            Some(name) => name.scattering(distance, het).map(Some),
            None if distance.is_some() => bail!("--profile-distance (profile_distance) needs --scattering half-space or dipole"),
            None if het.is_some() => bail!("--profile-het (profile_het) needs --scattering half-space or dipole"),
            None => Ok(None),
        }
    }

    /// TransCut's options over `d` (its own, or radiosity's for the translucent objects).
    fn transcut(&self, d: TransCutOptions, defaults: &MethodDefaults) -> anyhow::Result<TransCutOptions> {
        let solver = match (&self.solver, &defaults.solver) {
            (Some(k), _) => *k,
            (None, Some(name)) => solver_kind(name).map_err(|e| anyhow!("[bake] solver: {e}"))?,
            (None, None) => d.solver,
        };
        let tets = self.tets.or(defaults.tets).map_or(Ok(d.tets), usize::try_from)?;
        let grading = self.grading.or(defaults.grading).unwrap_or(d.grading);
        let discretization = match (self.discretization, &defaults.discretization) {
            (Some(d), _) => d,
            (None, Some(name)) => discretization(name).map_err(|e| anyhow!("[bake] discretization: {e}"))?,
            (None, None) => d.discretization,
        };
        Ok(TransCutOptions {
            tets,
            grading,
            discretization,
            tolerance: self.tolerance.or(defaults.tolerance).unwrap_or(d.tolerance),
            solver,
            backend: self.backend,
            ..d
        })
    }

    /// The hierarchical dipole's options over `d`, its defaults.
    ///
    /// Each flag overrides the same key of a scene file. A file's key that belongs to a choice
    /// the command line overrode goes with it: its `theta` under `--oracle paper`, its `eps1`
    /// and `eps2` under `--oracle opening-angle` or `--theta`, its `budget` under a `--mode`
    /// other than incremental. Any other option that does not fit the oracle or the mode in
    /// effect is an error naming it (the flag, or the file's `[bake]` key).
    fn dipole(&self, d: DipoleOptions, defaults: &MethodDefaults) -> anyhow::Result<DipoleOptions> {
        if self.oracle == Some(OracleName::Paper) && self.theta.is_some() {
            bail!("--theta is the opening-angle oracle's: --oracle paper takes --eps1 and --eps2");
        }
        // The command line's oracle: named, or the opening angle its --theta implies.
        let cli_oracle = self.oracle.or(self.theta.map(|_| OracleName::OpeningAngle));
        let theta = self.theta.or(defaults.theta.filter(|_| cli_oracle != Some(OracleName::Paper)));
        let file_eps = |v: Option<f64>, key| v.filter(|_| cli_oracle != Some(OracleName::OpeningAngle)).map(|v| (v, key));
        let eps1 = self.eps1.map(|v| (v, "--eps1")).or(file_eps(defaults.eps1, "[bake] eps1"));
        let eps2 = self.eps2.map(|v| (v, "--eps2")).or(file_eps(defaults.eps2, "[bake] eps2"));
        let oracle = match cli_oracle.or(defaults.oracle).or(theta.map(|_| OracleName::OpeningAngle)) {
            Some(OracleName::Paper) => {
                if theta.is_some() {
                    bail!("[bake] theta is the opening-angle oracle's: oracle = \"paper\" takes eps1 and eps2");
                }
                Oracle::Paper { eps1: eps1.map_or(PAPER_EPS, |e| e.0), eps2: eps2.map_or(PAPER_EPS, |e| e.0) }
            }
            chosen => {
                match eps1.or(eps2) {
                    Some((_, flag)) if flag.starts_with("--") => bail!(
                        "{flag} is a threshold of the paper oracle: give --oracle paper (the opening-angle oracle takes --theta)"
                    ),
                    Some((_, key)) => bail!(
                        "{key} is a threshold of the paper oracle: set oracle = \"paper\" (the opening-angle oracle takes theta)"
                    ),
                    None => {}
                }
                match chosen {
                    None => d.oracle,
                    Some(_) => Oracle::OpeningAngle { theta: theta.unwrap_or(DEFAULT_THETA) },
                }
            }
        };
        let name = self.mode.or(defaults.mode).unwrap_or(DEFAULT_MODE);
        // A file's budget goes with the file's mode: a --mode other than incremental drops it.
        let file_budget = defaults.budget.filter(|_| self.mode.is_none_or(|m| m == ModeName::Incremental));
        let budget = self.budget.map(|b| (b, "--budget")).or(file_budget.map(|b| (b, "[bake] budget")));
        let mode = match (name, budget) {
            (ModeName::Incremental, budget) => {
                EvalMode::Incremental { budget: budget.map(|(b, _)| usize::try_from(b)).transpose()? }
            }
            (name, Some((_, "--budget"))) => bail!(
                "--budget caps the links an incremental update makes: it needs --mode incremental (the mode is {})",
                value_name(name)
            ),
            (name, Some((_, key))) => bail!(
                "{key} caps the links an incremental update makes: it needs mode = \"incremental\" (the mode is {})",
                value_name(name)
            ),
            (ModeName::OnTheFly, None) => EvalMode::OnTheFly,
            (ModeName::Render, None) => EvalMode::Render,
        };
        Ok(DipoleOptions {
            oracle,
            rule: match self.rule.or(defaults.rule) {
                None => d.rule,
                Some(RuleName::Gl3) => EdgeRule::default(),
                Some(RuleName::Paper) => EdgeRule::PAPER,
            },
            receivers: match self.receivers.or(defaults.receivers) {
                None => d.receivers,
                Some(ReceiverName::Vertices) => Receivers::Vertices,
                Some(ReceiverName::Faces) => Receivers::FaceCentroids,
            },
            mode,
            ..d
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dipole(args: MethodArgs) -> anyhow::Result<DipoleOptions> {
        match (MethodArgs { method: Some(DIPOLE.into()), ..args }).method(&MethodDefaults::default())? {
            Method::HierarchicalDipole(o) => Ok(o),
            other => panic!("{other:?}"),
        }
    }

    fn error(args: MethodArgs, defaults: &MethodDefaults) -> String {
        args.method(defaults).unwrap_err().to_string()
    }

    #[test]
    fn the_method_names_are_the_cores() {
        assert!(Method::NAMES.contains(&TRANSCUT) && Method::NAMES.contains(&DIPOLE));
        assert_eq!(Method::default().name(), TRANSCUT);
        assert_eq!(Oracle::default(), Oracle::OpeningAngle { theta: DEFAULT_THETA });
        assert_eq!(EvalMode::default(), EvalMode::OnTheFly);
        assert_eq!(DEFAULT_MODE, ModeName::OnTheFly);
    }

    /// The grading and the discretisation: a scene file's keys, overridden by the flags; 0 is
    /// uniform; an unknown name is named with the valid ones; another method refuses them.
    #[test]
    fn grading_and_discretization_reach_transcuts_options() {
        let file = MethodDefaults::from_bake_table(BakeTable {
            grading: Some("2".into()),
            discretization: Some("Fitted".into()),
            ..BakeTable::default()
        })
        .unwrap();
        let Method::TransCut(o) = MethodArgs::default().method(&file).unwrap() else { panic!() };
        assert_eq!((o.grading, o.discretization), (Grading::Graded { layers: 2 }.into(), Discretization::ExponentiallyFitted));
        let args = MethodArgs {
            grading: Some(Grading::Uniform.into()),
            discretization: Some(Discretization::ConsistentFem),
            ..MethodArgs::default()
        };
        let Method::TransCut(o) = args.method(&file).unwrap() else { panic!() };
        assert_eq!((o.grading, o.discretization), (Grading::Uniform.into(), Discretization::ConsistentFem));
        let auto = MethodDefaults::from_bake_table(BakeTable { grading: Some("auto".into()), ..BakeTable::default() }).unwrap();
        let Method::TransCut(o) = MethodArgs::default().method(&auto).unwrap() else { panic!() };
        assert_eq!(o.grading, GradingChoice::Auto);
        let e = MethodDefaults::from_bake_table(BakeTable { grading: Some("65".into()), ..BakeTable::default() }).unwrap_err();
        assert!(e.to_string().contains("[bake] grading: '65': auto, 0 (uniform) or 1 to 64"), "{e}");
        assert_eq!(grading_choice("AUTO"), Ok(GradingChoice::Auto));
        assert_eq!(grading_choice("0"), Ok(Grading::Uniform.into()));
        assert!(grading_choice("-1").is_err() && grading_choice("graded").is_err());
        let bad = MethodDefaults::from_bake_table(BakeTable { discretization: Some("galerkin".into()), ..BakeTable::default() })
            .unwrap();
        let e = error(MethodArgs::default(), &bad);
        assert!(e.contains("[bake] discretization") && e.contains("transcut, fitted, consistent-fem"), "{e}");
        let e = error(
            MethodArgs { method: Some(DIPOLE.into()), grading: Some(GradingChoice::Auto), ..MethodArgs::default() },
            &MethodDefaults::default(),
        );
        assert!(e.contains("--grading"), "{e}");
    }

    #[test]
    fn names_choose_the_method_and_the_command_line_overrides_the_file() {
        let file = MethodDefaults::from_bake_table(BakeTable {
            method: Some("transcut".into()),
            tets: Some(5000),
            tolerance: Some(1e-4),
            solver: Some("mg-pcg".into()),
            ..BakeTable::default()
        })
        .unwrap();
        let Method::TransCut(o) = MethodArgs::default().method(&file).unwrap() else { panic!() };
        assert_eq!((o.tets, o.tolerance, o.solver), (5000, 1e-4, SolverKind::MultigridPcg));
        let args = MethodArgs { tets: Some(7), solver: Some(SolverKind::Pcg), ..MethodArgs::default() };
        let Method::TransCut(o) = args.method(&file).unwrap() else { panic!() };
        assert_eq!((o.tets, o.solver), (7, SolverKind::Pcg));
        assert_eq!(MethodArgs::default().method(&MethodDefaults::default()).unwrap(), Method::default());
        // The command line's method over the file's: the file's TransCut options are not its.
        let args = MethodArgs { method: Some("hierarchical-dipole".into()), ..MethodArgs::default() };
        assert_eq!(args.method(&file).unwrap(), Method::HierarchicalDipole(DipoleOptions::default()));
    }

    #[test]
    fn a_scene_files_dipole_options_apply_to_the_dipole_only() {
        let table = |method: Option<&str>, theta, mode: Option<&str>| {
            MethodDefaults::from_bake_table(BakeTable {
                method: method.map(Into::into),
                theta,
                mode: mode.map(Into::into),
                ..BakeTable::default()
            })
        };
        let file = table(Some(DIPOLE), Some(0.3), Some("render")).unwrap();
        let Method::HierarchicalDipole(o) = MethodArgs::default().method(&file).unwrap() else { panic!() };
        assert_eq!((o.oracle, o.mode), (Oracle::OpeningAngle { theta: 0.3 }, EvalMode::Render));
        // The command line overrides the file; its paper oracle has no theta.
        let args = MethodArgs { theta: Some(0.6), mode: Some(ModeName::OnTheFly), ..MethodArgs::default() };
        let Method::HierarchicalDipole(o) = args.method(&file).unwrap() else { panic!() };
        assert_eq!((o.oracle, o.mode), (Oracle::OpeningAngle { theta: 0.6 }, EvalMode::OnTheFly));
        let paper = MethodArgs { oracle: Some(OracleName::Paper), ..MethodArgs::default() };
        let Method::HierarchicalDipole(o) = paper.method(&file).unwrap() else { panic!() };
        assert_eq!(o.oracle, Oracle::Paper { eps1: PAPER_EPS, eps2: PAPER_EPS });
        // A file of TransCut (named, or by default) with the dipole's options is refused by name.
        for method in [None, Some(TRANSCUT)] {
            let e = error(MethodArgs::default(), &table(method, Some(0.3), None).unwrap());
            assert!(e.contains("[bake] theta") && e.contains("hierarchical-dipole"), "{e}");
        }
        let e = table(Some(DIPOLE), None, Some("sometimes")).unwrap_err().to_string();
        assert!(e.contains("'sometimes'") && e.contains("incremental"), "{e}");
        // Out of range through the core's check.
        let e = error(MethodArgs::default(), &table(Some(DIPOLE), Some(1.5), None).unwrap());
        assert!(e.contains("theta"), "{e}");
    }

    #[test]
    fn unknown_names_list_the_valid_ones() {
        let args = MethodArgs { method: Some("nonsense".into()), ..MethodArgs::default() };
        let e = error(args, &MethodDefaults::default());
        assert!(e.contains("nonsense") && e.contains("transcut") && e.contains("hierarchical-dipole"), "{e}");
        let file = MethodDefaults { solver: Some("gauss".into()), ..MethodDefaults::default() };
        let e = error(MethodArgs::default(), &file);
        assert!(e.contains("gauss") && e.contains("ssor-pcg"), "{e}");
        assert!(method_help().contains("transcut") && method_help().contains("hierarchical-dipole"));
        assert!(MethodArgs { method: Some("Help".into()), ..MethodArgs::default() }.wants_help());
    }

    #[test]
    fn dipole_options_map_onto_the_cores() {
        assert_eq!(dipole(MethodArgs::default()).unwrap(), DipoleOptions::default());
        let o = dipole(MethodArgs {
            theta: Some(0.3),
            rule: Some(RuleName::Paper),
            receivers: Some(ReceiverName::Faces),
            mode: Some(ModeName::Incremental),
            budget: Some(5000),
            ..MethodArgs::default()
        })
        .unwrap();
        assert_eq!(o.oracle, Oracle::OpeningAngle { theta: 0.3 });
        assert_eq!(o.rule, EdgeRule::PAPER);
        assert_eq!(o.receivers, Receivers::FaceCentroids);
        assert_eq!(o.mode, EvalMode::Incremental { budget: Some(5000) });
        let o = dipole(MethodArgs { oracle: Some(OracleName::Paper), eps2: Some(0.02), ..MethodArgs::default() }).unwrap();
        assert_eq!(o.oracle, Oracle::Paper { eps1: 0.05, eps2: 0.02 });
        for (mode, want) in [(ModeName::OnTheFly, EvalMode::OnTheFly), (ModeName::Render, EvalMode::Render)] {
            assert_eq!(dipole(MethodArgs { mode: Some(mode), ..MethodArgs::default() }).unwrap().mode, want);
        }
        assert_eq!(dipole(MethodArgs { rule: Some(RuleName::Gl3), ..MethodArgs::default() }).unwrap().rule, EdgeRule::default());
        // A command's default mode (animate's), and --budget under it.
        let animate =
            MethodDefaults { method: Some(DIPOLE.into()), mode: Some(ModeName::Incremental), ..MethodDefaults::default() };
        let Method::HierarchicalDipole(o) = MethodArgs { budget: Some(10), ..MethodArgs::default() }.method(&animate).unwrap()
        else {
            panic!()
        };
        assert_eq!(o.mode, EvalMode::Incremental { budget: Some(10) });
    }

    #[test]
    fn radiosity_takes_its_own_options_and_the_translucent_objects_tets() {
        let args = MethodArgs {
            method: Some(RADIOSITY.into()),
            tets: Some(5000),
            patch_size: Some(4.0),
            rays: Some(256),
            iteration: Some(IterationName::GaussSeidel),
            radiosity_tolerance: Some(1e-4),
            ..MethodArgs::default()
        };
        let Method::Radiosity(o) = args.method(&MethodDefaults::default()).unwrap() else { panic!() };
        assert_eq!((o.transcut.tets, o.patch_size_mm, o.form_factors.rays_per_patch), (5000, Some(4.0), 256));
        assert_eq!((o.solve.iteration, o.solve.tolerance, o.solve.bounces), (Iteration::GaussSeidel, 1e-4, None));
        let file = MethodDefaults::from_bake_table(BakeTable {
            method: Some(RADIOSITY.into()),
            bounces: Some(2),
            iteration: Some("gauss-seidel".into()),
            ..BakeTable::default()
        })
        .unwrap();
        let e = error(MethodArgs::default(), &file);
        assert!(e.contains("bounces") && e.contains("Jacobi"), "{e}");
        let e = MethodDefaults::from_bake_table(BakeTable { iteration: Some("sor".into()), ..BakeTable::default() }).unwrap_err();
        assert!(e.to_string().contains("jacobi, gauss-seidel, bicgstab"), "{e}");
        let file = BakeTable { method: Some(RADIOSITY.into()), iteration: Some("BiCGSTAB".into()), ..BakeTable::default() };
        let Method::Radiosity(o) = MethodArgs::default().method(&MethodDefaults::from_bake_table(file).unwrap()).unwrap() else {
            panic!()
        };
        assert_eq!(o.solve.iteration, Iteration::BiCgStab);
    }

    #[test]
    fn the_backend_reaches_the_radiosity_gathers_and_the_diffusion_solves() {
        for backend in [Backend::Cpu, Backend::Gpu, Backend::Auto] {
            let args = MethodArgs { method: Some(RADIOSITY.into()), backend: Some(backend), ..MethodArgs::default() };
            let Method::Radiosity(o) = args.method(&MethodDefaults::default()).unwrap() else { panic!() };
            assert_eq!((o.backend, o.transcut.backend), (Some(backend), Some(backend)));
        }
        let args = MethodArgs { method: Some(RADIOSITY.into()), ..MethodArgs::default() };
        let Method::Radiosity(o) = args.method(&MethodDefaults::default()).unwrap() else { panic!() };
        assert_eq!((o.backend, o.transcut.backend), (None, None), "no flag: TRANSCUT_BACKEND decides at the bake");
    }

    #[test]
    fn radiosity_takes_its_scattering_from_the_flag_or_the_file() {
        let radiosity = |args: MethodArgs, file: &MethodDefaults| match (MethodArgs { method: Some(RADIOSITY.into()), ..args })
            .method(file)
        {
            Ok(Method::Radiosity(o)) => Ok(o.scattering),
            Ok(other) => panic!("{other:?}"),
            Err(e) => Err(e.to_string()),
        };
        let none = MethodDefaults::default();
        assert_eq!(radiosity(MethodArgs::default(), &none), Ok(TranslucentScattering::Diffusion));
        let dipole = MethodArgs { scattering: Some(ScatteringName::Dipole), ..MethodArgs::default() };
        assert_eq!(radiosity(dipole, &none), Ok(TranslucentScattering::profile(ProfileKind::Dipole)));
        let interior = MethodArgs {
            scattering: Some(ScatteringName::HalfSpace),
            profile_distance: Some(DistanceName::Interior),
            ..MethodArgs::default()
        };
        let Ok(TranslucentScattering::Profile(p)) = radiosity(interior, &none) else { panic!() };
        assert_eq!((p.profile, p.distance), (ProfileKind::HalfSpace, OpticalDistance::INTERIOR));
        let alone = MethodArgs { profile_distance: Some(DistanceName::Chord), ..MethodArgs::default() };
        assert!(radiosity(alone, &none).unwrap_err().contains("needs --scattering half-space or dipole"));
        let both = MethodArgs {
            scattering: Some(ScatteringName::Diffusion),
            profile_distance: Some(DistanceName::Interior),
            ..MethodArgs::default()
        };
        assert!(radiosity(both, &none).unwrap_err().contains("not of diffusion"));
        // The scene file's [bake] scattering and profile_distance, under the flags.
        let table = BakeTable { method: Some(RADIOSITY.into()), ..BakeTable::default() };
        let file = MethodDefaults::from_bake_table(table).unwrap().with_scattering(Some("Half-Space"), Some("interior")).unwrap();
        let Ok(TranslucentScattering::Profile(p)) = radiosity(MethodArgs::default(), &file) else { panic!() };
        assert_eq!(p.distance, OpticalDistance::INTERIOR);
        let flag = MethodArgs { scattering: Some(ScatteringName::Diffusion), ..MethodArgs::default() };
        assert!(radiosity(flag, &file).unwrap_err().contains("not of diffusion"), "the file's distance with the flag's S");
        // The heterogeneous rule: the flag, the file's, and refused without a profile.
        let sheng = MethodArgs {
            scattering: Some(ScatteringName::Dipole),
            profile_het: Some(HetName::Sheng2014),
            ..MethodArgs::default()
        };
        let Ok(TranslucentScattering::Profile(p)) = radiosity(sheng, &none) else { panic!() };
        assert_eq!((p.profile, p.het), (ProfileKind::Dipole, HetRule::Sheng2014));
        let Ok(TranslucentScattering::Profile(p)) = radiosity(MethodArgs::default(), &file) else { panic!() };
        assert_eq!(p.het, HetRule::Consistent);
        let file_het = file.clone().with_profile_het(Some("sheng2014")).unwrap();
        let Ok(TranslucentScattering::Profile(p)) = radiosity(MethodArgs::default(), &file_het) else { panic!() };
        assert_eq!(p.het, HetRule::Sheng2014);
        let alone = MethodArgs { profile_het: Some(HetName::Consistent), ..MethodArgs::default() };
        assert!(radiosity(alone, &none).unwrap_err().contains("--profile-het (profile_het) needs --scattering"));
        let diffusion = MethodArgs {
            scattering: Some(ScatteringName::Diffusion),
            profile_het: Some(HetName::Sheng2014),
            ..MethodArgs::default()
        };
        assert!(radiosity(diffusion, &none).unwrap_err().contains("not of diffusion"));
        let e = MethodDefaults::default().with_profile_het(Some("mean")).unwrap_err().to_string();
        assert!(e.contains("[bake] profile_het") && e.contains("consistent, sheng2014"), "{e}");
        let e = MethodDefaults::default().with_scattering(Some("table"), None).unwrap_err().to_string();
        assert!(e.contains("[bake] scattering") && e.contains("diffusion, half-space, dipole"), "{e}");
        let e = error(MethodArgs { scattering: Some(ScatteringName::Dipole), ..MethodArgs::default() }, &none);
        assert!(e.contains("--scattering is an option of the radiosity method"), "{e}");
    }

    #[test]
    fn options_of_another_method_are_refused_by_name() {
        let none = MethodDefaults::default();
        let e = error(MethodArgs { theta: Some(0.4), ..MethodArgs::default() }, &none);
        assert!(e.contains("--theta") && e.contains("hierarchical-dipole") && e.contains("not of transcut"), "{e}");
        let args = MethodArgs { method: Some(DIPOLE.into()), tets: Some(1000), ..MethodArgs::default() };
        let e = error(args, &none);
        assert!(e.contains("--tets") && e.contains("of the transcut and radiosity methods, not of hierarchical-dipole"), "{e}");
        let args = MethodArgs { patch_size: Some(4.0), ..MethodArgs::default() };
        let e = error(args, &none);
        assert!(e.contains("--patch-size is an option of the radiosity method, not of transcut"), "{e}");
        let args = MethodArgs { method: Some("transcut".into()), mode: Some(ModeName::Render), ..MethodArgs::default() };
        assert!(error(args, &none).contains("--mode"));
        // A file that chose the dipole and gave TransCut's options.
        let file = MethodDefaults::from_bake_table(BakeTable {
            method: Some(DIPOLE.into()),
            solver: Some("pcg".into()),
            ..BakeTable::default()
        })
        .unwrap();
        let e = error(MethodArgs::default(), &file);
        assert!(e.contains("[bake] solver") && e.contains("transcut"), "{e}");
    }

    /// A scene file's PRT keys set the method's options under the command line's flags; in a
    /// file of another method they are refused by name.
    #[test]
    fn a_scene_files_prt_keys() {
        let file = MethodDefaults::from_bake_table(BakeTable {
            method: Some(PRT.into()),
            prt_samples: Some(12),
            prt_terms: Some(2048),
            prt_basis: Some(12),
            prt_cache: Some("cache".into()),
            ..BakeTable::default()
        })
        .unwrap();
        let Method::Prt(o) = MethodArgs::default().method(&file).unwrap() else { panic!("not prt") };
        assert_eq!((o.samples_log2, o.terms_per_vertex, o.basis), (12, 2048, BasisSize::K12));
        assert_eq!(o.cache, Some(PrtCache::Folder("cache".into())));
        let args = MethodArgs { prt_samples: Some(14), prt_cache: Some("flag".into()), ..MethodArgs::default() };
        let Method::Prt(o) = args.method(&file).unwrap() else { panic!("not prt") };
        assert_eq!((o.samples_log2, o.terms_per_vertex), (14, 2048), "the flag wins over the file");
        assert_eq!(o.cache, Some(PrtCache::Folder("flag".into())));
        let transcut = MethodDefaults::from_bake_table(BakeTable { prt_terms: Some(2048), ..BakeTable::default() }).unwrap();
        let e = MethodArgs::default().method(&transcut).unwrap_err().to_string();
        assert!(e.contains("[bake] prt_terms is an option of the prt method"), "{e}");
    }

    fn polygrid(args: MethodArgs, file: &MethodDefaults) -> anyhow::Result<PolygridOptions> {
        match (MethodArgs { method: args.method.clone().or(Some(POLYGRID.into())), ..args }).method(file)? {
            Method::Polygrid(o) => Ok(o),
            other => panic!("{other:?}"),
        }
    }

    /// The polygrid's flags map onto its options, the shared solve options onto its solves, and
    /// nothing else changes.
    #[test]
    fn polygrid_takes_its_own_options_and_the_shared_solves() {
        let none = MethodDefaults::default();
        assert_eq!(polygrid(MethodArgs::default(), &none).unwrap(), PolygridOptions::default());
        let o = polygrid(
            MethodArgs {
                polygrid_nodes: Some(50_000),
                polygrid_cube: Some(2.5),
                polygrid_resolution: Some(12),
                polygrid_stencil: Some(Stencil::FiniteVolume),
                tolerance: Some(1e-8),
                solver: Some(SolverKind::MultigridPcg),
                backend: Some(Backend::Cpu),
                ..MethodArgs::default()
            },
            &none,
        )
        .unwrap();
        let solve = TransCutOptions {
            tolerance: 1e-8,
            solver: SolverKind::MultigridPcg,
            backend: Some(Backend::Cpu),
            ..TransCutOptions::default()
        };
        let want = PolygridOptions { nodes: 50_000, cube_mm: Some(2.5), resolution: 12, stencil: Stencil::FiniteVolume, solve };
        assert_eq!(o, want);
        // The method by name in any case; the stencils by name, and an unknown one listed.
        let named = MethodArgs { method: Some("PolyGrid".into()), ..MethodArgs::default() };
        assert_eq!(named.method(&none).unwrap(), Method::Polygrid(PolygridOptions::default()));
        assert_eq!(stencil("fem"), Ok(Stencil::Fem));
        assert_eq!(stencil("Finite-Volume"), Ok(Stencil::FiniteVolume));
        assert_eq!(stencil("paper-LSQ"), Ok(Stencil::PaperLsq));
        let e = stencil("lsq").unwrap_err();
        assert!(e.contains("'lsq'") && e.contains("fem, finite-volume, paper-lsq"), "{e}");
        assert!(method_help().lines().any(|l| l.trim_start().starts_with("polygrid ")), "{}", method_help());
        // Out of range through the core's check, naming the method and the option.
        for (args, words) in [
            (MethodArgs { polygrid_cube: Some(0.0), ..MethodArgs::default() }, ["polygrid: cube_mm = 0", "> 0"]),
            (MethodArgs { polygrid_cube: Some(f64::NAN), ..MethodArgs::default() }, ["polygrid: cube_mm = NaN", "finite"]),
            (MethodArgs { tolerance: Some(1.0), ..MethodArgs::default() }, ["polygrid: tolerance", "(0, 1)"]),
        ] {
            let e = format!("{:#}", polygrid(args, &none).unwrap_err());
            assert!(words.iter().all(|w| e.contains(w)), "{e}");
        }
    }

    #[test]
    fn polygrid_options_are_refused_with_another_method_and_others_with_polygrid() {
        let none = MethodDefaults::default();
        let flags: [(&str, MethodArgs); 4] = [
            ("--polygrid-nodes", MethodArgs { polygrid_nodes: Some(1000), ..MethodArgs::default() }),
            ("--polygrid-cube", MethodArgs { polygrid_cube: Some(2.0), ..MethodArgs::default() }),
            ("--polygrid-resolution", MethodArgs { polygrid_resolution: Some(4), ..MethodArgs::default() }),
            ("--polygrid-stencil", MethodArgs { polygrid_stencil: Some(Stencil::Fem), ..MethodArgs::default() }),
        ];
        for (flag, args) in flags {
            for method in [TRANSCUT, DIPOLE, RADIOSITY, PRT] {
                let e = error(MethodArgs { method: Some(method.into()), ..args.clone() }, &none);
                assert_eq!(e, format!("{flag} is an option of the polygrid method, not of {method} (the method chosen)"));
            }
        }
        let polygrid_with = |args: MethodArgs| error(MethodArgs { method: Some(POLYGRID.into()), ..args }, &none);
        let e = polygrid_with(MethodArgs { tets: Some(1000), ..MethodArgs::default() });
        assert_eq!(e, "--tets is an option of the transcut and radiosity methods, not of polygrid (the method chosen)");
        let e = polygrid_with(MethodArgs { theta: Some(0.3), ..MethodArgs::default() });
        assert!(e.contains("--theta is an option of the hierarchical-dipole method, not of polygrid"), "{e}");
        let e = polygrid_with(MethodArgs { prt_terms: Some(100), ..MethodArgs::default() });
        assert!(e.contains("--prt-terms is an option of the prt method, not of polygrid"), "{e}");
        // The shared solve options name their three methods.
        let e = error(MethodArgs { method: Some(DIPOLE.into()), solver: Some(SolverKind::Pcg), ..MethodArgs::default() }, &none);
        assert!(
            e.contains("--solver is an option of the transcut, radiosity and polygrid methods, not of hierarchical-dipole"),
            "{e}"
        );
    }

    /// A scene file's polygrid keys set the options under the command line's flags; in a file
    /// of another method they are refused by name, and an unknown stencil lists the valid ones.
    #[test]
    fn a_scene_files_polygrid_keys() {
        let table = |method: &str| BakeTable {
            method: Some(method.into()),
            polygrid_nodes: Some(30_000),
            polygrid_cube: Some(3.0),
            polygrid_resolution: Some(6),
            polygrid_stencil: Some("finite-volume".into()),
            tolerance: Some(1e-7),
            solver: Some("pcg".into()),
            ..BakeTable::default()
        };
        let file = MethodDefaults::from_bake_table(table(POLYGRID)).unwrap();
        let o = polygrid(MethodArgs::default(), &file).unwrap();
        assert_eq!((o.nodes, o.cube_mm, o.resolution, o.stencil), (30_000, Some(3.0), 6, Stencil::FiniteVolume));
        assert_eq!((o.solve.tolerance, o.solve.solver), (1e-7, SolverKind::Pcg));
        let args = MethodArgs { polygrid_resolution: Some(10), polygrid_stencil: Some(Stencil::Fem), ..MethodArgs::default() };
        let o = polygrid(args, &file).unwrap();
        assert_eq!((o.nodes, o.resolution, o.stencil), (30_000, 10, Stencil::Fem), "the flag wins over the file");
        for (key, set) in [
            ("polygrid_nodes", (|t| t.polygrid_nodes = Some(10)) as SetKey),
            ("polygrid_cube", |t| t.polygrid_cube = Some(1.0)),
            ("polygrid_resolution", |t| t.polygrid_resolution = Some(4)),
            ("polygrid_stencil", |t| t.polygrid_stencil = Some("fem".into())),
        ] {
            for method in [TRANSCUT, PRT] {
                let mut t = BakeTable { method: Some(method.into()), ..BakeTable::default() };
                set(&mut t);
                let e = error(MethodArgs::default(), &MethodDefaults::from_bake_table(t).unwrap());
                assert_eq!(e, format!("[bake] {key} is an option of the polygrid method, not of {method} (the file's method)"));
            }
        }
        let tets = BakeTable { method: Some(POLYGRID.into()), tets: Some(1000), ..BakeTable::default() };
        let e = error(MethodArgs::default(), &MethodDefaults::from_bake_table(tets).unwrap());
        assert!(e.contains("[bake] tets is an option of the transcut and radiosity methods, not of polygrid"), "{e}");
        let bad = BakeTable { polygrid_stencil: Some("lsq".into()), ..table(POLYGRID) };
        let e = MethodDefaults::from_bake_table(bad).unwrap_err().to_string();
        assert!(e.contains("[bake] polygrid_stencil") && e.contains("'lsq'") && e.contains("fem, finite-volume"), "{e}");
        let e = format!(
            "{:#}",
            polygrid(
                MethodArgs::default(),
                &MethodDefaults::from_bake_table(BakeTable { polygrid_resolution: Some(0), ..table(POLYGRID) }).unwrap()
            )
            .unwrap_err()
        );
        assert!(e.contains("polygrid: resolution = 0"), "{e}");
    }

    /// Sets keys of a `[bake]` table.
    type SetKey = fn(&mut BakeTable);

    /// A dipole scene file's `[bake]` table with `set` applied.
    fn dipole_file(set: impl FnOnce(&mut BakeTable)) -> anyhow::Result<MethodDefaults> {
        let mut table = BakeTable { method: Some(DIPOLE.into()), ..BakeTable::default() };
        set(&mut table);
        MethodDefaults::from_bake_table(table)
    }

    fn file_dipole(args: MethodArgs, file: &MethodDefaults) -> anyhow::Result<DipoleOptions> {
        match args.method(file)? {
            Method::HierarchicalDipole(o) => Ok(o),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_scene_file_sets_every_dipole_option_of_the_command_line() {
        let file = dipole_file(|t| {
            t.oracle = Some("paper".into());
            t.eps1 = Some(0.02);
            t.eps2 = Some(0.08);
            t.rule = Some("paper".into());
            t.receivers = Some("faces".into());
            t.mode = Some("incremental".into());
            t.budget = Some(5000);
        })
        .unwrap();
        let o = file_dipole(MethodArgs::default(), &file).unwrap();
        assert_eq!(o.oracle, Oracle::Paper { eps1: 0.02, eps2: 0.08 });
        assert_eq!(o.rule, EdgeRule::PAPER);
        assert_eq!(o.receivers, Receivers::FaceCentroids);
        assert_eq!(o.mode, EvalMode::Incremental { budget: Some(5000) });
        // The same as the command line's flags, names in any case.
        let flags = dipole(MethodArgs {
            oracle: Some(OracleName::Paper),
            eps1: Some(0.02),
            eps2: Some(0.08),
            rule: Some(RuleName::Paper),
            receivers: Some(ReceiverName::Faces),
            mode: Some(ModeName::Incremental),
            budget: Some(5000),
            ..MethodArgs::default()
        })
        .unwrap();
        assert_eq!(o, flags);
        let upper = dipole_file(|t| {
            t.oracle = Some("Opening-Angle".into());
            t.rule = Some("GL3".into());
            t.receivers = Some("Vertices".into());
        })
        .unwrap();
        assert_eq!(file_dipole(MethodArgs::default(), &upper).unwrap(), DipoleOptions::default());
        // One threshold given: the other is the default.
        let one = dipole_file(|t| {
            t.oracle = Some("paper".into());
            t.eps2 = Some(0.01);
        })
        .unwrap();
        assert_eq!(file_dipole(MethodArgs::default(), &one).unwrap().oracle, Oracle::Paper { eps1: PAPER_EPS, eps2: 0.01 });
    }

    #[test]
    fn the_command_line_overrides_each_dipole_key_of_the_file() {
        let paper = dipole_file(|t| {
            t.oracle = Some("paper".into());
            t.eps1 = Some(0.02);
            t.eps2 = Some(0.08);
            t.rule = Some("paper".into());
            t.receivers = Some("faces".into());
            t.mode = Some("incremental".into());
            t.budget = Some(5000);
        })
        .unwrap();
        // Flag by flag.
        let o = file_dipole(
            MethodArgs {
                eps1: Some(0.03),
                rule: Some(RuleName::Gl3),
                receivers: Some(ReceiverName::Vertices),
                budget: Some(7),
                ..MethodArgs::default()
            },
            &paper,
        )
        .unwrap();
        assert_eq!(o.oracle, Oracle::Paper { eps1: 0.03, eps2: 0.08 });
        assert_eq!((o.rule, o.receivers), (EdgeRule::default(), Receivers::Vertices));
        assert_eq!(o.mode, EvalMode::Incremental { budget: Some(7) });
        // --theta (or --oracle opening-angle) replaces the file's paper oracle and its thresholds.
        let o = file_dipole(MethodArgs { theta: Some(0.3), ..MethodArgs::default() }, &paper).unwrap();
        assert_eq!(o.oracle, Oracle::OpeningAngle { theta: 0.3 });
        let o = file_dipole(MethodArgs { oracle: Some(OracleName::OpeningAngle), ..MethodArgs::default() }, &paper).unwrap();
        assert_eq!(o.oracle, Oracle::OpeningAngle { theta: DEFAULT_THETA });
        // --mode render replaces the file's incremental mode and its budget.
        let o = file_dipole(MethodArgs { mode: Some(ModeName::Render), ..MethodArgs::default() }, &paper).unwrap();
        assert_eq!(o.mode, EvalMode::Render);
        // A file's theta under --oracle opening-angle; its thresholds under --oracle paper; its
        // budget under --mode incremental.
        let theta = dipole_file(|t| t.theta = Some(0.25)).unwrap();
        let o = file_dipole(MethodArgs { oracle: Some(OracleName::OpeningAngle), ..MethodArgs::default() }, &theta).unwrap();
        assert_eq!(o.oracle, Oracle::OpeningAngle { theta: 0.25 });
        let eps = dipole_file(|t| t.eps1 = Some(0.04)).unwrap();
        let o = file_dipole(MethodArgs { oracle: Some(OracleName::Paper), ..MethodArgs::default() }, &eps).unwrap();
        assert_eq!(o.oracle, Oracle::Paper { eps1: 0.04, eps2: PAPER_EPS });
        let budget = dipole_file(|t| t.budget = Some(9)).unwrap();
        let o = file_dipole(MethodArgs { mode: Some(ModeName::Incremental), ..MethodArgs::default() }, &budget).unwrap();
        assert_eq!(o.mode, EvalMode::Incremental { budget: Some(9) });
        // --eps1 with the file's paper oracle: the paper oracle.
        let oracle = dipole_file(|t| t.oracle = Some("paper".into())).unwrap();
        let o = file_dipole(MethodArgs { eps1: Some(0.2), ..MethodArgs::default() }, &oracle).unwrap();
        assert_eq!(o.oracle, Oracle::Paper { eps1: 0.2, eps2: PAPER_EPS });
    }

    #[test]
    fn a_scene_files_dipole_keys_are_checked_as_the_flags_are() {
        // Unknown names list the valid ones.
        let names: [(SetKey, &[&str]); 5] = [
            (|t| t.oracle = Some("solid".into()), &["[bake] oracle", "'solid'", "opening-angle, paper"]),
            (|t| t.rule = Some("simpson".into()), &["[bake] rule", "'simpson'", "gl3, paper"]),
            (|t| t.receivers = Some("edges".into()), &["[bake] receivers", "'edges'", "vertices, faces"]),
            (|t| t.mode = Some("sometimes".into()), &["[bake] mode", "'sometimes'", "on-the-fly, render, incremental"]),
            (|t| t.budget = Some(0), &["[bake] budget = 0", "at least 1"]),
        ];
        for (set, words) in names {
            let e = dipole_file(set).unwrap_err().to_string();
            assert!(words.iter().all(|w| e.contains(w)), "{e}");
        }
        // Keys that contradict the oracle or the mode in effect.
        let cases: [(SetKey, MethodArgs, &[&str]); 6] = [
            (
                |t| {
                    t.oracle = Some("paper".into());
                    t.theta = Some(0.3);
                },
                MethodArgs::default(),
                &["[bake] theta", "oracle = \"paper\" takes eps1 and eps2"],
            ),
            (|t| t.eps1 = Some(0.1), MethodArgs::default(), &["[bake] eps1", "oracle = \"paper\""]),
            (
                |t| {
                    t.oracle = Some("opening-angle".into());
                    t.eps2 = Some(0.1);
                },
                MethodArgs::default(),
                &["[bake] eps2", "paper oracle"],
            ),
            (|t| t.budget = Some(10), MethodArgs::default(), &["[bake] budget", "mode = \"incremental\"", "on-the-fly"]),
            (
                |t| {
                    t.mode = Some("render".into());
                    t.budget = Some(10);
                },
                MethodArgs::default(),
                &["[bake] budget", "(the mode is render)"],
            ),
            // The flags' own checks over a file.
            (|t| t.theta = Some(0.3), MethodArgs { eps1: Some(0.1), ..MethodArgs::default() }, &["--eps1", "--oracle paper"]),
        ];
        for (set, args, words) in cases {
            let file = dipole_file(set).unwrap();
            let e = format!("{:#}", args.method(&file).unwrap_err());
            assert!(words.iter().all(|w| e.contains(w)), "{file:?}: {e}");
        }
        // Out of range through the core's check, as the flags.
        let e = format!(
            "{:#}",
            MethodArgs::default()
                .method(
                    &dipole_file(|t| {
                        t.oracle = Some("paper".into());
                        t.eps1 = Some(-1.0);
                    })
                    .unwrap()
                )
                .unwrap_err()
        );
        assert!(e.contains("eps1") && e.contains("> 0"), "{e}");
    }

    #[test]
    fn a_file_of_another_method_that_sets_a_dipole_key_is_refused_by_name() {
        let keys: [(&str, SetKey); 8] = [
            ("theta", |t| t.theta = Some(0.3)),
            ("oracle", |t| t.oracle = Some("paper".into())),
            ("eps1", |t| t.eps1 = Some(0.1)),
            ("eps2", |t| t.eps2 = Some(0.1)),
            ("rule", |t| t.rule = Some("paper".into())),
            ("receivers", |t| t.receivers = Some("faces".into())),
            ("mode", |t| t.mode = Some("render".into())),
            ("budget", |t| t.budget = Some(10)),
        ];
        for (key, set) in keys {
            for method in [None, Some(TRANSCUT)] {
                let mut table = BakeTable { method: method.map(Into::into), ..BakeTable::default() };
                set(&mut table);
                let file = MethodDefaults::from_bake_table(table).unwrap();
                let e = error(MethodArgs::default(), &file);
                assert!(
                    e.contains(&format!("[bake] {key} is an option of the hierarchical-dipole method, not of transcut")),
                    "{key}: {e}"
                );
            }
        }
    }

    #[test]
    fn contradicting_or_out_of_range_dipole_options_are_refused() {
        let cases: [(MethodArgs, &[&str]); 6] = [
            (MethodArgs { oracle: Some(OracleName::Paper), theta: Some(0.4), ..MethodArgs::default() }, &["--theta", "--eps1"]),
            (MethodArgs { eps1: Some(0.1), ..MethodArgs::default() }, &["--eps1", "--oracle paper"]),
            (MethodArgs { budget: Some(10), ..MethodArgs::default() }, &["--budget", "--mode incremental", "on-the-fly"]),
            (MethodArgs { budget: Some(10), mode: Some(ModeName::Render), ..MethodArgs::default() }, &["render"]),
            (MethodArgs { theta: Some(1.5), ..MethodArgs::default() }, &["hierarchical-dipole", "theta", "(0, 1]"]),
            (MethodArgs { oracle: Some(OracleName::Paper), eps1: Some(-1.0), ..MethodArgs::default() }, &["eps1", "> 0"]),
        ];
        for (args, words) in cases {
            let e = format!("{:#}", dipole(args.clone()).unwrap_err());
            assert!(words.iter().all(|w| e.contains(w)), "{args:?}: {e}");
        }
    }
}
