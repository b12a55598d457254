//! The hierarchical integration B(x) = ∫_S E Rd dA over a triangle mesh (Mertens et al. 2003
//! eqs. 4–7, §3.2, §5): a cluster tree of emitting triangles, one of receiving points, links
//! between clusters chosen by the [`Oracle`], and per update: the irradiance pulled up the
//! emitter tree (area-weighted), gathered over the links, pushed down the receiver tree.
//!
//! A far link is the dipole between the clusters' centres expanded to second order on both
//! sides, as a fast multipole method's multipole and local expansions: with D = c_R − c_E,
//! f = Rd(‖D‖), ∇f = kD and H = kI + lDDᵀ (k, l from [`Dipole::rd_slope_over_r`] and
//! [`Dipole::rd_curvature`]), the emitter's flux Φ, first and second flux moments m and Q about
//! its centre (pulled up the tree), and ξ a receiver's offset from its cluster's centre,
//!
//! B(c_R + ξ) ≈ Φf − ∇f·m + ½H:Q + (Φ∇f − Hm)·ξ + ½Φ ξᵀHξ,
//!
//! the ξ terms pushed down the receiver tree. One plain sample (the paper's) is biased by the
//! kernel's curvature: against the O(n²) sum on a sun-lit geodesic sphere of 5,120 triangles at
//! θ = 0.4, one sample is 1.1% (peak-relative RMS) off, the first-order expansion 0.6%, the
//! second-order one 0.04% (core/tests/integration/hierarchical_dipole.rs). With [`DipoleGeometry::PaperSources`] the kernel depends on the receiver's normal
//! and the sample is left uncorrected, as the paper has it.
//!
//! The receivers are cut into [`TASKS`] subtrees (or as many as [`DipoleHierarchy::set_tasks`]
//! asks for: the GPU traverses one per invocation), each traversed against the whole emitter
//! tree on its own (in parallel, each writing only its own nodes), so the result does not
//! depend on the number of threads. A task's links are kept (render and incremental modes)
//! in the order of its traversal.

use std::collections::HashMap;
use std::time::Instant;

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use crate::optics::quadrature::triangle_rule7;
use crate::optics::{triangle_integral_rgb, Dipole, DipoleGeometry, DipoleTable, EdgeRule};
use crate::progress::{ms, Cancelled};

use super::error::HierarchyError;
use super::options::{DipoleOptions, EvalMode, Receivers};
use super::oracle::Decision;
use super::tree::{ClusterItem, ClusterNode, ClusterTree};

/// The receiver subtrees traversed independently (fewer where the tree has fewer leaves).
pub const TASKS: usize = 256;

/// The emitter subtrees the pull computes in parallel.
const PULL_TASKS: usize = 64;

/// A refitted tree is rebuilt when the sum of its radii exceeds this multiple of the sum
/// right after its build (design note §5.9: a refitted tree degrades under large motion).
const REBUILD_RADIUS_GROWTH: f64 = 2.0;

/// A far link: the receiver node gathers from the emitter node through f, k and l per channel
/// (module documentation), looked up in the dipole table at each gather from the nodes'
/// centres: a lookup costs less than reading the nine values stored (8 bytes a link, not 44).
#[derive(Debug, Clone, Copy, PartialEq)]
struct FarLink {
    receiver: u32,
    emitter: u32,
}

/// A near link: a receiving leaf and an emitting triangle with the analytic form factor `f`
/// per channel (Mertens eq. 18).
#[derive(Debug, Clone, Copy, PartialEq)]
struct NearLink {
    receiver: u32,
    emitter: u32,
    f: [f32; 3],
}

/// One receiver subtree and its links, each kind in the order of the traversal.
#[derive(Debug, Clone)]
struct Task {
    root: u32,
    far: Vec<FarLink>,
    near: Vec<NearLink>,
    /// The frame its links were made at (`None`: never).
    built_at: Option<u64>,
}

impl Task {
    fn new(root: u32) -> Self {
        Self { root, far: Vec::new(), near: Vec::new(), built_at: None }
    }

    fn links(&self) -> usize {
        self.far.len() + self.near.len()
    }
}

/// What a link found by the traversal carries.
enum Found {
    /// A far link.
    Far,
    /// A near link's analytic form factor, or `None` where it was kept from before.
    Near(Option<[f64; 3]>),
}

/// The kernel of a far link per channel: f = Rd(‖D‖), k = Rd′/‖D‖, l = k′/‖D‖.
#[derive(Debug, Clone, Copy)]
struct Kernel {
    f: [f64; 3],
    k: [f64; 3],
    l: [f64; 3],
}

/// The emitter tree under one irradiance, per node and channel: the mean irradiance (for near
/// links), the flux Φ = ∫ E dA and the flux moments m = ∫ E (x − c) dA and
/// Q = ∫ E (x − c)(x − c)ᵀ dA about the node's centre. Kept between updates, so its memory
/// is not allocated (and faulted in) again.
#[derive(Debug, Clone, Default)]
struct Emitted {
    irradiance: Vec<[f64; 3]>,
    flux: Vec<[f64; 3]>,
    moment: Vec<[DVec3; 3]>,
    second: Vec<[DMat3; 3]>,
}

/// What a receiver subtree gathered, per node and channel: B at the node's centre, its
/// gradient and its Hessian. Kept between updates, as [`Emitted`].
#[derive(Debug, Clone, Default)]
struct Gathered {
    b: Vec<[f64; 3]>,
    gradient: Vec<[DVec3; 3]>,
    hessian: Vec<[DMat3; 3]>,
}

