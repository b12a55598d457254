//! The paper's stencil ([`PolygridSystem::paper_lsq`]): Wang et al. 2008 eq. 9 with App. B's
//! least-squares weights ([`super::lsq`]), for reproduction and comparison. It is not the
//! default: Stam's ψ = κφ form is not conservative at κ interfaces (design note P3: a two-layer
//! slab's transmission −51%), the weights are consistent only where the links follow the grid's
//! axes (P4), and the matrix is not symmetric (P5), so it is solved by BiCGSTAB.
//!
//! Rows (media on the nodes, the volume-weighted means of σa and σ′s of their cells, κ from
//! them):
//!
//! - a node off the boundary (eq. 9, scaled by its dual volume V_i):
//!   V_i [(Σ_j w_j κ_i + σa_i) φ_i − Σ_j w_j κ_j φ_j] = 0, j over its links: the six lattice
//!   neighbours, the pillow's surface node above it (with a pillow), and at a mirror face the
//!   mirror image of the opposite neighbour (a ghost, the zero-flux condition);
//! - a node under the boundary condition (the paper's boundary relation, with
//!   docs/ARCHITECTURE.md's terms instead of the paper's C = 2.1489, scaled by its dual area
//!   S_i): S_i [φ_i/(2A) + κ_i/|P| Σ_p (φ_i − φ_p)/d_p] = S_i Q_i/(2A), p over its partners,
//!   the links to nodes off the boundary (one for a face node; a pillow's surface node has
//!   exactly one), d_p = |x_i − x_p|. A node on a polycube's convex edge or corner without a
//!   pillow has no such link (the paper deletes it, §5.1); it takes the nodes off the
//!   boundary among its cells' corners instead, so that it still has a radiance.
//!
//! Where App. B's weights make no Laplacian (fewer than six links that do not determine it, as
//! at a pillowed polycube's convex edges and corners; weights summing to ≤ 0 on skewed links; a
//! fit conditioned over [`super::lsq::MAX_CONDITION`]; folded links), the node takes the P1
//! Laplacian's weights on its Kuhn tets instead ([`p1_weights`]): the paper leaves such nodes
//! unspecified (design note P6), and this keeps every row of a fold-free grid solvable.
//!
//! The source, the query and the energy balance are the finite-volume system's, so the two
//! compare one to one; the energy balance is not exact here, and its defect is the measure of
//! P3.

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use super::error::PolygridError;
use super::grid::{Polygrid, NONE};
use super::lsq::{grid_frame, laplacian_weights, CONSISTENT, MAX_CONDITION};
use super::system::{check_inputs, robin_boundary, trilinear, BoundaryNodes, PolygridSystem};
use crate::optics::Medium;
use crate::sparse::{CsrMatrix3, CsrPattern, Triplet};

/// What the paper stencil's weights looked like over a grid (design note P4).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct LsqDiagnostics {
    /// Nodes with an App. B stencil (those off the boundary).
    pub stencil_nodes: usize,
    /// Of them, those with a negative weight: the matrix is then not an M-matrix, and
    /// relaxation may diverge.
    pub negative_weight_nodes: usize,
    /// The most negative weight relative to its node's largest (0 when none is negative).
    pub most_negative_ratio: f64,
    /// The scaled fit's condition number (about 3 on a regular grid) over the nodes that keep
    /// the paper's weights: the median and the largest.
    pub median_condition: f64,
    pub max_condition: f64,
    /// Nodes whose links leave the Laplacian of the six monomials undetermined (fewer than six
    /// links, not symmetric: a pillow's convex edges and corners), and the largest defect
    /// ‖Wᵀw − e‖/‖e‖ there.
    pub inconsistent_nodes: usize,
    pub max_defect: f64,
    /// Nodes whose paper weights make no Laplacian (fewer than six links not determining it,
    /// weights summing to ≤ 0 on skewed links, a fit over [`super::lsq::MAX_CONDITION`], or
    /// folded links), which take the P1 Laplacian's weights on their Kuhn tets instead.
    pub p1_nodes: usize,
    /// Mirror images used at zero-flux faces.
    pub mirror_links: usize,
    /// Boundary nodes without a link off the boundary, tied to their cells' inner corners.
    pub cell_linked_boundary_nodes: usize,
}

