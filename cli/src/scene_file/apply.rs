//! Applies a scene file's `[[edit]]` list ([`super::edits`]) to a baked scene through the
//! core's [`Session`] and hands `transcut render` what to draw: every piece of every edited
//! object, in world space, with its radiance.
//!
//! A relight applies to every object, all or none ([`Session::relight`]); every other edit to
//! its object. Each object is solved with its own shadows: shadows cast by the other objects of
//! the scene are not seen by edits. A radiosity bake is the exception: it is one coupled
//! solution ([`Session::radiosity`]), so a relight, an albedo, an emission or a whole medium
//! re-solves the whole scene, every object shadowing and lighting every other; its other
//! edits are refused by name.

use anyhow::{anyhow, bail, Context};
use glam::DMat4;
use serde::Serialize;
use transcut::edit::{Cutter, Editor, MediumEdit, MediumOp, PaintStroke, Region, SweptStroke, UpdateStats};
use transcut::mesh::TriMesh;
use transcut::progress::ProgressFn;
use transcut::render::Camera;
use transcut::{DVec3, MediumSource, Progress, Session};

use super::edits::{EditKind, EditStep, Keep, OpSpec, RegionSpec};

/// What one edit did to one object (a relight gives one per object).
#[derive(Debug, Clone, Serialize)]
pub struct EditReport {
    /// 1-based position of the edit in the scene file.
    pub edit: usize,
    pub kind: String,
    pub object: String,
    /// Pieces of the object after the edit.
    pub pieces: usize,
    pub stats: UpdateStats,
}

/// Runs `steps` in order on `session` (objects named `names`). `camera` is the scene file's
/// camera (cut strokes are in its pixels). `progress` sees every edit's reports, its stages
/// prefixed `"edit N (kind): "`, and restarts at 0 for each edit. `each` is called after every
/// edit with its report.
///
/// # Errors
/// The first failing edit, named by its index and kind (the core error says what is wrong).
pub fn apply(
    steps: &[EditStep],
    session: &mut Session,
    names: &[String],
    camera: &Camera,
    progress: &ProgressFn<'_>,
    mut each: impl FnMut(&EditReport),
) -> anyhow::Result<Vec<EditReport>> {
    let mut reports = Vec::new();
    for step in steps {
        let label = || format!("edit {} (kind = \"{}\")", step.index, step.kind_name);
        let prefix = format!("edit {} ({})", step.index, step.kind_name);
        let callback = |stage: &str, f: f64| progress(&format!("{prefix}: {stage}"), f);
        let p = Progress::new(&callback);
        let updated: Vec<(usize, UpdateStats)> = match (&step.kind, step.object) {
            (EditKind::Relight(lights), _) => session.relight(lights, p).with_context(label)?.into_iter().enumerate().collect(),
            (kind, Some(o)) => {
                // The core's error names the object (index and name).
                let stats = run(session, o, kind, camera, p).with_context(label)?;
                vec![(o, stats)]
            }
            (_, None) => return Err(anyhow!("internal: {} names no object", label())),
        };
        for (o, stats) in updated {
            let pieces = session.editor(o)?.map_or(1, |e| e.pieces().len());
            let report = EditReport { edit: step.index, kind: step.kind_name.clone(), object: names[o].clone(), pieces, stats };
            each(&report);
            reports.push(report);
        }
    }
    Ok(reports)
}

