//! The editor's topology edits (TransCut §5.1): cut, split, fracture, move
//! and recombine pieces. Each rebuilds the affected pieces (mesh, per-tet media table, system,
//! hierarchy; φ carried over through the kept vertices as the warm start), re-lights every piece
//! (the shadows change with any piece) and re-solves; the new pieces are swapped in only when all
//! of that succeeded.

use std::collections::HashMap;
use std::time::Instant;

use glam::{DMat3, DMat4, DVec3};

use super::cut::{self, CutResult, CutStats};
use super::cutter::{Cutter, SweptStroke};
use super::error::EditError;
use super::piece::{self, Piece, Span, Timings};
use super::pieces;
use super::{Editor, UpdateStats};
use crate::mesh::TetMesh;
use crate::progress::Progress;

/// A piece to build: rest-space mesh, original tet ids, transform and warm start.
struct Plan {
    mesh: TetMesh,
    original_tets: Vec<u32>,
    transform: DMat4,
    warm: Vec<[f64; 3]>,
}

/// What a cut does to one piece.
enum Outcome {
    /// Nothing removed or moved.
    Keep,
    /// Every tet removed: the piece disappears.
    Remove,
    /// Rebuilt from the cut mesh.
    Rebuild(Box<Plan>),
}

impl Editor {
    /// Removes the cutter's positive side (world space) from every piece (TransCut §5.1, by
    /// [`cut::cut`]): a piece entirely removed disappears; the others get a new mesh, system
    /// and hierarchy, and every piece is re-lit and re-solved from its last φ.
    ///
    /// # Errors
    /// [`EditError::InvalidCutter`] / [`EditError::InvalidStroke`] / [`EditError::InvalidOptions`]
    /// from the cut; [`EditError::NothingLeft`] when nothing at all would remain; assembly and
    /// solve errors. The editor is unchanged on error.
    pub fn cut(&mut self, cutter: &Cutter) -> Result<UpdateStats, EditError> {
        self.cut_with_progress(cutter, Progress::none())
    }

    /// [`Editor::cut`] reporting the stages `"cut"`, `"assembly"`, `"hierarchy"`, `"occluder"`,
    /// `"light"` and `"solve"` to `progress`, which can cancel it.
    ///
    /// # Errors
    /// As [`Editor::cut`], plus [`EditError::Cancelled`]; the editor is unchanged on error.
    pub fn cut_with_progress(&mut self, cutter: &Cutter, progress: Progress) -> Result<UpdateStats, EditError> {
        let start = Instant::now();
        cutter.validate()?;
        let whole = Span::whole(&progress);
        let mut timings = Timings::default();
        let n = self.pieces.len();
        let mut outcomes = Vec::with_capacity(n);
        let mut stats: Option<CutStats> = None;
        for (i, p) in self.pieces.iter().enumerate() {
            let part = whole.part(0.0, 0.2).item(i, n);
            part.report("cut", 0.0)?;
            let local = cutter_in_rest_space(cutter, &p.transform)?;
            match cut::cut_with(&p.mesh, &p.original_tets, &local, &self.options.cut, &|| part.report("cut", 0.0)) {
                Ok(r) if r.stats.removed_tets == 0 && r.stats.moved_vertices == 0 => {
                    stats = Some(merge(stats, &r.stats));
                    outcomes.push(Outcome::Keep);
                }
                Ok(r) => {
                    stats = Some(merge(stats, &r.stats));
                    outcomes.push(Outcome::Rebuild(Box::new(plan_of_cut(r, p))));
                }
                Err(EditError::NothingLeft { .. }) => {
                    stats = Some(merge(stats, &removed_stats(p)));
                    outcomes.push(Outcome::Remove);
                }
                Err(e) => return Err(e),
            }
        }
        if outcomes.iter().all(|o| matches!(o, Outcome::Remove)) {
            return Err(EditError::NothingLeft { piece: self.pieces.len().saturating_sub(1) });
        }
        whole.report("cut", 0.2)?;
        let mut next = Vec::with_capacity(n);
        let mut changed = 0;
        for (i, (p, outcome)) in self.pieces.iter().zip(outcomes).enumerate() {
            match outcome {
                Outcome::Keep => next.push(p.clone()),
                Outcome::Remove => changed += p.mesh.tet_count(),
                Outcome::Rebuild(plan) => {
                    changed += plan.original_tets.len();
                    next.push(self.build(*plan, &mut timings, whole.part(0.2, 0.4).item(i, n))?);
                }
            }
        }
        let mut out = self.commit(next, &mut timings, changed, start, whole.part(0.4, 1.0))?;
        out.cut = stats;
        Ok(out)
    }

