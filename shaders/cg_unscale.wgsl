// The correction of a scaled solve, d = S y (S = D^-½), for read-back.
// CPU twin: x = S ŷ at the end of sparse::pcg (mixed).

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> sdiag: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> y: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> out: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = flat_index(wg, nwg, lid);
    if (i >= params.n) {
        return;
    }
    out[i] = sdiag[i] * y[i];
}
