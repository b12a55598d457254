//! The media of a translucent object under the profile S (Sheng et al. 2014 §4, eq. 16;
//! design/radiosity.md §1.5, pitfall 4): which [`MediumSource`]s the profile matrix takes, and a
//! spatially varying one as the bounded set of distinct media and the medium at each point that
//! [`crate::radiosity::ProfileMatrix::build_media`] reads ([`MediumIndex`]).
//!
//! - [`MediumSource::Homogeneous`]: one medium (the homogeneous matrix).
//! - [`MediumSource::Layers`] (depth below the object's surface, the patch surface itself),
//!   [`MediumSource::Voxels`] and [`MediumSource::Veins`] (object space): evaluated at any point.
//! - [`MediumSource::Table`] and [`MediumSource::PerTet`] give media per tet of a tet mesh,
//!   which the profile S (no tets) does not have: refused ([`ProfileMediumError::TetMedium`]).
//!
//! The object must have one η (Fresnel at its surface, and each profile's boundary term):
//! layers of different η are refused ([`ProfileMediumError::MixedEta`]); voxels and veins have
//! one by construction. Heterogeneous media take chord distances only
//! ([`ProfileMediumError::InteriorHeterogeneous`]): the interior mode measures one optical
//! distance per pair of patch vertices over the voxel graph (Theta* paths, the smaller of the two
//! directions, samples corrected to first order) and keeps no path, so per-medium lengths along
//! it would need that polyline kept and classified per sample; not done.
//!
//! # Continuous media: quantised
//!
//! Blended layers, trilinear voxels and veins vary continuously, so the media are quantised
//! into at most [`MAX_MEDIA`] distinct ones rather than the rule applied to every sample's own
//! medium: eq. 16 is not consistent under subdivision (pitfall 4: splitting one medium's path
//! into pieces changes its value), so it needs lengths merged per *distinct* medium, which a
//! continuum has none of; a bounded set also bounds the profiles built (three per medium) and
//! the work per sample. The field is sampled on a grid over the object's bounding box at the
//! segment spacing (at most 32³ points) and at every patch vertex:
//!
//! - at most [`MAX_MEDIA`] distinct coefficient sets: those, exactly (layers without blending,
//!   voxels of few values, identical media, which collapse to the homogeneous matrix);
//! - more: k-means (Lloyd, 16 iterations, farthest-point start from the most frequent value) in
//!   the features (ln σ′t, ln σtr) per channel, the two lengths every profile scales with (mean
//!   free path and diffusion length), weighted by how often each value was sampled; each centre
//!   is the weighted mean σa, σ′s of its members (a convex combination, so valid).
//!
//! A point is then its exact medium when sampled, else the nearest centre in those features.
//!
//! # The medium lattice
//!
//! A profile matrix reads the medium at every piece of every sample's segment: hundreds of
//! millions of points for a small object, each a closest-point query (layers) or Perlin noise
//! (veins). So the quantised medium is tabulated once at the nodes of a lattice over the
//! bounding box at half the segment spacing h, and a point takes its nearest node's medium
//! ([`MediumLattice`]). That moves an interface by at most √3/4·h, below the h/2 by which the
//! segment sampling already places it. A lattice over [`MAX_LATTICE_NODES`] nodes is not
//! built and points are evaluated directly.
//!
//! # Segment spacing (the medium's feature size)
//!
//! - layers: a quarter of the thinnest layer, or of the blending width when smaller (> 0);
//! - voxels: half the smallest voxel edge;
//! - veins: a sixteenth of the smaller of the period and the noise scale (a vein of sharpness 3
//!   is about 0.3 of a period wide at half weight, so five pieces or more across it);
//!
//! object-space lengths scaled by the smallest column of the object's transform and by
//! `mm_per_unit`.

use std::collections::HashMap;

use glam::{DMat4, DVec3};
use rayon::prelude::*;

use super::super::Target;
use crate::mesh::TriangleBvh;
use crate::optics::Medium;
use crate::radiosity::{MediumIndex, ObjectPatches, MAX_MEDIA};
use crate::scene::{MediumSource, SceneError, Shape};
use crate::volume::{Coefficients, Layers, MediumField, Veins, VoxelGrid};

