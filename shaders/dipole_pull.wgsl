// Pulls the irradiance up one level of the emitter tree, bottom-up (Mertens et al. 2003 §5.3):
// per node and channel the flux Φ = ∫E dA and the moments m = ∫E (x − c) dA and
// Q = ∫E (x − c)(x − c)ᵀ dA about its centre c. On a triangle E = Σᵢ Eᵢλᵢ is linear in its
// corners' values (vᵢ = corner − centroid, s = Σvᵢ, S = Σ vᵢvᵢᵀ, A the area):
// Φ = A ΣEᵢ/3, m = (A/12) Σ Eᵢvᵢ, Q = (A/60) Σᵢ Eᵢ (ssᵀ + vᵢsᵀ + svᵢᵀ + S + 2vᵢvᵢᵀ)
// (from ∫λ₁^a λ₂^b λ₃^c dA = 2A a!b!c!/(a+b+c+2)!); an inner node sums its children's, moved to
// its centre (o = c_child − c: m += Φo, Q += m oᵀ + o mᵀ + Φ ooᵀ). Slots as in dipole_common.
// CPU twin: hierarchy::integrator (DipoleHierarchy::pull).

@group(0) @binding(1) var<storage, read> order: array<u32>;
@group(0) @binding(2) var<storage, read> nodes: array<Node>;
@group(0) @binding(3) var<storage, read> positions: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> triangles: array<vec4<u32>>;
@group(0) @binding(5) var<storage, read> irradiance: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> emitted: array<vec4<f32>>;

// The symmetric matrix a bᵀ + b aᵀ as (diagonal, off-diagonal xy, xz, yz).
fn sym_diag(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return 2.0 * a * b;
}

fn sym_off(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(a.x * b.y + b.x * a.y, a.x * b.z + b.x * a.z, a.y * b.z + b.y * a.z);
}

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let k = dparams.level_start + flat_index(wg, nwg, lid);
    if (k >= dparams.level_end) {
        return;
    }
    let index = order[k];
    let node = nodes[index];
    let at = index * SLOTS;
    var flux = vec3<f32>(0.0);
    var m: array<vec3<f32>, 3>;
    var qd: array<vec3<f32>, 3>;
    var qo: array<vec3<f32>, 3>;
    if (node.leaf == 1u) {
        let t = triangles[node.right_or_item];
        var v = array<vec3<f32>, 3>(positions[t.x].xyz - node.centre, positions[t.y].xyz - node.centre,
                                    positions[t.z].xyz - node.centre);
        var e = array<vec3<f32>, 3>(irradiance[t.x].xyz, irradiance[t.y].xyz, irradiance[t.z].xyz);
        let s = v[0] + v[1] + v[2];
        let big_d = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        let big_o = vec3<f32>(v[0].x * v[0].y + v[1].x * v[1].y + v[2].x * v[2].y,
                              v[0].x * v[0].z + v[1].x * v[1].z + v[2].x * v[2].z,
                              v[0].y * v[0].z + v[1].y * v[1].z + v[2].y * v[2].z);
        flux = node.weight * (e[0] + e[1] + e[2]) / 3.0;
        for (var c = 0u; c < 3u; c = c + 1u) {
            var mc = vec3<f32>(0.0);
            var dc = vec3<f32>(0.0);
            var oc = vec3<f32>(0.0);
            for (var i = 0u; i < 3u; i = i + 1u) {
                let ei = e[i][c];
                let vi = v[i];
                mc = mc + ei * vi;
                // ssᵀ + vᵢsᵀ + svᵢᵀ + S + 2vᵢvᵢᵀ
                dc = dc + ei * (s * s + sym_diag(vi, s) + big_d + 2.0 * vi * vi);
                oc = oc + ei * (0.5 * sym_off(s, s) + sym_off(vi, s) + big_o + sym_off(vi, vi));
            }
            m[c] = mc * (node.weight / 12.0);
            qd[c] = dc * (node.weight / 60.0);
            qo[c] = oc * (node.weight / 60.0);
        }
    } else {
        var children = array<u32, 2>(index + 1u, node.right_or_item);
        for (var j = 0u; j < 2u; j = j + 1u) {
            let child = children[j];
            let o = nodes[child].centre - node.centre;
            let ca = child * SLOTS;
            let cf = emitted[ca].xyz;
            flux = flux + cf;
            for (var c = 0u; c < 3u; c = c + 1u) {
                let cm = emitted[ca + 1u + c].xyz;
                m[c] = m[c] + cm + o * cf[c];
                qd[c] = qd[c] + emitted[ca + 4u + c].xyz + sym_diag(cm, o) + o * o * cf[c];
                qo[c] = qo[c] + emitted[ca + 7u + c].xyz + sym_off(cm, o) + 0.5 * sym_off(o, o) * cf[c];
            }
        }
    }
    emitted[at] = vec4<f32>(flux, 0.0);
    for (var c = 0u; c < 3u; c = c + 1u) {
        emitted[at + 1u + c] = vec4<f32>(m[c], 0.0);
        emitted[at + 4u + c] = vec4<f32>(qd[c], 0.0);
        emitted[at + 7u + c] = vec4<f32>(qo[c], 0.0);
    }
}
