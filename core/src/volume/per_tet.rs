//! [`PerTetMedia`]: one medium per tet, the form in which a heterogeneous material reaches the
//! diffusion assembly.

use std::collections::HashMap;

use rayon::prelude::*;

use super::error::VolumeError;
use super::field::{Coefficients, MediumField, TetSampling};
use crate::mesh::TetMesh;
use crate::optics::Medium;

/// The heterogeneous medium of a tet mesh: σa and σ′s (per RGB channel, mm⁻¹) constant in
/// each tet, and one refractive index η and one anisotropy g for the whole object.
///
/// **One η per object.** The diffusion boundary condition φ + 2Aκ ∂φ/∂n = 4q/(1 − Fdr) and the
/// radiance query use a single Fdr, A and Ft(ωo), all functions of the η of the medium at the
/// surface, so an object has one η (the diffusion assembly rejects surface media that disagree).
/// The interior of the diffusion equation does not see η at all, nor g (σ′s = (1 − g)σs already
/// holds it), so one g per object loses nothing the solver uses; it is kept for methods that
/// need the phase function.
///
/// Every tet's coefficients are valid: finite, ≥ 0, and σa + σ′s > 0 in every channel (so
/// κ = 1/(3(σa + σ′s)) is finite); every constructor checks this and names the first tet at
/// fault.
///
/// # Into the diffusion solver
///
/// [`crate::diffusion::assemble`] takes the mesh's per-tet material ids and a `&[Medium]`
/// table. [`PerTetMedia::apply`] writes ids into the mesh and returns the matching table:
///
/// ```
/// use transcut::diffusion::assemble;
/// use transcut::mesh::TetMesh;
/// use transcut::optics::Medium;
/// use transcut::volume::{Coefficients, PerTetMedia, TableLayout, TetSampling};
/// use transcut::DVec3;
///
/// let corners: Vec<DVec3> =
///     (0..8).map(|d| DVec3::new((d & 1) as f64, ((d >> 1) & 1) as f64, ((d >> 2) & 1) as f64)).collect();
/// let tets = vec![[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]];
/// let mut mesh = TetMesh::new(corners, tets, vec![])?;
/// // Absorption growing along x.
/// let field = |p: DVec3| Coefficients::new([0.01 + 0.1 * p.x; 3], [2.0; 3]);
/// let media = PerTetMedia::from_field(&mesh, &field, 1.3, 0.0, TetSampling::FivePoint)?;
/// let table = media.apply(&mut mesh, TableLayout::PerTet)?;
/// let mut system = assemble(&mesh, &table, 10.0)?;
/// // Later (painting): new values, same ids, the pattern is reused.
/// let table = media.material_table(TableLayout::PerTet).media;
/// system.set_media(&table)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct PerTetMedia {
    coefficients: Vec<Coefficients>,
    eta: f64,
    g: f64,
}

/// How [`PerTetMedia::material_table`] numbers the media.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum TableLayout {
    /// Material id = tet index, one table entry per tet. The ids do not depend on the values,
    /// so after painting or re-sampling [`crate::diffusion::DiffusionSystem::set_media`] can
    /// refill the matrix on the structure it was assembled with.
    #[default]
    PerTet,
    /// Bit-identical media share one id, numbered in the order of their first tet. A table
    /// as small as the material table it came from; the ids change with the values.
    Compact,
}

/// Per-tet material ids and the media they index: the two inputs of
/// [`crate::diffusion::assemble`] (ids through [`TetMesh::set_materials`]).
#[derive(Debug, Clone, PartialEq)]
pub struct MaterialTable {
    /// One id per tet, indexing `media`.
    pub ids: Vec<u32>,
    /// The media.
    pub media: Vec<Medium>,
}

/// Largest tet count whose ids fit in `u32`.
const MAX_TETS: usize = 1 << 32;

