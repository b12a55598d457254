//! `transcut bench radiosity`: the translucent radiosity of a scene file through the bake and its
//! session ([`super::radiosity_coupled`], `"coupled"`), and first the radiosity stage
//! (`transcut::radiosity`, `"entries"`) on an opaque Cornell
//! box, the scene of design/radiosity.md §3.8 with the block diffuse: a 200 mm box open at the
//! front (white 0.73, the left wall red, the right green), a 60 × 60 × 120 mm block on the floor
//! (white) and a point light under the ceiling, its direct light shadowed through the patches'
//! BVH. Per patch size: patches, nonzeros and memory of F, the form factors' time, and Jacobi
//! and Gauss–Seidel and BiCGSTAB to 1e-3 with their sweeps and energy defect, and on the
//! `--backend`'s GPU the Jacobi's sweeps (`GpuRadiosity`) against the CPU's.

use std::time::Instant;

use serde::Serialize;
use transcut::gpu::{Backend, GpuContext, GpuError, GpuRadiosity};
use transcut::radiosity::{
    refine_to_edge_length, solve, FormFactorOptions, FormFactors, Iteration, Opaque, PatchSet, SolveOptions, Surface,
};
use transcut::DVec3;

use super::args::BenchArgs;
use super::stats::{median, ms, peak_rss_mib, reset_peak_rss, rss_mib};

/// The box's side and the block's size (mm).
const SIDE: f64 = 200.0;
const BLOCK: [f64; 3] = [60.0, 60.0, 120.0];
const WHITE: [f64; 3] = [0.73; 3];
const RED: [f64; 3] = [0.63, 0.065, 0.05];
const GREEN: [f64; 3] = [0.14, 0.45, 0.09];
/// The point light's intensity (W/sr, mm units: E = I cos θ/d²).
const INTENSITY: f64 = 4.0e4;

#[derive(Serialize)]
struct Entry {
    patch_size_mm: f64,
    patches: usize,
    nonzeros: usize,
    nonzeros_per_patch: f64,
    form_factor_mib: f64,
    median_form_factor_ms: f64,
    median_jacobi_ms: f64,
    jacobi_sweeps: usize,
    median_gauss_seidel_ms: f64,
    gauss_seidel_sweeps: usize,
    jacobi_to_gauss_seidel: f64,
    /// BiCGSTAB to the same tolerance (two applications of F an iteration).
    median_bicgstab_ms: f64,
    bicgstab_iterations: usize,
    jacobi_to_bicgstab: f64,
    energy_defect: f64,
    /// The Jacobi's sweeps on the `--backend`'s GPU (`GpuRadiosity::jacobi`, F uploaded once,
    /// not timed): the time of the CPU's sweeps, the device's, their ratio and agreement.
    gpu: Option<GpuEntry>,
    /// Why the GPU sweeps were not measured at this size (e.g. F larger than a device buffer).
    gpu_skipped: Option<String>,
    /// Resident memory when this size started, and its peak while it ran (`None` where the
    /// peak cannot be started again, so it would be an earlier size's).
    start_rss_mib: Option<f64>,
    peak_rss_mib: Option<f64>,
}

#[derive(Serialize)]
struct GpuEntry {
    sweeps: usize,
    median_upload_ms: f64,
    median_cpu_sweeps_ms: f64,
    median_gpu_sweeps_ms: f64,
    cpu_to_gpu: f64,
    relative_rms: f64,
}

/// A surface: positions and counter-clockwise triangles.
type Mesh = (Vec<DVec3>, Vec<[u32; 3]>);

/// A quad a → b → c → d (counter-clockwise about its front) as two triangles.
fn quad(corners: [DVec3; 4]) -> Mesh {
    (corners.to_vec(), vec![[0, 1, 2], [0, 2, 3]])
}

