// The exact solve at the coarsest multigrid level, z = A_c⁻¹ r: a dense product with the inverse
// of the coarsest Galerkin operator, computed once per matrix on the host in f64 from its
// Cholesky factor (the map the CPU applies by forward and back substitution), exactly symmetric,
// stored with three f32 per entry. One invocation per row i, every row in parallel with no
// barrier (a triangular solve would be 2 n_c dependent steps in a single workgroup); by symmetry
// row i is read as column i (entry (j, i) at step j), so neighbouring invocations read
// neighbouring entries. CPU twin: the Cholesky solve of Multigrid::cycle.

@group(0) @binding(0) var<uniform> params: Params; // n = coarsest vertices
@group(0) @binding(1) var<storage, read> inverse: array<f32>;
@group(0) @binding(2) var<storage, read> r: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> z: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = flat_index(wg, nwg, lid);
    let n = params.n;
    if (i >= n) {
        return;
    }
    var acc = vec3<f32>(0.0);
    for (var j = 0u; j < n; j = j + 1u) {
        let k = 3u * (j * n + i);
        acc = acc + vec3<f32>(inverse[k], inverse[k + 1u], inverse[k + 2u]) * r[j].xyz;
    }
    z[i] = vec4<f32>(acc, 0.0);
}