impl PerTetMedia {
    /// Per-tet coefficients with the object's η and g.
    ///
    /// # Errors
    /// [`VolumeError::InvalidObjectParameter`] for η outside [1, 4) or g outside (−1, 1);
    /// [`VolumeError::InvalidTetMedium`] naming the first tet with a non-finite or negative
    /// coefficient or σa + σ′s = 0 (and the coefficient and channel);
    /// [`VolumeError::LengthMismatch`] for more than 2³² tets (ids are `u32`).
    pub fn new(coefficients: Vec<Coefficients>, eta: f64, g: f64) -> Result<Self, VolumeError> {
        check_object(eta, g)?;
        if coefficients.len() > MAX_TETS {
            return Err(VolumeError::LengthMismatch {
                what: "per-tet media (material ids are u32)",
                expected: MAX_TETS,
                found: coefficients.len(),
            });
        }
        let first_invalid = coefficients
            .par_iter()
            .enumerate()
            .filter_map(|(tet, c)| c.validate().err().map(|source| (tet, source)))
            .find_first(|_| true);
        if let Some((tet, source)) = first_invalid {
            return Err(VolumeError::InvalidTetMedium { tet, source });
        }
        Ok(Self { coefficients, eta, g })
    }

    /// The homogeneous medium `medium` in every tet of `mesh`.
    ///
    /// # Errors
    /// [`VolumeError::InvalidMedium`] (`"material"`, index 0) if `medium` is invalid.
    pub fn uniform(mesh: &TetMesh, medium: &Medium) -> Result<Self, VolumeError> {
        medium.validate().map_err(|source| VolumeError::InvalidMedium { what: "material", index: 0, source })?;
        Ok(Self { coefficients: vec![Coefficients::from(medium); mesh.tet_count()], eta: medium.eta, g: medium.g })
    }

    /// From a material-id table: tet t gets `table[mesh.materials()[t]]`.
    ///
    /// η and g are those of the media on the surface (the materials of the tets that own a
    /// boundary face), which must agree on η, exactly as [`crate::diffusion::assemble`]
    /// requires; g is taken from the medium of the first boundary face. Interior materials
    /// may have any η and g: the diffusion equation does not use them.
    ///
    /// # Errors
    /// [`VolumeError::InvalidMedium`] naming the first invalid table entry;
    /// [`VolumeError::MaterialOutOfRange`] naming the first tet whose id has no entry;
    /// [`VolumeError::MixedObjectParameter`] naming two surface materials whose η differ.
    pub fn from_materials(mesh: &TetMesh, table: &[Medium]) -> Result<Self, VolumeError> {
        for (index, m) in table.iter().enumerate() {
            m.validate().map_err(|source| VolumeError::InvalidMedium { what: "material", index, source })?;
        }
        let ids = mesh.materials();
        if let Some(tet) = ids.par_iter().position_first(|&m| m as usize >= table.len()) {
            return Err(VolumeError::MaterialOutOfRange { tet, material: ids[tet], media: table.len() });
        }
        let surface = |f: &crate::mesh::BoundaryFace| ids[f.tet as usize] as usize;
        let first = mesh.boundary_faces().first().map_or(ids[0] as usize, surface);
        let (eta, g) = (table[first].eta, table[first].g);
        if let Some(other) = mesh.boundary_faces().iter().map(surface).find(|&m| table[m].eta != eta) {
            return Err(VolumeError::MixedObjectParameter {
                field: "eta",
                what: "material",
                first,
                first_value: eta,
                other,
                other_value: table[other].eta,
            });
        }
        let coefficients = ids.par_iter().map(|&m| Coefficients::from(&table[m as usize])).collect();
        Ok(Self { coefficients, eta, g })
    }

    /// Samples `field` in every tet of `mesh` with the rule `sampling` (positions in the
    /// mesh's scene units), with the object's η and g.
    ///
    /// # Errors
    /// Those of [`PerTetMedia::new`]: an invalid η or g, or a tet whose sampled coefficients
    /// are invalid (the field returned NaN, a negative value, or σa + σ′s = 0).
    pub fn from_field(
        mesh: &TetMesh,
        field: &(impl MediumField + ?Sized),
        eta: f64,
        g: f64,
        sampling: TetSampling,
    ) -> Result<Self, VolumeError> {
        check_object(eta, g)?;
        let coefficients =
            (0..mesh.tet_count()).into_par_iter().map(|t| sampling.average(field, mesh.tet_positions(t))).collect();
        Self::new(coefficients, eta, g)
    }

