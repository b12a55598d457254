//! Errors of the diffusion solver.

use crate::input::fmt_num;

use crate::optics::OpticsError;
use crate::sparse::SparseError;

/// Colour channel names for messages (0 = red, 1 = green, 2 = blue).
const CHANNELS: [&str; 3] = ["red", "green", "blue"];

fn channel_name(channel: usize) -> &'static str {
    CHANNELS.get(channel).copied().unwrap_or("?")
}

/// What went wrong in assembling or solving a diffusion system.
///
/// Every variant names what is at fault (tet, vertex, material, channel) and the offending
/// value; nothing of the caller's data is changed when an error is returned.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DiffusionError {
    /// The length scale `mm_per_unit` is not finite and > 0.
    #[error("mm_per_unit = {value_g}: must be finite and > 0 (millimetres per scene unit)", value_g = fmt_num(*.value))]
    InvalidScale {
        /// The value given.
        value: f64,
    },
    /// A tet refers to a material id that has no entry in the media table.
    #[error("tet {tet} has material id {material}, but the media table has {media} entries")]
    MaterialOutOfRange {
        /// The tet.
        tet: usize,
        /// Its material id.
        material: u32,
        /// Length of the media table.
        media: usize,
    },
    /// A medium of the table is invalid.
    #[error("medium {index} of the table is invalid: {source}")]
    InvalidMedium {
        /// Index into the media table (the material id).
        index: usize,
        /// What is wrong with it.
        #[source]
        source: OpticsError,
    },
    /// The media on the object's surface disagree on the refractive index (one η per object:
    /// the boundary condition and the radiance query use a single Fdr, A and Ft).
    #[error(
        "the surface media disagree on the refractive index: material {first} has eta = \
         {first_eta_g}, material {other} has eta = {other_eta_g} (one eta per object)", first_eta_g = fmt_num(*.first_eta), other_eta_g = fmt_num(*.other_eta))]
    MixedRefractiveIndex {
        /// The first material found on the boundary.
        first: u32,
        /// Its η.
        first_eta: f64,
        /// A boundary material with a different η.
        other: u32,
        /// That η.
        other_eta: f64,
    },
    /// A tet whose geometry gives a non-finite coefficient (a numerically degenerate tet whose
    /// dihedral angle is 0 or π), after scaling to millimetres.
    #[error("tet {tet} is numerically degenerate: its {what} is {value_g} (in mm units)", value_g = fmt_num(*.value))]
    DegenerateTet {
        /// The tet.
        tet: usize,
        /// The quantity, e.g. `"volume"` or `"edge weight"`.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// A per-vertex array has the wrong length.
    #[error("{what}: expected {expected} entries, found {found}")]
    LengthMismatch {
        /// The array, e.g. `"source q (one entry per boundary vertex)"`.
        what: &'static str,
        /// The length needed.
        expected: usize,
        /// The length given.
        found: usize,
    },
    /// A source value is negative, NaN or infinite.
    #[error(
        "source q at boundary vertex {index} (mesh vertex {vertex}), channel {channel} ({}) \
         = {value_g}: must be finite and >= 0", channel_name(*.channel), value_g = fmt_num(*.value))]
    InvalidSource {
        /// Index into the boundary vertex list.
        index: usize,
        /// The mesh vertex.
        vertex: u32,
        /// The colour channel.
        channel: usize,
        /// The value given.
        value: f64,
    },
    /// A fluence value given to a query is NaN or infinite.
    #[error("{what} at vertex {vertex}, channel {channel} ({}) = {value_g}: must be finite", channel_name(*.channel), value_g = fmt_num(*.value))]
    NonFinite {
        /// The array, e.g. `"initial guess"`.
        what: &'static str,
        /// The mesh vertex.
        vertex: usize,
        /// The colour channel.
        channel: usize,
        /// The value given.
        value: f64,
    },
    /// The iterative solve stopped before meeting its tolerance.
    #[error(
        "the diffusion solve did not converge: relative residuals {residual:?} after \
         {iterations:?} iterations (tolerance {tolerance_g})", tolerance_g = fmt_num(*.tolerance))]
    NotConverged {
        /// Iterations per channel.
        iterations: [usize; 3],
        /// Final relative residual per channel.
        residual: [f64; 3],
        /// The tolerance asked for.
        tolerance: f64,
    },
    /// A row-local refill ([`super::DiffusionSystem::update_media_rows`]) would change the
    /// refractive index at the surface, which changes the boundary terms of every boundary row
    /// and the right-hand side: use [`super::DiffusionSystem::set_media`].
    #[error(
        "the media change the refractive index at the surface from {old_g} to {new_g}: a row-local \
         refill cannot change the boundary terms (refill the whole matrix)", old_g = fmt_num(*.old), new_g = fmt_num(*.new))]
    RefractiveIndexChanged {
        /// The η the system holds.
        old: f64,
        /// The η of the new media.
        new: f64,
    },
    /// A tet index given to a row-local refill is out of range.
    #[error("tet {tet} does not exist (the mesh has {count} tets)")]
    TetOutOfRange {
        /// The index given.
        tet: usize,
        /// Number of tets.
        count: usize,
    },
    /// A row-local refill was given media that also change a tet it was not told about.
    #[error(
        "the new media change material {material} of tet {tet}, which is not in the list of \
         changed tets (its rows would not be refilled)"
    )]
    UnlistedMediaChange {
        /// A tet whose medium changed but is not listed.
        tet: usize,
        /// Its material id.
        material: u32,
    },
    /// The sparse layer failed (pattern building, preconditioner, PCG breakdown, …).
    #[error(transparent)]
    Sparse(#[from] SparseError),
    /// The caller's `keep_going` asked to stop (the `*_with` builders).
    #[error("cancelled by the progress callback")]
    Cancelled,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_what_is_wrong() {
        let e = DiffusionError::MaterialOutOfRange { tet: 7, material: 3, media: 2 };
        assert_eq!(e.to_string(), "tet 7 has material id 3, but the media table has 2 entries");
        let e = DiffusionError::InvalidSource { index: 4, vertex: 19, channel: 2, value: -1.0 };
        let msg = e.to_string();
        assert!(msg.contains("mesh vertex 19") && msg.contains("blue") && msg.contains("-1"), "{msg}");
        let e = DiffusionError::InvalidScale { value: f64::NAN };
        assert!(e.to_string().contains("NaN"));
    }
}
