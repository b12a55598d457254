//! Untangling and smoothing of a mapped polygrid by node-wise optimisation (Escobar et al. 2003,
//! "Simultaneous untangling and smoothing of tetrahedral meshes"; Knupp 2001 for the
//! algebraic distortion).
//!
//! The projection of [`super::map_to_surface`] is not injective where the surface bends within
//! a cube (the bunny's ears and neck): a few surface quads turn over and the cells under them
//! fold, at every cube size. Laplacian smoothing cannot repair that, because it does not see
//! orientation. Here every element is measured against its lattice shape by the mean-ratio
//! distortion with the *modified* determinant of Escobar et al., which stays finite and smooth
//! for turned elements, so minimising the sum over a node's elements moves the node out of
//! a fold instead of stopping at it. A size term keeps nodes that the projection gathered at
//! one point from staying there (`size_penalty`), and a node whose elements are all valid
//! never takes a move that turns one (`guarded`).
//!
//! - [`untangle_surface`]: the boundary nodes slide on the surface (a Newton step in the
//!   tangent plane, projected back by closest point, kept only if the projected distortion
//!   fell), measured by the four corner triangles of each surface quad against a square.
//! - [`untangle_volume`]: the other nodes move freely, measured by the six Kuhn tets of each
//!   cell (the elements the FEM stencil integrates over, [`super::Polygrid::kuhn_tets`])
//!   against the lattice's Kuhn tets.
//!
//! Both visit only the nodes of poor elements (turned, nearly flat or very distorted) and their
//! neighbours, colour by colour (each colour's nodes in parallel: Gauss–Seidel in colour
//! order), a few Newton iterations per visit.

use glam::{DMat3, DVec2, DVec3};
use rayon::prelude::*;

use crate::mesh::Incidence;

/// A turned or nearly flat element: normalised determinant below this.
const FLAT: f64 = 0.02;

/// An element so distorted that its nodes are smoothed: mean-ratio distortion above this
/// (1 for the lattice's shape).
const DISTORTED: f64 = 4.0;

/// Escobar's ε: the modified determinant's δ is √(ε(ε − σ_min)) where σ_min < ε.
const EPSILON: f64 = 1e-3;

/// Sweeps without fewer turned elements after which a pass gives up.
const STALL: usize = 20;

/// Newton iterations per node visit.
const NEWTON: usize = 4;

/// What an untangling pass did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct UntangleReport {
    /// Turned (or flat) elements before and after.
    pub turned_before: usize,
    pub turned_after: usize,
    /// Sweeps over the active nodes.
    pub sweeps: usize,
    /// Node visits.
    pub visits: usize,
}

/// Escobar et al. 2003 eq. 5: the modified determinant h(σ) = ½(σ + √(σ² + 4δ²)), positive
/// for every σ when δ > 0 and equal to σ for δ = 0, σ > 0; with dh/dσ.
fn modified_determinant(sigma: f64, delta: f64) -> (f64, f64) {
    let root = (sigma * sigma + 4.0 * delta * delta).sqrt();
    let h = 0.5 * (sigma + root);
    // dh/dσ = h / root (the derivative of ½(σ + root) is ½(1 + σ/root) = h/root).
    (h, if root > 0.0 { h / root } else { 0.5 })
}

/// δ for a neighbourhood whose smallest normalised determinant is `sigma_min` (Escobar et al.
/// 2003 §3): 0 when every element is valid, else just large enough to regularise the turned
/// ones.
fn delta_for(sigma_min: f64) -> f64 {
    if sigma_min < EPSILON {
        (EPSILON * (EPSILON - sigma_min)).sqrt()
    } else {
        0.0
    }
}

/// The size term added to the shape distortion: ½(h + 1/h) − 1 of the modified normalised
/// determinant h, 0 at the target's size, and its derivative by σ (given dh/dσ). The mean
/// ratio alone is blind to size, and with δ > 0 an element shrunk to a point scores 0, below
/// every valid shape: where the projection has gathered several surface nodes at one point
/// (a pit of the surface), the size term is what pushes them apart again.
fn size_penalty(h: f64, dh: f64) -> (f64, f64) {
    (0.5 * (h + 1.0 / h) - 1.0, 0.5 * (1.0 - 1.0 / (h * h)) * dh)
}

