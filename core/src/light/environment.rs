//! Distant lighting from all directions: a constant sky or an equirectangular radiance image.
//!
//! # Equirectangular convention (+z up, Blender's)
//!
//! A direction ω = (sin θ cos φ, sin θ sin φ, cos θ), with θ ∈ [0, π] the polar angle from +z
//! (the zenith) and φ = atan2(y, x) the azimuth, maps to image coordinates
//!
//! u = (π − φ) / 2π ∈ [0, 1) (column, left to right), v = θ / π ∈ [0, 1] (row, top to bottom).
//!
//! So the top row is the zenith, the bottom row the nadir, the image centre (u = ½) looks along
//! +x, the left and right edges along −x, and u = ¼ looks along +y. This is the convention of
//! Blender's Environment Texture node (equirectangular projection) with rows stored top first, as
//! `.hdr` and `.exr` files store them; a caller holding Blender pixel data (bottom row first)
//! flips the rows before building a map.
//!
//! Radiance is piecewise constant over texels (nearest-texel lookup): the sampling density, the
//! SH9 projection and the lookup then describe exactly the same function.

use std::f64::consts::PI;
use std::path::Path;
use std::sync::{Arc, OnceLock};

use glam::DVec3;
use rayon::prelude::*;

use super::error::LightError;
use super::sh::{sh_azimuth_factors, sh_index, sh_polar_factors, AzimuthFactors, PolarFactors, MAX_ORDER};
use crate::input::{quote, BoundedFile, Limits};

/// The largest environment map file [`EquirectMap::load`] reads, in bytes (1 GiB).
pub const MAX_ENVIRONMENT_FILE_BYTES: u64 = 1 << 30;

/// Why a file whose first bytes are `head` is not an environment map.
fn not_an_image(head: &[u8]) -> String {
    let start = String::from_utf8_lossy(&head[..head.len().min(16)]).into_owned();
    format!("not a Radiance HDR or OpenEXR file: it starts with {}", quote(&start))
}

/// The first bytes of an OpenEXR file.
const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// The image format a file's first bytes announce: `#?` (`#?RADIANCE`, `#?RGBE`) for Radiance
/// HDR, the OpenEXR magic number for EXR; `None` for anything else.
fn image_format(head: &[u8]) -> Option<image::ImageFormat> {
    if head.starts_with(b"#?") {
        Some(image::ImageFormat::Hdr)
    } else if head.starts_with(&EXR_MAGIC) {
        Some(image::ImageFormat::OpenExr)
    } else {
        None
    }
}

/// Rec. 709 / sRGB luminance weights for linear RGB.
pub const LUMINANCE: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// Luminance Y = 0.2126 R + 0.7152 G + 0.0722 B of linear Rec. 709 RGB.
#[must_use]
pub fn luminance(rgb: [f64; 3]) -> f64 {
    LUMINANCE[0] * rgb[0] + LUMINANCE[1] * rgb[1] + LUMINANCE[2] * rgb[2]
}

/// Light arriving from infinitely far away in every direction.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Environment {
    /// The same radiance (linear RGB) from every direction.
    Constant([f64; 3]),
    /// Radiance from an equirectangular image.
    Equirect(EquirectMap),
}

/// The image coordinates (u, v) ∈ [0, 1)×[0, 1] of the unit direction `d` (module docs:
/// u = (π − atan2(y, x)) / 2π, v = acos(z) / π).
#[must_use]
pub fn direction_to_equirect(d: DVec3) -> (f64, f64) {
    let phi = d.y.atan2(d.x);
    let mut u = (PI - phi) / (2.0 * PI);
    if u >= 1.0 {
        u -= 1.0;
    }
    (u.max(0.0), d.z.clamp(-1.0, 1.0).acos() / PI)
}

/// The unit direction at image coordinates (u, v): φ = π − 2πu, θ = πv (inverse of
/// [`direction_to_equirect`]).
#[must_use]
pub fn equirect_to_direction(u: f64, v: f64) -> DVec3 {
    let phi = PI - 2.0 * PI * u;
    let theta = PI * v;
    DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
}

