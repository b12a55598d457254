//! The errors of an acquisition: bad input named, solver failures passed on.

use crate::polygrid::PolygridError;
use crate::progress::Cancelled;
use crate::sparse::SparseError;
use crate::volume::VolumeError;

/// What went wrong in an acquisition. Every input check runs before any solve, so an error
/// about the input leaves nothing half done; no partial result is ever returned as complete.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum InverseError {
    /// A grid with fewer than 2 nodes along an axis, or too many nodes.
    #[error("invalid node grid {dims:?}: {reason}")]
    InvalidGrid {
        /// Nodes along x, y, z.
        dims: [usize; 3],
        /// Why it is refused.
        reason: &'static str,
    },
    /// A scalar setting out of range (spacing, η, margin, tolerance, …).
    #[error("invalid {what}: {value} ({expected})")]
    InvalidSetting {
        /// The setting's name.
        what: &'static str,
        /// The value given.
        value: f64,
        /// What it must be.
        expected: &'static str,
    },
    /// λ < 0 (or not finite).
    #[error("the regularisation weight λ must be finite and ≥ 0, got {0}")]
    NegativeLambda(f64),
    /// A different number of images than of light patterns.
    #[error("{images} images for {patterns} light patterns: one image per pattern is needed")]
    PatternCountMismatch {
        /// Images given.
        images: usize,
        /// Patterns given.
        patterns: usize,
    },
    /// No pattern at all.
    #[error("no light pattern: at least one image is needed")]
    NoPatterns,
    /// An image (or a pattern, or a mask) with the wrong number of pixels.
    #[error("{what} {index} has {found} pixels, the observed face has {expected} ({nx} × {ny} nodes)")]
    WrongImageSize {
        /// "image", "pattern" or "mask".
        what: &'static str,
        /// Its index.
        index: usize,
        /// Pixels expected (nodes of the face).
        expected: usize,
        /// Pixels found.
        found: usize,
        /// Face nodes along x.
        nx: usize,
        /// Face nodes along y.
        ny: usize,
    },
    /// A NaN or infinite pixel (or a negative one in a light pattern).
    #[error("{what} {index}: pixel {pixel} channel {channel} is {value}")]
    BadPixel {
        /// "image" or "pattern".
        what: &'static str,
        /// Its index.
        index: usize,
        /// The pixel (x fastest).
        pixel: usize,
        /// The colour channel.
        channel: usize,
        /// The value.
        value: f64,
    },
    /// No pixel is left to fit after masking (or the unmasked pixels of a channel are all 0).
    #[error("the mask leaves nothing to fit in channel {channel}: {reason}")]
    EmptyMask {
        /// The colour channel.
        channel: usize,
        /// Why.
        reason: &'static str,
    },
    /// An acquisition description that does not say what it must (no pattern kind, two kinds
    /// at once, an unknown optimiser, …).
    #[error("the acquisition description: {0}")]
    InvalidDescription(String),
    /// A file the description names does not exist.
    #[error("{path}: no such file")]
    MissingFile {
        /// The path, as resolved against the description's folder.
        path: String,
    },
    /// An image file that cannot be read or decoded (or written).
    #[error("{path}: {reason}")]
    ImageFile {
        /// The path.
        path: String,
        /// What went wrong.
        reason: String,
    },
    /// An image file with a different size than the face it shows.
    #[error("{path} is {found_width} × {found_height} pixels, the face has {width} × {height} nodes")]
    ImageFileSize {
        /// The path.
        path: String,
        /// Pixels expected across and down (face nodes along x and y).
        width: usize,
        /// See `width`.
        height: usize,
        /// Pixels found across.
        found_width: usize,
        /// Pixels found down.
        found_height: usize,
    },
    /// A NaN or infinite pixel in an image file (or a negative one in a pattern image).
    #[error("{path}: pixel ({x}, {y}) channel {channel} is {value}")]
    ImageFilePixel {
        /// The path.
        path: String,
        /// Column (face node i).
        x: usize,
        /// Row from the top (face node j).
        y: usize,
        /// The colour channel.
        channel: usize,
        /// The value.
        value: f64,
    },
    /// Parameters of the wrong length, or not finite.
    #[error("parameters: {0}")]
    InvalidParameters(String),
    /// A linear solve failed (not converged, breakdown).
    #[error("the {what} solve of image {image} failed: {source}")]
    Solve {
        /// "forward" or "adjoint".
        what: &'static str,
        /// The image.
        image: usize,
        /// The solver's error.
        #[source]
        source: SparseError,
    },
    /// A linear solve stopped at its iteration cap short of the tolerance.
    #[error("the {what} solve of image {image} did not converge (relative residual {residual:.3e})")]
    NotConverged {
        /// "forward" or "adjoint".
        what: &'static str,
        /// The image.
        image: usize,
        /// The residual reached.
        residual: f64,
    },
    /// Building the independent (polygrid) forward model failed.
    #[error(transparent)]
    Polygrid(#[from] PolygridError),
    /// Building the voxel grid failed.
    #[error(transparent)]
    Volume(#[from] VolumeError),
    /// The sparse pattern could not be built.
    #[error(transparent)]
    Sparse(#[from] SparseError),
    /// The progress callback asked to stop.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}
