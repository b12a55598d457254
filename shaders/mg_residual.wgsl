// The residual of a multigrid level after pre-smoothing, res = r − A z (three channels, CSR, one
// invocation per row), which mg_restrict carries to the coarser level.
// CPU twin: residual of sparse::hierarchy::vcycle.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> row_ptr: array<u32>;
@group(0) @binding(2) var<storage, read> col_idx: array<u32>;
@group(0) @binding(3) var<storage, read> vals: array<f32>;
@group(0) @binding(4) var<storage, read> r: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> z: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> res: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = flat_index(wg, nwg, lid);
    if (i >= params.n) {
        return;
    }
    var acc = vec3<f32>(0.0);
    let end = row_ptr[i + 1u];
    for (var k = row_ptr[i]; k < end; k = k + 1u) {
        let a = vec3<f32>(vals[3u * k], vals[3u * k + 1u], vals[3u * k + 2u]);
        acc = acc + a * z[col_idx[k]].xyz;
    }
    res[i] = vec4<f32>(r[i].xyz - acc, 0.0);
}
