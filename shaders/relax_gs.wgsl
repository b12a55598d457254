// One colour of a coloured Gauss–Seidel sweep of the polygrid diffusion's relaxation
// (J. Wang et al. 2008 §5.2), one invocation per active row of the colour (rows[offset ..
// offset + n], frozen rows left out by the host): x_i = (b_i − Σ_{j≠i} a_ij x_j) / a_ii per
// channel, the sum in column order, in place. No two rows of one colour are coupled, so a row
// reads only rows of other colours, which this dispatch does not write; the host dispatches the
// colours in order (and back again for a symmetric sweep).
// CPU twin: sparse::relax::coloured_gauss_seidel_sweep.

struct Relax {
    n: u32,      // active rows of the colour
    offset: u32, // the colour's first entry in rows
    omega: f32,  // unused here (relax_jacobi.wgsl: the damping)
    pad: u32,
}

@group(0) @binding(0) var<uniform> relax: Relax;
@group(0) @binding(1) var<storage, read> row_ptr: array<u32>;
@group(0) @binding(2) var<storage, read> col_idx: array<u32>;
@group(0) @binding(3) var<storage, read> vals: array<f32>;
@group(0) @binding(4) var<storage, read> b: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> diag: array<vec4<f32>>; // xyz: a_ii
@group(0) @binding(6) var<storage, read> rows: array<u32>;
@group(0) @binding(7) var<storage, read_write> x: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let t = flat_index(wg, nwg, lid);
    if (t >= relax.n) {
        return;
    }
    let i = rows[relax.offset + t];
    var acc = vec3<f32>(0.0);
    let end = row_ptr[i + 1u];
    for (var k = row_ptr[i]; k < end; k = k + 1u) {
        let j = col_idx[k];
        if (j != i) {
            let a = vec3<f32>(vals[3u * k], vals[3u * k + 1u], vals[3u * k + 2u]);
            acc = acc + a * x[j].xyz;
        }
    }
    x[i] = vec4<f32>((b[i].xyz - acc) / diag[i].xyz, 0.0);
}
