//! The GPU path against its CPU twin: assembly entry by entry, SpMV and dot products,
//! the full solve within 1e-4 relative RMS of the CPU f64 solution on every shared mesh, an
//! exact small case against a dense direct solve, the radiance query, backend choice and errors.
//!
//! These tests need a GPU adapter; scripts/test.sh installs Mesa's lavapipe (software Vulkan) so
//! one exists everywhere. Without an adapter they FAIL with a message; `TRANSCUT_GPU_TESTS=skip`
//! skips them, loudly.
#![cfg(feature = "gpu")]
#![allow(clippy::needless_range_loop)] // per-channel loops read clearer with indices

use std::sync::OnceLock;

use crate::gpu_common;
use gpu_common::{device, lit, lock, rel_rms, scaled_tets, shared_mesh_dir, system_for};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use transcut::diffusion::SolverKind;
use transcut::diffusion::{
    assemble, assemble_consistent, assemble_fitted, solve, surface_radiance, DiffusionSystem, Discretization,
};
use transcut::gpu::{self, Backend, GpuError, SolveWith};
use transcut::mesh::TetMesh;
use transcut::optics::Medium;
use transcut::sparse::SolveOptions;
use transcut::DVec3;

/// The shared meshes, tetrahedralised at about `TETS` tets and scaled to 60 mm across.
const TETS: usize = 25_000;

fn shared_meshes() -> &'static [(String, TetMesh, f64)] {
    static MESHES: OnceLock<Vec<(String, TetMesh, f64)>> = OnceLock::new();
    MESHES.get_or_init(|| {
        let dir = shared_mesh_dir();
        let mut files: Vec<_> = std::fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("the shared meshes are expected in {}: {e}", dir.display()))
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|x| x == "obj" || x == "ply"))
            .collect();
        files.sort();
        assert!(files.len() >= 8, "expected the 8 shared meshes in {}", dir.display());
        files.iter().map(|path| scaled_tets(path, TETS)).collect()
    })
}

/// The worst |ΔM_ij| / max(M_ii, M_jj) between two matrices on one pattern, over the entries,
/// and the worst relative difference of the diagonals.
fn entry_differences(x: &transcut::sparse::CsrMatrix3, y: &transcut::sparse::CsrMatrix3) -> (f64, f64) {
    let p = y.pattern();
    let diag = y.diagonal();
    let (mut worst, mut worst_diag) = (0.0f64, 0.0f64);
    for i in 0..y.n() {
        for k in p.row_ptr()[i]..p.row_ptr()[i + 1] {
            let j = p.col_idx()[k] as usize;
            for c in 0..3 {
                let (a, b) = (x.values()[k][c], y.values()[k][c]);
                worst = worst.max((a - b).abs() / diag[i][c].max(diag[j][c]));
                if i == j {
                    worst_diag = worst_diag.max((a - b).abs() / b.abs());
                }
            }
        }
    }
    (worst, worst_diag)
}

