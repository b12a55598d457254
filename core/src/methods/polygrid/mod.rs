//! Polygrid diffusion (Wang et al. 2008 §5) behind the method contract: each object's surface
//! voxelised into a polycube, the polycube cut into a grid of regular connectivity and moved
//! onto the surface ([`crate::polygrid`]), the diffusion equation of docs/ARCHITECTURE.md
//! solved on its nodes, Lo(x, n) read at the boundary nodes and interpolated at the user's
//! vertices.
//!
//! - `prepare`: the polycube at a cube size from [`PolygridOptions::cube_mm`] or the node
//!   budget; where the voxel polycube changes the surface's topology or the map folds a cell,
//!   the cube is made smaller at the same node spacing (the resolution halved each time, so the
//!   hierarchy's levels stay, down to one cell per cube), so a bake never returns a picture
//!   from a folded grid. Then the stencil: [`Stencil::Fem`] puts the medium
//!   on the cells' Kuhn split and assembles TransCut's system on it (the state and every
//!   capability are then TransCut's, on the polygrid's nodes); [`Stencil::FiniteVolume`] takes
//!   each cell's medium (the volume-weighted mean of σa and σ′s of its tets, never of κ) and
//!   assembles [`PolygridSystem::finite_volume`]; [`Stencil::PaperLsq`] takes the same cell
//!   media and assembles [`PolygridSystem::paper_lsq`];
//! - `solve`: q at the boundary nodes, the solve (FEM: TransCut's solvers and backends; finite
//!   volumes: SSOR-preconditioned CG on the CPU or Jacobi PCG on the GPU, by the backend; the
//!   paper's stencil: Jacobi-BiCGSTAB on the CPU), eq. 3 at the boundary nodes, clamped at 0,
//!   interpolated at the user's vertices through the boundary's surface map.

use std::sync::Arc;
use std::time::Instant;

use super::transcut::{Prepared, TransCutState};
use super::{BakedState, Lighting, ObjectStats, Stage, SubsurfaceMethod, Target};
use crate::diffusion::resolution;
use crate::diffusion::{DiffusionError, Solution};
use crate::gpu::{self, Backend, GpuError};
use crate::mesh::{TetMesh, TriangleBvh};
use crate::mesher::map_user_vertices;
use crate::optics::Medium;
use crate::polygrid::{
    map_to_surface, CellQuality, LsqDiagnostics, MapOptions, Polycube, Polygrid, PolygridError, PolygridSystem,
};
use crate::progress::{ms, solve_fraction};
use crate::scene::{PolygridOptions, SceneError, Shape, Stencil};
use crate::sparse::{bicgstab, pcg, Preconditioner, PreconditionerKind, SolveOptions, SparseError};

/// The polygrid method ([`SubsurfaceMethod`]).
pub struct PolygridMethod;

/// The polygrid method between `prepare` and the end of the bake.
pub(crate) enum PolygridPrepared {
    /// P1 on the Kuhn split: TransCut's system on the polygrid's nodes.
    Fem(Box<Prepared>),
    /// The finite-volume or the paper's system on the nodes.
    Nodes(Box<NodeSystem>),
}

/// A polygrid object solved on its nodes (finite volumes or the paper's stencil): the grid's
/// Kuhn split (for the surface map and the kept state), its media, the system and the last
/// fluence.
pub(crate) struct NodeSystem {
    tet_mesh: TetMesh,
    media: Vec<Medium>,
    system: PolygridSystem,
    precond: Option<Preconditioner>,
    fluence: Vec<[f64; 3]>,
    mm_per_unit: f64,
}

impl SubsurfaceMethod for PolygridMethod {
    type Options = PolygridOptions;
    type State = PolygridPrepared;

    /// The polygrid bakes translucent surfaces (a polycube is cut from a surface, so a ready
    /// tet mesh is refused; diffuse objects as every per-object method).
    fn check(target: &Target<'_>, options: &PolygridOptions) -> Result<(), SceneError> {
        target.medium("polygrid")?;
        if let Shape::Tetrahedra(_) = target.object.shape {
            return Err(SceneError::Unsupported {
                index: target.index,
                name: target.object.name.clone(),
                method: "polygrid",
                reason: "a polygrid is cut from a surface and this object is a ready tet mesh; bake it with transcut".into(),
            });
        }
        crate::scene::Method::Polygrid(options.clone()).validate().map_err(SceneError::InvalidOptions)
    }

