// Shared declarations of the libtranscut compute kernels (prepended to every kernel by
// core::gpu::shaders). Vectors hold the three colour channels in .xyz of a vec4<f32> (w unused);
// matrix values hold three f32 per nonzero (r, g, b), in the order of the CSR pattern.

const WG: u32 = 256u;

// Sizes of the problem, one uniform for every kernel.
struct Params {
    n: u32,           // rows (vertices)
    nnz: u32,         // nonzeros of the pattern
    n_tets: u32,
    n_boundary: u32,
    n_groups: u32,    // workgroups of a row kernel = partial sums written by it
    pad0: u32,
    pad1: u32,
    pad2: u32,
    rad_phi: f32,     // Ft(n)/(4π)·(1 + 1/A): TransCut eq. 3, coefficient of φ
    rad_q: f32,       // Ft(n)/(4π)·4/(1 + Fdr): coefficient of q
    pad3: f32,
    pad4: f32,
}

// The per-channel scalars of the device-side PCG (xyz = channels).
struct Scalars {
    rho: vec4<f32>,        // r̂ᵀr̂ of the current residual (scaled system)
    alpha: vec4<f32>,
    beta: vec4<f32>,
    rr: vec4<f32>,         // ‖r‖² of the unscaled residual r = D^½ r̂
    tol2: vec4<f32>,       // a channel is active while rr > tol2
    running: vec4<f32>,    // 1 while the channel iterates, 0 once converged
    iterations: vec4<u32>, // iterations per channel
    breakdown: vec4<u32>,  // 1 where pᵀÂp ≤ 0 or not finite
}

// Flattened invocation index of a 1D problem dispatched on a 2D grid of workgroups (a grid
// dimension is limited to 65535 workgroups).
fn flat_index(wg: vec3<u32>, nwg: vec3<u32>, lid: u32) -> u32 {
    return (wg.y * nwg.x + wg.x) * WG + lid;
}

fn flat_group(wg: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return wg.y * nwg.x + wg.x;
}

var<workgroup> tree: array<vec4<f32>, WG>;

// Tree reduction over the workgroup: every invocation passes its value, all receive the sum.
// Must be called in uniform control flow by every invocation of the workgroup.
fn workgroup_sum(lid: u32, v: vec4<f32>) -> vec4<f32> {
    tree[lid] = v;
    workgroupBarrier();
    for (var stride = WG / 2u; stride > 0u; stride = stride / 2u) {
        if (lid < stride) {
            tree[lid] = tree[lid] + tree[lid + stride];
        }
        workgroupBarrier();
    }
    let s = tree[0];
    workgroupBarrier();
    return s;
}