    /// Splits every piece along the cutter into the tets whose centroid lies on its positive
    /// side and the others, keeping BOTH as separate pieces (same transform). Every tet is kept
    /// and no vertex moves, so the pieces fit together exactly again and [`Editor::recombine`]
    /// restores the piece they came from. (For a smooth cut surface, cut with the cutter and its
    /// [`Cutter::flipped`] twin instead.) A piece entirely on one side stays as it is.
    ///
    /// # Errors
    /// [`EditError::InvalidCutter`] / [`EditError::InvalidStroke`]; assembly and solve errors.
    /// The editor is unchanged on error.
    pub fn split(&mut self, cutter: &Cutter) -> Result<UpdateStats, EditError> {
        self.split_with_progress(cutter, Progress::none())
    }

    /// [`Editor::split`] reporting as [`Editor::cut_with_progress`] does (stage `"split"` for
    /// the partition).
    ///
    /// # Errors
    /// As [`Editor::split`], plus [`EditError::Cancelled`]; the editor is unchanged on error.
    pub fn split_with_progress(&mut self, cutter: &Cutter, progress: Progress) -> Result<UpdateStats, EditError> {
        let start = Instant::now();
        cutter.validate()?;
        let whole = Span::whole(&progress);
        let mut timings = Timings::default();
        let mut next = Vec::new();
        let mut changed = 0;
        let n = self.pieces.len();
        for (i, p) in self.pieces.iter().enumerate() {
            let part = whole.part(0.0, 0.4).item(i, n);
            part.report("split", 0.0)?;
            let local = cutter_in_rest_space(cutter, &p.transform)?;
            let (positive, negative): (Vec<u32>, Vec<u32>) =
                (0..p.mesh.tet_count() as u32).partition(|&t| local.signed_distance(centroid(&p.mesh, t as usize)) > 0.0);
            if positive.is_empty() || negative.is_empty() {
                next.push(p.clone());
                continue;
            }
            for (k, side) in [negative, positive].into_iter().enumerate() {
                let plan = plan_of_subset(p, &side)?;
                changed += plan.original_tets.len();
                next.push(self.build(plan, &mut timings, part.item(k, 2))?);
            }
        }
        self.commit(next, &mut timings, changed, start, whole.part(0.4, 1.0))
    }

    /// Splits every piece into its connected components ([`pieces::connected_components`]),
    /// each a piece of its own with the same transform, solved with its own boundary.
    ///
    /// # Errors
    /// Assembly and solve errors. The editor is unchanged on error.
    pub fn fracture(&mut self) -> Result<UpdateStats, EditError> {
        self.fracture_with_progress(Progress::none())
    }

    /// [`Editor::fracture`] reporting as [`Editor::cut_with_progress`] does (stage
    /// `"components"` for the search of the connected parts).
    ///
    /// # Errors
    /// As [`Editor::fracture`], plus [`EditError::Cancelled`]; the editor is unchanged on error.
    pub fn fracture_with_progress(&mut self, progress: Progress) -> Result<UpdateStats, EditError> {
        let start = Instant::now();
        let whole = Span::whole(&progress);
        let mut timings = Timings::default();
        let mut next = Vec::new();
        let mut changed = 0;
        let n = self.pieces.len();
        for (i, p) in self.pieces.iter().enumerate() {
            let part = whole.part(0.0, 0.4).item(i, n);
            part.report("components", 0.0)?;
            let components = pieces::connected_components(&p.mesh);
            if components.len() < 2 {
                next.push(p.clone());
                continue;
            }
            let m = components.len();
            for (k, tets) in components.into_iter().enumerate() {
                let plan = plan_of_subset(p, &tets)?;
                changed += plan.original_tets.len();
                next.push(self.build(plan, &mut timings, part.item(k, m))?);
            }
        }
        self.commit(next, &mut timings, changed, start, whole.part(0.4, 1.0))
    }

    /// Places piece `piece` with the rigid transform `transform` (rest → world). Its matrix does
    /// not change; every piece is re-lit (its own source and the shadows move) and re-solved.
    ///
    /// # Errors
    /// [`EditError::NoSuchPiece`]; [`EditError::NotRigid`] ([`pieces::check_rigid`]); light and
    /// solve errors. The editor is unchanged on error.
    pub fn set_piece_transform(&mut self, piece: usize, transform: DMat4) -> Result<UpdateStats, EditError> {
        self.set_piece_transform_with_progress(piece, transform, Progress::none())
    }

