// Shared declarations of the hierarchical dipole's kernels (Mertens et al. 2003; prepended after
// common.wgsl to dipole_refit, dipole_pull, dipole_traverse and dipole_push by core::gpu::shaders):
// the uniform, the cluster node, and the dipole profile and its triangle form factor in f32, the
// twins of core::optics::dipole and core::optics::dipole_patch. Channels are the .xyz of a vec3.

// One uniform for every dipole kernel.
struct DipoleParams {
    n_vertices: u32,
    n_triangles: u32,
    n_tasks: u32,
    level_start: u32,   // refit and pull: the nodes order[level_start..level_end] of one level
    level_end: u32,
    item_kind: u32,     // refit: 0 emitting triangles, 1 receiving vertices, 2 receiving face centroids
    oracle: u32,        // 0 the opening angle, 1 the paper's solid angle
    rule: u32,          // 0 3-point Gauss–Legendre, 1 the paper's midpoint rule
    sigma_rule: u32,    // the midpoint rule's σL < 2/5 split
    pad0: u32,
    pad1: u32,
    pad2: u32,
    theta: f32,         // the opening angle
    eps1: f32,          // the paper oracle's thresholds
    eps2: f32,
    near_angle: f32,    // Oracle::rule7_below: a near pair farther than this is integrated by the 7-point rule
    max_l_over_r: f32,  // the edge rule's split bound
    pad3: f32,
    pad4: f32,
    pad5: f32,
    sigma_tr: vec4<f32>,
    z_r: vec4<f32>,
    z_v: vec4<f32>,
    scale: vec4<f32>,   // α′/(4π)
}

@group(0) @binding(0) var<uniform> dparams: DipoleParams;

// A cluster of core::hierarchy::tree::ClusterNode, with its subtree's end (exclusive).
struct Node {
    centre: vec3<f32>,
    radius: f32,
    normal: vec3<f32>,
    weight: f32,
    right_or_item: u32, // inner: the right child (the left is the next node); leaf: the item
    leaf: u32,
    end: u32,
    pad: u32,
}

// Per node, the vec4 slots of the emitter's flux expansion (dipole_pull) and of the receiver's
// local expansion (dipole_traverse, dipole_push): 0 the flux Φ or value b; 1..3 per channel the
// first moment m or gradient (xyz); 4..6 per channel the diagonal of Q or of the Hessian (xx, yy,
// zz); 7..9 per channel its off-diagonal (xy, xz, yz).
const SLOTS: u32 = 10u;

const PI: f32 = 3.14159265358979;
const TAU: f32 = 6.28318530717959;

// A foot closer to an edge's line than this fraction of the edge's length lies on the line (f32:
// the corners are relative to the receiver, so a receiver at a corner is within rounding of it).
const COLLINEAR: f32 = 1e-5;
// The deepest bisection of an edge (f32 resolves no finer split).
const MAX_SPLIT_DEPTH: f32 = 22.0;

fn normalize_or_zero(v: vec3<f32>) -> vec3<f32> {
    let l = length(v);
    if (l > 1e-30) {
        return v / l;
    }
    return vec3<f32>(0.0);
}

// e^x − 1 without cancellation: a Taylor polynomial for |x| < 0.1 (error below x⁶/720), else
// exp(x) − 1 (a cancellation of at most 10×). WGSL has no expm1.
fn expm1(x: vec3<f32>) -> vec3<f32> {
    let series = x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x * (1.0 / 24.0 + x * (1.0 / 120.0)))));
    return select(exp(x) - 1.0, series, abs(x) < vec3<f32>(0.1));
}

// Rd(r) per channel from r² (Jensen et al. 2001; core::optics::Dipole::rd).
fn rd(r2: f32) -> vec3<f32> {
    let s = dparams.sigma_tr.xyz;
    let dr = sqrt(r2 + dparams.z_r.xyz * dparams.z_r.xyz);
    let dv = sqrt(r2 + dparams.z_v.xyz * dparams.z_v.xyz);
    let tr = dparams.z_r.xyz * (s + 1.0 / dr) * exp(-s * dr) / (dr * dr);
    let tv = dparams.z_v.xyz * (s + 1.0 / dv) * exp(-s * dv) / (dv * dv);
    return dparams.scale.xyz * (tr + tv);
}

