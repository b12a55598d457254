//! Errors of heterogeneous media: voxel files, per-tet tables, procedural fields.

use std::path::PathBuf;

use crate::input::{fmt_num, InputError};
use crate::optics::OpticsError;

/// Names of the six voxel channels, in storage order (σa RGB, then σ′s RGB).
pub const VOXEL_CHANNEL_NAMES: [&str; 6] =
    ["sigma_a red", "sigma_a green", "sigma_a blue", "sigma_s_prime red", "sigma_s_prime green", "sigma_s_prime blue"];

/// The name of voxel channel `channel` (0..6), or `"?"` out of range.
fn voxel_channel_name(channel: usize) -> &'static str {
    VOXEL_CHANNEL_NAMES.get(channel).copied().unwrap_or("?")
}

/// What is wrong with a heterogeneous medium, a voxel grid or a procedural field.
///
/// Every variant names what is at fault (file, voxel, tet, material, channel) and the offending
/// value; nothing of the caller's data is changed when an error is returned. Errors found while
/// reading a voxel file come wrapped in [`VolumeError::VoxelFile`], which names the file;
/// [`VolumeError::root`] strips that context.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum VolumeError {
    /// A voxel file could not be read or written.
    #[error("voxel file {}: {source}", .path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A voxel file was refused before it was read: it is not a regular file, or its size is
    /// not the one its header declares, or larger than
    /// [`MAX_VOXEL_FILE_BYTES`](super::MAX_VOXEL_FILE_BYTES).
    #[error("voxel file {}: {source}", .path.display())]
    Refused {
        /// The file.
        path: PathBuf,
        /// Which bound it broke.
        #[source]
        source: InputError,
    },
    /// An error in the contents of a voxel file (the inner error says what).
    #[error("voxel file {}: {source}", .path.display())]
    VoxelFile {
        /// The file.
        path: PathBuf,
        /// What is wrong with its contents.
        #[source]
        source: Box<VolumeError>,
    },
    /// The data does not start with the voxel-file magic `b"TCVOX1\0\0"`.
    #[error("not a TCVOX1 voxel file: the first 8 bytes are {found:?}, expected {:?}", super::voxel::MAGIC)]
    BadMagic {
        /// The first bytes found (fewer than 8 when the data is shorter).
        found: Vec<u8>,
    },
    /// The data ends before the header or the voxel values do.
    #[error("truncated {part}: expected {expected} bytes, found {found}")]
    Truncated {
        /// `"header"` or `"voxel data"`.
        part: &'static str,
        /// Total bytes the header declares (header + data).
        expected: u64,
        /// Bytes present.
        found: u64,
    },
    /// There are bytes after the last voxel value.
    #[error("{extra} unexpected bytes after the voxel data: expected {expected} bytes in all, found {found}", extra = .found - .expected)]
    TrailingBytes {
        /// Total bytes the header declares.
        expected: u64,
        /// Bytes present.
        found: u64,
    },
    /// A grid dimension is zero.
    #[error("grid dimensions {}x{}x{}: every dimension must be at least 1", .dims[0], .dims[1], .dims[2])]
    ZeroDimension {
        /// nx, ny, nz.
        dims: [u32; 3],
    },
    /// The grid has more values than this machine can address.
    #[error("grid dimensions {}x{}x{} with {channels} channels are too large to hold in memory", .dims[0], .dims[1], .dims[2])]
    TooLarge {
        /// nx, ny, nz.
        dims: [u32; 3],
        /// Channels per voxel.
        channels: u32,
    },
    /// The channel count is not the supported 6 (σa RGB, σ′s RGB).
    #[error("{found} channels per voxel: only 6 (sigma_a RGB, sigma_s_prime RGB) are supported")]
    UnsupportedChannels {
        /// The channel count found.
        found: u32,
    },
    /// The grid origin or voxel size is invalid.
    #[error("{field} = [{}, {}, {}]: {requirement}", fmt_num(.value[0]), fmt_num(.value[1]), fmt_num(.value[2]))]
    InvalidGeometry {
        /// `"origin"` or `"voxel_size"`.
        field: &'static str,
        /// The value given.
        value: [f64; 3],
        /// What it must satisfy.
        requirement: &'static str,
    },
    /// A voxel value is invalid (NaN, infinite or negative, or σa + σ′s = 0 in a colour channel).
    #[error(
        "voxel ({}, {}, {}) (linear index {index}), channel {channel} ({}): value {}: {requirement}",
        .voxel[0], .voxel[1], .voxel[2], voxel_channel_name(*.channel), fmt_num(*.value)
    )]
    InvalidVoxel {
        /// The voxel (i, j, k).
        voxel: [u32; 3],
        /// Its linear index i + nx (j + ny k).
        index: usize,
        /// The channel, 0..6 (σa R, G, B, σ′s R, G, B).
        channel: usize,
        /// The value found (for the σa + σ′s check: the sum).
        value: f64,
        /// What the value must satisfy.
        requirement: &'static str,
    },
    /// An array has the wrong length.
    #[error("{what}: expected {expected} entries, found {found}")]
    LengthMismatch {
        /// The array.
        what: &'static str,
        /// The length needed.
        expected: usize,
        /// The length given.
        found: usize,
    },
    /// The medium of a tet is invalid (non-finite or negative coefficient, σa + σ′s = 0).
    #[error("tet {tet}: {source}")]
    InvalidTetMedium {
        /// The tet.
        tet: usize,
        /// What is wrong, naming the coefficient and the channel.
        #[source]
        source: OpticsError,
    },
    /// The object's refractive index η or anisotropy g is invalid.
    #[error("object parameters: {source}")]
    InvalidObjectParameter {
        /// What is wrong (names `eta` or `g`).
        #[source]
        source: OpticsError,
    },
    /// A medium given as input (a material-table entry, a layer, a vein medium) is invalid.
    #[error("{what} {index}: {source}")]
    InvalidMedium {
        /// Which list: `"material"`, `"layer"`, `"vein medium"`.
        what: &'static str,
        /// Its index in that list.
        index: usize,
        /// What is wrong with it.
        #[source]
        source: OpticsError,
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
    /// Media that must share the object's η (or g) disagree: one η per object, because the
    /// boundary condition and the radiance query use a single Fdr, A and Ft.
    #[error(
        "{what} {first} has {field} = {} but {what} {other} has {field} = {} (one {field} per object)",
        fmt_num(*.first_value), fmt_num(*.other_value)
    )]
    MixedObjectParameter {
        /// `"eta"` or `"g"`.
        field: &'static str,
        /// Which list: `"material"`, `"vein medium"`.
        what: &'static str,
        /// The first entry.
        first: usize,
        /// Its value.
        first_value: f64,
        /// An entry that disagrees.
        other: usize,
        /// Its value.
        other_value: f64,
    },
    /// A scalar parameter of a procedural field is out of range.
    #[error("{field} = {}: {requirement}", fmt_num(*.value))]
    InvalidParameter {
        /// The parameter, e.g. `"blend_mm"`.
        field: &'static str,
        /// The value given.
        value: f64,
        /// What it must satisfy.
        requirement: &'static str,
    },
    /// The layer list is invalid.
    #[error("layer {index}: {reason}")]
    InvalidLayers {
        /// The layer at fault.
        index: usize,
        /// Why.
        reason: String,
    },
    /// The tet mesh has no boundary surface to measure depth from.
    #[error("the tet mesh has no boundary faces: depth below the surface is undefined")]
    NoBoundary,
}

