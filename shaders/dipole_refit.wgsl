// Refits one level of a cluster tree to moved vertices, bottom-up (Mertens et al. 2003 §5.1;
// design/hierarchical-dipole.md §1.5): a leaf from its item (an emitting triangle: centroid, area,
// unit normal, farthest corner; a receiving vertex or face centroid: the point, weight 1, radius 0),
// an inner node from its two children (area-weighted centre and normal, a radius bounding both).
// One invocation per node of order[level_start..level_end]; the deeper levels ran before.
// Receiving vertices get no normal (the distance geometry reads none). CPU twin:
// hierarchy::tree::ClusterTree::refit.

@group(0) @binding(1) var<storage, read> order: array<u32>;
@group(0) @binding(2) var<storage, read_write> nodes: array<Node>;
@group(0) @binding(3) var<storage, read> positions: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> triangles: array<vec4<u32>>;

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let k = dparams.level_start + flat_index(wg, nwg, lid);
    if (k >= dparams.level_end) {
        return;
    }
    let index = order[k];
    var node = nodes[index];
    if (node.leaf == 1u) {
        let item = node.right_or_item;
        if (dparams.item_kind == 1u) {
            node.centre = positions[item].xyz;
            node.weight = 1.0;
            node.normal = vec3<f32>(0.0);
            node.radius = 0.0;
        } else {
            let t = triangles[item];
            let a = positions[t.x].xyz;
            let b = positions[t.y].xyz;
            let c = positions[t.z].xyz;
            let centre = (a + b + c) / 3.0;
            let cr = cross(b - a, c - a);
            node.centre = centre;
            node.normal = normalize_or_zero(cr);
            if (dparams.item_kind == 0u) {
                node.weight = 0.5 * length(cr);
                node.radius = max(distance(a, centre), max(distance(b, centre), distance(c, centre)));
            } else {
                node.weight = 1.0;
                node.radius = 0.0;
            }
        }
    } else {
        let l = nodes[index + 1u];
        let r = nodes[node.right_or_item];
        let w = l.weight + r.weight;
        node.weight = w;
        if (w > 0.0) {
            node.centre = (l.centre * l.weight + r.centre * r.weight) / w;
        } else {
            node.centre = 0.5 * (l.centre + r.centre);
        }
        node.normal = normalize_or_zero(l.normal * l.weight + r.normal * r.weight);
        node.radius = max(distance(l.centre, node.centre) + l.radius, distance(r.centre, node.centre) + r.radius);
    }
    nodes[index] = node;
}