/// An equirectangular radiance image (linear RGB, `f32` texels, rows top first; convention in
/// the module docs) with an intensity multiplier, its SH9 projection and an importance-sampling
/// distribution.
///
/// Importance sampling ([`EquirectMap::sample`]): texel (x, y) is chosen with probability
/// Y_xy ΔΩ_y / W, W = Σ Y ΔΩ, Y the texel's luminance ([`luminance`]) and
/// ΔΩ_y = (2π/width)(cos θ_y − cos θ_{y+1}) its exact solid angle (a row from the marginal CDF,
/// then a column from the row's conditional CDF), then a direction uniform in solid angle inside
/// the texel (φ uniform, cos θ uniform). The density is pdf(ω) = Y(ω)/W: proportional to
/// luminance per unit solid angle, i.e. to luminance × sin θ in (θ, φ), with no singularity at
/// the poles.
///
/// The image and what is derived from it are immutable once built (constructors check every
/// texel) and shared: cloning a map is cheap, and so is changing its multiplier.
#[derive(Clone)]
pub struct EquirectMap {
    data: Arc<MapData>,
    intensity: f64,
}

impl std::fmt::Debug for EquirectMap {
    /// Size, multiplier and SH9 projection; not the texels.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EquirectMap")
            .field("width", &self.data.width)
            .field("height", &self.data.height)
            .field("intensity", &self.intensity)
            .field("sh9", &self.sh9())
            .finish_non_exhaustive()
    }
}

impl PartialEq for EquirectMap {
    fn eq(&self, other: &Self) -> bool {
        self.intensity == other.intensity && (Arc::ptr_eq(&self.data, &other.data) || self.data == other.data)
    }
}

/// The texels and the data derived from them (independent of the multiplier).
#[derive(PartialEq)]
struct MapData {
    width: usize,
    height: usize,
    texels: Vec<[f32; 3]>,
    /// SH9 projection of the texels (per channel).
    sh9: [[f64; 9]; 3],
    /// `None` when every texel is black.
    sampler: Option<MapSampler>,
    /// The projection to order [`MAX_ORDER`], made on first use ([`EquirectMap::sh`]).
    sh: ShCache,
}

/// A projection made on first use; a function of the texels, so never part of a comparison.
#[derive(Default)]
struct ShCache(OnceLock<Vec<[f64; 3]>>);

impl PartialEq for ShCache {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// The CDFs of the importance sampling described on [`EquirectMap`].
#[derive(PartialEq)]
struct MapSampler {
    /// Marginal CDF over rows, `height + 1` entries from 0 to 1.
    rows: Vec<f64>,
    /// Conditional CDF over columns of each row, `width + 1` entries per row (all zero for a
    /// black row, which the marginal never picks).
    cols: Vec<f64>,
    /// W = Σ Y ΔΩ over all texels (without the intensity multiplier).
    total: f64,
}

/// A direction drawn from an environment map and its density.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnvSample {
    /// Unit direction towards the sky.
    pub direction: DVec3,
    /// Density per unit solid angle.
    pub pdf: f64,
}

impl EquirectMap {
    /// Builds a map from interleaved linear RGB floats (`3 · width · height` of them, rows top
    /// first), as an application or the C ABI holds them.
    ///
    /// # Errors
    /// [`LightError::ImageSize`] for a zero side, [`LightError::ImageBufferLength`] when the
    /// buffer is not exactly `3 · width · height` long, [`LightError::ImageTexel`] for a NaN,
    /// infinite or negative texel, [`LightError::ImageIntensity`] for a bad multiplier.
    pub fn from_rgb(width: usize, height: usize, rgb: &[f32], intensity: f64) -> Result<Self, LightError> {
        check_size(width, height)?;
        let expected = width.checked_mul(height).and_then(|n| n.checked_mul(3)).unwrap_or(usize::MAX);
        if rgb.len() != expected {
            return Err(LightError::ImageBufferLength { width, height, expected, actual: rgb.len() });
        }
        let texels = rgb.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        Self::from_texels(width, height, texels, intensity)
    }

