//! Painting (TransCut §5.2): a 3D stroke blends a medium into the tets of the ORIGINAL mesh near
//! it, with a Gaussian influence by the distance from each tet's centre to the closest stroke
//! point. Only the weights and the new coefficients are computed here (pure);
//! [`super::Editor::paint`] refills the matrix rows of the affected vertices and re-solves.

use glam::DVec3;
use rayon::prelude::*;

use super::error::EditError;
use crate::optics::Medium;
use crate::volume::{Coefficients, PerTetMedia};

/// Tets whose weight is below this are untouched (the Gaussian's tail).
pub const MIN_WEIGHT: f64 = 1e-3;

/// A 3D paint stroke (TransCut §5.2): points on the current surface (world space), a Gaussian
/// influence w(d) = strength · exp(−d² / (2 radius²)) by the distance d from a tet's centroid (at
/// rest placement) to the closest stroke point; tets with w < 1e-3 are untouched; a touched
/// tet's σa, σ′s become (1 − w)·old + w·medium.
#[derive(Debug, Clone, PartialEq)]
pub struct PaintStroke {
    pub points: Vec<DVec3>,
    pub radius: f64,
    pub medium: Medium,
    pub strength: f64,
}

impl PaintStroke {
    /// Checks the stroke for an object of refractive index `eta` and anisotropy `g`.
    ///
    /// # Errors
    /// [`EditError::InvalidStroke`] naming the fault: no points, a non-finite point, a radius
    /// that is not finite and > 0, a strength outside [0, 1], an invalid medium, or a medium
    /// whose η or g differs from the object's (one η per object).
    pub fn validate(&self, eta: f64, g: f64) -> Result<(), EditError> {
        let bad = |s: String| Err(EditError::InvalidStroke(s));
        if self.points.is_empty() {
            return bad("the stroke has no points".into());
        }
        if let Some(k) = self.points.iter().position(|p| !p.is_finite()) {
            return bad(format!("stroke point {k} = {} is not finite", self.points[k]));
        }
        if !(self.radius.is_finite() && self.radius > 0.0) {
            return bad(format!("radius {}: must be finite and > 0", self.radius));
        }
        if !(0.0..=1.0).contains(&self.strength) {
            return bad(format!("strength {}: must lie in [0, 1]", self.strength));
        }
        if let Err(e) = self.medium.validate() {
            return bad(format!("medium: {e}"));
        }
        if self.medium.eta != eta || self.medium.g != g {
            return bad(format!(
                "the medium has eta = {}, g = {} but the object has eta = {eta}, g = {g} (one eta per object)",
                self.medium.eta, self.medium.g
            ));
        }
        Ok(())
    }

    /// The influence w(d) = strength · exp(−d²/(2 radius²)) at distance `d`.
    #[must_use]
    pub fn weight(&self, d: f64) -> f64 {
        self.strength * (-d * d / (2.0 * self.radius * self.radius)).exp()
    }

    /// The distance beyond which w < [`MIN_WEIGHT`]: radius · √(2 ln(strength / 10⁻³)) (0 when
    /// the strength itself is below the threshold).
    #[must_use]
    pub fn reach(&self) -> f64 {
        if self.strength < MIN_WEIGHT {
            0.0
        } else {
            self.radius * (2.0 * (self.strength / MIN_WEIGHT).ln()).sqrt()
        }
    }

