// Partial sums of aᵀb per channel, one per workgroup (tree reduction in workgroup memory);
// reduce_sum adds the partials. CPU twin: sparse::dot3.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> a: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> b: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> partials: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = flat_index(wg, nwg, lid);
    var part = vec4<f32>(0.0);
    if (i < params.n) {
        part = a[i] * b[i];
    }
    let total = workgroup_sum(lid, part);
    if (lid == 0u) {
        partials[flat_group(wg, nwg)] = total;
    }
}
