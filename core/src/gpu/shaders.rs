//! The WGSL kernels of `shaders/` (one file per kernel, plus `common.wgsl` prepended to each),
//! embedded with `include_str!`. Every kernel is validated by naga in `core/tests/integration/gpu_shaders.rs`.

/// The declarations shared by every kernel (`shaders/common.wgsl`): the `Params` uniform, the
/// PCG `Scalars`, the 2D-grid index helpers and the workgroup tree reduction.
pub const COMMON: &str = include_str!("../../../shaders/common.wgsl");

/// The declarations shared by the hierarchical dipole's kernels (`shaders/dipole_common.wgsl`),
/// prepended after [`COMMON`] to theirs: the `DipoleParams` uniform, the cluster `Node`, the
/// dipole profile and its triangle form factor in f32.
pub const DIPOLE_COMMON: &str = include_str!("../../../shaders/dipole_common.wgsl");

/// A compute kernel (one file of `shaders/`, entry point `main`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[non_exhaustive]
pub enum Kernel {
    /// Per-tet volume and cotangent edge coefficients (TransCut eq. 10).
    TetGeometry,
    /// Row-wise gather of the matrix values (TransCut eqs. 10, 13, 14).
    Assemble,
    /// s = D^-½ from the assembled diagonal.
    JacobiDiag,
    /// Â = S A S.
    JacobiScale,
    /// q = A p fused with partial sums of pᵀq.
    SpmvDot,
    /// Partial sums of aᵀb.
    Dot,
    /// Sum of partial sums.
    ReduceSum,
    /// α = ρ / pᵀÂp.
    ReduceAlpha,
    /// β, ρ, ‖r‖², stopping test.
    ReduceBeta,
    /// ρ and ‖r‖² after a (re)start.
    ReduceRestart,
    /// Start of a scaled PCG solve.
    CgInit,
    /// y += α p, r̂ −= α q with partial norms.
    CgUpdate,
    /// p = r̂ + β p.
    CgDirection,
    /// Residual replacement r̂ = b̂ − Â y.
    CgResidual,
    /// d = S y.
    CgUnscale,
    /// TransCut eq. 3 along the normal.
    Radiance,
    /// Multigrid: one Chebyshev–Jacobi smoothing step.
    MgSmooth,
    /// Multigrid: res = r − A z.
    MgResidual,
    /// Multigrid: r_c = Pᵀ r_f.
    MgRestrict,
    /// Multigrid: x_f += P e_c (TransCut eq. 16).
    MgProlong,
    /// Multigrid: z = A_c⁻¹ r at the coarsest level.
    MgCoarse,
    /// MG-PCG: ‖r‖², iteration count, stopping test.
    MgReduceNorm,
    /// MG-PCG: β and ρ from rᵀz.
    MgReduceRz,
    /// Hierarchical dipole: one level of a cluster tree refitted to moved vertices.
    DipoleRefit,
    /// Hierarchical dipole: the flux expansion pulled up one level of the emitter tree.
    DipolePull,
    /// Hierarchical dipole: the dual-tree traversal of one receiver subtree per invocation.
    DipoleTraverse,
    /// Hierarchical dipole: the local expansions pushed down one receiver subtree.
    DipolePush,
    /// Radiosity: one Jacobi sweep, the gathered F B and the opaque patches' update.
    RadSweep,
    /// PRT: the compressed transfer's product with the Haar-transformed irradiance, per
    /// receiver vertex and basis function (R. Wang et al. 2008 eqs. 7–8).
    PrtRelight,
    /// PRT: Lo = C(η) Σₖ sₖ (Tₖ q) per output vertex, clamped at 0 with the clamp flagged.
    PrtCombine,
    /// Polygrid relaxation: one weighted Jacobi sweep, x' = x + ω D⁻¹(b − A x), frozen rows
    /// copied.
    RelaxJacobi,
    /// Polygrid relaxation: one colour of a coloured Gauss–Seidel sweep, in place.
    RelaxGaussSeidel,
}

impl Kernel {
    /// Every kernel.
    pub const ALL: [Kernel; 32] = [
        Kernel::TetGeometry,
        Kernel::Assemble,
        Kernel::JacobiDiag,
        Kernel::JacobiScale,
        Kernel::SpmvDot,
        Kernel::Dot,
        Kernel::ReduceSum,
        Kernel::ReduceAlpha,
        Kernel::ReduceBeta,
        Kernel::ReduceRestart,
        Kernel::CgInit,
        Kernel::CgUpdate,
        Kernel::CgDirection,
        Kernel::CgResidual,
        Kernel::CgUnscale,
        Kernel::Radiance,
        Kernel::MgSmooth,
        Kernel::MgResidual,
        Kernel::MgRestrict,
        Kernel::MgProlong,
        Kernel::MgCoarse,
        Kernel::MgReduceNorm,
        Kernel::MgReduceRz,
        Kernel::DipoleRefit,
        Kernel::DipolePull,
        Kernel::DipoleTraverse,
        Kernel::DipolePush,
        Kernel::RadSweep,
        Kernel::PrtRelight,
        Kernel::PrtCombine,
        Kernel::RelaxJacobi,
        Kernel::RelaxGaussSeidel,
    ];

