//! The diffusion system M φ = b on a tet mesh ([`DiffusionSystem`]): its assembly, the refills
//! after media change (whole, row-local, single entries, with their undo) and after the light
//! changes (the source q and the right-hand side b).
//!
//! The values are filled row by row in parallel from the mesh-only [`Structure`], by one of two
//! kernels ([`Discretization`]): TransCut's eqs. 10–14 ([`super::transcut`]) or the consistent
//! P1 reference ([`super::fem`]). Every row sums its own tets in increasing tet order, so the
//! matrix is bit-for-bit symmetric and identical for any thread count, and a row refilled alone
//! is bit-identical to the same row of a full fill.

use std::sync::Arc;

use rayon::prelude::*;

use super::error::DiffusionError;
use super::fem;
use super::fitted;
use super::structure::{fill_selected_rows, BoundaryVertices, Coefficients, Structure};
use super::transcut;
use crate::mesh::TetMesh;
use crate::optics::{BoundaryTerms, Medium};
use crate::sparse::{CsrMatrix3, CsrPattern};

/// Which discretisation of the diffusion equation a [`DiffusionSystem`] holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum Discretization {
    /// TransCut eqs. 10–14: cotangent edge weights, lumped volume and boundary mass.
    #[default]
    TransCut,
    /// The P1 Galerkin reference with consistent volume and boundary mass and a consistent
    /// boundary load ([`super::fem`]), scaled by the same factor 4.
    ConsistentFem,
    /// TransCut's rows with each edge's stiffness part exponentially fitted to the boundary
    /// layer along it ([`super::fitted`]): more accurate where σtr h is not small, and second
    /// order in h.
    ExponentiallyFitted,
    /// The fitted rows with, on boundary vertices of the smooth surface, the absorption that
    /// makes each row exact for the boundary layer under it ([`super::fitted`],
    /// [`super::layer`]): the most accurate at practical sizes (on the R = 10 mm sphere every
    /// preset within 1% at 300k graded tets), but its convergence slows on fine meshes, where
    /// the fitted rows alone overtake it.
    FittedLayer,
}

impl Discretization {
    /// Every discretisation, in the order of their names.
    pub const ALL: [Discretization; 4] = [
        Discretization::TransCut,
        Discretization::ExponentiallyFitted,
        Discretization::ConsistentFem,
        Discretization::FittedLayer,
    ];

    /// The name used by the command line and scene files: `transcut`, `fitted`, `consistent-fem`,
    /// `fitted-layer`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Discretization::TransCut => "transcut",
            Discretization::ExponentiallyFitted => "fitted",
            Discretization::ConsistentFem => "consistent-fem",
            Discretization::FittedLayer => "fitted-layer",
        }
    }

    /// The discretisation of a [`Self::name`] (any case).
    #[must_use]
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|d| d.name().eq_ignore_ascii_case(name.trim()))
    }
}

/// A diffusion system on a tet mesh: the sparsity pattern (shared), the three-channel matrix M,
/// the source q per boundary vertex and the right-hand side b.
///
/// The matrix depends on the media only ([`DiffusionSystem::set_media`] refills it, e.g. after
/// painting); the right-hand side on the light only ([`DiffusionSystem::set_source`], relighting).
/// The pattern and the mesh geometry are computed once.
#[derive(Debug, Clone)]
pub struct DiffusionSystem {
    structure: Arc<Structure>,
    discretization: Discretization,
    media: Vec<Medium>,
    /// κ and μ of `media` for row-local entry refills: derived by the first
    /// [`DiffusionSystem::update_media_entries`], kept up to date by it from then on, dropped by
    /// whole-table changes (so systems that are never painted do not hold them).
    coefficients: Option<Coefficients>,
    /// Whether tet t's material id is t ([`crate::volume::TableLayout::PerTet`]): then the tets
    /// of a media entry are known without a scan.
    per_tet_ids: bool,
    terms: BoundaryTerms,
    matrix: CsrMatrix3,
    source: Vec<[f64; 3]>,
    rhs: Vec<[f64; 3]>,
}

/// What [`DiffusionSystem::update_media_entries`] overwrote: the previous media entries (in
/// reverse order of the update) and the previous values of the refilled rows.
#[derive(Debug)]
pub(crate) struct MediaUndo {
    previous: Vec<(u32, Medium)>,
    rows: Vec<u32>,
    old_values: Vec<[f64; 3]>,
}

impl MediaUndo {
    /// The refilled rows, ascending.
    pub(crate) fn row_ids(&self) -> &[u32] {
        &self.rows
    }
}

/// The q and b that [`DiffusionSystem::replace_source`] replaced.
#[derive(Debug)]
pub(crate) struct SourceState {
    source: Vec<[f64; 3]>,
    rhs: Vec<[f64; 3]>,
}

/// Assembles the TransCut system (eqs. 10–14) of `mesh` filled with `media`, indexed by the
/// mesh's per-tet material ids; positions are in scene units, `mm_per_unit` millimetres each.
/// The source starts at q = 0 (b = 0); set it with [`DiffusionSystem::set_source`].
///
/// # Errors
/// [`DiffusionError::InvalidScale`] for a `mm_per_unit` that is not finite and > 0;
/// [`DiffusionError::MaterialOutOfRange`] naming the first tet whose material id has no
/// medium; [`DiffusionError::InvalidMedium`] naming an invalid medium of the table;
/// [`DiffusionError::MixedRefractiveIndex`] when the media on the surface disagree on η;
/// [`DiffusionError::DegenerateTet`] for a tet whose geometry gives non-finite coefficients.
pub fn assemble(mesh: &TetMesh, media: &[Medium], mm_per_unit: f64) -> Result<DiffusionSystem, DiffusionError> {
    DiffusionSystem::new(mesh, media, mm_per_unit, Discretization::TransCut)
}

