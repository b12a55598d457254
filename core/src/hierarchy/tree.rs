//! The cluster trees of the hierarchical dipole (Mertens et al. 2003 §5.1): a binary tree over
//! the emitting triangles and one over the receiving points, each node a cluster with its
//! area, centroid, normal and bounding radius.
//!
//! Built top-down by median splits of the items' centres along the longest axis of their
//! bounds, one item per leaf, nodes depth-first (a node's left child right after it, a
//! subtree a contiguous range). When the surface deforms the tree is refitted bottom-up in
//! O(n) with its topology kept (design/hierarchical-dipole.md §1.5), and every node whose
//! data changed is stamped with the refit's frame, so that links between unchanged clusters
//! can be kept.

use glam::DVec3;

/// What a leaf is made of: its centre, weight (area for a triangle, 1 for a point), normal
/// (unit, or zero) and bounding radius about the centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClusterItem {
    pub centre: DVec3,
    pub weight: f64,
    pub normal: DVec3,
    pub radius: f64,
}

impl ClusterItem {
    /// The item of triangle `corners`: its centroid, area, unit normal and the distance from
    /// its centroid to its farthest corner.
    #[must_use]
    pub fn triangle(corners: [DVec3; 3]) -> Self {
        let centre = (corners[0] + corners[1] + corners[2]) / 3.0;
        let cross = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
        let radius = corners.iter().map(|c| c.distance(centre)).fold(0.0, f64::max);
        Self { centre, weight: 0.5 * cross.length(), normal: cross.normalize_or_zero(), radius }
    }

    /// A receiving point with unit (or zero) normal `normal`.
    #[must_use]
    pub fn point(centre: DVec3, normal: DVec3) -> Self {
        Self { centre, weight: 1.0, normal, radius: 0.0 }
    }
}

/// One cluster.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClusterNode {
    /// The weighted mean of its items' centres (for triangles: the area centroid).
    pub centre: DVec3,
    /// The sum of its items' weights (for triangles: the area, mm²).
    pub weight: f64,
    /// The weighted sum of its items' unit normals, normalised (zero when they cancel).
    pub normal: DVec3,
    /// A radius about `centre` that bounds every item.
    pub radius: f64,
    /// Inner node: the right child (the left is the next node); leaf: the item.
    pub right_or_item: u32,
    /// Whether the node is a leaf.
    pub leaf: bool,
}

impl ClusterNode {
    /// The children of an inner node `index`.
    #[must_use]
    pub fn children(&self, index: u32) -> Option<[u32; 2]> {
        (!self.leaf).then_some([index + 1, self.right_or_item])
    }
}

/// A cluster tree over a fixed set of items (module documentation).
#[derive(Debug, Clone)]
pub struct ClusterTree {
    nodes: Vec<ClusterNode>,
    /// Per node, the end of its subtree's range (exclusive).
    ends: Vec<u32>,
    /// Per node, the last frame its data changed at ([`ClusterTree::refit`]).
    changed_at: Vec<u64>,
    /// Per item, its leaf.
    leaf_of: Vec<u32>,
}

impl ClusterTree {
    /// The tree over `items` (at least one).
    ///
    /// # Panics
    /// When `items` is empty or holds more than `u32::MAX / 2` items.
    #[must_use]
    pub fn build(items: &[ClusterItem]) -> Self {
        assert!(!items.is_empty() && items.len() < (u32::MAX / 2) as usize, "a cluster tree needs 1..2³¹ items");
        let mut order: Vec<u32> = (0..items.len() as u32).collect();
        let mut tree = Self {
            nodes: Vec::with_capacity(2 * items.len() - 1),
            ends: Vec::with_capacity(2 * items.len() - 1),
            changed_at: Vec::new(),
            leaf_of: vec![0; items.len()],
        };
        tree.split(items, &mut order);
        tree.changed_at = vec![0; tree.nodes.len()];
        tree.refit(items, 0);
        tree
    }

