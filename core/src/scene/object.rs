//! An object of a scene: its shape (a surface to mesh, or a ready tet mesh), its placement and
//! its material ([`Material`]: a translucent medium — homogeneous, a material table, per-tet
//! values, a voxel grid or a procedural field — or an opaque diffuse surface).

use glam::{DMat4, DVec3};

use super::material::{Diffuse, Material};
use crate::mesh::{MeshError, TetMesh, TriMesh};
use crate::optics::{dipole, Medium};
use crate::volume::{check_object, Coefficients, Layers, PerTetMedia, TableLayout, TetSampling, Veins, VolumeError, VoxelGrid};

/// The geometry of an object, in object space (scene units).
#[derive(Debug, Clone)]
pub enum Shape {
    /// A closed (or nearly closed) surface; the bake tetrahedralizes it and returns radiance at
    /// its vertices, in the user's order.
    Surface(TriMesh),
    /// A ready tetrahedral mesh; the bake solves on it as given and returns radiance at every
    /// tet-mesh vertex (0 at interior vertices, which have no outgoing radiance).
    Tetrahedra(TetMesh),
}

impl Shape {
    /// Number of vertices the bake returns radiance for.
    #[must_use]
    pub fn output_vertex_count(&self) -> usize {
        match self {
            Self::Surface(mesh) => mesh.user_vertex_count(),
            Self::Tetrahedra(mesh) => mesh.vertex_count(),
        }
    }
}

/// The medium filling an object. Every heterogeneous source is reduced to one medium per tet
/// (TransCut assumes κ and μ piecewise constant per tet) on the mesh the bake solves on.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub enum MediumSource {
    /// One medium everywhere.
    Homogeneous(Medium),
    /// A table indexed by the material ids of a [`Shape::Tetrahedra`] mesh
    /// ([`TetMesh::materials`]); with a surface, every tet has id 0.
    Table(Vec<Medium>),
    /// One medium per tet of a [`Shape::Tetrahedra`] mesh, in tet order.
    PerTet(PerTetMedia),
    /// A voxel grid placed in object space (scene units), sampled at five points per tet
    /// ([`TetSampling::FivePoint`]), with the object's η and g.
    Voxels {
        /// The coefficients.
        grid: VoxelGrid,
        /// Refractive index of the object.
        eta: f64,
        /// Scattering anisotropy of the object.
        g: f64,
    },
    /// Media by depth below the (world-space) surface, depths in millimetres.
    Layers(Layers),
    /// Marble veins from seeded noise, evaluated in object space (they move with the object).
    Veins(Veins),
}

impl From<Medium> for MediumSource {
    fn from(medium: Medium) -> Self {
        Self::Homogeneous(medium)
    }
}

impl MediumSource {
    /// The object's refractive index and scattering anisotropy (η, g): the medium's, a voxel
    /// grid's or per-tet media's own, veins' base medium's, a table's or layers' first entry's
    /// (what a medium made homogeneous from new coefficients keeps); `None` for an empty table
    /// or no layers.
    #[must_use]
    pub fn eta_and_g(&self) -> Option<(f64, f64)> {
        match self {
            Self::Homogeneous(m) => Some((m.eta, m.g)),
            Self::Table(table) => table.first().map(|m| (m.eta, m.g)),
            Self::PerTet(media) => Some((media.eta(), media.g())),
            Self::Voxels { eta, g, .. } => Some((*eta, *g)),
            Self::Layers(layers) => layers.layers().first().map(|l| (l.medium.eta, l.medium.g)),
            Self::Veins(veins) => Some((veins.base().eta, veins.base().g)),
        }
    }

