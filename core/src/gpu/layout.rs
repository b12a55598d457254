//! The `#[repr(C)]` structs shared with the kernels (their WGSL twins are in
//! `shaders/common.wgsl` and `shaders/assemble.wgsl`; the sizes are checked in the tests).

use bytemuck::{Pod, Zeroable};

/// `Params` of `common.wgsl`: the problem sizes and the radiance coefficients.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, Pod, Zeroable)]
pub(crate) struct Params {
    pub n: u32,
    pub nnz: u32,
    pub n_tets: u32,
    pub n_boundary: u32,
    pub n_groups: u32,
    pub pad: [u32; 3],
    pub rad_phi: f32,
    pub rad_q: f32,
    pub pad_f: [f32; 2],
}

/// `Scalars` of `common.wgsl`: the per-channel PCG scalars on the device.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, Pod, Zeroable)]
pub(crate) struct Scalars {
    pub rho: [f32; 4],
    pub alpha: [f32; 4],
    pub beta: [f32; 4],
    pub rr: [f32; 4],
    pub tol2: [f32; 4],
    pub running: [f32; 4],
    pub iterations: [u32; 4],
    pub breakdown: [u32; 4],
}

/// `Row` of `assemble.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, Pod, Zeroable)]
pub(crate) struct RowInfo {
    pub value_start: u32,
    pub value_end: u32,
    pub inc_start: u32,
    pub inc_end: u32,
    pub diag: u32,
    /// Per channel: 2S_i/(3A) on boundary vertices, with the fitted scheme's layer absorption
    /// over the lumped one added; 0 inside.
    pub boundary: [f32; 3],
}

/// `Incidence` of `assemble.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, Pod, Zeroable)]
pub(crate) struct Incidence {
    pub tet: u32,
    pub local: u32,
    pub slots: [u32; 3],
}

/// Three-channel f64 vectors as the kernels' vec4<f32> (w = 0).
pub(crate) fn to_vec4(v: &[[f64; 3]]) -> Vec<[f32; 4]> {
    v.iter().map(|x| [x[0] as f32, x[1] as f32, x[2] as f32, 0.0]).collect()
}

/// The kernels' vec4<f32> bytes as three-channel f64 vectors (the first `n`).
pub(crate) fn from_vec4(bytes: &[u8], n: usize) -> Vec<[f64; 3]> {
    let v: &[[f32; 4]] = bytemuck::cast_slice(&bytes[..16 * n]);
    v.iter().map(|x| [f64::from(x[0]), f64::from(x[1]), f64::from(x[2])]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn struct_sizes_match_the_wgsl_layouts() {
        // WGSL: Params 12 × 4 bytes, Scalars 8 × vec4, Row 8 × 4, Incidence 5 × 4.
        assert_eq!(size_of::<Params>(), 48);
        assert_eq!(size_of::<Scalars>(), 128);
        assert_eq!(size_of::<RowInfo>(), 32);
        assert_eq!(size_of::<Incidence>(), 20);
    }
}
