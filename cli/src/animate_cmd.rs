//! `transcut animate`: per-vertex radiance of every frame of a deforming mesh, written as one
//! float32 `.npy` of shape (frames, vertices, 3).
//!
//! The frames are meshes of one topology (the first frame's vertices and triangles). The first
//! is baked into a [`Session`]; every later one moves its vertices there
//! ([`Session::set_positions`]), so the method updates rather than bakes again (the
//! hierarchical dipole refits its cluster trees and, in its default incremental mode here,
//! relinks only what moved). Only a method that can deform a mesh can animate.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context};
use clap::Args;
use serde::Serialize;
use transcut::hierarchy::DipoleStats;
use transcut::mesh::{self, TriMesh};
use transcut::{BakeOptions, Method, Progress, Session};

use crate::method_args::{MethodArgs, MethodDefaults, ModeName};
use crate::object_args::{ObjectArgs, FORMS_HELP};
use crate::output::{write_f32, write_npy_header};
use crate::progress::StageBar;

/// Arguments of `transcut animate`.
#[derive(Args)]
#[command(after_help = format!("{FORMS_HELP}

Example:
  transcut animate frames/*.obj --scale 40 --light sun:dir=0,-1,-1,irradiance=3 -o radiance.npy"))]
pub struct AnimateArgs {
    /// The frames in order: surface meshes (.obj or .ply) with the first frame's vertices (the
    /// same count and order) and triangles, only the positions moved.
    #[arg(required = true, value_name = "FRAMES")]
    pub frames: Vec<PathBuf>,
    #[command(flatten)]
    pub object: ObjectArgs,
    /// The method (default hierarchical-dipole, the one that can deform a mesh; its mode
    /// defaults to incremental here).
    #[command(flatten)]
    pub method: MethodArgs,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Output: .npy, float32 of shape (frames, vertices, 3), the rows of each frame in the
    /// input's vertex order. Written whole or not at all.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Print statistics as JSON on stdout, one entry per frame (no progress bar).
    #[arg(long)]
    pub json: bool,
}

/// What one frame's update measured (the first frame's is its bake).
#[derive(Debug, Serialize)]
struct FrameReport {
    /// 1-based, as the frames were given.
    frame: usize,
    path: String,
    total_ms: f64,
    light_ms: f64,
    #[serde(flatten)]
    dipole: DipoleStats,
}

/// A frame: its file and its vertices' positions in the user's order (object space, what
/// [`Session::set_positions`] takes).
struct Frame {
    path: PathBuf,
    positions: Vec<[f64; 3]>,
}

/// Why `mesh` does not have `first`'s topology: vertex count, welding (vertices merged in one
/// and not the other), triangle count or a triangle's corners (as user vertices).
fn topology_difference(first: &TriMesh, mesh: &TriMesh) -> Option<String> {
    let (n, n0) = (mesh.user_vertex_count(), first.user_vertex_count());
    if n != n0 {
        return Some(format!("it has {n} vertices, the first frame {n0}"));
    }
    let (map, map0) = (mesh.user_to_internal(), first.user_to_internal());
    if let Some(v) = (0..n).find(|&v| map[v] != map0[v]) {
        return Some(format!(
            "its vertex {v} (0-based) is welded differently: it coincides with another vertex in one frame and not in the other"
        ));
    }
    let (t, t0) = (mesh.triangles(), first.triangles());
    if t.len() != t0.len() {
        return Some(format!(
            "it has {} triangles, the first frame {} (after welding, degenerate ones dropped)",
            t.len(),
            t0.len()
        ));
    }
    let i = (0..t.len()).find(|&i| t[i] != t0[i])?;
    // The welded vertices as the lowest user vertex of each (the welding is the same).
    let mut user = vec![0u32; mesh.positions().len()];
    for (u, &w) in map.iter().enumerate().rev() {
        user[w as usize] = u as u32;
    }
    let corners = |tri: [u32; 3]| tri.map(|w| user[w as usize]);
    Some(format!(
        "its triangle {i} has the vertices {:?}, the first frame's {:?} (0-based; a reversed order is a turned face)",
        corners(t[i]),
        corners(t0[i])
    ))
}

/// The first frame's mesh and every frame, each checked against the first's topology.
fn load_frames(paths: &[PathBuf]) -> anyhow::Result<(TriMesh, Vec<Frame>)> {
    let mut first: Option<TriMesh> = None;
    let mut frames = Vec::with_capacity(paths.len());
    for (k, path) in paths.iter().enumerate() {
        let mesh = mesh::load(path).with_context(|| format!("loading frame {} ({})", k + 1, path.display()))?;
        if let Some(why) = first.as_ref().and_then(|first| topology_difference(first, &mesh)) {
            bail!(
                "frame {} ({}) has another topology than frame 1 ({}): {why}; every frame needs the first frame's vertices and \
                 triangles, only moved",
                k + 1,
                path.display(),
                paths[0].display()
            );
        }
        frames.push(Frame { path: path.clone(), positions: user_positions(&mesh) });
        first.get_or_insert(mesh);
    }
    Ok((first.context("no frames")?, frames))
}

/// The positions of `mesh`'s vertices in the user's order.
fn user_positions(mesh: &TriMesh) -> Vec<[f64; 3]> {
    mesh.user_to_internal().iter().map(|&w| mesh.positions()[w as usize].to_array()).collect()
}

pub fn run(args: &AnimateArgs) -> anyhow::Result<()> {
    if args.object.print_help(&args.method) {
        return Ok(());
    }
    let defaults = MethodDefaults {
        method: Some(transcut::methods::hierarchical_dipole::NAME.into()),
        mode: Some(ModeName::Incremental),
        ..MethodDefaults::default()
    };
    let method = args.method.method(&defaults)?;
    if !matches!(method, Method::HierarchicalDipole(_)) {
        bail!(
            "the {} method cannot deform a mesh, which animate needs: use --method {}",
            method.name(),
            transcut::methods::hierarchical_dipole::NAME
        );
    }
    if let Some(path) = &args.output {
        if !path.extension().is_some_and(|e| e.eq_ignore_ascii_case("npy")) {
            bail!("output {}: animate writes .npy (float32, frames × vertices × 3)", path.display());
        }
    }
    let start = Instant::now();
    let (first, frames) = load_frames(&args.frames)?;
    let name = crate::object_args::object_name(&args.frames[0]);
    let (vertices, triangles) = (first.user_vertex_count(), first.triangles().len());
    let scene = args.object.scene(name, first)?;
    let options = BakeOptions { method: method.clone(), threads: args.threads, ..BakeOptions::default() };

    let count = frames.len();
    let bar = StageBar::new(args.json);
    let progress = |k: usize| {
        let bar = &bar;
        move |stage: &str, f: f64| bar.update(&format!("frame {}/{count} {stage}", k + 1), (k as f64 + f) / count as f64)
    };
    let mut radiance: Vec<Vec<[f64; 3]>> = Vec::with_capacity(count);
    let mut reports = Vec::with_capacity(count);
    let mut session: Option<Session> = None;
    for (k, frame) in frames.iter().enumerate() {
        let callback = progress(k);
        let t = Instant::now();
        let (light_ms, dipole) = if let Some(s) = session.as_mut() {
            let update = s
                .set_positions(0, &frame.positions, Progress::new(&callback))
                .with_context(|| format!("frame {} ({})", k + 1, frame.path.display()))?;
            let light_ms = update.source_ms;
            (light_ms, s.dipole(0)?.context("internal: a deformed object without its live state")?.state().stats)
        } else {
            let baked = Session::bake(&scene, &options, Progress::new(&callback));
            let s = session.insert(baked.with_context(|| format!("baking frame 1 ({})", frame.path.display()))?);
            let bake = s.baked(0)?.context("internal: a session without its bake")?;
            (bake.stats.source_ms, bake.dipole().context("internal: a dipole bake without its state")?.stats)
        };
        let s = session.as_ref().context("internal: no session")?;
        radiance.push(s.radiance(0)?.context("internal: a deformed object without radiance at its vertices")?);
        let report = FrameReport {
            frame: k + 1,
            path: frame.path.display().to_string(),
            total_ms: t.elapsed().as_secs_f64() * 1e3,
            light_ms,
            dipole,
        };
        if !args.json {
            let d = &report.dipole;
            bar.suspend(|| {
                eprintln!(
                    "frame {}/{count}: {:.0} ms (light {:.0}, refit {:.0}, links {:.0}, gather {:.0}, push {:.0}), {} links, {} \
                     form factors",
                    report.frame,
                    report.total_ms,
                    report.light_ms,
                    d.refit_ms,
                    d.link_ms,
                    d.gather_ms,
                    d.push_ms,
                    d.links,
                    d.form_factors
                );
            });
        }
        reports.push(report);
    }
    bar.finish();
    if let Some(path) = &args.output {
        write_frames(path, &radiance, vertices).with_context(|| format!("writing {}", path.display()))?;
    }
    let total_ms = start.elapsed().as_secs_f64() * 1e3;
    if args.json {
        let report = serde_json::json!({
            "frames": reports,
            "output": args.output.as_ref().map(|p| p.display().to_string()),
            "vertices": vertices,
            "triangles": triangles,
            "method": method.name(),
            "options": format!("{method:?}"),
            "total_ms": total_ms,
        });
        crate::output::print_json(&report)?;
    } else {
        let out = args.output.as_ref().map_or_else(|| "(not written)".into(), |p| p.display().to_string());
        println!("{out}: {count} frames × {vertices} vertices by {} in {total_ms:.0} ms", method.name());
    }
    Ok(())
}

/// Writes the frames' radiance as float32 .npy of shape (frames, vertices, 3).
fn write_frames(path: &Path, radiance: &[Vec<[f64; 3]>], vertices: usize) -> anyhow::Result<()> {
    transcut::output::write_atomically(path, |out| {
        write_npy_header(out, &[radiance.len(), vertices, 3])?;
        radiance.iter().try_for_each(|frame| write_f32(out, frame))
    })?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use transcut::mesh::icosphere;
    use transcut::DVec3;

    fn mesh(positions: &[DVec3], triangles: &[[u32; 3]]) -> TriMesh {
        let p: Vec<[f64; 3]> = positions.iter().map(|p| p.to_array()).collect();
        TriMesh::from_triangles(&p, &triangles.concat()).unwrap()
    }

    #[test]
    fn topology_differences_say_what_differs() {
        let base = icosphere(1.0, 1);
        let (p, t) = (base.positions().to_vec(), base.triangles().to_vec());
        let moved: Vec<DVec3> = p.iter().map(|x| *x * (1.0 + 0.1 * x.z)).collect();
        assert_eq!(topology_difference(&base, &mesh(&moved, &t)), None);
        assert_eq!(user_positions(&mesh(&moved, &t))[5], moved[5].to_array());
        let other = icosphere(1.0, 2);
        assert!(topology_difference(&base, &other).unwrap().contains("162 vertices, the first frame 42"));
        // Two triangles' corners exchanged: the same counts, another triangle list.
        let mut swapped = t.clone();
        swapped.swap(0, 1);
        let why = topology_difference(&base, &mesh(&p, &swapped)).unwrap();
        assert!(why.contains("triangle 0"), "{why}");
        // Vertex 7 moved onto vertex 3: welded into one.
        let mut collapsed = p.clone();
        collapsed[7] = collapsed[3];
        let why = topology_difference(&base, &mesh(&collapsed, &t)).unwrap();
        assert!(why.contains("vertex 7") && why.contains("welded"), "{why}");
    }
}
