// The PRT exitance combined into radiance (R. Wang et al. 2008 eq. 7; ARCHITECTURE.md "What a
// bake returns"), one invocation per output vertex o with receiver v = output_map[o]:
//   Lo[o][c] = max(0, Σₖ w[k][c] · gathered[(v K + k) 3 + c]),  w = C(η) s (host-side product),
// 0 for an output vertex without a receiver (0xffffffff: inside a tet mesh). The fourth lane is
// 1 where the clamp at zero changed a channel, 0 elsewhere: the host counts the clamped vertices
// while it reads Lo back (no atomics). CPU twin: the `radiance` function of methods::prt (f64).

struct PrtParams {
    vertices: u32,        // receiver vertices V
    rows_per_vertex: u32, // basis functions K
    samples: u32,         // irradiance samples (prt_relight.wgsl)
    outputs: u32,         // output vertices
}

@group(0) @binding(0) var<uniform> prt: PrtParams;
@group(0) @binding(1) var<storage, read> weights: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> output_map: array<u32>;
@group(0) @binding(3) var<storage, read> gathered: array<f32>;
@group(0) @binding(4) var<storage, read_write> radiance: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let o = flat_index(wg, nwg, lid);
    if (o >= prt.outputs) {
        return;
    }
    let v = output_map[o];
    if (v >= prt.vertices) {
        radiance[o] = vec4<f32>(0.0);
        return;
    }
    var lo = vec3<f32>(0.0);
    for (var k = 0u; k < prt.rows_per_vertex; k = k + 1u) {
        let g = 3u * (v * prt.rows_per_vertex + k);
        lo = lo + weights[k].xyz * vec3<f32>(gathered[g], gathered[g + 1u], gathered[g + 2u]);
    }
    let clamped = any(lo < vec3<f32>(0.0));
    radiance[o] = vec4<f32>(max(lo, vec3<f32>(0.0)), select(0.0, 1.0, clamped));
}