/// TransCut's assembly (marble) and its fitted variants (skin1, whose blue boundary layer the
/// tets do not resolve, so that the fitting factors are far from 1; with and without the
/// layer's absorption on boundary rows) on the device, against the CPU's matrices entry by
/// entry (f32 geometry: relative to the larger diagonal of the entry's rows), and symmetric bit
/// for bit.
#[test]
fn gpu_assembly_matches_the_cpu_matrix_entry_by_entry() {
    let _g = lock();
    let Some(ctx) = device() else { return };
    for (name, mesh, scale) in shared_meshes() {
        let skin1 = [Medium::preset("skin1").unwrap()];
        let fitted = assemble_fitted(mesh, &skin1, *scale).unwrap();
        let (fitting, _) = entry_differences(assemble(mesh, &skin1, *scale).unwrap().matrix(), fitted.matrix());
        assert!(fitting > 1e-3, "{name}: the fitting changes skin1's matrix by only {fitting:e}");
        let layer = DiffusionSystem::new(mesh, &skin1, *scale, Discretization::FittedLayer).unwrap();
        let (_, absorption) = entry_differences(fitted.matrix(), layer.matrix());
        assert!(absorption > 1e-3, "{name}: the layer changes skin1's diagonal by only {absorption:e}");
        for (what, cpu) in [
            ("transcut, marble", system_for(mesh, *scale, "marble")),
            ("fitted, skin1", fitted),
            ("fitted with the layer, skin1", layer),
        ] {
            let gpu_m = gpu::assemble(ctx, &cpu).unwrap();
            let a = cpu.matrix();
            let (worst, worst_diag) = entry_differences(&gpu_m, a);
            eprintln!(
                "{name} ({what}): {} rows, worst |ΔM_ij|/max(M_ii, M_jj) = {worst:.2e}, worst diagonal {worst_diag:.2e}",
                a.n()
            );
            assert!(worst < 2e-5, "{name} ({what}): GPU assembly differs from the CPU's by {worst:e} (relative to the diagonal)");
            assert!(worst_diag < 2e-5, "{name} ({what}): GPU diagonal differs by {worst_diag:e}");
            // Symmetric bit for bit, as on the CPU (each row gathers its tets in the same order).
            let p = a.pattern();
            for i in 0..a.n() {
                for k in p.row_ptr()[i]..p.row_ptr()[i + 1] {
                    let j = p.col_idx()[k] as usize;
                    assert_eq!(gpu_m.get(i, j), gpu_m.get(j, i), "{name} ({what}): GPU matrix not symmetric at ({i}, {j})");
                }
            }
        }
    }
}

#[test]
fn gpu_spmv_and_dot_match_the_cpu() {
    let _g = lock();
    let Some(ctx) = device() else { return };
    let (name, mesh, scale) = &shared_meshes()[0];
    let sys = system_for(mesh, *scale, "skin1");
    let a = sys.matrix();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let x: Vec<[f64; 3]> =
        (0..a.n()).map(|_| [rng.random_range(-1.0..1.0), rng.random_range(0.0..2.0), rng.random_range(-3.0..1.0)]).collect();
    let y_cpu = a.mul_vec(&x).unwrap();
    let (y_gpu, xax) = gpu::spmv_dot(ctx, a, &x).unwrap();
    let scale_row: Vec<[f64; 3]> = (0..a.n())
        .map(|i| {
            let (s, e) = (a.pattern().row_ptr()[i], a.pattern().row_ptr()[i + 1]);
            [0, 1, 2].map(|c| (s..e).map(|k| (a.values()[k][c] * x[a.pattern().col_idx()[k] as usize][c]).abs()).sum::<f64>())
        })
        .collect();
    for i in 0..a.n() {
        for c in 0..3 {
            assert!(
                (y_gpu[i][c] - y_cpu[i][c]).abs() <= 1e-6 * scale_row[i][c] + 1e-30,
                "{name}: row {i} channel {c}: {} vs {}",
                y_gpu[i][c],
                y_cpu[i][c]
            );
        }
    }
    let xax_cpu = transcut::sparse::dot3(&x, &y_cpu);
    let abs_sum: [f64; 3] = [0, 1, 2].map(|c| x.iter().zip(&scale_row).map(|(xi, s)| xi[c].abs() * s[c]).sum());
    for c in 0..3 {
        assert!((xax[c] - xax_cpu[c]).abs() <= 1e-5 * abs_sum[c], "xᵀAx channel {c}: {} vs {}", xax[c], xax_cpu[c]);
    }
    // Dot products at sizes around the workgroup size and the 2D grid, against f64 sums.
    for n in [1usize, 255, 256, 257, 1000, 65_537, 300_001] {
        let a: Vec<[f64; 3]> = (0..n).map(|_| [rng.random_range(0.0..1.0), rng.random_range(-1.0..1.0), 1.0]).collect();
        let b: Vec<[f64; 3]> = (0..n).map(|_| [rng.random_range(0.0..1.0), rng.random_range(-1.0..1.0), 1.0]).collect();
        let g = gpu::dot(ctx, &a, &b).unwrap();
        let c = transcut::sparse::dot3(&a, &b);
        let abs: [f64; 3] = [0, 1, 2].map(|ch| a.iter().zip(&b).map(|(x, y)| (x[ch] * y[ch]).abs()).sum());
        for ch in 0..3 {
            assert!((g[ch] - c[ch]).abs() <= 1e-6 * abs[ch], "dot n = {n} channel {ch}: {} vs {}", g[ch], c[ch]);
        }
        assert_eq!(g[2], n as f64, "a sum of n ones is exact in f32 up to 2^24");
    }
    assert!(matches!(gpu::dot(ctx, &[[1.0; 3]], &[]), Err(GpuError::Diffusion(_))));
}

