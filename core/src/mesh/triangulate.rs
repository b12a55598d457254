//! Polygon triangulation (placeholder).
