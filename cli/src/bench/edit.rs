//! `transcut bench edit`: the interactive edits of TransCut §5 and the Fig. 7 curve on one mesh.
//!
//! The input (default the Stanford bunny) is scaled to 60 mm, marble, lit by one sun from
//! (0, 1, 1) (irradiance 3, with shadows, as `transcut bake`), tetrahedralised once per size
//! and `--grading` (default 0, one spacing).
//! Per run, back to back:
//! - **cold bake**: TransCut's bake of the tet mesh ([`transcut::bake()`]: assembly, source,
//!   cold SSOR-PCG solve);
//! - **relight**: an [`Editor`] started from that bake (its default solver, aggregation
//!   MG-PCG, or `--solver`) relights after the sun moved 5° about x (warm start from the
//!   previous fluence): iterations and their ratio against a cold solve of the same system with
//!   the same solver, and times against a cold bake under the moved sun (the bake's SSOR-PCG
//!   from zero);
//! - **paint**: a stroke of 8 points across the front of the surface, Gaussian radius 2 mm, of
//!   an absorbing marble-like ink (rows rebuilt, tets changed, ms);
//! - **cut**: a plane through the centre of the bounds removing the back half (rebuild of the
//!   topology, hierarchy and matrix and the solve included, ms); then a **bite**: a ball of a
//!   fifth of the largest extent ([`Cutter::Solid`], an icosphere) centred on the front vertex
//!   nearest the middle, removed from what the plane kept. The cut's own steps (classify,
//!   separate, snap) are timed in `last.cut`.
//!
//! Medians over `--runs`. Then Fig. 7 ([`super::fig7`]) on the same tet mesh
//! (unshadowed sun, the reference solved to 1e-10): relative error against time for Jacobi
//! PCG, SSOR-PCG, the cascade and MG-PCG on the paper's hierarchy and on the aggregation, the
//! time to 1% and its ratio to the best single-level solver.

use std::time::Instant;

use anyhow::Context;
use serde::Serialize;
use transcut::diffusion::{assemble, Solver, SolverKind};
use transcut::edit::{Cutter, EditOptions, Editor, PaintStroke, UpdateStats};
use transcut::gpu::Backend;
use transcut::light::Light;
use transcut::mesh;
use transcut::mesher::{tetrahedralize, Grading, MesherOptions};
use transcut::optics::Medium;
use transcut::sparse::hierarchy::HierarchyOptions;
use transcut::sparse::SolveOptions;
use transcut::DVec3;
use transcut::{bake, BakeOptions, MediumSource, Object, ObjectStats, Scene, TransCutOptions};

use super::args::BenchArgs;
use super::fig7::{fig7, rotate_about_x, Fig7};
use super::stats::{median, ms, relative_error};

/// A bake's solve, medians over runs.
#[derive(Serialize)]
struct ColdEntry {
    iterations: [usize; 3],
    median_solve_ms: f64,
    median_source_ms: f64,
    median_assembly_ms: f64,
    solve_runs_ms: Vec<f64>,
}

/// One kind of edit, medians over runs, with the last run's full statistics.
#[derive(Serialize)]
struct EditEntry {
    median_total_ms: f64,
    median_solve_ms: f64,
    total_runs_ms: Vec<f64>,
    last: UpdateStats,
}

#[derive(Serialize)]
struct RelightEntry {
    /// The editor's solver.
    solver: SolverKind,
    /// The cold bake under the moved sun (the same system, solved from zero by the bake's
    /// SSOR-PCG).
    cold: ColdEntry,
    /// The editor's relight (warm start).
    warm: EditEntry,
    /// The same system (the last run's) solved from zero with the editor's solver.
    cold_same_solver_iterations: [usize; 3],
    /// Σ warm iterations / Σ cold iterations of the same solver over the channels.
    iteration_ratio: f64,
    /// Σ warm iterations / Σ cold-bake (SSOR-PCG) iterations: not a warm-start measure when
    /// the solvers differ.
    iteration_ratio_vs_cold_bake: f64,
    /// Warm solve ms / cold solve ms (medians).
    solve_time_ratio: f64,
    /// max over channels ‖φ_warm − φ_cold‖ / ‖φ_cold‖ (both solved to the same tolerance).
    relative_difference_vs_cold: Option<f64>,
}

#[derive(Serialize)]
struct PaintEntry {
    points: usize,
    radius_mm: f64,
    #[serde(flatten)]
    edit: EditEntry,
}