    /// Builds a map by evaluating `radiance(direction)` at every texel centre: handy for
    /// analytic skies and tests.
    ///
    /// # Errors
    /// As [`EquirectMap::from_rgb`].
    pub fn from_fn(
        width: usize,
        height: usize,
        intensity: f64,
        radiance: impl Fn(DVec3) -> [f64; 3],
    ) -> Result<Self, LightError> {
        check_size(width, height)?;
        let mut texels = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                let d = equirect_to_direction((x as f64 + 0.5) / width as f64, (y as f64 + 0.5) / height as f64);
                texels.push(radiance(d).map(|c| c as f32));
            }
        }
        Self::from_texels(width, height, texels, intensity)
    }

    /// Loads a Radiance `.hdr` or OpenEXR file (the format from its magic number) as linear
    /// RGB; an alpha channel is dropped.
    ///
    /// The file is read through [`crate::input`]: only a regular file of at most
    /// [`MAX_ENVIRONMENT_FILE_BYTES`], and its magic number is checked before the rest is read.
    /// Negative values, which some EXR tools write as filter ringing, are clamped to 0;
    /// NaN or infinite texels are an error.
    ///
    /// # Errors
    /// [`LightError::ImageLoad`] when the file is refused, cannot be read or decoded,
    /// [`LightError::ImageTexel`] for a non-finite texel, [`LightError::ImageIntensity`].
    pub fn load(path: impl AsRef<Path>, intensity: f64) -> Result<Self, LightError> {
        let path = path.as_ref();
        let name = path.display().to_string();
        let load_err = |reason: String| LightError::ImageLoad { path: name.clone(), reason };
        let limits = Limits { max_bytes: MAX_ENVIRONMENT_FILE_BYTES, max_line: None };
        let mut file = BoundedFile::open(path, limits).map_err(|e| load_err(e.to_string()))?;
        let (head, _) = file.head().map_err(|e| load_err(e.to_string()))?;
        let format = image_format(head).ok_or_else(|| load_err(not_an_image(head)))?;
        let bytes = file.read_all().map_err(|e| load_err(e.to_string()))?;
        Self::decode(&bytes, format, intensity).map_err(|e| match e {
            LightError::ImageLoad { reason, .. } => load_err(reason),
            other => other,
        })
    }

    /// Decodes a Radiance `.hdr` or OpenEXR file held in memory, as [`EquirectMap::load`] does
    /// (the format from the magic number).
    ///
    /// # Errors
    /// As [`EquirectMap::load`]; [`LightError::ImageLoad`] names the source `(memory)`.
    pub fn from_file_bytes(bytes: &[u8], intensity: f64) -> Result<Self, LightError> {
        let load_err = |reason: String| LightError::ImageLoad { path: "(memory)".into(), reason };
        let head = &bytes[..bytes.len().min(crate::input::HEAD_BYTES)];
        let format = image_format(head).ok_or_else(|| load_err(not_an_image(head)))?;
        Self::decode(bytes, format, intensity)
    }

    /// Decodes `bytes` of the given format (with the `image` crate's default memory limits).
    fn decode(bytes: &[u8], format: image::ImageFormat, intensity: f64) -> Result<Self, LightError> {
        let load_err = |reason: String| LightError::ImageLoad { path: "(memory)".into(), reason };
        let reader = image::ImageReader::with_format(std::io::Cursor::new(bytes), format);
        let img = reader.decode().map_err(|e| load_err(e.to_string()))?.into_rgb32f();
        let (width, height) = (img.width() as usize, img.height() as usize);
        check_size(width, height)?;
        let texels = img.pixels().map(|p| p.0.map(|c| if c < 0.0 { 0.0 } else { c })).collect();
        Self::from_texels(width, height, texels, intensity)
    }

    fn from_texels(width: usize, height: usize, texels: Vec<[f32; 3]>, intensity: f64) -> Result<Self, LightError> {
        check_intensity(intensity)?;
        if let Some(i) = texels.iter().position(|t| t.iter().any(|c| !c.is_finite() || *c < 0.0)) {
            return Err(LightError::ImageTexel { x: i % width, y: i / width, value: texels[i] });
        }
        let mut data = MapData { width, height, texels, sh9: [[0.0; 9]; 3], sampler: None, sh: ShCache::default() };
        data.sh9 = data.project_sh9();
        data.sampler = data.build_sampler();
        Ok(Self { data: Arc::new(data), intensity })
    }

    /// Width in texels.
    #[must_use]
    pub fn width(&self) -> usize {
        self.data.width
    }

    /// Height in texels.
    #[must_use]
    pub fn height(&self) -> usize {
        self.data.height
    }

    /// The intensity multiplier applied to every texel.
    #[must_use]
    pub fn intensity(&self) -> f64 {
        self.intensity
    }

    /// Changes the intensity multiplier (cheap: the derived data does not depend on it).
    ///
    /// # Errors
    /// [`LightError::ImageIntensity`] for a NaN, infinite or negative value (the map is then
    /// unchanged).
    pub fn set_intensity(&mut self, intensity: f64) -> Result<(), LightError> {
        check_intensity(intensity)?;
        self.intensity = intensity;
        Ok(())
    }

    /// The stored texel at column `x`, row `y` (row 0 at the top), without the multiplier.
    ///
    /// # Panics
    /// If `x ≥ width` or `y ≥ height`.
    #[must_use]
    pub fn texel(&self, x: usize, y: usize) -> [f32; 3] {
        let m = &*self.data;
        assert!(x < m.width && y < m.height, "texel ({x}, {y}) outside {}×{}", m.width, m.height);
        m.texels[y * m.width + x]
    }

    /// Column and row of the texel seen in the unit direction `d`.
    #[must_use]
    pub fn texel_index(&self, d: DVec3) -> (usize, usize) {
        self.data.texel_index(d)
    }

    /// Radiance (with the multiplier) arriving from the unit direction `d`.
    #[must_use]
    pub fn radiance(&self, d: DVec3) -> [f64; 3] {
        let m = &*self.data;
        let (x, y) = m.texel_index(d);
        m.texels[y * m.width + x].map(|c| f64::from(c) * self.intensity)
    }

    /// The SH9 projection L_c,i = ∫ L_c(ω) Y_i(ω) dω of the (piecewise-constant) map, per
    /// channel c, with the multiplier; the order of the nine coefficients is that of
    /// [`super::sh`]. Each texel's integral of Y_i is evaluated in closed form
    /// ([`super::sh::sh9_patch_integrals`]), so the projection is exact for the stored image.
    #[must_use]
    pub fn sh9(&self) -> [[f64; 9]; 3] {
        self.data.sh9.map(|c| c.map(|v| v * self.intensity))
    }

    /// The projection L_lm = ∫ L(ω) Y_lm(ω) dω of the (piecewise-constant) map to any order n
    /// ≤ [`MAX_ORDER`] (bands l < n, the basis of [`super::sh`], per coefficient l(l + 1) + m
    /// the three channels), with the multiplier. Each texel's integral of Y_lm is a θ factor
    /// times a φ factor ([`super::sh::sh_polar_factors`], [`super::sh::sh_azimuth_factors`]), so
    /// this is the stored image's projection to rounding, and its first nine coefficients are
    /// [`EquirectMap::sh9`]'s. The projection to [`MAX_ORDER`] is made once per image, on the
    /// first call (rows in parallel, summed in row order: independent of the thread count), and
    /// shared by every clone and multiplier; lower orders are its leading coefficients.
    ///
    /// # Errors
    /// [`LightError::InvalidOption`] (field `sh_order`) for an order outside [1, [`MAX_ORDER`]].
    pub fn sh(&self, order: usize) -> Result<Vec<[f64; 3]>, LightError> {
        if !(1..=MAX_ORDER).contains(&order) {
            return Err(LightError::InvalidOption {
                field: "sh_order",
                value: order.to_string(),
                requirement: format!("must be in [1, {MAX_ORDER}]"),
            });
        }
        let all = self.data.sh.0.get_or_init(|| self.data.project_sh());
        Ok(all[..order * order].iter().map(|c| c.map(|v| v * self.intensity)).collect())
    }

    /// Whether every texel is black (then it casts no light and cannot be sampled).
    #[must_use]
    pub fn is_black(&self) -> bool {
        self.data.sampler.is_none()
    }

    /// Draws a direction with density ∝ luminance (described on [`EquirectMap`]) from
    /// `u` ∈ [0, 1)², or `None` for an all-black map. The inversion is continuous within each
    /// texel, so stratified `u` give stratified directions. The density does not depend on the
    /// multiplier.
    #[must_use]
    pub fn sample(&self, u: [f64; 2]) -> Option<EnvSample> {
        self.data.sample(u)
    }

    /// Density per unit solid angle of [`EquirectMap::sample`] at the unit direction `d`
    /// (0 for an all-black map): Y(texel of d) / Σ Y ΔΩ.
    #[must_use]
    pub fn pdf(&self, d: DVec3) -> f64 {
        self.data.pdf(d)
    }
}