    /// The touched tets and their weights: (tet, w) for every centroid whose weight by the
    /// distance to the closest stroke point is ≥ [`MIN_WEIGHT`], in increasing tet order.
    /// Centroids outside the stroke's bounding box grown by [`Self::reach`] are skipped at once.
    #[must_use]
    pub fn weights(&self, centroids: &[DVec3]) -> Vec<(u32, f64)> {
        let reach = self.reach();
        if reach == 0.0 {
            return Vec::new();
        }
        let lo = self.points.iter().fold(DVec3::INFINITY, |a, &p| a.min(p)) - DVec3::splat(reach);
        let hi = self.points.iter().fold(DVec3::NEG_INFINITY, |a, &p| a.max(p)) + DVec3::splat(reach);
        centroids
            .par_iter()
            .enumerate()
            .filter(|(_, c)| c.cmpge(lo).all() && c.cmple(hi).all())
            .filter_map(|(t, c)| {
                let d2 = self.points.iter().map(|p| p.distance_squared(*c)).fold(f64::INFINITY, f64::min);
                let w = self.weight(d2.sqrt());
                (w >= MIN_WEIGHT).then_some((t as u32, w))
            })
            .collect()
    }

    /// The new coefficients of the touched tets: (1 − w)·old + w·medium for each (tet, w) of
    /// [`Self::weights`] (a convex combination of valid coefficients, so valid).
    #[must_use]
    pub fn changes(&self, media: &PerTetMedia, centroids: &[DVec3]) -> Vec<(u32, Coefficients)> {
        let new = Coefficients::from(&self.medium);
        self.weights(centroids).into_iter().map(|(t, w)| (t, media.coefficients()[t as usize].lerp(&new, w))).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stroke() -> PaintStroke {
        PaintStroke { points: vec![DVec3::ZERO, DVec3::X], radius: 0.5, medium: Medium::preset("marble").unwrap(), strength: 0.8 }
    }

    #[test]
    fn weights_are_the_gaussian_of_the_closest_point_and_cut_at_the_threshold() {
        let s = stroke();
        let centroids = vec![
            DVec3::new(0.0, 0.3, 0.0), // closest: point 0, d = 0.3
            DVec3::new(1.2, 0.0, 0.0), // closest: point 1, d = 0.2
            DVec3::new(0.5, 0.0, 2.0), // far: d ≈ 2.06, w ≈ 0.8 e^{-8.5} < 1e-3
            DVec3::new(0.5, 1.5, 0.0), // d = √(0.25 + 2.25) = 1.58: w = 0.8 e^{-5} ≈ 5.4e-3
        ];
        let w = s.weights(&centroids);
        assert_eq!(w.iter().map(|x| x.0).collect::<Vec<_>>(), vec![0, 1, 3]);
        assert!((w[0].1 - 0.8 * (-0.09f64 / 0.5).exp()).abs() < 1e-15);
        assert!((w[1].1 - 0.8 * (-0.04f64 / 0.5).exp()).abs() < 1e-15);
        assert!((w[2].1 - 0.8 * (-2.5f64 / 0.5).exp()).abs() < 1e-15);
        // The reach is where the weight equals the threshold.
        assert!((s.weight(s.reach()) - MIN_WEIGHT).abs() < 1e-15);
    }

    #[test]
    fn invalid_strokes_are_named() {
        let m = Medium::preset("marble").unwrap();
        let ok = stroke();
        assert!(ok.validate(m.eta, m.g).is_ok());
        let e = PaintStroke { points: vec![DVec3::ZERO, DVec3::new(f64::NAN, 0.0, 0.0)], ..ok.clone() }
            .validate(m.eta, m.g)
            .unwrap_err();
        assert!(matches!(e, EditError::InvalidStroke(ref s) if s.contains("point 1")), "{e}");
        assert!(
            matches!(PaintStroke { radius: -1.0, ..ok.clone() }.validate(m.eta, m.g), Err(EditError::InvalidStroke(ref s)) if s.contains("radius"))
        );
        assert!(matches!(PaintStroke { points: vec![], ..ok.clone() }.validate(m.eta, m.g), Err(EditError::InvalidStroke(_))));
        assert!(matches!(PaintStroke { strength: 1.5, ..ok.clone() }.validate(m.eta, m.g), Err(EditError::InvalidStroke(_))));
        assert!(matches!(ok.validate(1.3, m.g), Err(EditError::InvalidStroke(ref s)) if s.contains("eta")));
    }
}
