//! Welding (placeholder).
