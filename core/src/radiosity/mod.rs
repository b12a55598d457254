//! The radiosity stage of translucent radiosity (Sheng et al. 2014, papers/002;
//! design/radiosity.md): patches at the vertices of every surface of a scene and the form
//! factors between them with visibility, the operator F of B = (I − SF)⁻¹ S E.
//!
//! - [`PatchSet`]: vertex patches (dual cells, Aᵢ = Σ_{t∋i} A_t/3) on the scene's surfaces, two
//!   per vertex on a two-sided surface (one each side); [`refine_to_edge_length`] splits a coarse
//!   surface (a two-triangle wall) so that it can carry colour bleeding.
//! - [`FormFactors`]: gathering form factors F_{i→j} cast from each patch's dual cell through one
//!   BVH of all surfaces, a hit at barycentrics b adding b_k/N to its triangle's corner patches
//!   (the radiosity interpolated linearly), symmetrised and balanced so that reciprocity
//!   AᵢFᵢⱼ = AⱼFⱼᵢ holds to rounding and each row sums to the fraction of its rays that hit
//!   something (1 in a closed scene).
//! - [`solve`]: classical radiosity B = ρ ⊙ (E + F B) + M on the patches (S = diag ρ), Jacobi or
//!   Gauss–Seidel with an a-posteriori error estimate and the energy balance.
//! - [`analytic`]: the closed-form form factors the tests compare with.

pub mod analytic;
mod distance;
mod error;
mod form_factor;
mod heterogeneous;
mod patches;
mod path_media;
mod profile;
mod profile_media;
mod profile_scattering;
mod solver;

pub use distance::{pair_distances, DistanceMode, InteriorGraph, PairDistances, MAX_VOXELS};
pub use error::RadiosityError;
pub use form_factor::{FormFactorOptions, FormFactors};
pub use heterogeneous::{merge_lengths, HetRule};
pub use patches::{refine_to_edge_length, PatchSet, Surface, MAX_REFINED_TRIANGLES};
pub use path_media::{path_fractions, MediumIndex, MAX_MEDIA, MAX_STEPS};
pub use profile::{Exponentials, HalfSpace, Profile, Tabulated};
pub use profile_media::{EntryMedia, RADIAL};
pub use profile_scattering::{radiance_factor, ObjectPatches, ProfileMatrix, ProfileOptions, ProfileScattering, SampleCache};
pub use solver::{
    solve, solve_coupled, solve_coupled_with, EnergyBalance, Gather, Iteration, Opaque, Scattering, Solution, SolveOptions,
    Translucent,
};