/// What the profile S cannot take in a medium, named.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ProfileMediumError {
    #[error(
        "profile scattering cannot take a {kind}: it gives media per tet of a tet mesh, and the profile S has no tets; give a \
         homogeneous medium, layers, a voxel grid or veins, or use scattering = \"diffusion\""
    )]
    TetMedium { kind: &'static str },
    #[error(
        "profile scattering needs one refractive index per object, but layer 0 has η = {first} and layer {layer} η = {other}"
    )]
    MixedEta { layer: usize, first: f64, other: f64 },
    #[error(
        "profile scattering through a heterogeneous medium gathers chord distances only (the interior distance keeps no \
         path to measure per medium): use profile distance \"chord\", or scattering = \"diffusion\""
    )]
    InteriorHeterogeneous,
}

/// The checks of the profile S on `target`'s shape and `medium` that need no geometry
/// (module documentation).
///
/// # Errors
/// [`SceneError::InvalidObject`] for a tet-mesh shape, a per-tet medium, layers of several η,
/// an invalid medium or an opaque surface.
pub(super) fn check_medium(target: &Target<'_>, medium: Option<&MediumSource>) -> Result<(), SceneError> {
    if matches!(target.object.shape, Shape::Tetrahedra(_)) {
        return Err(target.invalid(
            "profile scattering works on surfaces: give the object as a surface, or use scattering = \"diffusion\" for a tet mesh",
        ));
    }
    let named = |e: ProfileMediumError| target.invalid(e.to_string());
    match medium {
        None => Err(target.invalid("an opaque diffuse surface has no profile")),
        Some(MediumSource::Table(_)) => Err(named(ProfileMediumError::TetMedium { kind: "material table" })),
        Some(MediumSource::PerTet(_)) => Err(named(ProfileMediumError::TetMedium { kind: "per-tet medium" })),
        Some(MediumSource::Homogeneous(m)) => m.validate().map_err(|e| target.invalid(format!("medium: {e}"))),
        Some(source @ MediumSource::Layers(layers)) => {
            let first = layers.layers()[0].medium.eta;
            if let Some((layer, l)) = layers.layers().iter().enumerate().find(|(_, l)| l.medium.eta != first) {
                return Err(named(ProfileMediumError::MixedEta { layer, first, other: l.medium.eta }));
            }
            source.validate(&target.object.shape).map_err(|e| target.invalid(format!("medium: {e}")))
        }
        Some(source) => source.validate(&target.object.shape).map_err(|e| target.invalid(format!("medium: {e}"))),
    }
}

/// A profile object's media: one, or a heterogeneous field quantised (module documentation).
#[derive(Debug, Clone)]
pub(super) enum ObjectMedia {
    Homogeneous(Medium),
    Heterogeneous(Box<QuantisedMedia>),
}

impl ObjectMedia {
    /// The media of `source` in the object of `target` whose patches are `patches` (mm, world
    /// space times `mm_per_unit`); a field of one distinct medium is that medium. `source` must
    /// have passed [`check_medium`].
    pub(super) fn new(target: &Target<'_>, source: &MediumSource, patches: &ObjectPatches, mm_per_unit: f64) -> ObjectMedia {
        let to_object = target.object.transform.inverse();
        let stretch = (0..3).map(|c| target.object.transform.col(c).truncate().length()).fold(f64::INFINITY, f64::min);
        let object_mm = stretch * mm_per_unit;
        let (field, spacing, eta) = match source {
            MediumSource::Homogeneous(m) => return ObjectMedia::Homogeneous(*m),
            MediumSource::Layers(layers) => {
                let mut thinnest = f64::INFINITY;
                let mut previous = 0.0;
                for l in &layers.layers()[..layers.layers().len() - 1] {
                    thinnest = thinnest.min(l.max_depth_mm - previous);
                    previous = l.max_depth_mm;
                }
                if layers.blend_mm() > 0.0 {
                    thinnest = thinnest.min(layers.blend_mm());
                }
                let spacing = if thinnest.is_finite() { 0.25 * thinnest } else { 1.0 };
                let field = Field::Layers { layers: layers.clone(), surface: patches.bvh().clone() };
                (field, spacing, layers.layers()[0].medium.eta)
            }
            MediumSource::Voxels { grid, eta, .. } => {
                let spacing = 0.5 * grid.voxel_size().min_element() * object_mm;
                (Field::Voxels { grid: grid.clone(), to_object, mm_per_unit }, spacing, *eta)
            }
            MediumSource::Veins(veins) => {
                let p = veins.params();
                let spacing = p.period.min(p.noise_scale) / 16.0 * object_mm;
                (Field::Veins { veins: veins.clone(), to_object, mm_per_unit }, spacing, veins.base().eta)
            }
            MediumSource::Table(_) | MediumSource::PerTet(_) => unreachable!("refused by check_medium"),
        };
        let media = QuantisedMedia::new(field, spacing, eta, patches.positions());
        if media.palette.len() == 1 {
            ObjectMedia::Homogeneous(media.palette[0])
        } else {
            ObjectMedia::Heterogeneous(Box::new(media))
        }
    }

