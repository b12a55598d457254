//! Sparse linear algebra (placeholder until sparse lands).
