//! [`Layers`]: media by depth below the object's surface (skin: epidermis, dermis, fat).
//!
//! The depth of a point is its distance to the boundary surface of the tet mesh (the boundary
//! faces, through a [`TriangleBvh`]), converted to millimetres with `mm_per_unit`. Layer k,
//! k = 0 (outermost) … L − 1 (innermost), fills the depths between the boundaries
//! b_{k−1} and b_k = `max_depth_mm` of layer k (b_{−1} = 0; the innermost layer fills every depth
//! beyond b_{L−2}). Across each boundary the media blend smoothly over a width w = `blend_mm`:
//!
//! ```text
//! s_k(d) = smoothstep((d − b_k)/w + 1/2),  smoothstep(x) = 3x² − 2x³ on x clamped to [0, 1]
//!          (w = 0: s_k(d) = 0 for d ≤ b_k, 1 beyond)
//! c ← c_0;  for k = 0 … L − 2:  c ← (1 − s_k(d)) c + s_k(d) c_{k+1}
//! ```
//!
//! (σa and σ′s per channel). Away from the transitions this is exactly the medium of the
//! layer; where transitions overlap (a layer thinner than w) it stays a convex combination of
//! the layers' media, so always valid.
//!
//! η and g of the object are those of the outermost layer, the medium at the surface (one η
//! per object, see [`PerTetMedia`]); the inner layers' η and g are not used by the diffusion
//! equation.

use glam::DVec3;

use super::error::VolumeError;
use super::field::{Coefficients, MediumField, TetSampling};
use super::per_tet::PerTetMedia;
use crate::mesh::{TetMesh, TriangleBvh};
use crate::optics::Medium;

/// One layer: its medium down to `max_depth_mm` below the surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Layer {
    /// Depth (mm) of the layer's lower boundary; the innermost layer extends beyond it
    /// (`f64::INFINITY` is accepted there).
    pub max_depth_mm: f64,
    /// The layer's medium.
    pub medium: Medium,
}

/// Media by depth below the surface, blended smoothly (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct Layers {
    layers: Vec<Layer>,
    coefficients: Vec<Coefficients>,
    blend_mm: f64,
}

impl Layers {
    /// Layers from the outermost in, as (max depth in mm, medium), blended over `blend_mm`.
    ///
    /// # Errors
    /// [`VolumeError::InvalidLayers`] for an empty list, or a max depth that is not > 0 and
    /// greater than the previous one (finite except for the innermost layer);
    /// [`VolumeError::InvalidMedium`] (`"layer"`) naming an invalid medium;
    /// [`VolumeError::InvalidParameter`] for a `blend_mm` that is not finite and ≥ 0.
    pub fn new(layers: &[(f64, Medium)], blend_mm: f64) -> Result<Self, VolumeError> {
        if layers.is_empty() {
            return Err(VolumeError::InvalidLayers { index: 0, reason: "at least one layer is needed".into() });
        }
        let mut previous = 0.0;
        for (index, &(depth, medium)) in layers.iter().enumerate() {
            medium.validate().map_err(|source| VolumeError::InvalidMedium { what: "layer", index, source })?;
            let innermost = index + 1 == layers.len();
            if !(depth > previous && (depth.is_finite() || innermost)) {
                return Err(VolumeError::InvalidLayers {
                    index,
                    reason: format!(
                        "max_depth_mm = {depth}: must be finite{} and greater than {previous} (the previous boundary, or 0)",
                        if innermost { " or infinite" } else { "" }
                    ),
                });
            }
            previous = depth;
        }
        if !(blend_mm.is_finite() && blend_mm >= 0.0) {
            return Err(VolumeError::InvalidParameter {
                field: "blend_mm",
                value: blend_mm,
                requirement: "must be finite and >= 0 (mm)",
            });
        }
        let layers: Vec<Layer> = layers.iter().map(|&(max_depth_mm, medium)| Layer { max_depth_mm, medium }).collect();
        let coefficients = layers.iter().map(|l| Coefficients::from(&l.medium)).collect();
        Ok(Self { layers, coefficients, blend_mm })
    }

    /// The layers, outermost first.
    #[must_use]
    pub fn layers(&self) -> &[Layer] {
        &self.layers
    }

    /// The blending width (mm).
    #[must_use]
    pub fn blend_mm(&self) -> f64 {
        self.blend_mm
    }