    fn prepare(
        target: &Target<'_>,
        options: &PolygridOptions,
        stats: &mut ObjectStats,
        stage: Stage<'_>,
    ) -> Result<PolygridPrepared, SceneError> {
        let (index, object) = (target.index, target.object);
        let name = || object.name.clone();
        let polygrid_error = |source| SceneError::Polygrid { index, name: name(), source };
        let t = Instant::now();
        stage("polycube", 0.0)?;
        let (grid, quality) = build_grid(target, options).map_err(polygrid_error)?;
        stage("polygrid", 0.4)?;
        let mut tet_mesh = TetMesh::new(grid.positions().to_vec(), grid.kuhn_tets(), Vec::new())
            .map_err(|e| target.invalid(format!("the polygrid's Kuhn split is invalid: {e}")))?;
        let bvh = TriangleBvh::from_indexed(target.world.positions(), target.world.triangles());
        let (map, _) = map_user_vertices(target.world, &tet_mesh, &bvh);
        tet_mesh.set_surface_map(map);
        stats.meshing_ms = ms(t);
        stats.polygrid = Some(PolygridStats {
            cubes: grid.polycube().cells().len(),
            cube_mm: grid.polycube().cube() * object.mm_per_unit,
            resolution: grid.resolution(),
            nodes: grid.node_count(),
            cells: grid.cells().len(),
            quality,
            lsq: None,
        });
        stage("assembly", 0.6)?;
        match options.stencil {
            Stencil::Fem => Ok(PolygridPrepared::Fem(Box::new(Prepared::from_tets(
                target,
                tet_mesh,
                None,
                options.solve.discretization,
                stats,
            )?))),
            Stencil::FiniteVolume | Stencil::PaperLsq => {
                let t = Instant::now();
                let media = target
                    .medium("polygrid")?
                    .apply(&mut tet_mesh, &object.transform.inverse(), object.mm_per_unit)
                    .map_err(|source| SceneError::Medium { index, name: name(), source })?;
                let (measured, verdict) =
                    resolution::surface_resolution(&tet_mesh, &media, object.mm_per_unit, resolution::MAX_RESOLUTION);
                stats.resolution = measured;
                verdict.map_err(|u| SceneError::unresolved(index, name(), u))?;
                let cell_media = cell_media(&tet_mesh, &media);
                let system = if options.stencil == Stencil::PaperLsq {
                    PolygridSystem::paper_lsq(&grid, &cell_media, object.mm_per_unit, None)
                } else {
                    PolygridSystem::finite_volume(&grid, &cell_media, object.mm_per_unit, None)
                }
                .map_err(polygrid_error)?;
                if let Some(p) = stats.polygrid.as_mut() {
                    p.lsq = system.lsq_diagnostics().copied();
                }
                stats.assembly_ms = ms(t);
                stats.tets = tet_mesh.tet_count();
                stats.vertices = grid.node_count();
                stats.boundary_vertices = system.boundary().ids.len();
                let fluence = vec![[0.0; 3]; grid.node_count()];
                Ok(PolygridPrepared::Nodes(Box::new(NodeSystem {
                    tet_mesh,
                    media,
                    system,
                    precond: None,
                    fluence,
                    mm_per_unit: object.mm_per_unit,
                })))
            }
        }
    }

    fn solve(
        target: &Target<'_>,
        state: &mut PolygridPrepared,
        lighting: &Lighting<'_>,
        options: &PolygridOptions,
        stats: &mut ObjectStats,
        stage: Stage<'_>,
    ) -> Result<Vec<[f64; 3]>, SceneError> {
        match state {
            PolygridPrepared::Fem(p) => p.solve_lit(target, lighting, &options.solve, stats, stage),
            PolygridPrepared::Nodes(fv) => fv.solve(target, lighting, options, stats, stage),
        }
    }

    fn into_baked(state: PolygridPrepared) -> BakedState {
        match state {
            PolygridPrepared::Fem(p) => BakedState::TransCut(p.into_state()),
            PolygridPrepared::Nodes(fv) => BakedState::TransCut(fv.into_state()),
        }
    }
}

/// What the polygrid method built for an object ([`ObjectStats::polygrid`]).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PolygridStats {
    /// Cubes of the polycube.
    pub cubes: usize,
    /// The cube edge, mm.
    pub cube_mm: f64,
    /// Cells per cube edge.
    pub resolution: u32,
    /// Nodes, the pillow's surface nodes included.
    pub nodes: usize,
    /// Cells: the cubes' `resolution³` each, and the pillow's one per boundary quad.
    pub cells: usize,
    /// The cells' scaled Jacobians after the map.
    pub quality: CellQuality,
    /// The paper stencil's weights ([`Stencil::PaperLsq`]; `None` for the others).
    pub lsq: Option<LsqDiagnostics>,
}

