//! The profile scattering matrix S of one translucent object (Sheng et al. 2014 §4–5, eq. 8;
//! design/radiosity.md §1.5 (b)): B_j = Σᵢ S_ji qᵢ + δ_j q_j, with the entry
//!
//! S_ji = ∫_{Aᵢ} R(d(x_j, y)) dA_y (Mertens' point-to-patch factor; design §1.1),
//!
//! x_j the receiving patch's vertex, Aᵢ the source patch's dual cell, R a [`Profile`] per
//! channel truncated at its cutoff radius, d the optical distance ([`DistanceMode`]) and δ the
//! profile's local term. q is the *transmitted* irradiance (after Fresnel at entry, t = 1 −
//! F_ext for diffuse light) and B the exitance leaving the surface; the radiance along the
//! normal is Lo = Ft(n)/(π(1 − Fdr)) · B ([`radiance_factor`], ARCHITECTURE.md: Fresnel at exit).
//!
//! # Quadrature (design §1.5, "Quadrature")
//!
//! With ρᵢ the radius of cell i about its vertex and e = |x_j − xᵢ|:
//!
//! - e ≤ 2ρᵢ (the patch itself and its first ring): each piece (a sixth of a triangle) of the
//!   cell is integrated in polar coordinates about the foot of x_j on its plane (height h),
//!   exactly in the radius through the disc integral C of the profile,
//!   ∫_T R dA = (1/2π) Σ_edges ∫_{Δθ} [C(√(ρ_e(θ)² + h²)) − C(h)] dθ (Mertens et al. 2003 eq. 18
//!   with the radial integral in closed form for every profile), 8 Gauss–Legendre points per
//!   π/8 of angle; chord distances.
//! - e ≤ 5ρᵢ: the 7-point degree-5 rule on each piece, each point y at distance
//!   d_ji + (|x_j − y| − e) (the optical distance of the vertices corrected to first order).
//! - beyond: two points in distance, μ ± σ with weights Aᵢ/2, where μ and σ² are the mean and
//!   variance of the distance over the cell (from each piece's centroid, its covariance along
//!   and across the line of sight; [`distance_rule`]): exact for profiles cubic in d over the
//!   cell. One point R(d)·Aᵢ is not enough: for the dipole's e^{−σr}/r³ on a 1 mm grid it is
//!   1.7% off at 5.4 mm and 1.1% (blue) at 14 mm, the curvature over the cell.
//!
//! # Re-indexing (design §1.5, "Changing translucency"; check A11)
//!
//! The build keeps every sample as an f32 pair (distance, weight), per entry, in a
//! [`SampleCache`]; a new medium or profile re-evaluates S from it ([`ProfileMatrix::reindex`])
//! without any geometry, bit-identical to a fresh build with the same gathering radius.

use std::f64::consts::PI;
use std::sync::Arc;

use glam::DVec3;
use rayon::prelude::*;

use crate::mesh::TriangleBvh;
use crate::optics::{fdr, ft_out};

use super::distance::{pair_distances, DistanceMode, PairDistances};
use super::error::RadiosityError;
use super::heterogeneous::HetRule;
use super::patches::{PatchSet, Surface};
use super::path_media::MediumIndex;
use super::profile::{gauss_legendre, Profile};
use super::profile_media::EntryMedia;
use super::solver::Scattering;

/// Cells within this many cell radii of the receiver are integrated in polar coordinates.
pub(super) const NEAR: f64 = 2.0;
/// Cells within this many cell radii of the receiver get the 7-point rule per piece.
const RULE7: f64 = 5.0;

/// Angle (radians) per 8-point Gauss–Legendre panel of the polar quadrature.
const PANEL_ANGLE: f64 = PI / 8.0;

/// Lo(x, n) per unit exitance B for a medium of index `eta`: T(η, 0)/(π η² (1 − Fdr))
/// (ARCHITECTURE.md, "What a bake returns", the energy-consistent constant of dipole-based
/// methods; 0.33345 at η = 1.3 with the Fdr fit, 0.06% above the design's 1 − Fdr_exact).
#[must_use]
pub fn radiance_factor(eta: f64) -> f64 {
    ft_out(eta, 1.0) / (PI * (1.0 - fdr(eta)))
}

/// The patches of one translucent object: vertex, outward normal, dual-cell area and pieces,
/// the cell's radius about its vertex, and a BVH of the object's own triangles (for sight).
#[derive(Debug, Clone)]
pub struct ObjectPatches {
    pub(super) positions: Vec<DVec3>,
    pub(super) normals: Vec<DVec3>,
    pub(super) areas: Vec<f64>,
    pub(super) radii: Vec<f64>,
    piece_start: Vec<usize>,
    pieces: Vec<[DVec3; 3]>,
    bvh: TriangleBvh,
}