// Rd, k = Rd′/r and l = k′/r per channel at distance r (core::optics::Dipole::rd_with_derivatives).
struct Derivatives {
    f: vec3<f32>,
    k: vec3<f32>,
    l: vec3<f32>,
}

fn rd_with_derivatives(r: f32) -> Derivatives {
    var out = Derivatives(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    let s = dparams.sigma_tr.xyz;
    for (var j = 0u; j < 2u; j = j + 1u) {
        let z = select(dparams.z_v.xyz, dparams.z_r.xyz, j == 0u);
        let d = sqrt(r * r + z * z);
        let sd = s * d;
        let inv = 1.0 / d;
        let e = z * exp(-sd);
        let inv2 = inv * inv;
        let inv3 = inv2 * inv;
        out.f = out.f + e * (1.0 + sd) * inv3;
        out.k = out.k - e * ((sd + 3.0) * sd + 3.0) * inv3 * inv2;
        out.l = out.l + e * (((sd + 6.0) * sd + 15.0) * sd + 15.0) * inv3 * inv2 * inv2;
    }
    let c = dparams.scale.xyz;
    return Derivatives(c * out.f, c * out.k, c * out.l);
}

// ∫ Rd(‖x‖) over the triangle (corners relative to the receiver) by the 7-point degree-5 rule
// (Radon 1948; core::optics::quadrature::triangle_rule7).
fn rule7(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> vec3<f32> {
    let area = 0.5 * length(cross(b - a, c - a));
    let s15 = 3.87298334620742;
    let a1 = (6.0 - s15) / 21.0;
    let b1 = (9.0 + 2.0 * s15) / 21.0;
    let a2 = (6.0 + s15) / 21.0;
    let b2 = (9.0 - 2.0 * s15) / 21.0;
    let w1 = (155.0 - s15) / 1200.0;
    let w2 = (155.0 + s15) / 1200.0;
    let centre = (a + b + c) / 3.0;
    var sum = 9.0 / 40.0 * rd(dot(centre, centre));
    let p1 = array<vec3<f32>, 3>(b1 * a + a1 * (b + c), b1 * b + a1 * (a + c), b1 * c + a1 * (a + b));
    let p2 = array<vec3<f32>, 3>(b2 * a + a2 * (b + c), b2 * b + a2 * (a + c), b2 * c + a2 * (a + b));
    for (var i = 0u; i < 3u; i = i + 1u) {
        sum = sum + w1 * rd(dot(p1[i], p1[i])) + w2 * rd(dot(p2[i], p2[i]));
    }
    return area * sum;
}

// The edge integrals I₂ of the real and the virtual source (Mertens eq. 13), per channel.
struct Pair {
    r: vec3<f32>,
    v: vec3<f32>,
}

// One segment of I₂ for one source of height h (per channel), by the rule (core::optics::
// dipole_patch::edge_integrals): Gauss–Legendre, in the near-foot form where ρ < h at its middle.
fn segment(h: vec3<f32>, radial: vec3<f32>, r: f32, lo: f32, hi: f32) -> vec3<f32> {
    let s_tr = dparams.sigma_tr.xyz;
    let mid = 0.5 * (lo + hi);
    let half = 0.5 * (hi - lo);
    if (dparams.rule == 1u) {
        let rho2 = r * r + mid * mid;
        let s = sqrt(rho2 + h * h);
        return 2.0 * half * exp(-s_tr * s) / s * r / rho2;
    }
    let dt = half * 0.774596669241483;
    let ts = array<f32, 3>(mid - dt, mid, mid + dt);
    let ws = array<f32, 3>(5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0);
    let near = vec3<f32>(r * r + mid * mid) < h * h;
    var sum = vec3<f32>(0.0);
    for (var k = 0u; k < 3u; k = k + 1u) {
        let rho2 = r * r + ts[k] * ts[k];
        let s = sqrt(rho2 + h * h);
        let gap = rho2 / (s + h);
        let deficit = exp(-s_tr * h) * (gap - h * expm1(-s_tr * gap)) / (h * s);
        let plain = exp(-s_tr * s) / s;
        sum = sum + ws[k] * select(plain, deficit, near) * r / rho2;
    }
    let angle = atan(hi / r) - atan(lo / r);
    return select(half * sum, radial * angle - half * sum, near);
}

// I₂ of one edge for both sources: bisected until L < max_l_over_r · r₀ and, with Gauss–Legendre,
// σL ≤ 1 for the largest σ.
fn edge_integrals(hr: vec3<f32>, hv: vec3<f32>, rad_r: vec3<f32>, rad_v: vec3<f32>, r: f32, t1: f32, t2: f32) -> Pair {
    let s = dparams.sigma_tr;
    let sigma_max = max(s.x, max(s.y, s.z));
    var out = Pair(vec3<f32>(0.0), vec3<f32>(0.0));
    var stack: array<vec3<f32>, 32>;
    stack[0] = vec3<f32>(t1, t2, 0.0);
    var sp = 1u;
    loop {
        if (sp == 0u) {
            break;
        }
        sp = sp - 1u;
        let seg = stack[sp];
        let lo = seg.x;
        let hi = seg.y;
        let mid = 0.5 * (lo + hi);
        let seg_len = abs(hi - lo);
        let r0 = sqrt(r * r + mid * mid);
        var sigma_split = seg_len * sigma_max > 1.0;
        if (dparams.rule == 1u) {
            sigma_split = dparams.sigma_rule == 1u && seg_len * sigma_max >= 0.4;
        }
        if ((seg_len >= dparams.max_l_over_r * r0 || sigma_split) && seg.z < MAX_SPLIT_DEPTH) {
            stack[sp] = vec3<f32>(lo, mid, seg.z + 1.0);
            stack[sp + 1u] = vec3<f32>(mid, hi, seg.z + 1.0);
            sp = sp + 2u;
            continue;
        }
        out.r = out.r + segment(hr, rad_r, r, lo, hi);
        out.v = out.v + segment(hv, rad_v, r, lo, hi);
    }
    return out;
}

// F(A, xₒ) = ∫_A Rd(‖x − xₒ‖) dx per channel over the triangle with corners relative to the
// receiver xₒ (Mertens eq. 18 in the distance geometry; core::optics::triangle_integral_rgb):
// Σ_j z_j [Θ e^{−σh_j}/h_j − Σ_e I₂(e, j)], Θ snapped to 0 or 2π off the triangle's boundary.
fn triangle_integral(c0: vec3<f32>, c1: vec3<f32>, c2: vec3<f32>) -> vec3<f32> {
    let cr = cross(c1 - c0, c2 - c0);
    let double_area = length(cr);
    if (!(double_area > 0.0)) {
        return vec3<f32>(0.0);
    }
    let n = cr / double_area;
    let h0 = dot(-c0, n);
    let foot = -h0 * n;
    let s = dparams.sigma_tr.xyz;
    let hr = sqrt(h0 * h0 + dparams.z_r.xyz * dparams.z_r.xyz);
    let hv = sqrt(h0 * h0 + dparams.z_v.xyz * dparams.z_v.xyz);
    let rad_r = exp(-s * hr) / hr;
    let rad_v = exp(-s * hv) / hv;
    var corners = array<vec3<f32>, 3>(c0, c1, c2);
    var theta = 0.0;
    var on_boundary = false;
    var edges = Pair(vec3<f32>(0.0), vec3<f32>(0.0));
    for (var e = 0u; e < 3u; e = e + 1u) {
        let a = corners[e];
        let b = corners[(e + 1u) % 3u];
        let len = length(b - a);
        let u = (b - a) / len;
        let pa = a - foot;
        let pb = b - foot;
        let r = dot(n, cross(u, foot - a));
        if (abs(r) <= COLLINEAR * len) {
            let slack = COLLINEAR * len;
            on_boundary = on_boundary || (dot(pa, u) <= slack && dot(pb, u) >= -slack);
            continue;
        }
        theta = theta + atan2(dot(n, cross(pa, pb)), dot(pa, pb));
        let p = edge_integrals(hr, hv, rad_r, rad_v, r, dot(pa, u), dot(pb, u));
        edges.r = edges.r + p.r;
        edges.v = edges.v + p.v;
    }
    if (!on_boundary) {
        theta = select(0.0, TAU, theta > PI);
    }
    let sum = dparams.z_r.xyz * (theta * rad_r - edges.r) + dparams.z_v.xyz * (theta * rad_v - edges.v);
    return dparams.scale.xyz * sum;
}
