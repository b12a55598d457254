//! TransCut's validity limit: how well the tet mesh resolves the medium's diffusion length.
//!
//! Near a lit surface the fluence falls off as `exp(−σtr d)`, `σtr = √(3 σa σ′t)`. Linear
//! elements of size `h` follow that boundary layer only while `σtr · h` is small: coarser, and
//! the surface nodes average the layer away, so the radiance comes out too dark and, far
//! beyond, negative and clamped to zero. The measure reported is `σtr · h` per channel, with
//! `σtr` the largest over the media of the tets at the surface and `h` the mean boundary edge
//! length in mm.
//!
//! How much of the fluence error reaches the radiance depends on the albedo: eq. 3 subtracts
//! `4q/(1 + Fdr)` from `(1 + 1/A) φ`, so a relative error in φ is multiplied by
//! [`amplification`] (1.3 for marble, 4 for skin's blue). Measured on the uniformly lit sphere
//! (docs/benchmarks.md, "Resolution of the medium"), the radiance error is about
//! `0.01 (amp · σtr h)²` up to 30%, so a channel's bound is `σtr · h ≤ MAX_RESOLUTION / amp`
//! (amp capped at [`MAX_AMPLIFICATION`]). A mesh above it is refused with [`Unresolved`],
//! which names the tet count (the spacing scales as `N^(−1/3)`) and the object scale that would
//! resolve it: the bake as `SceneError::Unresolved`, a medium edit or paint stroke that makes
//! the surface medium too dense for the mesh as `EditError::Unresolved`.

use super::system::Discretization;
use crate::mesh::TetMesh;
use crate::optics::{a_coefficient, fdr, Medium};

/// The largest `amp · σtr · h` a channel may have with TransCut's assembly (and the fitting
/// alone, and the consistent FEM): at it the uniformly lit sphere's radiance is about 25% too
/// dark; beyond it the error grows to 50–90% and then to zero radiance.
pub const MAX_RESOLUTION: f64 = 5.0;

/// The largest `amp · σtr · h` for `discretization`: [`MAX_RESOLUTION`], or twice it for
/// [`Discretization::FittedLayer`], whose boundary rows are exact for the layer. Measured for
/// it at about twice the bound (skin1's blue, σtr h 2.0–3.1, amp 4): the uniformly lit 10 mm
/// sphere 1.9–4.6% RMS off its closed form, the sun-lit one (a terminator across it) 4.6–4.7%
/// relative L2 off a 4M-tet bake, where the fitting alone is 32–58% and the paper's 51–75% off
/// (`docs/benchmarks.md`, "The boundary layer's absorption").
#[must_use]
pub fn max_resolution(discretization: Discretization) -> f64 {
    match discretization {
        Discretization::FittedLayer => 2.0 * MAX_RESOLUTION,
        _ => MAX_RESOLUTION,
    }
}

/// The amplification used in a channel's bound is capped here, so that a channel whose
/// diffusion radiance is (nearly) negative whatever the mesh (albedo below about 0.1, where
/// eq. 3 itself gives Lo ≤ 0) still has the bound `MAX_RESOLUTION / MAX_AMPLIFICATION`.
pub const MAX_AMPLIFICATION: f64 = 5.0;

/// The factor by which a relative error of the surface fluence is multiplied in the radiance,
/// per channel, for the uniformly lit half-space: there `φ(0) = Q / (1 + 2Aκσtr)` with
/// `κσtr = √(σa / (3σ′t))`, and `Lo ∝ (1 + 1/A) φ − 4q/(1 + Fdr)` gives
/// `amp = 1 / (1 − (1 − Fdr)(1 + 2Aκσtr)/2)`; capped at [`MAX_AMPLIFICATION`] (also where the
/// denominator is not positive).
#[must_use]
pub(crate) fn amplification(m: &Medium) -> [f64; 3] {
    let (f, a) = (fdr(m.eta), a_coefficient(m.eta));
    let st = m.sigma_t_prime();
    [0, 1, 2].map(|c| {
        let ks = if st[c] > 0.0 { (m.sigma_a[c] / (3.0 * st[c])).sqrt() } else { 0.0 };
        let d = 1.0 - (1.0 - f) * (1.0 + 2.0 * a * ks) / 2.0;
        if d > 1.0 / MAX_AMPLIFICATION {
            1.0 / d
        } else {
            MAX_AMPLIFICATION
        }
    })
}

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

/// Per tet of `mesh`: whether it owns a boundary face (the tets whose media the check reads).
#[must_use]
pub(crate) fn surface_tets(mesh: &TetMesh) -> Vec<bool> {
    let mut at_surface = vec![false; mesh.tet_count()];
    for f in mesh.boundary_faces() {
        at_surface[f.tet as usize] = true;
    }
    at_surface
}

