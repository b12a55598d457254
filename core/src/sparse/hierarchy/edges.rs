//! The retained vertex set and the edge set of the next coarser graph (TransCut §4.1.2–4.1.3).
//!
//! * **Independent set**: [`independent_set`] over all vertices of `G^l`.
//! * **Enhancement** (§4.1.3): an edge `(i, j)` of `G^l` whose ends are both dropped and share
//!   no retained neighbour (`N(i) ∩ N(j) ∩ P^{l+1} = ∅`) would lose its connection at level
//!   `l + 1`; both ends are marked, the independent-set procedure picks vertices among the marked
//!   ones and they join `P^{l+1}`; repeated until nothing is marked.
//! * **Edges** (§4.1.2): for every dropped vertex, an edge between every two of its retained
//!   one-ring neighbours (they are two-ring neighbours of each other), plus every edge of `G^l`
//!   between two retained vertices. The pattern constructor sorts and removes duplicates.

use rayon::prelude::*;

use super::codes::independent_set;
use crate::sparse::{CsrPattern, SparseError};

/// The outcome of one coarsening step.
pub(crate) struct Coarsening {
    /// Retained fine vertices, increasing; coarse vertex `c` is fine vertex `retained[c]`.
    pub retained: Vec<u32>,
    /// Size of the independent set before enhancement.
    pub independent: usize,
    /// Enhancement rounds that added vertices.
    pub enhancement_rounds: usize,
    /// The coarse graph (with its diagonal), in coarse indices.
    pub graph: CsrPattern,
}

/// Whether sorted `a` and sorted `b` share an element `k` with `keep[k]`.
fn share_retained(a: &[u32], b: &[u32], keep: &[bool]) -> bool {
    let (mut x, mut y) = (0, 0);
    while x < a.len() && y < b.len() {
        match a[x].cmp(&b[y]) {
            std::cmp::Ordering::Less => x += 1,
            std::cmp::Ordering::Greater => y += 1,
            std::cmp::Ordering::Equal => {
                if keep[a[x] as usize] {
                    return true;
                }
                x += 1;
                y += 1;
            }
        }
    }
    false
}

/// The dropped vertices (`keep[i] == false`) with an edge to another dropped vertex sharing no
/// retained neighbour (§4.1.3): empty once enhancement is complete.
pub fn lost_connections(graph: &CsrPattern, keep: &[bool]) -> Vec<u32> {
    (0..graph.n() as u32)
        .into_par_iter()
        .filter(|&i| {
            !keep[i as usize]
                && graph
                    .row(i as usize)
                    .iter()
                    .any(|&j| j != i && !keep[j as usize] && !share_retained(graph.row(i as usize), graph.row(j as usize), keep))
        })
        .collect()
}

/// One coarsening step of `graph` with the vertex codes `codes`.
pub(crate) fn coarsen(graph: &CsrPattern, codes: &[u32]) -> Result<Coarsening, SparseError> {
    let n = graph.n();
    let first = independent_set(graph, codes, (0..n as u32).collect());
    let independent = first.len();
    let mut keep = vec![false; n];
    for &i in &first {
        keep[i as usize] = true;
    }
    let mut enhancement_rounds = 0;
    loop {
        let marked = lost_connections(graph, &keep);
        if marked.is_empty() {
            break;
        }
        enhancement_rounds += 1;
        for i in independent_set(graph, codes, marked) {
            keep[i as usize] = true;
        }
    }
    let retained: Vec<u32> = (0..n as u32).filter(|&i| keep[i as usize]).collect();
    let mut coarse_of = vec![u32::MAX; n];
    for (c, &i) in retained.iter().enumerate() {
        coarse_of[i as usize] = c as u32;
    }
    let edges: Vec<[u32; 2]> = (0..n as u32)
        .into_par_iter()
        .flat_map_iter(|i| {
            let row = graph.row(i as usize);
            let mut out = Vec::new();
            if keep[i as usize] {
                for &j in row {
                    if j > i && keep[j as usize] {
                        out.push([coarse_of[i as usize], coarse_of[j as usize]]);
                    }
                }
            } else {
                let r: Vec<u32> = row.iter().filter(|&&j| keep[j as usize]).map(|&j| coarse_of[j as usize]).collect();
                for a in 0..r.len() {
                    for b in a + 1..r.len() {
                        out.push([r[a], r[b]]);
                    }
                }
            }
            out
        })
        .collect();
    let graph = CsrPattern::from_edges(retained.len(), &edges)?;
    Ok(Coarsening { retained, independent, enhancement_rounds, graph })
}
