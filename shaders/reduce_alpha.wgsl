// PCG step length: sums the partials of pᵀÂp (spmv_dot) and sets α = ρ / pᵀÂp for every active
// channel, 0 for the others; pᵀÂp ≤ 0 or not finite marks a breakdown and stops the channel.
// CPU twin: the α of sparse::pcg.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> partials: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> s: Scalars;

@compute @workgroup_size(256)
fn main(@builtin(local_invocation_index) lid: u32) {
    var acc = vec4<f32>(0.0);
    for (var k = lid; k < params.n_groups; k = k + WG) {
        acc = acc + partials[k];
    }
    let pq = workgroup_sum(lid, acc);
    if (lid == 0u) {
        var alpha = vec4<f32>(0.0);
        for (var c = 0u; c < 3u; c = c + 1u) {
            if (s.running[c] > 0.5) {
                if (pq[c] > 0.0 && pq[c] <= 3.0e38) {
                    alpha[c] = s.rho[c] / pq[c];
                } else {
                    s.breakdown[c] = 1u;
                    s.running[c] = 0.0;
                }
            }
        }
        s.alpha = alpha;
    }
}
