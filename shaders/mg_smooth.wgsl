// One step of the Chebyshev–Jacobi smoother of the multigrid V-cycle, one invocation per row:
// d = a d + b D⁻¹ (r − A z) per channel, then z' = z + d into a second buffer (the rows around
// read z, so it is not updated in place; the host alternates the two buffers). The first step of
// a smoothing does not read d (a = 0, b = 1/θ); the first step of a pre-smoothing starts from
// z = 0 and reads neither A nor z. Later steps: a = ρ_k ρ_{k−1}, b = 2ρ_k/δ, the Chebyshev
// recurrence over [λmax/ratio, λmax] of D⁻¹A, computed on the host.
// CPU twin: Smoother::smooth of sparse::hierarchy::vcycle.

struct Cheb {
    a: vec4<f32>,
    b: vec4<f32>,
    from_zero: u32, // 1: z = 0 (reads neither A nor z)
    first: u32,     // 1: d is not read (a = 0)
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<uniform> cheb: Cheb;
@group(0) @binding(2) var<storage, read> row_ptr: array<u32>;
@group(0) @binding(3) var<storage, read> col_idx: array<u32>;
@group(0) @binding(4) var<storage, read> vals: array<f32>;
@group(0) @binding(5) var<storage, read> r: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> inv_diag: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> z: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> d: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read_write> z_out: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = flat_index(wg, nwg, lid);
    if (i >= params.n) {
        return;
    }
    var res = r[i].xyz;
    var zi = vec3<f32>(0.0);
    if (cheb.from_zero == 0u) {
        var acc = vec3<f32>(0.0);
        let end = row_ptr[i + 1u];
        for (var k = row_ptr[i]; k < end; k = k + 1u) {
            let a = vec3<f32>(vals[3u * k], vals[3u * k + 1u], vals[3u * k + 2u]);
            acc = acc + a * z[col_idx[k]].xyz;
        }
        res = res - acc;
        zi = z[i].xyz;
    }
    var di = cheb.b.xyz * inv_diag[i].xyz * res;
    if (cheb.first == 0u) {
        di = di + cheb.a.xyz * d[i].xyz;
    }
    d[i] = vec4<f32>(di, 0.0);
    z_out[i] = vec4<f32>(zi + di, 0.0);
}
