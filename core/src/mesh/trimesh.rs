//! The surface triangle mesh every method starts from.

use glam::DVec3;

use super::MeshError;

/// Options for merging duplicate vertex positions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WeldOptions {
    /// Positions closer than `relative_tolerance × bounding-box diagonal` are merged.
    pub relative_tolerance: f64,
}

impl Default for WeldOptions {
    fn default() -> Self {
        Self { relative_tolerance: 1e-7 }
    }
}

/// A welded triangle mesh with a map back to the user's vertices.
///
/// Internal vertices are the welded ones; `user_to_internal[i]` is the internal vertex that stands
/// for the user's vertex `i` (in the order of the file or array the mesh came from), so results
/// can always be returned in the user's own vertex order.
#[derive(Debug, Clone)]
pub struct TriMesh {
    pub(crate) positions: Vec<DVec3>,
    pub(crate) triangles: Vec<[u32; 3]>,
    pub(crate) user_to_internal: Vec<u32>,
}

impl TriMesh {
    /// Internal (welded) vertex positions.
    #[must_use]
    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    /// Triangles over internal vertices, counter-clockwise seen from outside where the input was
    /// consistently oriented.
    #[must_use]
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// For each user vertex, the internal vertex that stands for it.
    #[must_use]
    pub fn user_to_internal(&self) -> &[u32] {
        &self.user_to_internal
    }

    /// Number of vertices in the user's input.
    #[must_use]
    pub fn user_vertex_count(&self) -> usize {
        self.user_to_internal.len()
    }

    /// Axis-aligned bounds `(min, max)` of the internal vertices.
    #[must_use]
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.positions.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        )
    }

    /// Length of the bounding-box diagonal.
    #[must_use]
    pub fn diagonal(&self) -> f64 {
        let (lo, hi) = self.bounds();
        (hi - lo).length()
    }

    /// The three corner positions of triangle `t`.
    #[must_use]
    pub fn triangle(&self, t: usize) -> [DVec3; 3] {
        let [a, b, c] = self.triangles[t];
        [self.positions[a as usize], self.positions[b as usize], self.positions[c as usize]]
    }

    /// Area-weighted normal of triangle `t` (length = twice the area).
    #[must_use]
    pub fn triangle_cross(&self, t: usize) -> DVec3 {
        let [a, b, c] = self.triangle(t);
        (b - a).cross(c - a)
    }

    /// Total surface area.
    #[must_use]
    pub fn area(&self) -> f64 {
        (0..self.triangles.len()).map(|t| 0.5 * self.triangle_cross(t).length()).sum()
    }

    /// Signed enclosed volume by the divergence theorem (exact for closed, consistently oriented
    /// meshes; an estimate for open ones).
    #[must_use]
    pub fn signed_volume(&self) -> f64 {
        (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.triangle(t);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }
}

pub(crate) fn check_finite(vertex: usize, p: DVec3) -> Result<(), MeshError> {
    if p.is_finite() {
        Ok(())
    } else {
        Err(MeshError::NonFinite { vertex, x: p.x, y: p.y, z: p.z })
    }
}
