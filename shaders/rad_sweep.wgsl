// One Jacobi sweep of radiosity (Sheng et al. 2014 eq. 2; design/radiosity.md §1.6), one
// invocation per patch: the gathered irradiance E_i = Σ_j F_ij B_j over row i of the form
// factors (scalar CSR, f32 values, columns in order), and B'_i = ρ_i E_i + base_i with
// base = ρ ⊙ E_d + M. A translucent patch has ρ = base = 0 (its B' comes from its object's
// scattering of `gathered`, on the host). CPU twin: radiosity::FormFactors::apply and the
// opaque update of radiosity::solve_coupled.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> row_start: array<u32>;
@group(0) @binding(2) var<storage, read> columns: array<u32>;
@group(0) @binding(3) var<storage, read> values: array<f32>;
@group(0) @binding(4) var<storage, read> albedo: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> base: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> b_in: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> b_out: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> gathered: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = flat_index(wg, nwg, lid);
    if (i >= params.n) {
        return;
    }
    var e = vec4<f32>(0.0);
    for (var k = row_start[i]; k < row_start[i + 1u]; k = k + 1u) {
        e = e + values[k] * b_in[columns[k]];
    }
    gathered[i] = e;
    b_out[i] = albedo[i] * e + base[i];
}
