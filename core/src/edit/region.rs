//! Material edits: where ([`Region`]) and how ([`MediumOp`]) the σa and σ′s of the ORIGINAL
//! mesh's tets change. Selection and the new values are computed here, purely;
//! [`super::Editor::edit_medium`] applies them to the pieces and re-solves.

use glam::DVec3;
use rayon::prelude::*;

use super::error::EditError;
use crate::mesh::{TetMesh, TriangleBvh};
use crate::optics::Medium;
use crate::volume::{Coefficients, PerTetMedia, VolumeError};

/// Where a material edit applies. Coordinates in world space, scene units (at the piece's rest
/// placement = where the original object was baked); depths in millimetres.
#[derive(Debug, Clone, PartialEq)]
pub enum Region {
    /// Every tet of the original mesh.
    All,
    /// One flag per tet of the ORIGINAL mesh.
    Mask(Vec<bool>),
    /// Tets whose centroid lies inside (distance to `center` ≤ `radius`).
    Sphere { center: DVec3, radius: f64 },
    /// Tets whose centroid lies between `min_mm` and `max_mm` (inclusive) below the ORIGINAL
    /// surface: the distance from the centroid to the closest boundary triangle of the original
    /// mesh, in millimetres (the depth of [`crate::volume::Layers`]).
    Depth { min_mm: f64, max_mm: f64 },
}

/// How the coefficients of the selected tets change.
#[derive(Debug, Clone, PartialEq)]
pub enum MediumOp {
    /// σa, σ′s replaced (η, g must match the object: one η per object).
    Assign(Medium),
    /// σa, σ′s replaced, the object's η and g kept.
    Set { sigma_a: [f64; 3], sigma_s: [f64; 3] },
    /// σa, σ′s multiplied per channel (factors finite, ≥ 0; the result must stay valid).
    Scale { sigma_a: [f64; 3], sigma_s: [f64; 3] },
    /// σa, σ′s added per channel (finite; the result must stay valid).
    Add { sigma_a: [f64; 3], sigma_s: [f64; 3] },
}

/// A material edit: an operation applied inside a region.
#[derive(Debug, Clone, PartialEq)]
pub struct MediumEdit {
    pub region: Region,
    pub op: MediumOp,
}

impl Region {
    /// The selected tets of `original` (rest space), increasing ids. `centroids` are the
    /// original tets' centroids.
    ///
    /// # Errors
    /// [`EditError::InvalidRegion`] for a mask whose length is not the original tet count, a
    /// sphere with a non-finite centre or a radius that is not finite and ≥ 0, a depth range
    /// that is NaN, negative or empty (min > max).
    pub fn select(&self, original: &TetMesh, centroids: &[DVec3], mm_per_unit: f64) -> Result<Vec<u32>, EditError> {
        let pick = |f: &(dyn Fn(usize) -> bool + Sync)| -> Vec<u32> {
            (0..centroids.len() as u32).into_par_iter().filter(|&t| f(t as usize)).collect()
        };
        match self {
            Self::All => Ok((0..centroids.len() as u32).collect()),
            Self::Mask(mask) => {
                if mask.len() != centroids.len() {
                    return Err(EditError::InvalidRegion(format!(
                        "the mask has {} flags but the original mesh has {} tets",
                        mask.len(),
                        centroids.len()
                    )));
                }
                Ok(pick(&|t| mask[t]))
            }
            Self::Sphere { center, radius } => {
                if !center.is_finite() {
                    return Err(EditError::InvalidRegion(format!("sphere centre {center} is not finite")));
                }
                if !(radius.is_finite() && *radius >= 0.0) {
                    return Err(EditError::InvalidRegion(format!("sphere radius {radius}: must be finite and >= 0")));
                }
                let r2 = radius * radius;
                Ok(pick(&|t| centroids[t].distance_squared(*center) <= r2))
            }
            Self::Depth { min_mm, max_mm } => {
                if !(*min_mm >= 0.0 && max_mm >= min_mm) {
                    return Err(EditError::InvalidRegion(format!(
                        "depth range [{min_mm}, {max_mm}] mm: need 0 <= min_mm <= max_mm"
                    )));
                }
                let depth = depth_below_surface(original, mm_per_unit)?;
                Ok(pick(&|t| {
                    let d = depth(centroids[t]);
                    d >= *min_mm && d <= *max_mm
                }))
            }
        }
    }
}