impl ObjectPatches {
    /// The front patches of surface `surface` of `patches` (one translucent object, its patches
    /// `patches.front_range(surface)` in that order).
    ///
    /// # Panics
    /// When `surface` is not a surface of `patches`.
    #[must_use]
    pub fn from_patch_set(patches: &PatchSet, surface: usize) -> ObjectPatches {
        let range = patches.front_range(surface);
        let positions = patches.positions()[range.clone()].to_vec();
        let normals = patches.normals()[range.clone()].to_vec();
        let areas = patches.areas()[range.clone()].to_vec();
        let (mut piece_start, mut pieces, mut radii) = (vec![0], Vec::new(), Vec::new());
        for p in range.clone() {
            let x = patches.positions()[p];
            let mut r: f64 = 0.0;
            for piece in patches.cell_pieces(p) {
                r = piece.iter().fold(r, |r, c| r.max((*c - x).length()));
                pieces.push(piece);
            }
            radii.push(r);
            piece_start.push(pieces.len());
        }
        let own = |t: &[u32; 3]| t.iter().all(|&v| range.contains(&(v as usize)));
        let corners: Vec<[DVec3; 3]> =
            patches.front_triangles().iter().filter(|t| own(t)).map(|t| t.map(|v| patches.positions()[v as usize])).collect();
        ObjectPatches { positions, normals, areas, radii, piece_start, pieces, bvh: TriangleBvh::new(corners) }
    }

    /// The patches of one closed surface given by `positions` and `triangles` (counter-clockwise
    /// seen from outside), as [`PatchSet::new`] would make them.
    ///
    /// # Errors
    /// As [`PatchSet::new`].
    pub fn from_surface(positions: &[DVec3], triangles: &[[u32; 3]]) -> Result<ObjectPatches, RadiosityError> {
        let set = PatchSet::new(&[Surface { positions, triangles, two_sided: false }])?;
        Ok(Self::from_patch_set(&set, 0))
    }

    /// The number of patches.
    #[must_use]
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether there is no patch.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Each patch's vertex.
    #[must_use]
    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    /// Each patch's area.
    #[must_use]
    pub fn areas(&self) -> &[f64] {
        &self.areas
    }

    /// Each cell's radius about its vertex (the farthest corner of its pieces).
    #[must_use]
    pub fn cell_radii(&self) -> &[f64] {
        &self.radii
    }

    /// The BVH of the object's triangles.
    #[must_use]
    pub fn bvh(&self) -> &TriangleBvh {
        &self.bvh
    }

    pub(super) fn pieces(&self, i: usize) -> &[[DVec3; 3]] {
        &self.pieces[self.piece_start[i]..self.piece_start[i + 1]]
    }
}

/// How the profile matrix is built.
#[derive(Debug, Clone)]
pub struct ProfileOptions {
    /// How distances are measured.
    pub distance: DistanceMode,
    /// Each channel's profile is cut where at most this fraction of its regular total is left
    /// beyond (design: 10⁻³).
    pub tail: f64,
    /// The radius (mm) within which samples are gathered; `None`: the largest channel cutoff.
    /// A re-indexed profile must have its cutoffs within it.
    pub gather_radius: Option<f64>,
}

impl Default for ProfileOptions {
    fn default() -> Self {
        Self { distance: DistanceMode::Euclidean, tail: 1e-3, gather_radius: None }
    }
}

/// The geometry of the matrix: its pattern and every entry's samples (module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct SampleCache {
    row_ptr: Vec<usize>,
    cols: Vec<u32>,
    /// Per entry, its value samples R(d)·w and its cumulative samples C(d)·w.
    value_start: Vec<usize>,
    values: Vec<[f32; 2]>,
    cumulative_start: Vec<usize>,
    cumulative: Vec<[f32; 2]>,
    gather_radius: f64,
    /// For a heterogeneous object, each entry's medium or its samples through several media
    /// ([`EntryMedia`]); `None` for a homogeneous one.
    pub(super) media: Option<Box<EntryMedia>>,
}

