//! Applies a scene file's `[[edit]]` list ([`crate::scene_edits`]) to the baked objects with the
//! core's [`Editor`] and hands `transcut render` what to draw: every piece of every edited
//! object, in world space, with its radiance.
//!
//! An editor is started from each edited object's bake ([`Editor::from_bake`], no second solve)
//! under the scene's lights; with a `relight` in the list every object gets one. Each editor
//! solves its own object: shadows cast by the other objects of the scene are not seen by edits.

use anyhow::{anyhow, Context};
use glam::DMat4;
use serde::Serialize;
use transcut::edit::cut::{Cutter, SweptStroke};
use transcut::edit::{EditOptions, Editor, MediumEdit, MediumOp, PaintStroke, Region, UpdateStats};
use transcut::light::Light;
use transcut::mesh::TriMesh;
use transcut::render::Camera;
use transcut::scene::{Object, ObjectBake};
use transcut::DVec3;

use crate::scene_edits::{EditKind, EditStep, Keep, OpSpec, RegionSpec};

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

/// The edited scene: one editor per edited object, the lights after the last relight and a
/// report per edit and object.
pub struct Edited {
    pub editors: Vec<Option<Editor>>,
    pub lights: Vec<Light>,
    pub reports: Vec<EditReport>,
}

/// Runs `steps` in order. `camera` is the scene file's camera (cut strokes are in its pixels).
/// `each` is called after every edit with its report.
///
/// # Errors
/// The first failing edit, named by its index and kind (the core error says what is wrong).
pub fn apply(
    steps: &[EditStep],
    objects: &[Object],
    baked: &[ObjectBake],
    lights: &[Light],
    camera: &Camera,
    options: &EditOptions,
    mut each: impl FnMut(&EditReport),
) -> anyhow::Result<Edited> {
    let relight = steps.iter().any(|s| s.object.is_none());
    let mut editors: Vec<Option<Editor>> = (0..objects.len()).map(|_| None).collect();
    for (i, (object, bake)) in objects.iter().zip(baked).enumerate() {
        if relight || steps.iter().any(|s| s.object == Some(i)) {
            let editor = Editor::from_bake(bake, object.mm_per_unit, lights, options)
                .with_context(|| format!("starting the editor of object {} ({})", i + 1, object.name))?;
            editors[i] = Some(editor);
        }
    }
    let mut current_lights = lights.to_vec();
    let mut reports = Vec::new();
    for step in steps {
        let label = || format!("edit {} (kind = \"{}\")", step.index, step.kind_name);
        let targets: Vec<usize> = match step.object {
            Some(o) => vec![o],
            None => (0..objects.len()).collect(),
        };
        for o in targets {
            let editor = editors[o].as_mut().ok_or_else(|| anyhow!("internal: object {} has no editor", o + 1))?;
            let stats = run(editor, &step.kind, camera)
                .with_context(|| format!("{}: object {} ({})", label(), o + 1, objects[o].name))?;
            let report = EditReport {
                edit: step.index,
                kind: step.kind_name.clone(),
                object: objects[o].name.clone(),
                pieces: editor.pieces().len(),
                stats,
            };
            each(&report);
            reports.push(report);
        }
        if let EditKind::Relight(l) = &step.kind {
            current_lights.clone_from(l);
        }
    }
    Ok(Edited { editors, lights: current_lights, reports })
}

/// One edit on one editor.
fn run(editor: &mut Editor, kind: &EditKind, camera: &Camera) -> anyhow::Result<UpdateStats> {
    Ok(match kind {
        EditKind::Relight(lights) => editor.relight(lights)?,
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
            editor.edit_medium(&MediumEdit { region, op })?
        }
        EditKind::Paint { points, radius, medium, strength } => {
            editor.paint(&PaintStroke { points: points.clone(), radius: *radius, medium: *medium, strength: *strength })?
        }
        EditKind::CutPlane { point, normal, keep } => {
            // The core's plane removes the side its normal points into; the file's normal points
            // to the side that is kept.
            let n = normal.normalize();
            let cutter = Cutter::Plane { point: *point, normal: if *keep == Keep::Back { n } else { -n } };
            if *keep == Keep::Both {
                editor.split(&cutter)?
            } else {
                editor.cut(&cutter)?
            }
        }
        EditKind::CutStroke { pixels, keep } => {
            let cutter = Cutter::Stroke(stroke(camera, pixels)?);
            match keep {
                Keep::Both => editor.split(&cutter)?,
                Keep::Left => editor.cut(&cutter.flipped())?,
                _ => editor.cut(&cutter)?,
            }
        }
        EditKind::Fracture => editor.fracture()?,
        EditKind::MovePiece { piece, translate, axis, angle_deg, pivot } => {
            let count = editor.pieces().len();
            let current = editor
                .pieces()
                .get(*piece)
                .ok_or_else(|| anyhow!("'piece': piece {piece} does not exist (there are {count})"))?;
            let transform = current.transform();
            let pivot = pivot.unwrap_or_else(|| centroid(current.mesh().positions(), transform));
            let rotation = match axis {
                Some(a) => DMat4::from_axis_angle(a.normalize(), angle_deg.to_radians()),
                None => DMat4::IDENTITY,
            };
            let moved = DMat4::from_translation(*translate + pivot) * rotation * DMat4::from_translation(-pivot) * transform;
            editor.set_piece_transform(*piece, moved)?
        }
        EditKind::Recombine => editor.recombine()?,
    })
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