    /// The file name in `shaders/`.
    #[must_use]
    pub fn file(self) -> &'static str {
        match self {
            Kernel::TetGeometry => "tet_geometry.wgsl",
            Kernel::Assemble => "assemble.wgsl",
            Kernel::JacobiDiag => "jacobi_diag.wgsl",
            Kernel::JacobiScale => "jacobi_scale.wgsl",
            Kernel::SpmvDot => "spmv_dot.wgsl",
            Kernel::Dot => "dot.wgsl",
            Kernel::ReduceSum => "reduce_sum.wgsl",
            Kernel::ReduceAlpha => "reduce_alpha.wgsl",
            Kernel::ReduceBeta => "reduce_beta.wgsl",
            Kernel::ReduceRestart => "reduce_restart.wgsl",
            Kernel::CgInit => "cg_init.wgsl",
            Kernel::CgUpdate => "cg_update.wgsl",
            Kernel::CgDirection => "cg_direction.wgsl",
            Kernel::CgResidual => "cg_residual.wgsl",
            Kernel::CgUnscale => "cg_unscale.wgsl",
            Kernel::Radiance => "radiance.wgsl",
            Kernel::MgSmooth => "mg_smooth.wgsl",
            Kernel::MgResidual => "mg_residual.wgsl",
            Kernel::MgRestrict => "mg_restrict.wgsl",
            Kernel::MgProlong => "mg_prolong.wgsl",
            Kernel::MgCoarse => "mg_coarse.wgsl",
            Kernel::MgReduceNorm => "mg_reduce_norm.wgsl",
            Kernel::MgReduceRz => "mg_reduce_rz.wgsl",
            Kernel::DipoleRefit => "dipole_refit.wgsl",
            Kernel::DipolePull => "dipole_pull.wgsl",
            Kernel::DipoleTraverse => "dipole_traverse.wgsl",
            Kernel::DipolePush => "dipole_push.wgsl",
            Kernel::RadSweep => "rad_sweep.wgsl",
            Kernel::PrtRelight => "prt_relight.wgsl",
            Kernel::PrtCombine => "prt_combine.wgsl",
            Kernel::RelaxJacobi => "relax_jacobi.wgsl",
            Kernel::RelaxGaussSeidel => "relax_gs.wgsl",
        }
    }

    /// The kernel's own file, without the common declarations.
    #[must_use]
    pub fn body(self) -> &'static str {
        match self {
            Kernel::TetGeometry => include_str!("../../../shaders/tet_geometry.wgsl"),
            Kernel::Assemble => include_str!("../../../shaders/assemble.wgsl"),
            Kernel::JacobiDiag => include_str!("../../../shaders/jacobi_diag.wgsl"),
            Kernel::JacobiScale => include_str!("../../../shaders/jacobi_scale.wgsl"),
            Kernel::SpmvDot => include_str!("../../../shaders/spmv_dot.wgsl"),
            Kernel::Dot => include_str!("../../../shaders/dot.wgsl"),
            Kernel::ReduceSum => include_str!("../../../shaders/reduce_sum.wgsl"),
            Kernel::ReduceAlpha => include_str!("../../../shaders/reduce_alpha.wgsl"),
            Kernel::ReduceBeta => include_str!("../../../shaders/reduce_beta.wgsl"),
            Kernel::ReduceRestart => include_str!("../../../shaders/reduce_restart.wgsl"),
            Kernel::CgInit => include_str!("../../../shaders/cg_init.wgsl"),
            Kernel::CgUpdate => include_str!("../../../shaders/cg_update.wgsl"),
            Kernel::CgDirection => include_str!("../../../shaders/cg_direction.wgsl"),
            Kernel::CgResidual => include_str!("../../../shaders/cg_residual.wgsl"),
            Kernel::CgUnscale => include_str!("../../../shaders/cg_unscale.wgsl"),
            Kernel::Radiance => include_str!("../../../shaders/radiance.wgsl"),
            Kernel::MgSmooth => include_str!("../../../shaders/mg_smooth.wgsl"),
            Kernel::MgResidual => include_str!("../../../shaders/mg_residual.wgsl"),
            Kernel::MgRestrict => include_str!("../../../shaders/mg_restrict.wgsl"),
            Kernel::MgProlong => include_str!("../../../shaders/mg_prolong.wgsl"),
            Kernel::MgCoarse => include_str!("../../../shaders/mg_coarse.wgsl"),
            Kernel::MgReduceNorm => include_str!("../../../shaders/mg_reduce_norm.wgsl"),
            Kernel::MgReduceRz => include_str!("../../../shaders/mg_reduce_rz.wgsl"),
            Kernel::DipoleRefit => include_str!("../../../shaders/dipole_refit.wgsl"),
            Kernel::DipolePull => include_str!("../../../shaders/dipole_pull.wgsl"),
            Kernel::DipoleTraverse => include_str!("../../../shaders/dipole_traverse.wgsl"),
            Kernel::DipolePush => include_str!("../../../shaders/dipole_push.wgsl"),
            Kernel::RadSweep => include_str!("../../../shaders/rad_sweep.wgsl"),
            Kernel::PrtRelight => include_str!("../../../shaders/prt_relight.wgsl"),
            Kernel::PrtCombine => include_str!("../../../shaders/prt_combine.wgsl"),
            Kernel::RelaxJacobi => include_str!("../../../shaders/relax_jacobi.wgsl"),
            Kernel::RelaxGaussSeidel => include_str!("../../../shaders/relax_gs.wgsl"),
        }
    }

    /// Whether the kernel is one of the hierarchical dipole's (they share `dipole_common.wgsl`).
    #[must_use]
    pub fn is_dipole(self) -> bool {
        matches!(self, Kernel::DipoleRefit | Kernel::DipolePull | Kernel::DipoleTraverse | Kernel::DipolePush)
    }

    /// The complete module source: `common.wgsl` (and for the dipole's kernels
    /// `dipole_common.wgsl`) followed by the kernel's file.
    #[must_use]
    pub fn source(self) -> String {
        if self.is_dipole() {
            format!("{COMMON}\n{DIPOLE_COMMON}\n{}", self.body())
        } else {
            format!("{COMMON}\n{}", self.body())
        }
    }
}