    /// The largest transport coefficient σtr (mm⁻¹) per channel anywhere in the source — every
    /// medium of a table, layer stack or vein pair, every per-tet value and voxel — so
    /// `1/σtr` is the shortest diffusion length the object's tets must resolve. Zero for an
    /// empty table or no layers.
    #[must_use]
    pub fn max_sigma_tr(&self) -> [f64; 3] {
        let of = |c: &Coefficients| std::array::from_fn(|k| dipole::sigma_tr(c.sigma_a[k], c.sigma_s_prime[k]));
        let max = |all: &mut dyn Iterator<Item = [f64; 3]>| {
            all.fold([0.0; 3], |m: [f64; 3], s| std::array::from_fn(|k| m[k].max(s[k])))
        };
        match self {
            Self::Homogeneous(m) => m.sigma_tr(),
            Self::Table(table) => max(&mut table.iter().map(Medium::sigma_tr)),
            Self::PerTet(media) => max(&mut media.coefficients().iter().map(of)),
            Self::Voxels { grid, .. } => {
                let [nx, ny, nz] = grid.dims();
                let voxels = (0..nz).flat_map(|z| (0..ny).flat_map(move |y| (0..nx).map(move |x| [x, y, z])));
                max(&mut voxels.filter_map(|v| grid.voxel(v)).map(|c| of(&c)))
            }
            Self::Layers(layers) => max(&mut layers.layers().iter().map(|l| l.medium.sigma_tr())),
            Self::Veins(veins) => max(&mut [veins.base(), veins.vein()].into_iter().map(Medium::sigma_tr)),
        }
    }

    /// Checks what can be checked without the tet mesh.
    ///
    /// # Errors
    /// A message naming the invalid medium, table entry or parameter.
    pub fn validate(&self, shape: &Shape) -> Result<(), String> {
        match self {
            Self::Homogeneous(m) => m.validate().map_err(|e| e.to_string()),
            Self::Table(table) => {
                if table.is_empty() {
                    return Err("the material table is empty".into());
                }
                for (i, m) in table.iter().enumerate() {
                    m.validate().map_err(|e| format!("material table entry {i}: {e}"))?;
                }
                if let Shape::Tetrahedra(mesh) = shape {
                    if let Some((t, &id)) = mesh.materials().iter().enumerate().find(|(_, &id)| id as usize >= table.len()) {
                        return Err(format!("tet {t} has material id {id} but the table has {} entries", table.len()));
                    }
                }
                Ok(())
            }
            Self::PerTet(media) => match shape {
                Shape::Tetrahedra(mesh) if mesh.tet_count() == media.len() => Ok(()),
                Shape::Tetrahedra(mesh) => {
                    Err(format!("per-tet media for {} tets but the tet mesh has {}", media.len(), mesh.tet_count()))
                }
                Shape::Surface(_) => Err("per-tet media need a ready tet mesh (the bake's tets are not known in advance); \
                                          use a voxel grid or a procedural field with a surface"
                    .into()),
            },
            Self::Voxels { eta, g, .. } => check_object(*eta, *g).map_err(|e| format!("voxel medium: {e}")),
            Self::Layers(_) | Self::Veins(_) => Ok(()),
        }
    }

    /// The medium table for the diffusion assembly on `mesh` (world space, the object's tets),
    /// writing the material ids it indexes into `mesh`. `to_object` maps world to object space.
    ///
    /// # Errors
    /// [`VolumeError`] from sampling a field or from a length mismatch.
    pub(crate) fn apply(&self, mesh: &mut TetMesh, to_object: &DMat4, mm_per_unit: f64) -> Result<Vec<Medium>, VolumeError> {
        let in_object_space = |mesh: &TetMesh| {
            let m = *to_object;
            mesh.clone().map_positions(move |p: DVec3| m.transform_point3(p)).map_err(|_| VolumeError::InvalidParameter {
                field: "transform determinant",
                value: m.determinant(),
                requirement: "the world-to-object map must keep every tet valid",
            })
        };
        let per_tet = match self {
            Self::Homogeneous(m) => {
                mesh.set_materials(vec![0; mesh.tet_count()]).expect("one id per tet");
                return Ok(vec![*m]);
            }
            Self::Table(table) => return Ok(table.clone()),
            Self::PerTet(media) => media.clone(),
            Self::Voxels { grid, eta, g } => grid.per_tet(&in_object_space(mesh)?, *eta, *g, TetSampling::FivePoint)?,
            Self::Layers(layers) => layers.per_tet(mesh, mm_per_unit, TetSampling::FivePoint)?,
            Self::Veins(veins) => veins.per_tet(&in_object_space(mesh)?, TetSampling::FivePoint)?,
        };
        per_tet.apply(mesh, TableLayout::PerTet)
    }
}

