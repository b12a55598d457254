// Multigrid coarse-grid correction x_f += P e_c, P the interpolation of TransCut eq. 16
// (φ^l(x_i) = φ^{l+1}(x_i) for a retained vertex, Σ_{j∈R(i)} λ_ij φ^{l+1}(x_j)/λ_i otherwise,
// λ_ij = 1/|x_i − x_j|), stored as CSR with one f32 weight per nonzero shared by the three
// channels, one invocation per fine vertex. CPU twin: Prolongation::prolong_add.

@group(0) @binding(0) var<uniform> params: Params; // n = fine vertices
@group(0) @binding(1) var<storage, read> p_ptr: array<u32>;
@group(0) @binding(2) var<storage, read> p_cols: array<u32>;
@group(0) @binding(3) var<storage, read> p_weights: array<f32>;
@group(0) @binding(4) var<storage, read> coarse: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> fine: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = flat_index(wg, nwg, lid);
    if (i >= params.n) {
        return;
    }
    var acc = vec3<f32>(0.0);
    let end = p_ptr[i + 1u];
    for (var k = p_ptr[i]; k < end; k = k + 1u) {
        acc = acc + p_weights[k] * coarse[p_cols[k]].xyz;
    }
    fine[i] = fine[i] + vec4<f32>(acc, 0.0);
}