impl SampleCache {
    /// The samples of `patches` within `gather_radius` (mm) at the distances `distances`.
    pub(super) fn build(patches: &ObjectPatches, distances: &PairDistances, gather_radius: f64) -> SampleCache {
        let n = patches.len();
        let nodes = gauss_legendre(8);
        let rows: Vec<RowSamples> = (0..n)
            .into_par_iter()
            .map(|j| {
                let (sources, dist) = distances.row(j);
                let (mut cols, mut values, mut vstart, mut cum, mut cstart) =
                    (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
                for (&i, &d) in sources.iter().zip(dist) {
                    let i = i as usize;
                    let rho = patches.radii[i];
                    if patches.areas[i] <= 0.0 || d - rho > gather_radius {
                        continue;
                    }
                    cols.push(i as u32);
                    vstart.push(values.len());
                    cstart.push(cum.len());
                    entry_samples(patches, j, i, d, &nodes, &mut values, &mut cum);
                }
                (cols, values, vstart, cum, cstart)
            })
            .collect();
        Self::assemble(rows, gather_radius)
    }

    /// The cache of the rows `rows` (columns, value samples and starts, cumulative samples and
    /// starts per row).
    pub(super) fn assemble(rows: Vec<RowSamples>, gather_radius: f64) -> SampleCache {
        let mut cache = SampleCache {
            row_ptr: vec![0],
            cols: Vec::new(),
            value_start: Vec::new(),
            values: Vec::new(),
            cumulative_start: Vec::new(),
            cumulative: Vec::new(),
            gather_radius,
            media: None,
        };
        for (cols, values, vstart, cum, cstart) in rows {
            let (v0, c0) = (cache.values.len(), cache.cumulative.len());
            cache.cols.extend(cols);
            cache.value_start.extend(vstart.iter().map(|s| s + v0));
            cache.cumulative_start.extend(cstart.iter().map(|s| s + c0));
            cache.values.extend(values);
            cache.cumulative.extend(cum);
            cache.row_ptr.push(cache.cols.len());
        }
        cache.value_start.push(cache.values.len());
        cache.cumulative_start.push(cache.cumulative.len());
        cache
    }

    /// The number of entries.
    #[must_use]
    pub fn nonzeros(&self) -> usize {
        self.cols.len()
    }

    /// The number of samples kept (each 8 bytes).
    #[must_use]
    pub fn samples(&self) -> usize {
        self.values.len() + self.cumulative.len() + self.media.as_ref().map_or(0, |m| m.samples())
    }

    /// For a heterogeneous object, each entry's medium or mixed samples; `None` for a
    /// homogeneous one.
    #[must_use]
    pub fn media(&self) -> Option<&EntryMedia> {
        self.media.as_deref()
    }

    /// The gathering radius (mm).
    #[must_use]
    pub fn gather_radius(&self) -> f64 {
        self.gather_radius
    }

    /// The columns of row `j`'s entries and the range of their indices.
    pub(super) fn row_range(&self, j: usize) -> std::ops::Range<usize> {
        self.row_ptr[j]..self.row_ptr[j + 1]
    }

    /// The source patch of entry `k`.
    pub(super) fn col(&self, k: usize) -> usize {
        self.cols[k] as usize
    }

    /// The number of rows.
    pub(super) fn rows(&self) -> usize {
        self.row_ptr.len() - 1
    }

    /// Entry k's value for `profile` truncated at `cutoff`: Σ w R(d) (d ≤ cutoff) + Σ w C(min(d, cutoff)).
    pub(super) fn entry(&self, k: usize, profile: &Profile, cutoff: f64) -> f64 {
        let mut sum = 0.0;
        for &[d, w] in &self.values[self.value_start[k]..self.value_start[k + 1]] {
            let d = f64::from(d);
            if d <= cutoff {
                sum += f64::from(w) * profile.value(d);
            }
        }
        for &[d, w] in &self.cumulative[self.cumulative_start[k]..self.cumulative_start[k + 1]] {
            sum += f64::from(w) * profile.disc_integral(f64::from(d).min(cutoff));
        }
        sum
    }
}

/// The optical distances of the pairs of `patches` whose cells may reach within `radius` (mm).
fn gathered_distances(patches: &ObjectPatches, mode: &DistanceMode, radius: f64) -> PairDistances {
    let max_cell = patches.radii.iter().copied().fold(0.0, f64::max);
    let mean_cell = patches.radii.iter().sum::<f64>() / patches.len().max(1) as f64;
    pair_distances(&patches.positions, &patches.normals, &patches.bvh, mode, radius + max_cell, 1e-3 * mean_cell)
}

/// One row's columns, value samples and their starts, cumulative samples and their starts.
pub(super) type RowSamples = (Vec<u32>, Vec<[f32; 2]>, Vec<usize>, Vec<[f32; 2]>, Vec<usize>);

/// Which rule of the module documentation integrates a source cell of radius `rho` whose vertex
/// is `e` from the receiver.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum CellRule {
    /// e ≤ 2ρ: polar coordinates about the receiver's foot.
    Polar,
    /// e ≤ 5ρ: the 7-point rule per piece.
    Rule7,
    /// Beyond: two points in distance.
    TwoPoint,
}

