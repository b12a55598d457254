//! Which subsurface method bakes a scene, with its typed options.
//!
//! Every method answers the same question — a [`super::Scene`] in, the radiance Lo(x, n) per
//! vertex of each object out (ARCHITECTURE.md, "What a bake returns") — so the front ends
//! (C ABI, CLI, scene files, Blender) choose one by name ([`Method::from_name`]) and share
//! everything else. The set is closed: a method is a variant here, a folder under
//! `core/src/methods/`, and one line in the conformance suite `core/tests/integration/methods.rs`.

use crate::diffusion::{Discretization, SolverKind};
use crate::gpu::Backend;
use crate::hierarchy::DipoleOptions;
use crate::mesher::Grading;
pub use crate::polygrid::Stencil;
use crate::prt::PrtOptions;
use crate::radiosity::{FormFactorOptions, SolveOptions};

use super::scattering::TranslucentScattering;

/// How TransCut grades each surface object's tets ([`TransCutOptions::grading`]).
///
/// A graded mesh (one cube of each size) buys a finer surface for the same tet count, which is
/// what an unresolved boundary layer needs (skin1's blue on the R = 10 mm sphere at 300k tets:
/// 1.22% RMS uniform, 0.84% graded). Where the layer is resolved, grading changes little
/// (marble: 0.03% either way) and costs twice: a cut or fracture exposes the interior, whose
/// tets are up to 2^k times coarser, as new surface (skin1's blue on a cut face 16.5% off a
/// fresh bake graded, 13.9% uniform), and the graded lattice's vertices lie nearer the
/// surface, where winding numbers cost more (the open bunny at 1M tets meshes in about 2.1 s
/// graded against 1.2 s uniform). Numbers: `docs/benchmarks.md`.
///
/// The default is [`GradingChoice::Auto`]: graded only where the medium needs it. Cuts,
/// fractures and splits work on graded tets as on uniform ones (a cutter thinner than the
/// interior tets, such as a slab, still separates the sides, [`crate::edit::cut`] step 1);
/// a cut face through the graded interior is coarser, which the dense media that Auto grades
/// would suffer on a uniform mesh of the same budget everywhere.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GradingChoice {
    /// Per object, from its medium and the tet budget: [`Grading::Graded`] with one cube per
    /// size where a uniform mesh of the budget would leave some channel's diffusion length
    /// `1/σtr` (the shortest anywhere in the medium, [`super::MediumSource::max_sigma_tr`])
    /// under [`GradingChoice::AUTO_RESOLUTION`]⁻¹ lattice spacings, [`Grading::Uniform`]
    /// otherwise.
    Auto,
    /// This grading for every object.
    Fixed(Grading),
}

impl GradingChoice {
    /// The σtr h at the uniform spacing above which [`GradingChoice::Auto`] grades: the
    /// boundary layer spans fewer than two lattice spacings. Below it the layer assembly's error
    /// on the sphere stays under about 0.3% in every preset at 300k tets (skin2's blue at
    /// σtr h = 0.51: 0.24%; skin1's at 0.81: 1.22%).
    pub const AUTO_RESOLUTION: f64 = 0.5;

    /// The grading of an object: for [`GradingChoice::Auto`] from `measure`, called only then,
    /// which gives the medium's largest σtr per channel (mm⁻¹) and the lattice spacing a
    /// uniform mesh of the budget would have ([`crate::mesher::uniform_spacing_estimate`] in
    /// millimetres).
    #[must_use]
    pub fn resolve(self, measure: impl FnOnce() -> ([f64; 3], f64)) -> Grading {
        match self {
            Self::Fixed(grading) => grading,
            Self::Auto => {
                let (max_sigma_tr, uniform_spacing_mm) = measure();
                let coarsest = max_sigma_tr.iter().fold(0.0f64, |m, &s| m.max(s)) * uniform_spacing_mm;
                if coarsest > Self::AUTO_RESOLUTION {
                    Grading::Graded { layers: 1 }
                } else {
                    Grading::Uniform
                }
            }
        }
    }
}

