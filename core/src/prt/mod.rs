//! Precomputed translucent transfer (R. Wang et al. 2008, papers/001; design/prt.md).
pub mod basis;
