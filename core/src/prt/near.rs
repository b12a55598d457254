//! The near-field correction of the transfer rows (design/prt.md §1.3, not in the paper): the
//! point rule Σⱼ aⱼ bₖ(‖x_v − xⱼ‖) misses the z_r-wide peak of a dense medium's profile when the
//! samples are coarse (cream at 4096 samples on a 10 mm sphere: 23% off), so every row gets
//!
//! ∫_cell bₖ(‖x_v − y‖) dA(y) − Σ_{j in cell} aⱼ bₖ(‖x_v − xⱼ‖)
//!
//! for every cell (a triangle with samples and the sample-less triangles whose area they carry,
//! [`super::samples`]) within a few sample spacings of v. The correction is linear in bₖ, so it
//! survives the PCA; it makes uniform light exact and leaves the far field to the samples, where
//! the profile is smooth on their scale. Where it goes among the samples is the transfer's
//! choice ([`super::transfer`]).
//!
//! The triangle integrals ([`triangle_integral`]) are exact in the radial direction, through the
//! exact disc integral of the basis ([`RdBasis::disc`]), and numeric only along the edges; a
//! triangle far from v against its size takes the 7-point rule.

use glam::DVec3;

use crate::optics::quadrature::triangle_rule7_points;

use super::basis::{RdBasis, MAX_TERMS};

/// Edge segments longer than this fraction of their in-plane distance from the foot are bisected.
const SPLIT_RATIO: f64 = 0.5;
/// The deepest bisection of an edge.
const MAX_DEPTH: u32 = 48;

/// A uniform grid of triangles (by bounding box) for the query "every triangle within `radius`
/// of a point".
#[derive(Debug, Clone)]
pub(crate) struct TriangleGrid {
    origin: DVec3,
    cell: f64,
    dims: [usize; 3],
    start: Vec<u32>,
    items: Vec<u32>,
}

impl TriangleGrid {
    /// The grid of `triangles` over `positions`, cells of side `cell` (at most 2²⁴ cells: the
    /// side grows where the box would need more).
    pub(crate) fn new(positions: &[DVec3], triangles: &[[u32; 3]], cell: f64) -> TriangleGrid {
        let (lo, hi) = positions.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        let extent = (hi - lo).max(DVec3::splat(1e-12));
        let mut cell = cell.max(1e-12);
        while (extent / cell).ceil().element_product() > (1u64 << 24) as f64 {
            cell *= 2.0;
        }
        let dims = (extent / cell).ceil().max(DVec3::ONE).to_array().map(|d| d as usize);
        let index = |c: [usize; 3]| (c[2] * dims[1] + c[1]) * dims[0] + c[0];
        let cell_of = |p: DVec3| {
            let c = ((p - lo) / cell).floor();
            [0, 1, 2].map(|a| (c[a].max(0.0) as usize).min(dims[a] - 1))
        };
        let boxes: Vec<([usize; 3], [usize; 3])> = triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| positions[v as usize]);
                (cell_of(a.min(b).min(c)), cell_of(a.max(b).max(c)))
            })
            .collect();
        let mut start = vec![0u32; dims[0] * dims[1] * dims[2] + 1];
        let for_cells = |(lo, hi): &([usize; 3], [usize; 3]), f: &mut dyn FnMut(usize)| {
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    for x in lo[0]..=hi[0] {
                        f(index([x, y, z]));
                    }
                }
            }
        };
        for b in &boxes {
            for_cells(b, &mut |c| start[c + 1] += 1);
        }
        for c in 1..start.len() {
            start[c] += start[c - 1];
        }
        let mut fill = start.clone();
        let mut items = vec![0u32; *start.last().unwrap() as usize];
        for (t, b) in boxes.iter().enumerate() {
            for_cells(b, &mut |c| {
                items[fill[c] as usize] = t as u32;
                fill[c] += 1;
            });
        }
        TriangleGrid { origin: lo, cell, dims, start, items }
    }

    /// Every triangle whose bounding box comes within `radius` of `p`, once each, into `out`
    /// (cleared first), sorted.
    pub(crate) fn near(&self, p: DVec3, radius: f64, out: &mut Vec<u32>) {
        out.clear();
        let lo = ((p - radius - self.origin) / self.cell).floor();
        let hi = ((p + radius - self.origin) / self.cell).floor();
        let clamp = |v: f64, a: usize| (v.max(0.0) as usize).min(self.dims[a] - 1);
        for z in clamp(lo.z, 2)..=clamp(hi.z, 2) {
            for y in clamp(lo.y, 1)..=clamp(hi.y, 1) {
                for x in clamp(lo.x, 0)..=clamp(hi.x, 0) {
                    let c = (z * self.dims[1] + y) * self.dims[0] + x;
                    out.extend_from_slice(&self.items[self.start[c] as usize..self.start[c + 1] as usize]);
                }
            }
        }
        out.sort_unstable();
        out.dedup();
    }
}

