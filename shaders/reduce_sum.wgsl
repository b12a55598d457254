// Sum of the n_groups partial sums written by a row kernel (one workgroup: strided loads, then a
// tree reduction), into out[0]. CPU twin: sparse::ops::sum_partials.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> partials: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> out: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(local_invocation_index) lid: u32) {
    var acc = vec4<f32>(0.0);
    for (var k = lid; k < params.n_groups; k = k + WG) {
        acc = acc + partials[k];
    }
    let total = workgroup_sum(lid, acc);
    if (lid == 0u) {
        out[0] = total;
    }
}
