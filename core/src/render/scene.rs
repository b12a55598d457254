//! What a render draws (objects, lights, ground plane) and how (options), with validation.

use crate::input::fmt_vec;
pub use crate::mesh::area_weighted_normals;
use std::borrow::Cow;

use glam::DVec3;
use rayon::prelude::*;

use super::{Camera, RenderError};
use crate::optics::{ETA_MAX, ETA_MIN};

/// One object to draw: a triangle mesh with baked per-vertex radiance.
///
/// `radiance[i]` is the value a bake returns for vertex i (ARCHITECTURE.md, "What a bake
/// returns"): the linear RGB radiance Lo(x, n) leaving the surface along its normal. The renderer
/// turns it into the radiance towards the eye by the Fresnel ratio Ft(η, ωo)/Ft(η, n) (see the
/// [module documentation](super)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderObject<'a> {
    /// Vertex positions in world space, scene units. Must be finite.
    pub positions: &'a [DVec3],
    /// Triangles as vertex indices, counter-clockwise seen from outside (the side the normals
    /// point to). Every index must be `< positions.len()`.
    pub triangles: &'a [[u32; 3]],
    /// Baked radiance along the normal, linear RGB, one per position. Must be finite (small
    /// negative values from a solver are accepted and clamp to black on display).
    pub radiance: &'a [[f64; 3]],
    /// Outward vertex normals, one per position (need not be unit length; must be finite). When
    /// `None`, area-weighted normals are computed: n_i ∝ Σ_{t ∋ i} (p1 − p0) × (p2 − p0), each
    /// triangle weighted by twice its area.
    pub normals: Option<&'a [DVec3]>,
    /// Refractive index of the medium relative to air, in [[`ETA_MIN`], [`ETA_MAX`]).
    pub eta: f64,
}

/// A parallel light that makes specular highlights and lights the ground plane.
///
/// Its strength is an irradiance, as for the core's
/// [`Light::Directional`](crate::light::Light::Directional): the power per unit area on a surface
/// facing the light (a delta light has no finite radiance).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpecularLight {
    /// Direction from the scene towards the light (need not be unit; must be finite, non-zero).
    pub direction_to_light: DVec3,
    /// Irradiance E normal to the light direction, linear RGB, each ≥ 0.
    pub irradiance: [f64; 3],
}

/// A large diffuse square below the objects, lit by the [`SpecularLight`]s and the constant
/// environment without shadows.
///
/// Its radiance is the Lambertian ρ/π · (Σ_l E_l (n·l)⁺ + π L_env), the same at every point, so it
/// reads as a flat grey floor that anchors the object in space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundPlane {
    /// The centre of the square, on the plane.
    pub point: DVec3,
    /// The plane's upward normal (need not be unit; finite, non-zero).
    pub normal: DVec3,
    /// Diffuse reflectance ρ per channel, in [0, 1].
    pub albedo: [f64; 3],
    /// Half the side of the square, > 0.
    pub half_extent: f64,
}

impl GroundPlane {
    /// Albedo of [`below`](Self::below)'s plane: a neutral mid grey.
    pub const DEFAULT_ALBEDO: [f64; 3] = [0.5; 3];

    /// How much larger than the objects' bounding-box diagonal the square is made by
    /// [`below`](Self::below).
    pub const EXTENT_PER_DIAGONAL: f64 = 50.0;

    /// A grey ground plane touching the bottom of the box `bounds_min..bounds_max` seen along
    /// `up`: through the box corner lowest along û, centred under the box, with half side
    /// [`EXTENT_PER_DIAGONAL`](Self::EXTENT_PER_DIAGONAL) × the box diagonal (at least 1 scene
    /// unit) and albedo [`DEFAULT_ALBEDO`](Self::DEFAULT_ALBEDO). A zero `up` is treated as +Y.
    #[must_use]
    pub fn below(bounds_min: DVec3, bounds_max: DVec3, up: DVec3) -> GroundPlane {
        let up = up.try_normalize().unwrap_or(DVec3::Y);
        let centre = 0.5 * (bounds_min + bounds_max);
        let half = 0.5 * (bounds_max - bounds_min);
        // Lowest corner along û: centre − Σ |half_k û_k|.
        let drop = (half * up).abs().element_sum();
        GroundPlane {
            point: centre - drop * up,
            normal: up,
            albedo: Self::DEFAULT_ALBEDO,
            half_extent: (Self::EXTENT_PER_DIAGONAL * 2.0 * half.length()).max(1.0),
        }
    }

