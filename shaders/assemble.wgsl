// TransCut eqs. 10, 13 and 14, one invocation per matrix row i (a gather: no atomics, every row
// sums its own tets in increasing tet order, so M is exactly symmetric and deterministic). For
// every tet t around i and every other vertex j of t, the tet's edge weight
// w_ijt = −κ_t c_ij (eq. 10) goes to M_ij as 4 w_ijt (eq. 14) and to M_ii as −4 w_ijt;
// V_t μ_t goes to M_ii (eq. 13, lumped absorption), and 2S_i/(3A) on boundary vertices.
// The exponentially fitted variant scales each w_ijt by f(σtr,t |ij|), f(x) = x / sinh x (the
// media carry σtr = 0 for TransCut's own scheme, where f is exactly 1), and its boundary rows'
// absorption comes with the boundary term.
// CPU twins: diffusion::transcut::fill_transcut and diffusion::fitted::fill_fitted.

struct Row {
    value_start: u32,  // first nonzero of the row
    value_end: u32,
    inc_start: u32,    // the row's tets: incidences[inc_start..inc_end]
    inc_end: u32,
    diag: u32,         // position of the diagonal nonzero
    // Per channel: 2S_i/(3A) on boundary vertices (plus, for the fitted scheme, its boundary
    // layer's absorption over the lumped one, computed on the CPU), 0 inside.
    boundary_r: f32,
    boundary_g: f32,
    boundary_b: f32,
}

// One tet around the row's vertex: the tet, the vertex's local index in it, and the value slots
// (relative to the row start) of the other three local vertices, increasing.
struct Incidence {
    tet: u32,
    local: u32,
    s0: u32,
    s1: u32,
    s2: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> rows: array<Row>;
@group(0) @binding(2) var<storage, read> incidences: array<Incidence>;
@group(0) @binding(3) var<storage, read> geometry: array<f32>;
@group(0) @binding(4) var<storage, read> media: array<vec4<f32>>; // per material: κ, μ, σtr
@group(0) @binding(5) var<storage, read_write> values: array<f32>;
@group(0) @binding(6) var<storage, read> positions: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> tets: array<vec4<u32>>;

// f(x) = x / sinh x per channel: its series 1 − x²/6 + 7x⁴/360 − 31x⁶/15120 below 1/4 (f32
// exact there, and exactly 1 at 0), x / sinh x above (0 once sinh overflows).
fn stiffness_factor(x: vec3<f32>) -> vec3<f32> {
    let y = x * x;
    let series = 1.0 + y * (-1.0 / 6.0 + y * (7.0 / 360.0 - y * (31.0 / 15120.0)));
    return select(x / sinh(x), series, x < vec3<f32>(0.25));
}

// Index of edge ab (a ≠ b) in the order 01, 02, 03, 12, 13, 23.
fn edge_index(a: u32, b: u32) -> u32 {
    let lo = min(a, b);
    let hi = max(a, b);
    return lo * (5u - lo) / 2u + hi - 1u;
}

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    let i = flat_index(wg, nwg, lid);
    if (i >= params.n) {
        return;
    }
    let row = rows[i];
    for (var k = row.value_start; k < row.value_end; k = k + 1u) {
        values[3u * k] = 0.0;
        values[3u * k + 1u] = 0.0;
        values[3u * k + 2u] = 0.0;
    }
    var d = vec3<f32>(0.0);
    for (var m = row.inc_start; m < row.inc_end; m = m + 1u) {
        let inc = incidences[m];
        let base = 8u * inc.tet;
        let material = bitcast<u32>(geometry[base + 7u]);
        let kappa = media[3u * material].xyz;
        let mu = media[3u * material + 1u].xyz;
        let sigma_tr = media[3u * material + 2u].xyz;
        let tet = tets[inc.tet];
        var corners = array<u32, 4>(tet.x, tet.y, tet.z, tet.w);
        let here = positions[corners[inc.local]].xyz;
        var slots = array<u32, 3>(inc.s0, inc.s1, inc.s2);
        for (var k = 0u; k < 3u; k = k + 1u) {
            let b = k + select(0u, 1u, k >= inc.local); // k-th other local vertex
            let coef = geometry[base + 1u + edge_index(inc.local, b)];
            let f = stiffness_factor(sigma_tr * length(positions[corners[b]].xyz - here));
            let w4 = -4.0 * kappa * coef * f;
            let pos = 3u * (row.value_start + slots[k]);
            values[pos] = values[pos] + w4.x;
            values[pos + 1u] = values[pos + 1u] + w4.y;
            values[pos + 2u] = values[pos + 2u] + w4.z;
            d = d - w4;
        }
        d = d + geometry[base] * mu;
    }
    d = d + vec3<f32>(row.boundary_r, row.boundary_g, row.boundary_b);
    values[3u * row.diag] = d.x;
    values[3u * row.diag + 1u] = d.y;
    values[3u * row.diag + 2u] = d.z;
}