/// The scene's surfaces (facing into the box, the block's outwards) and their albedos.
fn scene() -> Vec<(Mesh, [f64; 3])> {
    let p = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    let s = SIDE;
    let mut out = vec![
        (quad([p(0., 0., 0.), p(s, 0., 0.), p(s, s, 0.), p(0., s, 0.)]), WHITE),
        (quad([p(0., 0., s), p(0., s, s), p(s, s, s), p(s, 0., s)]), WHITE),
        (quad([p(0., 0., 0.), p(0., s, 0.), p(0., s, s), p(0., 0., s)]), RED),
        (quad([p(s, 0., 0.), p(s, 0., s), p(s, s, s), p(s, s, 0.)]), GREEN),
        (quad([p(0., s, 0.), p(s, s, 0.), p(s, s, s), p(0., s, s)]), WHITE),
    ];
    let (lo, hi) = (p(0.5 * (s - BLOCK[0]), 0.5 * (s - BLOCK[1]), 0.0), p(0.5 * (s + BLOCK[0]), 0.5 * (s + BLOCK[1]), BLOCK[2]));
    let c = |i: usize| {
        p(if i & 1 == 0 { lo.x } else { hi.x }, if i & 2 == 0 { lo.y } else { hi.y }, if i & 4 == 0 { lo.z } else { hi.z })
    };
    for face in [[4, 5, 7, 6], [0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3]] {
        out.push((quad(face.map(c)), WHITE));
    }
    out
}

/// The GPU sweeps' times over the runs of one patch size.
#[derive(Default)]
struct GpuTimes {
    upload: Vec<f64>,
    cpu: Vec<f64>,
    gpu: Vec<f64>,
    relative_rms: f64,
    /// Why the device could not take this size.
    skipped: Option<String>,
}

/// Sweeps per measurement (the Jacobi's to 1e-3 on this box, about).
const GPU_SWEEPS: usize = 10;

impl GpuTimes {
    /// Times `GPU_SWEEPS` Jacobi sweeps from nothing on the device and on the CPU (the solver's
    /// Jacobi with that count of bounces, so one sweep fewer), and their agreement.
    fn measure(
        &mut self,
        ctx: &GpuContext,
        f: &FormFactors,
        patches: &PatchSet,
        albedo: &[[f64; 3]],
        direct: &[[f64; 3]],
        emission: &[[f64; 3]],
    ) -> anyhow::Result<()> {
        let n = patches.len();
        let t = Instant::now();
        let opaque = Opaque { albedo, direct, emission };
        let gpu = match GpuRadiosity::new(ctx, f, &opaque, &vec![false; n]) {
            Ok(gpu) => gpu,
            Err(e @ GpuError::TooLarge { .. }) => {
                self.skipped = Some(e.to_string());
                return Ok(());
            }
            Err(e) => return Err(e.into()),
        };
        self.upload.push(ms(t));
        let zero = vec![[0.0; 3]; n];
        let t = Instant::now();
        let on_device = gpu.jacobi(&zero, GPU_SWEEPS)?;
        self.gpu.push(ms(t));
        let options = SolveOptions { bounces: Some(GPU_SWEEPS), ..SolveOptions::default() };
        let t = Instant::now();
        let cpu = solve(f, patches.areas(), albedo, direct, emission, &options, &|| true)?;
        self.cpu.push(ms(t));
        self.relative_rms = super::stats::relative_error(&on_device, &cpu.radiosity);
        Ok(())
    }

