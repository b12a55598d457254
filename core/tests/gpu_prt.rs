//! The PRT relight on the device (`gpu::GpuPrt`, `shaders/prt_relight.wgsl`,
//! `shaders/prt_combine.wgsl`) against its CPU twins (design/prt.md §7: ≤ 1e-5 relative):
//!
//! - the product with the Haar-transformed irradiance against `Transfer::apply` on real
//!   transfers (an icosphere, 2¹⁰ samples, the near field) at several budgets, uncompressed
//!   included, under a structured light different per channel;
//! - the combine against C(η) Σₖ sₖ (Tₖ q)[v] in f64, clamp and clamp count included, through an
//!   output map with vertices without a receiver and receivers taken twice;
//! - bad input refused with an error, buffers kept across relights;
//! - a bake with `TRANSCUT_BACKEND=gpu` relit on the device, named in its statistics.
//!
//! The tolerances are relative to the magnitude the f32 sums round against: per value, the
//! difference over the sum of the absolute products (step · Σ |value · q| for the product,
//! C(η) Σₖ |sₖ (Tₖ q)[v]| for the combine); over all values, the relative RMS per channel.
//!
//! These tests need a GPU adapter (lavapipe where no GPU is present; see `gpu.rs`).
#![cfg(feature = "gpu")]

mod gpu_common;
use gpu_common::{device, lock};

use transcut::gpu::{GpuError, GpuPrt};
use transcut::mesh::{icosphere, TriMesh};
use transcut::methods::prt::radiance_per_exitance;
use transcut::optics::Medium;
use transcut::prt::{haar_irradiance, BasisSize, PrtOptions, RdBasis, SurfaceSamples, Transfer};
use transcut::DVec3;

/// The largest relative difference allowed (design/prt.md §7, "GPU twin").
const TOL: f64 = 1e-5;

/// The 10 mm icosphere (642 vertices) and 2¹⁰ samples on it.
fn sphere() -> (TriMesh, SurfaceSamples) {
    let mesh = icosphere(10.0, 3);
    let samples = SurfaceSamples::new(mesh.positions(), mesh.triangles(), 10, 3).unwrap();
    (mesh, samples)
}

/// The transfer from `samples` to every vertex of `mesh` at `budget` terms per vertex (K = 16,
/// the near field on).
fn transfer(mesh: &TriMesh, samples: &SurfaceSamples, budget: usize) -> Transfer {
    let options = PrtOptions { samples_log2: 10, terms_per_vertex: budget, ..PrtOptions::default() };
    let basis = RdBasis::get(BasisSize::K16);
    Transfer::precompute(mesh.positions(), mesh.positions(), mesh.triangles(), samples, basis, &options, &|_| Ok(())).unwrap()
}

/// A sun from one side, a dimmer one from another in the blue, a bright band in the green and a
/// little ambient light: non-uniform, different per channel, nowhere dark.
fn light(samples: &SurfaceSamples) -> Vec<[f64; 3]> {
    let sun = DVec3::new(0.3, -0.5, 0.8).normalize();
    let other = DVec3::new(-0.7, 0.6, 0.1).normalize();
    samples
        .positions
        .iter()
        .zip(&samples.normals)
        .map(|(p, n)| {
            let d = n.dot(sun).max(0.0);
            [3.0 * d + 0.1, 2.0 * d + if p.z.abs() < 2.0 { 1.5 } else { 0.05 }, 0.2 + n.dot(other).max(0.0)]
        })
        .collect()
}

/// Per row and channel, step · Σ |value · q[index][c]| over the row's terms: the magnitude the
/// f32 sum rounds against.
fn magnitudes(transfer: &Transfer, q_haar: &[[f32; 4]]) -> Vec<f64> {
    let mut out = vec![0.0; 3 * transfer.steps().len()];
    for (row, step) in transfer.steps().iter().enumerate() {
        for (index, value) in transfer.row_entries(row) {
            let e = q_haar[index as usize];
            for c in 0..3 {
                out[3 * row + c] += (f64::from(value) * f64::from(e[c])).abs() * f64::from(*step);
            }
        }
    }
    out
}

