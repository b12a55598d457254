//! The elements around each node of a mesh whose elements are fixed-size corner lists (tets,
//! triangles, quads, edges), in compressed rows: what node-wise smoothing, untangling and
//! snapping read to visit a node's ring.

/// For each node, the (element, corner) pairs of the elements that have it as a corner, in
/// increasing element order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Incidence {
    start: Vec<usize>,
    pairs: Vec<(u32, u8)>,
}

impl Incidence {
    /// The incidence of `elements` over `nodes` nodes (every corner must be below `nodes`).
    ///
    /// # Panics
    /// When a corner is `nodes` or more.
    #[must_use]
    pub fn new<const N: usize>(elements: &[[u32; N]], nodes: usize) -> Incidence {
        let mut start = vec![0usize; nodes + 1];
        for e in elements {
            for &v in e {
                start[v as usize + 1] += 1;
            }
        }
        for i in 0..nodes {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut pairs = vec![(0u32, 0u8); start[nodes]];
        for (k, e) in elements.iter().enumerate() {
            for (corner, &v) in e.iter().enumerate() {
                pairs[fill[v as usize]] = (k as u32, corner as u8);
                fill[v as usize] += 1;
            }
        }
        Incidence { start, pairs }
    }

    /// The (element, corner) pairs around `node`.
    #[must_use]
    pub fn around(&self, node: usize) -> &[(u32, u8)] {
        &self.pairs[self.start[node]..self.start[node + 1]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_corner_is_listed_once_under_its_node() {
        // Two triangles sharing the edge 1–2, and node 4 in no element.
        let tris = [[0u32, 1, 2], [2, 1, 3]];
        let incidence = Incidence::new(&tris, 5);
        assert_eq!(incidence.around(0), &[(0, 0)]);
        assert_eq!(incidence.around(1), &[(0, 1), (1, 1)]);
        assert_eq!(incidence.around(2), &[(0, 2), (1, 0)]);
        assert_eq!(incidence.around(3), &[(1, 2)]);
        assert!(incidence.around(4).is_empty());
    }
}