    /// The blended coefficients at `depth_mm` below the surface (see the module documentation).
    #[must_use]
    pub fn at_depth(&self, depth_mm: f64) -> Coefficients {
        let mut c = self.coefficients[0];
        for k in 0..self.layers.len() - 1 {
            let b = self.layers[k].max_depth_mm;
            let s = if self.blend_mm > 0.0 {
                let x = ((depth_mm - b) / self.blend_mm + 0.5).clamp(0.0, 1.0);
                x * x * (3.0 - 2.0 * x)
            } else if depth_mm > b {
                1.0
            } else {
                0.0
            };
            c = c.lerp(&self.coefficients[k + 1], s);
        }
        c
    }

    /// This depth profile bound to the surface of `mesh` (scene units, `mm_per_unit`
    /// millimetres each): a [`MediumField`] of positions.
    ///
    /// # Errors
    /// [`VolumeError::InvalidParameter`] for a `mm_per_unit` that is not finite and > 0;
    /// [`VolumeError::NoBoundary`] for a mesh without boundary faces.
    pub fn field(&self, mesh: &TetMesh, mm_per_unit: f64) -> Result<LayeredField<'_>, VolumeError> {
        if !(mm_per_unit.is_finite() && mm_per_unit > 0.0) {
            return Err(VolumeError::InvalidParameter {
                field: "mm_per_unit",
                value: mm_per_unit,
                requirement: "must be finite and > 0 (millimetres per scene unit)",
            });
        }
        if mesh.boundary_faces().is_empty() {
            return Err(VolumeError::NoBoundary);
        }
        let triangles: Vec<[u32; 3]> = mesh.boundary_faces().iter().map(|f| f.vertices).collect();
        let surface = TriangleBvh::from_indexed(mesh.positions(), &triangles);
        Ok(LayeredField { layers: self, surface, mm_per_unit })
    }

    /// The per-tet media of `mesh`: [`Layers::field`] sampled with `sampling`
    /// ([`TetSampling::Centroid`]: the layer at the depth of the tet's centroid;
    /// [`TetSampling::FivePoint`]: the mean over five points, which resolves layers thinner
    /// than the tets better). η and g are the outermost layer's.
    ///
    /// # Errors
    /// Those of [`Layers::field`].
    pub fn per_tet(&self, mesh: &TetMesh, mm_per_unit: f64, sampling: TetSampling) -> Result<PerTetMedia, VolumeError> {
        let field = self.field(mesh, mm_per_unit)?;
        let outer = &self.layers[0].medium;
        PerTetMedia::from_field(mesh, &field, outer.eta, outer.g, sampling)
    }
}

/// [`Layers`] bound to a mesh surface: coefficients by depth below it.
#[derive(Debug, Clone)]
pub struct LayeredField<'a> {
    layers: &'a Layers,
    surface: TriangleBvh,
    mm_per_unit: f64,
}

impl LayeredField<'_> {
    /// Depth of `p` below the surface in mm: the distance to the closest boundary face times
    /// `mm_per_unit` (for points inside the mesh; outside, the distance to the surface).
    #[must_use]
    pub fn depth_mm(&self, p: DVec3) -> f64 {
        // The BVH is not empty (checked in `Layers::field`).
        self.surface.closest_point(p).map_or(0.0, |s| s.distance) * self.mm_per_unit
    }
}