    /// [`Editor::set_piece_transform`] reporting the stages `"occluder"`, `"light"` and
    /// `"solve"` to `progress`, which can cancel it.
    ///
    /// # Errors
    /// As [`Editor::set_piece_transform`], plus [`EditError::Cancelled`]; the editor is
    /// unchanged on error.
    pub fn set_piece_transform_with_progress(
        &mut self,
        piece: usize,
        transform: DMat4,
        progress: Progress,
    ) -> Result<UpdateStats, EditError> {
        let start = Instant::now();
        if piece >= self.pieces.len() {
            return Err(EditError::NoSuchPiece { index: piece, count: self.pieces.len() });
        }
        pieces::check_rigid(&transform)?;
        // In place (no copy of the pieces): the re-light and re-solve put everything back on
        // error but the transform, restored here.
        let mut timings = Timings::default();
        let previous = std::mem::replace(&mut self.pieces[piece].transform, transform);
        let (lights, options) = (&self.lights, &self.options);
        let span = Span::whole(&progress);
        match piece::light_and_solve(
            &mut self.pieces,
            lights,
            &options.source,
            piece::Shadowing::new(options.shadows, None),
            &self.setup,
            &mut timings,
            span,
        ) {
            Ok(occluder) => {
                self.occluder = occluder;
                Ok(UpdateStats::new(&timings, 0, 0, start))
            }
            Err(e) => {
                self.pieces[piece].transform = previous;
                Err(e)
            }
        }
    }

    /// Welds pieces whose boundaries touch again ([`pieces::weld`], within
    /// `options.weld_tolerance` in world space), repeatedly, until no two pieces touch. A welded
    /// piece lives in the rest space and transform of the first of the two.
    ///
    /// # Errors
    /// [`EditError::InvalidOptions`] for a zero weld tolerance; [`EditError::Mesh`] when welded
    /// faces would make an invalid mesh; assembly and solve errors. The editor is unchanged on
    /// error.
    pub fn recombine(&mut self) -> Result<UpdateStats, EditError> {
        self.recombine_with_progress(Progress::none())
    }

    /// [`Editor::recombine`] reporting as [`Editor::cut_with_progress`] does (stage `"weld"`
    /// before each pair of pieces tried).
    ///
    /// # Errors
    /// As [`Editor::recombine`], plus [`EditError::Cancelled`]; the editor is unchanged on error.
    pub fn recombine_with_progress(&mut self, progress: Progress) -> Result<UpdateStats, EditError> {
        let start = Instant::now();
        let whole = Span::whole(&progress);
        let weld = whole.part(0.0, 0.4);
        let mut timings = Timings::default();
        let mut next = self.pieces.clone();
        let mut changed = 0;
        let n = next.len();
        'search: loop {
            for i in 0..next.len() {
                for j in i + 1..next.len() {
                    // Each weld leaves one piece fewer: at most n − 1 welds.
                    let part = weld.item(n - next.len(), n.saturating_sub(1));
                    part.report("weld", 0.0)?;
                    if let Some(plan) = weld_pair(&next[i], &next[j], self.options.weld_tolerance)? {
                        changed += plan.original_tets.len();
                        let merged = self.build(plan, &mut timings, part)?;
                        next.remove(j);
                        next[i] = merged;
                        continue 'search;
                    }
                }
            }
            break;
        }
        if next.len() == self.pieces.len() {
            return Ok(UpdateStats::new(&timings, 0, 0, start));
        }
        self.commit(next, &mut timings, changed, start, whole.part(0.4, 1.0))
    }

    /// Builds a planned piece with the editor's media and solver setup.
    fn build(&self, plan: Plan, timings: &mut Timings, span: Span) -> Result<Piece, EditError> {
        piece::build(plan.mesh, plan.original_tets, plan.transform, &self.media, &self.setup, Some(plan.warm), timings, span)
    }

    /// Re-lights and re-solves `next` (every piece: the shadows depend on all), then swaps it in.
    fn commit(
        &mut self,
        mut next: Vec<Piece>,
        timings: &mut Timings,
        changed: usize,
        start: Instant,
        span: Span,
    ) -> Result<UpdateStats, EditError> {
        let (lights, options) = (&self.lights, &self.options);
        let occluder = piece::light_and_solve(
            &mut next,
            lights,
            &options.source,
            piece::Shadowing::new(options.shadows, None),
            &self.setup,
            timings,
            span,
        )?;
        let rebuilt = changed > 0;
        self.located = super::locate(self.original.tet_count(), &next);
        self.pieces = next;
        self.occluder = occluder;
        if rebuilt {
            self.uncut = false;
        }
        Ok(UpdateStats::new(timings, 0, changed, start))
    }
}