impl Default for GradingChoice {
    /// [`GradingChoice::Auto`].
    fn default() -> Self {
        Self::Auto
    }
}

impl From<Grading> for GradingChoice {
    fn from(grading: Grading) -> Self {
        Self::Fixed(grading)
    }
}

/// The subsurface method of a bake, with its options.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Method {
    /// TransCut (Li et al. 2012, §3): the diffusion equation on a tetrahedral mesh of each
    /// object, heterogeneous media, interactive relighting, material edits and cuts (§5).
    TransCut(TransCutOptions),
    /// The hierarchical dipole (Mertens et al. 2003): the dipole of a homogeneous medium
    /// integrated over the surface through cluster trees, no volume and no solve; relight and
    /// deformation (new vertex positions every frame).
    HierarchicalDipole(DipoleOptions),
    /// Translucent radiosity (Sheng et al. 2014): every object's surface in patches exchanging
    /// light through form factors with visibility, translucent objects scattering it through
    /// their TransCut diffusion solve and opaque diffuse objects reflecting and emitting it;
    /// inter-reflection and colour bleeding between all objects.
    Radiosity(RadiosityOptions),
    /// Precomputed translucent transfer (R. Wang et al. 2008): the dipole of a homogeneous
    /// medium in a PCA basis, its transfer from surface samples to the vertices precomputed and
    /// compressed once; material edits and relights without a new precompute.
    Prt(PrtOptions),
    /// Polygrid diffusion (Wang et al. 2008 §5): the diffusion equation on a grid of regular
    /// connectivity cut from a polycube of the object's shape; heterogeneous media, relight,
    /// material edits.
    Polygrid(PolygridOptions),
}

impl From<PolygridOptions> for Method {
    fn from(options: PolygridOptions) -> Self {
        Self::Polygrid(options)
    }
}

impl From<PrtOptions> for Method {
    fn from(options: PrtOptions) -> Self {
        Self::Prt(options)
    }
}

impl From<RadiosityOptions> for Method {
    fn from(options: RadiosityOptions) -> Self {
        Self::Radiosity(options)
    }
}

impl From<DipoleOptions> for Method {
    fn from(options: DipoleOptions) -> Self {
        Self::HierarchicalDipole(options)
    }
}

impl Default for Method {
    fn default() -> Self {
        Self::TransCut(TransCutOptions::default())
    }
}

impl From<TransCutOptions> for Method {
    fn from(options: TransCutOptions) -> Self {
        Self::TransCut(options)
    }
}