impl PolygridSystem {
    /// The paper's stencil on `grid` (see the module documentation), inputs as
    /// [`PolygridSystem::finite_volume`]. The matrix is not symmetric: solve it by
    /// [`crate::sparse::bicgstab`]; [`PolygridSystem::lsq_diagnostics`] reports its weights.
    ///
    /// # Errors
    /// As [`PolygridSystem::finite_volume`]; [`PolygridError::Stencil`] naming the first node
    /// that has no link to carry its row (a pillow surface node off the boundary condition, a
    /// boundary node with no node off the boundary among its cells).
    pub fn paper_lsq(
        grid: &Polygrid,
        cell_media: &[Medium],
        mm_per_unit: f64,
        robin: Option<&[bool]>,
    ) -> Result<Self, PolygridError> {
        let terms = check_inputs(grid, cell_media, mm_per_unit, robin)?;
        let x: Vec<DVec3> = grid.positions().iter().map(|&p| p * mm_per_unit).collect();
        let n = grid.node_count();
        let (ids, area, normal) = robin_boundary(grid, &x, robin);
        let mut on_robin = vec![false; n];
        for &i in &ids {
            on_robin[i as usize] = true;
        }
        let tets = grid.kuhn_tets();
        let media = NodeMedia::new(grid, &tets, &x, cell_media);
        let frames = lattice_frames(grid, &x);

        // Rows off the boundary: App. B's weights, or P1's where they are no Laplacian.
        let mut rows: Vec<Option<InteriorRow>> = (0..n as u32)
            .into_par_iter()
            .map(|i| if on_robin[i as usize] { Ok(None) } else { interior_row(i, grid, &x, frames[i as usize]).map(Some) })
            .collect::<Result<_, _>>()?;
        let replaced: Vec<u32> = (0..n as u32).filter(|&i| rows[i as usize].as_ref().is_some_and(|r| r.replaced_by_p1)).collect();
        for (i, (columns, weights)) in replaced.iter().zip(p1_weights(grid.node_count(), &tets, &x, &replaced)) {
            let row = rows[*i as usize].as_mut().expect("a row off the boundary");
            row.columns = columns;
            row.weights = weights;
        }
        let mut triplets = Vec::with_capacity(8 * n);
        let mut entries = Vec::with_capacity(7 * n);
        let mut diagnostics = LsqDiagnostics { p1_nodes: replaced.len(), ..LsqDiagnostics::default() };
        let mut conditions = Vec::new();
        for (i, row) in rows.into_iter().enumerate() {
            let Some(row) = row else { continue };
            let v = media.volume[i];
            let (kappa, sa) = (media.kappa[i], media.sigma_a[i]);
            let sum: f64 = row.weights.iter().sum();
            triplets.push(Triplet::new(i as u32, i as u32, std::array::from_fn(|c| v * (sum * kappa[c] + sa[c]))));
            for (&j, &w) in row.columns.iter().zip(&row.weights) {
                let kj = media.kappa[j as usize];
                triplets.push(Triplet::new(i as u32, j, kj.map(|k| -v * w * k)));
                entries.push([i as u32, j]);
            }
            diagnostics.stencil_nodes += 1;
            if row.paper_smallest < 0.0 {
                diagnostics.negative_weight_nodes += 1;
                diagnostics.most_negative_ratio = diagnostics.most_negative_ratio.min(row.paper_smallest / row.paper_largest);
            }
            if row.defect > CONSISTENT {
                diagnostics.inconsistent_nodes += 1;
                diagnostics.max_defect = diagnostics.max_defect.max(row.defect);
            }
            diagnostics.mirror_links += row.mirrors;
            if !row.replaced_by_p1 {
                conditions.push(row.condition);
            }
        }
        conditions.sort_by(f64::total_cmp);
        diagnostics.median_condition = conditions.get(conditions.len() / 2).copied().unwrap_or(0.0);
        diagnostics.max_condition = conditions.last().copied().unwrap_or(0.0);

        // Rows on the boundary: the boundary relation with the partners off it.
        let mut partners: Vec<Vec<u32>> =
            ids.iter().map(|&i| grid.links(i).filter(|&j| !on_robin[j as usize]).collect()).collect();
        let lonely: Vec<usize> = (0..ids.len()).filter(|&k| partners[k].is_empty()).collect();
        if !lonely.is_empty() {
            let mut cells_of: Vec<Vec<u32>> = vec![Vec::new(); n];
            for (c, cell) in grid.cells().iter().enumerate() {
                for &v in cell {
                    cells_of[v as usize].push(c as u32);
                }
            }
            for &k in &lonely {
                let mut inner: Vec<u32> = cells_of[ids[k] as usize]
                    .iter()
                    .flat_map(|&c| grid.cells()[c as usize])
                    .filter(|&j| !on_robin[j as usize])
                    .collect();
                inner.sort_unstable();
                inner.dedup();
                if inner.is_empty() {
                    return Err(PolygridError::Stencil {
                        node: ids[k],
                        reason: "no node of its cells lies off the boundary (a cube of one cell without a pillow): \
                                 raise the resolution"
                            .into(),
                    });
                }
                partners[k] = inner;
            }
            diagnostics.cell_linked_boundary_nodes = lonely.len();
        }
        for (&i, p) in ids.iter().zip(&partners) {
            let (s, kappa) = (area[i as usize], media.kappa[i as usize]);
            let inverse_d: Vec<f64> = p.iter().map(|&j| 1.0 / (x[i as usize] - x[j as usize]).length()).collect();
            let share = 1.0 / p.len() as f64;
            let sum: f64 = inverse_d.iter().sum::<f64>() * share;
            triplets.push(Triplet::new(i, i, kappa.map(|k| s / (2.0 * terms.a) + s * k * sum)));
            for (&j, &inv) in p.iter().zip(&inverse_d) {
                triplets.push(Triplet::new(i, j, kappa.map(|k| -s * k * share * inv)));
                entries.push([i, j]);
            }
        }
        let pattern = std::sync::Arc::new(CsrPattern::from_entries(n, &entries)?);
        let matrix = CsrMatrix3::from_triplets_with_pattern(pattern, &triplets)?;
        let absorption = (0..n).map(|i| media.sigma_a[i].map(|s| s * media.volume[i])).collect();
        let boundary = BoundaryNodes {
            area_mm2: ids.iter().map(|&i| area[i as usize]).collect(),
            normal: ids.iter().map(|&i| normal[i as usize]).collect(),
            ids,
        };
        let nb = boundary.ids.len();
        Ok(Self {
            matrix,
            boundary,
            terms,
            absorption,
            source: vec![[0.0; 3]; nb],
            rhs: vec![[0.0; 3]; n],
            lsq: Some(diagnostics),
        })
    }

