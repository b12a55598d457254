// Sums the partials of cg_update (r̂ᵀr̂ and ‖r‖²), counts the iteration of every active channel,
// sets β = r̂ᵀr̂ / ρ and ρ = r̂ᵀr̂, and stops a channel once ‖r‖² ≤ tol2. Inactive channels get
// β = 0 (their α stays 0, so y and r̂ stop changing). CPU twin: the β of sparse::pcg.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> partials: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> s: Scalars;

@compute @workgroup_size(256)
fn main(@builtin(local_invocation_index) lid: u32) {
    var acc_scaled = vec4<f32>(0.0);
    var acc_unscaled = vec4<f32>(0.0);
    for (var k = lid; k < params.n_groups; k = k + WG) {
        acc_scaled = acc_scaled + partials[2u * k];
        acc_unscaled = acc_unscaled + partials[2u * k + 1u];
    }
    let rs = workgroup_sum(lid, acc_scaled);
    let ru = workgroup_sum(lid, acc_unscaled);
    if (lid == 0u) {
        var beta = vec4<f32>(0.0);
        for (var c = 0u; c < 3u; c = c + 1u) {
            if (s.running[c] > 0.5) {
                s.iterations[c] = s.iterations[c] + 1u;
                if (s.rho[c] > 0.0) {
                    beta[c] = rs[c] / s.rho[c];
                }
                s.rho[c] = rs[c];
                s.rr[c] = ru[c];
                if (!(ru[c] > s.tol2[c])) {
                    s.running[c] = 0.0;
                }
            }
        }
        s.beta = beta;
    }
}
