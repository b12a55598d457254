// Jacobi scaling factors S = D^-½ from the assembled matrix: s_i = 1/√M_ii per channel (0 where
// M_ii is not positive: the solve then fails its f64 residual check instead of dividing by 0).
// CPU twin: sparse::precond::inverse_diagonal (its square root).

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> row_ptr: array<u32>;
@group(0) @binding(2) var<storage, read> col_idx: array<u32>;
@group(0) @binding(3) var<storage, read> vals: array<f32>;
@group(0) @binding(4) var<storage, read_write> sdiag: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = flat_index(wg, nwg, lid);
    if (i >= params.n) {
        return;
    }
    var d = vec3<f32>(0.0);
    let end = row_ptr[i + 1u];
    for (var k = row_ptr[i]; k < end; k = k + 1u) {
        if (col_idx[k] == i) {
            d = vec3<f32>(vals[3u * k], vals[3u * k + 1u], vals[3u * k + 2u]);
        }
    }
    let positive = d > vec3<f32>(0.0);
    sdiag[i] = vec4<f32>(select(vec3<f32>(0.0), inverseSqrt(d), positive), 0.0);
}