/// The media of the tets that own a boundary face (`materials[t]` indexes `media`), each once.
#[must_use]
pub(crate) fn surface_media<'a>(mesh: &TetMesh, media: &'a [Medium]) -> Vec<&'a Medium> {
    let mut used = vec![false; media.len()];
    for (&m, _) in mesh.materials().iter().zip(surface_tets(mesh)).filter(|(_, s)| *s) {
        if let Some(u) = used.get_mut(m as usize) {
            *u = true;
        }
    }
    media.iter().zip(&used).filter(|(_, &u)| u).map(|(m, _)| m).collect()
}

/// `σtr · h` per channel: the largest over `media`.
#[must_use]
pub(crate) fn resolution(media: &[&Medium], spacing_mm: f64) -> [f64; 3] {
    media.iter().fold([0.0; 3], |acc, m| {
        let s = m.sigma_tr();
        [0, 1, 2].map(|c| acc[c].max(s[c] * spacing_mm))
    })
}

/// The resolution of `mesh` filled with `media` (`materials[t]` indexes `media`) at its
/// surface: `σtr · h` per channel ([`resolution`] of the [`surface_media`] at the
/// [`surface_spacing_mm`]), and [`check`]'s verdict with the largest `amp · σtr · h` `max`.
pub(crate) fn surface_resolution(
    mesh: &TetMesh,
    media: &[Medium],
    mm_per_unit: f64,
    max: f64,
) -> ([f64; 3], Result<(), Unresolved>) {
    let spacing = surface_spacing_mm(mesh, mm_per_unit);
    let surface = surface_media(mesh, media);
    (resolution(&surface, spacing), check(&surface, spacing, mesh.tet_count(), max))
}

/// What would bring a channel at `ratio` times its bound down to `target` times it: the tet
/// count (`tets` now; the spacing scales as `N^(−1/3)`, so the count as the cube of the ratio)
/// and the object scale factor (shrinking the object shrinks `h` in mm at the same count).
#[must_use]
pub(crate) fn remedy(ratio: f64, target: f64, tets: usize) -> (f64, f64) {
    let r = ratio / target;
    ((tets as f64 * r.powi(3)).ceil(), 1.0 / r)
}

/// Why a mesh does not resolve a medium: its worst channel, and what would resolve it.
#[derive(Debug, Clone, PartialEq)]
pub struct Unresolved {
    /// `red`, `green` or `blue`.
    pub channel: &'static str,
    /// σtr · h of that channel.
    pub sigma_tr_h: f64,
    /// The largest σtr · h allowed in this channel of this medium: the assembly's
    /// [`max_resolution`] over the radiance amplification of the channel's albedo.
    pub bound: f64,
    /// The mesh's spacing at the surface in mm (the mean boundary edge length).
    pub spacing_mm: f64,
    /// The tets the mesh has.
    pub tets: usize,
    /// About how many tets would resolve the channel.
    pub tets_needed: f64,
    /// The factor on the object's size (its `mm_per_unit`) that would resolve it at the same
    /// tet count.
    pub scale: f64,
}

impl std::fmt::Display for Unresolved {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the mesh does not resolve the medium's {} channel: σtr·h = {:.3} at the surface (mesh spacing {:.4} mm) is \
             above its bound {:.3}, where the radiance would be too dark or zero; about {:.0} tets instead of {} would \
             resolve it, or the object at {:.3e} times its size (mm_per_unit)",
            self.channel, self.sigma_tr_h, self.spacing_mm, self.bound, self.tets_needed, self.tets, self.scale
        )
    }
}