#[test]
fn gpu_solve_matches_the_cpu_f64_solution_on_every_shared_mesh() {
    let _g = lock();
    let Some(ctx) = device() else { return };
    for (k, (name, mesh, scale)) in shared_meshes().iter().enumerate() {
        // Media from the clearest (ketchup-like marble) to the most absorbing across meshes.
        let preset = ["marble", "skin1", "ketchup", "wholemilk", "apple", "marble", "skin2", "potato"][k % 8];
        let sys = system_for(mesh, *scale, preset);
        for tol in [1e-6, 1e-9] {
            let options = SolveOptions::default().with_tolerance(tol);
            let cpu = solve(&sys, None, &SolveOptions::default().with_tolerance(1e-12)).unwrap();
            let g = gpu::solve(ctx, &sys, None, &options).unwrap();
            let err = rel_rms(&g.solution.phi, &cpu.phi);
            eprintln!(
                "{name} ({preset}, {} vertices, tol {tol:e}): rel RMS vs CPU f64 {:.2e} {:.2e} {:.2e}, residual {:.1e} {:.1e} {:.1e}, iterations {:?}, rounds {}",
                sys.vertex_count(),
                err[0],
                err[1],
                err[2],
                g.solution.stats.relative_residual[0],
                g.solution.stats.relative_residual[1],
                g.solution.stats.relative_residual[2],
                g.solution.stats.iterations,
                g.stats.rounds
            );
            assert!(g.solution.stats.converged);
            assert!(g.stats.assembled_on_device);
            assert!(g.solution.stats.relative_residual.iter().all(|&r| r <= tol), "{name}: {:?}", g.solution.stats);
            assert!(err.iter().all(|&e| e < 1e-4), "{name} ({preset}, tol {tol:e}): GPU vs CPU relative RMS {err:?}");
            // The residual is the true f64 one: recompute it.
            let r = sys.matrix().mul_vec(&g.solution.phi).unwrap();
            let bn = transcut::sparse::norm3(sys.rhs());
            let rn = transcut::sparse::norm3(
                &r.iter().zip(sys.rhs()).map(|(a, b)| [b[0] - a[0], b[1] - a[1], b[2] - a[2]]).collect::<Vec<_>>(),
            );
            for c in 0..3 {
                assert!((rn[c] / bn[c] - g.solution.stats.relative_residual[c]).abs() <= 1e-3 * tol);
            }
        }
    }
}