    /// The object's refractive index.
    pub(super) fn eta(&self) -> f64 {
        match self {
            ObjectMedia::Homogeneous(m) => m.eta,
            ObjectMedia::Heterogeneous(q) => q.eta,
        }
    }
}

/// A heterogeneous field and what its points are evaluated at.
#[derive(Debug, Clone)]
enum Field {
    /// Depth below the patch surface (mm).
    Layers {
        layers: Layers,
        surface: TriangleBvh,
    },
    /// Object space: world point (mm / `mm_per_unit`) through `to_object`.
    Voxels {
        grid: VoxelGrid,
        to_object: DMat4,
        mm_per_unit: f64,
    },
    Veins {
        veins: Veins,
        to_object: DMat4,
        mm_per_unit: f64,
    },
}

impl Field {
    fn at(&self, p_mm: DVec3) -> Coefficients {
        match self {
            Field::Layers { layers, surface } => layers.at_depth(surface.closest_point(p_mm).map_or(0.0, |s| s.distance)),
            Field::Voxels { grid, to_object, mm_per_unit } => grid.sample(to_object.transform_point3(p_mm / *mm_per_unit)),
            Field::Veins { veins, to_object, mm_per_unit } => veins.coefficients(to_object.transform_point3(p_mm / *mm_per_unit)),
        }
    }
}

/// The features k-means and the nearest-centre rule compare: (ln σ′t, ln σtr) per channel
/// (module documentation), σtr floored at 10⁻⁶σ′t (no absorption).
fn features(c: &Coefficients) -> [f64; 6] {
    let mut f = [0.0; 6];
    for ch in 0..3 {
        let t = c.sigma_a[ch] + c.sigma_s_prime[ch];
        f[2 * ch] = t.ln();
        f[2 * ch + 1] = (3.0 * c.sigma_a[ch] * t).sqrt().max(1e-6 * t).ln();
    }
    f
}

fn distance2(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum()
}

fn key(c: &Coefficients) -> [u64; 6] {
    c.to_array().map(f64::to_bits)
}

/// A field quantised into at most [`MAX_MEDIA`] media (module documentation).
#[derive(Debug, Clone)]
pub(super) struct QuantisedMedia {
    field: Field,
    spacing: f64,
    eta: f64,
    /// The distinct media (σa, σ′s of the centres, the object's η and g = 0: profiles use σ′s).
    palette: Vec<Medium>,
    centres: Vec<[f64; 6]>,
    /// The sampled coefficients and their medium.
    exact: HashMap<[u64; 6], u16>,
    /// Every point's medium tabulated (module documentation), when small enough.
    lattice: Option<MediumLattice>,
}

impl QuantisedMedia {
    fn new(field: Field, spacing: f64, eta: f64, vertices: &[DVec3]) -> QuantisedMedia {
        let (lo, hi) = vertices
            .iter()
            .fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        let size = (hi - lo).max(DVec3::ZERO);
        let steps = (size / spacing).ceil().as_uvec3().clamp(glam::UVec3::ONE, glam::UVec3::splat(31)) + 1;
        let mut points = vertices.to_vec();
        for z in 0..steps.z {
            for y in 0..steps.y {
                for x in 0..steps.x {
                    let t = DVec3::new(x as f64, y as f64, z as f64) / (steps - 1).max(glam::UVec3::ONE).as_dvec3();
                    points.push(lo + size * t);
                }
            }
        }
        let sampled: Vec<Coefficients> = points.par_iter().map(|&p| field.at(p)).collect();
        let (mut values, mut counts, mut index) = (Vec::new(), Vec::new(), HashMap::new());
        for c in sampled {
            let k = *index.entry(key(&c)).or_insert_with(|| {
                values.push(c);
                counts.push(0.0f64);
                values.len() - 1
            });
            counts[k] += 1.0;
        }
        let (palette, exact) = if values.len() <= MAX_MEDIA {
            let exact = index.into_iter().map(|(k, v)| (k, v as u16)).collect();
            (values, exact)
        } else {
            let centres = k_means(&values, &counts, MAX_MEDIA);
            let feats: Vec<[f64; 6]> = centres.iter().map(features).collect();
            let exact = index.into_iter().map(|(k, v)| (k, nearest(&feats, &features(&values[v])) as u16)).collect();
            (centres, exact)
        };
        let centres = palette.iter().map(features).collect();
        let palette = palette.iter().map(|c| c.with_eta_g(eta, 0.0)).collect();
        let mut media = QuantisedMedia { field, spacing, eta, palette, centres, exact, lattice: None };
        media.lattice = MediumLattice::new(lo, hi, 0.5 * spacing, |p| media.quantise(p));
        media
    }