impl NodeSystem {
    fn solve(
        &mut self,
        target: &Target<'_>,
        lighting: &Lighting<'_>,
        options: &PolygridOptions,
        stats: &mut ObjectStats,
        stage: Stage<'_>,
    ) -> Result<Vec<[f64; 3]>, SceneError> {
        let (index, name) = (target.index, || target.object.name.clone());
        let polygrid_error = |source| SceneError::Polygrid { index, name: name(), source };
        stage("light", 0.7)?;
        let t = Instant::now();
        let boundary = self.system.boundary();
        let points: Vec<_> = boundary.ids.iter().map(|&v| self.tet_mesh.positions()[v as usize]).collect();
        let eta = self.system.boundary_terms().eta;
        let q = lighting.transmitted_source_with(&points, &boundary.normal, eta, &|f| stage("light", 0.7 + 0.1 * f))?;
        stats.source_ms = ms(t);
        let t = Instant::now();
        self.system.set_source(&q).map_err(polygrid_error)?;
        stage("solve", 0.8)?;
        // The finite-volume matrix (symmetric): SSOR-PCG on the CPU or Jacobi PCG on the
        // device, where the backend says; the paper's (unsymmetric): Jacobi-BiCGSTAB on the CPU.
        let symmetric = self.system.is_symmetric();
        let backend = if symmetric {
            crate::methods::transcut::backend(&options.solve).map_err(|e| target.invalid(e.to_string()))?
        } else {
            Backend::Cpu
        };
        let tolerance = options.solve.tolerance;
        let monitor = |_: usize, residual: [f64; 3]| stage("solve", 0.8 + 0.19 * solve_fraction(residual, tolerance)).is_ok();
        let solve_options = SolveOptions::default()
            .with_tolerance(tolerance)
            .with_max_iterations(options.solve.max_iterations)
            .with_monitor(&monitor);
        let warm = self.fluence.iter().any(|p| p.iter().any(|&x| x != 0.0)).then_some(self.fluence.as_slice());
        let (system, cached) = (&self.system, &mut self.precond);
        let on_cpu = || -> Result<Solution, GpuError> {
            let sparse = |e| GpuError::Diffusion(DiffusionError::Sparse(e));
            if cached.is_none() {
                let kind = if symmetric { PreconditionerKind::Ssor } else { PreconditionerKind::Jacobi };
                *cached = Some(Preconditioner::new(system.matrix(), kind).map_err(sparse)?);
            }
            let mut phi = warm.map_or_else(|| vec![[0.0; 3]; system.rhs().len()], <[_]>::to_vec);
            let solver = if symmetric { pcg } else { bicgstab };
            let precond = cached.as_ref().expect("built above");
            let stats = solver(system.matrix(), system.rhs(), &mut phi, precond, &solve_options).map_err(sparse)?;
            Ok(Solution { phi, stats })
        };
        let not_reached = |iterations: [usize; 3], residual: [f64; 3]| {
            polygrid_error(PolygridError::Sparse(SparseError::InvalidOption(format!(
                "the {} solve did not reach the tolerance {tolerance} in {iterations:?} iterations (residual {residual:?})",
                options.stencil.name(),
            ))))
        };
        let (solution, report) = gpu::solve_matrix_on(backend, system.matrix(), system.rhs(), warm, &solve_options, on_cpu)
            .map_err(|e| match e {
                GpuError::Diffusion(DiffusionError::Sparse(SparseError::Cancelled { .. })) => {
                    SceneError::Cancelled(crate::progress::Cancelled)
                }
                GpuError::Diffusion(DiffusionError::NotConverged { iterations, residual, .. }) => {
                    not_reached(iterations, residual)
                }
                GpuError::Diffusion(DiffusionError::Sparse(e)) => polygrid_error(PolygridError::Sparse(e)),
                GpuError::Diffusion(e) => polygrid_error(PolygridError::Diffusion(e)),
                source => SceneError::Gpu { index, name: name(), source },
            })?;
        if !solution.stats.converged {
            return Err(not_reached(solution.stats.iterations, solution.stats.relative_residual));
        }
        stats.iterations = solution.stats.iterations;
        stats.relative_residual = solution.stats.relative_residual;
        stats.backend = report.used;
        stats.device = report.device;
        stats.backend_fallback = report.fallback;
        self.fluence = solution.phi;
        let lo = self.system.radiance(&self.fluence).map_err(polygrid_error)?;
        let per_vertex = self.per_vertex(&lo);
        let mut clamped = vec![[0.0]; self.tet_mesh.vertex_count()];
        for (&v, l) in self.system.boundary().ids.iter().zip(&lo) {
            if l.iter().any(|&x| x < 0.0) {
                clamped[v as usize] = [1.0];
            }
        }
        stats.clamped_vertices = self.tet_mesh.sample_at_user_vertices(&clamped).iter().filter(|c| c[0] > 0.0).count();
        stats.solve_ms = ms(t);
        Ok(self.tet_mesh.sample_at_user_vertices(&per_vertex))
    }