/// An object of the scene: a shape in object space, its placement and its material (a
/// translucent medium, or an opaque diffuse surface).
#[derive(Debug, Clone)]
pub struct Object {
    /// A name for messages and reports.
    pub name: String,
    /// The geometry, in object space, scene units.
    pub shape: Shape,
    /// Object → world transform (scene units).
    pub transform: DMat4,
    /// Millimetres per scene unit: the media are in mm⁻¹.
    pub mm_per_unit: f64,
    /// What the object is made of.
    pub material: Material,
}

impl Object {
    /// The smallest object a bake accepts: a bounding-box diagonal of 10⁻⁶ mm (a nanometre),
    /// in world space. Far below any diffusing medium, and far above where the assembled
    /// system's volumes and areas (size³, size²) would underflow f64.
    pub const MIN_SIZE_MM: f64 = 1e-6;
    /// The largest object a bake accepts: a bounding-box diagonal of 10⁹ mm (a thousand
    /// kilometres), for the same reason from above.
    pub const MAX_SIZE_MM: f64 = 1e9;

    /// Checks the object's size, the bounding-box diagonal of its `world` surface times
    /// `mm_per_unit`, against [`Self::MIN_SIZE_MM`] and [`Self::MAX_SIZE_MM`].
    ///
    /// # Errors
    /// A message giving the size and the bound it breaks.
    pub fn check_size(&self, world: &TriMesh) -> Result<(), String> {
        size_in_range(world.diagonal() * self.mm_per_unit)
    }

    /// A surface at the origin (identity transform) filled with one medium.
    #[must_use]
    pub fn new(name: impl Into<String>, mesh: TriMesh, medium: Medium, mm_per_unit: f64) -> Self {
        Self::with_shape(name, Shape::Surface(mesh), MediumSource::Homogeneous(medium), mm_per_unit)
    }

    /// A ready tet mesh at the origin (identity transform).
    #[must_use]
    pub fn from_tets(name: impl Into<String>, mesh: TetMesh, medium: MediumSource, mm_per_unit: f64) -> Self {
        Self::with_shape(name, Shape::Tetrahedra(mesh), medium, mm_per_unit)
    }

    /// Any shape and material (a [`MediumSource`], a [`Medium`] or a [`Diffuse`]), at the origin.
    #[must_use]
    pub fn with_shape(name: impl Into<String>, shape: Shape, material: impl Into<Material>, mm_per_unit: f64) -> Self {
        Self { name: name.into(), shape, transform: DMat4::IDENTITY, mm_per_unit, material: material.into() }
    }

    /// An opaque diffuse surface at the origin (identity transform); it may be open.
    #[must_use]
    pub fn diffuse(name: impl Into<String>, mesh: TriMesh, diffuse: Diffuse, mm_per_unit: f64) -> Self {
        Self::with_shape(name, Shape::Surface(mesh), diffuse, mm_per_unit)
    }

    /// The translucent medium, or `None` for an opaque surface.
    #[must_use]
    pub fn medium(&self) -> Option<&MediumSource> {
        self.material.medium()
    }

    /// Checks the scale, the transform and the medium (what can be checked without meshing).
    ///
    /// # Errors
    /// A message naming what is invalid.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.mm_per_unit.is_finite() && self.mm_per_unit > 0.0) {
            return Err(format!("mm_per_unit must be positive and finite, got {}", self.mm_per_unit));
        }
        if !self.transform.is_finite() || self.transform.determinant().abs() < 1e-300 {
            return Err("the transform is singular or not finite".into());
        }
        self.material.validate(&self.shape)
    }

    /// The surface in world space (the boundary of a tet mesh), for shadows and rendering. Its
    /// user vertices are the ones the bake returns radiance for ([`Shape::output_vertex_count`]).
    ///
    /// # Errors
    /// [`MeshError`] when a tet mesh's boundary has no triangle of non-zero area.
    pub fn world_surface(&self) -> Result<TriMesh, MeshError> {
        Ok(match &self.shape {
            Shape::Surface(mesh) => mesh.transformed(&self.transform),
            Shape::Tetrahedra(mesh) => boundary_surface(mesh)?.transformed(&self.transform),
        })
    }
}

