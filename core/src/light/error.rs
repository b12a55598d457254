//! Errors of lights, environment maps and source queries.

use crate::input::fmt_num;

/// What is wrong with a light, an environment map, or the arguments of a source query.
///
/// Every variant names what is at fault: the light's index in the caller's list and the field,
/// the surface point's index, the texel, or the option.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LightError {
    /// A field of light `index` is out of its valid range (or NaN / infinite).
    #[error("light {index} ({kind}): {field} = {value}: {requirement}")]
    InvalidLight {
        /// Position of the light in the list it was given in.
        index: usize,
        /// The kind of light, e.g. `"spot"`.
        kind: &'static str,
        /// The field at fault, e.g. `"cone_half_angle_deg"`.
        field: &'static str,
        /// The value given, formatted.
        value: String,
        /// What the value must satisfy.
        requirement: &'static str,
    },
    /// A surface point or its normal is unusable.
    #[error("surface point {index}: {field} = {value}: {requirement}")]
    InvalidPoint {
        /// Index of the point.
        index: usize,
        /// `"position"` or `"normal"`.
        field: &'static str,
        /// The value given, formatted.
        value: String,
        /// What the value must satisfy.
        requirement: &'static str,
    },
    /// The point and normal arrays differ in length.
    #[error("{points} surface points but {normals} normals: one normal per point is needed")]
    LengthMismatch {
        /// Number of points.
        points: usize,
        /// Number of normals.
        normals: usize,
    },
    /// The refractive index is unusable.
    #[error("eta = {value_g}: the refractive index must be finite and in [{min_g}, {max_g})", value_g = fmt_num(*.value), min_g = fmt_num(*.min), max_g = fmt_num(*.max))]
    InvalidEta {
        /// The value given.
        value: f64,
        /// Smallest accepted index.
        min: f64,
        /// Accepted indices are strictly below this.
        max: f64,
    },
    /// The caller's progress check asked to stop ([`super::transmitted_source_with`]).
    #[error(transparent)]
    Cancelled(#[from] crate::progress::Cancelled),
    /// A source option is out of range, or too small for the lights given.
    #[error("source option {field} = {value}: {requirement}")]
    InvalidOption {
        /// The option, e.g. `"area_samples"`.
        field: &'static str,
        /// The value given, formatted.
        value: String,
        /// What the value must satisfy.
        requirement: String,
    },
    /// An environment map has no texels.
    #[error("environment map is {width}×{height}: both sides must be at least 1")]
    ImageSize {
        /// Width in texels.
        width: usize,
        /// Height in texels.
        height: usize,
    },
    /// An RGB buffer does not hold exactly `3 · width · height` floats.
    #[error("environment map of {width}×{height} texels needs {expected} floats (RGB), got {actual}")]
    ImageBufferLength {
        /// Width in texels.
        width: usize,
        /// Height in texels.
        height: usize,
        /// 3 · width · height.
        expected: usize,
        /// Length of the buffer given.
        actual: usize,
    },
    /// A texel is NaN, infinite or negative.
    #[error("environment map texel (column {x}, row {y}) = {value:?}: radiance must be finite and ≥ 0")]
    ImageTexel {
        /// Column (0 = left).
        x: usize,
        /// Row (0 = top).
        y: usize,
        /// The texel's RGB value.
        value: [f32; 3],
    },
    /// The intensity multiplier of an environment map is NaN, infinite or negative.
    #[error("environment map intensity = {value_g}: must be finite and ≥ 0", value_g = fmt_num(*.value))]
    ImageIntensity {
        /// The value given.
        value: f64,
    },
    /// An image file could not be read or decoded.
    #[error("cannot load environment map {path:?}: {reason}")]
    ImageLoad {
        /// The file.
        path: String,
        /// Why (the decoder's message).
        reason: String,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_what_is_wrong() {
        let e = LightError::InvalidLight {
            index: 3,
            kind: "spot",
            field: "cone_half_angle_deg",
            value: "120".into(),
            requirement: "must be in (0, 90]",
        };
        assert_eq!(e.to_string(), "light 3 (spot): cone_half_angle_deg = 120: must be in (0, 90]");
        let e = LightError::ImageBufferLength { width: 4, height: 2, expected: 24, actual: 23 };
        assert!(e.to_string().contains("needs 24 floats"), "{e}");
        let e = LightError::LengthMismatch { points: 3, normals: 2 };
        assert!(e.to_string().starts_with("3 surface points but 2 normals"), "{e}");
    }
}