impl Gathered {
    /// Zero over `len` nodes, reusing the memory.
    fn reset(&mut self, len: usize) {
        self.b.clear();
        self.b.resize(len, [0.0; 3]);
        self.gradient.clear();
        self.gradient.resize(len, [DVec3::ZERO; 3]);
        self.hessian.clear();
        self.hessian.resize(len, [DMat3::ZERO; 3]);
    }

    /// Adds a far link's expansion at local node `at` (module documentation); at a receiving
    /// `leaf` (a point, nothing below to push to) only its value.
    fn far(&mut self, at: usize, leaf: bool, d: DVec3, kernel: Kernel, emitted: &Emitted, e: usize) {
        let Kernel { f, k, l } = kernel;
        for c in 0..3 {
            let (phi, m, q) = (emitted.flux[e][c], emitted.moment[e][c], emitted.second[e][c]);
            let trace_q = q.x_axis.x + q.y_axis.y + q.z_axis.z;
            let dm = d.dot(m);
            self.b[at][c] += phi * f[c] - k[c] * dm + 0.5 * (k[c] * trace_q + l[c] * d.dot(q * d));
        }
        if leaf {
            return;
        }
        let ddt = DMat3::from_cols(d * d.x, d * d.y, d * d.z);
        for c in 0..3 {
            let (phi, m) = (emitted.flux[e][c], emitted.moment[e][c]);
            let dm = d.dot(m);
            // ∇f·Φ − H m with H = kI + l DDᵀ.
            self.gradient[at][c] += d * (k[c] * phi - l[c] * dm) - m * k[c];
            let h = &mut self.hessian[at][c];
            *h += ddt * (phi * l[c]);
            let diagonal = phi * k[c];
            h.x_axis.x += diagonal;
            h.y_axis.y += diagonal;
            h.z_axis.z += diagonal;
        }
    }

    /// Adds a near link's contribution at local node `at`: B += F·E.
    fn near(&mut self, at: usize, f: [f64; 3], emitted: &Emitted, e: usize) {
        for ((b, f), e) in self.b[at].iter_mut().zip(f).zip(emitted.irradiance[e]) {
            *b += f * e;
        }
    }
}

/// What one update measured.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct DipoleStats {
    /// Emitting triangles (leaves of the emitter tree).
    pub triangles: usize,
    /// Receiving points.
    pub receivers: usize,
    /// Nodes of both trees.
    pub nodes: usize,
    /// Links used by the update (far + near).
    pub links: usize,
    /// Of them, leaf pairs with a form factor over the triangle (analytic, or the 7-point rule).
    pub near_links: usize,
    /// Links made by the update, near links with their form factor evaluated (0 in render
    /// mode with links kept; a far link's kernel is a table lookup at every gather).
    pub form_factors: usize,
    /// Receiver subtrees whose links are older than the geometry or medium (incremental mode
    /// with a budget): their error decays as later updates relink them.
    pub stale_tasks: usize,
    /// Refitting (or rebuilding) the trees after the last deformation.
    pub refit_ms: f64,
    /// Traversing the trees and evaluating form factors.
    pub link_ms: f64,
    /// Pulling the irradiance and gathering over the links.
    pub gather_ms: f64,
    /// Pushing down the receiver tree and averaging onto the vertices.
    pub push_ms: f64,
}

/// The hierarchical dipole over one surface (module documentation). Lengths in millimetres.
#[derive(Debug, Clone)]
pub struct DipoleHierarchy {
    positions: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    /// The medium's dipole per channel, tabulated for the far links and the 7-point rule.
    table: DipoleTable,
    options: DipoleOptions,
    emitters: ClusterTree,
    receivers: ClusterTree,
    receiver_items: Vec<ClusterItem>,
    rest_radius: [f64; 2],
    tasks: Vec<Task>,
    /// How many receiver subtrees the traversal is cut into (at least; [`ClusterTree::cut`]).
    task_count: usize,
    /// One more per new trees or new cut ([`DipoleHierarchy::topology`]).
    topology: u64,
    /// The current frame: 0 at build, one more per deformation or medium change.
    frame: u64,
    /// Where the next budgeted relink starts (round-robin over stale tasks).
    next_task: usize,
    /// Refit time of the last deformation, reported by the next update.
    refit_ms: f64,
    /// The emitter tree's expansions and each task's gathered expansions, kept for reuse.
    emitted: Emitted,
    gathered: Vec<Gathered>,
}

/// The receiver's data a form factor needs: its point and unit normal.
fn receiver_point(node: &ClusterNode) -> (DVec3, DVec3) {
    (node.centre, node.normal)
}

impl DipoleHierarchy {
    /// The hierarchy over the triangles `triangles` of `positions` (mm), the medium's dipole
    /// per channel.
    ///
    /// # Errors
    /// [`HierarchyError`] for an empty or degenerate surface, an index out of range, a
    /// non-finite position or invalid options.
    pub fn new(
        positions: Vec<DVec3>,
        triangles: Vec<[u32; 3]>,
        dipoles: [Dipole; 3],
        options: DipoleOptions,
    ) -> Result<Self, HierarchyError> {
        options.validate().map_err(HierarchyError::InvalidOptions)?;
        if triangles.is_empty() {
            return Err(HierarchyError::NoTriangles);
        }
        for (triangle, t) in triangles.iter().enumerate() {
            if let Some(&index) = t.iter().find(|&&i| i as usize >= positions.len()) {
                return Err(HierarchyError::IndexOutOfRange { triangle, index, vertices: positions.len() });
            }
        }
        check_positions(&positions)?;
        let emitter_items = emitter_items(&positions, &triangles);
        if !(emitter_items.iter().map(|i| i.weight).sum::<f64>() > 0.0) {
            return Err(HierarchyError::NoArea);
        }
        let receiver_items = receiver_items(&positions, &triangles, options.receivers);
        let emitters = ClusterTree::build(&emitter_items);
        let receivers = ClusterTree::build(&receiver_items);
        let tasks = receivers.cut(TASKS).into_iter().map(Task::new).collect();
        Ok(Self {
            rest_radius: [emitters.radius_sum(), receivers.radius_sum()],
            table: DipoleTable::new(dipoles, table_reach(&emitters)),
            positions,
            triangles,
            options,
            emitters,
            receivers,
            receiver_items,
            tasks,
            task_count: TASKS,
            topology: 0,
            frame: 0,
            next_task: 0,
            refit_ms: 0.0,
            emitted: Emitted::default(),
            gathered: Vec::new(),
        })
    }