    /// The plane's outgoing radiance ρ/π · (Σ_l E_l (n·l̂)⁺ + π L_env) under the given lights and
    /// constant environment (no shadows; lights below the plane contribute nothing).
    #[must_use]
    pub fn radiance(&self, lights: &[SpecularLight], environment: Option<[f64; 3]>) -> [f64; 3] {
        let n = self.normal.normalize_or_zero();
        let mut e = DVec3::from(environment.unwrap_or([0.0; 3])) * std::f64::consts::PI;
        for l in lights {
            let cos = n.dot(l.direction_to_light.normalize_or_zero()).max(0.0);
            e += DVec3::from(l.irradiance) * cos;
        }
        (DVec3::from(self.albedo) * e / std::f64::consts::PI).to_array()
    }

    /// The square as 4 corners, counter-clockwise seen from above (along −n).
    pub(crate) fn corners(&self) -> [DVec3; 4] {
        let n = self.normal.normalize();
        let t = n.any_orthonormal_vector();
        let b = n.cross(t);
        let (t, b) = (t * self.half_extent, b * self.half_extent);
        let c = self.point;
        // t × b = n, so (−t−b) → (t−b) → (t+b) → (−t+b) runs counter-clockwise about n.
        [c - t - b, c + t - b, c + t + b, c - t + b]
    }
}

/// Everything a render draws.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderScene<'a> {
    /// The camera; its width and height are the image size.
    pub camera: Camera,
    /// The objects, drawn with one z-buffer.
    pub objects: Vec<RenderObject<'a>>,
    /// Lights for the specular highlights (a GGX lobe weighted by the exact Fresnel reflectance)
    /// and for the ground plane. Empty: no highlights.
    pub lights: Vec<SpecularLight>,
    /// A constant environment radiance (linear RGB), reflected by the objects' surfaces with
    /// weight R(η, θo), and lighting the ground plane. `None`: no reflection.
    pub environment: Option<[f64; 3]>,
    /// An optional ground plane (see [`GroundPlane::below`]).
    pub ground: Option<GroundPlane>,
}

/// The supersampling pattern: where in each pixel the scene is sampled.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum SamplePattern {
    /// One sample at the pixel centre (no anti-aliasing).
    Centre,
    /// Four samples on a grid rotated by atan(½) ("RGSS"): offsets (⅜, ⅛), (⅞, ⅜), (⅛, ⅝),
    /// (⅝, ⅞). Every row and column of the pixel holds one sample, so near-horizontal and
    /// near-vertical edges get 4 coverage levels from 4 samples.
    RotatedGrid4,
    /// n × n stratified samples at ((i + ½)/n, (j + ½)/n), n in 1..=8.
    Grid(u32),
}

impl SamplePattern {
    /// Sample offsets inside the pixel, in [0, 1)², in a fixed order.
    #[must_use]
    pub fn offsets(self) -> Vec<[f64; 2]> {
        match self {
            SamplePattern::Centre => vec![[0.5, 0.5]],
            SamplePattern::RotatedGrid4 => {
                vec![[0.375, 0.125], [0.875, 0.375], [0.125, 0.625], [0.625, 0.875]]
            }
            SamplePattern::Grid(n) => {
                let step = 1.0 / f64::from(n);
                (0..n).flat_map(|j| (0..n).map(move |i| [(f64::from(i) + 0.5) * step, (f64::from(j) + 0.5) * step])).collect()
            }
        }
    }
}

/// The reconstruction filter that turns samples into pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Filter {
    /// The mean of the pixel's own samples (box of width 1 pixel).
    Box,
    /// The tent (triangle) filter of radius 1 pixel, w(dx, dy) = (1 − |dx|)⁺ (1 − |dy|)⁺ with
    /// (dx, dy) the sample's offset from the pixel centre in pixels, over the samples of the
    /// pixel and its 8 neighbours, normalised by the sum of the weights. Softer than the box,
    /// with less aliasing on edges.
    Tent,
}

/// How often surfaces are shaded within a pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum Shading {
    /// Multisampling: coverage and depth are resolved at every sample, but each triangle is
    /// shaded once per pixel, at the centroid of the samples it covers there (a point inside the
    /// triangle, since the triangle is convex), and that value is given to those samples. Edges
    /// and occlusion are anti-aliased exactly as with [`PerSample`](Self::PerSample); only
    /// shading that varies within a pixel (a highlight narrower than a pixel) is not. Several
    /// times faster.
    #[default]
    PerPixel,
    /// Full supersampling: every sample is shaded at its own position.
    PerSample,
}

/// What the alpha channel covers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum AlphaMode {
    /// Alpha is the coverage of the objects only; the ground plane and background are 0.
    #[default]
    Objects,
    /// Alpha is the coverage of the objects and the ground plane; only background is 0.
    ObjectsAndGround,
}

