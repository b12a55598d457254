//! What a bake returns per object, whatever the method.

use crate::gpu::Backend;
use crate::mesher::MesherStats;

use super::hierarchical_dipole::DipoleState;
use super::polygrid::PolygridStats;
use super::prt::PrtState;
use super::radiosity::RadiosityObject;
use super::transcut::TransCutState;

/// Per-vertex `values` at points given as three vertices (in range) and barycentric weights.
#[must_use]
pub fn interpolate_vertices(values: &[[f64; 3]], points: &[([u32; 3], [f64; 3])]) -> Vec<[f64; 3]> {
    points.iter().map(|(v, w)| std::array::from_fn(|c| (0..3).map(|k| w[k] * values[v[k] as usize][c]).sum())).collect()
}

/// One object's bake: the radiance, what was measured, and what the method prepared.
#[derive(Debug, Clone)]
pub struct ObjectBake {
    /// Lo(x, n), linear RGB, one per vertex of the object's input mesh, in the user's order
    /// (for a ready tet mesh: one per tet-mesh vertex, 0 inside): finite and ≥ 0.
    pub radiance: Vec<[f64; 3]>,
    pub stats: ObjectStats,
    /// What the method prepared and solved: later solves and edits start from it.
    pub state: BakedState,
}

impl ObjectBake {
    /// The bake's radiance at points of the user's surface, each three user vertices (in
    /// range: callers check) and barycentric weights: TransCut samples its tet mesh's boundary
    /// solution there ([`crate::mesh::TetMesh::sample_at_user_points`]); the other methods,
    /// whose radiance lives at the vertices, interpolate it ([`interpolate_vertices`]).
    #[must_use]
    pub fn radiance_on_surface(&self, points: &[([u32; 3], [f64; 3])]) -> Vec<[f64; 3]> {
        match &self.state {
            BakedState::TransCut(s) if !s.tet_mesh.surface_map().is_empty() => {
                s.tet_mesh.sample_at_user_points(points, &s.radiance)
            }
            _ => interpolate_vertices(&self.radiance, points),
        }
    }

    /// The refractive index at the object's surface, for renderers' Fresnel and specular terms.
    #[must_use]
    pub fn eta(&self) -> f64 {
        match &self.state {
            BakedState::TransCut(s) => s.eta,
            BakedState::HierarchicalDipole(s) => s.eta(),
            BakedState::Prt(s) => s.eta(),
            BakedState::Radiosity(s) => s.eta,
        }
    }

    /// TransCut's state, when TransCut baked the object.
    #[must_use]
    pub fn transcut(&self) -> Option<&TransCutState> {
        match &self.state {
            BakedState::TransCut(s) => Some(s),
            BakedState::HierarchicalDipole(_) | BakedState::Radiosity(_) | BakedState::Prt(_) => None,
        }
    }

    /// The hierarchical dipole's state, when that method baked the object.
    #[must_use]
    pub fn dipole(&self) -> Option<&DipoleState> {
        match &self.state {
            BakedState::HierarchicalDipole(s) => Some(s),
            BakedState::TransCut(_) | BakedState::Radiosity(_) | BakedState::Prt(_) => None,
        }
    }

    /// The radiosity method's state of the object, when that method baked the scene.
    #[must_use]
    pub fn radiosity(&self) -> Option<&RadiosityObject> {
        match &self.state {
            BakedState::Radiosity(s) => Some(s),
            BakedState::TransCut(_) | BakedState::HierarchicalDipole(_) | BakedState::Prt(_) => None,
        }
    }

    /// The PRT method's state, when that method baked the object.
    #[must_use]
    pub fn prt(&self) -> Option<&PrtState> {
        match &self.state {
            BakedState::Prt(s) => Some(s),
            _ => None,
        }
    }

    /// The name of the method that baked the object ([`crate::scene::Method::name`]).
    #[must_use]
    pub fn method(&self) -> &'static str {
        self.stats.method
    }
}