impl Method {
    /// The names of every method this library has, in the order front ends list them (also
    /// the order of the C ABI's `TC_METHOD_*` values).
    pub const NAMES: &'static [&'static str] = &["transcut", "hierarchical-dipole", "radiosity", "prt", "polygrid"];

    /// Every method with its default options, in the order of [`Method::NAMES`].
    #[must_use]
    pub fn all() -> Vec<Method> {
        Self::NAMES.iter().filter_map(|name| Self::from_name(name)).collect()
    }

    /// The name front ends use: `transcut`, `hierarchical-dipole`, `radiosity`, `prt`,
    /// `polygrid`.
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Self::TransCut(_) => "transcut",
            Self::HierarchicalDipole(_) => "hierarchical-dipole",
            Self::Radiosity(_) => "radiosity",
            Self::Prt(_) => "prt",
            Self::Polygrid(_) => "polygrid",
        }
    }

    /// One line saying what the method is, for `--method help` and user interfaces.
    #[must_use]
    pub fn description(&self) -> &'static str {
        match self {
            Self::TransCut(_) => {
                "TransCut (Li et al. 2012): diffusion on a tetrahedral mesh; heterogeneous media, relight, paint, cut"
            }
            Self::HierarchicalDipole(_) => {
                "hierarchical dipole (Mertens et al. 2003): the dipole integrated over the surface; homogeneous media, relight, \
                 deforming meshes"
            }
            Self::Radiosity(_) => {
                "translucent radiosity (Sheng et al. 2014): translucent and opaque diffuse objects exchanging light; \
                 inter-reflection, colour bleeding, emissive surfaces"
            }
            Self::Prt(_) => {
                "precomputed translucent transfer (R. Wang et al. 2008): the dipole in a PCA basis over precomputed surface \
                 transfer; homogeneous media, real-time material edits and relights"
            }
            Self::Polygrid(_) => {
                "polygrid diffusion (Wang et al. 2008): diffusion on a grid of regular connectivity cut from a polycube of the \
                 object; heterogeneous media, relight, material edits"
            }
        }
    }

    /// The method called `name` (any case, surrounding spaces ignored) with its default
    /// options, or `None`.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Method> {
        match name.trim().to_ascii_lowercase().as_str() {
            "transcut" => Some(Self::TransCut(TransCutOptions::default())),
            "hierarchical-dipole" => Some(Self::HierarchicalDipole(DipoleOptions::default())),
            "radiosity" => Some(Self::Radiosity(RadiosityOptions::default())),
            "prt" => Some(Self::Prt(PrtOptions::default())),
            "polygrid" => Some(Self::Polygrid(PolygridOptions::default())),
            _ => None,
        }
    }

    /// What front ends say for a name that is no method: the name and every valid one.
    #[must_use]
    pub fn unknown(name: &str) -> String {
        format!("unknown method '{}' (the methods are: {})", name.trim(), Self::NAMES.join(", "))
    }

    /// Checks the method's options.
    ///
    /// # Errors
    /// A message naming the method and the option out of range.
    pub fn validate(&self) -> Result<(), String> {
        match self {
            Self::TransCut(o) => o.validate(),
            Self::HierarchicalDipole(o) => o.validate(),
            Self::Radiosity(o) => o.validate(),
            Self::Prt(o) => o.validate(),
            Self::Polygrid(o) => o.validate(),
        }
        .map_err(|e| format!("{}: {e}", self.name()))
    }
}

/// How TransCut bakes: the tet mesh it solves on, the solve, and where it runs.
#[derive(Debug, Clone, PartialEq)]
pub struct TransCutOptions {
    /// Target tetrahedra per surface object (objects given as a tet mesh are solved as given),
    /// in [1, [`TransCutOptions::MAX_TETS`]].
    pub tets: usize,
    /// How the tet sizes vary inside each object. Default [`GradingChoice::Auto`]: graded where
    /// the medium's boundary layer needs it, uniform elsewhere.
    pub grading: GradingChoice,
    /// The assembly: [`Discretization::FittedLayer`] (default: TransCut's rows with the
    /// stiffness fitted to the boundary layer and the boundary rows' absorption taken from it,
    /// the most accurate at practical sizes), [`Discretization::ExponentiallyFitted`] (the
    /// stiffness fitting alone: less accurate up to a few million tets, but second order in h),
    /// [`Discretization::TransCut`] (the paper's, eqs. 10–14) or
    /// [`Discretization::ConsistentFem`] (the P1 reference).
    pub discretization: Discretization,
    /// Relative residual ‖b − Mφ‖/‖b‖ at which every solve stops, in (0, 1).
    pub tolerance: f64,
    /// Iteration cap of every solve, in [1, [`TransCutOptions::MAX_ITERATIONS`]].
    pub max_iterations: usize,
    /// The bake's solver on the CPU (default [`SolverKind::SsorPcg`], the fastest single
    /// solve). On the device the single-level kinds run Jacobi PCG ([`crate::gpu::solve_on`]).
    pub solver: SolverKind,
    /// The solver of interactive updates after the bake (relight, material edits, cuts;
    /// default [`SolverKind::AggregationPcg`], whose hierarchy pays off over many solves).
    pub edit_solver: SolverKind,
    /// Where the solve runs; `None`: as `TRANSCUT_BACKEND` says (cpu, gpu, auto), else
    /// [`Backend::Auto`] (the GPU when a hardware adapter exists, else the CPU; the statistics
    /// say which ran and why).
    pub backend: Option<Backend>,
}