impl MapData {
    fn texel_index(&self, d: DVec3) -> (usize, usize) {
        let (u, v) = direction_to_equirect(d);
        let x = ((u * self.width as f64) as usize).min(self.width - 1);
        let y = ((v * self.height as f64) as usize).min(self.height - 1);
        (x, y)
    }

    /// Exact solid angle of a texel in row `y`: (2π/width)(cos θ_y − cos θ_{y+1}).
    fn row_solid_angle(&self, y: usize) -> f64 {
        let (t0, t1) = self.row_thetas(y);
        2.0 * PI / self.width as f64 * (t0.cos() - t1.cos())
    }

    fn row_thetas(&self, y: usize) -> (f64, f64) {
        (PI * y as f64 / self.height as f64, PI * (y + 1) as f64 / self.height as f64)
    }

    /// Azimuth interval [φ₀, φ₁] of column `x`.
    fn col_phis(&self, x: usize) -> (f64, f64) {
        let w = self.width as f64;
        (PI - 2.0 * PI * (x + 1) as f64 / w, PI - 2.0 * PI * x as f64 / w)
    }

    /// Σ over texels of L_texel · ∫_texel Y_i dω, rows in parallel (summed in row order, so
    /// the result does not depend on the thread count).
    fn project_sh9(&self) -> [[f64; 9]; 3] {
        let cols: Vec<AzimuthFactors> = (0..self.width)
            .map(|x| {
                let (p0, p1) = self.col_phis(x);
                AzimuthFactors::new(p0, p1)
            })
            .collect();
        let rows: Vec<[[f64; 9]; 3]> = (0..self.height)
            .into_par_iter()
            .map(|y| {
                let (t0, t1) = self.row_thetas(y);
                let polar = PolarFactors::new(t0, t1);
                let mut out = [[0.0; 9]; 3];
                for (t, azimuth) in self.texels[y * self.width..(y + 1) * self.width].iter().zip(&cols) {
                    if *t == [0.0; 3] {
                        continue;
                    }
                    let w = polar.patch(azimuth);
                    for (o, &l) in out.iter_mut().zip(t) {
                        for (oi, wi) in o.iter_mut().zip(&w) {
                            *oi += f64::from(l) * wi;
                        }
                    }
                }
                out
            })
            .collect();
        let mut out = [[0.0; 9]; 3];
        for row in &rows {
            for (o, r) in out.iter_mut().zip(row) {
                for (oi, ri) in o.iter_mut().zip(r) {
                    *oi += ri;
                }
            }
        }
        out
    }