/// The worst |a − b| / bound over the values, and the worst channel's relative RMS (values
/// laid out channel-minor, as the transfer's product and Lo are).
fn errors(a: &[f64], b: &[f64], bound: &[f64]) -> (f64, f64) {
    let worst = a
        .iter()
        .zip(b)
        .zip(bound)
        .map(|((x, y), m)| if *m > 0.0 { (x - y).abs() / m } else { (x - y).abs() })
        .fold(0.0, f64::max);
    let rms = (0..3)
        .map(|c| {
            let num: f64 = a.iter().zip(b).skip(c).step_by(3).map(|(x, y)| (x - y).powi(2)).sum();
            let den: f64 = b.iter().skip(c).step_by(3).map(|y| y * y).sum();
            (num / den).sqrt()
        })
        .fold(0.0, f64::max);
    (worst, rms)
}

/// The CPU twin of the combine in f64: Lo, its clamp count and the magnitude of each sum.
fn combine_on_cpu(
    gathered: &[f64],
    weights: &[Vec<f64>; 3],
    per_exitance: f64,
    output: &[Option<u32>],
) -> (Vec<[f64; 3]>, usize, Vec<f64>) {
    let k = weights[0].len();
    let mut clamped = 0;
    let mut bound = Vec::new();
    let lo = output
        .iter()
        .map(|v| {
            let Some(v) = v else {
                bound.extend([0.0; 3]);
                return [0.0; 3];
            };
            let g = &gathered[*v as usize * k * 3..(*v as usize + 1) * k * 3];
            let lo = [0, 1, 2].map(|c| per_exitance * (0..k).map(|j| weights[c][j] * g[j * 3 + c]).sum::<f64>());
            bound.extend([0, 1, 2].map(|c| per_exitance * (0..k).map(|j| (weights[c][j] * g[j * 3 + c]).abs()).sum::<f64>()));
            clamped += usize::from(lo.iter().any(|x| *x < 0.0));
            lo.map(|x| x.max(0.0))
        })
        .collect();
    (lo, clamped, bound)
}

/// The product on the device equals `Transfer::apply` within 1e-5 of each row's magnitude, at
/// budgets from a few terms per row to every coefficient.
#[test]
fn the_product_matches_the_cpu_apply_at_every_budget() {
    let Some(ctx) = device() else { return };
    let _guard = lock();
    let (mesh, samples) = sphere();
    let q_haar = haar_irradiance(&light(&samples));
    for budget in [48, 1024, usize::MAX] {
        let transfer = transfer(&mesh, &samples, budget);
        let mut cpu = vec![0.0; transfer.vertices() * transfer.basis_terms() * 3];
        transfer.apply(&q_haar, &mut cpu);
        let gpu = GpuPrt::new(ctx, &transfer).unwrap().apply(&q_haar).unwrap();
        assert_eq!(gpu.len(), cpu.len());
        let (worst, rms) = errors(&gpu, &cpu, &magnitudes(&transfer, &q_haar));
        eprintln!(
            "budget {budget}: {} terms, worst {worst:.2e} of the row magnitude, relative RMS {rms:.2e}",
            transfer.stats().terms
        );
        assert!(worst <= TOL && rms <= TOL, "budget {budget}: worst {worst:.2e}, RMS {rms:.2e}");
        assert!(cpu.iter().any(|x| *x < 0.0) && cpu.iter().any(|x| *x > 0.0), "rows of both signs are compared");
    }
}