/// Refuses a mesh that does not resolve one of `media` (the surface media): the channel of the
/// largest `σtr · h / bound` when that is above 1 (or not a number), a channel's bound being
/// `max` ([`max_resolution`] of the assembly) over its amplification.
///
/// # Errors
/// [`Unresolved`] naming the channel, `σtr · h`, its bound, the spacing and the tet count or
/// scale that would resolve it.
pub(crate) fn check(media: &[&Medium], spacing_mm: f64, tets: usize, max: f64) -> Result<(), Unresolved> {
    let mut worst: Option<(f64, usize, f64, f64)> = None; // (ratio, channel, σtr·h, bound)
    for m in media {
        let (s, amp) = (m.sigma_tr(), amplification(m));
        for c in 0..3 {
            let (x, bound) = (s[c] * spacing_mm, max / amp[c]);
            let ratio = x / bound;
            if worst.is_none_or(|w| ratio > w.0 || ratio.is_nan()) {
                worst = Some((ratio, c, x, bound));
            }
        }
    }
    let Some((ratio, channel, sigma_tr_h, bound)) = worst else { return Ok(()) };
    // Written so that a NaN is refused too.
    if ratio <= 1.0 {
        return Ok(());
    }
    // Aim a little below the bound, so that the count it names is enough.
    let (tets_needed, scale) = remedy(ratio, 0.9, tets);
    Err(Unresolved { channel: ["red", "green", "blue"][channel], sigma_tr_h, bound, spacing_mm, tets, tets_needed, scale })
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

    fn marble() -> Medium {
        Medium::new([0.0021, 0.0041, 0.0071], [2.19, 2.62, 3.00], 1.5, 0.0).unwrap()
    }

    #[test]
    fn sigma_tr_h_is_the_largest_of_the_surface_media() {
        let m = regular_tet(1.0);
        let marble = marble();
        // σtr = √(3 σa (σa + σ′s)) by hand: blue √(3 · 0.0071 · 3.0071) = √0.064051 = 0.253083.
        let used = surface_media(&m, std::slice::from_ref(&marble));
        let s = resolution(&used, 2.0);
        assert!((s[2] - 2.0 * 0.253_083).abs() < 2e-6, "{s:?}");
        // A medium no surface tet uses does not count.
        let dense = Medium::new([1.0; 3], [1.0; 3], 1.3, 0.0).unwrap();
        let both = [marble, dense];
        assert_eq!(surface_media(&m, &both).len(), 1);
        assert_eq!(resolution(&surface_media(&m, &both), 2.0), s);
    }

    #[test]
    fn the_amplification_follows_the_albedo() {
        // Marble blue by hand (η = 1.5): Fdr = −1.44/2.25 + 0.71/1.5 + 0.668 + 0.0954 = 0.59673,
        // A = 1.59673/0.40327 = 3.9594, κσtr = √(0.0071/(3 · 3.0071)) = 0.028054,
        // amp = 1/(1 − 0.40327 · (1 + 2 · 3.9594 · 0.028054)/2) = 1.3271.
        let amp = amplification(&marble());
        assert!((amp[2] - 1.3271).abs() < 2e-4, "{amp:?}");
        assert!(amp[0] < amp[1] && amp[1] < amp[2], "{amp:?}");
        // A channel that absorbs almost everything is capped.
        let dark = Medium::new([2.0; 3], [0.05; 3], 1.3, 0.0).unwrap();
        assert_eq!(amplification(&dark), [MAX_AMPLIFICATION; 3]);
    }

    #[test]
    fn above_the_bound_the_error_names_channel_count_and_scale() {
        let marble = marble();
        let bound = MAX_RESOLUTION / amplification(&marble)[2];
        let sigma_blue = marble.sigma_tr()[2];
        // Just under blue's bound: accepted.
        assert!(check(&[&marble], 0.99 * bound / sigma_blue, 100, MAX_RESOLUTION).is_ok());
        // Blue at twice its bound: (2 / 0.9)³ = 10.97× the tets, or 0.45× the size.
        let spacing = 2.0 * bound / sigma_blue;
        let e = check(&[&marble], spacing, 5000, MAX_RESOLUTION).unwrap_err();
        let Unresolved { channel, sigma_tr_h, bound: b, tets_needed, scale, .. } = &e;
        assert_eq!(*channel, "blue");
        assert!((sigma_tr_h / (2.0 * bound) - 1.0).abs() < 1e-12);
        assert_eq!(*b, bound);
        assert_eq!(*tets_needed, (5000.0 * (2.0f64 / 0.9).powi(3)).ceil());
        assert!((scale - 0.45).abs() < 1e-12);
        let text = e.to_string();
        for part in ["blue", "5000", "54870"] {
            assert!(text.contains(part), "{part} in {text}");
        }
        assert!(check(&[&marble], f64::NAN, 100, MAX_RESOLUTION).is_err());
        assert!(check(&[], 1.0, 100, MAX_RESOLUTION).is_ok());
        // The fitted rows with the layer's absorption take twice the bound.
        assert_eq!(max_resolution(Discretization::FittedLayer), 2.0 * MAX_RESOLUTION);
        assert_eq!(max_resolution(Discretization::TransCut), MAX_RESOLUTION);
        assert!(check(&[&marble], spacing, 5000, max_resolution(Discretization::FittedLayer)).is_ok());
        assert!(check(&[&marble], 1.01 * spacing, 5000, max_resolution(Discretization::FittedLayer)).is_err());
    }
}