/// The mean-ratio distortion of a tet with edge matrix `e` (columns x₁ − x₀, x₂ − x₀, x₃ − x₀)
/// against the target whose inverse edge matrix is `w_inv` (Knupp 2001; Escobar et al. 2003
/// eq. 6 with the modified determinant): S = E W⁻¹, η = |S|²_F / (3 h(det S)^{2/3}), 1 for the
/// target's shape at any size and rotation, plus [`size_penalty`]. Returns the sum and its
/// gradient by E, or `None` where it is infinite (a flat or turned tet at δ = 0).
fn tet_distortion(e: DMat3, w_inv: DMat3, delta: f64) -> Option<(f64, DMat3)> {
    let s = e * w_inv;
    let norm2 = s.x_axis.length_squared() + s.y_axis.length_squared() + s.z_axis.length_squared();
    let (h, dh) = modified_determinant(s.determinant(), delta);
    if !(h > 0.0) {
        return None;
    }
    let h23 = h.powf(2.0 / 3.0);
    let eta = norm2 / (3.0 * h23);
    let (size, dsize) = size_penalty(h, dh);
    // ∂|S|²/∂E = 2 S W⁻ᵀ; ∂ det S/∂E = det W⁻¹ cof E, cof E's columns e₁×e₂, e₂×e₀, e₀×e₁.
    let cofactor = DMat3::from_cols(e.y_axis.cross(e.z_axis), e.z_axis.cross(e.x_axis), e.x_axis.cross(e.y_axis));
    let dsigma = w_inv.determinant();
    let grad = (s * w_inv.transpose()) * (2.0 / (3.0 * h23)) + cofactor * ((dsize - 2.0 * eta * dh / (3.0 * h)) * dsigma);
    Some((eta + size, grad))
}

/// The mean-ratio distortion of a triangle corner with edge vectors `e0`, `e1` (in a tangent
/// plane) against a square corner of edge `size` (the 2-D form of [`tet_distortion`]):
/// S = E / size, η = |S|²_F / (2 h(det S)), 1 for a right isosceles corner, plus
/// [`size_penalty`]. Returns the sum and its gradient by e0 and e1, or `None` where it is
/// infinite.
fn corner_distortion(e0: DVec2, e1: DVec2, size: f64, delta: f64) -> Option<(f64, [DVec2; 2])> {
    let inv = 1.0 / size;
    let (s0, s1) = (e0 * inv, e1 * inv);
    let norm2 = s0.length_squared() + s1.length_squared();
    let (h, dh) = modified_determinant(s0.perp_dot(s1), delta);
    if !(h > 0.0) {
        return None;
    }
    let eta = norm2 / (2.0 * h);
    let (size, dsize) = size_penalty(h, dh);
    // ∂ det S/∂s0 = (s1.y, −s1.x), ∂/∂s1 = (−s0.y, s0.x).
    let c = eta * dh / h - dsize;
    let g0 = (s0 / h - DVec2::new(s1.y, -s1.x) * c) * inv;
    let g1 = (s1 / h - DVec2::new(-s0.y, s0.x) * c) * inv;
    Some((eta + size, [g0, g1]))
}

