//! A row ordering for parallel Gauss–Seidel sweeps: Cuthill–McKee level sets cut into parts
//! by separator levels (used by [`super::Ssor`]).
//!
//! Breadth-first search from a pseudo-peripheral vertex (George & Liu 1979), neighbours taken
//! by increasing degree (Cuthill & McKee 1969), numbers the vertices level by level; an edge
//! joins two vertices of the same or of adjacent levels. Whole levels chosen as *separators*,
//! at least two levels apart, cut the others into *parts* that share no edge. Ordering the parts
//! first (each in search order) and the separators last gives a lower triangle in which a part's
//! rows depend only on rows of the same part, and a separator's rows on the parts and on rows
//! of the same separator: a forward sweep runs all parts in parallel, then all separators in
//! parallel (a backward sweep, the reverse), and computes exactly the sequential sweep of this
//! ordering. Graph-only (no positions), sequential, `O(nnz)`, deterministic.
//!
//! The search order also gives the sweeps their locality: a row's neighbours lie within about
//! two levels of it, where a mesher's vertex numbering scatters them across the whole matrix.

use std::ops::Range;

use super::CsrPattern;

/// The ordering: `perm[new] = old`, and the row ranges (in the new numbering) of the parts and
/// of the separators, in order; the parts cover `0..parts.last().end`, the separators the rest.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct SweepOrdering {
    pub(crate) perm: Vec<u32>,
    pub(crate) parts: Vec<Range<usize>>,
    pub(crate) separators: Vec<Range<usize>>,
}

/// Breadth-first search of the component of `start` over vertices whose `mark` differs from
/// `stamp`, marking them; neighbours are visited by increasing degree (then index). Appends the
/// visited vertices to `order` and their level (from `level0`) to `level`; returns the number of
/// levels.
fn search(
    p: &CsrPattern,
    start: usize,
    stamp: u32,
    mark: &mut [u32],
    order: &mut Vec<u32>,
    level: &mut [u32],
    level0: u32,
) -> u32 {
    let degree = |i: usize| p.row(i).len();
    let first = order.len();
    mark[start] = stamp;
    order.push(start as u32);
    level[start] = level0;
    let mut head = first;
    let mut next: Vec<u32> = Vec::new();
    while head < order.len() {
        let i = order[head] as usize;
        head += 1;
        next.clear();
        next.extend(p.row(i).iter().copied().filter(|&j| mark[j as usize] != stamp));
        next.sort_unstable_by_key(|&j| (degree(j as usize), j));
        for &j in &next {
            mark[j as usize] = stamp;
            level[j as usize] = level[i] + 1;
            order.push(j);
        }
    }
    level[*order.last().expect("start was pushed") as usize] - level0 + 1
}

