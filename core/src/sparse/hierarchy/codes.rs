//! Random vertex codes and the parallel independent-set procedure of TransCut §4.1.1.
//!
//! Every vertex gets a 32-bit code `h_i` packing a hashed random number (high bits) and its
//! index `i` (low bits): the random part breaks patterns in the vertex numbering, the index makes
//! every code unique, so "smaller code" is a strict total order. In one round every candidate
//! whose code is smaller than the codes of all its candidate neighbours is selected, and it and
//! its candidate neighbours leave the candidate set; two selected vertices are never adjacent, so
//! the round is a pure function of the current candidate set and runs in parallel without races.
//! Rounds repeat until no candidate is left. The result depends only on the graph, the
//! candidate set and the seed: not on the number of threads.

use rayon::prelude::*;

use crate::sparse::CsrPattern;

/// The PCG-RXS-M-XS 32-bit hash ("pcg_hash") recommended for GPU random numbers by Jarzynski
/// and Olano, *Hash Functions for GPU Rendering*, JCGT 9(3), 2020: one step of the PCG LCG
/// (multiplier 747796405, increment 2891336453) followed by the RXS-M-XS output permutation.
/// A bijection on `u32`; the stand-in for the hash of TransCut's reference \[30\].
#[must_use]
pub fn pcg_hash(input: u32) -> u32 {
    let state = input.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// The number of low bits that hold the vertex index for a graph of `n` vertices (at least 1).
fn index_bits(n: usize) -> u32 {
    let max = n.saturating_sub(1) as u64;
    (64 - max.leading_zeros()).max(1)
}

/// The 32-bit codes of TransCut §4.1.1 for `n` vertices (`n ≤ 2³²`): the top `32 − k` bits are
/// the top bits of `pcg_hash(i + pcg_hash(seed))`, the low `k` bits the index `i`, `k` the bits
/// needed for `n − 1`. Unique per vertex; deterministic in `(n, seed)`.
#[must_use]
pub fn vertex_codes(n: usize, seed: u32) -> Vec<u32> {
    let k = index_bits(n);
    let salt = pcg_hash(seed);
    (0..n)
        .into_par_iter()
        .map(|i| {
            let i = i as u32;
            if k >= 32 {
                i
            } else {
                let random = pcg_hash(i.wrapping_add(salt)) >> k;
                (random << k) | i
            }
        })
        .collect()
}

/// Runs the independent-set rounds (TransCut §4.1.1) on `graph` (its off-diagonal entries are the edges) over the
/// candidates `candidates` (sorted vertex ids) and returns the selected vertices, sorted: no two
/// are adjacent, and every candidate not selected has a selected neighbour that was a candidate.
pub fn independent_set(graph: &CsrPattern, codes: &[u32], candidates: Vec<u32>) -> Vec<u32> {
    let n = graph.n();
    let mut in_q = vec![false; n];
    for &i in &candidates {
        in_q[i as usize] = true;
    }
    let mut q = candidates;
    let mut selected_all = Vec::new();
    let mut selected = vec![false; n];
    while !q.is_empty() {
        // Select every candidate whose code is below those of its candidate neighbours.
        let picked: Vec<u32> = q
            .par_iter()
            .copied()
            .filter(|&i| {
                let hi = codes[i as usize];
                graph.row(i as usize).iter().all(|&j| j == i || !in_q[j as usize] || codes[j as usize] > hi)
            })
            .collect();
        for &i in &picked {
            selected[i as usize] = true;
        }
        // Remove the picked vertices and their candidate neighbours.
        let keep: Vec<u32> = q
            .par_iter()
            .copied()
            .filter(|&i| !selected[i as usize] && !graph.row(i as usize).iter().any(|&j| selected[j as usize]))
            .collect();
        for &i in &q {
            in_q[i as usize] = false;
        }
        for &i in &keep {
            in_q[i as usize] = true;
        }
        for &i in &picked {
            selected[i as usize] = false;
        }
        selected_all.extend_from_slice(&picked);
        q = keep;
    }
    selected_all.par_sort_unstable();
    selected_all
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_are_unique_and_keep_the_index_in_the_low_bits() {
        for n in [1usize, 2, 7, 1000, 70_000] {
            let codes = vertex_codes(n, 42);
            let k = index_bits(n);
            let mask = if k >= 32 { u32::MAX } else { (1u32 << k) - 1 };
            for (i, &c) in codes.iter().enumerate() {
                assert_eq!((c & mask) as usize, i);
            }
            let mut sorted = codes.clone();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(sorted.len(), n);
        }
        // The seed changes the order; the hash is the published pcg_hash.
        assert_ne!(vertex_codes(1000, 1), vertex_codes(1000, 2));
        assert_eq!(pcg_hash(0), 129_708_002);
    }

    #[test]
    fn independent_set_on_a_path_is_maximal_and_independent() {
        let n = 200;
        let edges: Vec<[u32; 2]> = (0..n as u32 - 1).map(|i| [i, i + 1]).collect();
        let g = CsrPattern::from_edges(n, &edges).unwrap();
        let codes = vertex_codes(n, 7);
        let set = independent_set(&g, &codes, (0..n as u32).collect());
        let mut sel = vec![false; n];
        for &i in &set {
            sel[i as usize] = true;
        }
        for i in 0..n - 1 {
            assert!(!(sel[i] && sel[i + 1]), "adjacent {i}");
        }
        for i in 0..n {
            assert!(sel[i] || g.row(i).iter().any(|&j| sel[j as usize]), "{i} has no selected neighbour");
        }
    }
}
