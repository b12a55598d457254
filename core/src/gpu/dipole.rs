//! The hierarchical dipole on the device (Mertens et al. 2003; `shaders/dipole_*.wgsl`): the
//! trees refitted to moved vertices level by level (`dipole_refit.wgsl`), the irradiance pulled
//! up the emitter tree (`dipole_pull.wgsl`), one dual-tree traversal per receiver subtree
//! gathering as it links (`dipole_traverse.wgsl`: the on-the-fly mode) and the local expansions
//! pushed down (`dipole_push.wgsl`), all in f32.
//!
//! [`GpuDipole`] evaluates the trees, oracle, subtrees and options of a
//! [`DipoleHierarchy`]: its CPU twin is that hierarchy's [`DipoleHierarchy::update`] in
//! [`EvalMode::OnTheFly`](crate::hierarchy::EvalMode::OnTheFly) after the same
//! [`DipoleHierarchy::set_positions`]. The trees are only refitted on the device, never rebuilt:
//! the bounds stay valid under any motion (the oracle stays conservative), a tree degraded by
//! large motion only makes more links; build a new [`GpuDipole`] from a rebuilt hierarchy to
//! restore it. The distance geometry only (the paper's source geometry is refused).

use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use glam::DVec3;

use super::context::{dispatch, GpuContext};
use super::error::GpuError;
use super::layout::{from_vec4, to_vec4};
use super::pool::Lease;
use super::shaders::Kernel;
use crate::hierarchy::integrator::{check_irradiance, check_positions, face_to_vertex};
use crate::hierarchy::tree::{ClusterNode, ClusterTree};
use crate::hierarchy::{DipoleHierarchy, HierarchyError, Oracle, Receivers};
use crate::optics::{DipoleGeometry, EdgeRule};
use crate::progress::ms;

/// The receiver subtrees [`GpuDipole::for_device`] cuts the receivers into: one per this many
/// receiving points, each one invocation of the traversal.
pub const RECEIVERS_PER_TASK: usize = 8;

/// The traversal's stack (`STACK` in `dipole_traverse.wgsl`).
const STACK: usize = 64;

/// Vec4 slots per node of the flux and local expansions (`SLOTS` in `dipole_common.wgsl`).
const SLOTS: u64 = 10;

/// `DipoleParams` of `dipole_common.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, Pod, Zeroable)]
struct DipoleParams {
    n_vertices: u32,
    n_triangles: u32,
    n_tasks: u32,
    level_start: u32,
    level_end: u32,
    item_kind: u32,
    oracle: u32,
    rule: u32,
    sigma_rule: u32,
    pad: [u32; 3],
    theta: f32,
    eps1: f32,
    eps2: f32,
    near_angle: f32,
    max_l_over_r: f32,
    pad_f: [f32; 3],
    sigma_tr: [f32; 4],
    z_r: [f32; 4],
    z_v: [f32; 4],
    scale: [f32; 4],
}

/// `Node` of `dipole_common.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, Pod, Zeroable)]
struct GpuNode {
    centre: [f32; 3],
    radius: f32,
    normal: [f32; 3],
    weight: f32,
    right_or_item: u32,
    leaf: u32,
    end: u32,
    pad: u32,
}

/// What one device update measured.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct GpuDipoleStats {
    /// Links made by the traversal (far + near).
    pub links: usize,
    /// Of them, leaf pairs with a form factor over the triangle.
    pub near_links: usize,
    /// Receiver subtrees, one invocation each.
    pub tasks: usize,
    /// Uploading the positions and refitting both trees (the last [`GpuDipole::set_positions`]).
    pub refit_ms: f64,
    /// Uploading the irradiance and pulling it up the emitter tree.
    pub pull_ms: f64,
    /// The traversal with its form factors.
    pub traverse_ms: f64,
    /// Pushing down the receiver tree and reading B back.
    pub push_ms: f64,
}

/// One tree on the device: its nodes and the order its levels are refitted in.
struct DeviceTree<'c> {
    nodes: Lease<'c>,
    /// Node indices, deepest level first.
    order: Lease<'c>,
    /// Per level, bottom-up, its range of `order`.
    levels: Vec<(u32, u32)>,
    len: usize,
    /// The deepest node's depth below the root.
    depth: usize,
}