    fn entry(self) -> Option<GpuEntry> {
        (!self.gpu.is_empty()).then(|| {
            let (cpu, gpu) = (median(self.cpu), median(self.gpu));
            GpuEntry {
                sweeps: GPU_SWEEPS,
                median_upload_ms: median(self.upload),
                median_cpu_sweeps_ms: cpu,
                median_gpu_sweeps_ms: gpu,
                cpu_to_gpu: cpu / gpu,
                relative_rms: self.relative_rms,
            }
        })
    }
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let light = DVec3::new(0.5 * SIDE, 0.5 * SIDE, SIDE - 10.0);
    let context = match args.backend {
        Backend::Cpu => Err("backend cpu: the GPU was not asked for".to_owned()),
        Backend::Gpu => Ok(GpuContext::shared()?),
        Backend::Auto => GpuContext::shared().map_err(|e| e.to_string()),
    };
    let mut entries = Vec::new();
    for &h in &args.patch_sizes {
        let (start_rss_mib, reset) = (rss_mib(), reset_peak_rss());
        let surfaces = scene()
            .into_iter()
            .map(|((p, t), albedo)| refine_to_edge_length(&p, &t, h).map(|m| (m, albedo)))
            .collect::<Result<Vec<_>, _>>()?;
        let views: Vec<Surface> =
            surfaces.iter().map(|((p, t), _)| Surface { positions: p, triangles: t, two_sided: false }).collect();
        let patches = PatchSet::new(&views)?;
        let n = patches.len();
        let albedo: Vec<[f64; 3]> = (0..n).map(|i| surfaces[patches.surface_of(i)].1).collect();
        let bias = 1e-6 * patches.diagonal();
        let direct: Vec<[f64; 3]> = patches
            .positions()
            .iter()
            .zip(patches.normals())
            .map(|(&x, &normal)| {
                let to = light - x;
                let (d, cos) = (to.length(), normal.dot(to) / to.length());
                let seen = cos > 0.0 && !patches.bvh().occluded(x + bias * normal, to / d, bias, d);
                [if seen { INTENSITY * cos / (d * d) } else { 0.0 }; 3]
            })
            .collect();
        let emission = vec![[0.0; 3]; n];
        let (mut ff_ms, mut jacobi_ms, mut gs_ms) = (Vec::new(), Vec::new(), Vec::new());
        let (mut jacobi_sweeps, mut gs_sweeps, mut defect, mut nonzeros, mut bytes) = (0, 0, 0.0, 0, 0);
        let (mut krylov_ms, mut krylov_iterations) = (Vec::new(), 0);
        let mut device = GpuTimes::default();
        for _ in 0..args.runs {
            let t = Instant::now();
            let f = FormFactors::gather(&patches, &FormFactorOptions::default(), &|| true)?;
            ff_ms.push(ms(t));
            if let Ok(ctx) = &context {
                device.measure(ctx, &f, &patches, &albedo, &direct, &emission)?;
            }
            (nonzeros, bytes) = (f.nonzeros(), f.bytes());
            for (iteration, times) in
                [(Iteration::Jacobi, &mut jacobi_ms), (Iteration::GaussSeidel, &mut gs_ms), (Iteration::BiCgStab, &mut krylov_ms)]
            {
                let options = SolveOptions { iteration, ..SolveOptions::default() };
                let t = Instant::now();
                let s = solve(&f, patches.areas(), &albedo, &direct, &emission, &options, &|| true)?;
                times.push(ms(t));
                match iteration {
                    Iteration::Jacobi => (jacobi_sweeps, defect) = (s.iterations, s.energy.defect()),
                    Iteration::GaussSeidel => gs_sweeps = s.iterations,
                    _ => krylov_iterations = s.iterations,
                }
            }
        }
        let (jacobi, gs, krylov) = (median(jacobi_ms), median(gs_ms), median(krylov_ms));
        entries.push(Entry {
            patch_size_mm: h,
            patches: n,
            nonzeros,
            nonzeros_per_patch: nonzeros as f64 / n as f64,
            form_factor_mib: bytes as f64 / (1024.0 * 1024.0),
            median_form_factor_ms: median(ff_ms),
            median_jacobi_ms: jacobi,
            jacobi_sweeps,
            median_gauss_seidel_ms: gs,
            gauss_seidel_sweeps: gs_sweeps,
            jacobi_to_gauss_seidel: jacobi / gs,
            median_bicgstab_ms: krylov,
            bicgstab_iterations: krylov_iterations,
            jacobi_to_bicgstab: jacobi / krylov,
            energy_defect: defect,
            gpu_skipped: device.skipped.clone(),
            gpu: device.entry(),
            start_rss_mib,
            peak_rss_mib: peak_rss_mib().filter(|_| reset),
        });
    }
    let coupled = super::radiosity_coupled::run(&args.scene, &args.patch_sizes, args.radiosity_tets, args.runs)?;
    let report = serde_json::json!({
        "suite": "radiosity",
        "scene": "Cornell box, 200 mm, open front, diffuse 60 x 60 x 120 mm block, point light 10 mm under the ceiling",
        "rays_per_patch": FormFactorOptions::default().rays_per_patch,
        "tolerance": SolveOptions::default().tolerance,
        "gpu_device": context.as_ref().map_or_else(|e| serde_json::json!({ "fallback": e }), |c| {
            serde_json::json!({ "name": c.device_name(), "software": c.is_software() })
        }),
        "threads": rayon::current_num_threads(),
        "runs": args.runs,
        "entries": entries,
        "coupled_scene": args.scene.display().to_string(),
        "coupled": coupled,
    });
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}