    /// Eq. 3's radiance per boundary node, clamped at 0, per node (0 inside).
    fn per_vertex(&self, lo: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut per_vertex = vec![[0.0; 3]; self.tet_mesh.vertex_count()];
        for (&v, l) in self.system.boundary().ids.iter().zip(lo) {
            per_vertex[v as usize] = l.map(|x| x.max(0.0));
        }
        per_vertex
    }

    /// The kept state: the grid's Kuhn split with its media, the fluence and the radiance.
    fn into_state(self) -> TransCutState {
        let lo = self.system.radiance(&self.fluence).unwrap_or_default();
        let radiance = self.per_vertex(&lo);
        TransCutState {
            eta: self.system.boundary_terms().eta,
            tet_mesh: self.tet_mesh,
            media: self.media,
            mm_per_unit: self.mm_per_unit,
            fluence: self.fluence,
            radiance,
            meshed: None,
        }
    }
}

/// Each cell's medium from its six Kuhn tets ([`Polygrid::kuhn_tets`]: tets 6c … 6c + 5): the
/// volume-weighted mean of σa and σ′s (κ follows from them; averaging κ itself would bias
/// interfaces), η and g of the first tet.
fn cell_media(tet_mesh: &TetMesh, media: &[Medium]) -> Vec<Medium> {
    let materials = tet_mesh.materials();
    (0..tet_mesh.tet_count() / 6)
        .map(|c| {
            let first = media[materials[6 * c] as usize];
            let (mut sa, mut ss, mut volume) = ([0.0; 3], [0.0; 3], 0.0);
            for t in 6 * c..6 * c + 6 {
                let (m, v) = (media[materials[t] as usize], tet_mesh.tet_volume(t));
                volume += v;
                for k in 0..3 {
                    sa[k] += v * m.sigma_a[k];
                    ss[k] += v * m.sigma_s_prime[k];
                }
            }
            Medium { sigma_a: sa.map(|x| x / volume), sigma_s_prime: ss.map(|x| x / volume), ..first }
        })
        .collect()
}

/// The node spacing (scene units) and first cube size of `options` for an object.
fn spacing_and_cube(target: &Target<'_>, options: &PolygridOptions) -> (f64, f64) {
    let res = f64::from(options.resolution);
    match options.cube_mm {
        Some(cube_mm) => {
            let cube = cube_mm / target.object.mm_per_unit;
            (cube / res, cube)
        }
        None => {
            let volume = target.world.signed_volume().abs().max(f64::MIN_POSITIVE);
            let h = (volume / options.nodes as f64).cbrt();
            (h, h * res)
        }
    }
}

/// The object's polygrid: voxelised, cut and mapped, with smaller cubes at the same spacing
/// where a cube size fails (see the module documentation).
fn build_grid(target: &Target<'_>, options: &PolygridOptions) -> Result<(Polygrid, CellQuality), PolygridError> {
    let (h, mut cube) = spacing_and_cube(target, options);
    let mut resolution = options.resolution;
    let bvh = TriangleBvh::from_indexed(target.world.positions(), target.world.triangles());
    loop {
        let result = Polycube::voxelize(target.world, cube).and_then(|polycube| {
            let mut grid = Polygrid::with_pillow(Arc::new(polycube), resolution)?;
            let quality = map_to_surface(&mut grid, &bvh, &MapOptions::default())?;
            Ok((grid, quality))
        });
        match result {
            Err(
                PolygridError::TopologyChanged { .. }
                | PolygridError::Fold { .. }
                | PolygridError::SurfaceFold { .. }
                | PolygridError::Empty(_),
            ) if resolution > 1 => {
                resolution = (resolution / 2).max(1);
                cube = h * f64::from(resolution);
            }
            other => return other,
        }
    }
}
