//! Errors of the sparse module.

use crate::input::fmt_num;

/// The colour channel names, by channel index (0 = R, 1 = G, 2 = B).
pub const CHANNEL_NAMES: [&str; 3] = ["R", "G", "B"];

fn channel_label(channel: &usize) -> &'static str {
    CHANNEL_NAMES.get(*channel).copied().unwrap_or("?")
}

/// What went wrong in building a sparse matrix, reading or writing one, or solving a system.
///
/// Channel indices are 0, 1, 2 for R, G, B; messages show both.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SparseError {
    /// A vector or matrix has the wrong size.
    #[error("{what}: expected {expected}, found {found}")]
    DimensionMismatch {
        /// The operand at fault, e.g. `"right-hand side length"`.
        what: &'static str,
        /// The size the operation needs.
        expected: usize,
        /// The size it was given.
        found: usize,
    },
    /// A row or column index is not below the matrix dimension.
    #[error("{what}: index {index} is out of range for dimension {n}")]
    IndexOutOfRange {
        /// The input at fault, e.g. `"edge 12"` or `"triplet 7 column"`.
        what: String,
        /// The offending index.
        index: u64,
        /// The matrix dimension.
        n: usize,
    },
    /// A NaN or infinite value in an input.
    #[error("{what} has a non-finite value {value_g} at row {row}, channel {channel} ({})", channel_label(.channel), value_g = fmt_num(*.value))]
    NonFinite {
        /// The input at fault: `"right-hand side"`, `"initial guess"`, `"matrix"`, …
        what: &'static str,
        /// The row (for the matrix, the row of the entry).
        row: usize,
        /// The colour channel (0 = R, 1 = G, 2 = B).
        channel: usize,
        /// The value found.
        value: f64,
    },
    /// An entry to add lies outside the fixed sparsity pattern.
    #[error("entry ({row}, {col}) is not in the sparsity pattern")]
    NotInPattern {
        /// Row of the entry.
        row: usize,
        /// Column of the entry.
        col: usize,
    },
    /// Two matrices that must share a sparsity pattern do not.
    #[error("the sparsity patterns differ: {0}")]
    PatternMismatch(String),
    /// A preconditioner needs a positive diagonal and found a non-positive (or NaN) one.
    #[error("diagonal entry at row {row} is {value_g} on channel {channel} ({}); the preconditioner needs a positive diagonal (is the matrix SPD?)", channel_label(.channel), value_g = fmt_num(*.value))]
    NonPositiveDiagonal {
        /// The row.
        row: usize,
        /// The colour channel.
        channel: usize,
        /// The diagonal value.
        value: f64,
    },
    /// A relaxation sweep divides by a diagonal entry that is zero or not finite.
    #[error("diagonal entry at row {row} is {value_g} on channel {channel} ({}); a relaxation sweep divides by it, so it must be finite and nonzero (or the row frozen)", channel_label(.channel), value_g = fmt_num(*.value))]
    UnusableDiagonal {
        /// The row.
        row: usize,
        /// The colour channel.
        channel: usize,
        /// The diagonal value.
        value: f64,
    },
    /// Two rows of one colour of a [`Colouring`](super::relax::Colouring) are coupled by a stored
    /// off-diagonal entry, so they cannot be updated at the same time.
    #[error("rows {row} and {col} both have colour {colour} but entry ({row}, {col}) couples them; rows of one colour must not be coupled")]
    ColouringConflict {
        /// The row of the coupling entry.
        row: usize,
        /// Its column.
        col: usize,
        /// The colour both rows have.
        colour: u32,
    },
    /// The iteration broke down: for CG, `pᵀAp ≤ 0` (the matrix is not positive definite) or
    /// `rᵀz ≤ 0` (the preconditioner is not); for BiCGSTAB, a vanishing inner product.
    #[error("{method} broke down on channel {channel} ({}) at iteration {iteration}: {reason}", channel_label(.channel))]
    Breakdown {
        /// `"PCG"` or `"BiCGSTAB"`.
        method: &'static str,
        /// The colour channel that broke down.
        channel: usize,
        /// The iteration (1-based) at which it happened.
        iteration: usize,
        /// What was found, e.g. `"pᵀAp = -3.2e-1 ≤ 0: the matrix is not positive definite"`.
        reason: String,
    },
    /// The monitor callback asked to stop.
    #[error("cancelled by the monitor at iteration {iteration}")]
    Cancelled {
        /// The iteration after which the monitor returned `false` (for a hierarchy build, the
        /// number of levels built).
        iteration: usize,
    },
    /// An option is out of its valid range.
    #[error("invalid option: {0}")]
    InvalidOption(String),
    /// The matrix is too large for 32-bit column indices.
    #[error("too large: {0}")]
    TooLarge(String),
    /// A file could not be read or written.
    #[error("cannot access {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A Matrix Market file is malformed or of an unsupported kind.
    #[error("{path}:{line}: {message}")]
    MatrixMarket {
        /// The file.
        path: String,
        /// The 1-based line number (0 when the file ended early).
        line: usize,
        /// What is wrong.
        message: String,
    },
}
