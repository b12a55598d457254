//! Translucent radiosity's iteration on the device (`gpu::GpuRadiosity`, `shaders/rad_sweep.wgsl`)
//! against its CPU twins (design/radiosity.md A12: ≤ 1e-4 relative RMS): one sweep's gathered
//! F B and opaque update against `FormFactors::apply`, sweeps on the device against the CPU's
//! Jacobi with a count of bounces, and the closed sphere's closed form reached on the device.
//!
//! These tests need a GPU adapter (lavapipe where no GPU is present; see `gpu.rs`).
#![cfg(feature = "gpu")]

use crate::gpu_common;
use gpu_common::{device, lock};

use transcut::gpu::GpuRadiosity;
use transcut::mesh::icosphere;
use transcut::radiosity::{solve, FormFactorOptions, FormFactors, Iteration, Opaque, PatchSet, SolveOptions, Surface};
use transcut::DVec3;

/// √(Σ|a − b|² / Σ|b|²), the worst channel of those not all zero.
fn relative_rms(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    (0..3)
        .filter_map(|c| {
            let num: f64 = a.iter().zip(b).map(|(x, y)| (x[c] - y[c]).powi(2)).sum();
            let den: f64 = b.iter().map(|y| y[c] * y[c]).sum();
            (den > 0.0).then(|| (num / den).sqrt())
        })
        .fold(0.0, f64::max)
}

/// The inside of a sphere of radius 10 (its triangles turned inwards), its patches and F.
fn closed_sphere() -> (PatchSet, FormFactors) {
    let mesh = icosphere(10.0, 3);
    let positions: Vec<DVec3> = mesh.positions().to_vec();
    let triangles: Vec<[u32; 3]> = mesh.triangles().iter().map(|t| [t[0], t[2], t[1]]).collect();
    let patches = PatchSet::new(&[Surface { positions: &positions, triangles: &triangles, two_sided: false }]).unwrap();
    let factors =
        FormFactors::gather(&patches, &FormFactorOptions { rays_per_patch: 256, ..Default::default() }, &|| true).unwrap();
    (patches, factors)
}

/// A point light's irradiance on the patches (no shadows inside a convex surface).
fn point_light(patches: &PatchSet) -> Vec<[f64; 3]> {
    let light = DVec3::new(2.0, -3.0, 1.5);
    patches
        .positions()
        .iter()
        .zip(patches.normals())
        .map(|(&x, &n)| {
            let d = light - x;
            [100.0 * n.dot(d).max(0.0) / d.length().powi(3), 50.0 * n.dot(d).max(0.0) / d.length().powi(3), 0.0]
        })
        .collect()
}

#[test]
fn one_sweep_matches_the_cpu_gather_and_update() {
    let Some(ctx) = device() else { return };
    let _guard = lock();
    let (patches, factors) = closed_sphere();
    let n = patches.len();
    let direct = point_light(&patches);
    let albedo: Vec<[f64; 3]> = (0..n).map(|i| [0.5 + 0.3 * (i % 3) as f64 / 2.0, 0.6, 0.4]).collect();
    let emission: Vec<[f64; 3]> = (0..n).map(|i| [0.0, 0.1 * (i % 5) as f64, 0.2]).collect();
    // Every third patch stands for a translucent object's: its update is the host's.
    let translucent: Vec<bool> = (0..n).map(|i| i % 3 == 0).collect();
    let opaque = Opaque { albedo: &albedo, direct: &direct, emission: &emission };
    let gpu = GpuRadiosity::new(ctx, &factors, &opaque, &translucent).unwrap();
    let b: Vec<[f64; 3]> = (0..n).map(|i| [1.0 + (i % 7) as f64, 2.0, 0.5 * (i % 2) as f64]).collect();
    let sweep = gpu.sweep(&b).unwrap();
    let gathered = factors.apply(&b);
    let want: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            if translucent[i] {
                [0.0; 3]
            } else {
                std::array::from_fn(|c| albedo[i][c] * (direct[i][c] + gathered[i][c]) + emission[i][c])
            }
        })
        .collect();
    let (e_gather, e_update) = (relative_rms(&sweep.gathered, &gathered), relative_rms(&sweep.radiosity, &want));
    assert!(e_gather <= 1e-4 && e_update <= 1e-4, "gathered {e_gather}, updated {e_update}");
    assert!(translucent.iter().zip(&sweep.radiosity).all(|(&t, b)| !t || *b == [0.0; 3]), "translucent rows are the host's");
}

#[test]
fn device_sweeps_match_the_cpu_jacobi_and_the_closed_form() {
    let Some(ctx) = device() else { return };
    let _guard = lock();
    let (patches, factors) = closed_sphere();
    let n = patches.len();
    let direct = point_light(&patches);
    let rho = 0.7;
    let (albedo, zero) = (vec![[rho; 3]; n], vec![[0.0; 3]; n]);
    let opaque = Opaque { albedo: &albedo, direct: &direct, emission: &zero };
    let gpu = GpuRadiosity::new(ctx, &factors, &opaque, &vec![false; n]).unwrap();
    // k sweeps from nothing are k bounces of the CPU's Jacobi.
    for bounces in [1, 4, 12] {
        let on_device = gpu.jacobi(&zero, bounces).unwrap();
        let options = SolveOptions { iteration: Iteration::Jacobi, bounces: Some(bounces), ..SolveOptions::default() };
        let cpu = solve(&factors, patches.areas(), &albedo, &direct, &zero, &options, &|| true).unwrap();
        let e = relative_rms(&on_device, &cpu.radiosity);
        assert!(e <= 1e-4, "{bounces} bounces: {e} RMS off the CPU");
    }
    // Converged (ρ^60 ≈ 5e-10): B = ρE_d + ρ²Ē/(1 − ρ) with Ē the mean irradiance (design §3.2).
    let b = gpu.jacobi(&zero, 60).unwrap();
    let areas = patches.areas();
    let mean: [f64; 3] =
        std::array::from_fn(|c| areas.iter().zip(&direct).map(|(a, e)| a * e[c]).sum::<f64>() / areas.iter().sum::<f64>());
    let want: Vec<[f64; 3]> =
        direct.iter().map(|e| std::array::from_fn(|c| rho * e[c] + rho * rho * mean[c] / (1.0 - rho))).collect();
    let worst = b.iter().zip(&want).flat_map(|(x, y)| (0..2).map(move |c| (x[c] - y[c]).abs() / y[c])).fold(0.0, f64::max);
    assert!(worst <= 0.02, "the closed sphere on the device: {worst} off the closed form at worst");
    assert!(b.iter().all(|x| x[2] == 0.0), "a dark channel stays dark");
}
