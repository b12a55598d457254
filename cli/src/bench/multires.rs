//! `transcut bench multires`: TransCut Fig. 7 ([`super::fig7`]) on the bunny (60 mm, marble,
//! an unshadowed sun from (0, 1, 1), as `bench solve`) at several sizes, the reference solved to
//! 1e-12.

use anyhow::Context;
use serde::Serialize;
use transcut::diffusion::assemble;
use transcut::mesh;
use transcut::mesher::{tetrahedralize, MesherOptions};
use transcut::optics::Medium;
use transcut::DVec3;

use super::args::BenchArgs;
use super::fig7::{fig7, Fig7};

#[derive(Serialize)]
struct SizeEntry {
    target_tets: usize,
    tets: usize,
    vertices: usize,
    #[serde(flatten)]
    fig7: Fig7,
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let input = mesh::load(&args.input).with_context(|| format!("loading {}", args.input.display()))?;
    let (lo, hi) = input.bounds();
    let mm_per_unit = 60.0 / (hi - lo).max_element();
    let medium = Medium::preset("marble")?;
    let sun = DVec3::new(0.0, 1.0, 1.0).normalize();
    let mut entries = Vec::new();
    for &target in &args.tets {
        let tet_mesh = tetrahedralize(&input, &MesherOptions::with_tets(target))?;
        let mut system = assemble(&tet_mesh, &[medium], mm_per_unit)?;
        let fig7 = fig7(&mut system, sun, args.runs as usize, 1e-12)?;
        entries.push(SizeEntry { target_tets: target, tets: tet_mesh.tets().len(), vertices: system.vertex_count(), fig7 });
    }
    let report = serde_json::json!({
        "suite": "multires",
        "input": args.input.display().to_string(),
        "mm_per_unit": mm_per_unit,
        "medium": "marble",
        "threads": rayon::current_num_threads(),
        "error": "max over channels of ||phi - phi*|| / ||phi*||, phi* solved to 1e-12",
        "entries": entries,
    });
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}
