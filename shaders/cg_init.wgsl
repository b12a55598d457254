// Starts a PCG solve of A d = f on the scaled system (Jacobi preconditioning as a symmetric
// diagonal scaling, Â = S A S, S = D^-½, d = S y): b̂ = S f, r̂ = p = b̂, y = 0, with the partial
// sums of r̂ᵀr̂ and ‖f‖² for reduce_restart. CPU twin: the start of sparse::pcg (mixed).

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> f: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> sdiag: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> bhat: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> r: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> p: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> y: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> partials: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = flat_index(wg, nwg, lid);
    var scaled = vec4<f32>(0.0);
    var unscaled = vec4<f32>(0.0);
    if (i < params.n) {
        let fi = f[i];
        let bh = sdiag[i] * fi;
        bhat[i] = bh;
        r[i] = bh;
        p[i] = bh;
        y[i] = vec4<f32>(0.0);
        scaled = bh * bh;
        unscaled = fi * fi;
    }
    let a = workgroup_sum(lid, scaled);
    let b = workgroup_sum(lid, unscaled);
    if (lid == 0u) {
        let g = flat_group(wg, nwg);
        partials[2u * g] = a;
        partials[2u * g + 1u] = b;
    }
}
