// The exact solve at the coarsest multigrid level, z = A_c⁻¹ r: a dense product with the inverse
// of the coarsest Galerkin operator, computed once per matrix on the host in f64 from its
// Cholesky factor (the map the CPU applies by forward and back substitution) and stored row-major
// with three f32 per entry. One workgroup per row: strided loads over the columns, then the
// workgroup tree reduction — every row in parallel, where a triangular solve would be 2 n_c
// dependent steps in a single workgroup. CPU twin: the Cholesky solve of Multigrid::cycle.

@group(0) @binding(0) var<uniform> params: Params; // n = coarsest vertices
@group(0) @binding(1) var<storage, read> inverse: array<f32>;
@group(0) @binding(2) var<storage, read> r: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> z: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let row = flat_group(wg, nwg);
    let n = params.n;
    var acc = vec4<f32>(0.0);
    if (row < n) {
        for (var j = lid; j < n; j = j + WG) {
            let k = 3u * (row * n + j);
            acc = acc + vec4<f32>(inverse[k], inverse[k + 1u], inverse[k + 2u], 0.0) * r[j];
        }
    }
    let total = workgroup_sum(lid, acc);
    if (lid == 0u && row < n) {
        z[row] = vec4<f32>(total.xyz, 0.0);
    }
}