    /// The paper stencil's diagnostics; `None` for the finite-volume system.
    #[must_use]
    pub fn lsq_diagnostics(&self) -> Option<&LsqDiagnostics> {
        self.lsq.as_ref()
    }

    /// Whether the matrix is symmetric (positive definite): the finite-volume one, solved by
    /// CG; the paper stencil's is not.
    #[must_use]
    pub fn is_symmetric(&self) -> bool {
        self.lsq.is_none()
    }
}

/// The media on the nodes: σa and σ′s averaged over the node's share of its cells (never κ),
/// κ = 1/(3σ′t) from them, and the dual volume V_i: an eighth of each of its cells (each
/// cell's volume that of its Kuhn tets, positive on every grid the fold check passes; a
/// cell's corner octants can turn negative at a polycube's convex corners).
struct NodeMedia {
    volume: Vec<f64>,
    sigma_a: Vec<[f64; 3]>,
    kappa: Vec<[f64; 3]>,
}

impl NodeMedia {
    fn new(grid: &Polygrid, tets: &[[u32; 4]], x: &[DVec3], cell_media: &[Medium]) -> Self {
        let n = grid.node_count();
        let eighths: Vec<f64> = tets
            .par_chunks(6)
            .map(|cell| {
                let volume: f64 = cell
                    .iter()
                    .map(|t| {
                        let [a, b, c, d] = t.map(|i| x[i as usize]);
                        (b - a).dot((c - a).cross(d - a)).abs() / 6.0
                    })
                    .sum();
                volume / 8.0
            })
            .collect();
        let (mut volume, mut sa, mut ss) = (vec![0.0; n], vec![[0.0; 3]; n], vec![[0.0; 3]; n]);
        for ((c, &v), m) in grid.cells().iter().zip(&eighths).zip(cell_media) {
            for &i in c {
                let i = i as usize;
                volume[i] += v;
                for ch in 0..3 {
                    sa[i][ch] += v * m.sigma_a[ch];
                    ss[i][ch] += v * m.sigma_s_prime[ch];
                }
            }
        }
        let sigma_a: Vec<[f64; 3]> = sa.iter().zip(&volume).map(|(s, v)| s.map(|s| s / v)).collect();
        let kappa = ss
            .iter()
            .zip(&volume)
            .zip(&sigma_a)
            .map(|((s, v), a)| std::array::from_fn(|c| 1.0 / (3.0 * (s[c] / v + a[c]))))
            .collect();
        Self { volume, sigma_a, kappa }
    }
}