#[test]
fn gpu_solve_is_exact_on_a_small_system_against_a_dense_direct_solve() {
    let _g = lock();
    let Some(ctx) = device() else { return };
    // A 3×3×3-cell cube of Kuhn-split cells, 64 vertices, lit from one side.
    let m = 3;
    let id = |x: usize, y: usize, z: usize| (x + (m + 1) * (y + (m + 1) * z)) as u32;
    let mut positions = Vec::new();
    for z in 0..=m {
        for y in 0..=m {
            for x in 0..=m {
                positions.push(DVec3::new(x as f64, y as f64, z as f64));
            }
        }
    }
    let mut tets = Vec::new();
    for z in 0..m {
        for y in 0..m {
            for x in 0..m {
                let c = |d: usize| id(x + (d & 1), y + ((d >> 1) & 1), z + ((d >> 2) & 1));
                for t in [[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]] {
                    tets.push(t.map(c));
                }
            }
        }
    }
    let mesh = TetMesh::new(positions, tets, vec![]).unwrap();
    for consistent in [false, true] {
        let media = [Medium::preset("skin1").unwrap()];
        let mut sys = if consistent { assemble_consistent(&mesh, &media, 2.0) } else { assemble(&mesh, &media, 2.0) }.unwrap();
        lit(&mut sys);
        let g = gpu::solve(ctx, &sys, None, &SolveOptions::default().with_tolerance(1e-13)).unwrap();
        assert_eq!(g.stats.assembled_on_device, !consistent);
        for c in 0..3 {
            let dense = sys.matrix().to_dense(c);
            let rhs = nalgebra::DVector::from_iterator(sys.vertex_count(), sys.rhs().iter().map(|b| b[c]));
            let exact = dense.lu().solve(&rhs).unwrap();
            let err =
                (0..sys.vertex_count()).map(|i| (g.solution.phi[i][c] - exact[i]).powi(2)).sum::<f64>().sqrt() / exact.norm();
            assert!(err < 1e-10, "consistent = {consistent}, channel {c}: relative error {err:e} against LU");
        }
    }
}

#[test]
fn gpu_radiance_matches_the_cpu() {
    let _g = lock();
    let Some(ctx) = device() else { return };
    let (_, mesh, scale) = &shared_meshes()[1];
    let sys = system_for(mesh, *scale, "marble");
    let phi = solve(&sys, None, &SolveOptions::default()).unwrap().phi;
    let cpu = surface_radiance(&sys, &phi).unwrap();
    let gpu_lo = gpu::surface_radiance(ctx, &sys, &phi).unwrap();
    assert_eq!(gpu_lo.len(), cpu.len());
    let err = rel_rms(&gpu_lo, &cpu);
    assert!(err.iter().all(|&e| e < 1e-6), "{err:?}");
    let mut bad = phi.clone();
    bad[sys.boundary().ids[3] as usize][1] = f64::NAN;
    assert!(matches!(gpu::surface_radiance(ctx, &sys, &bad), Err(GpuError::Diffusion(_))));
    assert!(matches!(gpu::surface_radiance(ctx, &sys, &phi[1..]), Err(GpuError::Diffusion(_))));
}

#[test]
fn buffers_are_reused_warm_starts_and_errors_match_the_cpu() {
    let _g = lock();
    let Some(ctx) = device() else { return };
    let (_, mesh, scale) = &shared_meshes()[2];
    let mut sys = system_for(mesh, *scale, "ketchup");
    let options = SolveOptions::default();
    let first = gpu::solve(ctx, &sys, None, &options).unwrap();
    let created = ctx.buffers_created();
    let again = gpu::solve(ctx, &sys, None, &options).unwrap();
    assert_eq!(ctx.buffers_created(), created, "a second solve of the same size allocates nothing");
    assert_eq!(again.solution.phi, first.solution.phi, "the GPU solve is deterministic");
    // Warm start from the solution: nothing to do.
    let warm = gpu::solve(ctx, &sys, Some(&first.solution.phi), &options).unwrap();
    assert_eq!(warm.stats.rounds, 0);
    assert_eq!(warm.solution.stats.iterations, [0; 3]);
    // Relighting on a resident solver: a dark channel is solved as zero, like the CPU.
    let solver = gpu::GpuSolver::new(ctx, &sys).unwrap();
    let q: Vec<[f64; 3]> = sys.source().iter().map(|q| [q[0], 0.0, 2.0 * q[2]]).collect();
    sys.set_source(&q).unwrap();
    let relit = solver.solve(&sys, Some(&first.solution.phi), &options).unwrap();
    let cpu = solve(&sys, None, &options.with_tolerance(1e-12)).unwrap();
    assert!(relit.solution.phi.iter().all(|p| p[1] == 0.0));
    let err = rel_rms(&relit.solution.phi, &cpu.phi);
    assert!(err[0] < 1e-4 && err[2] < 1e-4, "{err:?}");
    // Errors as on the CPU.
    let short = vec![[0.0; 3]; 3];
    assert!(matches!(gpu::solve(ctx, &sys, Some(&short), &options), Err(GpuError::Diffusion(_))));
    let mut nan = first.solution.phi.clone();
    nan[5][0] = f64::INFINITY;
    let e = gpu::solve(ctx, &sys, Some(&nan), &options).unwrap_err();
    assert!(e.to_string().contains("initial guess"), "{e}");
    let e = gpu::solve(ctx, &sys, None, &options.with_max_iterations(3)).unwrap_err();
    assert!(e.to_string().contains("converge"), "{e}");
}