#[derive(Serialize)]
struct SizeEntry {
    target_tets: usize,
    grading: Grading,
    tets: usize,
    vertices: usize,
    meshing_ms: f64,
    cold_bake: ColdEntry,
    median_editor_setup_ms: f64,
    relight_5deg: RelightEntry,
    paint: PaintEntry,
    cut_plane: EditEntry,
    cut_ball: EditEntry,
    fig7: Fig7,
}

fn cold_entry(stats: &[ObjectStats]) -> anyhow::Result<ColdEntry> {
    let last = stats.last().context("at least one run")?;
    let pick = |f: fn(&ObjectStats) -> f64| median(stats.iter().map(f).collect());
    Ok(ColdEntry {
        iterations: last.iterations,
        median_solve_ms: pick(|s| s.solve_ms),
        median_source_ms: pick(|s| s.source_ms),
        median_assembly_ms: pick(|s| s.assembly_ms),
        solve_runs_ms: stats.iter().map(|s| s.solve_ms).collect(),
    })
}

fn edit_entry(stats: Vec<UpdateStats>) -> anyhow::Result<EditEntry> {
    Ok(EditEntry {
        median_total_ms: median(stats.iter().map(|s| s.total_ms).collect()),
        median_solve_ms: median(stats.iter().map(|s| s.solve_ms).collect()),
        total_runs_ms: stats.iter().map(|s| s.total_ms).collect(),
        last: stats.last().context("at least one run")?.clone(),
    })
}

/// Iterations of a cold solve of `system` (its matrix and current b) with the editor's solver
/// and tolerance.
fn cold_iterations(system: &transcut::diffusion::DiffusionSystem, options: &EditOptions) -> anyhow::Result<[usize; 3]> {
    let solver = Solver::new(system, options.solver, &HierarchyOptions::default())?;
    let solve = SolveOptions::default().with_tolerance(options.tolerance).with_max_iterations(options.max_iterations);
    Ok(solver.solve(system, None, &solve)?.stats.iterations)
}

fn sun_light(towards: DVec3) -> Light {
    Light::Directional { direction: -towards, irradiance: [3.0; 3], angular_diameter_deg: 0.0 }
}

/// [`relative_error`] of two fluences of one mesh (`None` for two meshes).
fn relative_difference(a: &[[f64; 3]], b: &[[f64; 3]]) -> Option<f64> {
    (a.len() == b.len()).then(|| relative_error(a, b))
}