/// Depth (mm) of a point below the surface of `mesh`: its distance to the closest boundary
/// triangle times `mm_per_unit`, as [`crate::volume::Layers`] defines it.
fn depth_below_surface(mesh: &TetMesh, mm_per_unit: f64) -> Result<impl Fn(DVec3) -> f64 + Sync, EditError> {
    if mesh.boundary_faces().is_empty() {
        return Err(EditError::Volume(VolumeError::NoBoundary));
    }
    let triangles: Vec<[u32; 3]> = mesh.boundary_faces().iter().map(|f| f.vertices).collect();
    let surface = TriangleBvh::from_indexed(mesh.positions(), &triangles);
    Ok(move |p: DVec3| surface.closest_point(p).map_or(0.0, |s| s.distance) * mm_per_unit)
}

impl MediumOp {
    /// Checks the operation against the object's η and g.
    ///
    /// # Errors
    /// [`EditError::Medium`] for an invalid assigned medium or coefficients;
    /// [`EditError::InvalidOptions`] for
    /// an assigned η or g other than the object's, or a factor / term that is not finite (or a
    /// negative factor).
    pub fn validate(&self, eta: f64, g: f64) -> Result<(), EditError> {
        match self {
            Self::Assign(m) => {
                m.validate()?;
                if m.eta != eta || m.g != g {
                    return Err(EditError::InvalidOptions(format!(
                        "the assigned medium has eta = {}, g = {} but the object has eta = {eta}, g = {g} \
                         (one eta per object)",
                        m.eta, m.g
                    )));
                }
                Ok(())
            }
            Self::Set { sigma_a, sigma_s } => Ok(Coefficients::new(*sigma_a, *sigma_s).validate()?),
            Self::Scale { sigma_a, sigma_s } => check_terms("scale factor", sigma_a, sigma_s, true),
            Self::Add { sigma_a, sigma_s } => check_terms("added value", sigma_a, sigma_s, false),
        }
    }

    /// The new coefficients of a tet that had `old` (not validated).
    #[must_use]
    pub fn apply(&self, old: &Coefficients) -> Coefficients {
        let f = |a: [f64; 3], b: [f64; 3], op: fn(f64, f64) -> f64| [0, 1, 2].map(|c| op(a[c], b[c]));
        match self {
            Self::Assign(m) => Coefficients::from(m),
            Self::Set { sigma_a, sigma_s } => Coefficients::new(*sigma_a, *sigma_s),
            Self::Scale { sigma_a, sigma_s } => {
                Coefficients::new(f(old.sigma_a, *sigma_a, |x, y| x * y), f(old.sigma_s_prime, *sigma_s, |x, y| x * y))
            }
            Self::Add { sigma_a, sigma_s } => {
                Coefficients::new(f(old.sigma_a, *sigma_a, |x, y| x + y), f(old.sigma_s_prime, *sigma_s, |x, y| x + y))
            }
        }
    }
}

fn check_terms(what: &str, sigma_a: &[f64; 3], sigma_s: &[f64; 3], non_negative: bool) -> Result<(), EditError> {
    for (name, v) in [("sigma_a", sigma_a), ("sigma_s", sigma_s)] {
        if let Some(c) = v.iter().position(|x| !x.is_finite() || (non_negative && *x < 0.0)) {
            return Err(EditError::InvalidOptions(format!(
                "{what} {name}[{c}] = {}: must be finite{}",
                v[c],
                if non_negative { " and >= 0" } else { "" }
            )));
        }
    }
    Ok(())
}