    #[must_use]
    pub fn options(&self) -> &DipoleOptions {
        &self.options
    }

    /// Changes when links are made from the next update on; the links kept stay valid.
    ///
    /// # Errors
    /// [`HierarchyError::InvalidOptions`] for a budget of 0; nothing changed.
    pub fn set_mode(&mut self, mode: EvalMode) -> Result<(), HierarchyError> {
        let options = DipoleOptions { mode, ..self.options };
        options.validate().map_err(HierarchyError::InvalidOptions)?;
        self.options = options;
        Ok(())
    }

    #[must_use]
    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    #[must_use]
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// The dipole per channel.
    #[must_use]
    pub fn dipoles(&self) -> &[Dipole; 3] {
        self.table.dipoles()
    }

    /// The unit normal per vertex: the area-weighted mean of its triangles' (zero for a vertex
    /// on no triangle). The irradiance an update takes is the light entering along these.
    #[must_use]
    pub fn vertex_normals(&self) -> Vec<DVec3> {
        vertex_normals(&self.positions, &self.triangles)
    }

    /// Moves the vertices (same count and order; the topology is kept): refits both trees and
    /// marks what moved, so the next update relinks as its mode says. Rebuilds the trees when
    /// the refit ones have degraded (their radii summing to twice the rest value).
    ///
    /// # Errors
    /// [`HierarchyError::WrongLength`] or [`HierarchyError::NonFinite`]; nothing changed.
    pub fn set_positions(&mut self, positions: &[DVec3]) -> Result<(), HierarchyError> {
        if positions.len() != self.positions.len() {
            return Err(HierarchyError::WrongLength { what: "positions", expected: self.positions.len(), got: positions.len() });
        }
        check_positions(positions)?;
        let start = Instant::now();
        let moved: Vec<bool> = positions.iter().zip(&self.positions).map(|(a, b)| a != b).collect();
        self.positions.copy_from_slice(positions);
        self.frame += 1;
        let emitter_items = emitter_items(&self.positions, &self.triangles);
        self.receiver_items = receiver_items(&self.positions, &self.triangles, self.options.receivers);
        self.emitters.refit(&emitter_items, self.frame);
        self.receivers.refit(&self.receiver_items, self.frame);
        // A triangle whose corners moved within its leaf's data (a turn about its centroid)
        // still changes its analytic form factors.
        for (t, tri) in self.triangles.iter().enumerate() {
            if tri.iter().any(|&v| moved[v as usize]) {
                self.emitters.stamp_leaf(t, self.frame);
            }
        }
        if self.emitters.radius_sum() > REBUILD_RADIUS_GROWTH * self.rest_radius[0]
            || self.receivers.radius_sum() > REBUILD_RADIUS_GROWTH * self.rest_radius[1]
        {
            self.rebuild(&emitter_items);
        }
        self.refit_ms = ms(start);
        Ok(())
    }

    /// New trees over the current positions; every link is made again.
    fn rebuild(&mut self, emitter_items: &[ClusterItem]) {
        self.emitters = ClusterTree::build(emitter_items);
        self.receivers = ClusterTree::build(&self.receiver_items);
        self.emitters.touch_all(self.frame);
        self.receivers.touch_all(self.frame);
        self.rest_radius = [self.emitters.radius_sum(), self.receivers.radius_sum()];
        self.tasks = self.receivers.cut(self.task_count).into_iter().map(Task::new).collect();
        self.topology += 1;
    }

    /// Which trees and cut the hierarchy has: one more each time they are built anew (a
    /// deformation that degraded the refitted trees, [`DipoleHierarchy::set_tasks`]); a copy
    /// made of them elsewhere (the GPU's) is stale when this changed.
    #[must_use]
    pub fn topology(&self) -> u64 {
        self.topology
    }

    /// Cuts the receiver tree into at least `count` subtrees (where it has that many leaves),
    /// each traversed on its own: links are never made above a subtree's root, so more subtrees
    /// mean more links and more parallelism. [`TASKS`] by default; every link is made again.
    pub fn set_tasks(&mut self, count: usize) {
        self.task_count = count.max(1);
        self.frame += 1;
        self.emitters.touch_all(self.frame);
        self.receivers.touch_all(self.frame);
        self.tasks = self.receivers.cut(self.task_count).into_iter().map(Task::new).collect();
        self.topology += 1;
    }

    /// The roots of the receiver subtrees, in depth-first order.
    #[must_use]
    pub fn task_roots(&self) -> Vec<u32> {
        self.tasks.iter().map(|t| t.root).collect()
    }

    /// The cluster tree over the emitting triangles (its items are the triangles).
    #[must_use]
    pub fn emitter_tree(&self) -> &ClusterTree {
        &self.emitters
    }

