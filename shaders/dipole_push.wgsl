// Pushes the gathered local expansions down one receiver subtree per invocation (Mertens et al.
// 2003 §5.3, second order): in depth-first order each inner node's expansion (b, ∇b, H) moves to
// its children's centres (o = c_child − c: b + ∇b·o + ½oᵀHo, ∇b + Ho, H) and adds to theirs; a
// receiving leaf's b is its item's exitance B, written to out. CPU twin: DipoleHierarchy's push
// (hierarchy::integrator).

@group(0) @binding(1) var<storage, read> rnodes: array<Node>;
@group(0) @binding(2) var<storage, read> tasks: array<vec2<u32>>;
@group(0) @binding(3) var<storage, read_write> local: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> out: array<vec4<f32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let k = flat_index(wg, nwg, lid);
    if (k >= dparams.n_tasks) {
        return;
    }
    let root = tasks[k].x;
    let end = tasks[k].y;
    for (var n = root; n < end; n = n + 1u) {
        let node = rnodes[n];
        let at = n * SLOTS;
        if (node.leaf == 1u) {
            out[node.right_or_item] = vec4<f32>(local[at].xyz, 0.0);
            continue;
        }
        let b = local[at].xyz;
        var children = array<u32, 2>(n + 1u, node.right_or_item);
        for (var j = 0u; j < 2u; j = j + 1u) {
            let child = children[j];
            let o = rnodes[child].centre - node.centre;
            let ca = child * SLOTS;
            var db = vec3<f32>(0.0);
            for (var c = 0u; c < 3u; c = c + 1u) {
                let g = local[at + 1u + c].xyz;
                let hd = local[at + 4u + c].xyz;
                let ho = local[at + 7u + c].xyz;
                let h_o = vec3<f32>(hd.x * o.x + ho.x * o.y + ho.y * o.z, ho.x * o.x + hd.y * o.y + ho.z * o.z,
                                    ho.y * o.x + ho.z * o.y + hd.z * o.z);
                db[c] = b[c] + dot(g, o) + 0.5 * dot(o, h_o);
                local[ca + 1u + c] = local[ca + 1u + c] + vec4<f32>(g + h_o, 0.0);
                local[ca + 4u + c] = local[ca + 4u + c] + vec4<f32>(hd, 0.0);
                local[ca + 7u + c] = local[ca + 7u + c] + vec4<f32>(ho, 0.0);
            }
            local[ca] = local[ca] + vec4<f32>(db, 0.0);
        }
    }
}
