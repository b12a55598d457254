//! Items filed under a vertex by a counting sort, each vertex's short list then sorted on its
//! own: how the tet topology pairs up shared faces and finds unique edges in time linear in the
//! tets. One sort of all 4T faces (or 6T edges) is n log n over the whole mesh, and it was the
//! costliest step of building a mesh's topology, which the mesher's manifold repair does once
//! per round (`docs/benchmarks.md`, "Mesher").

use rayon::prelude::*;

/// Vertices per block of the parallel passes (a block's items are contiguous).
const BLOCK: usize = 4096;

/// Items grouped by the vertex they were filed under, each group sorted.
pub(crate) struct ByVertex<T> {
    /// Group `v` is `items[start[v]..start[v + 1]]`.
    start: Vec<usize>,
    items: Vec<T>,
}

impl<T: Ord + Copy + Default + Send + Sync> ByVertex<T> {
    /// Files the `(vertex, item)` pairs (every vertex below `vertex_count`) and sorts each
    /// vertex's items.
    pub(crate) fn new(vertex_count: usize, pairs: &[(u32, T)]) -> Self {
        let mut start = vec![0usize; vertex_count + 1];
        for &(v, _) in pairs {
            start[v as usize + 1] += 1;
        }
        for v in 0..vertex_count {
            start[v + 1] += start[v];
        }
        let mut fill = start[..vertex_count].to_vec();
        let mut items = vec![T::default(); start[vertex_count]];
        for &(v, item) in pairs {
            items[fill[v as usize]] = item;
            fill[v as usize] += 1;
        }
        let mut filed = Self { start, items };
        filed.blocks_mut().into_par_iter().for_each(|(vertices, block)| {
            let mut offset = 0;
            for count in vertices {
                block[offset..offset + count].sort_unstable();
                offset += count;
            }
        });
        filed
    }

    /// The blocks of [`BLOCK`] vertices: each one's group sizes and its items.
    fn blocks_mut(&mut self) -> Vec<(Vec<usize>, &mut [T])> {
        let vertex_count = self.start.len() - 1;
        let mut rest = self.items.as_mut_slice();
        (0..vertex_count)
            .step_by(BLOCK)
            .map(|v0| {
                let v1 = (v0 + BLOCK).min(vertex_count);
                let (block, tail) = std::mem::take(&mut rest).split_at_mut(self.start[v1] - self.start[v0]);
                rest = tail;
                ((v0..v1).map(|v| self.start[v + 1] - self.start[v]).collect(), block)
            })
            .collect()
    }

    /// What `visit(vertex, its sorted items, out)` pushes for every vertex, in vertex order; the
    /// first error in that order if any visit fails.
    ///
    /// # Errors
    /// The first error of `visit`.
    pub(crate) fn collect<O: Send, E: Send>(
        &self,
        visit: impl Fn(u32, &[T], &mut Vec<O>) -> Result<(), E> + Sync,
    ) -> Result<Vec<O>, E> {
        let vertex_count = self.start.len() - 1;
        let blocks: Vec<Result<Vec<O>, E>> = (0..vertex_count.div_ceil(BLOCK))
            .into_par_iter()
            .map(|b| {
                let mut out = Vec::new();
                for v in b * BLOCK..((b + 1) * BLOCK).min(vertex_count) {
                    visit(v as u32, &self.items[self.start[v]..self.start[v + 1]], &mut out)?;
                }
                Ok(out)
            })
            .collect();
        let mut all = Vec::with_capacity(blocks.iter().map(|b| b.as_ref().map_or(0, Vec::len)).sum());
        for block in blocks {
            all.extend(block?);
        }
        Ok(all)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Groups come out sorted, in vertex order, with empty vertices skipped, across several
    /// blocks; the first error in vertex order is the one returned.
    #[test]
    fn groups_are_sorted_in_vertex_order_and_the_first_error_wins() {
        let n = 3 * BLOCK + 5;
        // Vertex v gets the items (v * 7919) % 13, … for v multiple of 3, none otherwise.
        let pairs: Vec<(u32, u32)> = (0..n as u32)
            .rev()
            .filter(|v| v % 3 == 0)
            .flat_map(|v| (0..(v % 5)).map(move |k| (v, (v * 7919 + k * 31) % 13)))
            .collect();
        let filed = ByVertex::new(n, &pairs);
        let got: Vec<(u32, Vec<u32>)> = filed
            .collect(|v, items, out| -> Result<(), ()> {
                if !items.is_empty() {
                    out.push((v, items.to_vec()));
                }
                Ok(())
            })
            .unwrap();
        let mut want: Vec<(u32, Vec<u32>)> = Vec::new();
        for v in (0..n as u32).filter(|v| v % 3 == 0 && v % 5 != 0) {
            let mut items: Vec<u32> = (0..(v % 5)).map(|k| (v * 7919 + k * 31) % 13).collect();
            items.sort_unstable();
            want.push((v, items));
        }
        assert_eq!(got, want);
        let first_bad =
            filed.collect(|v, items, _: &mut Vec<()>| if v > BLOCK as u32 && !items.is_empty() { Err(v) } else { Ok(()) });
        assert_eq!(first_bad, Err((BLOCK as u32 + 1..).find(|v| v % 3 == 0 && v % 5 != 0).unwrap()));
    }
}
