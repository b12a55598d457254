//! The radiosity bake and its session with the iteration's gathers F B on the device
//! (`RadiosityOptions::backend`, `gpu::GpuRadiosity` as a `radiosity::Gather`) against the same
//! bake on the CPU: the radiosity per patch, the sweep counts, a relight, BiCGSTAB; Gauss–Seidel
//! under the GPU backend sweeps on the CPU and says so; `auto` never takes a software adapter.
//! The CPU bake is the reference: the device holds F and B in f32, the CPU in f64.
//!
//! These tests need a GPU adapter (lavapipe where no GPU is present; see `gpu_common`).
#![cfg(feature = "gpu")]

use crate::gpu_common;
use gpu_common::{device, lock};

use transcut::gpu::{Backend, GpuRadiosity};
use transcut::light::Light;
use transcut::mesh::{icosphere, TriMesh};
use transcut::methods::RadiosityStats;
use transcut::optics::Medium;
use transcut::radiosity::{FormFactorOptions, FormFactors, Gather, Iteration, PatchSet, SolveOptions, Surface};
use transcut::DVec3;
use transcut::{
    BakeOptions, Diffuse, Object, ProfileScatteringOptions, Progress, RadiosityOptions, Scene, Session, Sides,
    TranslucentScattering,
};

/// √(Σ|a − b|² / Σ|b|²), the worst channel of those not all zero.
fn relative_rms(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    assert_eq!(a.len(), b.len());
    (0..3)
        .filter_map(|c| {
            let num: f64 = a.iter().zip(b).map(|(x, y)| (x[c] - y[c]).powi(2)).sum();
            let den: f64 = b.iter().map(|y| y[c] * y[c]).sum();
            (den > 0.0).then(|| (num / den).sqrt())
        })
        .fold(0.0, f64::max)
}

/// A 100 mm square at height `z`, facing up or down.
fn square(name: &str, z: f64, up: bool, albedo: [f64; 3]) -> Object {
    let h = 50.0;
    let corners = [[-h, -h, z], [h, -h, z], [h, h, z], [-h, h, z]];
    let triangles: &[u32] = if up { &[0, 1, 2, 0, 2, 3] } else { &[0, 2, 1, 0, 3, 2] };
    let mesh = TriMesh::from_triangles(&corners, triangles).unwrap();
    Object::diffuse(name, mesh, Diffuse { sides: Sides::Front, ..Diffuse::new(albedo) }, 1.0)
}

/// A red floor and a white ceiling facing each other, a small marble ball between them, lit by
/// a point light under the ceiling.
fn scene(light: DVec3) -> Scene {
    let marble = Medium { eta: 1.3, ..Medium::preset("marble").unwrap() };
    Scene {
        objects: vec![
            square("floor", -12.0, true, [0.7, 0.3, 0.2]),
            square("ceiling", 40.0, false, [0.8, 0.8, 0.75]),
            Object::new("ball", icosphere(10.0, 2), marble, 1.0),
        ],
        lights: vec![Light::Point { position: light, intensity: [2000.0, 1800.0, 1500.0] }],
    }
}

const LIGHT: DVec3 = DVec3::new(20.0, 10.0, 25.0);

/// The radiosity options of these tests: 8 mm patches, the half-space profile S (no tets), a
/// tight tolerance so that the sweeps run long enough to show the f32 gathers' effect.
fn options(iteration: Iteration, backend: Backend) -> BakeOptions {
    BakeOptions::with_method(RadiosityOptions {
        patch_size_mm: Some(8.0),
        solve: SolveOptions { iteration, tolerance: 1e-7, ..SolveOptions::default() },
        scattering: TranslucentScattering::Profile(ProfileScatteringOptions::default()),
        backend: Some(backend),
        ..RadiosityOptions::default()
    })
}

fn baked(iteration: Iteration, backend: Backend) -> Session {
    Session::bake(&scene(LIGHT), &options(iteration, backend), Progress::none()).unwrap()
}

fn stats(session: &Session) -> RadiosityStats {
    session.radiosity().unwrap().stats().clone()
}

/// Every object's radiance on its patches (a fixed linear map of B per patch: B/π on the
/// squares, the profile's radiance factor times B on the ball), all objects in one list.
fn patch_radiance(session: &Session) -> Vec<[f64; 3]> {
    let r = session.radiosity().unwrap();
    (0..r.len()).flat_map(|i| r.patch_radiance(i).unwrap().to_vec()).collect()
}

/// The two sessions agree per patch to `tolerance` relative RMS (f32 on the device).
fn assert_agree(gpu: &Session, cpu: &Session, tolerance: f64, what: &str) -> f64 {
    let e = relative_rms(&patch_radiance(gpu), &patch_radiance(cpu));
    assert!(e <= tolerance, "{what}: the GPU's radiosity is {e} relative RMS off the CPU's");
    e
}

#[test]
fn the_device_gather_matches_the_cpu_and_reuses_its_buffers() {
    let Some(ctx) = device() else { return };
    let _guard = lock();
    let mesh = icosphere(10.0, 3);
    let inward: Vec<[u32; 3]> = mesh.triangles().iter().map(|t| [t[0], t[2], t[1]]).collect();
    let patches = PatchSet::new(&[Surface { positions: mesh.positions(), triangles: &inward, two_sided: false }]).unwrap();
    let factors =
        FormFactors::gather(&patches, &FormFactorOptions { rays_per_patch: 256, ..Default::default() }, &|| true).unwrap();
    let gpu = GpuRadiosity::for_gather(ctx, &factors).unwrap();
    assert_eq!(gpu.patches(), factors.len());
    let n = factors.len();
    let b: Vec<[f64; 3]> = (0..n).map(|i| [1.0 + (i % 7) as f64, 2.0 + 0.01 * i as f64, 0.5 * (i % 2) as f64]).collect();
    let first = gpu.gather(&b).unwrap();
    let e = relative_rms(&first, &factors.gather(&b).unwrap());
    assert!(e <= 1e-6, "one gather: {e} relative RMS off the CPU's");
    let created = ctx.buffers_created();
    let c: Vec<[f64; 3]> = b.iter().map(|x| [x[2], x[0], x[1]]).collect();
    let second = gpu.gather(&c).unwrap();
    assert!(relative_rms(&second, &factors.gather(&c).unwrap()) <= 1e-6);
    assert_eq!(ctx.buffers_created(), created, "a second gather makes no device buffer");
    assert!(gpu.gather(&b[1..]).is_err(), "a radiosity of another length is refused");
}