/// Per node the lattice axes of its lattice cells, summed: each cell's trilinear Jacobian at
/// its centre (the mean of its edges along each axis), so a node's frame
/// ([`grid_frame`]) follows the grid as its cells do, also where its own links are one-sided
/// and bent (a pillowed polycube's convex edges, rounded inwards by the map).
fn lattice_frames(grid: &Polygrid, x: &[DVec3]) -> Vec<DMat3> {
    let cells = &grid.cells()[..grid.lattice_cell_count()];
    let jacobians: Vec<DMat3> = cells
        .par_iter()
        .map(|c| {
            let [u, v, w] = trilinear(&c.map(|i| x[i as usize]), 0.5, 0.5, 0.5);
            DMat3::from_cols(u, v, w)
        })
        .collect();
    let mut frames = vec![DMat3::ZERO; grid.node_count()];
    for (c, j) in cells.iter().zip(&jacobians) {
        for &v in c {
            frames[v as usize] += *j;
        }
    }
    frames
}

/// One node's App. B row: its columns (links; a mirror image counts for the node it mirrors)
/// and weights.
struct InteriorRow {
    columns: Vec<u32>,
    weights: Vec<f64>,
    /// The paper fit's condition number and defect ([`super::lsq::NodeWeights`]).
    condition: f64,
    defect: f64,
    /// The paper weights' extremes (for the diagnostics; 0 when replaced).
    paper_smallest: f64,
    paper_largest: f64,
    /// Whether the paper's weights make no Laplacian here and P1's take their place.
    replaced_by_p1: bool,
    mirrors: usize,
}

impl InteriorRow {
    /// A row whose weights [`p1_weights`] fills in.
    fn replaced(condition: f64, defect: f64) -> Self {
        Self {
            columns: Vec::new(),
            weights: Vec::new(),
            condition,
            defect,
            paper_smallest: 0.0,
            paper_largest: 0.0,
            replaced_by_p1: true,
            mirrors: 0,
        }
    }
}

fn interior_row(i: u32, grid: &Polygrid, x: &[DVec3], axes: DMat3) -> Result<InteriorRow, PolygridError> {
    let stencil_error = |reason: String| PolygridError::Stencil { node: i, reason };
    let here = x[i as usize];
    let nb = grid.neighbours()[i as usize];
    let copy = grid.pillow_partner(i);
    if i as usize >= grid.lattice_node_count() {
        return Err(stencil_error(
            "a pillow surface node off the boundary condition has one link: the paper stencil needs the whole pillow \
             surface under it (no mirror quads with a pillow)"
                .into(),
        ));
    }
    // The frame: per axis x₊ − x₋ over the node's links, the pillow's surface node standing in
    // for a missing side (one-sided at a mirror face: its image is the reflection); where that
    // is turned or flat (a pillowed convex edge), its cells' axes.
    let mut own = [DVec3::ZERO; 3];
    for (k, axis) in own.iter_mut().enumerate() {
        let side = |j: u32| {
            if j != NONE {
                Some(x[j as usize])
            } else if copy != NONE {
                Some(x[copy as usize])
            } else {
                None
            }
        };
        let (minus, plus) = (nb[2 * k], nb[2 * k + 1]);
        *axis = match (side(minus), side(plus)) {
            (Some(a), Some(b)) if minus != NONE || plus != NONE => b - a,
            (Some(a), None) => 2.0 * (here - a),
            (None, Some(b)) => 2.0 * (b - here),
            _ => return Err(stencil_error(format!("it has no lattice link along axis {k}"))),
        };
    }
    let Some(frame) = grid_frame(DMat3::from_cols(own[0], own[1], own[2])).or_else(|| grid_frame(axes)) else {
        // Folded links: P1's weights.
        return Ok(InteriorRow::replaced(f64::INFINITY, 0.0));
    };
    let to_local = frame.transpose();
    let mut columns = Vec::with_capacity(7);
    let mut deltas = Vec::with_capacity(7);
    let mut mirrors = 0;
    for (dir, &j) in nb.iter().enumerate() {
        if j != NONE {
            columns.push(j);
            deltas.push(to_local * (x[j as usize] - here));
        } else if copy == NONE {
            // A zero-flux face: the image of the opposite neighbour across the axis plane.
            let opposite = nb[dir ^ 1];
            let mut d = to_local * (x[opposite as usize] - here);
            let axis = dir / 2;
            d[axis] = -d[axis];
            columns.push(opposite);
            deltas.push(d);
            mirrors += 1;
        }
    }
    if copy != NONE {
        columns.push(copy);
        deltas.push(to_local * (x[copy as usize] - here));
    }
    let w = laplacian_weights(&deltas);
    if !(w.is_laplacian() && w.condition <= MAX_CONDITION) {
        return Ok(InteriorRow::replaced(w.condition, w.defect));
    }
    let paper_largest = w.weights.iter().copied().fold(f64::MIN, f64::max);
    let paper_smallest = w.weights.iter().copied().fold(f64::MAX, f64::min);
    Ok(InteriorRow {
        columns,
        weights: w.weights,
        condition: w.condition,
        defect: w.defect,
        paper_smallest,
        paper_largest,
        replaced_by_p1: false,
        mirrors,
    })
}