/// How to render.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderOptions {
    /// Exposure in stops: every linear value is multiplied by 2^`exposure_ev`. Finite.
    pub exposure_ev: f64,
    /// Background radiance (linear RGB), shown where nothing is drawn. Finite.
    pub background: [f64; 3],
    /// Supersampling pattern.
    pub samples: SamplePattern,
    /// Reconstruction filter.
    pub filter: Filter,
    /// Shading once per triangle per pixel, or at every sample.
    pub shading: Shading,
    /// Perceptual roughness r of the specular lobe, in [0.01, 1]; the GGX width is α = r².
    pub specular_roughness: f64,
    /// What the alpha channel covers.
    pub alpha: AlphaMode,
    /// Skip triangles that face away from the camera (faster, right for closed meshes). When
    /// `false` both sides are drawn; a back face is shaded as if seen from its front.
    pub cull_back_faces: bool,
}

impl Default for RenderOptions {
    /// Exposure 0 EV, black background, 3 × 3 samples, tent filter, shading per pixel,
    /// roughness 0.3, alpha of the objects only, both faces drawn.
    fn default() -> Self {
        Self {
            exposure_ev: 0.0,
            background: [0.0; 3],
            samples: SamplePattern::Grid(3),
            filter: Filter::Tent,
            shading: Shading::PerPixel,
            specular_roughness: 0.3,
            alpha: AlphaMode::Objects,
            cull_back_faces: false,
        }
    }
}

/// Largest n of [`SamplePattern::Grid`].
pub const MAX_GRID: u32 = 8;

/// Smallest accepted [`RenderOptions::specular_roughness`].
pub const MIN_ROUGHNESS: f64 = 0.01;

fn option_err(field: &'static str, value: impl std::fmt::Debug, requirement: &'static str) -> RenderError {
    RenderError::InvalidOption { field, value: format!("{value:?}"), requirement }
}

fn finite3(v: [f64; 3]) -> bool {
    v.iter().all(|c| c.is_finite())
}

fn non_negative3(v: [f64; 3]) -> bool {
    v.iter().all(|c| c.is_finite() && *c >= 0.0)
}

impl RenderOptions {
    /// Checks every option.
    ///
    /// # Errors
    /// [`RenderError::InvalidOption`] naming the option: a non-finite exposure or background, a
    /// grid size outside 1..=[`MAX_GRID`], a roughness outside [[`MIN_ROUGHNESS`], 1].
    pub fn validate(&self) -> Result<(), RenderError> {
        if !self.exposure_ev.is_finite() {
            return Err(option_err("exposure_ev", self.exposure_ev, "must be finite"));
        }
        if !finite3(self.background) {
            return Err(option_err("background", self.background, "must be finite"));
        }
        if let SamplePattern::Grid(n) = self.samples {
            if !(1..=MAX_GRID).contains(&n) {
                return Err(option_err("samples", self.samples, "Grid(n) needs n in 1..=8"));
            }
        }
        let r = self.specular_roughness;
        if !(r.is_finite() && (MIN_ROUGHNESS..=1.0).contains(&r)) {
            return Err(option_err("specular_roughness", r, "must be in [0.01, 1]"));
        }
        Ok(())
    }
}

impl RenderScene<'_> {
    /// Checks the camera, lights, environment, ground plane and every object.
    ///
    /// # Errors
    /// The first problem found, as the [`RenderError`] variant that names it.
    pub fn validate(&self) -> Result<(), RenderError> {
        self.camera.validate()?;
        self.validate_lighting()?;
        for (i, o) in self.objects.iter().enumerate() {
            o.validate(i)?;
        }
        Ok(())
    }

    pub(crate) fn validate_lighting(&self) -> Result<(), RenderError> {
        for (index, l) in self.lights.iter().enumerate() {
            let d = l.direction_to_light;
            if !d.is_finite() || d == DVec3::ZERO {
                return Err(RenderError::InvalidLight {
                    index,
                    field: "direction_to_light",
                    value: fmt_vec(&d.to_array()),
                    requirement: "must be finite and non-zero",
                });
            }
            if !non_negative3(l.irradiance) {
                return Err(RenderError::InvalidLight {
                    index,
                    field: "irradiance",
                    value: format!("{:?}", l.irradiance),
                    requirement: "every channel must be finite and >= 0",
                });
            }
        }
        if let Some(env) = self.environment {
            if !non_negative3(env) {
                return Err(option_err("environment", env, "every channel must be finite and >= 0"));
            }
        }
        if let Some(g) = &self.ground {
            if !g.point.is_finite() {
                return Err(option_err("ground.point", g.point, "must be finite"));
            }
            if !g.normal.is_finite() || g.normal == DVec3::ZERO {
                return Err(option_err("ground.normal", g.normal, "must be finite and non-zero"));
            }
            if !g.albedo.iter().all(|a| (0.0..=1.0).contains(a)) {
                return Err(option_err("ground.albedo", g.albedo, "every channel must be in [0, 1]"));
            }
            if !(g.half_extent.is_finite() && g.half_extent > 0.0) {
                return Err(option_err("ground.half_extent", g.half_extent, "must be finite and > 0"));
            }
        }
        Ok(())
    }
}