    /// The projection to order [`MAX_ORDER`]: per row, Σ_x L(x, y) ∫cos mφ and ∫sin mφ over
    /// the column, times the row's θ factors; rows in parallel, summed in row order.
    fn project_sh(&self) -> Vec<[f64; 3]> {
        let n = MAX_ORDER;
        let cols: Vec<Vec<(f64, f64)>> = (0..self.width)
            .map(|x| {
                let (p0, p1) = self.col_phis(x);
                sh_azimuth_factors(n, p0, p1)
            })
            .collect();
        let rows: Vec<Vec<[f64; 3]>> = (0..self.height)
            .into_par_iter()
            .map(|y| {
                // Σ_x L ∫cos mφ and Σ_x L ∫sin mφ per m and channel.
                let mut cos_sums = [[0.0; 3]; MAX_ORDER];
                let mut sin_sums = [[0.0; 3]; MAX_ORDER];
                for (t, azimuth) in self.texels[y * self.width..(y + 1) * self.width].iter().zip(&cols) {
                    if *t == [0.0; 3] {
                        continue;
                    }
                    for (m, &(c, s)) in azimuth.iter().enumerate() {
                        for ch in 0..3 {
                            let l = f64::from(t[ch]);
                            cos_sums[m][ch] += l * c;
                            sin_sums[m][ch] += l * s;
                        }
                    }
                }
                let mut out = vec![[0.0; 3]; n * n];
                if cos_sums.iter().chain(&sin_sums).all(|v| *v == [0.0; 3]) {
                    return out;
                }
                let (t0, t1) = self.row_thetas(y);
                let polar = sh_polar_factors(n, t0, t1);
                for m in 0..n {
                    for l in m..n {
                        let f = polar[l * (l + 1) / 2 + m];
                        out[sh_index(l, m as isize)] = cos_sums[m].map(|v| f * v);
                        if m > 0 {
                            out[sh_index(l, -(m as isize))] = sin_sums[m].map(|v| f * v);
                        }
                    }
                }
                out
            })
            .collect();
        let mut out = vec![[0.0; 3]; n * n];
        for row in &rows {
            for (o, r) in out.iter_mut().zip(row) {
                for (oc, rc) in o.iter_mut().zip(r) {
                    *oc += rc;
                }
            }
        }
        out
    }