    /// The cluster tree over the receiving points (vertices or face centroids, by the options).
    #[must_use]
    pub fn receiver_tree(&self) -> &ClusterTree {
        &self.receivers
    }

    /// The memory of the links kept (render and incremental modes), in bytes: 8 per far link,
    /// 20 per near one.
    #[must_use]
    pub fn link_bytes(&self) -> usize {
        self.tasks.iter().map(|t| t.far.len() * size_of::<FarLink>() + t.near.len() * size_of::<NearLink>()).sum()
    }

    /// A new medium (one dipole per channel): every form factor changes, the links do not (the
    /// oracle is geometric).
    pub fn set_dipoles(&mut self, dipoles: [Dipole; 3]) {
        self.table = DipoleTable::new(dipoles, table_reach(&self.emitters));
        self.frame += 1;
        self.emitters.touch_all(self.frame);
        self.receivers.touch_all(self.frame);
    }

    /// The exitance B per vertex under the irradiance `irradiance` per vertex (the light
    /// entering along [`DipoleHierarchy::vertex_normals`], ≥ 0), by the options' mode;
    /// `keep_going` is asked between receiver subtrees.
    ///
    /// # Errors
    /// [`HierarchyError::WrongLength`] or [`HierarchyError::InvalidIrradiance`], or
    /// [`HierarchyError::Cancelled`]; nothing changed.
    pub fn update(
        &mut self,
        irradiance: &[[f64; 3]],
        keep_going: &(dyn Fn() -> bool + Sync),
    ) -> Result<(Vec<[f64; 3]>, DipoleStats), HierarchyError> {
        check_irradiance(irradiance, self.positions.len())?;
        let mut stats = DipoleStats {
            triangles: self.triangles.len(),
            receivers: self.receiver_items.len(),
            nodes: self.emitters.nodes().len() + self.receivers.nodes().len(),
            refit_ms: std::mem::take(&mut self.refit_ms),
            ..DipoleStats::default()
        };
        let t = Instant::now();
        let mut emitted = std::mem::take(&mut self.emitted);
        self.pull(irradiance, &mut emitted);
        let mut gathered = std::mem::take(&mut self.gathered);
        gathered.resize_with(self.tasks.len(), Gathered::default);
        stats.gather_ms += ms(t);

        let t = Instant::now();
        match self.options.mode {
            EvalMode::OnTheFly => {
                // Gathered as the links are found, in f64, none stored.
                let counts = self
                    .tasks
                    .par_iter()
                    .zip(gathered.par_iter_mut())
                    .map(|(task, g)| {
                        if !keep_going() {
                            return Err(Cancelled);
                        }
                        let root = task.root;
                        g.reset((self.receivers.subtree_end(root) - root) as usize);
                        let (mut links, mut near_links) = (0, 0);
                        self.traverse(root, &HashMap::new(), &mut |r, e, found| {
                            links += 1;
                            let at = (r - root) as usize;
                            match found {
                                Found::Far => self.gather_far(&mut *g, at, r, e, &emitted),
                                Found::Near(f) => {
                                    near_links += 1;
                                    g.near(at, f.expect("nothing is kept on the fly"), &emitted, e as usize);
                                }
                            }
                        });
                        Ok((links, near_links))
                    })
                    .collect::<Result<Vec<_>, Cancelled>>()?;
                stats.links = counts.iter().map(|r| r.0).sum();
                stats.near_links = counts.iter().map(|r| r.1).sum();
                stats.form_factors = stats.links;
                stats.link_ms = ms(t);
            }
            EvalMode::Render | EvalMode::Incremental { .. } => {
                stats.form_factors = self.relink(keep_going)?;
                stats.link_ms = ms(t);
                let t = Instant::now();
                self.tasks.par_iter().zip(gathered.par_iter_mut()).for_each(|(task, g)| self.gather(task, &emitted, g));
                stats.links = self.tasks.iter().map(Task::links).sum();
                stats.near_links = self.tasks.iter().map(|t| t.near.len()).sum();
                stats.stale_tasks = self.tasks.iter().filter(|t| self.is_stale(t)).count();
                stats.gather_ms += ms(t);
            }
        }
        let t = Instant::now();
        let b = self.push(&mut gathered);
        stats.push_ms = ms(t);
        (self.emitted, self.gathered) = (emitted, gathered);
        Ok((b, stats))
    }

    /// Whether a task's links are older than its geometry or medium.
    fn is_stale(&self, task: &Task) -> bool {
        let Some(built) = task.built_at else { return true };
        let changed = |tree: &ClusterTree, lo: u32, hi: u32| (lo..hi).any(|n| tree.changed_at(n) > built);
        // Every change of an emitter reaches the root; a receiver's stays in its subtree.
        self.emitters.changed_at(0) > built || changed(&self.receivers, task.root, self.receivers.subtree_end(task.root))
    }