/// Lo on the device equals C(η) Σₖ sₖ (Tₖ q)[v] of the CPU's product in f64, clamped at 0 with
/// the same count; one submission (`relight`) equals `apply` then `combine` bit for bit.
#[test]
fn the_combine_matches_the_cpu_radiance_and_its_clamp() {
    let Some(ctx) = device() else { return };
    let _guard = lock();
    let (mesh, samples) = sphere();
    let transfer = transfer(&mesh, &samples, 1024);
    let q_haar = haar_irradiance(&light(&samples));
    let mut gathered = vec![0.0; transfer.vertices() * transfer.basis_terms() * 3];
    transfer.apply(&q_haar, &mut gathered);
    let v = transfer.vertices() as u32;
    // Every vertex once in reverse, every 7th output without a receiver, every 5th vertex twice.
    let output: Vec<Option<u32>> = (0..v).rev().map(|i| (i % 7 != 3).then_some(i)).chain((0..v).step_by(5).map(Some)).collect();
    let marble = Medium { eta: 1.3, ..Medium::preset("marble").unwrap() };
    let skin = Medium { eta: 1.3, ..Medium::preset("skin1").unwrap() };
    let basis = RdBasis::get(BasisSize::K16);
    let per_exitance = radiance_per_exitance(marble.eta);
    let ((weights, _), (other, _)) = (basis.project_medium(&marble), basis.project_medium(&skin));
    // Marble less β skin, β the median ratio of their red Lo: negative Lo (the clamp) on about
    // half of the surface, where skin's shorter profile sees more light than marble's.
    let (lo_marble, _, _) = combine_on_cpu(&gathered, &weights, per_exitance, &output);
    let (lo_skin, _, _) = combine_on_cpu(&gathered, &other, per_exitance, &output);
    let mut ratios: Vec<f64> = lo_marble.iter().zip(&lo_skin).filter(|(_, b)| b[0] > 0.0).map(|(a, b)| a[0] / b[0]).collect();
    ratios.sort_by(f64::total_cmp);
    let beta = ratios[ratios.len() / 2];
    let difference: [Vec<f64>; 3] =
        std::array::from_fn(|c| weights[c].iter().zip(&other[c]).map(|(a, b)| a - beta * b).collect());
    let gpu = GpuPrt::new(ctx, &transfer).unwrap();
    gpu.apply(&q_haar).unwrap();
    for (name, w) in [("marble", &weights), ("marble - skin", &difference)] {
        let (want, want_clamped, bound) = combine_on_cpu(&gathered, w, per_exitance, &output);
        let (got, clamped) = gpu.combine(w, per_exitance, &output).unwrap();
        let (worst, rms) = errors(got.as_flattened(), want.as_flattened(), &bound);
        // Vertices whose clamp the f32 sums may decide otherwise: a channel within the
        // tolerance of zero before the clamp.
        let borderline = output
            .iter()
            .flatten()
            .filter(|&&v| {
                let g = &gathered[v as usize * 48..(v as usize + 1) * 48];
                (0..3).any(|c| {
                    let (sum, size) =
                        (0..16).fold((0.0, 0.0), |(s, m), j| (s + w[c][j] * g[3 * j + c], m + (w[c][j] * g[3 * j + c]).abs()));
                    sum.abs() <= TOL * size
                })
            })
            .count();
        eprintln!(
            "{name}: worst {worst:.2e} of the sum's magnitude, relative RMS {rms:.2e}, clamped {clamped} (CPU {want_clamped}, \
             {borderline} borderline)"
        );
        // The difference cancels by construction (Lo ≪ its terms), so only the per-value bound
        // against the terms' magnitude applies to it; the medium's own Lo also meets the RMS.
        assert!(worst <= TOL && (name != "marble" || rms <= TOL), "{name}: worst {worst:.2e}, RMS {rms:.2e}");
        assert!(clamped.abs_diff(want_clamped) <= borderline, "{name}: clamped {clamped}, CPU {want_clamped}");
        assert!(got.iter().zip(&output).all(|(lo, o)| o.is_some() || *lo == [0.0; 3]), "no receiver, no light");
        assert!(got.iter().flatten().all(|x| *x >= 0.0));
        if name == "marble" {
            assert_eq!(want_clamped, 0, "marble under light everywhere is positive everywhere");
        } else {
            assert!(want_clamped > output.len() / 5 && want_clamped < output.len() * 4 / 5, "{want_clamped} clamped");
        }
        let (once, once_clamped) = gpu.relight(&q_haar, w, per_exitance, &output).unwrap();
        assert_eq!((once, once_clamped), (got, clamped), "{name}: one submission, the same sums");
    }
}

