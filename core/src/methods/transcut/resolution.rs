//! TransCut's validity limit: how well the tet mesh resolves the medium's diffusion length.
//!
//! Near a lit surface the fluence falls off as `exp(−σtr d)`, `σtr = √(3 σa σ′t)`. Linear
//! elements of size `h` follow that boundary layer only while `σtr · h` is small: coarser, and
//! the surface nodes average the layer away, so the radiance comes out too dark and, far
//! beyond, negative and clamped to zero. The measure is `σtr · h` per channel, with `σtr` the
//! largest over the media of the tets at the surface and `h` the mean boundary edge length in
//! mm. A bake above [`MAX_RESOLUTION`] is refused with [`SceneError::Unresolved`], which names
//! the tet count (the spacing scales as `N^(−1/3)`) and the object scale that would resolve it.

use crate::mesh::TetMesh;
use crate::optics::Medium;
use crate::scene::SceneError;

/// The largest `σtr · h` (per channel) TransCut bakes: above it the radiance of the uniformly lit
/// sphere is off by more than about 25% (docs/benchmarks.md, "Resolution of the medium").
pub const MAX_RESOLUTION: f64 = 3.0;

/// The mean length, in mm, of the edges of the tet mesh's boundary triangles (each triangle's
/// three edges, so an edge shared by two triangles counts twice, like every other).
#[must_use]
pub(crate) fn surface_spacing_mm(mesh: &TetMesh, mm_per_unit: f64) -> f64 {
    let faces = mesh.boundary_faces();
    if faces.is_empty() {
        return 0.0;
    }
    let p = mesh.positions();
    let total: f64 = faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.vertices.map(|v| p[v as usize]);
            (b - a).length() + (c - b).length() + (a - c).length()
        })
        .sum();
    mm_per_unit * total / (3 * faces.len()) as f64
}

/// The largest σtr (mm⁻¹) per channel over the media of the tets that own a boundary face;
/// `materials[t]` indexes `media`.
#[must_use]
pub(crate) fn surface_sigma_tr(mesh: &TetMesh, media: &[Medium]) -> [f64; 3] {
    let materials = mesh.materials();
    let mut used = vec![false; media.len()];
    for f in mesh.boundary_faces() {
        if let Some(u) = materials.get(f.tet as usize).and_then(|&m| used.get_mut(m as usize)) {
            *u = true;
        }
    }
    media.iter().zip(&used).filter(|(_, &u)| u).fold([0.0; 3], |acc, (m, _)| {
        let s = m.sigma_tr();
        [acc[0].max(s[0]), acc[1].max(s[1]), acc[2].max(s[2])]
    })
}

/// `σtr · h` per channel.
#[must_use]
pub(crate) fn resolution(sigma_tr: [f64; 3], spacing_mm: f64) -> [f64; 3] {
    sigma_tr.map(|s| s * spacing_mm)
}

/// What would bring the worst channel's `resolution` down to `target`: the tet count (`tets`
/// now; the spacing scales as `N^(−1/3)`, so the count as the cube of the ratio) and the object
/// scale factor (shrinking the object shrinks `h` in mm at the same count).
#[must_use]
pub(crate) fn remedy(worst: f64, target: f64, tets: usize) -> (f64, f64) {
    let ratio = worst / target;
    ((tets as f64 * ratio.powi(3)).ceil(), 1.0 / ratio)
}

/// The bake's resolution, or [`SceneError::Unresolved`] for the first channel above
/// [`MAX_RESOLUTION`] (the worst, on ties the first).
///
/// # Errors
/// [`SceneError::Unresolved`] naming the object, the channel, `σtr · h`, the bound, the spacing
/// and the tet count or scale that would resolve it.
pub(crate) fn check(
    index: usize,
    name: &str,
    resolution: [f64; 3],
    spacing_mm: f64,
    tets: usize,
) -> Result<[f64; 3], SceneError> {
    let (channel, worst) = (0..3).fold((0, resolution[0]), |(c, w), k| if resolution[k] > w { (k, resolution[k]) } else { (c, w) });
    // Written so that a NaN is refused too.
    if worst <= MAX_RESOLUTION {
        return Ok(resolution);
    }
    // Aim a little below the bound, so that the count it names is enough.
    let (tets_needed, scale) = remedy(worst, 0.9 * MAX_RESOLUTION, tets);
    Err(SceneError::Unresolved {
        index,
        name: name.to_owned(),
        channel: ["red", "green", "blue"][channel],
        sigma_tr_h: worst,
        bound: MAX_RESOLUTION,
        spacing_mm,
        tets,
        tets_needed,
        scale,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// One regular tet with edge `e`: every boundary edge has length `e`.
    fn regular_tet(e: f64) -> TetMesh {
        let p = vec![
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(1.0, -1.0, -1.0),
            DVec3::new(-1.0, 1.0, -1.0),
            DVec3::new(-1.0, -1.0, 1.0),
        ]
        .into_iter()
        .map(|x| x * e / 8f64.sqrt())
        .collect();
        TetMesh::new(p, vec![[0, 1, 2, 3]], vec![0]).unwrap()
    }

    #[test]
    fn the_spacing_is_the_mean_boundary_edge_in_mm() {
        let m = regular_tet(2.0);
        assert!((surface_spacing_mm(&m, 1.0) - 2.0).abs() < 1e-12);
        assert!((surface_spacing_mm(&m, 1000.0) - 2000.0).abs() < 1e-9);
    }

    #[test]
    fn sigma_tr_is_the_largest_of_the_surface_media() {
        let m = regular_tet(1.0);
        let marble = Medium::new([0.0021, 0.0041, 0.0071], [2.19, 2.62, 3.00], 1.3, 0.0).unwrap();
        // σtr = √(3 σa (σa + σ′s)) by hand: blue √(3 · 0.0071 · 3.0071) = √0.064051 = 0.253083.
        let s = surface_sigma_tr(&m, &[marble]);
        assert!((s[2] - 0.253_083).abs() < 1e-6, "{s:?}");
        // A medium no surface tet uses does not count.
        let dense = Medium::new([1.0; 3], [1.0; 3], 1.3, 0.0).unwrap();
        assert_eq!(surface_sigma_tr(&m, &[marble, dense]), s);
    }

    #[test]
    fn above_the_bound_the_error_names_channel_count_and_scale() {
        assert_eq!(check(0, "a", [0.1, 0.2, MAX_RESOLUTION], 1.0, 100).unwrap(), [0.1, 0.2, MAX_RESOLUTION]);
        // Blue at twice the bound: (2 / 0.9)³ = 10.97× the tets, or 0.45× the size.
        let e = check(2, "statue", [1.0, 2.0 * MAX_RESOLUTION, 0.5], 216.0, 5000).unwrap_err();
        let SceneError::Unresolved { channel, sigma_tr_h, tets_needed, scale, .. } = &e else { panic!("{e}") };
        assert_eq!((*channel, *sigma_tr_h), ("green", 2.0 * MAX_RESOLUTION));
        assert_eq!(*tets_needed, (5000.0 * (2.0f64 / 0.9).powi(3)).ceil());
        assert!((scale - 0.45).abs() < 1e-12);
        let text = e.to_string();
        for part in ["object 2 (statue)", "green", "216", "5000", "54870"] {
            assert!(text.contains(part), "{part} in {text}");
        }
        assert!(check(0, "a", [f64::NAN, 0.0, 0.0], 1.0, 100).is_err());
    }
}