    /// Number of tets.
    #[must_use]
    pub fn len(&self) -> usize {
        self.coefficients.len()
    }

    /// Whether there are no tets.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.coefficients.is_empty()
    }

    /// The per-tet coefficients, in tet order.
    #[must_use]
    pub fn coefficients(&self) -> &[Coefficients] {
        &self.coefficients
    }

    /// The object's refractive index η.
    #[must_use]
    pub fn eta(&self) -> f64 {
        self.eta
    }

    /// The object's anisotropy g.
    #[must_use]
    pub fn g(&self) -> f64 {
        self.g
    }

    /// The medium of tet `tet` (its coefficients with the object's η and g).
    ///
    /// # Panics
    /// If `tet >= self.len()`.
    #[must_use]
    pub fn medium(&self, tet: usize) -> Medium {
        self.coefficients[tet].with_eta_g(self.eta, self.g)
    }

    /// Sets the coefficients of one tet (painting). On error nothing changes.
    ///
    /// # Errors
    /// [`VolumeError::LengthMismatch`] for a tet out of range; [`VolumeError::InvalidTetMedium`]
    /// for invalid coefficients.
    pub fn set(&mut self, tet: usize, coefficients: Coefficients) -> Result<(), VolumeError> {
        self.check(tet, coefficients)?;
        self.coefficients[tet] = coefficients;
        Ok(())
    }

    /// Whether [`PerTetMedia::set`] would accept `coefficients` for `tet`, without setting
    /// them (to check a batch of changes before applying any).
    ///
    /// # Errors
    /// Those of [`PerTetMedia::set`].
    pub fn check(&self, tet: usize, coefficients: Coefficients) -> Result<(), VolumeError> {
        if tet >= self.coefficients.len() {
            return Err(VolumeError::LengthMismatch { what: "tet index (tet count)", expected: self.len(), found: tet });
        }
        coefficients.validate().map_err(|source| VolumeError::InvalidTetMedium { tet, source })
    }

    /// Replaces the object's η and g. On error nothing changes.
    ///
    /// # Errors
    /// [`VolumeError::InvalidObjectParameter`] for η outside [1, 4) or g outside (−1, 1).
    pub fn set_eta_g(&mut self, eta: f64, g: f64) -> Result<(), VolumeError> {
        check_object(eta, g)?;
        self.eta = eta;
        self.g = g;
        Ok(())
    }

    /// The material ids and media table the diffusion assembly consumes (see [`TableLayout`]).
    #[must_use]
    pub fn material_table(&self, layout: TableLayout) -> MaterialTable {
        match layout {
            TableLayout::PerTet => MaterialTable {
                ids: (0..self.len()).map(|t| t as u32).collect(),
                media: (0..self.len()).map(|t| self.medium(t)).collect(),
            },
            TableLayout::Compact => {
                let mut index: HashMap<[u64; 6], u32> = HashMap::new();
                let mut media = Vec::new();
                let ids = self
                    .coefficients
                    .iter()
                    .map(|c| {
                        *index.entry(c.to_array().map(f64::to_bits)).or_insert_with(|| {
                            media.push(c.with_eta_g(self.eta, self.g));
                            (media.len() - 1) as u32
                        })
                    })
                    .collect();
                MaterialTable { ids, media }
            }
        }
    }

    /// Writes the material ids of `layout` into `mesh` and returns the media table, ready for
    /// [`crate::diffusion::assemble`]`(mesh, &table, mm_per_unit)`. On error the mesh is
    /// unchanged.
    ///
    /// # Errors
    /// [`VolumeError::LengthMismatch`] unless the mesh has one tet per entry.
    pub fn apply(&self, mesh: &mut TetMesh, layout: TableLayout) -> Result<Vec<Medium>, VolumeError> {
        self.check_mesh(mesh)?;
        let MaterialTable { ids, media } = self.material_table(layout);
        mesh.set_materials(ids).map_err(|_| VolumeError::LengthMismatch {
            what: "per-tet media (tets of the mesh)",
            expected: mesh.tet_count(),
            found: self.len(),
        })?;
        Ok(media)
    }

    /// The volume-weighted mean of the coefficients over `mesh`: Σ V_t c_t / Σ V_t, summed in
    /// tet order (deterministic).
    ///
    /// # Errors
    /// [`VolumeError::LengthMismatch`] unless the mesh has one tet per entry.
    pub fn volume_mean(&self, mesh: &TetMesh) -> Result<Coefficients, VolumeError> {
        self.check_mesh(mesh)?;
        let volumes: Vec<f64> = (0..mesh.tet_count()).into_par_iter().map(|t| mesh.tet_volume(t)).collect();
        let mut sum = [0.0; 6];
        let mut total = 0.0;
        for (c, v) in self.coefficients.iter().zip(&volumes) {
            for (s, x) in sum.iter_mut().zip(c.to_array()) {
                *s += v * x;
            }
            total += v;
        }
        Ok(Coefficients::from_array(sum.map(|s| s / total)))
    }

    fn check_mesh(&self, mesh: &TetMesh) -> Result<(), VolumeError> {
        if mesh.tet_count() == self.len() {
            Ok(())
        } else {
            Err(VolumeError::LengthMismatch {
                what: "per-tet media (tets of the mesh)",
                expected: mesh.tet_count(),
                found: self.len(),
            })
        }
    }
}