/// Newton's method for one node: `eval(x)` is the node's distortion and gradient (`None` when
/// infinite); the Hessian by central differences of the gradient at step `length` × 10⁻⁴,
/// damped until positive definite, the step capped at `length` / 2 and halved until the
/// distortion falls. Returns the new position (the old one if nothing fell).
fn newton(x: DVec3, length: f64, eval: &dyn Fn(DVec3) -> Option<(f64, DVec3)>) -> DVec3 {
    let Some((mut f, mut g)) = eval(x) else { return x };
    let mut x = x;
    let eps = 1e-4 * length;
    for _ in 0..NEWTON {
        if !(g.length() * length > 1e-9 * f) {
            break;
        }
        let column = |axis: DVec3| match (eval(x + eps * axis), eval(x - eps * axis)) {
            (Some((_, a)), Some((_, b))) => Some((a - b) / (2.0 * eps)),
            _ => None,
        };
        let hessian = match (column(DVec3::X), column(DVec3::Y), column(DVec3::Z)) {
            (Some(a), Some(b), Some(c)) => {
                let m = DMat3::from_cols(a, b, c);
                (m + m.transpose()) * 0.5
            }
            _ => DMat3::IDENTITY * (g.length() / length),
        };
        let scale = hessian.x_axis.x.abs() + hessian.y_axis.y.abs() + hessian.z_axis.z.abs() + f64::MIN_POSITIVE;
        let mut damping = 0.0;
        let mut step = DVec3::ZERO;
        for _ in 0..30 {
            let m = hessian + DMat3::IDENTITY * damping;
            if positive_definite(&m) {
                step = -(m.inverse() * g);
                if step.is_finite() && step.dot(g) < 0.0 {
                    break;
                }
            }
            damping = if damping == 0.0 { 1e-6 * scale } else { damping * 4.0 };
        }
        if step.length() > 0.5 * length {
            step *= 0.5 * length / step.length();
        }
        let mut accepted = false;
        for _ in 0..12 {
            if let Some((fy, gy)) = eval(x + step) {
                if fy < f {
                    x += step;
                    (f, g) = (fy, gy);
                    accepted = true;
                    break;
                }
            }
            step *= 0.5;
        }
        if !accepted {
            break;
        }
    }
    x
}

/// A node's distortion and gradient at a trial position, `None` where the move would turn an
/// element of a node whose elements are all valid (`turned_here` = 0): with δ > 0 (set by a
/// turned element nearby) the distortion is finite across zero volume, and a move that lowers
/// it by turning a valid element over is refused. Within a tangle any move that lowers the
/// distortion is taken: untangling may have to pass through other turned states.
fn guarded(local: Option<(f64, DVec3, usize)>, turned_here: usize) -> Option<(f64, DVec3)> {
    local.filter(|l| turned_here > 0 || l.2 == 0).map(|(f, g, _)| (f, g))
}

/// Whether a symmetric 3 × 3 matrix is positive definite (Sylvester's criterion).
fn positive_definite(m: &DMat3) -> bool {
    let (a, b) = (m.x_axis, m.y_axis);
    a.x > 0.0 && a.x * b.y - a.y * b.x > 0.0 && m.determinant() > 0.0
}

/// The six Kuhn tets of the unit lattice cell ([`super::Polygrid::kuhn_tets`]'s order), each
/// as the inverse of its edge matrix scaled by `spacing`.
fn kuhn_targets(spacing: f64) -> [DMat3; 6] {
    const PATHS: [[usize; 2]; 6] = [[1, 2], [1, 4], [2, 1], [2, 4], [4, 1], [4, 2]];
    let corner = |k: usize| DVec3::new((k & 1) as f64, ((k >> 1) & 1) as f64, ((k >> 2) & 1) as f64) * spacing;
    PATHS.map(|[a, b]| DMat3::from_cols(corner(a), corner(a | b), corner(7)).inverse())
}

