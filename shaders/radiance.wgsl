// TransCut eq. 3 along the normal, the per-vertex value a bake returns:
// Lo(x, n) = Ft(n)/(4π) · [(1 + 1/A) φ(x) − 4q(x)/(1 + Fdr)] = rad_phi φ − rad_q q,
// one invocation per boundary vertex. CPU twin: diffusion::surface_radiance.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> ids: array<u32>;
@group(0) @binding(2) var<storage, read> phi: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> q: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> out: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let k = flat_index(wg, nwg, lid);
    if (k >= params.n_boundary) {
        return;
    }
    out[k] = params.rad_phi * phi[ids[k]] - params.rad_q * q[k];
}
