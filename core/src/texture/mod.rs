//! Texture bakes: baked radiance into an image through the surface's UV map.
//!
//! A bake returns Lo(x, n) per vertex; game and film pipelines want images. A texture bake
//! finds, for every texel, the surface point it maps to through the UV map
//! ([`raster::rasterize`]: the triangle whose UV image holds the texel's centre, and the
//! barycentric weights there), asks the method for its radiance at those points (the session's
//! [`crate::session::Session::radiance_on_surface`]: TransCut samples its tet mesh's boundary
//! solution there, not a blur of the vertex colours), and pads every UV island by a margin of
//! texels ([`dilate::dilate`]) so that filtering and mip-mapping never pull in the background
//! at a seam, as bakers do.
//!
//! Conventions: UV (0, 0) is the image's bottom-left corner and (1, 1) its top-right (Blender
//! and OpenGL); [`Image::rgba`] rows go from the top, so texel (x, y) holds the point at
//! u = (x + ½)/width, v = 1 − (y + ½)/height. Texels of the surface have alpha 1, padded texels
//! alpha 1 too (they hold the nearest island's colour), the rest RGBA 0.

pub mod dilate;
pub mod raster;

use crate::render::Image;

pub use raster::{rasterize, TexelSample};

/// Largest width or height of a texture bake (16384, as the largest textures GPUs sample).
pub const MAX_TEXTURE_SIZE: u32 = 16_384;

/// What a texture bake is asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TextureOptions {
    /// Image width in texels, 1..=[`MAX_TEXTURE_SIZE`].
    pub width: u32,
    /// Image height in texels, 1..=[`MAX_TEXTURE_SIZE`].
    pub height: u32,
    /// Texels of padding around each UV island ([`dilate::dilate`]); 0 for none.
    pub margin: u32,
}

impl TextureOptions {
    /// A square texture of `size` texels with a margin of `size / 64` texels (16 at 1024), as
    /// Blender's baker defaults to.
    #[must_use]
    pub fn square(size: u32) -> TextureOptions {
        TextureOptions { width: size, height: size, margin: (size / 64).max(1) }
    }
}

/// Why a texture bake was refused.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum TextureError {
    /// The image size is 0 or above [`MAX_TEXTURE_SIZE`].
    #[error("texture size {width}×{height}: width and height must both be in 1..={MAX_TEXTURE_SIZE}")]
    InvalidSize {
        /// Width asked for.
        width: u32,
        /// Height asked for.
        height: u32,
    },
    /// The UV list does not give 3 corners per triangle.
    #[error("{uvs} UV corners for {triangles} triangles: one UV per triangle corner (3 per triangle) is needed")]
    UvCount {
        /// Triangles given.
        triangles: usize,
        /// UV corners given.
        uvs: usize,
    },
    /// A UV coordinate is NaN or infinite.
    #[error("UV of triangle {triangle} corner {corner} is not finite ({u}, {v})")]
    NonFiniteUv {
        /// Triangle index.
        triangle: usize,
        /// Corner 0..3.
        corner: usize,
        /// The u coordinate.
        u: f64,
        /// The v coordinate.
        v: f64,
    },
    /// A triangle names a vertex the object does not have.
    #[error("triangle {triangle} names vertex {vertex}, but the object has {count} vertices")]
    VertexOutOfRange {
        /// Triangle index.
        triangle: usize,
        /// The vertex named.
        vertex: u32,
        /// The object's vertex count.
        count: usize,
    },
}

/// Checks the size, the UV count and values, and the vertex indices against `vertex_count`.
///
/// # Errors
/// The [`TextureError`] naming the first problem.
pub fn check(
    triangles: &[[u32; 3]],
    uvs: &[[f64; 2]],
    vertex_count: usize,
    options: &TextureOptions,
) -> Result<(), TextureError> {
    let TextureOptions { width, height, .. } = *options;
    if !(1..=MAX_TEXTURE_SIZE).contains(&width) || !(1..=MAX_TEXTURE_SIZE).contains(&height) {
        return Err(TextureError::InvalidSize { width, height });
    }
    if uvs.len() != 3 * triangles.len() {
        return Err(TextureError::UvCount { triangles: triangles.len(), uvs: uvs.len() });
    }
    if let Some(i) = uvs.iter().position(|uv| !uv.iter().all(|x| x.is_finite())) {
        return Err(TextureError::NonFiniteUv { triangle: i / 3, corner: i % 3, u: uvs[i][0], v: uvs[i][1] });
    }
    for (t, tri) in triangles.iter().enumerate() {
        if let Some(&v) = tri.iter().find(|&&v| v as usize >= vertex_count) {
            return Err(TextureError::VertexOutOfRange { triangle: t, vertex: v, count: vertex_count });
        }
    }
    Ok(())
}