/// Whether an object whose bounding-box diagonal is `size_mm` millimetres can be baked.
fn size_in_range(size_mm: f64) -> Result<(), String> {
    if !(size_mm >= Object::MIN_SIZE_MM) {
        return Err(format!(
            "the object is too small to bake: its bounding-box diagonal is {size_mm:e} mm, below the minimum of {:e} mm \
             (check mm_per_unit and the transform)",
            Object::MIN_SIZE_MM
        ));
    }
    if !(size_mm <= Object::MAX_SIZE_MM) {
        return Err(format!(
            "the object is too large to bake: its bounding-box diagonal is {size_mm:e} mm, above the maximum of {:e} mm \
             (check mm_per_unit and the transform)",
            Object::MAX_SIZE_MM
        ));
    }
    Ok(())
}

/// The boundary of a tet mesh as a triangle mesh whose user vertices are all tet-mesh vertices
/// (interior ones unreferenced), so per-vertex values index it directly.
fn boundary_surface(mesh: &TetMesh) -> Result<TriMesh, MeshError> {
    let positions: Vec<[f64; 3]> = mesh.positions().iter().map(|p| p.to_array()).collect();
    let indices: Vec<u32> = mesh.boundary_faces().iter().flat_map(|f| f.vertices).collect();
    TriMesh::from_triangles(&positions, &indices)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The largest σtr per channel over every medium a source holds, each channel on its own.
    #[test]
    fn max_sigma_tr_takes_each_channels_largest_over_the_source() {
        let marble = Medium::preset("marble").unwrap();
        // One η and g for both, as veins require.
        let skin = Medium { eta: marble.eta, g: marble.g, ..Medium::preset("skin1").unwrap() };
        let (s, m) = (skin.sigma_tr(), marble.sigma_tr());
        let max: [f64; 3] = std::array::from_fn(|c| s[c].max(m[c]));
        assert!(s[2] > m[2] && s[0] != m[0], "the two presets differ: {s:?} {m:?}");
        assert_eq!(MediumSource::Homogeneous(skin).max_sigma_tr(), s);
        assert_eq!(MediumSource::Table(vec![marble, skin]).max_sigma_tr(), max);
        assert_eq!(MediumSource::Table(vec![]).max_sigma_tr(), [0.0; 3]);
        let layers = Layers::new(&[(1.0, marble), (f64::INFINITY, skin)], 0.1).unwrap();
        assert_eq!(MediumSource::Layers(layers).max_sigma_tr(), max);
        let veins = Veins::new(marble, skin, 7, Default::default()).unwrap();
        assert_eq!(MediumSource::Veins(veins).max_sigma_tr(), max);
        let coefficients = |m: &Medium| Coefficients { sigma_a: m.sigma_a, sigma_s_prime: m.sigma_s_prime };
        let grid = VoxelGrid::from_fn([2, 1, 1], DVec3::ZERO, DVec3::ONE, |centre| {
            if centre.x < 1.0 {
                coefficients(&marble)
            } else {
                coefficients(&skin)
            }
        })
        .unwrap();
        let voxels = MediumSource::Voxels { grid, eta: 1.3, g: 0.0 }.max_sigma_tr();
        for c in 0..3 {
            assert!((voxels[c] - max[c]).abs() < 1e-5 * max[c], "channel {c}: {voxels:?} {max:?}");
            // f32 storage
        }
    }

    #[test]
    fn sizes_outside_the_bounds_are_refused_by_name() {
        assert_eq!(size_in_range(1e-6), Ok(()));
        assert_eq!(size_in_range(1e9), Ok(()));
        assert_eq!(size_in_range(60.0), Ok(()));
        let tiny = size_in_range(1.7e-30).unwrap_err();
        assert!(tiny.starts_with("the object is too small to bake: its bounding-box diagonal is 1.7e-30 mm"), "{tiny}");
        assert!(tiny.contains("minimum of 1e-6 mm"), "{tiny}");
        let huge = size_in_range(2e12).unwrap_err();
        assert!(huge.contains("too large") && huge.contains("2e12 mm") && huge.contains("1e9 mm"), "{huge}");
        assert!(size_in_range(f64::NAN).unwrap_err().contains("too small"));
    }
}
