//! Optical media (placeholder until optics lands).
