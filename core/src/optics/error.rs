//! Errors of optical parameters.

use crate::input::fmt_num;

/// Names of the colour channels, in storage order, for error messages.
pub const CHANNEL_NAMES: [&str; 3] = ["red", "green", "blue"];

/// The name of colour channel `channel` (0, 1, 2), or `"?"` for an index out of range.
fn channel_name(channel: usize) -> &'static str {
    CHANNEL_NAMES.get(channel).copied().unwrap_or("?")
}

/// What is wrong with a medium, an artist parameter set or an optics query.
///
/// Every variant names the field at fault and, for per-channel quantities, the channel
/// (0 = red, 1 = green, 2 = blue) and the offending value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum OpticsError {
    /// A per-channel quantity is out of its valid range (or NaN / infinite).
    #[error("{field}[{channel}] ({}) = {value_g}: {requirement}", channel_name(*.channel), value_g = fmt_num(*.value))]
    InvalidChannel {
        /// The field, e.g. `"sigma_a"`.
        field: &'static str,
        /// The channel index, 0 = red, 1 = green, 2 = blue.
        channel: usize,
        /// The value given.
        value: f64,
        /// What the value must satisfy.
        requirement: &'static str,
    },
    /// A scalar quantity is out of its valid range (or NaN / infinite).
    #[error("{field} = {value_g}: {requirement}", value_g = fmt_num(*.value))]
    InvalidScalar {
        /// The field, e.g. `"eta"`.
        field: &'static str,
        /// The value given.
        value: f64,
        /// What the value must satisfy.
        requirement: &'static str,
    },
    /// No preset has this name.
    #[error("unknown medium preset {name:?}; valid presets are: {valid}")]
    UnknownPreset {
        /// The name asked for.
        name: String,
        /// The valid names, comma-separated.
        valid: String,
    },
    /// A valid medium has no artist-parameter equivalent in one channel (its diffuse albedo
    /// would be exactly 0 or 1, outside the open interval artist albedos live in).
    #[error("channel {channel} ({}) cannot be expressed as artist parameters: {reason}", channel_name(*.channel))]
    NotRepresentable {
        /// The channel index, 0 = red, 1 = green, 2 = blue.
        channel: usize,
        /// Why not.
        reason: &'static str,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_field_channel_and_value() {
        let e = OpticsError::InvalidChannel { field: "sigma_a", channel: 1, value: -0.5, requirement: "must be >= 0" };
        assert_eq!(e.to_string(), "sigma_a[1] (green) = -0.5: must be >= 0");
        let e = OpticsError::InvalidScalar { field: "eta", value: f64::NAN, requirement: "finite" };
        assert_eq!(e.to_string(), "eta = NaN: finite");
    }
}