/// The new coefficients of `tets` (original ids) under `op`, each validated: the changes an
/// edit makes, as (original tet, new coefficients), in the order of `tets`.
///
/// # Errors
/// [`EditError::Volume`] ([`VolumeError::InvalidTetMedium`]) naming the first tet whose new
/// coefficients are invalid (e.g. an `Add` that makes σa negative).
pub fn changes(media: &PerTetMedia, tets: &[u32], op: &MediumOp) -> Result<Vec<(u32, Coefficients)>, EditError> {
    let out: Vec<(u32, Coefficients)> = tets.par_iter().map(|&t| (t, op.apply(&media.coefficients()[t as usize]))).collect();
    if let Some((tet, source)) = out.par_iter().find_map_first(|(t, c)| c.validate().err().map(|e| (*t as usize, e))) {
        return Err(EditError::Volume(VolumeError::InvalidTetMedium { tet, source }));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube() -> TetMesh {
        let corners: Vec<DVec3> =
            (0..8).map(|d| DVec3::new((d & 1) as f64, ((d >> 1) & 1) as f64, ((d >> 2) & 1) as f64)).collect();
        let tets = vec![[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]];
        TetMesh::new(corners, tets, vec![]).unwrap()
    }

    fn centroids(m: &TetMesh) -> Vec<DVec3> {
        (0..m.tet_count()).map(|t| m.tet_positions(t).iter().sum::<DVec3>() / 4.0).collect()
    }

    #[test]
    fn regions_select_by_mask_sphere_and_depth() {
        let m = cube();
        let c = centroids(&m);
        assert_eq!(Region::All.select(&m, &c, 1.0).unwrap(), vec![0, 1, 2, 3, 4, 5]);
        let mask = vec![true, false, false, true, false, true];
        assert_eq!(Region::Mask(mask).select(&m, &c, 1.0).unwrap(), vec![0, 3, 5]);
        // Centroids are permutations of (1/4, 1/2, 3/4).
        let near_x = Region::Sphere { center: DVec3::new(1.0, 0.5, 0.5), radius: 0.45 };
        let picked = near_x.select(&m, &c, 1.0).unwrap();
        for (t, centroid) in c.iter().enumerate() {
            assert_eq!(picked.contains(&(t as u32)), centroid.distance(DVec3::new(1.0, 0.5, 0.5)) <= 0.45);
        }
        assert!(!picked.is_empty() && picked.len() < 6);
        // Every centroid is 1/4 unit deep: 1 mm at 4 mm per unit.
        assert_eq!(Region::Depth { min_mm: 0.9, max_mm: 1.1 }.select(&m, &c, 4.0).unwrap().len(), 6);
        assert!(Region::Depth { min_mm: 1.1, max_mm: 5.0 }.select(&m, &c, 4.0).unwrap().is_empty());
    }

    #[test]
    fn invalid_regions_and_ops_are_named() {
        let m = cube();
        let c = centroids(&m);
        let e = Region::Mask(vec![true; 5]).select(&m, &c, 1.0).unwrap_err();
        assert!(matches!(e, EditError::InvalidRegion(ref s) if s.contains("5 flags") && s.contains("6 tets")), "{e}");
        let e = Region::Sphere { center: DVec3::ZERO, radius: -1.0 }.select(&m, &c, 1.0).unwrap_err();
        assert!(matches!(e, EditError::InvalidRegion(ref s) if s.contains("radius")), "{e}");
        assert!(matches!(
            Region::Sphere { center: DVec3::NAN, radius: 1.0 }.select(&m, &c, 1.0),
            Err(EditError::InvalidRegion(_))
        ));
        assert!(matches!(Region::Depth { min_mm: 2.0, max_mm: 1.0 }.select(&m, &c, 1.0), Err(EditError::InvalidRegion(_))));
        assert!(matches!(Region::Depth { min_mm: f64::NAN, max_mm: 1.0 }.select(&m, &c, 1.0), Err(EditError::InvalidRegion(_))));
        let marble = Medium::preset("marble").unwrap();
        assert!(MediumOp::Assign(marble).validate(marble.eta, marble.g).is_ok());
        assert!(matches!(MediumOp::Assign(marble).validate(1.3, marble.g), Err(EditError::InvalidOptions(_))));
        let scale = MediumOp::Scale { sigma_a: [1.0, -1.0, 1.0], sigma_s: [1.0; 3] };
        assert!(matches!(scale.validate(1.5, 0.0), Err(EditError::InvalidOptions(ref s)) if s.contains("sigma_a[1]")));
    }

    #[test]
    fn ops_scale_add_assign_and_reject_invalid_results() {
        let m = cube();
        let marble = Medium::preset("marble").unwrap();
        let media = PerTetMedia::uniform(&m, &marble).unwrap();
        let scale = MediumOp::Scale { sigma_a: [2.0, 1.0, 0.5], sigma_s: [1.0, 3.0, 1.0] };
        let out = changes(&media, &[1, 4], &scale).unwrap();
        assert_eq!(out.len(), 2);
        assert_eq!(out[0].0, 1);
        assert_eq!(out[0].1.sigma_a, [2.0 * marble.sigma_a[0], marble.sigma_a[1], 0.5 * marble.sigma_a[2]]);
        assert_eq!(out[0].1.sigma_s_prime[1], 3.0 * marble.sigma_s_prime[1]);
        let add = MediumOp::Add { sigma_a: [-1.0, 0.0, 0.0], sigma_s: [0.0; 3] };
        let e = changes(&media, &[2, 3], &add).unwrap_err();
        assert!(matches!(e, EditError::Volume(VolumeError::InvalidTetMedium { tet: 2, .. })), "{e}");
    }
}