impl Default for TransCutOptions {
    fn default() -> Self {
        Self {
            tets: 200_000,
            grading: GradingChoice::default(),
            discretization: Discretization::FittedLayer,
            tolerance: 1e-6,
            max_iterations: 10_000,
            solver: SolverKind::SsorPcg,
            edit_solver: SolverKind::AggregationPcg,
            backend: None,
        }
    }
}

impl TransCutOptions {
    /// The largest `tets`: twenty million tetrahedra take about 10 GB to mesh, assemble and
    /// solve, beyond what an interactive bake is for.
    pub const MAX_TETS: usize = 20_000_000;
    /// The largest `max_iterations`: a solve that has not converged in a million iterations
    /// never will (every solver here converges in thousands on the test meshes).
    pub const MAX_ITERATIONS: usize = 1_000_000;
    /// The most cubes of one size a graded mesh keeps before the next doubling: beyond a few
    /// dozen, a graded mesh is a uniform one for any object the tet budget allows.
    pub const MAX_GRADING_LAYERS: u32 = 64;

    /// Checks the options.
    ///
    /// # Errors
    /// A message naming the option out of range, its value and the bound.
    pub fn validate(&self) -> Result<(), String> {
        if self.tets == 0 {
            return Err("tets must be at least 1".into());
        }
        if let GradingChoice::Fixed(Grading::Graded { layers }) = self.grading {
            if !(1..=Self::MAX_GRADING_LAYERS).contains(&layers) {
                return Err(format!("grading layers = {layers} is outside [1, {}]", Self::MAX_GRADING_LAYERS));
            }
        }
        if self.tets > Self::MAX_TETS {
            return Err(format!("tets = {} is above the maximum of {}", self.tets, Self::MAX_TETS));
        }
        if !(self.tolerance > 0.0 && self.tolerance < 1.0) {
            return Err(format!("tolerance must lie in (0, 1), got {}", self.tolerance));
        }
        if self.max_iterations == 0 {
            return Err("max_iterations must be at least 1".into());
        }
        if self.max_iterations > Self::MAX_ITERATIONS {
            return Err(format!("max_iterations = {} is above the maximum of {}", self.max_iterations, Self::MAX_ITERATIONS));
        }
        Ok(())
    }
}

/// How the polygrid method bakes: the polycube, the grid cut from it, the stencil and the solve.
#[derive(Debug, Clone, PartialEq)]
pub struct PolygridOptions {
    /// Target nodes per object, which sets the cube size with `resolution` when `cube_mm` is
    /// `None`, in [8, [`PolygridOptions::MAX_NODES`]].
    pub nodes: usize,
    /// The polycube's cube edge in mm; `None`: from `nodes` (the object's volume over the
    /// node budget). A cube at which the voxel polycube changes the surface's topology or the
    /// map folds is made smaller, at the same node spacing, down to one cell per cube.
    pub cube_mm: Option<f64>,
    /// Cells per cube edge, in [1, [`crate::polygrid::MAX_RESOLUTION`]] (the paper: 12–32).
    pub resolution: u32,
    /// The discretisation on the grid (default [`Stencil::Fem`], the most accurate at equal
    /// cost: P1 on the Kuhn split converges at second order on skewed cells, where the
    /// two-point finite-volume flux does not).
    pub stencil: Stencil,
    /// The solves (tolerance, iterations, CPU solver, edit solver, backend), as TransCut's;
    /// its `tets` is not used (a session meshes cut pieces at `nodes` tets).
    pub solve: TransCutOptions,
}

impl Default for PolygridOptions {
    fn default() -> Self {
        Self { nodes: 200_000, cube_mm: None, resolution: 8, stencil: Stencil::Fem, solve: TransCutOptions::default() }
    }
}

impl PolygridOptions {
    /// The largest `nodes`: as TransCut's tet budget, about 3.4 million nodes.
    pub const MAX_NODES: usize = 4_000_000;