/// Eight surface vertices across the front (+z) of `positions`' bounds at mid height: for each
/// of 8 points spaced over the middle 40% of the x extent just in front of the bounds, the
/// closest vertex.
fn stroke_points(positions: &[DVec3]) -> Vec<DVec3> {
    let (lo, hi) = positions
        .iter()
        .fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let c = 0.5 * (lo + hi);
    (0..8)
        .map(|k| {
            let x = lo.x + (hi.x - lo.x) * (0.3 + 0.4 * k as f64 / 7.0);
            let target = DVec3::new(x, c.y, hi.z + 0.1 * (hi.z - lo.z));
            positions
                .iter()
                .copied()
                .min_by(|a, b| a.distance_squared(target).total_cmp(&b.distance_squared(target)))
                .unwrap_or(target)
        })
        .collect()
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let input = mesh::load(&args.input).with_context(|| format!("loading {}", args.input.display()))?;
    let (lo, hi) = input.bounds();
    let mm_per_unit = 60.0 / (hi - lo).max_element();
    let marble = Medium::preset("marble")?;
    // About 7 times marble's absorption: the darkest ink the test's coarsest mesh (h ≈ 3.9 mm) still
    // resolves (σtr·h at 0.72 of its bound in blue); a darker one is refused (EditError::Unresolved).
    let ink = Medium::new([0.015, 0.03, 0.045], marble.sigma_s_prime, marble.eta, marble.g)?;
    let sun = DVec3::new(0.0, 1.0, 1.0).normalize();
    let sun5 = rotate_about_x(sun, 5.0);
    let transcut = TransCutOptions { backend: Some(Backend::Cpu), ..TransCutOptions::default() };
    let transcut = TransCutOptions { edit_solver: args.solver.unwrap_or(transcut.edit_solver), ..transcut };
    let bake_options = BakeOptions::with_method(transcut.clone());
    let edit_options = EditOptions::from_bake_options(&bake_options, &transcut);
    let radius_mm = 2.0;
    let runs = args.runs as usize;
    let ball_radius = 0.2 * (hi - lo).max_element();
    let ball = mesh::icosphere(ball_radius, 3);
    let gradings = args.gradings_or(&[0]);
    let mut entries = Vec::new();
    for (&target, layers) in args.tets.iter().flat_map(|t| gradings.iter().map(move |&g| (t, g))) {
        let grading = Grading::from_layers(layers);
        let t = Instant::now();
        let tet_mesh = tetrahedralize(&input, &MesherOptions { grading, ..MesherOptions::with_tets(target) })?;
        let meshing_ms = ms(t);
        let object = Object::from_tets("bench", tet_mesh.clone(), MediumSource::Homogeneous(marble), mm_per_unit);
        let scene = |towards: DVec3| Scene { objects: vec![object.clone()], lights: vec![sun_light(towards)] };
        let (mut cold, mut cold5, mut setup) = (Vec::new(), Vec::new(), Vec::new());
        let (mut relight, mut paint, mut cut, mut bite) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut difference = None;
        let mut cold_same = [0; 3];
        let mut points = Vec::new();
        for _ in 0..runs {
            let baked = bake(&scene(sun), &bake_options)?;
            cold.push(baked.objects[0].stats.clone());
            let baked5 = bake(&scene(sun5), &bake_options)?;
            cold5.push(baked5.objects[0].stats.clone());

            let t = Instant::now();
            let mut editor = Editor::from_bake(&baked.objects[0], &[sun_light(sun)], &edit_options)?;
            setup.push(ms(t));
            relight.push(editor.relight(&[sun_light(sun5)])?);
            let fluence5 = &baked5.objects[0].transcut().context("a TransCut bake")?.fluence;
            difference = relative_difference(editor.pieces()[0].fluence(), fluence5);
            cold_same = cold_iterations(editor.pieces()[0].system(), &edit_options)?;

            let surface = editor.pieces()[0].surface();
            points = stroke_points(surface.positions());
            let stroke = PaintStroke { points: points.clone(), radius: radius_mm / mm_per_unit, medium: ink, strength: 1.0 };
            paint.push(editor.paint(&stroke)?);

            let c = 0.5 * (lo + hi);
            cut.push(editor.cut(&Cutter::Plane { point: c, normal: DVec3::new(0.0, 0.0, -1.0) })?);
            let centre = points[points.len() / 2];
            let solid = ball.transformed(&glam::DMat4::from_translation(centre));
            bite.push(editor.cut(&Cutter::Solid(solid))?);
        }
        let cold_bake = cold_entry(&cold)?;
        let cold5 = cold_entry(&cold5)?;
        let warm = edit_entry(relight)?;
        let sum = |v: [usize; 3]| v.iter().sum::<usize>() as f64;
        let relight_5deg = RelightEntry {
            solver: edit_options.solver,
            cold_same_solver_iterations: cold_same,
            iteration_ratio: sum(warm.last.iterations) / sum(cold_same).max(1.0),
            iteration_ratio_vs_cold_bake: sum(warm.last.iterations) / sum(cold5.iterations).max(1.0),
            solve_time_ratio: warm.median_solve_ms / cold5.median_solve_ms,
            relative_difference_vs_cold: difference,
            cold: cold5,
            warm,
        };
        let mut system = assemble(&tet_mesh, &[marble], mm_per_unit)?;
        let fig7 = fig7(&mut system, sun, runs, 1e-10)?;
        entries.push(SizeEntry {
            target_tets: target,
            grading,
            tets: tet_mesh.tets().len(),
            vertices: tet_mesh.positions().len(),
            meshing_ms,
            cold_bake,
            median_editor_setup_ms: median(setup),
            relight_5deg,
            paint: PaintEntry { points: points.len(), radius_mm, edit: edit_entry(paint)? },
            cut_plane: edit_entry(cut)?,
            cut_ball: edit_entry(bite)?,
            fig7,
        });
    }
    let report = serde_json::json!({
        "suite": "edit",
        "input": args.input.display().to_string(),
        "mm_per_unit": mm_per_unit,
        "medium": "marble",
        "threads": rayon::current_num_threads(),
        "runs": runs,
        "fig7_error": "max over channels of ||phi - phi*|| / ||phi*||, phi* solved to 1e-10",
        "entries": entries,
    });
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}