    /// Makes the links the mode asks for; returns the form factors evaluated.
    fn relink(&mut self, keep_going: &(dyn Fn() -> bool + Sync)) -> Result<usize, HierarchyError> {
        let stale: Vec<usize> = (0..self.tasks.len()).filter(|&i| self.is_stale(&self.tasks[i])).collect();
        if stale.is_empty() {
            return Ok(0);
        }
        let (reuse, budget) = match self.options.mode {
            EvalMode::Incremental { budget } => (true, budget),
            _ => (false, None),
        };
        // With a budget: stale tasks in round-robin order from where the last update stopped,
        // as many as the budget covers by their current link counts (at least one).
        let chosen: Vec<usize> = match budget {
            None => stale,
            Some(budget) => {
                let start = stale.iter().position(|&i| i >= self.next_task).unwrap_or(0);
                let mut chosen = Vec::new();
                let mut spent = 0usize;
                for &i in stale[start..].iter().chain(&stale[..start]) {
                    let cost = self.tasks[i].links().max(1);
                    if !chosen.is_empty() && spent + cost > budget {
                        break;
                    }
                    spent += cost;
                    chosen.push(i);
                }
                self.next_task = chosen.last().map_or(0, |&i| i + 1);
                chosen
            }
        };
        let frame = self.frame;
        let this = &*self;
        let rebuilt = chosen
            .par_iter()
            .map(|&i| {
                if !keep_going() {
                    return Err(Cancelled);
                }
                let task = &this.tasks[i];
                // The analytic form factors of leaf pairs neither of which changed since the
                // task was linked.
                let kept: HashMap<(u32, u32), [f32; 3]> = match (reuse, task.built_at) {
                    (true, Some(built)) => task
                        .near
                        .iter()
                        .filter(|l| {
                            this.emitters.changed_at(l.emitter) <= built && this.receivers.changed_at(l.receiver) <= built
                        })
                        .map(|l| ((l.receiver, l.emitter), l.f))
                        .collect(),
                    _ => HashMap::new(),
                };
                let mut fresh = Task {
                    root: task.root,
                    far: Vec::with_capacity(task.far.len()),
                    near: Vec::with_capacity(task.near.len()),
                    built_at: Some(frame),
                };
                let mut evaluated = 0;
                this.traverse(task.root, &kept, &mut |receiver, emitter, found| match found {
                    Found::Far => {
                        evaluated += 1;
                        fresh.far.push(FarLink { receiver, emitter });
                    }
                    Found::Near(f) => {
                        let f = match f {
                            Some(f) => {
                                evaluated += 1;
                                to_f32(f)
                            }
                            None => kept[&(receiver, emitter)],
                        };
                        fresh.near.push(NearLink { receiver, emitter, f });
                    }
                });
                Ok((i, fresh, evaluated))
            })
            .collect::<Result<Vec<_>, Cancelled>>()?;
        let mut evaluated = 0;
        for (i, task, n) in rebuilt {
            self.tasks[i] = task;
            evaluated += n;
        }
        Ok(evaluated)
    }

    /// The dual-tree traversal from (`root`, emitter root): every link the oracle makes, in a
    /// fixed order, given to `link` as (receiver, emitter, what it carries); a near pair found
    /// in `kept` is not evaluated (`Found::Near(None)`).
    fn traverse(&self, root: u32, kept: &HashMap<(u32, u32), [f32; 3]>, link: &mut dyn FnMut(u32, u32, Found)) {
        let (rt, et) = (&self.receivers, &self.emitters);
        let mut stack = vec![(root, 0u32)];
        while let Some((r, e)) = stack.pop() {
            let (rn, en) = (rt.node(r), et.node(e));
            let children = rn.children(r).map(|[a, b]| [rt.node(a), rt.node(b)]);
            match self.options.oracle.decide(rn, children, en) {
                Decision::Accept => link(r, e, Found::Far),
                Decision::Near if kept.contains_key(&(r, e)) => link(r, e, Found::Near(None)),
                Decision::Near => link(r, e, Found::Near(Some(self.near_factor(rn, en.right_or_item as usize)))),
                Decision::OpenReceiver => {
                    let [a, b] = rn.children(r).expect("an inner receiver");
                    stack.push((b, e));
                    stack.push((a, e));
                }
                Decision::OpenEmitter => {
                    let [a, b] = en.children(e).expect("an inner emitter");
                    stack.push((r, b));
                    stack.push((r, a));
                }
            }
        }
    }

    /// Gathers far link (`r`, `e`) into local node `at` of `g`: its kernel from the nodes'
    /// centres, expanded as [`Gathered::far`] says.
    fn gather_far(&self, g: &mut Gathered, at: usize, r: u32, e: u32, emitted: &Emitted) {
        let (rn, en) = (self.receivers.node(r), self.emitters.node(e));
        g.far(at, rn.leaf, rn.centre - en.centre, self.far_factor(rn, en), emitted, e as usize);
    }

    /// The dipole between the clusters' centres with its derivatives (module documentation;
    /// in the paper's geometry the sample alone, k = l = 0).
    fn far_factor(&self, r: &ClusterNode, e: &ClusterNode) -> Kernel {
        let (x_o, n_o) = receiver_point(r);
        match self.options.geometry {
            DipoleGeometry::Distance => {
                let [f, k, l] = self.table.rd_with_derivatives(x_o.distance_squared(e.centre));
                Kernel { f, k, l }
            }
            geometry => {
                Kernel { f: self.dipoles().map(|p| point_kernel(&p, e.centre, x_o, n_o, geometry)), k: [0.0; 3], l: [0.0; 3] }
            }
        }
    }

    /// The form factor of triangle `t` at a receiving leaf: analytic (Mertens eq. 18, the
    /// three channels at once in the distance geometry) for the triangles seen under more than
    /// [`Oracle::rule7_below`] (those around the receiver), the 7-point rule of degree 5 for the
    /// others the oracle refused: as accurate there against the O(n²) sum, at a fifth of the cost.
    fn near_factor(&self, r: &ClusterNode, t: usize) -> [f64; 3] {
        let (x_o, n_o) = receiver_point(r);
        let corners = self.triangles[t].map(|v| self.positions[v as usize]);
        let geometry = self.options.geometry;
        let e = self.emitters.node(self.emitters.leaf_of(t));
        let analytic = e.radius >= self.options.oracle.rule7_below() * x_o.distance(e.centre);
        match geometry {
            DipoleGeometry::Distance if analytic => triangle_integral_rgb(self.dipoles(), corners, x_o, self.options.rule),
            DipoleGeometry::Distance => {
                triangle_rule7(&|x: DVec3| DVec3::from_array(self.table.rd(x.distance_squared(x_o))), corners).to_array()
            }
            geometry if analytic => self.dipoles().map(|d| d.triangle_integral(corners, x_o, n_o, geometry, self.options.rule)),
            geometry => self.dipoles().map(|d| triangle_rule7(&|x| point_kernel(&d, x, x_o, n_o, geometry), corners)),
        }
    }

