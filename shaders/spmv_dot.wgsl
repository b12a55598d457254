// q = A p for the three channels (CSR, one invocation per row), fused with the partial sums of
// pᵀq per workgroup (a tree reduction in workgroup memory); reduce_alpha finishes the sum.
// CPU twin: sparse::CsrMatrix3::spmv and sparse::dot3.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> row_ptr: array<u32>;
@group(0) @binding(2) var<storage, read> col_idx: array<u32>;
@group(0) @binding(3) var<storage, read> vals: array<f32>;
@group(0) @binding(4) var<storage, read> p: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> q: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> partials: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = flat_index(wg, nwg, lid);
    var part = vec4<f32>(0.0);
    if (i < params.n) {
        var acc = vec3<f32>(0.0);
        let end = row_ptr[i + 1u];
        for (var k = row_ptr[i]; k < end; k = k + 1u) {
            let a = vec3<f32>(vals[3u * k], vals[3u * k + 1u], vals[3u * k + 2u]);
            acc = acc + a * p[col_idx[k]].xyz;
        }
        let qi = vec4<f32>(acc, 0.0);
        q[i] = qi;
        part = p[i] * qi;
    }
    let total = workgroup_sum(lid, part);
    if (lid == 0u) {
        partials[flat_group(wg, nwg)] = total;
    }
}