impl CellRule {
    pub(super) fn of(e: f64, rho: f64) -> CellRule {
        if e <= NEAR * rho {
            CellRule::Polar
        } else if e <= RULE7 * rho {
            CellRule::Rule7
        } else {
            CellRule::TwoPoint
        }
    }
}

/// The samples of entry (receiver `j`, source `i`) at optical distance `d` (module
/// documentation): value samples to `values`, cumulative ones to `cum`.
pub(super) fn entry_samples(
    patches: &ObjectPatches,
    j: usize,
    i: usize,
    d: f64,
    nodes: &[(f64, f64)],
    values: &mut Vec<[f32; 2]>,
    cum: &mut Vec<[f32; 2]>,
) {
    let x = patches.positions[j];
    let e = (patches.positions[i] - x).length();
    match CellRule::of(e, patches.radii[i]) {
        CellRule::Polar => {
            for piece in patches.pieces(i) {
                polar_samples(*piece, x, nodes, cum);
            }
        }
        CellRule::Rule7 => {
            for piece in patches.pieces(i) {
                for (y, w) in rule7(*piece) {
                    values.push([(d + ((y - x).length() - e)).max(0.0) as f32, w as f32]);
                }
            }
        }
        CellRule::TwoPoint => {
            let [(d0, w0), (d1, w1)] = distance_rule(patches.pieces(i), x, d - e, patches.areas[i]);
            values.push([d0 as f32, w0 as f32]);
            values.push([d1 as f32, w1 as f32]);
        }
    }
}

/// One ray of the polar quadrature of a triangle about the foot of a point x on its plane
/// (height `h`): it ends at `end` on the triangle's edge, `s` = |x − end| from x, with the
/// signed angular weight `w` (Δθ-weight/(2π)); `foot` is x's foot.
#[derive(Debug, Clone, Copy)]
pub(super) struct PolarRay {
    pub foot: DVec3,
    pub end: DVec3,
    pub s: f64,
    pub h: f64,
    pub w: f64,
}

/// The samples of ∫_T R(|x − y|) dA_y in polar coordinates about the foot of `x` on the plane
/// of the triangle `t` (module documentation): per edge, C(√(ρ(θ)² + h²))·w at the
/// Gauss–Legendre angles, w = Δθ-weight/(2π) (signed by the edge's turn), then C(|h|) with
/// −Θ/(2π), Θ the signed angle the triangle subtends at the foot.
fn polar_samples(t: [DVec3; 3], x: DVec3, nodes: &[(f64, f64)], out: &mut Vec<[f32; 2]>) {
    let mut h = 0.0;
    let theta_total = polar_rays(t, x, nodes, |ray| {
        h = ray.h;
        out.push([ray.s as f32, ray.w as f32]);
    });
    if theta_total.abs() > 1e-9 && h != 0.0 {
        out.push([h.abs() as f32, (-theta_total / (2.0 * PI)) as f32]);
    }
}

/// The rays of the polar quadrature of triangle `t` about the foot of `x` ([`polar_samples`]),
/// each given to `ray`; returns Θ, the signed angle the triangle subtends at the foot (0 for a
/// degenerate triangle, which has no ray).
pub(super) fn polar_rays(t: [DVec3; 3], x: DVec3, nodes: &[(f64, f64)], mut ray: impl FnMut(PolarRay)) -> f64 {
    let cross = (t[1] - t[0]).cross(t[2] - t[0]);
    let double_area = cross.length();
    if !(double_area > 0.0) {
        return 0.0;
    }
    let n = cross / double_area;
    let h = (x - t[0]).dot(n);
    let foot = x - h * n;
    let u = (t[1] - t[0]).normalize();
    let v = n.cross(u);
    let flat = |p: DVec3| glam::DVec2::new((p - foot).dot(u), (p - foot).dot(v));
    let mut theta_total = 0.0;
    for k in 0..3 {
        let (a, b) = (flat(t[k]), flat(t[(k + 1) % 3]));
        let edge = b - a;
        let turn = a.perp_dot(b);
        if turn.abs() <= 1e-12 * edge.length() * a.length().max(b.length()) {
            continue;
        }
        let dtheta = turn.atan2(a.dot(b));
        theta_total += dtheta;
        let start = a.y.atan2(a.x);
        let numerator = a.perp_dot(edge);
        let panels = (dtheta.abs() / PANEL_ANGLE).ceil().max(1.0) as usize;
        let width = dtheta / panels as f64;
        for p in 0..panels {
            let mid = start + (p as f64 + 0.5) * width;
            for &(z, w) in nodes {
                let theta = mid + 0.5 * width * z;
                let dir = glam::DVec2::new(theta.cos(), theta.sin());
                let rho = numerator / dir.perp_dot(edge);
                let s = rho.hypot(h);
                let end = foot + (rho * dir.x) * u + (rho * dir.y) * v;
                ray(PolarRay { foot, end, s, h, w: 0.5 * width * w / (2.0 * PI) });
            }
        }
    }
    theta_total
}