    /// The emitter tree under `irradiance` per vertex ([`Emitted`]): on a triangle the
    /// irradiance interpolated linearly from its corners, E = Σᵢ Eᵢλᵢ, whose moments follow
    /// from ∫ λ₁^a λ₂^b λ₃^c dA = 2A a! b! c!/(a + b + c + 2)! ([`leaf_expansion`]); pulled up
    /// area-weighted (design note §1.7: pbrt-v2's unweighted mean is a bug), the moments moved
    /// to each parent's centre ([`parent_expansion`]).
    fn pull(&self, irradiance: &[[f64; 3]], out: &mut Emitted) {
        let nodes = self.emitters.nodes();
        let n = nodes.len();
        out.flux.resize(n, [0.0; 3]);
        out.moment.resize(n, [DVec3::ZERO; 3]);
        out.second.resize(n, [DMat3::ZERO; 3]);
        out.irradiance.resize(n, [0.0; 3]);
        let Emitted { irradiance: mean, flux, moment, second } = out;
        // The subtrees of a cut in parallel, each on its own part of the arrays, then the
        // nodes above the cut.
        let roots = self.emitters.cut(PULL_TASKS);
        let mut parts = Vec::with_capacity(roots.len());
        let (mut f, mut m, mut q, mut at) = (&mut flux[..], &mut moment[..], &mut second[..], 0);
        for &root in &roots {
            let (lo, hi) = (root as usize, self.emitters.subtree_end(root) as usize);
            let (part_f, rest_f) = std::mem::take(&mut f)[lo - at..].split_at_mut(hi - lo);
            let (part_m, rest_m) = std::mem::take(&mut m)[lo - at..].split_at_mut(hi - lo);
            let (part_q, rest_q) = std::mem::take(&mut q)[lo - at..].split_at_mut(hi - lo);
            (f, m, q, at) = (rest_f, rest_m, rest_q, hi);
            parts.push((lo, part_f, part_m, part_q));
        }
        parts.into_par_iter().for_each(|(lo, f, m, q)| {
            for local in (0..f.len()).rev() {
                let index = lo + local;
                let node = nodes[index];
                (f[local], m[local], q[local]) = match node.children(index as u32) {
                    None => {
                        let t = self.triangles[node.right_or_item as usize];
                        let v = t.map(|i| self.positions[i as usize] - node.centre);
                        leaf_expansion(node.weight, v, t.map(|i| irradiance[i as usize]))
                    }
                    Some(children) => parent_expansion(nodes, index, children, |c| (f[c - lo], m[c - lo], q[c - lo])),
                };
            }
        });
        let mut below = roots.len();
        for index in (0..n).rev() {
            if below > 0 && index < self.emitters.subtree_end(roots[below - 1]) as usize {
                if index == roots[below - 1] as usize {
                    below -= 1;
                }
                continue;
            }
            let children = nodes[index].children(index as u32).expect("a node above the cut is inner");
            (flux[index], moment[index], second[index]) =
                parent_expansion(nodes, index, children, |c| (flux[c], moment[c], second[c]));
        }
        mean.par_iter_mut().zip(flux.par_iter()).zip(nodes.par_iter()).for_each(|((m, f), n)| {
            *m = if n.weight > 0.0 { f.map(|x| x / n.weight) } else { [0.0; 3] };
        });
    }

    /// What `task`'s stored links gather.
    fn gather(&self, task: &Task, emitted: &Emitted, g: &mut Gathered) {
        let root = task.root;
        g.reset((self.receivers.subtree_end(root) - root) as usize);
        for l in &task.far {
            self.gather_far(g, (l.receiver - root) as usize, l.receiver, l.emitter, emitted);
        }
        for l in &task.near {
            g.near((l.receiver - root) as usize, l.f.map(f64::from), emitted, l.emitter as usize);
        }
    }

    /// B per vertex: each task's B pushed down its subtree (a child inherits its parent's local
    /// expansion moved to the child's centre: b + g·o + ½oᵀHo, g + Ho, H), read at the
    /// receiving leaves, and for face receivers averaged onto the vertices by area.
    fn push(&self, gathered: &mut [Gathered]) -> Vec<[f64; 3]> {
        let tree = &self.receivers;
        let mut at_item = vec![[0.0f64; 3]; self.receiver_items.len()];
        for (task, g) in self.tasks.iter().zip(gathered) {
            for local in 0..g.b.len() {
                let index = task.root + local as u32;
                let node = tree.node(index);
                if let Some(children) = node.children(index) {
                    let (b, gradient, hessian) = (g.b[local], g.gradient[local], g.hessian[local]);
                    for child in children {
                        let (at, o) = ((child - task.root) as usize, tree.node(child).centre - node.centre);
                        for c in 0..3 {
                            let ho = hessian[c] * o;
                            g.b[at][c] += b[c] + gradient[c].dot(o) + 0.5 * o.dot(ho);
                            g.gradient[at][c] += gradient[c] + ho;
                            g.hessian[at][c] += hessian[c];
                        }
                    }
                } else {
                    at_item[node.right_or_item as usize] = g.b[local];
                }
            }
        }
        match self.options.receivers {
            Receivers::Vertices => at_item,
            Receivers::FaceCentroids => face_to_vertex(&self.positions, &self.triangles, &at_item),
        }
    }
}

