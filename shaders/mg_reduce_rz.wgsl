// Multigrid-preconditioned CG, after the V-cycle z = B r: sums the partials of rᵀz (dot.wgsl)
// and sets β = rᵀz / ρ, ρ = rᵀz for every active channel (β = 0 for the others, whose α is 0);
// rᵀz ≤ 0 or not finite (B not positive definite in f32) marks a breakdown and stops the channel.
// At a (re)start p = 0, so p = z + β p = z whatever β is. CPU twin: the β of mg_pcg.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> partials: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> s: Scalars;

@compute @workgroup_size(256)
fn main(@builtin(local_invocation_index) lid: u32) {
    var acc = vec4<f32>(0.0);
    for (var k = lid; k < params.n_groups; k = k + WG) {
        acc = acc + partials[k];
    }
    let rz = workgroup_sum(lid, acc);
    if (lid == 0u) {
        var beta = vec4<f32>(0.0);
        for (var c = 0u; c < 3u; c = c + 1u) {
            if (s.running[c] > 0.5) {
                if (rz[c] > 0.0 && rz[c] <= 3.0e38) {
                    if (s.rho[c] > 0.0) {
                        beta[c] = rz[c] / s.rho[c];
                    }
                    s.rho[c] = rz[c];
                } else {
                    s.breakdown[c] = 1u;
                    s.running[c] = 0.0;
                }
            }
        }
        s.beta = beta;
    }
}
