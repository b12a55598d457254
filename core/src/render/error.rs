//! Errors of the renderer.

use crate::input::{fmt_num, fmt_vec};

use std::path::PathBuf;

use glam::DVec3;

/// What is wrong with a render's inputs, or why an image could not be written.
///
/// Every variant names what is at fault: the camera field, the object's index in
/// [`RenderScene::objects`](super::RenderScene::objects) and the vertex or triangle, the light's
/// index, or the option.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RenderError {
    /// The image is empty or larger than the rasteriser supports.
    #[error("image size {width}×{height}: width and height must both be in 1..={max}")]
    InvalidSize {
        /// Width asked for, in pixels.
        width: u32,
        /// Height asked for, in pixels.
        height: u32,
        /// Largest supported width or height ([`MAX_DIMENSION`](super::MAX_DIMENSION)).
        max: u32,
    },
    /// A camera field is out of range, NaN or infinite, or the fields contradict each other.
    #[error("camera {field} = {value}: {requirement}")]
    InvalidCamera {
        /// The field at fault, e.g. `"vertical_fov_deg"`.
        field: &'static str,
        /// The value given, formatted.
        value: String,
        /// What the value must satisfy.
        requirement: &'static str,
    },
    /// The bounds given to [`Camera::frame`](super::Camera::frame) enclose nothing.
    #[error("bounds {min_g} .. {max_g}: {requirement}", min_g = fmt_vec(&.min.to_array()), max_g = fmt_vec(&.max.to_array()))]
    InvalidBounds {
        /// Lower corner given.
        min: DVec3,
        /// Upper corner given.
        max: DVec3,
        /// What the bounds must satisfy.
        requirement: &'static str,
    },
    /// A per-vertex value of an object is NaN, infinite or otherwise unusable.
    #[error("object {object}: {field}[{index}] = {value}: {requirement}")]
    InvalidVertex {
        /// Index of the object in the scene.
        object: usize,
        /// `"positions"`, `"radiance"` or `"normals"`.
        field: &'static str,
        /// Index of the vertex.
        index: usize,
        /// The value given, formatted.
        value: String,
        /// What the value must satisfy.
        requirement: &'static str,
    },
    /// A per-vertex array of an object does not have one entry per position.
    #[error("object {object}: {field} has {got} entries but the object has {expected} vertices")]
    LengthMismatch {
        /// Index of the object in the scene.
        object: usize,
        /// `"radiance"` or `"normals"`.
        field: &'static str,
        /// Number of positions.
        expected: usize,
        /// Number of entries given.
        got: usize,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error(
        "object {object}: triangle {triangle} corner {corner} is vertex index {index}, \
         out of range for {vertex_count} vertices"
    )]
    IndexOutOfRange {
        /// Index of the object in the scene.
        object: usize,
        /// Index of the triangle.
        triangle: usize,
        /// Corner of the triangle, 0..3.
        corner: usize,
        /// The vertex index given.
        index: u32,
        /// Number of vertices of the object.
        vertex_count: usize,
    },
    /// The refractive index of an object is unusable.
    #[error("object {object}: eta = {value_g}: the refractive index must be finite and in [{min_g}, {max_g})", value_g = fmt_num(*.value), min_g = fmt_num(*.min), max_g = fmt_num(*.max))]
    InvalidEta {
        /// Index of the object in the scene.
        object: usize,
        /// The value given.
        value: f64,
        /// Smallest accepted index.
        min: f64,
        /// Accepted indices are strictly below this.
        max: f64,
    },
    /// A field of a specular light is unusable.
    #[error("light {index}: {field} = {value}: {requirement}")]
    InvalidLight {
        /// Index of the light in [`RenderScene::lights`](super::RenderScene::lights).
        index: usize,
        /// `"direction_to_light"` or `"irradiance"`.
        field: &'static str,
        /// The value given, formatted.
        value: String,
        /// What the value must satisfy.
        requirement: &'static str,
    },
    /// A render option, the environment colour or a ground plane field is out of range.
    #[error("{field} = {value}: {requirement}")]
    InvalidOption {
        /// The option, e.g. `"exposure_ev"` or `"ground.albedo"`.
        field: &'static str,
        /// The value given, formatted.
        value: String,
        /// What the value must satisfy.
        requirement: &'static str,
    },
    /// The scene has more triangles than the rasteriser can index.
    #[error("the scene has {count} triangles to rasterise (after near-plane clipping); at most {max} are supported")]
    TooManyTriangles {
        /// Number of triangles after clipping.
        count: usize,
        /// The limit.
        max: usize,
    },
    /// An image file could not be encoded or written.
    #[error("writing {}: {source}", path.display())]
    Write {
        /// The file asked for.
        path: PathBuf,
        /// What the `image` crate reported.
        #[source]
        source: image::ImageError,
    },
}
