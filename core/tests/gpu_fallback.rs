//! Backend::Auto falls back to the CPU and says why when no GPU adapter can be had, and
//! Backend::Gpu fails with a clear error. No adapter is simulated by a name filter that matches
//! none (`TRANSCUT_GPU_ADAPTER`), set before the process-wide context is first created; one test
//! in this binary so nothing else races on the environment.
#![cfg(feature = "gpu")]

use transcut::diffusion::assemble;
use transcut::diffusion::SolverKind;
use transcut::gpu::{self, Backend, GpuContext, GpuError, SolveWith, ADAPTER_ENV};
use transcut::mesh::TetMesh;
use transcut::optics::Medium;
use transcut::sparse::SolveOptions;
use transcut::DVec3;

#[test]
fn auto_falls_back_to_the_cpu_and_gpu_fails_clearly_without_an_adapter() {
    std::env::set_var(ADAPTER_ENV, "no-such-adapter-anywhere");
    let corners: Vec<DVec3> = (0..8).map(|d| DVec3::new((d & 1) as f64, ((d >> 1) & 1) as f64, ((d >> 2) & 1) as f64)).collect();
    let tets = vec![[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]];
    let mesh = TetMesh::new(corners, tets, vec![]).unwrap();
    let mut sys = assemble(&mesh, &[Medium::preset("marble").unwrap()], 10.0).unwrap();
    sys.set_source(&vec![[1.0, 0.5, 0.25]; sys.boundary().len()]).unwrap();
    let options = SolveOptions::default();

    let e = GpuContext::shared().unwrap_err();
    assert!(matches!(e, GpuError::NoAdapter { .. }), "{e}");
    let message = e.to_string();
    assert!(message.contains("no GPU adapter") && message.contains("TRANSCUT_BACKEND=cpu"), "{message}");

    let (solution, report) = gpu::solve_on(Backend::Auto, SolveWith::Kind(SolverKind::SsorPcg), &sys, None, &options).unwrap();
    assert_eq!(report.used, Backend::Cpu);
    assert_eq!(report.requested, Backend::Auto);
    assert!(report.device.is_none());
    assert!(report.fallback.as_deref().is_some_and(|f| f.contains("no GPU adapter")), "{report:?}");
    let cpu = transcut::diffusion::solve(&sys, None, &options).unwrap();
    assert_eq!(solution.phi, cpu.phi);

    let e = gpu::solve_on(Backend::Gpu, SolveWith::Kind(SolverKind::SsorPcg), &sys, None, &options).unwrap_err();
    assert!(matches!(e, GpuError::NoAdapter { .. }), "{e}");
}