/// [`assemble`] asking `keep_going` between its steps (the mesh's structure and geometry, the
/// media's terms, the matrix), so that a caller can cancel inside a large assembly.
///
/// # Errors
/// As [`assemble`]; [`DiffusionError::Cancelled`] when `keep_going` returns `false`.
pub fn assemble_with(
    mesh: &TetMesh,
    media: &[Medium],
    mm_per_unit: f64,
    keep_going: &dyn Fn() -> bool,
) -> Result<DiffusionSystem, DiffusionError> {
    DiffusionSystem::new_with(mesh, media, mm_per_unit, Discretization::TransCut, keep_going)
}

/// The right-hand side of `system` for the source `q` (one entry per boundary vertex, in the
/// order of [`DiffusionSystem::boundary`]), without changing the system. For TransCut, eq. 12:
/// b_i = 8 S_i q_i / (3A(1 − Fdr)) on boundary vertices, 0 inside; for the consistent FEM the
/// consistent boundary load ([`super::fem`]).
///
/// # Errors
/// [`DiffusionError::LengthMismatch`] unless `q` has one entry per boundary vertex;
/// [`DiffusionError::InvalidSource`] naming the first negative or non-finite value.
pub fn rhs(system: &DiffusionSystem, q: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, DiffusionError> {
    let s = &system.structure;
    check_source(&s.boundary, q, false)?;
    Ok(rhs_unchecked(system, q))
}

/// b for a checked `q` ([`rhs`]).
fn rhs_unchecked(system: &DiffusionSystem, q: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let s = &system.structure;
    match system.discretization {
        Discretization::TransCut | Discretization::ExponentiallyFitted | Discretization::FittedLayer => {
            transcut::rhs_transcut(s, &system.terms, q)
        }
        Discretization::ConsistentFem => fem::rhs_consistent(s, &system.terms, q),
    }
}

impl DiffusionSystem {
    /// Assembles a system with the chosen discretisation; see [`assemble`] (TransCut) and
    /// [`assemble_consistent`].
    ///
    /// # Errors
    /// Those of [`assemble`].
    pub fn new(
        mesh: &TetMesh,
        media: &[Medium],
        mm_per_unit: f64,
        discretization: Discretization,
    ) -> Result<DiffusionSystem, DiffusionError> {
        Self::new_with(mesh, media, mm_per_unit, discretization, &|| true)
    }

    /// [`Self::new`] asking `keep_going` between its steps; see [`assemble_with`].
    ///
    /// # Errors
    /// Those of [`assemble_with`].
    pub fn new_with(
        mesh: &TetMesh,
        media: &[Medium],
        mm_per_unit: f64,
        discretization: Discretization,
        keep_going: &dyn Fn() -> bool,
    ) -> Result<DiffusionSystem, DiffusionError> {
        let check = || if keep_going() { Ok(()) } else { Err(DiffusionError::Cancelled) };
        super::structure::check_scale(mm_per_unit)?;
        check_materials(mesh.materials(), media)?;
        let structure = Arc::new(Structure::new(mesh, mm_per_unit)?);
        check()?;
        let (coefficients, terms) = prepare_media(&structure, media)?;
        check()?;
        let mut matrix = CsrMatrix3::zeros(Arc::clone(&structure.pattern));
        fill_matrix(&structure, discretization, &coefficients, &terms, matrix.values_mut());
        check()?;
        let nb = structure.boundary.len();
        let n = structure.n();
        let per_tet_ids =
            structure.materials.len() == media.len() && structure.materials.par_iter().enumerate().all(|(t, &m)| m as usize == t);
        Ok(DiffusionSystem {
            structure,
            discretization,
            media: media.to_vec(),
            coefficients: None,
            per_tet_ids,
            terms,
            matrix,
            source: vec![[0.0; 3]; nb],
            rhs: vec![[0.0; 3]; n],
        })
    }

    /// Refills the matrix for new media on the same mesh (painting, material edits): the pattern
    /// and geometry are reused. If η changes, the right-hand side is recomputed for the current
    /// source. On error the system is unchanged.
    ///
    /// # Errors
    /// [`DiffusionError::MaterialOutOfRange`], [`DiffusionError::InvalidMedium`],
    /// [`DiffusionError::MixedRefractiveIndex`] as in [`assemble`].
    pub fn set_media(&mut self, media: &[Medium]) -> Result<(), DiffusionError> {
        check_materials(&self.structure.materials, media)?;
        let (coefficients, terms) = prepare_media(&self.structure, media)?;
        fill_matrix(&self.structure, self.discretization, &coefficients, &terms, self.matrix.values_mut());
        self.media = media.to_vec();
        self.coefficients = None;
        if terms != self.terms {
            self.terms = terms;
            self.rhs = rhs(self, &self.source)?;
        }
        Ok(())
    }

    /// Refills only the matrix rows of the vertices of `tets` for the new media table `media`
    /// (painting, TransCut §5.2: "we only update the rows corresponding to the vertices of
    /// tetrahedra that are affected"). Returns the refilled rows, ascending (e.g. for
    /// [`crate::diffusion::MultiresSolver::refresh_rows`]).
    ///
    /// `media` is the whole new table (indexed by the mesh's material ids, as in
    /// [`DiffusionSystem::set_media`]); it may differ from the current one only in media used by
    /// the listed tets (with [`crate::volume::TableLayout::PerTet`] ids, exactly the listed
    /// tets' entries), and must keep the surface's η (the boundary terms of every boundary row
    /// and b depend on it). Each refilled row sums its tets in the same order as a full fill,
    /// so the matrix is bit-identical to [`DiffusionSystem::set_media`] with the same table.
    /// On error the system is unchanged.
    ///
    /// # Errors
    /// [`DiffusionError::TetOutOfRange`] for a tet id that does not exist;
    /// [`DiffusionError::MaterialOutOfRange`], [`DiffusionError::InvalidMedium`],
    /// [`DiffusionError::MixedRefractiveIndex`] as in [`assemble`];
    /// [`DiffusionError::RefractiveIndexChanged`] when the surface η differs from the current
    /// one; [`DiffusionError::UnlistedMediaChange`] naming a tet whose medium changed but which
    /// is not listed.
    pub fn update_media_rows(&mut self, media: &[Medium], tets: &[u32]) -> Result<Vec<u32>, DiffusionError> {
        let s = &*self.structure;
        let rows = s.rows_of_tets(tets)?;
        check_materials(&s.materials, media)?;
        let (coefficients, terms) = prepare_media(s, media)?;
        if terms != self.terms {
            return Err(DiffusionError::RefractiveIndexChanged { old: self.terms.eta, new: terms.eta });
        }
        check_listed(s, &self.media, media, tets)?;
        refill_rows(s, self.discretization, &coefficients, &terms, self.matrix.values_mut(), &rows);
        self.media = media.to_vec();
        self.coefficients = None;
        Ok(rows)
    }

    /// [`DiffusionSystem::update_media_rows`] for a few table entries, in time proportional to
    /// what they touch rather than to the table (the editor's paint, TransCut §5.2): sets
    /// `media[m] = medium` for each `(m, medium)` of `entries` (in order) and refills the matrix
    /// rows of the vertices of every tet whose material is one of them. The refilled rows are
    /// bit-identical to a full fill with the new table. Returns what it overwrote, for
    /// [`DiffusionSystem::undo_media_entries`]. On error the system is unchanged.
    ///
    /// # Errors
    /// [`DiffusionError::LengthMismatch`] for a material id outside the table;
    /// [`DiffusionError::InvalidMedium`] naming an invalid new medium;
    /// [`DiffusionError::RefractiveIndexChanged`] for a new medium on the surface whose η is
    /// not the surface's.
    pub(crate) fn update_media_entries(&mut self, entries: &[(u32, Medium)]) -> Result<MediaUndo, DiffusionError> {
        let s = &*self.structure;
        for &(m, medium) in entries {
            let index = m as usize;
            if index >= self.media.len() {
                return Err(DiffusionError::LengthMismatch {
                    what: "material id of a media entry (media table length)",
                    expected: self.media.len(),
                    found: index,
                });
            }
            medium.validate().map_err(|source| DiffusionError::InvalidMedium { index, source })?;
        }
        let eta = self.terms.eta;
        if let Some(&(_, medium)) = entries.iter().find(|(m, medium)| medium.eta != eta && s.face_material.contains(m)) {
            return Err(DiffusionError::RefractiveIndexChanged { old: eta, new: medium.eta });
        }
        // Nothing fails from here on.
        let tets: Vec<u32> = if self.per_tet_ids {
            entries.iter().map(|&(m, _)| m).collect()
        } else {
            let mut changed = vec![false; self.media.len()];
            for &(m, _) in entries {
                changed[m as usize] = true;
            }
            s.materials.par_iter().enumerate().filter_map(|(t, &m)| changed[m as usize].then_some(t as u32)).collect()
        };
        let rows = s.rows_of_tets(&tets)?;
        let row_ptr = s.pattern.row_ptr();
        let values = self.matrix.values();
        let old_values: Vec<[f64; 3]> =
            rows.iter().flat_map(|&r| values[row_ptr[r as usize]..row_ptr[r as usize + 1]].iter().copied()).collect();
        let mut previous: Vec<(u32, Medium)> = entries.iter().map(|&(m, medium)| (m, self.set_entry(m, medium))).collect();
        previous.reverse();
        // Refill from κ and μ of the new media (derived whole once, then kept entry by entry).
        let media = &self.media;
        let c = &*self.coefficients.get_or_insert_with(|| Coefficients::of(media));
        refill_rows(&self.structure, self.discretization, c, &self.terms, self.matrix.values_mut(), &rows);
        Ok(MediaUndo { previous, rows, old_values })
    }

    /// Derives now the κ and μ that row-local entry refills keep
    /// ([`DiffusionSystem::update_media_entries`]), so that the first refill does not pay for
    /// them: for systems that will be painted, such as an editor's.
    pub(crate) fn keep_coefficients(&mut self) {
        if self.coefficients.is_none() {
            self.coefficients = Some(Coefficients::of(&self.media));
        }
    }

    /// Puts back what [`DiffusionSystem::update_media_entries`] overwrote (the latest update
    /// first, if several): the media entries and the matrix rows, bit for bit.
    pub(crate) fn undo_media_entries(&mut self, undo: MediaUndo) {
        for (m, medium) in undo.previous {
            self.set_entry(m, medium);
        }
        let row_ptr = self.structure.pattern.row_ptr();
        let values = self.matrix.values_mut();
        let mut old = undo.old_values.as_slice();
        for &r in &undo.rows {
            let range = row_ptr[r as usize]..row_ptr[r as usize + 1];
            let (row, rest) = old.split_at(range.len());
            values[range].copy_from_slice(row);
            old = rest;
        }
    }

    /// Sets media entry `m` and, when they are kept, its κ, μ and σtr (as [`prepare_media`]
    /// derives them); returns the previous entry.
    fn set_entry(&mut self, m: u32, medium: Medium) -> Medium {
        let m = m as usize;
        if let Some(c) = &mut self.coefficients {
            c.set(m, &medium);
        }
        std::mem::replace(&mut self.media[m], medium)
    }

    /// Replaces the transmitted source q (as [`DiffusionSystem::set_source`], taking `q` by
    /// value) and returns the previous q and b, for [`DiffusionSystem::restore_source`]. On
    /// error the system is unchanged.
    ///
    /// # Errors
    /// Those of [`rhs`].
    pub(crate) fn replace_source(&mut self, q: Vec<[f64; 3]>) -> Result<SourceState, DiffusionError> {
        let rhs = rhs(self, &q)?;
        Ok(SourceState { source: std::mem::replace(&mut self.source, q), rhs: std::mem::replace(&mut self.rhs, rhs) })
    }

    /// Puts back the q and b that [`DiffusionSystem::replace_source`] returned.
    pub(crate) fn restore_source(&mut self, state: SourceState) {
        self.source = state.source;
        self.rhs = state.rhs;
    }

    /// Sets the transmitted source q (one entry per boundary vertex, in the order of
    /// [`DiffusionSystem::boundary`], per channel) and recomputes b ([`rhs`]). On error the
    /// system is unchanged.
    ///
    /// # Errors
    /// Those of [`rhs`].
    pub fn set_source(&mut self, q: &[[f64; 3]]) -> Result<(), DiffusionError> {
        self.rhs = rhs(self, q)?;
        self.source = q.to_vec();
        Ok(())
    }

    /// [`DiffusionSystem::set_source`] for a `q` of either sign: a difference of lightings, which
    /// a Krylov iteration of translucent radiosity scatters (the system is linear in q; only
    /// the light a bake computes must be ≥ 0).
    ///
    /// # Errors
    /// [`DiffusionError::LengthMismatch`]; [`DiffusionError::InvalidSource`] naming the first
    /// value that is not finite. On error the system is unchanged.
    pub(crate) fn set_signed_source(&mut self, q: &[[f64; 3]]) -> Result<(), DiffusionError> {
        check_source(&self.structure.boundary, q, true)?;
        self.rhs = rhs_unchecked(self, q);
        self.source = q.to_vec();
        Ok(())
    }

    /// The sparsity pattern (the mesh's vertex graph plus the diagonal), shared with the matrix.
    #[must_use]
    pub fn pattern(&self) -> &Arc<CsrPattern> {
        &self.structure.pattern
    }

    /// The matrix M, per channel.
    #[must_use]
    pub fn matrix(&self) -> &CsrMatrix3 {
        &self.matrix
    }

    /// The right-hand side b, one entry per vertex.
    #[must_use]
    pub fn rhs(&self) -> &[[f64; 3]] {
        &self.rhs
    }

    /// The transmitted source q, one entry per boundary vertex.
    #[must_use]
    pub fn source(&self) -> &[[f64; 3]] {
        &self.source
    }

    /// The boundary vertices (ids, areas S_i, normals): the order of q and of the radiance.
    #[must_use]
    pub fn boundary(&self) -> &BoundaryVertices {
        &self.structure.boundary
    }

    /// The boundary constants (Fdr, A, Ft along the normal) of the object's η.
    #[must_use]
    pub fn boundary_terms(&self) -> &BoundaryTerms {
        &self.terms
    }

    /// The discretisation this system holds.
    #[must_use]
    pub fn discretization(&self) -> Discretization {
        self.discretization
    }

    /// The media table the matrix was filled from.
    #[must_use]
    pub fn media(&self) -> &[Medium] {
        &self.media
    }

    /// Millimetres per scene unit.
    #[must_use]
    pub fn mm_per_unit(&self) -> f64 {
        self.structure.mm_per_unit
    }

    /// Number of vertices (unknowns per channel).
    #[must_use]
    pub fn vertex_count(&self) -> usize {
        self.structure.n()
    }

    /// The mesh-only structure.
    pub(crate) fn structure(&self) -> &Structure {
        &self.structure
    }
}

/// Assembles the consistent P1 system of `mesh` (see the module documentation), with the same
/// inputs, units and scale as [`assemble`].
///
/// # Errors
/// Those of [`assemble`].
pub fn assemble_consistent(mesh: &TetMesh, media: &[Medium], mm_per_unit: f64) -> Result<DiffusionSystem, DiffusionError> {
    DiffusionSystem::new(mesh, media, mm_per_unit, Discretization::ConsistentFem)
}

/// Assembles the exponentially fitted variant of TransCut's system ([`super::fitted`]), with
/// the same inputs, units and scale as [`assemble`].
///
/// # Errors
/// Those of [`assemble`].
pub fn assemble_fitted(mesh: &TetMesh, media: &[Medium], mm_per_unit: f64) -> Result<DiffusionSystem, DiffusionError> {
    DiffusionSystem::new(mesh, media, mm_per_unit, Discretization::ExponentiallyFitted)
}

/// Checks the material ids against the table, naming the first tet at fault.
fn check_materials(materials: &[u32], media: &[Medium]) -> Result<(), DiffusionError> {
    if let Some(tet) = materials.par_iter().position_first(|&m| m as usize >= media.len()) {
        return Err(DiffusionError::MaterialOutOfRange { tet, material: materials[tet], media: media.len() });
    }
    Ok(())
}

/// Every tet whose medium differs between `old` and `new` (bitwise, or by a table that grew)
/// must be in `tets`.
fn check_listed(s: &Structure, old: &[Medium], new: &[Medium], tets: &[u32]) -> Result<(), DiffusionError> {
    let changed: Vec<bool> = new.par_iter().enumerate().map(|(m, x)| old.get(m) != Some(x)).collect();
    let mut listed = vec![false; s.tets.len()];
    for &t in tets {
        listed[t as usize] = true;
    }
    let unlisted = s.materials.par_iter().enumerate().position_first(|(t, &m)| changed[m as usize] && !listed[t]);
    match unlisted {
        Some(tet) => Err(DiffusionError::UnlistedMediaChange { tet, material: s.materials[tet] }),
        None => Ok(()),
    }
}

/// Validates the media, derives κ and μ per material and the boundary constants of the one η of
/// the surface media.
pub(crate) fn prepare_media(s: &Structure, media: &[Medium]) -> Result<(Coefficients, BoundaryTerms), DiffusionError> {
    for (index, m) in media.iter().enumerate() {
        m.validate().map_err(|source| DiffusionError::InvalidMedium { index, source })?;
    }
    let first = s.face_material.first().copied().unwrap_or(0);
    let first_eta = media[first as usize].eta;
    if let Some(&other) = s.face_material.iter().find(|&&m| media[m as usize].eta != first_eta) {
        return Err(DiffusionError::MixedRefractiveIndex { first, first_eta, other, other_eta: media[other as usize].eta });
    }
    let terms =
        BoundaryTerms::new(first_eta).map_err(|source| DiffusionError::InvalidMedium { index: first as usize, source })?;
    Ok((Coefficients::of(media), terms))
}

/// Refills the matrix rows `rows` (increasing) of the chosen discretisation, each summed as in a
/// full fill ([`transcut::transcut_row`], [`fem::consistent_row`]).
fn refill_rows(
    s: &Structure,
    discretization: Discretization,
    c: &Coefficients,
    terms: &BoundaryTerms,
    values: &mut [[f64; 3]],
    rows: &[u32],
) {
    fill_selected_rows(values, s.pattern.row_ptr(), rows, |i, row| match discretization {
        Discretization::TransCut => transcut::transcut_row(s, c, terms, i, row),
        Discretization::ConsistentFem => fem::consistent_row(s, c, terms, i, row),
        Discretization::ExponentiallyFitted => fitted::fitted_row(s, c, terms, i, row, false),
        Discretization::FittedLayer => fitted::fitted_row(s, c, terms, i, row, true),
    });
}

/// Fills the matrix values of the chosen discretisation.
fn fill_matrix(s: &Structure, discretization: Discretization, c: &Coefficients, terms: &BoundaryTerms, values: &mut [[f64; 3]]) {
    match discretization {
        Discretization::TransCut => transcut::fill_transcut(s, c, terms, values),
        Discretization::ConsistentFem => fem::fill_consistent(s, c, terms, values),
        Discretization::ExponentiallyFitted => fitted::fill_fitted(s, c, terms, values, false),
        Discretization::FittedLayer => fitted::fill_fitted(s, c, terms, values, true),
    }
}

/// q must have one finite, non-negative entry per boundary vertex.
fn check_source(boundary: &BoundaryVertices, q: &[[f64; 3]], signed: bool) -> Result<(), DiffusionError> {
    if q.len() != boundary.len() {
        return Err(DiffusionError::LengthMismatch {
            what: "source q (one entry per boundary vertex)",
            expected: boundary.len(),
            found: q.len(),
        });
    }
    for (index, v) in q.iter().enumerate() {
        if let Some(channel) = v.iter().position(|x| !(x.is_finite() && (signed || *x >= 0.0))) {
            return Err(DiffusionError::InvalidSource { index, vertex: boundary.ids[index], channel, value: v[channel] });
        }
    }
    Ok(())
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // per-channel loops read best indexed
pub(crate) mod tests {
    use super::super::structure::{EDGE_INDEX, INTERIOR};
    use super::*;
    use glam::DVec3;

    /// The cube [0, size]³ as `cells`³ cubes of 6 Kuhn tets each (interior vertices from 2
    /// cells on).
    pub(crate) fn cube_mesh(cells: usize, size: f64) -> TetMesh {
        let m = cells + 1;
        let idx = |x: usize, y: usize, z: usize| (x + m * (y + m * z)) as u32;
        let h = size / cells as f64;
        let mut positions = Vec::new();
        for z in 0..m {
            for y in 0..m {
                for x in 0..m {
                    positions.push(DVec3::new(x as f64, y as f64, z as f64) * h);
                }
            }
        }
        let mut tets = Vec::new();
        for z in 0..cells {
            for y in 0..cells {
                for x in 0..cells {
                    let c = |d: usize| idx(x + (d & 1), y + ((d >> 1) & 1), z + ((d >> 2) & 1));
                    // Kuhn: six tets along the main diagonal 0 → 7.
                    for perm in [[1, 2, 4], [1, 4, 2], [2, 1, 4], [2, 4, 1], [4, 1, 2], [4, 2, 1]] {
                        let (a, b) = (perm[0], perm[0] | perm[1]);
                        tets.push([c(0), c(a), c(b), c(7)]);
                    }
                }
            }
        }
        TetMesh::new(positions, tets, Vec::new()).unwrap()
    }

    fn marble() -> Medium {
        Medium::preset("marble").unwrap()
    }

    #[test]
    fn rows_of_the_stiffness_sum_to_the_absorption_and_boundary_terms() {
        let mesh = cube_mesh(3, 2.0);
        let sys = assemble(&mesh, &[marble()], 1.5).unwrap();
        let p = sys.pattern();
        let vals = sys.matrix().values();
        let m = marble();
        let s = sys.structure();
        for i in 0..mesh.vertex_count() {
            let mut row_sum = [0.0; 3];
            for k in p.row_ptr()[i]..p.row_ptr()[i + 1] {
                for c in 0..3 {
                    row_sum[c] += vals[k][c];
                }
            }
            // −4Σw_ij cancels the off-diagonals: the row sum is V_i μ (+ 2S_i/(3A)).
            let vi: f64 = s.tets_of(i).iter().map(|inc| s.volume[inc.tet as usize]).sum();
            let b = s.boundary_index[i];
            let boundary =
                if b == INTERIOR { 0.0 } else { 2.0 * s.boundary.area_mm2[b as usize] / (3.0 * sys.boundary_terms().a) };
            for c in 0..3 {
                let expect = vi * m.sigma_a[c] + boundary;
                assert!((row_sum[c] - expect).abs() < 1e-12 * vals[p.diagonal_positions()[i]][c]);
            }
        }
        // Lengths in mm: the cube is 3 mm wide, so the volume is 27 mm³ and the area 54 mm².
        assert!((s.volume.iter().sum::<f64>() - 27.0).abs() < 1e-12);
        assert!((sys.boundary().total_area_mm2() - 54.0).abs() < 1e-12);
        assert!(sys.matrix().is_symmetric(0.0));
    }

    #[test]
    fn matrix_matches_a_direct_sum_of_equation_10() {
        // Direct transcription of eqs. 10, 13, 14 with the mesh module's dihedral angles.
        let mesh = cube_mesh(2, 1.0);
        let m = Medium::new([0.1, 0.2, 0.3], [1.0, 2.0, 3.0], 1.4, 0.0).unwrap();
        let sys = assemble(&mesh, &[m], 2.0).unwrap();
        let n = mesh.vertex_count();
        let kappa = m.diffusion_coefficient();
        let mut dense = vec![vec![[0.0; 3]; n]; n];
        for t in 0..mesh.tet_count() {
            let tet = mesh.tets()[t];
            let p = mesh.tet_positions(t).map(|x| x * 2.0);
            let angles = crate::mesh::dihedral_angles(p);
            for (i, j) in [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)] {
                let [k, l] = super::super::structure::other_pair(i, j);
                let theta = angles[EDGE_INDEX[k][l]];
                for c in 0..3 {
                    let w = -kappa[c] * (p[k] - p[l]).length() / theta.tan() / 6.0;
                    let (a, b) = (tet[i] as usize, tet[j] as usize);
                    dense[a][b][c] += 4.0 * w;
                    dense[b][a][c] += 4.0 * w;
                    dense[a][a][c] -= 4.0 * w;
                    dense[b][b][c] -= 4.0 * w;
                }
            }
            let v = crate::mesh::tet_volume(p);
            for &a in &tet {
                for c in 0..3 {
                    dense[a as usize][a as usize][c] += v * m.sigma_a[c];
                }
            }
        }
        let a = BoundaryTerms::new(1.4).unwrap().a;
        for f in 0..mesh.boundary_faces().len() {
            let area = mesh.boundary_area(f) * 4.0;
            for &v in &mesh.boundary_faces()[f].vertices {
                for c in 0..3 {
                    dense[v as usize][v as usize][c] += 2.0 * area / (3.0 * a);
                }
            }
        }
        let scale = dense.iter().flatten().map(|v| v[0].abs()).fold(0.0, f64::max);
        for i in 0..n {
            for j in 0..n {
                let got = sys.matrix().get(i, j).unwrap_or([0.0; 3]);
                for c in 0..3 {
                    assert!((got[c] - dense[i][j][c]).abs() < 1e-12 * scale, "({i}, {j}) {c}");
                }
            }
        }
    }

    #[test]
    fn right_hand_side_is_equation_12() {
        let mesh = cube_mesh(2, 1.0);
        let mut sys = assemble(&mesh, &[marble()], 1.0).unwrap();
        let nb = sys.boundary().len();
        assert_eq!(nb, 26);
        let q: Vec<[f64; 3]> = (0..nb).map(|k| [k as f64, 1.0, 0.5]).collect();
        sys.set_source(&q).unwrap();
        let t = *sys.boundary_terms();
        for (k, &v) in sys.boundary().ids.iter().enumerate() {
            let s = sys.boundary().area_mm2[k];
            for c in 0..3 {
                let expect = 8.0 * s * q[k][c] / (3.0 * t.a * (1.0 - t.fdr));
                assert!((sys.rhs()[v as usize][c] - expect).abs() < 1e-14 * (1.0 + expect));
            }
        }
        assert_eq!(sys.rhs()[13], [0.0; 3]); // the centre vertex is interior
        assert_eq!(sys.source(), &q[..]);
    }

    #[test]
    fn bad_inputs_are_named_and_leave_the_system_unchanged() {
        let mut mesh = cube_mesh(1, 1.0);
        assert!(matches!(assemble(&mesh, &[marble()], 0.0), Err(DiffusionError::InvalidScale { .. })));
        assert!(matches!(assemble(&mesh, &[marble()], f64::NAN), Err(DiffusionError::InvalidScale { .. })));
        assert!(matches!(assemble(&mesh, &[], 1.0), Err(DiffusionError::MaterialOutOfRange { tet: 0, material: 0, media: 0 })));
        let bad = Medium { sigma_a: [-1.0, 0.0, 0.0], ..marble() };
        assert!(matches!(assemble(&mesh, &[marble(), bad], 1.0), Err(DiffusionError::InvalidMedium { index: 1, .. })));
        mesh.set_materials(vec![0, 0, 1, 0, 0, 0]).unwrap();
        let other = Medium { eta: 1.3, ..marble() };
        let e = assemble(&mesh, &[marble(), other], 1.0).unwrap_err();
        assert!(matches!(e, DiffusionError::MixedRefractiveIndex { first: 0, other: 1, .. }), "{e}");

        let mut sys = assemble(&mesh, &[marble(), marble()], 1.0).unwrap();
        let before = sys.clone();
        assert!(matches!(sys.set_source(&[[1.0; 3]; 3]), Err(DiffusionError::LengthMismatch { .. })));
        let mut q = vec![[1.0; 3]; sys.boundary().len()];
        q[5][1] = f64::NAN;
        assert!(matches!(sys.set_source(&q), Err(DiffusionError::InvalidSource { index: 5, channel: 1, .. })));
        q[5][1] = -0.5;
        assert!(matches!(sys.set_source(&q), Err(DiffusionError::InvalidSource { index: 5, .. })));
        assert!(matches!(sys.set_media(&[marble()]), Err(DiffusionError::MaterialOutOfRange { tet: 2, .. })));
        assert_eq!(sys.matrix().values(), before.matrix().values());
        assert_eq!(sys.rhs(), before.rhs());
    }

    #[test]
    fn set_media_refills_values_on_the_same_pattern() {
        let mesh = cube_mesh(2, 1.0);
        let skin = Medium::preset("skin1").unwrap();
        let mut sys = assemble(&mesh, &[marble()], 1.0).unwrap();
        sys.set_source(&vec![[1.0; 3]; sys.boundary().len()]).unwrap();
        let pattern = Arc::clone(sys.pattern());
        sys.set_media(&[skin]).unwrap();
        assert!(Arc::ptr_eq(&pattern, sys.pattern()));
        let mut fresh = assemble(&mesh, &[skin], 1.0).unwrap();
        fresh.set_source(&vec![[1.0; 3]; fresh.boundary().len()]).unwrap();
        assert_eq!(sys.matrix().values(), fresh.matrix().values());
        // η changed from 1.5 to 1.3: b follows.
        assert_eq!(sys.rhs(), fresh.rhs());
    }

    #[test]
    fn row_local_refill_equals_a_full_refill_and_counts_its_rows() {
        let mut mesh = cube_mesh(4, 1.0);
        let nt = mesh.tet_count();
        mesh.set_materials((0..nt as u32).collect()).unwrap();
        let base: Vec<Medium> = (0..nt).map(|t| Medium { sigma_a: [0.01 + 1e-4 * t as f64; 3], ..marble() }).collect();
        for discretization in [Discretization::TransCut, Discretization::ConsistentFem] {
            let mut sys = DiffusionSystem::new(&mesh, &base, 1.7, discretization).unwrap();
            // Paint a few scattered tets (and one twice in the list).
            let painted = [3u32, 40, 41, 200, 3, 377];
            let mut media = base.clone();
            for &t in &painted {
                media[t as usize] = Medium { sigma_a: [0.3, 0.2, 0.1], sigma_s_prime: [1.5, 2.0, 2.5], ..marble() };
            }
            let rows = sys.update_media_rows(&media, &painted).unwrap();
            let mut full = DiffusionSystem::new(&mesh, &base, 1.7, discretization).unwrap();
            full.set_media(&media).unwrap();
            assert_eq!(sys.matrix().values(), full.matrix().values(), "{discretization:?}");
            assert_eq!(sys.media(), full.media());
            // The rows, from the tets directly.
            let mut verts: Vec<u32> = painted.iter().flat_map(|&t| mesh.tets()[t as usize]).collect();
            verts.sort_unstable();
            verts.dedup();
            assert_eq!(rows, verts);
            assert!(rows.len() < mesh.vertex_count() / 2);
            // Rows that were not listed really were not touched: a stale matrix stays stale.
            let mut stale = DiffusionSystem::new(&mesh, &base, 1.7, discretization).unwrap();
            let before = stale.matrix().values().to_vec();
            assert!(stale.update_media_rows(&base, &[]).unwrap().is_empty());
            assert_eq!(stale.matrix().values(), &before[..]);
        }
    }

    #[test]
    fn row_local_refill_rejects_bad_input_and_leaves_the_system_unchanged() {
        let mut mesh = cube_mesh(2, 1.0);
        let nt = mesh.tet_count();
        mesh.set_materials((0..nt as u32).collect()).unwrap();
        let base = vec![marble(); nt];
        let mut sys = assemble(&mesh, &base, 1.0).unwrap();
        let before = sys.clone();
        let mut media = base.clone();
        media[5].sigma_a = [0.5; 3];
        assert!(
            matches!(sys.update_media_rows(&media, &[nt as u32]), Err(DiffusionError::TetOutOfRange { tet, count }) if tet == nt && count == nt)
        );
        assert!(matches!(sys.update_media_rows(&media, &[4]), Err(DiffusionError::UnlistedMediaChange { tet: 5, material: 5 })));
        assert!(matches!(sys.update_media_rows(&media[..3], &[5]), Err(DiffusionError::MaterialOutOfRange { tet: 3, .. })));
        let eta: Vec<Medium> = base.iter().map(|m| Medium { eta: 1.3, ..*m }).collect();
        let all: Vec<u32> = (0..nt as u32).collect();
        assert!(matches!(sys.update_media_rows(&eta, &all), Err(DiffusionError::RefractiveIndexChanged { .. })));
        media[5].sigma_a = [f64::NAN; 3];
        assert!(matches!(sys.update_media_rows(&media, &[5]), Err(DiffusionError::InvalidMedium { index: 5, .. })));
        assert_eq!(sys.matrix().values(), before.matrix().values());
        assert_eq!(sys.media(), before.media());
    }

    #[test]
    fn entry_refill_equals_a_full_refill_and_its_undo_restores_every_bit() {
        let mut mesh = cube_mesh(4, 1.0);
        let nt = mesh.tet_count();
        mesh.set_materials((0..nt as u32).collect()).unwrap();
        let base: Vec<Medium> = (0..nt).map(|t| Medium { sigma_a: [0.01 + 1e-4 * t as f64; 3], ..marble() }).collect();
        let ink = Medium { sigma_a: [0.3, 0.2, 0.1], sigma_s_prime: [1.5, 2.0, 2.5], ..marble() };
        for discretization in [Discretization::TransCut, Discretization::ConsistentFem] {
            let mut sys = DiffusionSystem::new(&mesh, &base, 1.7, discretization).unwrap();
            let before = sys.clone();
            // Tet 3 twice: the last value wins, the undo restores the first.
            let entries = [(3u32, marble()), (40, ink), (41, ink), (200, ink), (3, ink), (377, ink)];
            let undo = sys.update_media_entries(&entries).unwrap();
            let mut media = base.clone();
            for &(t, m) in &entries {
                media[t as usize] = m;
            }
            let mut full = DiffusionSystem::new(&mesh, &base, 1.7, discretization).unwrap();
            full.set_media(&media).unwrap();
            assert_eq!(sys.matrix().values(), full.matrix().values(), "{discretization:?}");
            assert_eq!(sys.media(), full.media());
            let mut rows = DiffusionSystem::new(&mesh, &base, 1.7, discretization).unwrap();
            let tets: Vec<u32> = entries.iter().map(|e| e.0).collect();
            assert_eq!(undo.row_ids(), rows.update_media_rows(&media, &tets).unwrap());
            sys.undo_media_entries(undo);
            assert_eq!(sys.matrix().values(), before.matrix().values());
            assert_eq!(sys.media(), before.media());
            // The undo also restored the kept κ and μ: a later refill starts from the base.
            sys.update_media_entries(&[(100, ink)]).unwrap();
            let mut media = base.clone();
            media[100] = ink;
            full.set_media(&media).unwrap();
            assert_eq!(sys.matrix().values(), full.matrix().values());
        }
        // A shared table (ids are not tet indices): an entry refills the rows of every tet using it.
        mesh.set_materials((0..nt as u32).map(|t| t % 3).collect()).unwrap();
        let table = [marble(), Medium { sigma_a: [0.02; 3], ..marble() }, Medium { sigma_a: [0.04; 3], ..marble() }];
        let mut sys = assemble(&mesh, &table, 1.7).unwrap();
        let undo = sys.update_media_entries(&[(1, ink)]).unwrap();
        let mut full = assemble(&mesh, &table, 1.7).unwrap();
        let tets: Vec<u32> = (0..nt as u32).filter(|t| t % 3 == 1).collect();
        let rows = full.update_media_rows(&[table[0], ink, table[2]], &tets).unwrap();
        assert_eq!(sys.matrix().values(), full.matrix().values());
        assert_eq!(undo.row_ids(), rows);
    }

    #[test]
    fn entry_refill_rejects_bad_entries_and_leaves_the_system_unchanged() {
        let mut mesh = cube_mesh(2, 1.0);
        let nt = mesh.tet_count();
        mesh.set_materials((0..nt as u32).collect()).unwrap();
        let mut sys = assemble(&mesh, &vec![marble(); nt], 1.0).unwrap();
        let before = sys.clone();
        let ink = Medium { sigma_a: [0.5; 3], ..marble() };
        let e = sys.update_media_entries(&[(0, ink), (nt as u32, ink)]).unwrap_err();
        assert!(matches!(e, DiffusionError::LengthMismatch { expected, found, .. } if expected == nt && found == nt), "{e}");
        let e = sys.update_media_entries(&[(0, ink), (5, Medium { sigma_a: [f64::NAN; 3], ..marble() })]).unwrap_err();
        assert!(matches!(e, DiffusionError::InvalidMedium { index: 5, .. }), "{e}");
        let surface = sys.structure().face_material[0];
        let e = sys.update_media_entries(&[(0, ink), (surface, Medium { eta: marble().eta + 0.1, ..marble() })]).unwrap_err();
        assert!(matches!(e, DiffusionError::RefractiveIndexChanged { .. }), "{e}");
        assert_eq!(sys.matrix().values(), before.matrix().values());
        assert_eq!(sys.media(), before.media());
        // No entries: nothing refilled.
        assert!(sys.update_media_entries(&[]).unwrap().row_ids().is_empty());
    }

    #[test]
    fn a_replaced_source_is_restored_bit_for_bit() {
        let mesh = cube_mesh(2, 1.0);
        let mut sys = assemble(&mesh, &[marble()], 1.0).unwrap();
        let nb = sys.boundary().len();
        sys.set_source(&(0..nb).map(|k| [k as f64, 1.0, 0.5]).collect::<Vec<_>>()).unwrap();
        let before = sys.clone();
        assert!(matches!(sys.replace_source(vec![[-1.0; 3]; nb]), Err(DiffusionError::InvalidSource { .. })));
        assert_eq!((sys.source(), sys.rhs()), (before.source(), before.rhs()));
        let old = sys.replace_source(vec![[2.0; 3]; nb]).unwrap();
        let mut direct = before.clone();
        direct.set_source(&vec![[2.0; 3]; nb]).unwrap();
        assert_eq!((sys.source(), sys.rhs()), (direct.source(), direct.rhs()));
        sys.restore_source(old);
        assert_eq!((sys.source(), sys.rhs()), (before.source(), before.rhs()));
    }

    #[test]
    fn assembly_is_deterministic_across_thread_counts() {
        let mesh = cube_mesh(6, 1.0);
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let a = one.install(|| assemble(&mesh, &[marble()], 1.0).unwrap());
        let four = rayon::ThreadPoolBuilder::new().num_threads(4).build().unwrap();
        let b = four.install(|| assemble(&mesh, &[marble()], 1.0).unwrap());
        assert_eq!(a.matrix().values(), b.matrix().values());
    }
}
