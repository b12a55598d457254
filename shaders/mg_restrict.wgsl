// Multigrid restriction r_c = Pᵀ r_f, P the interpolation of TransCut eq. 16 (rows sum to 1,
// weights λ_ij/λ_i shared by the three channels), stored transposed as CSR (one row per coarse
// vertex: the fine rows that interpolate from it and their weights, rows increasing), one
// invocation per coarse vertex: a gather, no atomics, a fixed summation order.
// CPU twin: Prolongation::restrict of sparse::hierarchy.

@group(0) @binding(0) var<uniform> params: Params; // n = coarse vertices
@group(0) @binding(1) var<storage, read> t_ptr: array<u32>;
@group(0) @binding(2) var<storage, read> t_rows: array<u32>;
@group(0) @binding(3) var<storage, read> t_weights: array<f32>;
@group(0) @binding(4) var<storage, read> fine: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> coarse: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let c = flat_index(wg, nwg, lid);
    if (c >= params.n) {
        return;
    }
    var acc = vec3<f32>(0.0);
    let end = t_ptr[c + 1u];
    for (var k = t_ptr[c]; k < end; k = k + 1u) {
        acc = acc + t_weights[k] * fine[t_rows[k]].xyz;
    }
    coarse[c] = vec4<f32>(acc, 0.0);
}
