//! How to bake: the method and what every method shares.

use super::method::Method;
use crate::light::SourceOptions;

/// How to bake a scene.
#[derive(Debug, Clone, PartialEq)]
pub struct BakeOptions {
    /// The subsurface method and its options (default TransCut).
    pub method: Method,
    /// Worker threads (0 = all cores).
    pub threads: usize,
    /// Whether objects shadow themselves and each other.
    pub shadows: bool,
    /// Sampling of area and environment lights and of shadow rays.
    pub source: SourceOptions,
}

impl Default for BakeOptions {
    /// TransCut with its defaults, all cores, shadows on, the default sampling.
    fn default() -> Self {
        Self { method: Method::default(), threads: 0, shadows: true, source: SourceOptions::default() }
    }
}

impl BakeOptions {
    /// The default options with `method`.
    #[must_use]
    pub fn with_method(method: impl Into<Method>) -> Self {
        Self { method: method.into(), ..Self::default() }
    }
}
