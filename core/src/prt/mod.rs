//! Precomputed translucent transfer with a PCA basis of the dipole profile (R. Wang et al. 2008,
//! "Real-time editing and relighting of homogeneous translucent materials", papers/001;
//! design/prt.md): the light-independent, material-independent part of a dipole bake done
//! once, so that a material edit is a K-term re-weighting and a relight one sparse product.
//!
//! With the profile in its basis, Rd(r; σ) ≈ Σₖ bₖ(r) sₖ(σ) ([`basis`], eq. 4), the exitance at a
//! vertex under transmitted irradiance q is
//!
//! B(x) = ∫ Rd(‖x − y‖) q(y) dA ≈ Σₖ sₖ(σ) Σⱼ Tₖ[x, j] qⱼ,  Tₖ[x, j] = aⱼ bₖ(‖x − xⱼ‖)
//!
//! over 2ⁿ surface samples xⱼ of area aⱼ ([`samples`], eqs. 5–7), each row corrected in the near
//! field ([`near`]) and kept as its largest Haar coefficients ([`haar`], [`transfer`], eq. 8),
//! qⱼ the mean over sample j's piece where a hard shadow's edge crosses it ([`cells`]).
//! The radiance is the quantity every method returns (ARCHITECTURE.md, "What a bake returns"):
//! Lo(x, n) = T(η, 0)/(π η² (1 − Fdr)) · B(x), the energy-consistent constant of the dipole
//! methods (0.33345 at η = 1.3; Jensen's literal T/π is 1.066× brighter).
//!
//! The transfer depends on geometry alone: one per object, shared by the three channels, and a
//! change of the object's scale s (mm per unit) is the material edit σ → sσ
//! (Rd(sr; σ) s² = Rd(r; sσ)).

pub mod basis;
pub mod cells;
pub mod env;
pub mod haar;
pub mod io;
pub(crate) mod near;
pub mod samples;
pub mod transfer;

pub use basis::{BasisSize, RdBasis};
pub use cells::cell_irradiance;
pub use io::{PrecomputeFileError, PrecomputeHeader, PrecomputeKey};
pub use samples::SurfaceSamples;
pub use transfer::{haar_irradiance, Transfer, TransferStats};

use std::path::PathBuf;

use crate::progress::Cancelled;

/// Where precomputed transfers are kept between sessions ([`io`]): a bake looks there first and
/// precomputes only when it finds no transfer of this surface and these options.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PrtCache {
    /// A folder of `.tcprt` files named by their [`PrecomputeKey`]: a transfer found there is
    /// used, one not found (or unreadable: an old version, a damaged file) is precomputed and
    /// written there.
    Folder(PathBuf),
    /// One `.tcprt` file: used when it exists (an error when it was made for another surface or
    /// other options), precomputed and written when it does not.
    File(PathBuf),
}

/// How a PRT precompute samples, corrects and compresses the transfer.
#[derive(Debug, Clone, PartialEq)]
pub struct PrtOptions {
    /// log₂ of the irradiance samples N, in [4, [`samples::MAX_SAMPLES_LOG2`]] (default 16).
    pub samples_log2: u32,
    /// The PCA basis (default [`BasisSize::K16`]).
    pub basis: BasisSize,
    /// Haar coefficients kept per vertex over all its K rows (default 1024: on the sun- and
    /// spot-lit cow 1.1e-2 from the exact dipole, 4.7e-3 at 2048; the paper keeps 256 per row,
    /// 3072 at K = 12, chosen by size alone); at least K (every row keeps its mean).
    pub terms_per_vertex: usize,
    /// The near-field correction of the rows ([`near`]; default on).
    pub near_field: bool,
    /// The near field's radius in sample spacings √(A/N) (default 8), in [1, 64]: beyond it the
    /// samples' point rule errs by about 0.05/c³ of the exitance for c spacings (measured on the
    /// uniformly lit 10 mm marble sphere: 8e-4 at 4, 1e-4 at 8, 4e-5 at 16).
    pub near_radius: f64,
    /// The seed of the sample pattern.
    pub seed: u64,
    /// Where transfers are kept between sessions (default none: every bake precomputes).
    pub cache: Option<PrtCache>,
}

impl Default for PrtOptions {
    fn default() -> Self {
        Self {
            samples_log2: 16,
            basis: BasisSize::K16,
            terms_per_vertex: 1024,
            near_field: true,
            near_radius: 8.0,
            seed: 0,
            cache: None,
        }
    }
}

impl PrtOptions {
    /// The most coefficients per vertex.
    pub const MAX_TERMS_PER_VERTEX: usize = 1 << 20;

    /// Checks the options.
    ///
    /// # Errors
    /// A message naming the option out of range.
    pub fn validate(&self) -> Result<(), String> {
        if !(4..=samples::MAX_SAMPLES_LOG2).contains(&self.samples_log2) {
            return Err(format!("samples_log2 {} is not in [4, {}]", self.samples_log2, samples::MAX_SAMPLES_LOG2));
        }
        let k = self.basis.terms();
        if !(k..=Self::MAX_TERMS_PER_VERTEX).contains(&self.terms_per_vertex) {
            return Err(format!(
                "terms_per_vertex {} is not in [{k}, {}] (every one of the {k} rows keeps its mean)",
                self.terms_per_vertex,
                Self::MAX_TERMS_PER_VERTEX
            ));
        }
        if !(self.near_radius >= 1.0 && self.near_radius <= 64.0) {
            return Err(format!("near_radius {} is not in [1, 64] sample spacings", self.near_radius));
        }
        Ok(())
    }
}

/// What can go wrong in the PRT stage.
#[derive(Debug, thiserror::Error)]
pub enum PrtError {
    /// The surface cannot be sampled as asked.
    #[error("samples: {0}")]
    Samples(String),
    /// A medium the precomputed transfer cannot represent.
    #[error("medium: {0}")]
    Medium(String),
    /// A saved transfer could not be read or written.
    #[error("precompute file: {0}")]
    File(#[from] PrecomputeFileError),
    /// The caller stopped the work.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}