impl<'c> DeviceTree<'c> {
    fn upload(ctx: &'c GpuContext, tree: &ClusterTree, label: &'static str) -> Result<Self, GpuError> {
        let nodes = tree.nodes();
        let mut depth = vec![0usize; nodes.len()];
        for (i, n) in nodes.iter().enumerate() {
            if let Some(children) = n.children(i as u32) {
                for c in children {
                    depth[c as usize] = depth[i] + 1;
                }
            }
        }
        let deepest = depth.iter().copied().max().unwrap_or(0);
        let mut order: Vec<u32> = (0..nodes.len() as u32).collect();
        order.sort_by_key(|&i| std::cmp::Reverse(depth[i as usize]));
        let mut levels = Vec::with_capacity(deepest + 1);
        let mut start = 0;
        while start < order.len() {
            let d = depth[order[start] as usize];
            let end = start + order[start..].iter().take_while(|&&i| depth[i as usize] == d).count();
            levels.push((start as u32, end as u32));
            start = end;
        }
        let gpu: Vec<GpuNode> = nodes.iter().enumerate().map(|(i, n)| to_gpu(n, tree.subtree_end(i as u32))).collect();
        Ok(Self {
            nodes: ctx.upload(&gpu, label)?,
            order: ctx.upload(&order, "dipole level order")?,
            levels,
            len: nodes.len(),
            depth: deepest,
        })
    }
}

fn to_gpu(n: &ClusterNode, end: u32) -> GpuNode {
    GpuNode {
        centre: n.centre.as_vec3().to_array(),
        radius: n.radius as f32,
        normal: n.normal.as_vec3().to_array(),
        weight: n.weight as f32,
        right_or_item: n.right_or_item,
        leaf: u32::from(n.leaf),
        end,
        pad: 0,
    }
}

/// The hierarchical dipole of one [`DipoleHierarchy`] on a device (module documentation).
pub struct GpuDipole<'c> {
    ctx: &'c GpuContext,
    params: DipoleParams,
    receivers: Receivers,
    triangles: Vec<[u32; 3]>,
    positions: Vec<DVec3>,
    emitters: DeviceTree<'c>,
    receiver_tree: DeviceTree<'c>,
    receiver_items: usize,
    tasks: Lease<'c>,
    n_tasks: usize,
    positions_buf: Lease<'c>,
    triangles_buf: Lease<'c>,
    irradiance: Lease<'c>,
    emitted: Lease<'c>,
    local: Lease<'c>,
    out: Lease<'c>,
    links: Lease<'c>,
    refit_ms: f64,
}

impl std::fmt::Debug for GpuDipole<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuDipole")
            .field("device", &self.ctx.device_name())
            .field("triangles", &self.triangles.len())
            .field("tasks", &self.n_tasks)
            .finish()
    }
}

impl<'c> GpuDipole<'c> {
    /// Cuts `hierarchy`'s receivers into one subtree per [`RECEIVERS_PER_TASK`] points
    /// ([`DipoleHierarchy::set_tasks`]; the traversal's parallelism on the device) and uploads
    /// it: the GPU evaluation of the same hierarchy [`DipoleHierarchy::update`] then twins.
    ///
    /// # Errors
    /// As [`GpuDipole::new`].
    pub fn for_device(ctx: &'c GpuContext, hierarchy: &mut DipoleHierarchy) -> Result<Self, GpuError> {
        hierarchy.set_tasks(hierarchy.receiver_tree().item_count().div_ceil(RECEIVERS_PER_TASK));
        Self::new(ctx, hierarchy)
    }