    /// Appends the subtree over `order` (depth-first), its data filled in by `refit`.
    fn split(&mut self, items: &[ClusterItem], order: &mut [u32]) {
        let index = self.nodes.len();
        let blank =
            ClusterNode { centre: DVec3::ZERO, weight: 0.0, normal: DVec3::ZERO, radius: 0.0, right_or_item: 0, leaf: true };
        self.nodes.push(blank);
        self.ends.push(0);
        if let [item] = order {
            self.nodes[index].right_or_item = *item;
            self.leaf_of[*item as usize] = index as u32;
        } else {
            let (lo, hi) = order.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &i| {
                let c = items[i as usize].centre;
                (lo.min(c), hi.max(c))
            });
            let extent = hi - lo;
            let axis = if extent.x >= extent.y && extent.x >= extent.z {
                0
            } else if extent.y >= extent.z {
                1
            } else {
                2
            };
            let half = order.len() / 2;
            // Ties broken by the other coordinates (then the index), so the tree depends on
            // where the items are and not on the order they come in: a mesh with its vertices
            // renumbered gets the same tree, and the same radiance.
            let key = |i: u32| {
                let c = items[i as usize].centre;
                [c[axis], c[(axis + 1) % 3], c[(axis + 2) % 3]]
            };
            order.select_nth_unstable_by(half, |&a, &b| {
                let (ka, kb) = (key(a), key(b));
                ka[0].total_cmp(&kb[0]).then(ka[1].total_cmp(&kb[1])).then(ka[2].total_cmp(&kb[2])).then(a.cmp(&b))
            });
            let (left, right) = order.split_at_mut(half);
            self.split(items, left);
            self.nodes[index].leaf = false;
            self.nodes[index].right_or_item = self.nodes.len() as u32;
            self.split(items, right);
        }
        self.ends[index] = self.nodes.len() as u32;
    }

    /// Recomputes every node from `items` (the items the tree was built over, moved) bottom-up,
    /// keeping the topology, and stamps the nodes whose data changed with `frame`. Returns how
    /// many changed.
    ///
    /// # Panics
    /// When `items` has another length than the tree was built with.
    pub fn refit(&mut self, items: &[ClusterItem], frame: u64) -> usize {
        assert_eq!(items.len(), self.leaf_of.len(), "refit with the items the tree was built over");
        let mut changed = 0;
        for index in (0..self.nodes.len()).rev() {
            let old = self.nodes[index];
            let mut node = old;
            if node.leaf {
                let item = items[node.right_or_item as usize];
                node.centre = item.centre;
                node.weight = item.weight;
                node.normal = item.normal;
                node.radius = item.radius;
            } else {
                let (a, b) = (self.nodes[index + 1], self.nodes[node.right_or_item as usize]);
                let weight = a.weight + b.weight;
                node.weight = weight;
                node.centre =
                    if weight > 0.0 { (a.centre * a.weight + b.centre * b.weight) / weight } else { 0.5 * (a.centre + b.centre) };
                node.normal = (a.normal * a.weight + b.normal * b.weight).normalize_or_zero();
                node.radius = (a.centre.distance(node.centre) + a.radius).max(b.centre.distance(node.centre) + b.radius);
            }
            if node != old || frame == 0 {
                self.nodes[index] = node;
                self.changed_at[index] = frame;
                changed += 1;
            }
        }
        changed
    }

    /// Stamps the leaf of item `item` as changed at `frame` (its form factors change even when
    /// its cluster data does not: a triangle turned about its centroid).
    pub fn stamp_leaf(&mut self, item: usize, frame: u64) {
        let leaf = self.leaf_of[item] as usize;
        self.changed_at[leaf] = self.changed_at[leaf].max(frame);
    }

    /// Stamps every node as changed at `frame` (a new medium invalidates every form factor).
    pub fn touch_all(&mut self, frame: u64) {
        self.changed_at.fill(frame);
    }

    #[must_use]
    pub fn nodes(&self) -> &[ClusterNode] {
        &self.nodes
    }

    #[must_use]
    pub fn node(&self, index: u32) -> &ClusterNode {
        &self.nodes[index as usize]
    }

    /// The end (exclusive) of node `index`'s subtree in depth-first order.
    #[must_use]
    pub fn subtree_end(&self, index: u32) -> u32 {
        self.ends[index as usize]
    }

    /// The frame node `index` last changed at.
    #[must_use]
    pub fn changed_at(&self, index: u32) -> u64 {
        self.changed_at[index as usize]
    }

    /// The leaf of item `item`.
    #[must_use]
    pub fn leaf_of(&self, item: usize) -> u32 {
        self.leaf_of[item]
    }

    /// The number of items.
    #[must_use]
    pub fn item_count(&self) -> usize {
        self.leaf_of.len()
    }

    /// The sum of every node's radius, a measure of how far a refit tree has degraded.
    #[must_use]
    pub fn radius_sum(&self) -> f64 {
        self.nodes.iter().map(|n| n.radius).sum()
    }

    /// Disjoint subtrees that together hold every leaf, at least `count` of them where the
    /// tree has that many leaves: the frontier of a breadth-first descent that splits the
    /// largest subtree first. Sorted by node index (depth-first order).
    #[must_use]
    pub fn cut(&self, count: usize) -> Vec<u32> {
        let mut frontier = vec![0u32];
        while frontier.len() < count {
            let Some((at, _)) = frontier
                .iter()
                .enumerate()
                .filter(|(_, &n)| !self.nodes[n as usize].leaf)
                .max_by_key(|(_, &n)| (self.ends[n as usize] - n, std::cmp::Reverse(n)))
            else {
                break;
            };
            let n = frontier.swap_remove(at);
            frontier.extend(self.nodes[n as usize].children(n).expect("an inner node"));
        }
        frontier.sort_unstable();
        frontier
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn points(n: usize) -> Vec<ClusterItem> {
        (0..n)
            .map(|i| {
                let t = i as f64 * 0.618_034;
                ClusterItem::point(DVec3::new(t.sin() * 5.0, (2.0 * t).cos() * 3.0, (i as f64).sqrt()), DVec3::Z)
            })
            .collect()
    }

    #[test]
    fn every_node_bounds_its_items_and_sums_their_weights() {
        let items: Vec<ClusterItem> = (0..97)
            .map(|i| {
                let p = DVec3::new(i as f64, (i * i % 13) as f64, (i % 7) as f64);
                ClusterItem::triangle([p, p + DVec3::X, p + DVec3::new(0.0, 2.0, 0.5)])
            })
            .collect();
        let tree = ClusterTree::build(&items);
        assert_eq!(tree.nodes().len(), 2 * items.len() - 1);
        for (i, node) in tree.nodes().iter().enumerate() {
            let leaves: Vec<u32> = (i as u32..tree.subtree_end(i as u32))
                .filter(|&j| tree.node(j).leaf)
                .map(|j| tree.node(j).right_or_item)
                .collect();
            let weight: f64 = leaves.iter().map(|&t| items[t as usize].weight).sum();
            assert!((node.weight - weight).abs() < 1e-9 * weight);
            for &t in &leaves {
                let it = items[t as usize];
                assert!(it.centre.distance(node.centre) + it.radius <= node.radius + 1e-9, "node {i}");
                assert_eq!(
                    tree.leaf_of(t as usize),
                    tree.nodes().iter().position(|n| n.leaf && n.right_or_item == t).unwrap() as u32
                );
            }
        }
    }

    #[test]
    fn refit_equals_a_build_of_the_moved_items_with_the_same_topology_and_stamps_what_moved() {
        let items = points(200);
        let mut tree = ClusterTree::build(&items);
        let mut moved = items.clone();
        moved[17].centre += DVec3::new(0.1, 0.0, 0.0);
        let changed = tree.refit(&moved, 3);
        // The moved leaf and its ancestors: the depth of leaf 17.
        let leaf = tree.leaf_of(17);
        let depth = (0..tree.nodes().len() as u32).filter(|&n| n <= leaf && tree.subtree_end(n) > leaf).count();
        assert_eq!(changed, depth);
        assert_eq!(tree.changed_at(leaf), 3);
        assert_eq!(tree.changed_at(tree.leaf_of(18)), 0);
        assert_eq!(tree.refit(&moved, 4), 0, "a refit that moves nothing changes nothing");
    }

    #[test]
    fn a_cut_partitions_the_leaves() {
        let tree = ClusterTree::build(&points(1000));
        for count in [1, 2, 7, 64, 5000] {
            let cut = tree.cut(count);
            assert!(cut.len() >= count.min(1000));
            let covered: u32 = cut.iter().map(|&n| tree.subtree_end(n) - n).sum::<u32>();
            let leaves: usize = cut.iter().map(|&n| (n..tree.subtree_end(n)).filter(|&j| tree.node(j).leaf).count()).sum();
            assert_eq!(leaves, 1000, "{count}");
            assert!(covered as usize <= tree.nodes().len());
            assert!(cut.windows(2).all(|w| tree.subtree_end(w[0]) <= w[1]), "disjoint ranges");
        }
    }
}