    fn texel_luminance(&self, i: usize) -> f64 {
        luminance(self.texels[i].map(f64::from))
    }

    fn build_sampler(&self) -> Option<MapSampler> {
        let (w, h) = (self.width, self.height);
        let mut cols = vec![0.0; h * (w + 1)];
        let mut row_weight = vec![0.0; h];
        for y in 0..h {
            let cdf = &mut cols[y * (w + 1)..(y + 1) * (w + 1)];
            let mut acc = 0.0;
            for x in 0..w {
                acc += self.texel_luminance(y * w + x);
                cdf[x + 1] = acc;
            }
            if acc > 0.0 {
                cdf.iter_mut().for_each(|c| *c /= acc);
            }
            row_weight[y] = acc * self.row_solid_angle(y);
        }
        let mut rows = vec![0.0; h + 1];
        let mut acc = 0.0;
        for y in 0..h {
            acc += row_weight[y];
            rows[y + 1] = acc;
        }
        if acc <= 0.0 {
            return None;
        }
        rows.iter_mut().for_each(|c| *c /= acc);
        Some(MapSampler { rows, cols, total: acc })
    }

    fn sample(&self, u: [f64; 2]) -> Option<EnvSample> {
        let s = self.sampler.as_ref()?;
        let (y, fy) = invert_cdf(&s.rows, u[0]);
        let w = self.width;
        let (x, fx) = invert_cdf(&s.cols[y * (w + 1)..(y + 1) * (w + 1)], u[1]);
        let (t0, t1) = self.row_thetas(y);
        let (c0, c1) = (t0.cos(), t1.cos());
        let cos_t = (c0 + fy * (c1 - c0)).clamp(-1.0, 1.0);
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let (p0, p1) = self.col_phis(x);
        let phi = p1 - fx * (p1 - p0);
        let direction = DVec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t);
        let pdf = self.texel_luminance(y * w + x) / s.total;
        Some(EnvSample { direction, pdf })
    }

    fn pdf(&self, d: DVec3) -> f64 {
        match &self.sampler {
            None => 0.0,
            Some(s) => {
                let (x, y) = self.texel_index(d);
                self.texel_luminance(y * self.width + x) / s.total
            }
        }
    }
}

/// Finds bin i with cdf[i] ≤ u < cdf[i+1] (never a zero-width bin) and the position of u
/// within it, in [0, 1).
fn invert_cdf(cdf: &[f64], u: f64) -> (usize, f64) {
    let bins = cdf.len() - 1;
    let i = cdf.partition_point(|&c| c <= u).clamp(1, bins) - 1;
    let width = cdf[i + 1] - cdf[i];
    let f = if width > 0.0 { ((u - cdf[i]) / width).clamp(0.0, 1.0 - f64::EPSILON) } else { 0.5 };
    (i, f)
}

fn check_size(width: usize, height: usize) -> Result<(), LightError> {
    if width == 0 || height == 0 {
        Err(LightError::ImageSize { width, height })
    } else {
        Ok(())
    }
}