/// What a method prepared for one object, one variant per method.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub enum BakedState {
    /// TransCut: the tet mesh, its media and system, the fluence.
    TransCut(TransCutState),
    /// The hierarchical dipole: the cluster trees (and links) over the surface, the medium.
    HierarchicalDipole(DipoleState),
    /// Translucent radiosity: the object's patch surface and its radiance, with its TransCut
    /// state when translucent.
    Radiosity(Box<RadiosityObject>),
    /// PRT: the samples, the compressed transfer, the medium's basis weights.
    Prt(PrtState),
}

/// What was measured for one object. Fields that a method does not have are 0 (or `None`); the
/// meaning of each per method is in its documentation.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ObjectStats {
    /// The method that baked the object ([`crate::scene::Method::name`]).
    pub method: &'static str,
    /// TransCut: the tetrahedra solved on.
    pub tets: usize,
    /// The nodes the method solved for (TransCut: tet-mesh vertices).
    pub vertices: usize,
    /// The nodes on the surface (TransCut: boundary vertices of the tet mesh).
    pub boundary_vertices: usize,
    /// Solver iterations per channel.
    pub iterations: [usize; 3],
    /// Final relative residual per channel.
    pub relative_residual: [f64; 3],
    /// The user's vertices whose radiance the clamp at zero changed: those interpolated from a
    /// surface node (with a non-zero weight) whose radiance came out negative in a channel and
    /// was clamped to zero (the diffusion approximation can give Lo < 0 where φ < 2q: very
    /// absorbing media, coarse meshes). For a ready tet mesh, the clamped boundary vertices.
    pub clamped_vertices: usize,
    /// Triangles of the object's surface whose winding was reversed to orient it consistently
    /// and outwards ([`crate::mesh::TriMesh::flipped_faces`]); 0 for a well-wound input.
    pub flipped_faces: usize,
    /// How well the method's discretisation resolves the medium, per channel, against the
    /// method's own validity limit (TransCut: σtr · h at the surface, the transport coefficient
    /// times the mean boundary edge length in mm; a bake is refused where a channel is above
    /// [`crate::methods::transcut::MAX_RESOLUTION`] over the radiance amplification of its
    /// albedo). 0 where the method has no such measure.
    pub resolution: [f64; 3],
    /// Building the method's geometry (TransCut: tetrahedralisation).
    pub meshing_ms: f64,
    /// Assembling the method's light-independent operators (TransCut: M).
    pub assembly_ms: f64,
    /// The light transmitted into the surface, with shadows.
    pub source_ms: f64,
    /// The solve and the radiance at the user's vertices.
    pub solve_ms: f64,
    /// The whole object.
    pub total_ms: f64,
    /// The backend the solve ran on (`cpu` or `gpu`).
    pub backend: Backend,
    /// The GPU adapter's name when the GPU ran.
    pub device: Option<String>,
    /// Why `auto` solved on the CPU, when it did.
    pub backend_fallback: Option<String>,
    /// The mesher's own statistics (`None` for an object given as a ready tet mesh).
    pub meshing: Option<MesherStats>,
    /// Whether the light-independent part was read from a saved precompute instead of computed
    /// (PRT with a cache, [`crate::prt::PrtCache`]).
    pub precompute_loaded: bool,
    /// Whether the tets were kept from an earlier bake of the same surface instead of meshed
    /// (TransCut, [`crate::bake::bake_reusing`]); `meshing` then describes the meshing that
    /// made them and `meshing_ms` the copy.
    pub mesh_reused: bool,
    /// The polygrid method's polycube and grid (`None` for the other methods).
    pub polygrid: Option<PolygridStats>,
}

impl ObjectStats {
    /// Empty statistics of `method` (every count and time 0, the CPU backend).
    #[must_use]
    pub fn new(method: &'static str) -> Self {
        Self {
            method,
            tets: 0,
            vertices: 0,
            boundary_vertices: 0,
            iterations: [0; 3],
            relative_residual: [0.0; 3],
            clamped_vertices: 0,
            flipped_faces: 0,
            resolution: [0.0; 3],
            meshing_ms: 0.0,
            assembly_ms: 0.0,
            source_ms: 0.0,
            solve_ms: 0.0,
            total_ms: 0.0,
            backend: Backend::Cpu,
            device: None,
            backend_fallback: None,
            meshing: None,
            precompute_loaded: false,
            mesh_reused: false,
            polygrid: None,
        }
    }
}