/// ∫ over the triangle `corners` of every bₖ(‖y − x‖) dA(y), added to `out` (mm, the basis's
/// units), in polar coordinates about the foot p of x on the triangle's plane (height h):
/// with s² = ρ² + h², ρ dρ = s ds, so the radial integral over the wedge from p to an edge is
/// exact in the disc integral D of the basis, [D(s_e(θ)) − D(|h|)]/2π, and the triangle is the
/// signed sum of its three wedges (as [`crate::optics::Dipole::triangle_integral`] does for the
/// dipole):
///
/// ∫ₜ b dA = (1/2π) [Σₑ ∫ D(√(Rₑ² + t² + h²)) Rₑ/(Rₑ² + t²) dt − Θ D(|h|)],
///
/// t along edge e from the foot of p on its line, Rₑ the signed distance of p from that line
/// (positive on the left of the edge), Θ the angle the triangle subtends at p (2π inside, 0
/// outside). Only the edge integrals are numeric: 4-point Gauss–Legendre on segments bisected
/// until each is shorter than half its in-plane distance from p.
pub(crate) fn triangle_integral(basis: &RdBasis, corners: [DVec3; 3], x: DVec3, out: &mut [f64]) {
    let [a, b, c] = corners;
    let centre = (a + b + c) / 3.0;
    let radius = centre.distance_squared(a).max(centre.distance_squared(b)).max(centre.distance_squared(c)).sqrt();
    if centre.distance(x) > FAR * radius {
        // Far against its size: the kernel is smooth over it, the 7-point rule suffices.
        let k = basis.terms();
        let mut row = [0.0; MAX_TERMS];
        for (p, w) in triangle_rule7_points(corners) {
            basis.eval(p.distance(x), &mut row[..k]);
            for (o, v) in out.iter_mut().zip(&row[..k]) {
                *o += w * v;
            }
        }
        return;
    }
    let Some(n) = (b - a).cross(c - a).try_normalize() else {
        return;
    };
    let h = (x - a).dot(n);
    let foot = x - h * n;
    let k = basis.terms();
    let mut edges = [0.0; MAX_TERMS];
    let (mut theta, mut on_boundary) = (0.0, false);
    for e in 0..3 {
        let (p, q) = (corners[e], corners[(e + 1) % 3]);
        let length = p.distance(q);
        let u = (q - p) / length;
        let (pa, pb) = (p - foot, q - foot);
        let r = n.dot(u.cross(foot - p));
        if r.abs() <= COLLINEAR * length {
            let slack = COLLINEAR * length;
            on_boundary |= pa.dot(u) <= slack && pb.dot(u) >= -slack;
            continue;
        }
        theta += n.dot(pa.cross(pb)).atan2(pa.dot(pb));
        edge_integral(basis, r, h, pa.dot(u), pb.dot(u), &mut edges[..k]);
    }
    if !on_boundary {
        theta = if theta > std::f64::consts::PI { std::f64::consts::TAU } else { 0.0 };
    }
    let mut at_foot = [0.0; MAX_TERMS];
    if theta != 0.0 {
        basis.disc(h.abs(), &mut at_foot[..k]);
    }
    for ((o, e), d) in out.iter_mut().zip(&edges[..k]).zip(&at_foot[..k]) {
        *o += (e - theta * d) / std::f64::consts::TAU;
    }
}

/// A triangle whose centre is farther from x than this many times its circumradius is
/// integrated by the 7-point rule (degree 5: relative error ~(1/FAR)⁶ for a kernel smooth on the
/// scale of the distance).
const FAR: f64 = 6.0;

/// An edge line passing within this fraction of the edge's length of the foot bounds a wedge
/// without area.
const COLLINEAR: f64 = 1e-12;