/// The two-point rule in distance for a cell far from the receiver `x` (module documentation):
/// with piece k's area w_k, centroid c_k at distance d_k along u_k and covariance
/// Σ_k = (1/12) Σ_v (v − c_k)(v − c_k)ᵀ (a uniform triangle's), the distance's mean
/// μ = Σ w_k [d_k + (tr Σ_k − u_kᵀΣ_k u_k)/(2d_k)]/A (the spread across the line of sight
/// lengthens the distance to second order) and variance σ² = Σ w_k [(d_k − μ)² + u_kᵀΣ_k u_k]/A;
/// `shift` (the optical distance minus the chord) is added to both nodes. Returns
/// [(μ − σ, A/2), (μ + σ, A/2)].
pub(super) fn distance_rule(pieces: &[[DVec3; 3]], x: DVec3, shift: f64, area: f64) -> [(f64, f64); 2] {
    let mut stats = Vec::with_capacity(pieces.len());
    for &[a, b, c] in pieces {
        let w = 0.5 * (b - a).cross(c - a).length();
        let centroid = (a + b + c) / 3.0;
        let to = centroid - x;
        let d = to.length();
        let u = to / d;
        let (mut along, mut trace) = (0.0, 0.0);
        for v in [a, b, c] {
            let o = v - centroid;
            along += o.dot(u).powi(2) / 12.0;
            trace += o.length_squared() / 12.0;
        }
        stats.push((w, d, along, trace));
    }
    let total: f64 = stats.iter().map(|s| s.0).sum();
    let mean = stats.iter().map(|&(w, d, along, trace)| w * (d + (trace - along) / (2.0 * d))).sum::<f64>() / total;
    let var = stats.iter().map(|&(w, d, along, _)| w * ((d - mean).powi(2) + along)).sum::<f64>() / total;
    let sd = var.max(0.0).sqrt();
    [((mean - sd + shift).max(0.0), 0.5 * area), (mean + sd + shift, 0.5 * area)]
}

/// The 7-point degree-5 rule on a triangle (Radon 1948; Stroud T2:5-1): points and weights
/// (weights summing to the area).
pub(super) use crate::optics::quadrature::triangle_rule7_points as rule7;

/// The profile matrix S of one object, per channel, with its samples for re-indexing.
#[derive(Debug, Clone, PartialEq)]
pub struct ProfileMatrix {
    /// Shared between a matrix and the ones re-indexed from it (never changed in place).
    cache: Arc<SampleCache>,
    /// S per entry and channel (the local term on the diagonal included).
    values: Vec<[f64; 3]>,
    cutoffs: [f64; 3],
    tail: f64,
}

impl ProfileMatrix {
    /// S of `patches` for the channel profiles `profiles` (module documentation).
    ///
    /// # Errors
    /// [`RadiosityError::InvalidOptions`] unless `tail` is in (0, 1) and the gathering radius
    /// (when given) finite and > 0.
    pub fn build(
        patches: &ObjectPatches,
        profiles: &[Profile; 3],
        options: &ProfileOptions,
    ) -> Result<ProfileMatrix, RadiosityError> {
        if !(options.tail > 0.0 && options.tail < 1.0) {
            return Err(RadiosityError::InvalidOptions(format!("profile tail must be in (0, 1), got {}", options.tail)));
        }
        let cutoffs: [f64; 3] = std::array::from_fn(|c| profiles[c].cutoff(options.tail));
        let radius = match options.gather_radius {
            Some(r) if r.is_finite() && r > 0.0 => r,
            Some(r) => return Err(RadiosityError::InvalidOptions(format!("gather radius must be finite and > 0, got {r}"))),
            None => cutoffs.iter().copied().fold(0.0, f64::max),
        };
        let distances = gathered_distances(patches, &options.distance, radius);
        let cache = SampleCache::build(patches, &distances, radius);
        Self::evaluate(Arc::new(cache), profiles, options.tail)
    }

