// PCG search direction on the scaled system: p = r̂ + β p (Jacobi preconditioning is the
// diagonal scaling, so z = r̂). CPU twin: p_update_jacobi of sparse::pcg.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> s: Scalars;
@group(0) @binding(2) var<storage, read> r: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> p: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = flat_index(wg, nwg, lid);
    if (i >= params.n) {
        return;
    }
    p[i] = r[i] + s.beta * p[i];
}