/// The sweep ordering of the symmetric pattern `p`, cut into at most `max_parts` parts of
/// about equal size (fewer when the graph has too few levels).
pub(crate) fn sweep_ordering(p: &CsrPattern, max_parts: usize) -> SweepOrdering {
    let n = p.n();
    let mut mark = vec![0u32; n];
    let mut level = vec![0u32; n];
    let mut order: Vec<u32> = Vec::with_capacity(n);
    let mut scratch: Vec<u32> = Vec::new();
    let mut levels = 0u32;
    let mut stamp = 0u32;
    for v in 0..n {
        if mark[v] != 0 {
            continue;
        }
        // Pseudo-peripheral start: the lowest-degree vertex of the last level of a search from
        // the component's first vertex; the second search from it gives the ordering.
        stamp += 1;
        scratch.clear();
        search(p, v, stamp, &mut mark, &mut scratch, &mut level, 0);
        let deepest = scratch.iter().map(|&i| level[i as usize]).max().unwrap_or(0);
        let start = scratch
            .iter()
            .copied()
            .filter(|&i| level[i as usize] == deepest)
            .min_by_key(|&i| (p.row(i as usize).len(), i))
            .expect("the component has a vertex") as usize;
        stamp += 1;
        levels += search(p, start, stamp, &mut mark, &mut order, &mut level, levels);
    }
    let nl = levels as usize;
    let mut count = vec![0usize; nl];
    for &l in &level {
        count[l as usize] += 1;
    }
    // Separator levels: where the vertices before a level first reach k/parts of the total,
    // two levels apart at least, never the first or the last level (so no part is empty).
    let mut is_separator = vec![false; nl];
    let parts = max_parts.max(1);
    let (mut before, mut next, mut last) = (0usize, 1usize, None::<usize>);
    for l in 0..nl {
        if next < parts && l >= 1 && l + 1 < nl && last.is_none_or(|s| l >= s + 2) && before * parts >= next * n {
            is_separator[l] = true;
            last = Some(l);
            next += 1;
        }
        before += count[l];
    }
    let in_separator = |i: u32| is_separator[level[i as usize] as usize];
    let mut perm: Vec<u32> = order.iter().copied().filter(|&i| !in_separator(i)).collect();
    let n_parts_rows = perm.len();
    perm.extend(order.iter().copied().filter(|&i| in_separator(i)));
    // Ranges: consecutive runs of non-separator levels (parts) and separator levels.
    let mut part_ranges = Vec::new();
    let mut sep_ranges = Vec::new();
    let (mut pos_part, mut pos_sep) = (0usize, n_parts_rows);
    let mut run = 0usize;
    for l in 0..nl {
        if is_separator[l] {
            if run > 0 {
                part_ranges.push(pos_part..pos_part + run);
                pos_part += run;
                run = 0;
            }
            sep_ranges.push(pos_sep..pos_sep + count[l]);
            pos_sep += count[l];
        } else {
            run += count[l];
        }
    }
    if run > 0 || part_ranges.is_empty() {
        part_ranges.push(pos_part..pos_part + run);
    }
    SweepOrdering { perm, parts: part_ranges, separators: sep_ranges }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sparse::fixtures::Grid;

    /// The vertex graph of an `nx × ny` grid (4-neighbour), plus `extra` isolated vertices.
    fn grid(nx: usize, ny: usize, extra: usize) -> CsrPattern {
        let g = Grid::new(nx, ny, 1);
        CsrPattern::from_edges(g.n() + extra, &g.edges(false)).unwrap()
    }

    /// The dependency structure the parallel sweeps rely on.
    fn check(p: &CsrPattern, o: &SweepOrdering) {
        let n = p.n();
        let mut seen = vec![false; n];
        for &i in &o.perm {
            assert!(!std::mem::replace(&mut seen[i as usize], true), "perm repeats {i}");
        }
        assert!(seen.iter().all(|&s| s));
        let mut inv = vec![0usize; n];
        for (k, &i) in o.perm.iter().enumerate() {
            inv[i as usize] = k;
        }
        let split = o.parts.last().unwrap().end;
        assert_eq!(o.parts[0].start, 0);
        assert_eq!(o.separators.last().map_or(n, |r| r.end), n);
        let which = |k: usize| -> (bool, usize) {
            match o.parts.iter().position(|r| r.contains(&k)) {
                Some(q) => (false, q),
                None => (true, o.separators.iter().position(|r| r.contains(&k)).unwrap()),
            }
        };
        for i in 0..n {
            let (si, qi) = which(inv[i]);
            for &j in p.row(i) {
                let (sj, qj) = which(inv[j as usize]);
                match (si, sj) {
                    // Parts never touch each other, separators never each other.
                    (false, false) | (true, true) => assert_eq!(qi, qj, "rows {i}, {j}"),
                    _ => {}
                }
            }
        }
        assert!(o.parts.iter().all(|r| r.end <= split));
    }

    #[test]
    fn parts_and_separators_decouple() {
        let p = grid(40, 25, 3);
        for parts in [1, 2, 4, 8] {
            let o = sweep_ordering(&p, parts);
            check(&p, &o);
            // The grid's 64 levels are cut into the requested parts (isolated vertices add
            // their own single-level components at the end).
            assert_eq!(o.separators.len(), parts - 1, "{parts} parts");
            let sizes: Vec<usize> = o.parts.iter().map(|r| r.len()).collect();
            let (lo, hi) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
            assert!(*hi <= 2 * lo + 80, "unbalanced parts {sizes:?}");
        }
    }

    #[test]
    fn small_and_disconnected_graphs() {
        // Too few levels for separators: one part.
        let p = grid(2, 1, 0);
        let o = sweep_ordering(&p, 8);
        check(&p, &o);
        assert_eq!((o.parts.len(), o.separators.len()), (1, 0));
        // Only isolated vertices.
        let p = CsrPattern::from_edges(5, &[]).unwrap();
        let o = sweep_ordering(&p, 4);
        check(&p, &o);
        // Two components.
        let mut e = vec![];
        for i in 0..30u32 {
            e.push([i, i + 1]);
            e.push([40 + i, 41 + i]);
        }
        let p = CsrPattern::from_edges(80, &e).unwrap();
        let o = sweep_ordering(&p, 4);
        check(&p, &o);
    }
}