/// Bad input is an error, never a panic or a read out of bounds; a relight allocates no new
/// device buffer once the first has run.
#[test]
fn bad_input_is_refused_and_buffers_are_kept() {
    let Some(ctx) = device() else { return };
    let _guard = lock();
    let (mesh, samples) = sphere();
    let transfer = transfer(&mesh, &samples, 64);
    let gpu = GpuPrt::new(ctx, &transfer).unwrap();
    let (weights, _) = RdBasis::get(BasisSize::K16).project_medium(&Medium::preset("marble").unwrap());
    let output: Vec<Option<u32>> = (0..transfer.vertices() as u32).map(Some).collect();
    let unsupported = |r: Result<_, GpuError>| matches!(r, Err(GpuError::Unsupported { .. }));
    assert!(unsupported(gpu.combine(&weights, 0.3, &output).map(|_| ())), "a combine before any product");
    assert!(unsupported(gpu.apply(&vec![[1.0; 4]; samples.len() - 1]).map(|_| ())), "a short irradiance");
    let q_haar = haar_irradiance(&light(&samples));
    let first = gpu.apply(&q_haar).unwrap();
    let short = [weights[0][..15].to_vec(), weights[1].clone(), weights[2].clone()];
    assert!(unsupported(gpu.combine(&short, 0.3, &output).map(|_| ())), "15 weights for 16 rows");
    let beyond = [Some(transfer.vertices() as u32)];
    assert!(unsupported(gpu.combine(&weights, 0.3, &beyond).map(|_| ())), "a receiver beyond the transfer");
    gpu.combine(&weights, 0.3, &output).unwrap();
    let created = ctx.buffers_created();
    assert_eq!(gpu.apply(&q_haar).unwrap(), first, "the device's sums do not depend on the run");
    gpu.combine(&weights, 0.3, &output).unwrap();
    assert_eq!(ctx.buffers_created(), created, "a second relight reuses the first one's buffers");
}

/// With `TRANSCUT_BACKEND=gpu` a PRT bake and its session's relights run their product on the
/// device (named in the statistics), within 1e-5 RMS of the CPU bake; a relight equals a fresh
/// device bake under the new light bit for bit.
#[test]
fn transcut_backend_gpu_relights_a_prt_bake_on_the_device() {
    use transcut::gpu::{Backend, BACKEND_ENV};
    use transcut::light::Light;
    use transcut::{bake, BakeOptions, Object, Progress, Scene, Session};
    let Some(ctx) = device() else { return };
    let _guard = lock();
    let sun = |d: DVec3| Light::Directional { direction: d, irradiance: [3.0; 3], angular_diameter_deg: 0.0 };
    let object = Object::new("ball", icosphere(10.0, 3), Medium::preset("marble").unwrap(), 1.0);
    let scene = |light| Scene { objects: vec![object.clone()], lights: vec![light] };
    let options = BakeOptions::with_method(PrtOptions { samples_log2: 12, terms_per_vertex: 512, ..PrtOptions::default() });
    let (first, moved) = (sun(DVec3::new(0.2, -0.3, -1.0)), sun(DVec3::new(-0.5, 0.4, -1.0)));
    std::env::set_var(BACKEND_ENV, "cpu");
    let cpu = bake(&scene(first.clone()), &options);
    std::env::set_var(BACKEND_ENV, "gpu");
    let on_device = bake(&scene(first.clone()), &options);
    let fresh_moved = bake(&scene(moved.clone()), &options);
    let session = Session::bake(&scene(first), &options, Progress::none());
    std::env::remove_var(BACKEND_ENV);

    let (cpu, on_device) = (cpu.unwrap(), on_device.unwrap());
    assert_eq!(cpu.objects[0].stats.backend, Backend::Cpu);
    let stats = &on_device.objects[0].stats;
    assert_eq!(stats.backend, Backend::Gpu);
    assert_eq!(stats.device.as_deref(), Some(ctx.device_name()));
    let (a, b) = (on_device.objects[0].radiance.as_flattened(), cpu.objects[0].radiance.as_flattened());
    let (_, rms) = errors(a, b, &vec![0.0; a.len()]);
    eprintln!("PRT bake on the device vs the CPU: relative RMS {rms:.2e}");
    assert!(rms <= TOL && rms > 0.0, "relative RMS {rms:.2e} (0 would mean the CPU ran)");
    let mut session = session.unwrap();
    session.relight(&[moved], Progress::none()).unwrap();
    assert_eq!(session.radiance(0).unwrap().unwrap(), fresh_moved.unwrap().objects[0].radiance);
}
