// Per-tet geometry for the TransCut assembly (eq. 10 without κ): the volume V_t and, for each of
// the six edges ij (order 01, 02, 03, 12, 13, 23), c_ij = (1/6)|kl| cot θ_kl, k, l the other two
// vertices and θ_kl the dihedral angle at edge kl. cot θ_kl = −∇β_i·∇β_j / |∇β_i × ∇β_j| with
// ∇β_a = n_a / ((p_a − p_b)·n_a), n_a a normal of the face opposite a (TransCut §3.3).
// CPU twin: diffusion::structure::edge_coefficients and signed_volume.
// Output: 8 f32 per tet: V_t, c_01, c_02, c_03, c_12, c_13, c_23, material id (bits).

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> positions: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> tets: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read> materials: array<u32>;
@group(0) @binding(4) var<storage, read_write> geometry: array<f32>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let t = flat_index(wg, nwg, lid);
    if (t >= params.n_tets) {
        return;
    }
    let tet = tets[t];
    var p = array<vec3<f32>, 4>(positions[tet.x].xyz, positions[tet.y].xyz,
                                positions[tet.z].xyz, positions[tet.w].xyz);
    var g: array<vec3<f32>, 4>;
    for (var a = 0u; a < 4u; a = a + 1u) {
        // The other three local vertices, increasing.
        let b = select(0u, 1u, a == 0u);
        let c = select(1u, 2u, a <= 1u);
        let d = select(2u, 3u, a <= 2u);
        let n = cross(p[c] - p[b], p[d] - p[b]);
        g[a] = n / dot(p[a] - p[b], n);
    }
    let base = 8u * t;
    geometry[base] = abs(dot(p[1] - p[0], cross(p[2] - p[0], p[3] - p[0]))) / 6.0;
    var edges = array<vec2<u32>, 6>(vec2<u32>(0u, 1u), vec2<u32>(0u, 2u), vec2<u32>(0u, 3u),
                                    vec2<u32>(1u, 2u), vec2<u32>(1u, 3u), vec2<u32>(2u, 3u));
    for (var e = 0u; e < 6u; e = e + 1u) {
        let ij = edges[e];
        let kl = edges[5u - e]; // the opposite edge
        let gi = g[ij.x];
        let gj = g[ij.y];
        let cot = -dot(gi, gj) / length(cross(gi, gj));
        geometry[base + 1u + e] = length(p[kl.x] - p[kl.y]) * cot / 6.0;
    }
    geometry[base + 7u] = bitcast<f32>(materials[t]);
}
