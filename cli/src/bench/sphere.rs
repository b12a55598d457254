//! `transcut bench sphere`: the diffusion solve's accuracy against the closed form of a uniformly
//! lit sphere (R = --radius-mm, 10 by default, `optics::UniformSphere`, the source of a constant
//! sky), for every --presets medium, --discretizations assembly and --grading mesh at each
//! --tets: the area-weighted RMS and mean of Lo(n)/Lo_exact − 1 over the surface per channel,
//! with σtr·h (the surface spacing against the diffusion length) and the mesher's and solver's
//! times. One mesh per grading and size serves every medium and assembly.

use std::time::Instant;

use anyhow::Context;
use serde::Serialize;
use transcut::diffusion::{solve, surface_radiance, DiffusionSystem};
use transcut::mesh::icosphere;
use transcut::mesher::{tetrahedralize_with, Grading, MesherOptions};
use transcut::optics::{f_ext, Medium, UniformSphere};
use transcut::sparse::SolveOptions;
use transcut::Progress;

use super::args::BenchArgs;
use super::stats::ms;

#[derive(Serialize)]
struct MediumEntry {
    preset: String,
    discretization: &'static str,
    /// σtr·h per channel, h the surface (finest) lattice spacing.
    sigma_tr_h: [f64; 3],
    /// The closed form's Lo(n) per channel (a negative value: the diffusion model itself
    /// predicts no light there, and the bake clamps to 0).
    exact_lo: [f64; 3],
    /// Area-weighted RMS of Lo/Lo_exact − 1 per channel.
    lo_rms: [f64; 3],
    /// Area-weighted mean of Lo/Lo_exact − 1 per channel.
    lo_mean: [f64; 3],
    assembly_ms: f64,
    solve_ms: f64,
    iterations: [usize; 3],
}

#[derive(Serialize)]
struct MeshEntry {
    target_tets: usize,
    /// 0: uniform; N: graded with N cubes of each size.
    grading: u32,
    tets: usize,
    vertices: usize,
    surface_spacing_mm: f64,
    cubes_per_level: Vec<usize>,
    mesh_ms: f64,
    media: Vec<MediumEntry>,
}

#[derive(Serialize)]
struct Report {
    suite: &'static str,
    radius_mm: f64,
    surface_triangles: usize,
    meshes: Vec<MeshEntry>,
}

/// Area-weighted RMS and mean of `got / exact − 1` per channel.
fn relative_errors(got: &[[f64; 3]], exact: [f64; 3], area: &[f64]) -> ([f64; 3], [f64; 3]) {
    let total: f64 = area.iter().sum();
    let (mut rms, mut mean) = ([0.0; 3], [0.0; 3]);
    for (lo, a) in got.iter().zip(area) {
        let w = a / total;
        for c in 0..3 {
            let e = lo[c] / exact[c] - 1.0;
            rms[c] += w * e * e;
            mean[c] += w * e;
        }
    }
    (rms.map(f64::sqrt), mean)
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let radius_mm = args.radius_mm;
    anyhow::ensure!(radius_mm > 0.0 && radius_mm.is_finite(), "--radius-mm must be positive, not {radius_mm}");
    let surface = icosphere(radius_mm, 6);
    let media: Vec<(String, Medium)> =
        args.presets.iter().map(|name| Ok((name.clone(), Medium::preset(name)?))).collect::<anyhow::Result<_>>()?;
    let mut meshes = Vec::new();
    for &target in &args.tets {
        // --grading, or uniform and 1, 2 and 4 cubes per size.
        for layers in args.gradings_or(&[0, 1, 2, 4]) {
            let grading = Grading::from_layers(layers);
            let start = Instant::now();
            let t =
                tetrahedralize_with(&surface, &MesherOptions { grading, ..MesherOptions::with_tets(target) }, Progress::none())
                    .with_context(|| format!("meshing the sphere at {target} tets, grading {layers}"))?;
            let mesh_ms = ms(start);
            let h = t.stats.spacing;
            let mut entries = Vec::new();
            for (name, m) in &media {
                let q = std::f64::consts::PI * (1.0 - f_ext(m.eta));
                let exact = UniformSphere::new(*m, radius_mm, [q; 3])?.surface_radiance(1.0);
                let tr = m.sigma_tr();
                for &discretization in &args.discretizations {
                    let start = Instant::now();
                    let mut sys = DiffusionSystem::new(&t.mesh, &[*m], 1.0, discretization)?;
                    let assembly_ms = ms(start);
                    sys.set_source(&vec![[q; 3]; sys.boundary().len()])?;
                    let start = Instant::now();
                    let solution = solve(&sys, None, &SolveOptions::default())?;
                    let solve_ms = ms(start);
                    let lo = surface_radiance(&sys, &solution.phi)?;
                    let (lo_rms, lo_mean) = relative_errors(&lo, exact, &sys.boundary().area_mm2);
                    eprintln!(
                        "{target} tets, grading {layers}: {name:9} {:8} σtr·h ({:.2} {:.2} {:.2}) Lo RMS ({:.2e} {:.2e} {:.2e})",
                        discretization.name(),
                        tr[0] * h,
                        tr[1] * h,
                        tr[2] * h,
                        lo_rms[0],
                        lo_rms[1],
                        lo_rms[2]
                    );
                    entries.push(MediumEntry {
                        preset: name.clone(),
                        discretization: discretization.name(),
                        sigma_tr_h: tr.map(|s| s * h),
                        exact_lo: exact,
                        lo_rms,
                        lo_mean,
                        assembly_ms,
                        solve_ms,
                        iterations: solution.stats.iterations,
                    });
                }
            }
            meshes.push(MeshEntry {
                target_tets: target,
                grading: layers,
                tets: t.stats.tets,
                vertices: t.stats.vertices,
                surface_spacing_mm: h,
                cubes_per_level: t.stats.cubes_per_level.clone(),
                mesh_ms,
                media: entries,
            });
        }
    }
    let report = Report { suite: "sphere", radius_mm, surface_triangles: surface.triangles().len(), meshes };
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_are_area_weighted() {
        // Two vertices, 10% high on three times the area of one 10% low: mean +5%, RMS 10%.
        let (rms, mean) = relative_errors(&[[1.1; 3], [0.9; 3]], [1.0; 3], &[3.0, 1.0]);
        for c in 0..3 {
            assert!((mean[c] - 0.05).abs() < 1e-12 && (rms[c] - 0.1).abs() < 1e-12, "{mean:?} {rms:?}");
        }
    }
}