    /// S of `patches` in a heterogeneous object (Sheng et al. 2014 §4, eq. 16;
    /// [`super::profile_media`]): `media` says which of the media of `palette` (each medium's
    /// three channel profiles) fills each point, and every sample's value is `rule` applied to
    /// the lengths of its path in each medium ([`super::path_fractions`]). Media of equal
    /// profiles are merged first, so a palette of one distinct medium gives exactly
    /// [`ProfileMatrix::build`] with its profiles. The gathering radius is the largest cutoff of
    /// every medium and channel. Chord distances only: `options.distance` must be
    /// [`DistanceMode::Euclidean`].
    ///
    /// # Errors
    /// As [`ProfileMatrix::build`]; [`RadiosityError::InvalidOptions`] for an interior distance
    /// mode, an empty palette or one of a size other than `media.count()`;
    /// [`RadiosityError::TooManyMedia`] beyond [`super::MAX_MEDIA`];
    /// [`RadiosityError::HetRuleProfile`] when `rule` cannot use a profile of the palette.
    pub fn build_media(
        patches: &ObjectPatches,
        palette: &[[Profile; 3]],
        media: &dyn MediumIndex,
        rule: HetRule,
        options: &ProfileOptions,
    ) -> Result<ProfileMatrix, RadiosityError> {
        let Some(distinct) = EntryMedia::distinct(palette, media)? else {
            return Self::build(patches, &palette[0], options);
        };
        if let DistanceMode::Interior { .. } = options.distance {
            return Err(RadiosityError::InvalidOptions(
                "interior distances through a heterogeneous medium are not gathered (only chords are): use chord distances, \
                 or the diffusion S"
                    .into(),
            ));
        }
        for p in palette.iter().flatten() {
            rule.check(p)?;
        }
        if !(options.tail > 0.0 && options.tail < 1.0) {
            return Err(RadiosityError::InvalidOptions(format!("profile tail must be in (0, 1), got {}", options.tail)));
        }
        let reach = palette.iter().flatten().map(|p| p.cutoff(options.tail)).fold(0.0, f64::max);
        let radius = match options.gather_radius {
            Some(r) if r.is_finite() && r > 0.0 => r,
            Some(r) => return Err(RadiosityError::InvalidOptions(format!("gather radius must be finite and > 0, got {r}"))),
            None => reach,
        };
        if reach > radius * (1.0 + 1e-12) {
            return Err(RadiosityError::InvalidOptions(format!(
                "a medium's profile reaches {reach:.3} mm, beyond the {radius:.3} mm gathering radius"
            )));
        }
        let distances = gathered_distances(patches, &options.distance, radius);
        let cache = EntryMedia::build(patches, &distances, radius, &distinct);
        let profiles: Vec<[Profile; 3]> = distinct.palette.iter().map(|&m| palette[m].clone()).collect();
        Ok(EntryMedia::evaluate(cache, &profiles, rule, options.tail))
    }

    /// The same geometry re-evaluated for new `profiles` (a changed medium): bit-identical to
    /// [`ProfileMatrix::build`] with the same distances and gathering radius.
    ///
    /// # Errors
    /// [`RadiosityError::InvalidOptions`] when a channel's new cutoff exceeds the gathering
    /// radius (entries beyond it were never sampled: build afresh).
    pub fn reindex(&self, profiles: &[Profile; 3]) -> Result<ProfileMatrix, RadiosityError> {
        if self.cache.media.is_some() {
            return Err(RadiosityError::InvalidOptions(
                "the matrix of a heterogeneous object is built afresh for a new medium, not re-indexed".into(),
            ));
        }
        Self::evaluate(Arc::clone(&self.cache), profiles, self.tail)
    }

    /// The matrix of its parts (the heterogeneous build's).
    pub(super) fn from_parts(cache: SampleCache, values: Vec<[f64; 3]>, cutoffs: [f64; 3], tail: f64) -> ProfileMatrix {
        ProfileMatrix { cache: Arc::new(cache), values, cutoffs, tail }
    }

    fn evaluate(cache: Arc<SampleCache>, profiles: &[Profile; 3], tail: f64) -> Result<ProfileMatrix, RadiosityError> {
        let cutoffs: [f64; 3] = std::array::from_fn(|c| profiles[c].cutoff(tail));
        if let Some(c) = (0..3).find(|&c| cutoffs[c] > cache.gather_radius * (1.0 + 1e-12)) {
            return Err(RadiosityError::InvalidOptions(format!(
                "channel {c}'s profile reaches {:.3} mm, beyond the {:.3} mm its samples were gathered within: build the matrix afresh",
                cutoffs[c], cache.gather_radius
            )));
        }
        let n = cache.row_ptr.len() - 1;
        let locals: [f64; 3] = std::array::from_fn(|c| profiles[c].local());
        let rows: Vec<Vec<[f64; 3]>> = (0..n)
            .into_par_iter()
            .map(|j| {
                (cache.row_ptr[j]..cache.row_ptr[j + 1])
                    .map(|k| {
                        std::array::from_fn(|c| {
                            let v = cache.entry(k, &profiles[c], cutoffs[c]);
                            if cache.cols[k] as usize == j {
                                v + locals[c]
                            } else {
                                v
                            }
                        })
                    })
                    .collect()
            })
            .collect();
        Ok(ProfileMatrix { values: rows.concat(), cache, cutoffs, tail })
    }

