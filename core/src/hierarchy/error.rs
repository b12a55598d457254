//! Why the hierarchical dipole refused its input. Nothing changed.

use crate::progress::Cancelled;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum HierarchyError {
    #[error("the surface has no triangles")]
    NoTriangles,
    #[error("the surface has no area (every triangle is degenerate)")]
    NoArea,
    #[error("triangle {triangle} refers to vertex {index}, but the surface has {vertices} vertices")]
    IndexOutOfRange { triangle: usize, index: u32, vertices: usize },
    #[error("vertex {vertex} is not finite: {value:?}")]
    NonFinite { vertex: usize, value: [f64; 3] },
    #[error("{what}: expected {expected} values (one per vertex), got {got}")]
    WrongLength { what: &'static str, expected: usize, got: usize },
    #[error("the irradiance at vertex {vertex} is not finite and ≥ 0: {value:?}")]
    InvalidIrradiance { vertex: usize, value: [f64; 3] },
    #[error("invalid options: {0}")]
    InvalidOptions(String),
    #[error("{0}")]
    Cancelled(#[from] Cancelled),
}