    /// Checks the options.
    ///
    /// # Errors
    /// A message naming the option out of range, its value and the bound.
    pub fn validate(&self) -> Result<(), String> {
        if !(8..=Self::MAX_NODES).contains(&self.nodes) {
            return Err(format!("nodes = {} must lie in [8, {}]", self.nodes, Self::MAX_NODES));
        }
        if let Some(c) = self.cube_mm {
            if !(c.is_finite() && c > 0.0) {
                return Err(format!("cube_mm = {c} must be finite and > 0"));
            }
        }
        if !(1..=crate::polygrid::MAX_RESOLUTION).contains(&self.resolution) {
            return Err(format!(
                "resolution = {} must lie in [1, {}] cells per cube edge",
                self.resolution,
                crate::polygrid::MAX_RESOLUTION
            ));
        }
        TransCutOptions { tets: 1, ..self.solve.clone() }.validate()
    }
}

/// How translucent radiosity bakes: the patches, the form factors, the iteration, and the
/// TransCut bake of each translucent object, whose diffusion solve is its scattering.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RadiosityOptions {
    /// The longest patch edge on opaque objects in mm (their meshes are refined to it, keeping
    /// their vertices); `None`: the scene's bounding-box diagonal / 80 (design/radiosity.md
    /// §1.3: about 4.3 mm in a 200 mm box). Translucent objects' patches are the boundary
    /// vertices of their tets.
    pub patch_size_mm: Option<f64>,
    /// How the form factors are cast.
    pub form_factors: FormFactorOptions,
    /// How the radiosity is solved (tolerance on the power, iteration, bounces).
    pub solve: SolveOptions,
    /// The tets and diffusion solves of the translucent objects (with the diffusion S).
    pub transcut: TransCutOptions,
    /// The scattering operator S of the translucent objects: their diffusion solve (default)
    /// or a profile matrix on their surface.
    pub scattering: TranslucentScattering,
    /// Where the iteration's gather E = F B runs (Jacobi sweeps, a warm start, BiCGSTAB; the
    /// Gauss–Seidel sweeps always run on the CPU); `None`: as `TRANSCUT_BACKEND` says, else
    /// [`Backend::Auto`] (a hardware GPU when one exists, never a software adapter; F that does
    /// not fit the device stays on the CPU). The statistics name the device and say why not.
    /// The translucent objects' diffusion solves follow [`TransCutOptions::backend`].
    pub backend: Option<Backend>,
}