    /// Uploads `hierarchy` (its trees, subtrees, surface, media and options) to the device.
    ///
    /// # Errors
    /// [`GpuError::Unsupported`] for the paper's source geometry; [`GpuError::TooLarge`] when the
    /// trees are deeper than the traversal's stack or a buffer exceeds the device's limits.
    pub fn new(ctx: &'c GpuContext, hierarchy: &DipoleHierarchy) -> Result<Self, GpuError> {
        let options = hierarchy.options();
        if options.geometry != DipoleGeometry::Distance {
            return Err(GpuError::Unsupported {
                what: "the hierarchical dipole's paper source geometry (DipoleGeometry::PaperSources) on the GPU",
            });
        }
        let (emitter_tree, receiver_tree) = (hierarchy.emitter_tree(), hierarchy.receiver_tree());
        let roots = hierarchy.task_roots();
        let tasks: Vec<[u32; 2]> = roots.iter().map(|&r| [r, receiver_tree.subtree_end(r)]).collect();
        let emitters = DeviceTree::upload(ctx, emitter_tree, "dipole emitter nodes")?;
        let receivers = DeviceTree::upload(ctx, receiver_tree, "dipole receiver nodes")?;
        // A task's stack holds at most 1 + its subtree's depth + the emitter tree's depth pairs.
        let task_depth = receivers.depth.saturating_sub(roots.iter().map(|&r| depth_of(receiver_tree, r)).min().unwrap_or(0));
        let needed = 1 + task_depth + emitters.depth;
        if needed > STACK {
            return Err(GpuError::TooLarge {
                what: "cluster tree depth (pairs on the traversal's stack)",
                needed: needed as u64,
                limit: STACK as u64,
                device: ctx.device_name().to_owned(),
            });
        }
        let dipoles = hierarchy.dipoles();
        let channel = |f: &dyn Fn(usize) -> f64| [f(0) as f32, f(1) as f32, f(2) as f32, 0.0];
        let (oracle, theta, eps1, eps2) = match options.oracle {
            Oracle::OpeningAngle { theta } => (0, theta, 0.0, 0.0),
            Oracle::Paper { eps1, eps2 } => (1, 0.0, eps1, eps2),
        };
        let (rule, sigma_rule) = match options.rule {
            EdgeRule::GaussLegendre3 { .. } => (0, 0),
            EdgeRule::PaperMidpoint { sigma_rule, .. } => (1, u32::from(sigma_rule)),
        };
        let positions = hierarchy.positions().to_vec();
        let triangles = hierarchy.triangles().to_vec();
        let params = DipoleParams {
            n_vertices: positions.len() as u32,
            n_triangles: triangles.len() as u32,
            n_tasks: tasks.len() as u32,
            oracle,
            rule,
            sigma_rule,
            theta: theta as f32,
            eps1: eps1 as f32,
            eps2: eps2 as f32,
            near_angle: options.oracle.rule7_below() as f32,
            max_l_over_r: options.rule.max_l_over_r() as f32,
            sigma_tr: channel(&|c| dipoles[c].sigma_tr),
            z_r: channel(&|c| dipoles[c].z_r),
            z_v: channel(&|c| dipoles[c].z_v),
            scale: channel(&|c| dipoles[c].alpha_prime / (4.0 * std::f64::consts::PI)),
            ..DipoleParams::default()
        };
        let receiver_items = receiver_tree.item_count();
        let gpu_triangles: Vec<[u32; 4]> = triangles.iter().map(|t| [t[0], t[1], t[2], 0]).collect();
        Ok(Self {
            ctx,
            params,
            receivers: options.receivers,
            positions_buf: ctx.upload(&to_vec4_points(&positions), "dipole positions")?,
            triangles_buf: ctx.upload(&gpu_triangles, "dipole triangles")?,
            irradiance: ctx.storage(16 * positions.len() as u64, "dipole irradiance")?,
            emitted: ctx.storage(16 * SLOTS * emitters.len as u64, "dipole flux expansions")?,
            local: ctx.storage(16 * SLOTS * receivers.len as u64, "dipole local expansions")?,
            out: ctx.storage(16 * receiver_items as u64, "dipole exitance")?,
            links: ctx.storage(8, "dipole link counts")?,
            tasks: ctx.upload(&tasks, "dipole tasks")?,
            n_tasks: tasks.len(),
            receiver_items,
            emitters,
            receiver_tree: receivers,
            triangles,
            positions,
            refit_ms: 0.0,
        })
    }

    /// The device's name.
    #[must_use]
    pub fn device_name(&self) -> &str {
        self.ctx.device_name()
    }

