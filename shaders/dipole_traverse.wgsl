// The dual-tree traversal of the hierarchical dipole (Mertens et al. 2003 §5.2–5.4), gathering
// as it links, one invocation per receiver subtree (tasks[k] = its root and end): from
// (root, emitter root) every pair is accepted as a far link, integrated as a near pair of leaves,
// or opened on the side the oracle says, depth first with a stack. A far link adds the emitter's
// flux expansion seen through the dipole between the centres (D = c_R − c_E, f = Rd(‖D‖),
// k = Rd′/‖D‖, l = k′/‖D‖) to the receiver's local expansion:
//   b += Φf − k D·m + ½(k tr Q + l DᵀQD);   inner receivers also ∇b += D(kΦ − l D·m) − k m,
//   H += Φ(kI + l DDᵀ);
// a near pair adds F·Ē, F the triangle's form factor at the receiving point (analytic, Mertens
// eq. 18, within min(2θ, 1) of it; else the 7-point rule) and Ē the triangle's mean irradiance.
// Each invocation writes only the local expansions of its own subtree. links[0] and links[1]
// count the links and the near ones. CPU twin: DipoleHierarchy::update in on-the-fly mode with the
// same subtrees (hierarchy::integrator).

@group(0) @binding(1) var<storage, read> rnodes: array<Node>;
@group(0) @binding(2) var<storage, read> enodes: array<Node>;
@group(0) @binding(3) var<storage, read> tasks: array<vec2<u32>>;
@group(0) @binding(4) var<storage, read> positions: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> triangles: array<vec4<u32>>;
@group(0) @binding(6) var<storage, read> emitted: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> local: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> links: array<atomic<u32>>;

const ACCEPT: u32 = 0u;
const NEAR: u32 = 1u;
const OPEN_RECEIVER: u32 = 2u;
const OPEN_EMITTER: u32 = 3u;
// The pairs waiting on one invocation's stack: at most 1 + the depth of its receiver subtree +
// the emitter tree's depth (checked on the host).
const STACK: u32 = 64u;

fn open_either(r: Node, e: Node, receiver_first: bool) -> u32 {
    if (r.leaf == 1u && e.leaf == 1u) {
        return NEAR;
    }
    if (r.leaf == 1u) {
        return OPEN_EMITTER;
    }
    if (e.leaf == 1u || receiver_first) {
        return OPEN_RECEIVER;
    }
    return OPEN_EMITTER;
}

// The solid angle ω = A_E/d² of emitter e from a point (+∞ at the centre itself).
fn omega(at: vec3<f32>, e: Node) -> f32 {
    let d2 = dot(at - e.centre, at - e.centre);
    if (!(d2 > 0.0)) {
        return 3.0e38;
    }
    return e.weight / d2;
}

// The oracle (hierarchy::oracle::Oracle::decide).
fn decide(ri: u32, r: Node, e: Node) -> u32 {
    if (dparams.oracle == 0u) {
        if (r.radius + e.radius < dparams.theta * distance(r.centre, e.centre)) {
            return ACCEPT;
        }
        return open_either(r, e, r.radius >= e.radius);
    }
    let here = omega(r.centre, e);
    if (!(here <= dparams.eps2)) {
        return open_either(r, e, e.leaf == 1u);
    }
    if (r.leaf == 0u) {
        let a = omega(rnodes[ri + 1u].centre, e);
        let b = omega(rnodes[r.right_or_item].centre, e);
        if (max(abs(a - here), abs(b - here)) > dparams.eps1 || a >= 3.0e38) {
            return OPEN_RECEIVER;
        }
    }
    return ACCEPT;
}

fn add(i: u32, v: vec3<f32>) {
    local[i] = local[i] + vec4<f32>(v, 0.0);
}

// A far link's expansion at receiver ri from emitter ei (the header).
fn far(ri: u32, r: Node, ei: u32, e: Node) {
    let d = r.centre - e.centre;
    let kernel = rd_with_derivatives(length(d));
    let ea = ei * SLOTS;
    let ra = ri * SLOTS;
    let phi = emitted[ea].xyz;
    var b = vec3<f32>(0.0);
    for (var c = 0u; c < 3u; c = c + 1u) {
        let m = emitted[ea + 1u + c].xyz;
        let qd = emitted[ea + 4u + c].xyz;
        let qo = emitted[ea + 7u + c].xyz;
        let dm = dot(d, m);
        let dqd = dot(d * d, qd) + 2.0 * (d.x * d.y * qo.x + d.x * d.z * qo.y + d.y * d.z * qo.z);
        let f = kernel.f[c];
        let k = kernel.k[c];
        let l = kernel.l[c];
        b[c] = phi[c] * f - k * dm + 0.5 * (k * (qd.x + qd.y + qd.z) + l * dqd);
        if (r.leaf == 0u) {
            add(ra + 1u + c, d * (k * phi[c] - l * dm) - m * k);
            add(ra + 4u + c, phi[c] * (l * d * d + vec3<f32>(k)));
            add(ra + 7u + c, phi[c] * l * vec3<f32>(d.x * d.y, d.x * d.z, d.y * d.z));
        }
    }
    add(ra, b);
}

// A near pair's F·Ē at receiving leaf ri from the triangle of emitting leaf ei.
fn near(ri: u32, r: Node, ei: u32, e: Node) {
    let t = triangles[e.right_or_item];
    let a = positions[t.x].xyz - r.centre;
    let b = positions[t.y].xyz - r.centre;
    let c = positions[t.z].xyz - r.centre;
    var f: vec3<f32>;
    if (e.radius < dparams.near_angle * distance(r.centre, e.centre)) {
        f = rule7(a, b, c);
    } else {
        f = triangle_integral(a, b, c);
    }
    var mean = vec3<f32>(0.0);
    if (e.weight > 0.0) {
        mean = emitted[ei * SLOTS].xyz / e.weight;
    }
    add(ri * SLOTS, f * mean);
}

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let k = flat_index(wg, nwg, lid);
    if (k >= dparams.n_tasks) {
        return;
    }
    let root = tasks[k].x;
    let end = tasks[k].y;
    for (var i = root * SLOTS; i < end * SLOTS; i = i + 1u) {
        local[i] = vec4<f32>(0.0);
    }
    var stack: array<vec2<u32>, STACK>;
    stack[0] = vec2<u32>(root, 0u);
    var sp = 1u;
    var count = 0u;
    var near_count = 0u;
    loop {
        if (sp == 0u) {
            break;
        }
        sp = sp - 1u;
        let pair = stack[sp];
        let r = rnodes[pair.x];
        let e = enodes[pair.y];
        let decision = decide(pair.x, r, e);
        if (decision == ACCEPT) {
            far(pair.x, r, pair.y, e);
            count = count + 1u;
        } else if (decision == NEAR) {
            near(pair.x, r, pair.y, e);
            count = count + 1u;
            near_count = near_count + 1u;
        } else if (decision == OPEN_RECEIVER) {
            stack[sp] = vec2<u32>(r.right_or_item, pair.y);
            stack[sp + 1u] = vec2<u32>(pair.x + 1u, pair.y);
            sp = sp + 2u;
        } else {
            stack[sp] = vec2<u32>(pair.x, e.right_or_item);
            stack[sp + 1u] = vec2<u32>(pair.x, pair.y + 1u);
            sp = sp + 2u;
        }
    }
    atomicAdd(&links[0], count);
    atomicAdd(&links[1], near_count);
}