impl RadiosityOptions {
    /// Checks the options.
    ///
    /// # Errors
    /// A message naming the option out of range.
    pub fn validate(&self) -> Result<(), String> {
        if let Some(h) = self.patch_size_mm {
            if !(h.is_finite() && h > 0.0) {
                return Err(format!("patch_size_mm must be finite and > 0, got {h}"));
            }
        }
        self.form_factors.validate()?;
        self.solve.validate()?;
        self.scattering.validate()?;
        self.transcut.validate().map_err(|e| format!("transcut: {e}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Auto grades exactly when the largest σtr h over the channels exceeds ½; a fixed grading
    /// is kept whatever the medium; the default is uniform.
    #[test]
    fn the_automatic_grading_follows_the_largest_sigma_tr_h() {
        let graded = Grading::Graded { layers: 1 };
        let auto = |s: [f64; 3], h: f64| GradingChoice::Auto.resolve(|| (s, h));
        assert_eq!(auto([0.1, 0.2, 0.49], 1.0), Grading::Uniform);
        assert_eq!(auto([0.1, 0.51, 0.2], 1.0), graded);
        assert_eq!(auto([1.2, 0.0, 0.0], 0.4), Grading::Uniform); // 0.48
        assert_eq!(auto([1.2, 0.0, 0.0], 0.45), graded); // 0.54
        assert_eq!(auto([0.0; 3], 1e3), Grading::Uniform);
        let fixed = GradingChoice::from(Grading::Graded { layers: 3 });
        let unmeasured = || -> ([f64; 3], f64) { panic!("a fixed grading measures nothing") };
        assert_eq!(fixed.resolve(unmeasured), Grading::Graded { layers: 3 });
        assert_eq!(GradingChoice::from(Grading::Uniform).resolve(unmeasured), Grading::Uniform);
        assert_eq!(TransCutOptions::default().grading, GradingChoice::Auto);
    }

    #[test]
    fn every_name_round_trips_and_unknown_names_list_the_valid_ones() {
        for (method, name) in Method::all().iter().zip(Method::NAMES) {
            assert_eq!(method.name(), *name);
            assert_eq!(Method::from_name(&name.to_uppercase()).as_ref(), Some(method));
            assert!(!method.description().is_empty());
        }
        assert_eq!(Method::all().len(), Method::NAMES.len());
        assert_eq!(Method::from_name(" TransCut "), Some(Method::default()));
        assert_eq!(Method::from_name("nonsense"), None);
        let message = Method::unknown("nonsense");
        assert!(message.contains("'nonsense'") && message.contains("transcut"), "{message}");
    }

    #[test]
    fn tets_and_iterations_are_bounded() {
        let at = |tets, max_iterations| TransCutOptions { tets, max_iterations, ..TransCutOptions::default() }.validate();
        assert_eq!(at(20_000_000, 1_000_000), Ok(()));
        assert_eq!(at(20_000_001, 10), Err("tets = 20000001 is above the maximum of 20000000".into()));
        assert_eq!(at(1000, 1_000_001), Err("max_iterations = 1000001 is above the maximum of 1000000".into()));
        assert_eq!(at(0, 10), Err("tets must be at least 1".into()));
    }

    #[test]
    fn options_out_of_range_are_named_with_the_method() {
        let bad = |o: TransCutOptions| Method::TransCut(o).validate().unwrap_err();
        let d = TransCutOptions::default;
        assert!(bad(TransCutOptions { tets: 0, ..d() }).starts_with("transcut: tets"));
        assert!(bad(TransCutOptions { tolerance: 1.0, ..d() }).contains("tolerance"));
        assert!(bad(TransCutOptions { tolerance: f64::NAN, ..d() }).contains("tolerance"));
        assert!(bad(TransCutOptions { max_iterations: 0, ..d() }).contains("max_iterations"));
        assert_eq!(Method::default().validate(), Ok(()));
    }

    #[test]
    fn radiosity_options_out_of_range_are_named() {
        let bad = |o: RadiosityOptions| Method::Radiosity(o).validate().unwrap_err();
        let d = RadiosityOptions::default;
        assert!(bad(RadiosityOptions { patch_size_mm: Some(0.0), ..d() }).starts_with("radiosity: patch_size_mm"));
        assert!(bad(RadiosityOptions { patch_size_mm: Some(f64::NAN), ..d() }).contains("patch_size_mm"));
        let solve = SolveOptions { tolerance: 0.0, ..SolveOptions::default() };
        assert!(bad(RadiosityOptions { solve, ..d() }).contains("tolerance"));
        let solve = SolveOptions { bounces: Some(0), ..SolveOptions::default() };
        assert!(bad(RadiosityOptions { solve, ..d() }).contains("bounces"));
        let transcut = TransCutOptions { tets: 0, ..TransCutOptions::default() };
        assert!(bad(RadiosityOptions { transcut, ..d() }).contains("radiosity: transcut: tets"));
        let profile = |tail, distance| {
            TranslucentScattering::Profile(super::super::ProfileScatteringOptions { tail, distance, ..Default::default() })
        };
        let scattering = profile(0.0, super::super::OpticalDistance::Chord);
        assert!(bad(RadiosityOptions { scattering, ..d() }).starts_with("radiosity: scattering.tail"));
        let voxels = super::super::OpticalDistance::Interior { voxel_mm: Some(-1.0), any_angle: true };
        assert!(bad(RadiosityOptions { scattering: profile(1e-3, voxels), ..d() }).contains("scattering.voxel_mm"));
        for name in TranslucentScattering::NAMES {
            assert_eq!(TranslucentScattering::from_name(name).unwrap().name(), *name);
        }
        assert_eq!(TranslucentScattering::from_name("nonsense"), None);
        assert_eq!(Method::Radiosity(d()).validate(), Ok(()));
    }
}