/// One edit (not a relight) on object `o`, reporting to `p`.
fn run(session: &mut Session, o: usize, kind: &EditKind, camera: &Camera, p: Progress) -> anyhow::Result<UpdateStats> {
    Ok(match kind {
        EditKind::Relight(lights) => session.relight(lights, p)?[o].clone(),
        EditKind::Medium { region, op } if session.radiosity().is_some() => {
            // The objects are coupled: a translucent object's medium changes whole.
            let why = "a radiosity bake changes a translucent object's medium as a whole";
            if *region != RegionSpec::All {
                bail!("'region': {why}: give region = \"all\" (or leave it out)");
            }
            match op {
                OpSpec::Assign(m) => session.set_medium(o, MediumSource::Homogeneous(*m), p)?.clone(),
                OpSpec::Scale { .. } => bail!("'scale': {why}: give the new medium with 'assign'"),
                OpSpec::Add { .. } => bail!("'add': {why}: give the new medium with 'assign'"),
            }
        }
        EditKind::Albedo(albedo) => session.set_albedo(o, *albedo, p)?.clone(),
        EditKind::Emission(emission) => session.set_emission(o, *emission, p)?.clone(),
        EditKind::Medium { region, op } => {
            let region = match region {
                RegionSpec::All => Region::All,
                RegionSpec::Sphere { center, radius } => Region::Sphere { center: *center, radius: *radius },
                RegionSpec::Depth { min_mm, max_mm } => Region::Depth { min_mm: *min_mm, max_mm: *max_mm },
            };
            let op = match op {
                OpSpec::Assign(m) => MediumOp::Assign(*m),
                OpSpec::Scale { sigma_a, sigma_s } => MediumOp::Scale { sigma_a: *sigma_a, sigma_s: *sigma_s },
                OpSpec::Add { sigma_a, sigma_s } => MediumOp::Add { sigma_a: *sigma_a, sigma_s: *sigma_s },
            };
            session.edit_medium(o, &MediumEdit { region, op }, p)?.clone()
        }
        EditKind::Paint { points, radius, medium, strength } => session
            .paint(o, &PaintStroke { points: points.clone(), radius: *radius, medium: *medium, strength: *strength }, p)?
            .clone(),
        EditKind::CutPlane { point, normal, keep } => {
            // The core's plane removes the side its normal points into; the file's normal points
            // to the side that is kept.
            let n = normal.normalize();
            let cutter = Cutter::Plane { point: *point, normal: if *keep == Keep::Back { n } else { -n } };
            if *keep == Keep::Both {
                session.split(o, &cutter, p)?.clone()
            } else {
                session.cut(o, &cutter, p)?.clone()
            }
        }
        EditKind::CutStroke { pixels, keep } => {
            let cutter = Cutter::Stroke(stroke(camera, pixels)?);
            match keep {
                Keep::Both => session.split(o, &cutter, p)?.clone(),
                Keep::Left => session.cut(o, &cutter.flipped(), p)?.clone(),
                _ => session.cut(o, &cutter, p)?.clone(),
            }
        }
        EditKind::Fracture => session.fracture(o, p)?.clone(),
        EditKind::MovePiece { piece, translate, axis, angle_deg, pivot } => {
            let (transform, pivot) = piece_placement(session, o, *piece, *pivot, p)?;
            let rotation = match axis {
                Some(a) => DMat4::from_axis_angle(a.normalize(), angle_deg.to_radians()),
                None => DMat4::IDENTITY,
            };
            let moved = DMat4::from_translation(*translate + pivot) * rotation * DMat4::from_translation(-pivot) * transform;
            session.set_piece_transform(o, *piece, moved, p)?.clone()
        }
        EditKind::Recombine => session.recombine(o, p)?.clone(),
    })
}

/// Piece `piece`'s transform and the pivot of a rotation of it: `pivot`, or its centroid.
fn piece_placement(
    session: &mut Session,
    o: usize,
    piece: usize,
    pivot: Option<DVec3>,
    p: Progress,
) -> anyhow::Result<(DMat4, DVec3)> {
    session.start(o, p)?;
    let editor = session.editor(o)?.ok_or_else(|| anyhow!("'piece': the object's method has no pieces"))?;
    let count = editor.pieces().len();
    let current =
        editor.pieces().get(piece).ok_or_else(|| anyhow!("'piece': piece {piece} does not exist (there are {count})"))?;
    let transform = current.transform();
    Ok((transform, pivot.unwrap_or_else(|| centroid(current.mesh().positions(), transform))))
}

/// The stroke's pixels swept along the rays of `camera` (TransCut §5.1). The core's stroke
/// removes the left of the drawing direction as seen in the image (a stroke drawn left to right
/// removes what is above it, as in the paper): keep = "right" is the core's stroke as is.
fn stroke(camera: &Camera, pixels: &[[f64; 2]]) -> anyhow::Result<SweptStroke> {
    let directions = pixels
        .iter()
        .enumerate()
        .map(|(k, p)| camera.ray_direction(p[0], p[1]).map_err(|e| anyhow!("'stroke' point {}: {e}", k + 1)))
        .collect::<anyhow::Result<Vec<_>>>()?;
    SweptStroke::perspective(camera.position, directions).context("'stroke'")
}

/// Mean of `positions` placed by `transform`.
fn centroid(positions: &[DVec3], transform: DMat4) -> DVec3 {
    let sum: DVec3 = positions.iter().map(|&p| transform.transform_point3(p)).sum();
    sum / positions.len().max(1) as f64
}

/// Every piece of `editor` as a world-space surface with the radiance of its vertices.
pub fn piece_meshes(editor: &Editor) -> Vec<(TriMesh, Vec<[f64; 3]>)> {
    editor
        .pieces()
        .iter()
        .map(|piece| {
            let surface = piece.surface();
            let lo = piece.radiance();
            let mut r = vec![[0.0; 3]; surface.positions().len()];
            for (user, &internal) in surface.user_to_internal().iter().enumerate() {
                r[internal as usize] = lo[user];
            }
            (surface, r)
        })
        .collect()
}
