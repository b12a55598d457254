//! `transcut bench bake`: TransCut's bake of a mesh (60 mm across, marble, one sun) at several
//! sizes: meshing, assembly, light, solve (iterations), total and peak memory.

use std::time::Instant;

use anyhow::Context;
use serde::Serialize;
use transcut::light::Light;
use transcut::mesh;
use transcut::optics::Medium;
use transcut::{bake, BakeOptions, Object, ObjectStats, Scene, TransCutOptions};

use super::args::BenchArgs;
use super::stats::{median, peak_rss_mib};

#[derive(Serialize)]
struct BakeEntry {
    target_tets: usize,
    tets: usize,
    vertices: usize,
    iterations: [usize; 3],
    median_ms: f64,
    runs_ms: Vec<f64>,
    median_meshing_ms: f64,
    median_assembly_ms: f64,
    median_source_ms: f64,
    median_solve_ms: f64,
    peak_rss_mib: Option<f64>,
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let input = mesh::load(&args.input).with_context(|| format!("loading {}", args.input.display()))?;
    let (lo, hi) = input.bounds();
    let mm_per_unit = 60.0 / (hi - lo).max_element();
    let scene = Scene {
        objects: vec![Object::new("bench", input, Medium::preset("marble")?, mm_per_unit)],
        lights: vec![Light::Directional {
            direction: transcut::DVec3::new(0.0, -1.0, -1.0),
            irradiance: [3.0; 3],
            angular_diameter_deg: 0.0,
        }],
    };
    let mut entries = Vec::new();
    for &target in &args.tets {
        let mut runs = Vec::new();
        let mut stats = Vec::new();
        for _ in 0..args.runs {
            let start = Instant::now();
            let options = BakeOptions::with_method(TransCutOptions { tets: target, ..TransCutOptions::default() });
            let b = bake(&scene, &options)?;
            runs.push(start.elapsed().as_secs_f64() * 1e3);
            stats.push(b.objects[0].stats.clone());
        }
        let last = stats.last().context("at least one run")?.clone();
        let pick = |f: fn(&ObjectStats) -> f64| median(stats.iter().map(f).collect());
        entries.push(BakeEntry {
            target_tets: target,
            tets: last.tets,
            vertices: last.vertices,
            iterations: last.iterations,
            median_ms: median(runs.clone()),
            runs_ms: runs,
            median_meshing_ms: pick(|s| s.meshing_ms),
            median_assembly_ms: pick(|s| s.assembly_ms),
            median_source_ms: pick(|s| s.source_ms),
            median_solve_ms: pick(|s| s.solve_ms),
            peak_rss_mib: peak_rss_mib(),
        });
    }
    let report = serde_json::json!({
        "suite": "bake",
        "input": args.input.display().to_string(),
        "mm_per_unit": mm_per_unit,
        "medium": "marble",
        "threads": rayon::current_num_threads(),
        "entries": entries,
    });
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}