impl VolumeError {
    /// The error without its file context: the inner error of [`VolumeError::VoxelFile`], the
    /// error itself otherwise.
    #[must_use]
    pub fn root(&self) -> &VolumeError {
        match self {
            VolumeError::VoxelFile { source, .. } => source.root(),
            other => other,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_what_is_wrong() {
        let e = VolumeError::Truncated { part: "voxel data", expected: 1224, found: 1220 };
        assert_eq!(e.to_string(), "truncated voxel data: expected 1224 bytes, found 1220");
        let e = VolumeError::InvalidVoxel {
            voxel: [1, 2, 3],
            index: 45,
            channel: 4,
            value: f64::NAN,
            requirement: "must be finite and >= 0 (mm^-1)",
        };
        assert_eq!(
            e.to_string(),
            "voxel (1, 2, 3) (linear index 45), channel 4 (sigma_s_prime green): value NaN: must be finite and >= 0 (mm^-1)"
        );
        let e = VolumeError::TrailingBytes { expected: 100, found: 104 };
        assert_eq!(e.to_string(), "4 unexpected bytes after the voxel data: expected 100 bytes in all, found 104");
        let wrapped = VolumeError::VoxelFile { path: "a/b.tcvox".into(), source: Box::new(e) };
        assert!(wrapped.to_string().starts_with("voxel file a/b.tcvox: 4 unexpected bytes"));
        assert!(matches!(wrapped.root(), VolumeError::TrailingBytes { expected: 100, found: 104 }));
    }
}
