// Multigrid-preconditioned CG, after the update x += α p, r −= α q (cg_update, or cg_residual on
// a residual replacement, both with S = 1): sums their partials of ‖r‖², counts the iteration of
// every active channel, stores ‖r‖² and stops a channel once ‖r‖² ≤ tol2. Unlike reduce_beta it
// leaves ρ and β alone: with a preconditioner they come from rᵀz (mg_reduce_rz), after the
// V-cycle. CPU twin: the residual norm and stopping test of sparse::hierarchy::mg_pcg.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> partials: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> s: Scalars;

@compute @workgroup_size(256)
fn main(@builtin(local_invocation_index) lid: u32) {
    var acc = vec4<f32>(0.0);
    for (var k = lid; k < params.n_groups; k = k + WG) {
        acc = acc + partials[2u * k + 1u];
    }
    let ru = workgroup_sum(lid, acc);
    if (lid == 0u) {
        for (var c = 0u; c < 3u; c = c + 1u) {
            if (s.running[c] > 0.5) {
                s.iterations[c] = s.iterations[c] + 1u;
                s.rr[c] = ru[c];
                if (!(ru[c] > s.tol2[c])) {
                    s.running[c] = 0.0;
                }
            }
        }
    }
}