    /// The medium of the field's value at `p`: its exact medium when sampled at construction,
    /// else the nearest centre.
    fn quantise(&self, p: DVec3) -> u8 {
        let c = self.field.at(p);
        let m = match self.exact.get(&key(&c)) {
            Some(&m) => usize::from(m),
            None => nearest(&self.centres, &features(&c)),
        };
        m as u8
    }

    /// The distinct media.
    pub(super) fn palette(&self) -> &[Medium] {
        &self.palette
    }
}

impl MediumIndex for QuantisedMedia {
    fn count(&self) -> usize {
        self.palette.len()
    }

    fn medium_at(&self, p: DVec3) -> usize {
        usize::from(match &self.lattice {
            Some(lattice) => lattice.at(p),
            None => self.quantise(p),
        })
    }

    fn spacing(&self) -> f64 {
        self.spacing
    }
}

/// The most nodes a [`MediumLattice`] has (one byte each).
const MAX_LATTICE_NODES: usize = 1 << 24;

/// A medium per node of a regular lattice (module documentation); a point takes its nearest
/// node's, points outside the lattice the nearest boundary node's.
#[derive(Debug, Clone)]
struct MediumLattice {
    origin: DVec3,
    step: f64,
    dims: [usize; 3],
    media: Vec<u8>,
}

impl MediumLattice {
    /// `medium(node)` at the nodes of a lattice of spacing `step` covering `lo`..`hi` (one node
    /// past each side); `None` when that takes over [`MAX_LATTICE_NODES`] nodes.
    fn new(lo: DVec3, hi: DVec3, step: f64, medium: impl Fn(DVec3) -> u8 + Sync) -> Option<MediumLattice> {
        let origin = lo - DVec3::splat(step);
        let n = ((hi + DVec3::splat(step) - origin) / step).ceil() + 1.0;
        if !(n.element_product() <= MAX_LATTICE_NODES as f64) {
            return None;
        }
        let dims = n.as_uvec3().to_array().map(|d| d as usize);
        let media = (0..dims[0] * dims[1] * dims[2])
            .into_par_iter()
            .map(|i| {
                let ijk = DVec3::new((i % dims[0]) as f64, (i / dims[0] % dims[1]) as f64, (i / (dims[0] * dims[1])) as f64);
                medium(origin + ijk * step)
            })
            .collect();
        Some(MediumLattice { origin, step, dims, media })
    }

    /// The medium of the node nearest `p`.
    fn at(&self, p: DVec3) -> u8 {
        // + ½ and truncation: round to nearest for the non-negative, and a negative saturates to 0.
        let q = (p - self.origin) / self.step + 0.5;
        let ijk: [usize; 3] = std::array::from_fn(|a| (q[a] as usize).min(self.dims[a] - 1));
        self.media[ijk[0] + self.dims[0] * (ijk[1] + self.dims[1] * ijk[2])]
    }
}

/// The index of the centre nearest `f` (the first of equals).
fn nearest(centres: &[[f64; 6]], f: &[f64; 6]) -> usize {
    let mut best = (f64::INFINITY, 0);
    for (k, c) in centres.iter().enumerate() {
        let d = distance2(c, f);
        if d < best.0 {
            best = (d, k);
        }
    }
    best.1
}