/// The cutter in a piece's rest space (the cutter itself when the transform is the identity, so
/// nothing is rounded).
fn cutter_in_rest_space(cutter: &Cutter, transform: &DMat4) -> Result<Cutter, EditError> {
    if *transform == DMat4::IDENTITY {
        return Ok(cutter.clone());
    }
    let inverse = transform.inverse();
    let rotation = DMat3::from_mat4(inverse);
    Ok(match cutter {
        Cutter::Plane { point, normal } => Cutter::Plane { point: inverse.transform_point3(*point), normal: rotation * *normal },
        Cutter::Stroke(s) => Cutter::Stroke(SweptStroke::new(
            s.origins().iter().map(|&o| inverse.transform_point3(o)).collect(),
            s.directions().iter().map(|&d| rotation * d).collect(),
        )?),
        Cutter::Solid(mesh) => Cutter::Solid(mesh.transformed(&inverse)),
    })
}

/// The plan of a cut piece: its φ carried over through the kept vertices.
fn plan_of_cut(r: CutResult, p: &Piece) -> Plan {
    let warm = r.kept_vertex.iter().map(|&v| p.fluence[v as usize]).collect();
    Plan { mesh: r.mesh, original_tets: r.original_tet, transform: p.transform, warm }
}

/// The statistics of a piece removed entirely.
fn removed_stats(p: &Piece) -> CutStats {
    CutStats {
        removed_tets: p.mesh.tet_count(),
        removed_vertices: p.mesh.vertex_count(),
        moved_vertices: 0,
        cut_surface_vertices: 0,
        max_cut_distance: 0.0,
        min_dihedral_degrees: f64::INFINITY,
        bound_degrees: f64::INFINITY,
        classify_ms: 0.0,
        separate_ms: 0.0,
        snap_ms: 0.0,
        total_ms: 0.0,
    }
}

/// Cut statistics summed over pieces (worst angle and largest distance over all).
fn merge(a: Option<CutStats>, b: &CutStats) -> CutStats {
    match a {
        None => b.clone(),
        Some(a) => CutStats {
            removed_tets: a.removed_tets + b.removed_tets,
            removed_vertices: a.removed_vertices + b.removed_vertices,
            moved_vertices: a.moved_vertices + b.moved_vertices,
            cut_surface_vertices: a.cut_surface_vertices + b.cut_surface_vertices,
            max_cut_distance: a.max_cut_distance.max(b.max_cut_distance),
            min_dihedral_degrees: a.min_dihedral_degrees.min(b.min_dihedral_degrees),
            bound_degrees: a.bound_degrees.min(b.bound_degrees),
            classify_ms: a.classify_ms + b.classify_ms,
            separate_ms: a.separate_ms + b.separate_ms,
            snap_ms: a.snap_ms + b.snap_ms,
            total_ms: a.total_ms + b.total_ms,
        },
    }
}

/// The plan of the sub-piece made of `tets` (local ids): [`pieces::extract`] compacts the
/// vertices in increasing old id, so φ is carried over through the sorted used vertices.
fn plan_of_subset(p: &Piece, tets: &[u32]) -> Result<Plan, EditError> {
    let (mesh, original_tets) = pieces::extract(&p.mesh, &p.original_tets, tets)?;
    let mut used: Vec<u32> = tets.iter().flat_map(|&t| p.mesh.tets()[t as usize]).collect();
    used.sort_unstable();
    used.dedup();
    let warm = used.iter().map(|&v| p.fluence[v as usize]).collect();
    Ok(Plan { mesh, original_tets, transform: p.transform, warm })
}

/// Welds `b` onto `a` in `a`'s rest space if they touch; φ carried over from both (b's
/// unmerged vertices found by their exact positions in a's rest space).
fn weld_pair(a: &Piece, b: &Piece, tolerance: f64) -> Result<Option<Plan>, EditError> {
    let b_mesh = if a.transform == b.transform {
        b.mesh.as_ref().clone()
    } else {
        let m = a.transform.inverse() * b.transform;
        b.mesh.as_ref().clone().map_positions(move |p| m.transform_point3(p))?
    };
    let Some((mesh, original_tets)) = pieces::weld(&a.mesh, &a.original_tets, &b_mesh, &b.original_tets, tolerance)? else {
        return Ok(None);
    };
    let key = |p: DVec3| p.to_array().map(f64::to_bits);
    let b_index: HashMap<[u64; 3], usize> = b_mesh.positions().iter().enumerate().map(|(i, &p)| (key(p), i)).collect();
    let n_a = a.mesh.vertex_count();
    let warm = (0..mesh.vertex_count())
        .map(|v| if v < n_a { a.fluence[v] } else { b_index.get(&key(mesh.positions()[v])).map_or([0.0; 3], |&i| b.fluence[i]) })
        .collect();
    Ok(Some(Plan { mesh, original_tets, transform: a.transform, warm }))
}

/// The centroid of tet `t`.
fn centroid(mesh: &TetMesh, t: usize) -> DVec3 {
    mesh.tet_positions(t).iter().sum::<DVec3>() / 4.0
}