impl MediumField for LayeredField<'_> {
    fn coefficients(&self, p: DVec3) -> Coefficients {
        self.layers.at_depth(self.depth_mm(p))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn media() -> [Medium; 3] {
        let skin = Medium::preset("skin1").unwrap();
        [
            skin,
            Medium { sigma_a: [0.1, 0.2, 0.3], ..skin },
            Medium { sigma_a: [0.01, 0.02, 0.03], sigma_s_prime: [1.0; 3], eta: 1.5, g: 0.9 },
        ]
    }

    #[test]
    fn profile_is_piecewise_constant_with_smooth_transitions() {
        let [a, b, c] = media();
        let layers = Layers::new(&[(0.5, a), (3.0, b), (f64::INFINITY, c)], 0.2).unwrap();
        assert_eq!(layers.at_depth(0.0), Coefficients::from(&a));
        assert_eq!(layers.at_depth(0.39), Coefficients::from(&a));
        assert_eq!(layers.at_depth(0.61), Coefficients::from(&b));
        assert_eq!(layers.at_depth(2.89), Coefficients::from(&b));
        assert_eq!(layers.at_depth(3.11), Coefficients::from(&c));
        assert_eq!(layers.at_depth(1e6), Coefficients::from(&c));
        // Mid-transition: the average.
        let mid = layers.at_depth(0.5);
        assert!((mid.sigma_a[2] - (a.sigma_a[2] + b.sigma_a[2]) / 2.0).abs() < 1e-15);
        // Monotone through the transition.
        let mut last = layers.at_depth(0.35).sigma_a[0];
        for i in 0..=40 {
            let v = layers.at_depth(0.4 + 0.005 * i as f64).sigma_a[0];
            assert!(v >= last);
            last = v;
        }
        let sharp = Layers::new(&[(0.5, a), (1.0, b)], 0.0).unwrap();
        assert_eq!(sharp.at_depth(0.5), Coefficients::from(&a));
        assert_eq!(sharp.at_depth(0.500_001), Coefficients::from(&b));
    }

    #[test]
    fn overlapping_transitions_stay_convex() {
        let [a, b, c] = media();
        let layers = Layers::new(&[(1.0, a), (1.1, b), (2.0, c)], 1.0).unwrap();
        for i in 0..100 {
            let v = layers.at_depth(i as f64 * 0.03);
            for ch in 0..3 {
                let lo = a.sigma_a[ch].min(b.sigma_a[ch]).min(c.sigma_a[ch]);
                let hi = a.sigma_a[ch].max(b.sigma_a[ch]).max(c.sigma_a[ch]);
                assert!(v.sigma_a[ch] >= lo - 1e-15 && v.sigma_a[ch] <= hi + 1e-15);
            }
            assert!(v.validate().is_ok());
        }
    }

    #[test]
    fn invalid_layers_are_named() {
        let [a, b, _] = media();
        assert!(matches!(Layers::new(&[], 0.1), Err(VolumeError::InvalidLayers { index: 0, .. })));
        assert!(matches!(Layers::new(&[(0.0, a)], 0.1), Err(VolumeError::InvalidLayers { index: 0, .. })));
        assert!(matches!(Layers::new(&[(1.0, a), (1.0, b)], 0.1), Err(VolumeError::InvalidLayers { index: 1, .. })));
        assert!(matches!(Layers::new(&[(f64::INFINITY, a), (2.0, b)], 0.1), Err(VolumeError::InvalidLayers { index: 0, .. })));
        assert!(matches!(Layers::new(&[(1.0, a), (f64::NAN, b)], 0.1), Err(VolumeError::InvalidLayers { index: 1, .. })));
        let bad = Medium { g: 1.0, ..b };
        assert!(matches!(
            Layers::new(&[(1.0, a), (2.0, bad)], 0.1),
            Err(VolumeError::InvalidMedium { what: "layer", index: 1, .. })
        ));
        assert!(matches!(Layers::new(&[(1.0, a)], -0.1), Err(VolumeError::InvalidParameter { field: "blend_mm", .. })));
    }

    #[test]
    fn depth_is_the_distance_to_the_boundary_in_mm() {
        // The cube [0, 1]³ as 6 Kuhn tets, 1 unit = 4 mm.
        let corners: Vec<DVec3> =
            (0..8).map(|d| DVec3::new((d & 1) as f64, ((d >> 1) & 1) as f64, ((d >> 2) & 1) as f64)).collect();
        let tets = vec![[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]];
        let mesh = TetMesh::new(corners, tets, vec![]).unwrap();
        let [a, b, c] = media();
        let layers = Layers::new(&[(0.5, a), (1.5, b), (f64::INFINITY, c)], 0.0).unwrap();
        let field = layers.field(&mesh, 4.0).unwrap();
        assert!((field.depth_mm(DVec3::splat(0.5)) - 2.0).abs() < 1e-12);
        assert!((field.depth_mm(DVec3::new(0.1, 0.5, 0.4)) - 0.4).abs() < 1e-12);
        assert_eq!(field.coefficients(DVec3::splat(0.5)), Coefficients::from(&c));
        assert_eq!(field.coefficients(DVec3::new(0.3, 0.5, 0.5)), Coefficients::from(&b));
        assert!(matches!(layers.field(&mesh, 0.0), Err(VolumeError::InvalidParameter { field: "mm_per_unit", .. })));
        let media = layers.per_tet(&mesh, 4.0, TetSampling::Centroid).unwrap();
        // η and g from the outermost layer (c has η = 1.5, g = 0.9).
        assert_eq!((media.eta(), media.g()), (a.eta, a.g));
        // Every Kuhn tet's centroid is a permutation of (1/4, 1/2, 3/4): 1/4 unit = 1 mm deep,
        // in layer b.
        assert!(media.coefficients().iter().all(|&v| v == Coefficients::from(&b)));
    }
}
