// One weighted Jacobi sweep of the polygrid diffusion's relaxation (J. Wang et al. 2008 §5.2),
// one invocation per row: x' = x + ω (b − A x) / a_ii per channel, (A x)_i summed in column
// order, from x into a second buffer (the rows around read x, so it is not updated in place;
// the host alternates the two). A frozen row (diag.w = 0) is copied unchanged.
// CPU twin: sparse::relax::jacobi_sweep.

struct Relax {
    n: u32,      // rows
    offset: u32, // unused here (relax_gs.wgsl: the colour's first entry of the row list)
    omega: f32,  // the damping ω
    pad: u32,
}

@group(0) @binding(0) var<uniform> relax: Relax;
@group(0) @binding(1) var<storage, read> row_ptr: array<u32>;
@group(0) @binding(2) var<storage, read> col_idx: array<u32>;
@group(0) @binding(3) var<storage, read> vals: array<f32>;
@group(0) @binding(4) var<storage, read> b: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> diag: array<vec4<f32>>; // xyz: a_ii; w: 1 active, 0 frozen
@group(0) @binding(6) var<storage, read> x: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> x_out: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = flat_index(wg, nwg, lid);
    if (i >= relax.n) {
        return;
    }
    let d = diag[i];
    if (d.w == 0.0) {
        x_out[i] = x[i];
        return;
    }
    var acc = vec3<f32>(0.0);
    let end = row_ptr[i + 1u];
    for (var k = row_ptr[i]; k < end; k = k + 1u) {
        let a = vec3<f32>(vals[3u * k], vals[3u * k + 1u], vals[3u * k + 2u]);
        acc = acc + a * x[col_idx[k]].xyz;
    }
    x_out[i] = vec4<f32>(x[i].xyz + relax.omega * (b[i].xyz - acc) / d.xyz, 0.0);
}