/// ∫_{t₁}^{t₂} D(√(R² + t² + h²)) R/(R² + t²) dt for every term into `out` (added).
fn edge_integral(basis: &RdBasis, r: f64, h: f64, t1: f64, t2: f64, out: &mut [f64]) {
    const GL4: [(f64, f64); 4] = [
        (-0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
        (-0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
        (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
        (0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
    ];
    let k = basis.terms();
    let mut d = [0.0; MAX_TERMS];
    let mut stack = [(0.0, 0.0, 0u32); MAX_DEPTH as usize + 2];
    stack[0] = (t1, t2, 0);
    let mut pending = 1;
    while pending > 0 {
        pending -= 1;
        let (lo, hi, depth) = stack[pending];
        let mid = 0.5 * (lo + hi);
        if (hi - lo).abs() > SPLIT_RATIO * (r * r + mid * mid).sqrt() && depth < MAX_DEPTH {
            stack[pending] = (lo, mid, depth + 1);
            stack[pending + 1] = (mid, hi, depth + 1);
            pending += 2;
            continue;
        }
        let half = 0.5 * (hi - lo);
        for &(node, w) in &GL4 {
            let t = mid + half * node;
            let rho2 = r * r + t * t;
            basis.disc((rho2 + h * h).sqrt(), &mut d[..k]);
            let weight = half * w * r / rho2;
            for (o, v) in out.iter_mut().zip(&d[..k]) {
                *o += weight * v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::basis::BasisSize;
    use super::*;

    /// A brute-force reference: adaptive 4-to-1 subdivision of the 7-point rule until every
    /// piece is smaller than 1/20 of its distance from x.
    fn cubature(basis: &RdBasis, corners: [DVec3; 3], x: DVec3, depth: u32, out: &mut [f64]) {
        let [a, b, c] = corners;
        let centre = (a + b + c) / 3.0;
        let radius = centre.distance(a).max(centre.distance(b)).max(centre.distance(c));
        let distance = (centre.distance(x) - radius).max(0.0);
        if depth > 0 && 2.0 * radius > 0.05 * distance {
            let (ab, bc, ca) = ((a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5);
            for piece in [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]] {
                cubature(basis, piece, x, depth - 1, out);
            }
            return;
        }
        let mut row = [0.0; MAX_TERMS];
        for (p, w) in triangle_rule7_points(corners) {
            basis.eval(p.distance(x), &mut row[..basis.terms()]);
            for (o, v) in out.iter_mut().zip(&row) {
                *o += w * v;
            }
        }
    }

    /// On a flat fan of triangles around x covering a disc of radius ρ (a regular 64-gon, whose
    /// area differs from the disc's only at the rim, where the basis is ~0 for ρ ≫ its scale),
    /// the corner-polar integrals sum to the disc integral D(ρ); the cubature of the same fan
    /// about a point off the fan's corner agrees with the polar rule about that point.
    #[test]
    fn fan_integrates_to_the_disc() {
        let basis = RdBasis::get(BasisSize::K16);
        let k = basis.terms();
        let rho = 40.0;
        let n = 256;
        let ring: Vec<DVec3> = (0..n)
            .map(|i| {
                rho * DVec3::new(
                    (i as f64 * std::f64::consts::TAU / n as f64).cos(),
                    (i as f64 * std::f64::consts::TAU / n as f64).sin(),
                    0.0,
                )
            })
            .collect();
        let mut sum = vec![0.0; k];
        for i in 0..n {
            triangle_integral(basis, [DVec3::ZERO, ring[i], ring[(i + 1) % n]], DVec3::ZERO, &mut sum);
        }
        // The 256-gon's chord segments lose area where r ∈ [ρ cos(π/256), ρ]: compare with the
        // disc integral to the polygon's inner radius and to its outer one.
        let (mut inner, mut outer) = (vec![0.0; k], vec![0.0; k]);
        basis.disc(rho * (std::f64::consts::PI / n as f64).cos(), &mut inner);
        basis.disc(rho, &mut outer);
        for j in 0..k {
            let (lo, hi) = (inner[j].min(outer[j]), inner[j].max(outer[j]));
            let slack = 1e-9 * outer[0].abs();
            assert!(sum[j] >= lo - slack && sum[j] <= hi + slack, "term {j}: {} not in [{lo}, {hi}]", sum[j]);
        }
        // A point 0.2 mm outside a triangle across its edge bc: the cubature against corner-polar
        // pieces, ∫_abc = ∫_xba + ∫_xac − ∫_xbc (the quadrilateral x b a c is convex).
        let (a, b, c) = (DVec3::new(0.0, 1.5, 0.0), DVec3::new(-1.0, 0.0, 0.0), DVec3::new(1.2, 0.1, 0.0));
        let x = 0.5 * (b + c) - DVec3::Y * 0.2;
        let (mut polar, mut minus, mut cub) = (vec![0.0; k], vec![0.0; k], vec![0.0; k]);
        triangle_integral(basis, [x, b, a], x, &mut polar);
        triangle_integral(basis, [x, a, c], x, &mut polar);
        triangle_integral(basis, [x, b, c], x, &mut minus);
        let mut direct = vec![0.0; k];
        triangle_integral(basis, [a, b, c], x, &mut direct);
        // And 0.4 mm above the plane, against brute-force cubature.
        let lifted = x + DVec3::Z * 0.4;
        let mut above = vec![0.0; k];
        triangle_integral(basis, [a, b, c], lifted, &mut above);
        cubature(basis, [a, b, c], lifted, 12, &mut cub);
        for j in 0..k {
            let want = polar[j] - minus[j];
            assert!((direct[j] - want).abs() < 1e-9 * polar[0].abs(), "term {j}: foot outside {} vs corners {want}", direct[j]);
            assert!((above[j] - cub[j]).abs() < 1e-5 * above[0].abs(), "term {j}: lifted {} vs cubature {}", above[j], cub[j]);
        }
    }

    #[test]
    fn the_grid_finds_every_triangle_within_the_radius() {
        let sphere = crate::mesh::icosphere(10.0, 3);
        let grid = TriangleGrid::new(sphere.positions(), sphere.triangles(), 2.0);
        let mut found = Vec::new();
        for p in [DVec3::new(10.0, 0.0, 0.0), DVec3::new(0.0, -7.0, 7.0), DVec3::ZERO] {
            grid.near(p, 2.0, &mut found);
            for t in 0..sphere.triangles().len() {
                let (closest, _) = crate::mesh::closest_point_on_triangle(p, sphere.triangle(t));
                if closest.distance(p) <= 2.0 {
                    assert!(found.binary_search(&(t as u32)).is_ok(), "triangle {t} at {} missed", closest.distance(p));
                }
            }
        }
    }
}