    /// The number of patches (rows and columns).
    #[must_use]
    pub fn len(&self) -> usize {
        self.cache.row_ptr.len() - 1
    }

    /// Whether the matrix has no row.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Row `j`: its columns and their values per channel.
    #[must_use]
    pub fn row(&self, j: usize) -> (&[u32], &[[f64; 3]]) {
        let r = self.cache.row_ptr[j]..self.cache.row_ptr[j + 1];
        (&self.cache.cols[r.clone()], &self.values[r])
    }

    /// The entry S_ji per channel (0 outside the pattern).
    #[must_use]
    pub fn get(&self, j: usize, i: usize) -> [f64; 3] {
        let (cols, values) = self.row(j);
        cols.binary_search(&(i as u32)).map_or([0.0; 3], |k| values[k])
    }

    /// Each channel's cutoff radius (mm).
    #[must_use]
    pub fn cutoffs(&self) -> [f64; 3] {
        self.cutoffs
    }

    /// The samples behind the matrix.
    #[must_use]
    pub fn cache(&self) -> &SampleCache {
        &self.cache
    }

    /// The bytes the matrix and its samples hold.
    #[must_use]
    pub fn bytes(&self) -> usize {
        self.values.len() * (24 + 4 + 16) + self.cache.samples() * 8
    }

    /// B = S q per channel.
    ///
    /// # Errors
    /// [`RadiosityError::WrongLength`] unless `q` has one value per patch.
    pub fn apply(&self, q: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, RadiosityError> {
        if q.len() != self.len() {
            return Err(RadiosityError::WrongLength { what: "transmitted irradiance", expected: self.len(), got: q.len() });
        }
        Ok((0..self.len())
            .into_par_iter()
            .map(|j| {
                let (cols, values) = self.row(j);
                let mut b = [0.0; 3];
                for (&i, s) in cols.iter().zip(values) {
                    for c in 0..3 {
                        b[c] += s[c] * q[i as usize][c];
                    }
                }
                b
            })
            .collect())
    }
}

/// S of one translucent object as a profile matrix, the radiosity solver's [`Scattering`]
/// (module documentation). The method builds it once per object and geometry, from the object's
/// front patches ([`ObjectPatches::from_patch_set`]) and its medium's profiles, and passes it as
/// the object's `Translucent::scattering`; a medium change is [`ProfileScattering::set_profiles`].
#[derive(Debug, Clone)]
pub struct ProfileScattering {
    matrix: ProfileMatrix,
}

impl ProfileScattering {
    /// S of `patches` for `profiles` ([`ProfileMatrix::build`]).
    ///
    /// # Errors
    /// As [`ProfileMatrix::build`].
    pub fn new(patches: &ObjectPatches, profiles: &[Profile; 3], options: &ProfileOptions) -> Result<Self, RadiosityError> {
        Ok(Self { matrix: ProfileMatrix::build(patches, profiles, options)? })
    }

    /// The matrix.
    #[must_use]
    pub fn matrix(&self) -> &ProfileMatrix {
        &self.matrix
    }

    /// S of `patches` in a heterogeneous object ([`ProfileMatrix::build_media`]).
    ///
    /// # Errors
    /// As [`ProfileMatrix::build_media`].
    pub fn with_media(
        patches: &ObjectPatches,
        palette: &[[Profile; 3]],
        media: &dyn MediumIndex,
        rule: HetRule,
        options: &ProfileOptions,
    ) -> Result<Self, RadiosityError> {
        Ok(Self { matrix: ProfileMatrix::build_media(patches, palette, media, rule, options)? })
    }

    /// Re-evaluates S for new profiles on the same geometry ([`ProfileMatrix::reindex`]).
    ///
    /// # Errors
    /// As [`ProfileMatrix::reindex`]; nothing changes on error.
    pub fn set_profiles(&mut self, profiles: &[Profile; 3]) -> Result<(), RadiosityError> {
        self.matrix = self.matrix.reindex(profiles)?;
        Ok(())
    }
}

impl Scattering for ProfileScattering {
    type Error = RadiosityError;