impl RenderObject<'_> {
    /// Checks the object; `object` is its index in the scene, used in the error.
    ///
    /// # Errors
    /// [`RenderError::InvalidEta`], [`RenderError::LengthMismatch`],
    /// [`RenderError::InvalidVertex`] (the first NaN or infinite position, radiance or normal),
    /// [`RenderError::IndexOutOfRange`] (the first triangle corner past the last vertex).
    pub fn validate(&self, object: usize) -> Result<(), RenderError> {
        let n = self.positions.len();
        if !(self.eta.is_finite() && (ETA_MIN..ETA_MAX).contains(&self.eta)) {
            return Err(RenderError::InvalidEta { object, value: self.eta, min: ETA_MIN, max: ETA_MAX });
        }
        if self.radiance.len() != n {
            return Err(RenderError::LengthMismatch { object, field: "radiance", expected: n, got: self.radiance.len() });
        }
        if let Some(normals) = self.normals {
            if normals.len() != n {
                return Err(RenderError::LengthMismatch { object, field: "normals", expected: n, got: normals.len() });
            }
        }
        let vertex_err = |field, index, value: String| RenderError::InvalidVertex {
            object,
            field,
            index,
            value,
            requirement: "must be finite",
        };
        if let Some(i) = self.positions.par_iter().position_first(|p| !p.is_finite()) {
            return Err(vertex_err("positions", i, format!("{}", self.positions[i])));
        }
        if let Some(i) = self.radiance.par_iter().position_first(|r| !finite3(*r)) {
            return Err(vertex_err("radiance", i, format!("{:?}", self.radiance[i])));
        }
        if let Some(normals) = self.normals {
            if let Some(i) = normals.par_iter().position_first(|v| !v.is_finite()) {
                return Err(vertex_err("normals", i, format!("{}", normals[i])));
            }
        }
        if let Some(t) = self.triangles.par_iter().position_first(|t| t.iter().any(|&v| v as usize >= n)) {
            let tri = self.triangles[t];
            let corner = (0..3).find(|&c| tri[c] as usize >= n).expect("some corner is out of range");
            return Err(RenderError::IndexOutOfRange { object, triangle: t, corner, index: tri[corner], vertex_count: n });
        }
        Ok(())
    }

    /// The object's normals: the given ones normalised, or area-weighted ones (see
    /// [`area_weighted_normals`]). Zero normals stay zero (shading then uses the face normal).
    pub(crate) fn shading_normals(&self) -> Cow<'_, [DVec3]> {
        match self.normals {
            Some(n) => Cow::Owned(n.par_iter().map(|v| v.normalize_or_zero()).collect()),
            None => Cow::Owned(area_weighted_normals(self.positions, self.triangles)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn area_weighted_normals_of_a_tetrahedron_corner() {
        // Three right-angled faces at the origin, outward normals −x, −y, −z, and the slanted face.
        let p = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
        let t = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let n = area_weighted_normals(&p, &t);
        let expect0 = -DVec3::ONE.normalize();
        assert!((n[0] - expect0).length() < 1e-15, "{}", n[0]);
        // Vertex 1 (x axis): faces −z (area ½), −y (area ½), slanted (area √3/2, normal (1,1,1)/√3).
        let s = DVec3::new(0.0, -1.0, -1.0) + DVec3::ONE;
        assert!((n[1] - s.normalize()).length() < 1e-15, "{}", n[1]);
        let lonely = area_weighted_normals(&[DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z], &[[0, 1, 2]]);
        assert_eq!(lonely[3], DVec3::ZERO);
        assert_eq!(lonely[0], DVec3::Z);
    }

    #[test]
    fn sample_patterns() {
        assert_eq!(SamplePattern::Centre.offsets(), vec![[0.5, 0.5]]);
        let g = SamplePattern::Grid(2).offsets();
        assert_eq!(g, vec![[0.25, 0.25], [0.75, 0.25], [0.25, 0.75], [0.75, 0.75]]);
        let r = SamplePattern::RotatedGrid4.offsets();
        // One sample per row and column quarter.
        let mut xs: Vec<f64> = r.iter().map(|o| o[0]).collect();
        xs.sort_by(f64::total_cmp);
        assert_eq!(xs, vec![0.125, 0.375, 0.625, 0.875]);
        assert_eq!(SamplePattern::Grid(8).offsets().len(), 64);
    }

    #[test]
    fn ground_below_a_box() {
        let g = GroundPlane::below(DVec3::new(-1.0, 2.0, 0.0), DVec3::new(1.0, 4.0, 1.0), DVec3::Y * 3.0);
        assert!((g.point - DVec3::new(0.0, 2.0, 0.5)).length() < 1e-15);
        assert_eq!(g.normal, DVec3::Y);
        let c = g.corners();
        // Counter-clockwise about the normal.
        assert!((c[1] - c[0]).cross(c[2] - c[0]).dot(g.normal) > 0.0);
        for p in c {
            assert!((p - g.point).dot(g.normal).abs() < 1e-12);
        }
        let lights = [
            SpecularLight { direction_to_light: DVec3::new(0.0, 2.0, 0.0), irradiance: [2.0; 3] },
            SpecularLight { direction_to_light: DVec3::NEG_Y, irradiance: [5.0; 3] },
        ];
        let l = g.radiance(&lights, Some([1.0, 0.0, 0.5]));
        let pi = std::f64::consts::PI;
        assert!((l[0] - 0.5 / pi * (2.0 + pi)).abs() < 1e-15);
        assert!((l[1] - 0.5 / pi * 2.0).abs() < 1e-15);
    }

    fn obj<'a>(p: &'a [DVec3], t: &'a [[u32; 3]], r: &'a [[f64; 3]]) -> RenderObject<'a> {
        RenderObject { positions: p, triangles: t, radiance: r, normals: None, eta: 1.3 }
    }

    #[test]
    fn object_validation_names_the_problem() {
        let p = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let r = [[1.0; 3]; 3];
        assert!(obj(&p, &[[0, 1, 2]], &r).validate(0).is_ok());
        let e = obj(&p, &[[0, 1, 2], [0, 3, 1]], &r).validate(4).unwrap_err();
        assert!(
            matches!(e, RenderError::IndexOutOfRange { object: 4, triangle: 1, corner: 1, index: 3, vertex_count: 3 }),
            "{e}"
        );
        let nan = [[1.0; 3], [1.0, f64::NAN, 1.0], [1.0; 3]];
        let e = obj(&p, &[[0, 1, 2]], &nan).validate(0).unwrap_err();
        assert!(e.to_string().contains("radiance[1]"), "{e}");
        let e = obj(&p, &[[0, 1, 2]], &r[..2]).validate(0).unwrap_err();
        assert!(matches!(e, RenderError::LengthMismatch { field: "radiance", expected: 3, got: 2, .. }), "{e}");
        let e = RenderObject { eta: 0.5, ..obj(&p, &[], &r) }.validate(2).unwrap_err();
        assert!(matches!(e, RenderError::InvalidEta { object: 2, .. }), "{e}");
        let bad_p = [DVec3::ZERO, DVec3::new(0.0, f64::INFINITY, 0.0), DVec3::Y];
        let e = obj(&bad_p, &[], &r).validate(0).unwrap_err();
        assert!(e.to_string().contains("positions[1]"), "{e}");
        let normals = [DVec3::Z; 2];
        let e = RenderObject { normals: Some(&normals), ..obj(&p, &[], &r) }.validate(0).unwrap_err();
        assert!(matches!(e, RenderError::LengthMismatch { field: "normals", .. }), "{e}");
    }

    #[test]
    fn option_validation_names_the_problem() {
        assert!(RenderOptions::default().validate().is_ok());
        let e = RenderOptions { exposure_ev: f64::NAN, ..Default::default() }.validate().unwrap_err();
        assert!(e.to_string().contains("exposure_ev"), "{e}");
        let e = RenderOptions { samples: SamplePattern::Grid(0), ..Default::default() }.validate().unwrap_err();
        assert!(e.to_string().contains("samples"), "{e}");
        let e = RenderOptions { specular_roughness: 0.0, ..Default::default() }.validate().unwrap_err();
        assert!(e.to_string().contains("specular_roughness"), "{e}");
        let e = RenderOptions { background: [0.0, f64::NAN, 0.0], ..Default::default() }.validate().unwrap_err();
        assert!(e.to_string().contains("background"), "{e}");
    }
}
