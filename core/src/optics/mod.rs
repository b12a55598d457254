//! Optical media and the boundary optics of the diffusion approximation.
//!
//! All lengths are millimetres and all coefficients mm⁻¹, per RGB channel, in `f64`.
//!
//! # The equations
//!
//! A [`Medium`] holds the absorption σa, the reduced scattering σ′s = (1 − g)σs, the refractive
//! index η (relative to air) and the anisotropy g. From them ([`medium`]):
//!
//! - σ′t = σa + σ′s, reduced albedo α′ = σ′s/σ′t;
//! - diffusion coefficient κ = 1/(3σ′t);
//! - effective transport coefficient σtr = √(σa/κ) = √(3σaσ′t), diffuse mean free path
//!   ℓd = 1/σtr (Jensen et al. 2001).
//!
//! At the boundary ([`fresnel`], [`boundary`]):
//!
//! - Fdr = −1.440/η² + 0.710/η + 0.668 + 0.0636η (Egan–Hilgeman fit of the internal diffuse
//!   reflectance), A = (1 + Fdr)/(1 − Fdr);
//! - Robin condition of the TransCut diffusion equation ∇·(κ∇φ) − σaφ = 0:
//!   φ + 2Aκ ∂φ/∂n = 4q/(1 − Fdr);
//! - exitant radiance Lo(ωo) = Ft(ωo)/(4π) · [(1 + 1/A)φ − 4q/(1 + Fdr)], with
//!   Ft(ωo) = T(η, θo)/η² the exact Fresnel transmittance out of the medium over η²;
//! - F_ext = 2∫₀¹ R(μ)μ dμ, the diffuse external reflectance (a constant environment of
//!   radiance L transmits q = πL(1 − F_ext)).
//!
//! The classical dipole ([`dipole`], Jensen et al. 2001) gives the diffuse reflectance profile
//! Rd(r) = α′/(4π)[z_r(σtr + 1/d_r)e^{−σtr d_r}/d_r² + z_v(σtr + 1/d_v)e^{−σtr d_v}/d_v²]
//! and its integral Rd = (α′/2)(1 + e^{−(4/3)A√(3(1−α′))})e^{−√(3(1−α′))}, which
//! [`ArtistParams`] inverts to turn a subsurface colour and radius into σa and σ′s.
//!
//! # Worked example
//!
//! Marble (Jensen et al. 2001) has ℓd ≈ 8.51 mm in red; an artist's colour and radius map to
//! coefficients and back; a uniformly lit marble sphere of radius 10 mm at η = 1.3 under a
//! constant white environment returns Lo ≈ 0.939 in red along the normal (ARCHITECTURE.md):
//!
//! ```
//! use transcut::optics::{f_ext, ArtistMapping, ArtistParams, Medium, UniformSphere};
//!
//! let marble = Medium::preset("marble")?;
//! assert!((marble.diffuse_mean_free_path()[0] - 8.51).abs() < 0.01);
//! assert!((marble.total_diffuse_reflectance()[0] - 0.830).abs() < 1e-3);
//!
//! // A scene in metres: radius in metres, 1000 mm per unit.
//! let artist = ArtistParams {
//!     albedo: [0.8, 0.6, 0.4],
//!     radius: [0.004, 0.002, 0.001],
//!     scale: 1.0,
//!     mm_per_unit: 1000.0,
//!     eta: 1.4,
//!     g: 0.0,
//!     mapping: ArtistMapping::Dipole,
//! };
//! let medium = artist.to_medium()?;
//! assert!((medium.sigma_t_prime()[0] - 0.25).abs() < 1e-12); // 1/(4 mm)
//! let back = medium.to_artist(1000.0, 1.0)?;
//! assert!((back.albedo[1] - 0.6).abs() < 1e-12);
//!
//! let at_1_3 = Medium { eta: 1.3, ..marble };
//! let q = std::f64::consts::PI * (1.0 - f_ext(1.3)); // 2.9495
//! let sphere = UniformSphere::new(at_1_3, 10.0, [q; 3])?;
//! let lo = sphere.surface_radiance(1.0);
//! assert!((lo[0] - 0.9394).abs() < 1e-4);
//! # Ok::<(), transcut::optics::OpticsError>(())
//! ```

pub mod analytic;
pub mod artist;
pub mod boundary;
pub mod dipole;
pub mod dipole_patch;
pub mod dipole_table;
mod error;
pub mod fresnel;
pub mod medium;
mod presets;
pub(crate) mod quadrature;

pub use analytic::{uniform_sphere_fluence, UniformSphere};
pub use artist::{half_space_albedo, ArtistMapping, ArtistParams};
pub use boundary::{radiance_from_fluence, BoundaryTerms};
pub use dipole::{rd_profile, reduced_albedo_from_rd, sigma_tr, total_diffuse_reflectance, Dipole};
pub use dipole_patch::{triangle_integral_rgb, DipoleGeometry, EdgeRule};
pub use dipole_table::DipoleTable;
pub use error::{OpticsError, CHANNEL_NAMES};
pub use fresnel::{
    a_coefficient, critical_cosine, f_ext, fdr, fdr_exact, fresnel_reflectance, fresnel_transmittance, ft_out,
    hemispherical_reflectance, transmittance_out,
};
pub use medium::{Medium, ETA_MAX, ETA_MIN};
pub use presets::PRESET_NAMES;