/// An emitter's flux Φ, first moment m and second moment Q per channel.
type Expansion = ([f64; 3], [DVec3; 3], [DMat3; 3]);

/// a bᵀ.
fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// The expansion of a triangle of area `area` whose corners lie at `v` from its centroid
/// (Σ vᵢ = 0), under the irradiance `e` at its corners interpolated linearly, E = Σᵢ Eᵢλᵢ:
/// Φ = A ΣEᵢ/3; ∫ λᵢλⱼ = A(1 + δᵢⱼ)/12 gives m = (A/12) Σ Eᵢvᵢ; and ∫ λᵢλⱼλₖ =
/// (A/60)(1 + δᵢⱼ + δⱼₖ + δᵢₖ + 2δᵢⱼδⱼₖ) gives Q = (A/60)[(Σ Eᵢ) Σⱼ vⱼvⱼᵀ + 2 Σᵢ Eᵢvᵢvᵢᵀ], the
/// terms with Σ vⱼ vanishing.
fn leaf_expansion(area: f64, v: [DVec3; 3], e: [[f64; 3]; 3]) -> Expansion {
    let corners = v.map(|vi| outer(vi, vi));
    let spread = corners[0] + corners[1] + corners[2];
    let total: [f64; 3] = std::array::from_fn(|c| e[0][c] + e[1][c] + e[2][c]);
    (
        total.map(|t| area * t / 3.0),
        std::array::from_fn(|c| (v[0] * e[0][c] + v[1] * e[1][c] + v[2] * e[2][c]) * (area / 12.0)),
        std::array::from_fn(|c| {
            let own = corners[0] * e[0][c] + corners[1] * e[1][c] + corners[2] * e[2][c];
            (spread * total[c] + own * 2.0) * (area / 60.0)
        }),
    )
}

/// The expansion of inner node `index` from its children's (`child(i)` for node i), each moved
/// to its centre (o = c_child − c_parent: m += Φo, Q += m oᵀ + o mᵀ + Φ o oᵀ).
fn parent_expansion(nodes: &[ClusterNode], index: usize, children: [u32; 2], child: impl Fn(usize) -> Expansion) -> Expansion {
    let mut sum: Expansion = ([0.0; 3], [DVec3::ZERO; 3], [DMat3::ZERO; 3]);
    for c in children {
        let c = c as usize;
        let o = nodes[c].centre - nodes[index].centre;
        let (cf, cm, cq) = child(c);
        for k in 0..3 {
            sum.0[k] += cf[k];
            sum.1[k] += cm[k] + o * cf[k];
            sum.2[k] += cq[k] + outer(cm[k], o) + outer(o, cm[k]) + outer(o, o) * cf[k];
        }
    }
    sum
}

/// The distance up to which a hierarchy's dipole table is built: twice the emitter tree's
/// bounding diameter, so a mesh may grow to twice its size before far lookups evaluate exactly.
fn table_reach(emitters: &ClusterTree) -> f64 {
    4.0 * emitters.node(0).radius
}

fn to_f32(f: [f64; 3]) -> [f32; 3] {
    f.map(|x| x as f32)
}

/// Rd between an emitting point `x` and a receiver at `x_o` with unit normal `n_o`, in
/// `geometry` (Jensen et al. 2001's profile; design note §1.2).
#[must_use]
pub fn point_kernel(d: &Dipole, x: DVec3, x_o: DVec3, n_o: DVec3, geometry: DipoleGeometry) -> f64 {
    match geometry {
        DipoleGeometry::Distance => d.rd(x.distance(x_o)),
        DipoleGeometry::PaperSources => {
            let term = |z: f64, s: f64| z * (1.0 + d.sigma_tr * s) * (-d.sigma_tr * s).exp() / (s * s * s);
            let (sr, sv) = (x.distance(x_o - d.z_r * n_o), x.distance(x_o + d.z_v * n_o));
            d.alpha_prime / (4.0 * std::f64::consts::PI) * (term(d.z_r, sr) + term(d.z_v, sv))
        }
    }
}

/// The emitter tree's items: one per triangle.
fn emitter_items(positions: &[DVec3], triangles: &[[u32; 3]]) -> Vec<ClusterItem> {
    triangles.iter().map(|t| ClusterItem::triangle(t.map(|v| positions[v as usize]))).collect()
}

/// The receiver tree's items: the vertices (with their area-weighted normals) or the
/// triangles' centroids (with their normals).
fn receiver_items(positions: &[DVec3], triangles: &[[u32; 3]], receivers: Receivers) -> Vec<ClusterItem> {
    match receivers {
        Receivers::Vertices => {
            positions.iter().zip(vertex_normals(positions, triangles)).map(|(&p, n)| ClusterItem::point(p, n)).collect()
        }
        Receivers::FaceCentroids => {
            emitter_items(positions, triangles).into_iter().map(|t| ClusterItem::point(t.centre, t.normal)).collect()
        }
    }
}

/// The area-weighted unit normal per vertex (zero on no triangle).
pub use crate::mesh::area_weighted_normals as vertex_normals;

