//! Hierarchical dipole integration (Mertens, Kautz, Bekaert, Seidel & Van Reeth 2003,
//! papers/003): the dipole BSSRDF of Jensen et al. 2001 integrated over a triangle mesh as a
//! hierarchical boundary-element sum, fast enough to redo every frame of a deforming mesh.
//!
//! B(xₒ) = ∫_S E(xᵢ) Rd(xᵢ, xₒ) dxᵢ (Mertens eq. 4), E the light entering the surface
//! ([`crate::light::transmitted_source`]'s q) and Rd the dipole profile; there is no volume
//! and no solve. The radiance is Lo = B · [`DipoleRadiance::per_exitance`].
//!
//! - [`tree`]: the cluster trees over emitting triangles and receiving points, refitted when
//!   the vertices move;
//! - [`oracle`]: where a link between two clusters may be made;
//! - [`integrator`]: links, pull, gather, push, the three modes ([`EvalMode`]) and the O(n²)
//!   reference ([`reference_quadratic`]);
//! - the near field's analytic triangle form factor is [`crate::optics::dipole_patch`].
//!
//! The choices, the paper's defects and the closed-form checks are in
//! `design/hierarchical-dipole.md`; the method behind the contract is
//! [`crate::methods::hierarchical_dipole`].

mod error;
pub mod integrator;
pub mod options;
pub mod oracle;
pub mod tree;

pub use error::HierarchyError;
pub use integrator::{point_kernel, reference_quadratic, vertex_normals, DipoleHierarchy, DipoleStats};
pub use options::{DipoleOptions, DipoleRadiance, EvalMode, Receivers};
pub use oracle::Oracle;