/// η in [1, 4) and g in (−1, 1), with the checks of [`Medium::validate`].
pub(crate) fn check_object(eta: f64, g: f64) -> Result<(), VolumeError> {
    Medium { sigma_a: [0.0; 3], sigma_s_prime: [1.0; 3], eta, g }
        .validate()
        .map_err(|source| VolumeError::InvalidObjectParameter { source })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::OpticsError;
    use glam::DVec3;

    /// The unit cube as 6 Kuhn tets; materials as given.
    pub(crate) fn cube(materials: Vec<u32>) -> TetMesh {
        let corners: Vec<DVec3> =
            (0..8).map(|d| DVec3::new((d & 1) as f64, ((d >> 1) & 1) as f64, ((d >> 2) & 1) as f64)).collect();
        let tets = vec![[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]];
        TetMesh::new(corners, tets, materials).unwrap()
    }

    fn marble() -> Medium {
        Medium::preset("marble").unwrap()
    }

    #[test]
    fn material_tables_round_trip_through_both_layouts() {
        let skin = Medium { eta: marble().eta, ..Medium::preset("skin1").unwrap() };
        let mesh = cube(vec![1, 0, 1, 1, 0, 1]);
        let media = PerTetMedia::from_materials(&mesh, &[marble(), skin]).unwrap();
        assert_eq!(media.medium(0), skin);
        assert_eq!(media.medium(1), marble());
        let compact = media.material_table(TableLayout::Compact);
        assert_eq!(compact.ids, vec![0, 1, 0, 0, 1, 0]);
        assert_eq!(compact.media, vec![skin, marble()]);
        let per_tet = media.material_table(TableLayout::PerTet);
        assert_eq!(per_tet.ids, (0..6).collect::<Vec<u32>>());
        assert_eq!(per_tet.media.len(), 6);
        assert_eq!(per_tet.media[4], marble());
    }

    #[test]
    fn surface_media_must_share_eta_and_interior_ones_need_not() {
        let a = marble();
        let b = Medium { eta: 1.3, ..a };
        let mesh = cube(vec![0, 0, 1, 0, 0, 0]); // every Kuhn tet touches the surface
        let e = PerTetMedia::from_materials(&mesh, &[a, b]).unwrap_err();
        assert!(matches!(e, VolumeError::MixedObjectParameter { field: "eta", first: 0, other: 1, .. }), "{e}");
        // An unused entry does not count.
        let mesh = cube(vec![0; 6]);
        let media = PerTetMedia::from_materials(&mesh, &[a, b]).unwrap();
        assert_eq!(media.eta(), a.eta);
    }

    #[test]
    fn invalid_inputs_are_named() {
        let mesh = cube(vec![0, 0, 0, 2, 0, 0]);
        assert!(matches!(
            PerTetMedia::from_materials(&mesh, &[marble(), marble()]),
            Err(VolumeError::MaterialOutOfRange { tet: 3, material: 2, media: 2 })
        ));
        let bad = Medium { sigma_s_prime: [1.0, f64::NAN, 1.0], ..marble() };
        assert!(matches!(
            PerTetMedia::from_materials(&mesh, &[marble(), bad]),
            Err(VolumeError::InvalidMedium { what: "material", index: 1, .. })
        ));
        let mut c = vec![Coefficients::from(marble()); 6];
        c[4].sigma_a[2] = -0.1;
        let e = PerTetMedia::new(c.clone(), 1.3, 0.0).unwrap_err();
        assert!(
            matches!(
                e,
                VolumeError::InvalidTetMedium {
                    tet: 4,
                    source: OpticsError::InvalidChannel { field: "sigma_a", channel: 2, .. }
                }
            ),
            "{e}"
        );
        assert!(e.to_string().starts_with("tet 4: sigma_a[2] (blue) = -0.1"), "{e}");
        c[4] = Coefficients::new([0.0; 3], [0.0, 1.0, 1.0]);
        let e = PerTetMedia::new(c, 1.3, 0.0).unwrap_err();
        assert!(matches!(e, VolumeError::InvalidTetMedium { tet: 4, .. }), "{e}");
        let ok = vec![Coefficients::from(marble()); 6];
        assert!(matches!(PerTetMedia::new(ok.clone(), 0.9, 0.0), Err(VolumeError::InvalidObjectParameter { .. })));
        assert!(matches!(PerTetMedia::new(ok, 1.3, 1.0), Err(VolumeError::InvalidObjectParameter { .. })));
    }

    #[test]
    fn set_apply_and_mean_check_their_inputs() {
        let mut mesh = cube(vec![]);
        let mut media = PerTetMedia::uniform(&mesh, &marble()).unwrap();
        let before = media.clone();
        assert!(media.set(6, Coefficients::from(marble())).is_err());
        assert!(media.set(0, Coefficients::new([f64::INFINITY; 3], [1.0; 3])).is_err());
        assert!(media.set_eta_g(5.0, 0.0).is_err());
        assert_eq!(media, before);
        media.set(0, Coefficients::new([1.0; 3], [1.0; 3])).unwrap();
        // Every Kuhn tet has volume 1/6: the mean is (1 + 5 σa)/6.
        let mean = media.volume_mean(&mesh).unwrap();
        assert!((mean.sigma_a[0] - (1.0 + 5.0 * marble().sigma_a[0]) / 6.0).abs() < 1e-15);
        let table = media.apply(&mut mesh, TableLayout::Compact).unwrap();
        assert_eq!(mesh.materials(), &[0, 1, 1, 1, 1, 1]);
        assert_eq!(table.len(), 2);
        let small = PerTetMedia::new(vec![Coefficients::from(marble()); 2], 1.3, 0.0).unwrap();
        assert!(matches!(small.apply(&mut mesh, TableLayout::PerTet), Err(VolumeError::LengthMismatch { .. })));
        assert!(matches!(small.volume_mean(&mesh), Err(VolumeError::LengthMismatch { .. })));
        assert_eq!(mesh.materials(), &[0, 1, 1, 1, 1, 1]);
    }

    #[test]
    fn sampling_a_field_is_deterministic_across_thread_counts() {
        let mesh = cube(vec![]);
        let field = |p: DVec3| Coefficients::new([(p.x * 7.0).sin().abs() + 0.01; 3], [1.0 + p.y; 3]);
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let a = one.install(|| PerTetMedia::from_field(&mesh, &field, 1.4, 0.0, TetSampling::FivePoint).unwrap());
        let four = rayon::ThreadPoolBuilder::new().num_threads(4).build().unwrap();
        let b = four.install(|| PerTetMedia::from_field(&mesh, &field, 1.4, 0.0, TetSampling::FivePoint).unwrap());
        assert_eq!(a, b);
        let nan = |_: DVec3| Coefficients::new([f64::NAN; 3], [1.0; 3]);
        assert!(matches!(
            PerTetMedia::from_field(&mesh, &nan, 1.4, 0.0, TetSampling::Centroid),
            Err(VolumeError::InvalidTetMedium { tet: 0, .. })
        ));
    }
}