    fn scatter(&mut self, q: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, RadiosityError> {
        self.matrix.apply(q)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::Medium;

    /// A flat square grid of `k`×`k` cells of side `h` in z = 0, normal +z.
    fn grid(k: usize, h: f64) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let mut p = Vec::new();
        for y in 0..=k {
            for x in 0..=k {
                p.push(DVec3::new(x as f64 * h, y as f64 * h, 0.0));
            }
        }
        let id = |x: usize, y: usize| (y * (k + 1) + x) as u32;
        let mut t = Vec::new();
        for y in 0..k {
            for x in 0..k {
                t.push([id(x, y), id(x + 1, y), id(x + 1, y + 1)]);
                t.push([id(x, y), id(x + 1, y + 1), id(x, y + 1)]);
            }
        }
        (p, t)
    }

    #[test]
    fn polar_samples_integrate_constants_and_areas() {
        // With R ≡ 1 on a disc of any radius, C(ρ) = πρ²: the polar samples of a triangle
        // sum C to its area, for feet inside, outside, at a corner and above the plane.
        let t = [DVec3::new(0.0, 0.0, 0.0), DVec3::new(2.0, 0.0, 0.0), DVec3::new(0.5, 1.5, 0.0)];
        let nodes = gauss_legendre(8);
        for x in [DVec3::new(0.7, 0.4, 0.0), DVec3::new(3.0, 2.0, 0.0), DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.7, 0.4, 0.8)] {
            let mut s = Vec::new();
            polar_samples(t, x, &nodes, &mut s);
            let area: f64 = s.iter().map(|&[d, w]| f64::from(w) * PI * f64::from(d).powi(2)).sum();
            assert!((area / 1.5 - 1.0).abs() < 1e-6, "{x}: {area}");
        }
        let total: f64 = rule7(t).iter().map(|p| p.1).sum();
        assert!((total - 1.5).abs() < 1e-14);
    }

    #[test]
    fn distance_rule_matches_the_cell_moments() {
        // A unit square as two triangles' six pieces... here simply two triangles, far away: the
        // rule integrates d and d² exactly to second order; check ∫ d² = Σ w (μ ± σ)² against
        // the exact ∫|x − y|² dA = A(|x − c|² + tr Cov) of the square (Cov = I/12 in-plane).
        let sq = [[DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0)], [DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0), DVec3::Y]];
        let x = DVec3::new(20.5, 0.5, 0.0);
        let rule = distance_rule(&sq, x, 0.0, 1.0);
        let second: f64 = rule.iter().map(|&(d, w)| w * d * d).sum();
        let exact = 400.0 + 2.0 / 12.0;
        assert!((second / exact - 1.0).abs() < 1e-5, "{second} vs {exact}");
        let first: f64 = rule.iter().map(|&(d, w)| w * d).sum();
        // ∫ d over the square at distance 20: 20 + (1/12)/(2·20) to second order.
        assert!((first - (20.0 + 1.0 / 480.0)).abs() < 1e-5, "{first}");
        assert_eq!(distance_rule(&sq, x, 1.5, 1.0)[1].0, rule[1].0 + 1.5);
    }

    #[test]
    fn patches_of_a_grid_and_self_entries() {
        let (p, t) = grid(4, 1.0);
        let patches = ObjectPatches::from_surface(&p, &t).unwrap();
        assert_eq!(patches.len(), 25);
        assert!((patches.areas().iter().sum::<f64>() - 16.0).abs() < 1e-12);
        let m = Medium { eta: 1.3, ..Medium::preset("marble").unwrap() };
        let profiles = Profile::dipole_rgb(&m);
        let s = ProfileMatrix::build(&patches, &profiles, &ProfileOptions::default()).unwrap();
        // Every pair of a 4 mm grid is within marble's cutoff: a full matrix.
        assert_eq!(s.cache().nonzeros(), 25 * 25);
        // The centre's self entry: Rd is nearly flat over a 1 mm² cell (Rd(0)·A to 30%).
        let c = 12;
        let d = m.dipole(0);
        let v = s.get(c, c)[0];
        assert!(v > 0.5 * d.rd(0.7) * patches.areas()[c] && v < d.rd(0.0) * patches.areas()[c], "{v}");
        // B = S q is linear and its length is checked.
        let q = vec![[1.0; 3]; 25];
        let b = s.apply(&q).unwrap();
        assert!(b.iter().all(|x| x[0] > 0.0));
        assert!(s.apply(&q[..3]).is_err());
        let mut op = ProfileScattering { matrix: s.clone() };
        assert_eq!(op.scatter(&q).unwrap(), b);
        // (1 − (0.3/2.3)²)/1.69/(π(1 − 0.444763)) with the Fdr fit.
        assert!((radiance_factor(1.3) - 0.333452).abs() < 1e-6, "{}", radiance_factor(1.3));
    }
}
