// Residual replacement every k iterations (van der Vorst & Ye 2000): r̂ = b̂ − Â y recomputed
// from the iterate, replacing the recursively updated one whose rounding drifts in f32, with the
// partial sums of r̂ᵀr̂ and ‖r‖² for reduce_restart. CPU twin: sparse::scaled::reliable_residual.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> row_ptr: array<u32>;
@group(0) @binding(2) var<storage, read> col_idx: array<u32>;
@group(0) @binding(3) var<storage, read> vals: array<f32>;
@group(0) @binding(4) var<storage, read> bhat: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> y: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> sdiag: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> r: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> partials: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = flat_index(wg, nwg, lid);
    var scaled = vec4<f32>(0.0);
    var unscaled = vec4<f32>(0.0);
    if (i < params.n) {
        var acc = vec3<f32>(0.0);
        let end = row_ptr[i + 1u];
        for (var k = row_ptr[i]; k < end; k = k + 1u) {
            let a = vec3<f32>(vals[3u * k], vals[3u * k + 1u], vals[3u * k + 2u]);
            acc = acc + a * y[col_idx[k]].xyz;
        }
        let ri = bhat[i] - vec4<f32>(acc, 0.0);
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