#[test]
fn backend_choice_reports_what_ran() {
    let _g = lock();
    assert_eq!("GPU".parse::<Backend>().unwrap(), Backend::Gpu);
    assert_eq!(" cpu ".parse::<Backend>().unwrap(), Backend::Cpu);
    assert_eq!("auto".parse::<Backend>().unwrap(), Backend::Auto);
    let e = "cuda".parse::<Backend>().unwrap_err();
    assert!(e.to_string().contains("cuda") && e.to_string().contains("cpu, gpu, auto"), "{e}");
    let Some(ctx) = device() else { return };
    let (_, mesh, scale) = &shared_meshes()[3];
    let sys = system_for(mesh, *scale, "skin2");
    let options = SolveOptions::default();
    let (cpu, report) = gpu::solve_on(Backend::Cpu, SolveWith::Kind(SolverKind::SsorPcg), &sys, None, &options).unwrap();
    assert_eq!((report.used, report.device.clone(), report.fallback.clone()), (Backend::Cpu, None, None));
    let (sol, report) = gpu::solve_on(Backend::Gpu, SolveWith::Kind(SolverKind::SsorPcg), &sys, None, &options).unwrap();
    assert_eq!((report.requested, report.used), (Backend::Gpu, Backend::Gpu));
    assert_eq!(report.device.as_deref(), Some(ctx.device_name()));
    assert!(report.fallback.is_none());
    assert!(report.gpu.is_some());
    assert!(rel_rms(&sol.phi, &cpu.phi).iter().all(|&e| e < 1e-4));
    // Auto takes a hardware GPU, but not a software one (lavapipe), and says why.
    let (sol, report) = gpu::solve_on(Backend::Auto, SolveWith::Kind(SolverKind::SsorPcg), &sys, None, &options).unwrap();
    assert_eq!(report.requested, Backend::Auto);
    if let Some(no_gpu) = gpu::no_hardware_gpu() {
        // No GPU device node: Auto does not load the drivers at all.
        assert_eq!(report.used, Backend::Cpu);
        assert_eq!(report.fallback.as_deref(), Some(no_gpu.as_str()));
        assert!(no_gpu.contains("/dev/dri/renderD*"), "{no_gpu}");
        assert_eq!(sol.phi, cpu.phi);
    } else if ctx.is_software() {
        assert_eq!(report.used, Backend::Cpu);
        let why = report.fallback.as_deref().unwrap_or_default();
        assert!(why.contains("software") && why.contains(ctx.device_name()), "{why}");
        assert_eq!(sol.phi, cpu.phi);
    } else {
        assert_eq!(report.used, Backend::Gpu);
        assert!(report.fallback.is_none());
        assert!(rel_rms(&sol.phi, &cpu.phi).iter().all(|&e| e < 1e-4));
    }
}

