// PCG update on the Jacobi-scaled system Â = D^-½ A D^-½: y += α p, r̂ −= α q (q = Â p), fused
// with the per-workgroup partial sums of r̂ᵀr̂ (for β) and of ‖r‖² = Σ D r̂² (the unscaled
// residual, for the stopping test); reduce_beta finishes them. CPU twin: sparse::pcg (mixed).

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> s: Scalars;
@group(0) @binding(2) var<storage, read_write> y: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> r: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> p: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> q: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> sdiag: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> partials: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = flat_index(wg, nwg, lid);
    var scaled = vec4<f32>(0.0);
    var unscaled = vec4<f32>(0.0);
    if (i < params.n) {
        let alpha = s.alpha;
        y[i] = y[i] + alpha * p[i];
        let ri = r[i] - alpha * q[i];
        r[i] = ri;
        scaled = ri * ri;
        let sd = sdiag[i];
        unscaled = vec4<f32>(scaled.xyz / (sd.xyz * sd.xyz), 0.0);
    }
    let a = workgroup_sum(lid, scaled);
    let b = workgroup_sum(lid, unscaled);
    if (lid == 0u) {
        let g = flat_group(wg, nwg);
        partials[2u * g] = a;
        partials[2u * g + 1u] = b;
    }
}
