// The compressed transfer's product (R. Wang et al. 2008 eqs. 7–8; design/prt.md §4 "GPU"): per
// receiver vertex v, basis function k and channel c,
//   gathered[(v K + k) 3 + c] = step[v K + k] · Σ_terms value(term) · q_haar[index(term)][c]
// over the row's entries (core::prt::Transfer, decoded on upload by gpu::prt: per entry its sample
// index, and its signed 16-bit quantised value, two to a word, an escape's 0). Four vertices per workgroup, 64
// invocations per vertex striding over each of its rows in turn, the row's partial sums reduced
// over those 64 in `tree` (common.wgsl). CPU twin: prt::Transfer::apply (the same f32 products,
// summed in another order).

struct PrtParams {
    vertices: u32,        // receiver vertices V
    rows_per_vertex: u32, // basis functions K
    samples: u32,         // irradiance samples N
    outputs: u32,         // output vertices (prt_combine.wgsl)
}

// Invocations per vertex: WG / LANES vertices per workgroup.
const LANES: u32 = 64u;

@group(0) @binding(0) var<uniform> prt: PrtParams;
@group(0) @binding(1) var<storage, read> row_start: array<u32>;
@group(0) @binding(2) var<storage, read> indices: array<u32>;
@group(0) @binding(3) var<storage, read> values: array<u32>;
@group(0) @binding(4) var<storage, read> steps: array<f32>;
@group(0) @binding(5) var<storage, read> q_haar: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> gathered: array<f32>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let v = flat_group(wg, nwg) * (WG / LANES) + lid / LANES;
    let lane = lid % LANES;
    let last = prt.samples - 1u;
    // Every invocation runs every row's reduction (uniform control flow for the barriers);
    // those past the last vertex add nothing.
    for (var k = 0u; k < prt.rows_per_vertex; k = k + 1u) {
        let row = v * prt.rows_per_vertex + k;
        var acc = vec4<f32>(0.0);
        if (v < prt.vertices) {
            let end = row_start[row + 1u];
            for (var t = row_start[row] + lane; t < end; t = t + LANES) {
                // Entry t's half of its word, shifted to the top, then arithmetically back.
                let half = values[t >> 1u] << (16u - 16u * (t & 1u));
                let value = f32(bitcast<i32>(half) >> 16u);
                acc = acc + value * q_haar[min(indices[t], last)];
            }
        }
        tree[lid] = acc;
        workgroupBarrier();
        for (var stride = LANES / 2u; stride > 0u; stride = stride / 2u) {
            if (lane < stride) {
                tree[lid] = tree[lid] + tree[lid + stride];
            }
            workgroupBarrier();
        }
        if (lane == 0u && v < prt.vertices) {
            let sum = tree[lid] * steps[row];
            gathered[3u * row] = sum.x;
            gathered[3u * row + 1u] = sum.y;
            gathered[3u * row + 2u] = sum.z;
        }
    }
}