/// `k` centres of `values` weighted by `weights` (module documentation): farthest-point start
/// from the heaviest value, then 16 Lloyd iterations; each centre the weighted mean of its
/// members' coefficients. Deterministic.
fn k_means(values: &[Coefficients], weights: &[f64], k: usize) -> Vec<Coefficients> {
    let feats: Vec<[f64; 6]> = values.iter().map(features).collect();
    let heaviest = (0..values.len()).fold(0, |b, i| if weights[i] > weights[b] { i } else { b });
    let mut centres = vec![values[heaviest]];
    let mut centre_feats = vec![feats[heaviest]];
    let mut gap: Vec<f64> = feats.iter().map(|f| distance2(f, &feats[heaviest])).collect();
    while centres.len() < k.min(values.len()) {
        let far = (0..values.len()).fold(0, |b, i| if gap[i] > gap[b] { i } else { b });
        if !(gap[far] > 0.0) {
            break;
        }
        centres.push(values[far]);
        centre_feats.push(feats[far]);
        for (g, f) in gap.iter_mut().zip(&feats) {
            *g = g.min(distance2(f, &feats[far]));
        }
    }
    for _ in 0..16 {
        let mut sums = vec![([0.0; 6], 0.0); centres.len()];
        for (i, f) in feats.iter().enumerate() {
            let c = nearest(&centre_feats, f);
            let v = values[i].to_array();
            for (s, x) in sums[c].0.iter_mut().zip(v) {
                *s += weights[i] * x;
            }
            sums[c].1 += weights[i];
        }
        for (c, (sum, w)) in sums.into_iter().enumerate() {
            if w > 0.0 {
                centres[c] = Coefficients::from_array(sum.map(|s| s / w));
                centre_feats[c] = features(&centres[c]);
            }
        }
    }
    centres
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lerp_family(n: usize) -> (Vec<Coefficients>, Coefficients, Coefficients) {
        let a = Coefficients::new([0.002, 0.003, 0.004], [2.0, 2.5, 3.0]);
        let b = Coefficients::new([0.05, 0.08, 0.1], [0.5, 0.6, 0.7]);
        ((0..n).map(|i| a.lerp(&b, i as f64 / (n - 1) as f64)).collect(), a, b)
    }

    #[test]
    fn k_means_covers_a_continuum_evenly() {
        // A blend of two media (veins, blended layers): 1000 values along one curve of the
        // feature space. Every value must be within a 1/16 of the curve's feature length of its
        // centre (an even split into 16 has 1/32; k-means from farthest points stays within 1/16).
        let (values, a, b) = lerp_family(1000);
        let weights = vec![1.0; values.len()];
        let centres = k_means(&values, &weights, MAX_MEDIA);
        assert_eq!(centres.len(), MAX_MEDIA);
        let feats: Vec<[f64; 6]> = centres.iter().map(features).collect();
        // The curve's length in features, summed along the family.
        let length: f64 = values.windows(2).map(|w| distance2(&features(&w[0]), &features(&w[1])).sqrt()).sum();
        assert!(length > distance2(&features(&a), &features(&b)).sqrt() * 0.999);
        for v in &values {
            let f = features(v);
            let d = distance2(&feats[nearest(&feats, &f)], &f).sqrt();
            assert!(d <= length / 16.0, "{d} vs {}", length / 16.0);
        }
        // Deterministic, and every centre a convex combination (valid).
        assert_eq!(k_means(&values, &weights, MAX_MEDIA), centres);
        assert!(centres.iter().all(|c| c.validate().is_ok()));
        // Fewer values than centres: the values themselves.
        assert_eq!(k_means(&values[..3], &weights[..3], MAX_MEDIA).len(), 3);
    }

    #[test]
    fn a_lattice_point_takes_its_nearest_node_s_medium() {
        // Medium 1 inside the ball of radius 1 about the origin, 0 outside, on a lattice of
        // step 0.1 over [-1.5, 1.5]³: a point's medium is the ball's at the point rounded to
        // the grid (the origin at -1.6, one node past each side), clamped at the lattice's edge.
        let inside = |p: DVec3| u8::from(p.length() < 1.0);
        let lattice = MediumLattice::new(DVec3::splat(-1.5), DVec3::splat(1.5), 0.1, inside).unwrap();
        assert_eq!(lattice.dims, [33; 3]);
        let rounded = |p: DVec3| ((p + 1.6) / 0.1).round() * 0.1 - 1.6;
        for p in
            [DVec3::new(0.96, 0.0, 0.0), DVec3::new(0.94, 0.0, 0.0), DVec3::new(0.5, 0.6, -0.57), DVec3::new(0.57, 0.57, 0.57)]
        {
            assert_eq!(lattice.at(p), inside(rounded(p)), "{p}");
        }
        assert_eq!(lattice.at(DVec3::new(0.04, 0.0, 0.0)), 1);
        assert_eq!(lattice.at(DVec3::new(9.0, 0.0, 0.0)), 0);
        // Too many nodes: none.
        assert!(MediumLattice::new(DVec3::ZERO, DVec3::splat(1.0), 1e-3, inside).is_none());
    }
}