/// The P1 Laplacian's weights at each of `nodes` on the Kuhn split ([`Polygrid::kuhn_tets`]):
/// w_j = −K_ij/V_i, K the stiffness of ∇² and V_i a quarter of each tet at the node, so
/// Σ_j w_j (f_j − f_i) ≈ ∇²f(x_i) as the paper's rows say, with Σ_j w_j = K_ii/V_i > 0 on
/// every grid the fold check passes; `tets` the grid's Kuhn split of its `n` nodes. Per node its
/// columns and weights.
fn p1_weights(n: usize, tets: &[[u32; 4]], x: &[DVec3], nodes: &[u32]) -> Vec<(Vec<u32>, Vec<f64>)> {
    let mut slot = vec![u32::MAX; n];
    for (k, &i) in nodes.iter().enumerate() {
        slot[i as usize] = k as u32;
    }
    let mut stiffness: Vec<Vec<(u32, f64)>> = vec![Vec::new(); nodes.len()];
    let mut volume = vec![0.0; nodes.len()];
    for t in tets {
        if t.iter().all(|&v| slot[v as usize] == u32::MAX) {
            continue;
        }
        let p = t.map(|v| x[v as usize]);
        let m = DMat3::from_cols(p[1] - p[0], p[2] - p[0], p[3] - p[0]);
        let v = m.determinant().abs() / 6.0;
        // ∇λ_1..3 are the rows of M⁻¹, ∇λ_0 = −their sum.
        let inv = m.inverse().transpose();
        let g = [-(inv.x_axis + inv.y_axis + inv.z_axis), inv.x_axis, inv.y_axis, inv.z_axis];
        for (a, &va) in t.iter().enumerate() {
            let k = slot[va as usize];
            if k == u32::MAX {
                continue;
            }
            volume[k as usize] += v / 4.0;
            for (b, &vb) in t.iter().enumerate() {
                if a != b {
                    stiffness[k as usize].push((vb, v * g[a].dot(g[b])));
                }
            }
        }
    }
    stiffness
        .into_iter()
        .zip(volume)
        .map(|(mut row, v)| {
            row.sort_unstable_by_key(|e| e.0);
            let mut columns: Vec<u32> = Vec::new();
            let mut weights: Vec<f64> = Vec::new();
            for (j, k) in row {
                if columns.last() == Some(&j) {
                    *weights.last_mut().expect("a column") -= k / v;
                } else {
                    columns.push(j);
                    weights.push(-k / v);
                }
            }
            (columns, weights)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::polygrid::Polycube;

    #[test]
    fn p1_weights_on_a_regular_kuhn_split_are_the_seven_point_laplacian() {
        // On a Kuhn-split cube lattice the P1 stiffness of an inner node has −h on its six axis
        // links and 0 on the diagonal ones, and the lumped volume is h³: w = 1/h² on the axes.
        let h = 0.5;
        let grid = Polygrid::new(Arc::new(Polycube::block(DVec3::ZERO, 1.5, [1, 1, 1]).unwrap()), 3).unwrap();
        let centre = grid.node_at([1, 1, 1]).unwrap();
        let (columns, weights) = p1_weights(grid.node_count(), &grid.kuhn_tets(), grid.positions(), &[centre]).remove(0);
        let axes = grid.neighbours()[centre as usize];
        for (j, w) in columns.iter().zip(&weights) {
            let expected = if axes.contains(j) { 1.0 / (h * h) } else { 0.0 };
            assert!((w - expected).abs() < 1e-12, "node {j}: {w} vs {expected}");
        }
        assert!(axes.iter().all(|a| columns.contains(a)));
    }
}