#[test]
fn a_jacobi_bake_and_its_relight_on_the_gpu_match_the_cpu() {
    let Some(ctx) = device() else { return };
    let _guard = lock();
    let mut cpu = baked(Iteration::Jacobi, Backend::Cpu);
    let mut gpu = baked(Iteration::Jacobi, Backend::Gpu);
    let (c, g) = (stats(&cpu), stats(&gpu));
    assert_eq!((c.device.as_deref(), c.device_fallback.as_deref()), (None, None), "the CPU bake: {c:?}");
    assert_eq!(g.device.as_deref(), Some(ctx.device_name()), "the GPU bake names its device: {g:?}");
    assert_eq!(g.device_fallback, None);
    let e = assert_agree(&gpu, &cpu, 1e-6, "the bake");
    assert!(c.iterations >= 5, "a bake of {} sweeps shows little", c.iterations);
    assert!(c.iterations.abs_diff(g.iterations) <= 1, "sweeps: CPU {}, GPU {}", c.iterations, g.iterations);
    assert!(g.estimated_error <= 1e-7 && (g.energy_defect - c.energy_defect).abs() <= 1e-5, "{g:?} against {c:?}");
    eprintln!("jacobi bake: {e:.2e} relative RMS, {} / {} sweeps (CPU / GPU)", c.iterations, g.iterations);

    // The light moved: a warm-started solve on each, on the same devices.
    let moved = scene(LIGHT + DVec3::new(-15.0, 5.0, 0.0)).lights;
    cpu.relight(&moved, Progress::none()).unwrap();
    gpu.relight(&moved, Progress::none()).unwrap();
    let (c, g) = (stats(&cpu), stats(&gpu));
    assert_eq!(g.device.as_deref(), Some(ctx.device_name()), "the relight gathers on the device: {g:?}");
    let e = assert_agree(&gpu, &cpu, 1e-6, "the relight");
    assert!(c.iterations.abs_diff(g.iterations) <= 1, "relight sweeps: CPU {}, GPU {}", c.iterations, g.iterations);
    eprintln!("jacobi relight: {e:.2e} relative RMS, {} / {} sweeps", c.iterations, g.iterations);
}

#[test]
fn bicgstab_on_the_gpu_matches_the_cpu() {
    let Some(ctx) = device() else { return };
    let _guard = lock();
    let cpu = baked(Iteration::BiCgStab, Backend::Cpu);
    let gpu = baked(Iteration::BiCgStab, Backend::Gpu);
    let (c, g) = (stats(&cpu), stats(&gpu));
    assert_eq!(g.device.as_deref(), Some(ctx.device_name()), "{g:?}");
    let e = assert_agree(&gpu, &cpu, 1e-6, "BiCGSTAB");
    assert!(c.iterations.abs_diff(g.iterations) <= 1, "iterations: CPU {}, GPU {}", c.iterations, g.iterations);
    eprintln!("bicgstab: {e:.2e} relative RMS, {} / {} iterations", c.iterations, g.iterations);
}

#[test]
fn gauss_seidel_under_the_gpu_backend_sweeps_on_the_cpu_and_says_so() {
    let Some(_ctx) = device() else { return };
    let _guard = lock();
    let cpu = baked(Iteration::GaussSeidel, Backend::Cpu);
    let gpu = baked(Iteration::GaussSeidel, Backend::Gpu);
    let (c, g) = (stats(&cpu), stats(&gpu));
    assert_eq!(c.device_fallback, None, "the CPU backend asked for nothing else");
    assert_eq!(g.device, None, "Gauss–Seidel gathers on the CPU: {g:?}");
    assert!(g.device_fallback.as_deref().is_some_and(|f| f.contains("Gauss–Seidel")), "{g:?}");
    // The same CPU path: the same answer to the rounding of parallel sums.
    assert_agree(&gpu, &cpu, 1e-12, "Gauss–Seidel");
    assert_eq!(c.iterations, g.iterations);
}

#[test]
fn auto_takes_no_software_adapter() {
    let Some(ctx) = device() else { return };
    let _guard = lock();
    let auto = stats(&baked(Iteration::Jacobi, Backend::Auto));
    if ctx.is_software() {
        assert_eq!(auto.device, None, "auto with only {} stays on the CPU: {auto:?}", ctx.device_name());
        let why = auto.device_fallback.as_deref().unwrap_or_default();
        assert!(why.contains("software") || why.contains("no GPU device node"), "auto says why: {why:?}");
        // Gauss–Seidel under auto: the reason is still that there is no GPU to use.
        let seidel = stats(&baked(Iteration::GaussSeidel, Backend::Auto));
        assert_eq!((seidel.device, seidel.device_fallback.as_deref()), (None, Some(why)));
    } else {
        eprintln!("a hardware GPU ({}) is present: auto uses it", ctx.device_name());
        assert_eq!(auto.device.as_deref(), Some(ctx.device_name()), "{auto:?}");
    }
}