    /// The device it runs on.
    #[must_use]
    pub fn context(&self) -> &'c GpuContext {
        self.ctx
    }

    /// The vertex positions (mm) its trees are fitted to.
    #[must_use]
    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    /// Moves the vertices (same count and order) and refits both trees on the device
    /// (`dipole_refit.wgsl`, one dispatch per level, bottom-up). CPU twin:
    /// [`DipoleHierarchy::set_positions`] without its rebuild.
    ///
    /// # Errors
    /// [`HierarchyError::WrongLength`] or [`HierarchyError::NonFinite`] (as
    /// [`GpuError::Hierarchy`]), nothing changed; device errors.
    pub fn set_positions(&mut self, positions: &[DVec3]) -> Result<(), GpuError> {
        if positions.len() != self.positions.len() {
            return Err(
                HierarchyError::WrongLength { what: "positions", expected: self.positions.len(), got: positions.len() }.into()
            );
        }
        check_positions(positions)?;
        let start = Instant::now();
        self.ctx.queue().write_buffer(&self.positions_buf, 0, bytemuck::cast_slice(&to_vec4_points(positions)));
        let kind = match self.receivers {
            Receivers::Vertices => 1,
            Receivers::FaceCentroids => 2,
        };
        let mut encoder = self.ctx.encoder();
        let mut uniforms = Vec::new();
        for (tree, item_kind) in [(&self.emitters, 0), (&self.receiver_tree, kind)] {
            for &(level_start, level_end) in &tree.levels {
                let params = DipoleParams { level_start, level_end, item_kind, ..self.params };
                uniforms.push((self.ctx.uniform(&params, "dipole refit params"), tree, level_end - level_start));
            }
        }
        {
            let mut pass =
                encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("dipole refit"), timestamp_writes: None });
            for (params, tree, count) in &uniforms {
                let bind = self
                    .ctx
                    .bind(Kernel::DipoleRefit, &[params, &tree.order, &tree.nodes, &self.positions_buf, &self.triangles_buf]);
                let (gx, gy, _) = self.ctx.grid(*count as usize)?;
                dispatch(&mut pass, self.ctx, Kernel::DipoleRefit, &bind, (gx, gy));
            }
        }
        self.ctx.submit_wait(encoder, "dipole refit")?;
        self.positions.copy_from_slice(positions);
        self.refit_ms = ms(start);
        Ok(())
    }

    /// The exitance B per vertex under `irradiance` per vertex (≥ 0, entering along
    /// [`DipoleHierarchy::vertex_normals`]): pull, traversal and push on the device, in f32.
    ///
    /// # Errors
    /// [`HierarchyError::WrongLength`] or [`HierarchyError::InvalidIrradiance`] (as
    /// [`GpuError::Hierarchy`]); device errors.
    pub fn update(&mut self, irradiance: &[[f64; 3]]) -> Result<(Vec<[f64; 3]>, GpuDipoleStats), GpuError> {
        check_irradiance(irradiance, self.positions.len())?;
        let ctx = self.ctx;
        let mut stats =
            GpuDipoleStats { tasks: self.n_tasks, refit_ms: std::mem::take(&mut self.refit_ms), ..Default::default() };

        let t = Instant::now();
        ctx.queue().write_buffer(&self.irradiance, 0, bytemuck::cast_slice(&to_vec4(irradiance)));
        ctx.queue().write_buffer(&self.links, 0, bytemuck::cast_slice(&[0u32, 0]));
        let uniforms: Vec<_> = self
            .emitters
            .levels
            .iter()
            .map(|&(level_start, level_end)| {
                (
                    ctx.uniform(&DipoleParams { level_start, level_end, ..self.params }, "dipole pull params"),
                    level_end - level_start,
                )
            })
            .collect();
        let mut encoder = ctx.encoder();
        {
            let mut pass =
                encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("dipole pull"), timestamp_writes: None });
            for (params, count) in &uniforms {
                let bind = ctx.bind(
                    Kernel::DipolePull,
                    &[
                        params,
                        &self.emitters.order,
                        &self.emitters.nodes,
                        &self.positions_buf,
                        &self.triangles_buf,
                        &self.irradiance,
                        &self.emitted,
                    ],
                );
                let (gx, gy, _) = ctx.grid(*count as usize)?;
                dispatch(&mut pass, ctx, Kernel::DipolePull, &bind, (gx, gy));
            }
        }
        ctx.submit_wait(encoder, "dipole pull")?;
        stats.pull_ms = ms(t);

        let t = Instant::now();
        let params = ctx.uniform(&self.params, "dipole params");
        let (gx, gy, _) = ctx.grid(self.n_tasks)?;
        let bind = ctx.bind(
            Kernel::DipoleTraverse,
            &[
                &params,
                &self.receiver_tree.nodes,
                &self.emitters.nodes,
                &self.tasks,
                &self.positions_buf,
                &self.triangles_buf,
                &self.emitted,
                &self.local,
                &self.links,
            ],
        );
        let mut encoder = ctx.encoder();
        {
            let mut pass = encoder
                .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("dipole traverse"), timestamp_writes: None });
            dispatch(&mut pass, ctx, Kernel::DipoleTraverse, &bind, (gx, gy));
        }
        let counts = ctx.read_back(encoder, &self.links, 8, "dipole traversal")?;
        let counts: &[u32] = bytemuck::cast_slice(&counts);
        (stats.links, stats.near_links) = (counts[0] as usize, counts[1] as usize);
        stats.traverse_ms = ms(t);

        let t = Instant::now();
        let bind = ctx.bind(Kernel::DipolePush, &[&params, &self.receiver_tree.nodes, &self.tasks, &self.local, &self.out]);
        let mut encoder = ctx.encoder();
        {
            let mut pass =
                encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("dipole push"), timestamp_writes: None });
            dispatch(&mut pass, ctx, Kernel::DipolePush, &bind, (gx, gy));
        }
        let bytes = ctx.read_back(encoder, &self.out, 16 * self.receiver_items as u64, "dipole push")?;
        let at_items = from_vec4(&bytes, self.receiver_items);
        let b = match self.receivers {
            Receivers::Vertices => at_items,
            Receivers::FaceCentroids => face_to_vertex(&self.positions, &self.triangles, &at_items),
        };
        stats.push_ms = ms(t);
        Ok((b, stats))
    }

    /// Both trees' nodes as the device holds them (emitters, receivers), for comparison with
    /// the CPU's refit.
    ///
    /// # Errors
    /// Device errors.
    pub fn trees(&self) -> Result<(Vec<ClusterNode>, Vec<ClusterNode>), GpuError> {
        let read = |tree: &DeviceTree<'_>| -> Result<Vec<ClusterNode>, GpuError> {
            let bytes = self.ctx.read_back(self.ctx.encoder(), &tree.nodes, 48 * tree.len as u64, "dipole tree read-back")?;
            let nodes: &[GpuNode] = bytemuck::cast_slice(&bytes);
            Ok(nodes
                .iter()
                .map(|n| ClusterNode {
                    centre: glam::Vec3::from(n.centre).as_dvec3(),
                    weight: f64::from(n.weight),
                    normal: glam::Vec3::from(n.normal).as_dvec3(),
                    radius: f64::from(n.radius),
                    right_or_item: n.right_or_item,
                    leaf: n.leaf == 1,
                })
                .collect())
        };
        Ok((read(&self.emitters)?, read(&self.receiver_tree)?))
    }
}

/// The depth of node `index` below the root.
fn depth_of(tree: &ClusterTree, index: u32) -> usize {
    let (mut at, mut depth) = (0u32, 0);
    while at != index {
        let [left, right] = tree.node(at).children(at).expect("index lies below an inner node");
        at = if index < right { left } else { right };
        depth += 1;
    }
    depth
}

fn to_vec4_points(points: &[DVec3]) -> Vec<[f32; 4]> {
    points.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32, 0.0]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn struct_sizes_match_the_wgsl_layouts() {
        // WGSL: DipoleParams 20 scalars + 4 vec4, Node 3 × 16 bytes.
        assert_eq!(size_of::<DipoleParams>(), 144);
        assert_eq!(size_of::<GpuNode>(), 48);
    }
}