/// Per vertex, the area-weighted mean of its triangles' values (Gouraud).
pub(crate) fn face_to_vertex(positions: &[DVec3], triangles: &[[u32; 3]], per_face: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let mut sum = vec![[0.0f64; 3]; positions.len()];
    let mut area = vec![0.0f64; positions.len()];
    for (t, value) in triangles.iter().zip(per_face) {
        let [a, b, c] = t.map(|v| positions[v as usize]);
        let w = 0.5 * (b - a).cross(c - a).length();
        for &v in t {
            area[v as usize] += w;
            for ch in 0..3 {
                sum[v as usize][ch] += w * value[ch];
            }
        }
    }
    sum.iter().zip(&area).map(|(s, &a)| if a > 0.0 { s.map(|x| x / a) } else { [0.0; 3] }).collect()
}

pub(crate) fn check_positions(positions: &[DVec3]) -> Result<(), HierarchyError> {
    match positions.iter().position(|p| !p.is_finite()) {
        Some(vertex) => Err(HierarchyError::NonFinite { vertex, value: positions[vertex].to_array() }),
        None => Ok(()),
    }
}

pub(crate) fn check_irradiance(irradiance: &[[f64; 3]], vertices: usize) -> Result<(), HierarchyError> {
    if irradiance.len() != vertices {
        return Err(HierarchyError::WrongLength { what: "irradiance", expected: vertices, got: irradiance.len() });
    }
    match irradiance.iter().position(|e| !e.iter().all(|x| x.is_finite() && *x >= 0.0)) {
        Some(vertex) => Err(HierarchyError::InvalidIrradiance { vertex, value: irradiance[vertex] }),
        None => Ok(()),
    }
}

/// The O(n²) reference: B at every receiver summed over every triangle, with no hierarchy.
/// A triangle closer than four of its bounding radii gets the analytic form factor (Gauss–
/// Legendre split at L/r₀ < 0.25), the others the 7-point rule of degree 5. For tests and
/// benchmarks; B per vertex as [`DipoleHierarchy::update`] returns it.
///
/// # Errors
/// As [`DipoleHierarchy::update`], without cancellation.
pub fn reference_quadratic(hierarchy: &DipoleHierarchy, irradiance: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, HierarchyError> {
    let (positions, triangles) = (&hierarchy.positions, &hierarchy.triangles);
    check_irradiance(irradiance, positions.len())?;
    let geometry = hierarchy.options.geometry;
    let rule = EdgeRule::GaussLegendre3 { max_l_over_r: 0.25 };
    let per_triangle: Vec<([DVec3; 3], ClusterItem, [f64; 3])> = triangles
        .iter()
        .map(|t| {
            let corners = t.map(|v| positions[v as usize]);
            let e = |c: usize| t.iter().map(|&v| irradiance[v as usize][c]).sum::<f64>() / 3.0;
            (corners, ClusterItem::triangle(corners), [e(0), e(1), e(2)])
        })
        .collect();
    let at_receivers: Vec<[f64; 3]> = hierarchy
        .receiver_items
        .par_iter()
        .map(|r| {
            let mut b = [0.0f64; 3];
            for (corners, item, e) in &per_triangle {
                let near = r.centre.distance(item.centre) < 4.0 * item.radius;
                for (c, d) in hierarchy.dipoles().iter().enumerate() {
                    let f = if near {
                        d.triangle_integral(*corners, r.centre, r.normal, geometry, rule)
                    } else {
                        triangle_rule7(&|x| point_kernel(d, x, r.centre, r.normal, geometry), *corners)
                    };
                    b[c] += f * e[c];
                }
            }
            b
        })
        .collect();
    Ok(match hierarchy.options.receivers {
        Receivers::Vertices => at_receivers,
        Receivers::FaceCentroids => face_to_vertex(positions, triangles, &at_receivers),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed-form moments against the 7-point rule, exact for these cubic integrands.
    #[test]
    fn a_triangles_expansion_equals_its_moments_by_quadrature() {
        let corners = [DVec3::new(0.3, -0.2, 1.0), DVec3::new(2.1, 0.4, 0.7), DVec3::new(0.9, 1.8, -0.5)];
        let centre = (corners[0] + corners[1] + corners[2]) / 3.0;
        let area = 0.5 * (corners[1] - corners[0]).cross(corners[2] - corners[0]).length();
        let e = [[1.0, 0.2, 3.0], [2.5, 0.0, 0.7], [0.4, 1.1, 0.9]];
        let (flux, moment, second) = leaf_expansion(area, corners.map(|x| x - centre), e);
        for c in 0..3 {
            // E(x) linear: its barycentric coordinates from the plane's affine frame.
            let irradiance = |x: DVec3| {
                let (u, v) = (corners[1] - corners[0], corners[2] - corners[0]);
                let w = x - corners[0];
                let (uu, uv, vv, wu, wv) = (u.dot(u), u.dot(v), v.dot(v), w.dot(u), w.dot(v));
                let det = uu * vv - uv * uv;
                let (l1, l2) = ((vv * wu - uv * wv) / det, (uu * wv - uv * wu) / det);
                e[0][c] * (1.0 - l1 - l2) + e[1][c] * l1 + e[2][c] * l2
            };
            let want_flux = triangle_rule7(&irradiance, corners);
            let want_moment = triangle_rule7(&|x: DVec3| (x - centre) * irradiance(x), corners);
            let want_second = triangle_rule7(&|x: DVec3| outer(x - centre, x - centre) * irradiance(x), corners);
            assert!((flux[c] - want_flux).abs() < 1e-12, "{c}: {} {want_flux}", flux[c]);
            assert!((moment[c] - want_moment).length() < 1e-12, "{c}: {} {want_moment}", moment[c]);
            assert!(second[c].abs_diff_eq(want_second, 1e-12), "{c}: {} {want_second}", second[c]);
        }
    }
}