fn check_intensity(value: f64) -> Result<(), LightError> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(LightError::ImageIntensity { value })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::sampling::Pattern;
    use crate::light::sh::sh9_basis;

    #[test]
    fn convention_round_trip() {
        // Centre of the image looks along +x, u = ¼ along +y, top row is +z.
        assert!((equirect_to_direction(0.5, 0.5) - DVec3::X).length() < 1e-15);
        assert!((equirect_to_direction(0.25, 0.5) - DVec3::Y).length() < 1e-15);
        assert!((equirect_to_direction(0.0, 0.5) + DVec3::X).length() < 1e-15);
        assert!((equirect_to_direction(0.3, 0.0) - DVec3::Z).length() < 1e-15);
        for (u, v) in [(0.1, 0.2), (0.5, 0.5), (0.9, 0.7), (0.0, 0.4), (0.75, 0.999)] {
            let (u2, v2) = direction_to_equirect(equirect_to_direction(u, v));
            assert!((u - u2).abs() < 1e-12 && (v - v2).abs() < 1e-12, "{u},{v} → {u2},{v2}");
        }
    }

    #[test]
    fn buffer_checks() {
        assert_eq!(EquirectMap::from_rgb(0, 2, &[], 1.0), Err(LightError::ImageSize { width: 0, height: 2 }));
        assert_eq!(
            EquirectMap::from_rgb(2, 1, &[1.0; 5], 1.0),
            Err(LightError::ImageBufferLength { width: 2, height: 1, expected: 6, actual: 5 })
        );
        let mut rgb = [1.0f32; 12];
        rgb[7] = f32::NAN;
        match EquirectMap::from_rgb(2, 2, &rgb, 1.0) {
            Err(LightError::ImageTexel { x: 0, y: 1, .. }) => {}
            other => panic!("{other:?}"),
        }
        rgb[7] = -1.0;
        assert!(matches!(EquirectMap::from_rgb(2, 2, &rgb, 1.0), Err(LightError::ImageTexel { x: 0, y: 1, .. })));
        assert_eq!(EquirectMap::from_rgb(1, 1, &[1.0; 3], -2.0), Err(LightError::ImageIntensity { value: -2.0 }));
        let mut m = EquirectMap::from_rgb(1, 1, &[1.0; 3], 1.0).unwrap();
        assert!(m.set_intensity(f64::NAN).is_err());
        assert_eq!(m.intensity(), 1.0);
        m.set_intensity(2.0).unwrap();
        assert_eq!(m.radiance(DVec3::Z), [2.0; 3]);
    }

    #[test]
    fn texel_layout_follows_the_convention() {
        // 4×2: top row red, bottom row blue; columns differ in green.
        let mut rgb = Vec::new();
        for y in 0..2 {
            for x in 0..4 {
                rgb.extend_from_slice(&[if y == 0 { 1.0 } else { 0.0 }, x as f32, if y == 1 { 1.0 } else { 0.0 }]);
            }
        }
        let m = EquirectMap::from_rgb(4, 2, &rgb, 1.0).unwrap();
        assert_eq!(m.radiance(DVec3::new(0.0, 0.0, 1.0))[0], 1.0);
        assert_eq!(m.radiance(DVec3::new(0.0, 0.0, -1.0))[2], 1.0);
        // +x is in the image centre: u = 0.5 → column 2; +y at u = 0.25 → column 1.
        assert_eq!(m.radiance(DVec3::new(1.0, 0.0, 0.1).normalize())[1], 2.0);
        assert_eq!(m.radiance(DVec3::new(0.0, 1.0, 0.1).normalize())[1], 1.0);
        assert_eq!(m.radiance(DVec3::new(-1.0, -0.01, 0.1).normalize())[1], 3.0);
        assert_eq!(m.texel(1, 0), [1.0, 1.0, 0.0]);
    }

    #[test]
    fn sh9_of_a_constant_and_a_linear_map() {
        let m = EquirectMap::from_fn(16, 8, 2.0, |_| [1.0, 0.5, 0.0]).unwrap();
        let sh = m.sh9();
        let s = (4.0 * PI).sqrt();
        assert!((sh[0][0] - 2.0 * s).abs() < 1e-12 && (sh[1][0] - s).abs() < 1e-12);
        assert!(sh[0][1..].iter().all(|v| v.abs() < 1e-12), "{:?}", sh[0]);
        assert_eq!(sh[2], [0.0; 9]);
        // A fine map of L = x + 2: coefficients √(4π)·2 and √(4π/3) for Y₁₁.
        let m = EquirectMap::from_fn(512, 256, 1.0, |d| [d.x + 2.0; 3]).unwrap();
        let sh = m.sh9();
        assert!((sh[0][0] - 2.0 * s).abs() < 1e-5);
        assert!((sh[0][3] - (4.0 * PI / 3.0).sqrt()).abs() < 1e-4, "{}", sh[0][3]);
        for i in [1, 2, 4, 5, 6, 7, 8] {
            assert!(sh[0][i].abs() < 1e-4, "{i}: {}", sh[0][i]);
        }
    }

    #[test]
    fn any_order_projection() {
        // Its first nine coefficients are the closed-form SH9 projection's.
        let m = EquirectMap::from_fn(48, 24, 1.5, |d| [(3.0 * d.x).exp(), 1.0 + d.z * d.y, 0.2]).unwrap();
        let sh9 = m.sh9();
        let sh = m.sh(5).unwrap();
        assert_eq!(sh.len(), 25);
        for c in 0..3 {
            for i in 0..9 {
                assert!((sh[i][c] - sh9[c][i]).abs() < 1e-12 * sh9[c][0].abs(), "{c} {i}: {} vs {}", sh[i][c], sh9[c][i]);
            }
        }
        // Lower orders are the leading coefficients of higher ones.
        assert_eq!(m.sh(8).unwrap()[..25], sh[..]);
        // A fine map of L = Y₃,₋₂ ∝ xyz and Y₄,₄ ∝ x⁴ − 6x²y² + y⁴ (independent closed forms):
        // coefficient 1 at its own index, ~0 elsewhere.
        let y3 = |d: DVec3| 0.5 * (105.0 / PI).sqrt() * d.x * d.y * d.z;
        let y4 = |d: DVec3| 3.0 / 16.0 * (35.0 / PI).sqrt() * (d.x.powi(4) - 6.0 * d.x * d.x * d.y * d.y + d.y.powi(4));
        let fine = EquirectMap::from_fn(720, 360, 1.0, |d| [y3(d) + 1.0, y4(d) + 1.0, 1.0]).unwrap();
        let sh = fine.sh(6).unwrap();
        for (i, c) in sh.iter().enumerate() {
            let expect = [
                if i == sh_index(3, -2) {
                    1.0
                } else if i == 0 {
                    (4.0 * PI).sqrt()
                } else {
                    0.0
                },
                if i == sh_index(4, 4) {
                    1.0
                } else if i == 0 {
                    (4.0 * PI).sqrt()
                } else {
                    0.0
                },
                if i == 0 { (4.0 * PI).sqrt() } else { 0.0 },
            ];
            for ch in 0..3 {
                assert!((c[ch] - expect[ch]).abs() < 2e-4, "{i} channel {ch}: {} vs {}", c[ch], expect[ch]);
            }
        }
        assert!(matches!(m.sh(0), Err(LightError::InvalidOption { field: "sh_order", .. })));
        assert!(matches!(m.sh(9), Err(LightError::InvalidOption { field: "sh_order", .. })));
    }

    #[test]
    fn sampling_density_is_consistent() {
        // A map with a bright patch: ∫ pdf = 1, and E_pdf[f/pdf] = ∫ f for f = L·Y₁₀.
        let m = EquirectMap::from_fn(64, 32, 1.0, |d| {
            let bright = if d.dot(DVec3::new(0.5, 0.5, 0.7).normalize()) > 0.95 { 50.0 } else { 0.2 };
            [bright, bright * 0.5, 0.1]
        })
        .unwrap();
        let p = Pattern::new(99);
        let n = 1 << 16;
        let (mut sum_f, mut mean_pdf_ratio) = (0.0, 0.0);
        for i in 0..n {
            let s = m.sample(p.get(i)).unwrap();
            assert!((s.direction.length() - 1.0).abs() < 1e-12);
            let pdf = m.pdf(s.direction);
            assert!((pdf - s.pdf).abs() <= 1e-9 * pdf, "{} vs {}", pdf, s.pdf);
            sum_f += m.radiance(s.direction)[0] * sh9_basis(s.direction)[2] / s.pdf;
            mean_pdf_ratio += 1.0 / s.pdf;
        }
        // E[1/pdf] = solid angle where pdf > 0 = 4π.
        assert!((mean_pdf_ratio / n as f64 - 4.0 * PI).abs() < 1e-2 * 4.0 * PI, "{}", mean_pdf_ratio / n as f64);
        let expect = m.sh9()[0][2];
        assert!((sum_f / n as f64 - expect).abs() < 1e-2 * expect.abs().max(0.1), "{} vs {expect}", sum_f / n as f64);
    }

    #[test]
    fn black_rows_are_never_sampled_and_black_maps_not_at_all() {
        let m = EquirectMap::from_fn(8, 8, 1.0, |d| if d.z > 0.0 { [1.0; 3] } else { [0.0; 3] }).unwrap();
        let p = Pattern::new(5);
        for i in 0..1024 {
            assert!(m.sample(p.get(i)).unwrap().direction.z > 0.0);
        }
        let black = EquirectMap::from_rgb(2, 2, &[0.0; 12], 1.0).unwrap();
        assert!(black.is_black() && black.sample([0.3, 0.3]).is_none() && black.pdf(DVec3::Z) == 0.0);
    }

    #[test]
    fn invert_cdf_skips_empty_bins() {
        let cdf = [0.0, 0.0, 0.5, 0.5, 1.0];
        assert_eq!(invert_cdf(&cdf, 0.0).0, 1);
        assert_eq!(invert_cdf(&cdf, 0.25), (1, 0.5));
        assert_eq!(invert_cdf(&cdf, 0.5).0, 3);
        assert_eq!(invert_cdf(&cdf, 0.999_999).0, 3);
    }
}