/// The texture of a surface whose radiance `sample` gives at [`TexelSample`]s (called once,
/// with every covered texel's sample, in texel order, returning one value per sample): the
/// covered texels take their radiance (clamped at 0, as a bake's), then every island is padded
/// by `options.margin` texels. Inputs are assumed [`check`]ed.
///
/// # Errors
/// The error `sample` returns.
pub fn bake_image<E>(
    triangles: &[[u32; 3]],
    uvs: &[[f64; 2]],
    options: &TextureOptions,
    sample: impl FnOnce(&[TexelSample]) -> Result<Vec<[f64; 3]>, E>,
) -> Result<Image, E> {
    let TextureOptions { width, height, margin } = *options;
    let texels = rasterize(triangles, uvs, width, height);
    let radiance = sample(&texels)?;
    assert_eq!(radiance.len(), texels.len(), "bake_image: one radiance per texel sample");
    let mut rgba = vec![[0.0_f32; 4]; width as usize * height as usize];
    for (t, l) in texels.iter().zip(&radiance) {
        rgba[t.texel] = [l[0].max(0.0) as f32, l[1].max(0.0) as f32, l[2].max(0.0) as f32, 1.0];
    }
    dilate::dilate(&mut rgba, width as usize, height as usize, margin as usize);
    Ok(Image { width, height, rgba })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit square as two triangles filling the whole UV square.
    fn square() -> (Vec<[u32; 3]>, Vec<[f64; 2]>) {
        (vec![[0, 1, 2], [0, 2, 3]], vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    }

    #[test]
    fn a_linear_field_over_a_full_square_is_reproduced_at_every_texel() {
        // Vertex values linear in (u, v): the texel holds the value at its centre exactly.
        let (tris, uvs) = square();
        let corner = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let f = |p: [f64; 2]| [p[0], p[1], 0.25 + p[0] - 0.5 * p[1]];
        let values: Vec<[f64; 3]> = corner.iter().map(|&c| f(c)).collect();
        let image = bake_image(&tris, &uvs, &TextureOptions { width: 8, height: 4, margin: 2 }, |texels| {
            Ok::<_, ()>(
                texels
                    .iter()
                    .map(|t| std::array::from_fn(|c| (0..3).map(|k| t.bary[k] * values[t.vertices[k] as usize][c]).sum()))
                    .collect(),
            )
        })
        .unwrap();
        for y in 0..4 {
            for x in 0..8 {
                let (u, v) = ((f64::from(x) + 0.5) / 8.0, 1.0 - (f64::from(y) + 0.5) / 4.0);
                let p = image.pixel(x, y).unwrap();
                let expect = f([u, v]);
                for c in 0..3 {
                    assert!((f64::from(p[c]) - expect[c].max(0.0)).abs() < 1e-6, "({x}, {y}) {c}: {p:?} vs {expect:?}");
                }
                assert_eq!(p[3], 1.0);
            }
        }
    }

    #[test]
    fn bad_input_is_named() {
        let (tris, uvs) = square();
        let ok = TextureOptions::square(16);
        assert_eq!(check(&tris, &uvs, 4, &ok), Ok(()));
        assert!(matches!(check(&tris, &uvs, 4, &TextureOptions { width: 0, ..ok }), Err(TextureError::InvalidSize { .. })));
        assert!(matches!(
            check(&tris, &uvs, 4, &TextureOptions { height: MAX_TEXTURE_SIZE + 1, ..ok }),
            Err(TextureError::InvalidSize { .. })
        ));
        assert_eq!(check(&tris, &uvs[..5], 4, &ok), Err(TextureError::UvCount { triangles: 2, uvs: 5 }));
        let mut nan = uvs.clone();
        nan[4][1] = f64::NAN;
        assert!(matches!(check(&tris, &nan, 4, &ok), Err(TextureError::NonFiniteUv { triangle: 1, corner: 1, .. })));
        assert_eq!(check(&tris, &uvs, 3, &ok), Err(TextureError::VertexOutOfRange { triangle: 1, vertex: 3, count: 3 }));
        assert_eq!(TextureOptions::square(1024).margin, 16);
    }
}