/// The polygrid's finite-volume system (its own matrix, not a `DiffusionSystem`) on the device:
/// `solve_matrix_on` meets the CPU's f64 tolerance, and a bake by the polygrid method with the
/// finite-volume stencil on `Backend::Gpu` says it ran there and returns the CPU bake's radiance.
#[test]
fn the_polygrid_finite_volume_system_solves_on_the_gpu_as_on_the_cpu() {
    use transcut::light::Light;
    use transcut::polygrid::{cubed_sphere, PolygridSystem};
    use transcut::sparse::{pcg, Preconditioner, PreconditionerKind};
    use transcut::{bake, BakeOptions, Method, Object, PolygridOptions, Scene, Stencil, TransCutOptions};
    let _g = lock();
    let Some(ctx) = device() else { return };
    let marble = Medium::new([0.0021, 0.0041, 0.0071], [2.19, 2.62, 3.00], 1.3, 0.0).unwrap();
    let grid = cubed_sphere(16, DVec3::ZERO, 10.0).unwrap();
    let mut system = PolygridSystem::finite_volume(&grid, &vec![marble; grid.cells().len()], 1.0, None).unwrap();
    let q: Vec<[f64; 3]> = system.boundary().normal.iter().map(|n| [n.z.max(0.0); 3]).collect();
    system.set_source(&q).unwrap();
    let options = SolveOptions::default().with_tolerance(1e-10);
    let cpu = || {
        let pre = Preconditioner::new(system.matrix(), PreconditionerKind::Ssor).unwrap();
        let mut phi = vec![[0.0; 3]; system.rhs().len()];
        let stats = pcg(system.matrix(), system.rhs(), &mut phi, &pre, &options).unwrap();
        Ok(transcut::diffusion::Solution { phi, stats })
    };
    let (reference, _) = gpu::solve_matrix_on(Backend::Cpu, system.matrix(), system.rhs(), None, &options, cpu).unwrap();
    let unused = || -> Result<transcut::diffusion::Solution, GpuError> { unreachable!("the GPU was asked for") };
    let (on_gpu, report) = gpu::solve_matrix_on(Backend::Gpu, system.matrix(), system.rhs(), None, &options, unused).unwrap();
    assert_eq!((report.used, report.device.as_deref()), (Backend::Gpu, Some(ctx.device_name())));
    assert!(on_gpu.stats.relative_residual.iter().all(|&r| r <= 1e-10), "{:?}", on_gpu.stats);
    let d = rel_rms(&on_gpu.phi, &reference.phi);
    assert!(d.iter().all(|&e| e < 1e-8), "{d:?}");

    let sun = Light::Directional { direction: DVec3::new(0.3, -0.2, -1.0), irradiance: [3.0; 3], angular_diameter_deg: 0.0 };
    let scene =
        Scene { objects: vec![Object::new("ball", crate::common::uv_sphere(8.0, 64, 32), marble, 1.0)], lights: vec![sun] };
    let bake_on = |backend| {
        let solve = TransCutOptions { tolerance: 1e-9, backend: Some(backend), ..TransCutOptions::default() };
        let options = PolygridOptions { nodes: 8_000, stencil: Stencil::FiniteVolume, solve, ..PolygridOptions::default() };
        bake(&scene, &BakeOptions { method: Method::Polygrid(options), ..BakeOptions::default() }).unwrap().objects.remove(0)
    };
    let (cpu, on_gpu) = (bake_on(Backend::Cpu), bake_on(Backend::Gpu));
    assert_eq!((cpu.stats.backend, on_gpu.stats.backend), (Backend::Cpu, Backend::Gpu));
    let d = rel_rms(&on_gpu.radiance, &cpu.radiance);
    assert!(d.iter().all(|&e| e < 1e-6), "{d:?}");
}
