// The Jacobi-scaled matrix Â_ij = s_i A_ij s_j (S = D^-½), on which CG with the identity is
// Jacobi-preconditioned CG on A (diagonal of Â = 1). CPU twin: sparse::scaled::ScaledOperator.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> row_ptr: array<u32>;
@group(0) @binding(2) var<storage, read> col_idx: array<u32>;
@group(0) @binding(3) var<storage, read> vals: array<f32>;
@group(0) @binding(4) var<storage, read> sdiag: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> scaled: array<f32>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = flat_index(wg, nwg, lid);
    if (i >= params.n) {
        return;
    }
    let si = sdiag[i].xyz;
    let end = row_ptr[i + 1u];
    for (var k = row_ptr[i]; k < end; k = k + 1u) {
        let a = vec3<f32>(vals[3u * k], vals[3u * k + 1u], vals[3u * k + 2u]);
        let v = si * a * sdiag[col_idx[k]].xyz;
        scaled[3u * k] = v.x;
        scaled[3u * k + 1u] = v.y;
        scaled[3u * k + 2u] = v.z;
    }
}