/// Untangles and smooths the nodes not `fixed` against the Kuhn tets `tets` (six per cell, in
/// [`super::Polygrid::kuhn_tets`]'s order) of a lattice of `spacing` (see the module
/// documentation), in at most `sweeps` sweeps.
pub fn untangle_volume(
    positions: &mut [DVec3],
    tets: &[[u32; 4]],
    fixed: &[bool],
    colours: &[u8],
    spacing: f64,
    sweeps: usize,
) -> UntangleReport {
    let targets = kuhn_targets(spacing);
    let incidence = Incidence::new(tets, positions.len());
    let sigma = |x: &[DVec3], t: usize| -> f64 {
        let [a, b, c, d] = tets[t].map(|i| x[i as usize]);
        (DMat3::from_cols(b - a, c - a, d - a) * targets[t % 6]).determinant()
    };
    let measure = |x: &[DVec3], which: &[u32]| -> Vec<(f64, f64)> {
        which
            .par_iter()
            .map(|&t| {
                let t = t as usize;
                let [a, b, c, d] = tets[t].map(|i| x[i as usize]);
                let s = sigma(x, t);
                (s, shape_only(tet_distortion(DMat3::from_cols(b - a, c - a, d - a), targets[t % 6], delta_for(s)), s))
            })
            .collect()
    };
    // The node's distortion, gradient and turned tets at `p`.
    let local = |x: &[DVec3], node: usize, p: DVec3, delta: f64| -> Option<(f64, DVec3, usize)> {
        let mut total = (0.0, DVec3::ZERO, 0);
        for &(t, corner) in incidence.around(node) {
            let mut v = tets[t as usize].map(|i| x[i as usize]);
            v[corner as usize] = p;
            let e = DMat3::from_cols(v[1] - v[0], v[2] - v[0], v[3] - v[0]);
            let target = targets[t as usize % 6];
            total.2 += usize::from(!(e.determinant() * target.determinant() > 0.0));
            let (eta, grad) = tet_distortion(e, target, delta)?;
            let g = match corner {
                0 => -(grad.x_axis + grad.y_axis + grad.z_axis),
                1 => grad.x_axis,
                2 => grad.y_axis,
                _ => grad.z_axis,
            };
            total = (total.0 + eta, total.1 + g, total.2);
        }
        Some(total)
    };
    let neighbour_sigma_min = |x: &[DVec3], node: usize| {
        incidence.around(node).iter().map(|&(t, _)| sigma(x, t as usize)).fold(f64::INFINITY, f64::min)
    };
    run_sweeps(positions, tets, fixed, colours, sweeps, &measure, &|x, node| {
        let delta = delta_for(neighbour_sigma_min(x, node));
        let Some((_, _, turned)) = local(x, node, x[node], delta) else { return x[node] };
        newton(x[node], spacing, &|p| guarded(local(x, node, p, delta), turned))
    })
}

