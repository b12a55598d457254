//! `transcut bench prt`: the PRT method (R. Wang et al. 2008) on `--input` (60 mm across,
//! marble, one shadowed sun), at `--prt-samples` (log₂, default 2¹⁶) with the default 3072
//! terms per vertex, through the bake and its session:
//!
//! - the precompute (samples and compressed transfer) and the first light, with the transfer's
//!   bytes, terms, dropped coefficient energy and the process's peak memory;
//! - a relight after turning the sun 5° (q at the samples with shadows, Haar, the product), a
//!   whole-object material edit (marble ↔ marble with twice its σa: projection and K-term sums) and a scale
//!   change, each the median of `--runs`;
//! - the same material edit by the TransCut editor on the same object at `--tets` (its first
//!   value), in the same run: the speed-up of PRT's edit against it.

use std::time::Instant;

use anyhow::Context;
use serde::Serialize;
use transcut::edit::{MediumEdit, MediumOp, Region};
use transcut::light::Light;
use transcut::mesh;
use transcut::optics::Medium;
use transcut::prt::PrtOptions;
use transcut::{BakeOptions, DVec3, Object, Progress, Scene, Session, TransCutOptions};

use super::args::BenchArgs;
use super::stats::{median, ms, peak_rss_mib};

/// The sun `degrees` from its starting direction, turned about the vertical.
fn sun(degrees: f64) -> Light {
    let (s, c) = degrees.to_radians().sin_cos();
    Light::Directional { direction: DVec3::new(s, -1.0, -c), irradiance: [3.0; 3], angular_diameter_deg: 0.0 }
}

#[derive(Debug, Serialize)]
struct Timed {
    median_ms: f64,
    runs_ms: Vec<f64>,
}

impl Timed {
    fn new(runs: Vec<f64>) -> Self {
        Self { median_ms: median(runs.clone()), runs_ms: runs }
    }
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let input = mesh::load(&args.input).with_context(|| format!("loading {}", args.input.display()))?;
    let (lo, hi) = input.bounds();
    let mm_per_unit = 60.0 / (hi - lo).max_element();
    let marble = Medium::preset("marble")?;
    // The edit: marble twice as absorbing (a medium TransCut's mesh resolves as well).
    let absorbing = Medium { sigma_a: marble.sigma_a.map(|s| 2.0 * s), ..marble };
    let scene = Scene { objects: vec![Object::new("bench", input, marble, mm_per_unit)], lights: vec![sun(0.0)] };
    let prt = PrtOptions { samples_log2: args.prt_samples, ..PrtOptions::default() };
    let options = BakeOptions::with_method(prt.clone());

    let start = Instant::now();
    let mut session = Session::bake(&scene, &options, Progress::none())?;
    let bake_ms = ms(start);
    let stats = session.bake_stats(0)?.clone();
    let (mut relight, mut edit, mut scale) = (Vec::new(), Vec::new(), Vec::new());
    for run in 0..args.runs {
        let angle = if run % 2 == 0 { 5.0 } else { 0.0 };
        let t = Instant::now();
        session.relight(&[sun(angle)], Progress::none())?;
        relight.push(ms(t));
        let medium = if run % 2 == 0 { absorbing } else { marble };
        let t = Instant::now();
        session.edit_medium(0, &MediumEdit { region: Region::All, op: MediumOp::Assign(medium) }, Progress::none())?;
        edit.push(ms(t));
        let t = Instant::now();
        session.set_mm_per_unit(0, mm_per_unit * if run % 2 == 0 { 1.1 } else { 1.0 }, Progress::none())?;
        scale.push(ms(t));
    }
    let live = session.prt(0)?.context("the session's PRT state")?;
    let transfer = *live.state().transfer_stats();
    let peak = peak_rss_mib();

    // TransCut's editor on the same object: the same whole-object edit.
    let tets = args.tets.first().copied().unwrap_or(200_000);
    let transcut = BakeOptions::with_method(TransCutOptions { tets, ..TransCutOptions::default() });
    let mut editor = Session::bake(&scene, &transcut, Progress::none())?;
    let mut transcut_edit = Vec::new();
    for run in 0..args.runs {
        let medium = if run % 2 == 0 { absorbing } else { marble };
        let t = Instant::now();
        editor.edit_medium(0, &MediumEdit { region: Region::All, op: MediumOp::Assign(medium) }, Progress::none())?;
        transcut_edit.push(ms(t));
    }
    let edit = Timed::new(edit);
    let transcut_edit = Timed::new(transcut_edit);
    let report = serde_json::json!({
        "suite": "prt",
        "input": args.input,
        "threads": rayon::current_num_threads(),
        "samples": 1u64 << args.prt_samples,
        "vertices": stats.vertices,
        "terms_per_vertex": prt.terms_per_vertex,
        "bake_ms": bake_ms,
        "samples_ms": stats.meshing_ms,
        "precompute_ms": stats.assembly_ms,
        "first_light_ms": stats.source_ms,
        "transfer": transfer,
        "peak_rss_mib": peak,
        "relight_5deg": Timed::new(relight),
        "material_edit": edit,
        "scale_change": Timed::new(scale),
        "transcut_tets": tets,
        "transcut_material_edit": transcut_edit,
        "edit_speedup_vs_transcut": transcut_edit.median_ms / edit.median_ms,
    });
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}