/// Untangles and smooths the surface quads `quads` (outward, counter-clockwise), their nodes
/// sliding on the surface: `project(p)` is the closest surface point and its unit normal.
/// Corners are measured against a square of edge `spacing`.
pub fn untangle_surface(
    positions: &mut [DVec3],
    reference: &[DVec3],
    quads: &[[u32; 4]],
    colours: &[u8],
    spacing: f64,
    sweeps: usize,
    project: &(dyn Fn(DVec3) -> (DVec3, DVec3) + Sync),
) -> UntangleReport {
    // The four corner triangles of each quad: (corner, next, previous).
    let corners: Vec<[u32; 3]> = quads.iter().flat_map(|q| (0..4).map(move |k| [q[k], q[(k + 1) % 4], q[(k + 3) % 4]])).collect();
    let incidence = Incidence::new(&corners, positions.len());
    // Each node's quad-edge neighbours.
    let edges: Vec<[u32; 2]> = quads.iter().flat_map(|q| (0..4).map(move |k| [q[k], q[(k + 1) % 4]])).collect();
    let edge_incidence = Incidence::new(&edges, positions.len());
    let neighbours = |node: usize| edge_incidence.around(node).iter().map(|&(e, corner)| edges[e as usize][1 - corner as usize]);
    let fixed: Vec<bool> = (0..positions.len()).map(|i| incidence.around(i).is_empty()).collect();
    // A corner's signed measure in the plane ⟂ `normal`.
    let in_plane =
        |p: DVec3, origin: DVec3, frame: &(DVec3, DVec3)| DVec2::new((p - origin).dot(frame.0), (p - origin).dot(frame.1));
    let frame_of = |normal: DVec3| {
        let t1 = normal.any_orthonormal_vector();
        (t1, normal.cross(t1))
    };
    let sigma = |x: &[DVec3], c: usize, frame: &(DVec3, DVec3)| {
        let [a, b, d] = corners[c].map(|i| x[i as usize]);
        in_plane(b, a, frame).perp_dot(in_plane(d, a, frame)) / (spacing * spacing)
    };
    // The corner's own normal says nothing about turning: each corner is measured in the
    // plane of the surface under its corner node.
    let measure = |x: &[DVec3], which: &[u32]| -> Vec<(f64, f64)> {
        which
            .par_iter()
            .map(|&c| {
                let c = c as usize;
                let [a, b, d] = corners[c].map(|i| x[i as usize]);
                let frame = &frame_of(project(a).1);
                let s = sigma(x, c, frame);
                (s, shape_only(corner_distortion(in_plane(b, a, frame), in_plane(d, a, frame), spacing, delta_for(s)), s))
            })
            .collect()
    };
    let local = |x: &[DVec3], node: usize, p: DVec3, frame: &(DVec3, DVec3), delta: f64| -> Option<(f64, DVec3, usize)> {
        let mut total = (0.0, DVec3::ZERO, 0);
        for &(c, corner) in incidence.around(node) {
            let mut v = corners[c as usize].map(|i| in_plane(x[i as usize], x[node], frame));
            v[corner as usize] = in_plane(p, x[node], frame);
            total.2 += usize::from(!((v[1] - v[0]).perp_dot(v[2] - v[0]) > 0.0));
            let (eta, [g0, g1]) = corner_distortion(v[1] - v[0], v[2] - v[0], spacing, delta)?;
            let g = match corner {
                0 => -(g0 + g1),
                1 => g0,
                _ => g1,
            };
            total = (total.0 + eta, total.1 + frame.0 * g.x + frame.1 * g.y, total.2);
        }
        Some(total)
    };
    run_sweeps(positions, &corners, &fixed, colours, sweeps, &measure, &|x, node| {
        let (_, normal) = project(x[node]);
        let frame = frame_of(normal);
        let sigma_min = incidence.around(node).iter().map(|&(c, _)| sigma(x, c as usize, &frame)).fold(f64::INFINITY, f64::min);
        let delta = delta_for(sigma_min);
        let Some((before, _, turned)) = local(x, node, x[node], &frame, delta) else { return x[node] };
        let eval = |p: DVec3| guarded(local(x, node, p, &frame, delta), turned);
        // Back onto the surface; kept only where the projected position is still better.
        // The projection must stay on this sheet of the surface (not jump across a thin part
        // to a point that merely looks right in the tangent plane).
        let try_step = |mut step: DVec3| {
            for _ in 0..6 {
                let (p, n) = project(x[node] + step);
                let on_sheet = n.dot(normal) > 0.5 && (p - (x[node] + step)).length() < 0.25 * spacing;
                if on_sheet && eval(p).is_some_and(|(f, _)| f < before) {
                    return Some(p);
                }
                step *= 0.5;
            }
            None
        };
        if let Some(p) = try_step(newton(x[node], spacing, &eval) - x[node]) {
            return p;
        }
        // Nodes gathered at one point (a pit of the surface that was the closest point of all
        // of them) sit on a saddle of the distortion: no gradient tells them apart. They part
        // along their lattice offsets from the gathering's lattice centre.
        let gathered: Vec<u32> = neighbours(node).filter(|&j| (x[j as usize] - x[node]).length() < 1e-3 * spacing).collect();
        if gathered.is_empty() {
            return x[node];
        }
        let centre =
            (gathered.iter().map(|&j| reference[j as usize]).sum::<DVec3>() + reference[node]) / (gathered.len() + 1) as f64;
        let away = reference[node] - centre;
        let away = away - normal * away.dot(normal);
        let Some(direction) = away.try_normalize() else { return x[node] };
        try_step(direction * (0.5 * spacing)).unwrap_or(x[node])
    })
}

/// The shape part of a distortion (`None`: infinite) of normalised determinant `sigma`: the
/// size term taken off again, so that the poor-element threshold sees the shape only.
fn shape_only<T>(distortion: Option<(f64, T)>, sigma: f64) -> f64 {
    distortion.map_or(f64::INFINITY, |(f, _)| f - size_penalty(modified_determinant(sigma, delta_for(sigma)).0, 0.0).0)
}

/// Per element of the listed ids: the normalised determinant and the shape distortion at the
/// given positions.
type Measure<'a> = dyn Fn(&[DVec3], &[u32]) -> Vec<(f64, f64)> + 'a;

/// The sweeps shared by both passes: measure every element (`measure`: normalised
/// determinant and shape distortion per element), visit the movable nodes of the poor ones
/// and their neighbours (`visit` returns a node's new position) colour by colour, the nodes of
/// one colour in parallel (`colours` must give the nodes of an element distinct colours, so
/// that the result is that of a sequential Gauss–Seidel sweep in colour order), until no
/// element is poor, nothing moves or `sweeps` is reached.
fn run_sweeps<const N: usize>(
    positions: &mut [DVec3],
    elements: &[[u32; N]],
    fixed: &[bool],
    colours: &[u8],
    sweeps: usize,
    measure: &Measure<'_>,
    visit: &(dyn Fn(&[DVec3], usize) -> DVec3 + Sync),
) -> UntangleReport {
    let turned = |q: &[(f64, f64)]| q.iter().filter(|q| !(q.0 > 0.0)).count();
    let poor = |q: &(f64, f64)| q.0 < FLAT || !(q.1 < DISTORTED);
    let all: Vec<u32> = (0..elements.len() as u32).collect();
    let mut q = measure(positions, &all);
    let mut report = UntangleReport { turned_before: turned(&q), ..UntangleReport::default() };
    let incidence = Incidence::new(elements, positions.len());
    let colour_count = colours.iter().copied().max().map_or(0, |c| c as usize + 1);
    let mut active = vec![false; positions.len()];
    let mut moved_node = vec![false; positions.len()];
    let mut poor_before = usize::MAX;
    let (mut fewest, mut since_fewer) = (report.turned_before, 0);
    for _ in 0..sweeps {
        active.fill(false);
        let poor_now = q.iter().filter(|q| poor(q)).count();
        // Done when nothing is poor, or when nothing is turned and the poor stopped falling.
        if poor_now == 0 || (turned(&q) == 0 && poor_now >= poor_before) {
            break;
        }
        poor_before = poor_now;
        for (e, nodes) in elements.iter().enumerate() {
            if poor(&q[e]) {
                for &v in nodes {
                    // The node and every node sharing an element with it.
                    for &(f, _) in incidence.around(v as usize) {
                        for &w in &elements[f as usize] {
                            active[w as usize] = true;
                        }
                    }
                }
            }
        }
        let mut moved = 0.0f64;
        moved_node.fill(false);
        for colour in 0..colour_count {
            let nodes: Vec<usize> =
                (0..positions.len()).filter(|&i| active[i] && !fixed[i] && colours[i] as usize == colour).collect();
            let x: &[DVec3] = positions;
            let moves: Vec<DVec3> = nodes.par_iter().map(|&i| visit(x, i)).collect();
            for (&i, p) in nodes.iter().zip(moves) {
                moved = moved.max((p - positions[i]).length());
                moved_node[i] = p != positions[i];
                positions[i] = p;
            }
            report.visits += nodes.len();
        }
        report.sweeps += 1;
        // Measure again the elements around the nodes that moved.
        let mut touched: Vec<u32> =
            (0..positions.len()).filter(|&i| moved_node[i]).flat_map(|i| incidence.around(i).iter().map(|&(e, _)| e)).collect();
        touched.sort_unstable();
        touched.dedup();
        for (&e, m) in touched.iter().zip(measure(positions, &touched)) {
            q[e as usize] = m;
        }
        // A tangle that has not shrunk in STALL sweeps is left to the caller (a smaller cube).
        let now = turned(&q);
        since_fewer = if now < fewest { 0 } else { since_fewer + 1 };
        fewest = fewest.min(now);
        if moved == 0.0 || since_fewer >= STALL {
            break;
        }
    }
    report.turned_after = turned(&q);
    report
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∂η/∂E by central differences.
    fn numeric_gradient(e: DMat3, w_inv: DMat3, delta: f64) -> DMat3 {
        let mut g = DMat3::ZERO;
        let step = 1e-6;
        for col in 0..3 {
            for row in 0..3 {
                let mut plus = e;
                let mut minus = e;
                plus.col_mut(col)[row] += step;
                minus.col_mut(col)[row] -= step;
                let d = (tet_distortion(plus, w_inv, delta).unwrap().0 - tet_distortion(minus, w_inv, delta).unwrap().0)
                    / (2.0 * step);
                g.col_mut(col)[row] = d;
            }
        }
        g
    }

    #[test]
    fn the_tet_distortion_is_one_at_the_target_and_its_gradient_matches_differences() {
        let targets = kuhn_targets(0.5);
        // The target itself, rotated: η = 1, gradient 0; scaled by 3: the shape's η = 1 and
        // the size term ½(27 + 1/27) − 1.
        let w = targets[3].inverse();
        let r = DMat3::from_rotation_y(0.7);
        let (eta, grad) = tet_distortion(r * w, targets[3], 0.0).unwrap();
        assert!((eta - 1.0).abs() < 1e-12, "{eta}");
        assert!(grad.to_cols_array().iter().all(|g| g.abs() < 1e-9), "{grad:?}");
        let (eta, _) = tet_distortion(r * w * 3.0, targets[3], 0.0).unwrap();
        assert!((eta - (1.0 + 0.5 * (27.0 + 1.0 / 27.0) - 1.0)).abs() < 1e-12, "{eta}");
        // A skewed tet and a turned one (δ > 0): analytic against numeric gradients.
        let skewed = DMat3::from_cols(DVec3::new(0.6, 0.1, 0.0), DVec3::new(0.2, 0.4, -0.1), DVec3::new(0.3, 0.3, 0.45));
        let turned = DMat3::from_cols(skewed.x_axis, skewed.y_axis, -skewed.z_axis);
        for (e, delta) in [(skewed, 0.0), (skewed, 0.01), (turned, 0.05)] {
            let (eta, grad) = tet_distortion(e, targets[0], delta).unwrap();
            assert!(eta > 1.0);
            let numeric = numeric_gradient(e, targets[0], delta);
            let error = (grad - numeric).to_cols_array().iter().map(|d| d.abs()).fold(0.0, f64::max);
            assert!(error < 1e-6 * grad.to_cols_array().iter().map(|d| d.abs()).fold(0.0, f64::max), "{grad:?} vs {numeric:?}");
        }
        // δ = 0: a flat or turned tet has no finite distortion.
        assert!(tet_distortion(turned, targets[0], 0.0).is_none());
    }

    #[test]
    fn the_corner_distortion_is_one_for_a_square_corner_and_its_gradient_matches_differences() {
        let (eta, g) = corner_distortion(DVec2::new(0.0, 2.0), DVec2::new(-2.0, 0.0), 2.0, 0.0).unwrap();
        assert!((eta - 1.0).abs() < 1e-12 && g.iter().all(|g| g.length() < 1e-12), "{eta} {g:?}");
        for (e0, e1, delta) in
            [(DVec2::new(1.0, 0.2), DVec2::new(0.3, 0.8), 0.0), (DVec2::new(1.0, 0.2), DVec2::new(0.3, -0.8), 0.02)]
        {
            let (_, g) = corner_distortion(e0, e1, 0.7, delta).unwrap();
            let f = |a: DVec2, b: DVec2| corner_distortion(a, b, 0.7, delta).unwrap().0;
            let h = 1e-6;
            let numeric = [
                DVec2::new(
                    f(e0 + DVec2::X * h, e1) - f(e0 - DVec2::X * h, e1),
                    f(e0 + DVec2::Y * h, e1) - f(e0 - DVec2::Y * h, e1),
                ) / (2.0 * h),
                DVec2::new(
                    f(e0, e1 + DVec2::X * h) - f(e0, e1 - DVec2::X * h),
                    f(e0, e1 + DVec2::Y * h) - f(e0, e1 - DVec2::Y * h),
                ) / (2.0 * h),
            ];
            for k in 0..2 {
                assert!((g[k] - numeric[k]).length() < 1e-6 * g[k].length().max(1.0), "{g:?} vs {numeric:?}");
            }
        }
    }

    #[test]
    fn the_modified_determinant_is_the_determinant_for_valid_elements_and_positive_for_turned_ones() {
        assert_eq!(modified_determinant(0.3, 0.0).0, 0.3);
        let (h, dh) = modified_determinant(-0.5, 0.01);
        // h ≈ δ²/|σ| for σ ≪ −δ, and dh/dσ ≈ δ²/σ².
        assert!(h > 0.0 && (h / (1e-4 / 0.5) - 1.0).abs() < 1e-3, "{h}");
        assert!((dh / (1e-4 / 0.25) - 1.0).abs() < 1e-2, "{dh}");
    }
}
