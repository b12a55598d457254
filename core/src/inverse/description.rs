//! An acquisition on disk: a description of the setup, the light
//! patterns and the optimiser, and one linear image file per pattern (OpenEXR, or any format
//! the `image` crate decodes to linear floats), read into the typed, in-memory inputs of
//! [`super::Acquisition::new`] and [`super::acquire`].
//!
//! The description is plain data ([`Description`], serde), so any front end parses its own
//! format (the CLI reads TOML) and the C ABI, which takes images in memory, never comes here.
//! Every check on it runs before the first file is opened, and every file is checked before
//! any solve, so bad input stops an acquisition before it starts.
//!
//! # Images and the face
//!
//! Pixel (x, y) of an image, rows from the top of the file, is face node (i, j) = (x, y) of the
//! observed face (x fastest, as in [`super::setup`]): an image is `nodes[0]` pixels wide and
//! `nodes[1]` high. A grey image counts as the same value in all three channels.
//!
//! ```toml
//! nodes = [40, 40, 12]         # grid nodes along x, y, z (the lit face is z = max)
//! spacing_mm = 0.5
//! eta = 1.3
//! observe = "back"             # "front" (the lit face) or "back" (the opposite face)
//! margin_mm = 1.0              # front only: pixels this close to light are not fitted
//! images = ["m00.exr", "m01.exr"]   # one per pattern, relative to this file
//!
//! [patterns]
//! grid = 4                     # the paper's 4 × 4 regions, row by row (16 images) …
//! q = [1.0, 1.0, 1.0]
//! # … or explicit rectangles, [[patterns.rect]] rect = [x0, x1, y0, y1] (mm), q = [r, g, b],
//! # … or one image of q per pattern, files = ["p00.exr", …].
//!
//! [optimiser]
//! method = "lbfgs"             # or "paper" (Polak–Ribière CG, golden-section search)
//! lambda = 1e-4                # or discrepancy = { noise_rms = 0.01 }
//! max_iterations = 40
//! channels = "rgb"             # or "grey": grey images, one channel fitted and copied
//! coarse_levels = 0            # N: fit blocks of 2^N, …, 2 cells before single cells
//! absorption_coarsening = 1    # F: σa on blocks F times wider than σ′s
//! ```

use std::io::Cursor;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::input::{BoundedFile, InputError, Limits};

use super::error::InverseError;
use super::model::{Setup, SolveSettings};
use super::optimize::{AcquireOptions, Channels, Lambda, Method};
use super::setup::{Observation, Pattern};

/// The largest image file read, in bytes (a 4096² RGBA float image is 256 MiB).
pub const MAX_IMAGE_FILE_BYTES: u64 = 256 << 20;

/// An acquisition description (module documentation for the TOML form).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Description {
    /// Grid nodes along x, y, z (≥ 2 each); the lit face is z = max.
    pub nodes: [usize; 3],
    /// Node spacing, mm.
    pub spacing_mm: f64,
    /// The sample's refractive index.
    pub eta: f64,
    /// Which face the camera sees.
    pub observe: Face,
    /// Front-lit only: pixels within this distance (mm) of a lit pixel are left out of the fit
    /// (design note P13).
    #[serde(default)]
    pub margin_mm: f64,
    /// One image per pattern, in pattern order (paths relative to the description's folder).
    pub images: Vec<PathBuf>,
    /// Optional masks, one per image: a pixel is fitted where the mask's first channel is > 0.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub masks: Vec<PathBuf>,
    /// The light patterns.
    pub patterns: PatternSet,
    /// The optimiser.
    #[serde(default)]
    pub optimiser: OptimiserSettings,
    /// Where the recovered voxel grid sits in a scene.
    #[serde(default)]
    pub output: OutputSettings,
}

/// The observed face.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Face {
    /// The lit face (thick samples).
    Front,
    /// The face opposite the light (thin samples).
    Back,
}

/// The light patterns: exactly one of `grid`, `rect` and `files`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PatternSet {
    /// n: the n × n regions of the lit face ([`Pattern::grid_all`]; the paper's n = 4).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grid: Option<usize>,
    /// q of every `grid` region, per channel.
    #[serde(default = "unit_q")]
    pub q: [f64; 3],
    /// Explicit rectangles.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub rect: Vec<RectPattern>,
    /// One image of q per pattern, at the lit face's nodes (as a projector's image resampled).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub files: Vec<PathBuf>,
}

fn unit_q() -> [f64; 3] {
    [1.0; 3]
}

/// One rectangle of light ([`Pattern::Rect`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RectPattern {
    /// [x0, x1, y0, y1], mm from the face's corner.
    pub rect: [f64; 4],
    /// q inside, per channel.
    pub q: [f64; 3],
}

/// The optimiser's settings; any left out take [`AcquireOptions::default`]'s values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OptimiserSettings {
    /// "lbfgs" (default) or "paper".
    pub method: MethodName,
    /// L-BFGS correction pairs.
    pub lbfgs_memory: usize,
    /// λ (≥ 0); at most one of `lambda` and `discrepancy`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lambda: Option<f64>,
    /// λ by the discrepancy principle.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub discrepancy: Option<Discrepancy>,
    /// Iterations at most per channel of the per-cell fit (0: homogeneous only).
    pub max_iterations: usize,
    /// Iterations at most per channel of the homogeneous fit.
    pub homogeneous_iterations: usize,
    /// Stop when every channel's RMS relative misfit is at most this (0: never).
    pub target_misfit_rms: f64,
    /// Stop when an iteration lowers f by less than this fraction.
    pub relative_decrease: f64,
    /// Stop when ‖∇f‖∞ is at most this.
    pub gradient_tolerance: f64,
    /// The linear solves' relative residual.
    pub solve_tolerance: f64,
    /// The homogeneous fit's starting σa, mm⁻¹.
    pub initial_sigma_a: [f64; 3],
    /// The homogeneous fit's starting σ′s, mm⁻¹.
    pub initial_sigma_s_prime: [f64; 3],
    /// "rgb" (default: each channel fitted) or "grey" (grey images: the first channel fitted
    /// and copied, [`Channels::Grey`]).
    pub channels: ChannelsName,
    /// Coarse-to-fine levels before the per-cell fit ([`AcquireOptions::coarse_levels`]).
    pub coarse_levels: usize,
    /// σa's blocks this many times wider than σ′s ([`AcquireOptions::absorption_coarsening`]).
    pub absorption_coarsening: usize,
}

/// The fitted channels' name in a description.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ChannelsName {
    /// [`Channels::Rgb`].
    Rgb,
    /// [`Channels::Grey`].
    Grey,
}

/// The optimiser's name in a description.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MethodName {
    /// [`Method::Lbfgs`].
    Lbfgs,
    /// [`Method::PaperCg`].
    Paper,
}

/// [`Lambda::Discrepancy`]'s settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Discrepancy {
    /// The images' noise, RMS relative to the signal.
    pub noise_rms: f64,
    /// τ ≥ 1.
    #[serde(default = "default_tau")]
    pub tau: f64,
    /// The first λ tried.
    #[serde(default = "default_start")]
    pub start: f64,
}

fn default_tau() -> f64 {
    1.1
}

fn default_start() -> f64 {
    1e-2
}

impl Default for OptimiserSettings {
    fn default() -> Self {
        let o = AcquireOptions::default();
        Self {
            method: MethodName::Lbfgs,
            lbfgs_memory: match Method::default() {
                Method::Lbfgs { memory } => memory,
                Method::PaperCg => 8,
            },
            lambda: None,
            discrepancy: None,
            max_iterations: o.max_iterations,
            homogeneous_iterations: o.homogeneous_iterations,
            target_misfit_rms: o.target_misfit_rms,
            relative_decrease: o.relative_decrease,
            gradient_tolerance: o.gradient_tolerance,
            solve_tolerance: o.solve.tolerance,
            initial_sigma_a: o.initial.0,
            initial_sigma_s_prime: o.initial.1,
            channels: ChannelsName::Rgb,
            coarse_levels: o.coarse_levels,
            absorption_coarsening: o.absorption_coarsening,
        }
    }
}

/// The voxel grid's placement: the block's lowest corner and the scene units per mm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OutputSettings {
    /// The block's lowest corner, scene units.
    pub origin: [f64; 3],
    /// Scene units per mm.
    pub units_per_mm: f64,
}

impl Default for OutputSettings {
    fn default() -> Self {
        Self { origin: [0.0; 3], units_per_mm: 1.0 }
    }
}

/// A description's inputs, read and checked: what [`super::Acquisition::new`] and
/// [`super::acquire`] take.
#[derive(Debug, Clone, PartialEq)]
pub struct Loaded {
    /// The setup.
    pub setup: Setup,
    /// The light patterns, in image order.
    pub patterns: Vec<Pattern>,
    /// The images, pixels x fastest.
    pub images: Vec<Vec<[f64; 3]>>,
    /// The masks (`true`: fit), when the description gives them.
    pub masks: Option<Vec<Vec<bool>>>,
    /// The optimiser's options.
    pub options: AcquireOptions,
}

impl Description {
    /// The setup it describes.
    ///
    /// # Errors
    /// [`InverseError::InvalidGrid`] for fewer than 2 nodes along an axis.
    pub fn setup(&self) -> Result<Setup, InverseError> {
        if self.nodes.iter().any(|&n| n < 2) {
            return Err(InverseError::InvalidGrid { dims: self.nodes, reason: "at least 2 nodes per axis" });
        }
        let observation = match self.observe {
            Face::Front => Observation::FrontLit { margin_mm: self.margin_mm },
            Face::Back => Observation::BackLit,
        };
        Ok(Setup { dims: self.nodes, spacing_mm: self.spacing_mm, eta: self.eta, observation })
    }

    /// The number of patterns (without reading a file).
    ///
    /// # Errors
    /// [`InverseError::InvalidDescription`] unless exactly one kind of pattern is given, or for
    /// a grid of 0 regions.
    pub fn pattern_count(&self) -> Result<usize, InverseError> {
        let p = &self.patterns;
        let kinds = usize::from(p.grid.is_some()) + usize::from(!p.rect.is_empty()) + usize::from(!p.files.is_empty());
        if kinds != 1 {
            return Err(InverseError::InvalidDescription(format!(
                "[patterns] needs exactly one of `grid`, `rect` and `files`, {kinds} given"
            )));
        }
        match p.grid {
            Some(0) => Err(InverseError::InvalidDescription("[patterns] grid = 0: at least 1 region".into())),
            Some(n) => Ok(n * n),
            None => Ok(p.rect.len() + p.files.len()),
        }
    }

    /// The optimiser's options.
    ///
    /// # Errors
    /// [`InverseError::NegativeLambda`] for λ < 0 or not finite;
    /// [`InverseError::InvalidDescription`] for both `lambda` and `discrepancy`;
    /// [`InverseError::InvalidSetting`] for a solve tolerance outside (0, 1).
    pub fn options(&self) -> Result<AcquireOptions, InverseError> {
        let o = &self.optimiser;
        let lambda = match (o.lambda, o.discrepancy) {
            (Some(_), Some(_)) => {
                return Err(InverseError::InvalidDescription("[optimiser] takes `lambda` or `discrepancy`, not both".into()))
            }
            (Some(l), None) if !(l.is_finite() && l >= 0.0) => return Err(InverseError::NegativeLambda(l)),
            (Some(l), None) => Lambda::Given(l),
            (None, Some(d)) => Lambda::Discrepancy { noise_rms: d.noise_rms, tau: d.tau, start: d.start },
            (None, None) => AcquireOptions::default().lambda,
        };
        if !(o.solve_tolerance > 0.0 && o.solve_tolerance < 1.0) {
            return Err(InverseError::InvalidSetting {
                what: "solve tolerance",
                value: o.solve_tolerance,
                expected: "in (0, 1)",
            });
        }
        let method = match o.method {
            MethodName::Lbfgs => Method::Lbfgs { memory: o.lbfgs_memory },
            MethodName::Paper => Method::PaperCg,
        };
        Ok(AcquireOptions {
            method,
            lambda,
            initial: (o.initial_sigma_a, o.initial_sigma_s_prime),
            homogeneous_iterations: o.homogeneous_iterations,
            max_iterations: o.max_iterations,
            target_misfit_rms: o.target_misfit_rms,
            relative_decrease: o.relative_decrease,
            gradient_tolerance: o.gradient_tolerance,
            solve: SolveSettings { tolerance: o.solve_tolerance, ..SolveSettings::default() },
            channels: match o.channels {
                ChannelsName::Rgb => Channels::Rgb,
                ChannelsName::Grey => Channels::Grey,
            },
            coarse_levels: o.coarse_levels,
            absorption_coarsening: o.absorption_coarsening,
        })
    }

    /// Checks the description, then reads and checks every file it names (relative paths
    /// against `base`, the description's folder).
    ///
    /// # Errors
    /// The errors of [`Description::setup`], [`Description::pattern_count`] and
    /// [`Description::options`]; [`InverseError::PatternCountMismatch`] for a different number
    /// of images than patterns, [`InverseError::InvalidDescription`] for a different number of
    /// masks than images (all before any file is opened); then the errors of [`read_image`].
    pub fn load(&self, base: &Path) -> Result<Loaded, InverseError> {
        let setup = self.setup()?;
        let options = self.options()?;
        let patterns = self.pattern_count()?;
        if self.images.len() != patterns {
            return Err(InverseError::PatternCountMismatch { images: self.images.len(), patterns });
        }
        if !self.masks.is_empty() && self.masks.len() != self.images.len() {
            return Err(InverseError::InvalidDescription(format!(
                "{} masks for {} images: one per image, or none",
                self.masks.len(),
                self.images.len()
            )));
        }
        let [nx, ny, _] = setup.dims;
        let resolve = |p: &PathBuf| base.join(p);
        let patterns = if let Some(n) = self.patterns.grid {
            Pattern::grid_all(n, setup.face_size_mm(), self.patterns.q)
        } else if !self.patterns.rect.is_empty() {
            self.patterns.rect.iter().map(|r| Pattern::Rect { rect: r.rect, q: r.q }).collect()
        } else {
            self.patterns
                .files
                .iter()
                .map(|p| {
                    let path = resolve(p);
                    let v = read_image(&path, nx, ny)?;
                    check_file_pixels(&path, &v, nx, true)?;
                    Ok(Pattern::Nodes(v))
                })
                .collect::<Result<_, InverseError>>()?
        };
        let images = self.images.iter().map(|p| read_image(&resolve(p), nx, ny)).collect::<Result<Vec<_>, _>>()?;
        let masks = if self.masks.is_empty() {
            None
        } else {
            let m = self.masks.iter().map(|p| Ok(read_image(&resolve(p), nx, ny)?.iter().map(|v| v[0] > 0.0).collect()));
            Some(m.collect::<Result<Vec<_>, InverseError>>()?)
        };
        Ok(Loaded { setup, patterns, images, masks, options })
    }
}

/// Reads a linear image of `width` × `height` pixels (OpenEXR, Radiance HDR, or any format the
/// `image` crate decodes; grey counts in all three channels, alpha is dropped), pixels x
/// fastest, rows from the top; NaN and infinite pixels are refused, naming the pixel.
///
/// # Errors
/// [`InverseError::MissingFile`]; [`InverseError::ImageFile`] for a file that cannot be read
/// or decoded; [`InverseError::ImageFileSize`] with both sizes; [`InverseError::ImageFilePixel`].
pub fn read_image(path: &Path, width: usize, height: usize) -> Result<Vec<[f64; 3]>, InverseError> {
    let name = path.display().to_string();
    let failed = |reason: String| InverseError::ImageFile { path: name.clone(), reason };
    let file = BoundedFile::open(path, Limits { max_bytes: MAX_IMAGE_FILE_BYTES, max_line: None }).map_err(|e| match e {
        InputError::Io(io) if io.kind() == std::io::ErrorKind::NotFound => InverseError::MissingFile { path: name.clone() },
        other => failed(other.to_string()),
    })?;
    let bytes = file.read_all().map_err(|e| failed(e.to_string()))?;
    let reader = image::ImageReader::new(Cursor::new(bytes)).with_guessed_format().map_err(|e| failed(e.to_string()))?;
    if reader.format().is_none() {
        return Err(failed("not an image this reader knows (OpenEXR, Radiance HDR or PNG)".into()));
    }
    let img = reader.decode().map_err(|e| failed(e.to_string()))?.into_rgb32f();
    let (w, h) = (img.width() as usize, img.height() as usize);
    if (w, h) != (width, height) {
        return Err(InverseError::ImageFileSize { path: name, width, height, found_width: w, found_height: h });
    }
    let v: Vec<[f64; 3]> = img.pixels().map(|p| p.0.map(f64::from)).collect();
    check_file_pixels(path, &v, width, false)?;
    Ok(v)
}

/// An error naming the first pixel that is not finite (or negative, with `nonnegative`).
fn check_file_pixels(path: &Path, v: &[[f64; 3]], width: usize, nonnegative: bool) -> Result<(), InverseError> {
    for (i, p) in v.iter().enumerate() {
        if let Some(channel) = p.iter().position(|&c| !c.is_finite() || (nonnegative && c < 0.0)) {
            return Err(InverseError::ImageFilePixel {
                path: path.display().to_string(),
                x: i % width,
                y: i / width,
                channel,
                value: p[channel],
            });
        }
    }
    Ok(())
}

/// Writes `pixels` (x fastest, rows from the top) as a `width` × `height` RGB float OpenEXR
/// file, whole or not at all ([`crate::output::write_atomically`]).
///
/// # Errors
/// [`InverseError::WrongImageSize`] for a pixel count other than `width` × `height`;
/// [`InverseError::ImageFile`] when it cannot be encoded or written.
pub fn write_image(path: &Path, width: usize, height: usize, pixels: &[[f64; 3]]) -> Result<(), InverseError> {
    if pixels.len() != width * height {
        return Err(InverseError::WrongImageSize {
            what: "image",
            index: 0,
            expected: width * height,
            found: pixels.len(),
            nx: width,
            ny: height,
        });
    }
    let failed = |reason: String| InverseError::ImageFile { path: path.display().to_string(), reason };
    let (w, h) =
        (u32::try_from(width).map_err(|e| failed(e.to_string()))?, u32::try_from(height).map_err(|e| failed(e.to_string()))?);
    let data: Vec<f32> = pixels.iter().flat_map(|p| p.map(|c| c as f32)).collect();
    let buffer = image::Rgb32FImage::from_raw(w, h, data).ok_or_else(|| failed("pixel buffer of the wrong size".into()))?;
    let mut bytes = Cursor::new(Vec::new());
    buffer.write_to(&mut bytes, image::ImageFormat::OpenExr).map_err(|e| failed(e.to_string()))?;
    crate::output::write_atomically(path, |out| std::io::Write::write_all(out, bytes.get_ref()))
        .map_err(|e| failed(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A folder of its own under the system's temporary folder, removed when dropped.
    struct Scratch(PathBuf);

    impl Scratch {
        fn new(name: &str) -> Self {
            let dir = std::env::temp_dir().join(format!("transcut-description-{name}-{}", std::process::id()));
            let _ = std::fs::remove_dir_all(&dir);
            std::fs::create_dir_all(&dir).unwrap();
            Self(dir)
        }
    }

    impl Drop for Scratch {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    /// A back-lit 4 × 3 × 3 description with two rectangle patterns and images m0, m1.
    fn two_rects() -> Description {
        Description {
            nodes: [4, 3, 3],
            spacing_mm: 0.5,
            eta: 1.3,
            observe: Face::Back,
            margin_mm: 0.0,
            images: vec!["m0.exr".into(), "m1.exr".into()],
            masks: Vec::new(),
            patterns: PatternSet {
                grid: None,
                q: [1.0; 3],
                rect: vec![
                    RectPattern { rect: [0.0, 0.5, 0.0, 0.5], q: [1.0; 3] },
                    RectPattern { rect: [1.0, 1.5, 0.5, 1.0], q: [2.0; 3] },
                ],
                files: Vec::new(),
            },
            optimiser: OptimiserSettings::default(),
            output: OutputSettings::default(),
        }
    }

    /// Pixel p of image m: a value no two pixels share, so a transposed read fails.
    fn pixel(m: usize, p: usize) -> [f64; 3] {
        [1.0 + p as f64, 0.5 + 0.25 * m as f64, 100.0 + 2.0 * p as f64]
    }

    fn write_two(dir: &Path) {
        for m in 0..2 {
            let v: Vec<[f64; 3]> = (0..12).map(|p| pixel(m, p)).collect();
            write_image(&dir.join(format!("m{m}.exr")), 4, 3, &v).unwrap();
        }
    }

    #[test]
    fn images_round_trip_pixel_for_pixel() {
        let s = Scratch::new("round-trip");
        write_two(&s.0);
        let loaded = two_rects().load(&s.0).unwrap();
        assert_eq!(loaded.images.len(), 2);
        for (m, img) in loaded.images.iter().enumerate() {
            for (p, v) in img.iter().enumerate() {
                // The values are exact in f32.
                assert_eq!(*v, pixel(m, p), "image {m} pixel {p}");
            }
        }
        assert_eq!(loaded.patterns[1], Pattern::Rect { rect: [1.0, 1.5, 0.5, 1.0], q: [2.0; 3] });
        assert_eq!(loaded.setup.observation, Observation::BackLit);
    }

    #[test]
    fn a_grid_of_four_gives_the_papers_sixteen_regions() {
        let mut d = two_rects();
        d.patterns = PatternSet { grid: Some(4), q: [1.0, 2.0, 3.0], rect: Vec::new(), files: Vec::new() };
        assert_eq!(d.pattern_count().unwrap(), 16);
        // Region (1, 2) of a 1.5 × 1 mm face: x in [0.375, 0.75], y in [0.5, 0.75].
        let all = Pattern::grid_all(4, [1.5, 1.0], [1.0, 2.0, 3.0]);
        assert_eq!(all[2 * 4 + 1], Pattern::Rect { rect: [0.375, 0.75, 0.5, 0.75], q: [1.0, 2.0, 3.0] });
    }

    #[test]
    fn a_wrong_image_size_names_both_sizes() {
        let s = Scratch::new("size");
        write_two(&s.0);
        write_image(&s.0.join("m1.exr"), 3, 4, &[[1.0; 3]; 12]).unwrap();
        let e = two_rects().load(&s.0).unwrap_err();
        let InverseError::ImageFileSize { path, width: 4, height: 3, found_width: 3, found_height: 4 } = &e else {
            panic!("{e:?}")
        };
        assert!(path.ends_with("m1.exr"), "{path}");
        assert!(e.to_string().contains("3 × 4 pixels, the face has 4 × 3"), "{e}");
    }

    #[test]
    fn a_nan_pixel_names_the_file_and_the_pixel() {
        let s = Scratch::new("nan");
        write_two(&s.0);
        let mut v: Vec<[f64; 3]> = (0..12).map(|p| pixel(0, p)).collect();
        v[6][2] = f64::NAN; // pixel (2, 1)
        write_image(&s.0.join("m0.exr"), 4, 3, &v).unwrap();
        let e = two_rects().load(&s.0).unwrap_err();
        let InverseError::ImageFilePixel { path, x: 2, y: 1, channel: 2, value } = &e else { panic!("{e:?}") };
        assert!(path.ends_with("m0.exr") && value.is_nan(), "{e}");
    }

    #[test]
    fn a_missing_file_names_its_path() {
        let s = Scratch::new("missing");
        write_two(&s.0);
        std::fs::remove_file(s.0.join("m1.exr")).unwrap();
        let e = two_rects().load(&s.0).unwrap_err();
        let InverseError::MissingFile { path } = &e else { panic!("{e:?}") };
        assert_eq!(Path::new(path), s.0.join("m1.exr"));
    }

    #[test]
    fn a_pattern_count_unlike_the_image_count_is_refused_before_any_file_is_read() {
        // No file exists: the count is checked first.
        let mut d = two_rects();
        d.images.push("m2.exr".into());
        let e = d.load(Path::new("/nonexistent")).unwrap_err();
        assert!(matches!(e, InverseError::PatternCountMismatch { images: 3, patterns: 2 }), "{e:?}");
        d.patterns.grid = Some(4);
        assert!(matches!(d.load(Path::new("/nonexistent")), Err(InverseError::InvalidDescription(_))));
    }

    #[test]
    fn a_negative_lambda_is_refused_before_any_file_is_read() {
        let mut d = two_rects();
        d.optimiser.lambda = Some(-1e-3);
        assert!(matches!(d.load(Path::new("/nonexistent")), Err(InverseError::NegativeLambda(l)) if l == -1e-3));
        d.optimiser.lambda = Some(1e-3);
        d.optimiser.discrepancy = Some(Discrepancy { noise_rms: 0.01, tau: 1.1, start: 1e-2 });
        assert!(matches!(d.options(), Err(InverseError::InvalidDescription(_))));
    }

    #[test]
    fn the_optimiser_keys_reach_the_options() {
        let mut d = two_rects();
        d.optimiser.method = MethodName::Paper;
        d.optimiser.channels = ChannelsName::Grey;
        d.optimiser.discrepancy = Some(Discrepancy { noise_rms: 0.02, tau: 1.5, start: 0.1 });
        d.optimiser.max_iterations = 7;
        d.optimiser.solve_tolerance = 1e-9;
        d.optimiser.coarse_levels = 2;
        d.optimiser.absorption_coarsening = 3;
        let o = d.options().unwrap();
        assert_eq!((o.coarse_levels, o.absorption_coarsening), (2, 3));
        assert_eq!(o.method, Method::PaperCg);
        assert_eq!(o.channels, Channels::Grey);
        assert_eq!(o.lambda, Lambda::Discrepancy { noise_rms: 0.02, tau: 1.5, start: 0.1 });
        assert_eq!((o.max_iterations, o.solve.tolerance), (7, 1e-9));
        // What is left out keeps the library's defaults.
        let defaults = AcquireOptions::default();
        assert_eq!((o.homogeneous_iterations, o.initial), (defaults.homogeneous_iterations, defaults.initial));
        let o = two_rects().options().unwrap();
        assert_eq!((o.coarse_levels, o.absorption_coarsening), (0, 1), "one fit per cell by default");
    }

    #[test]
    fn an_all_zero_mask_leaves_nothing_to_fit() {
        let s = Scratch::new("mask");
        write_two(&s.0);
        for m in 0..2 {
            write_image(&s.0.join(format!("w{m}.exr")), 4, 3, &[[0.0; 3]; 12]).unwrap();
        }
        let mut d = two_rects();
        d.masks = vec!["w0.exr".into(), "w1.exr".into()];
        let l = d.load(&s.0).unwrap();
        assert_eq!(l.masks.as_ref().map(|m| m[1].iter().filter(|&&k| k).count()), Some(0));
        let e = super::super::Acquisition::new(l.setup, &l.patterns, l.images, l.masks).unwrap_err();
        assert!(matches!(e, InverseError::EmptyMask { channel: 0, .. }), "{e:?}");
    }

    #[test]
    fn a_negative_pattern_pixel_is_refused() {
        let s = Scratch::new("pattern");
        write_two(&s.0);
        let mut q = vec![[1.0; 3]; 12];
        q[11] = [0.0, -0.5, 0.0];
        write_image(&s.0.join("p0.exr"), 4, 3, &[[1.0; 3]; 12]).unwrap();
        write_image(&s.0.join("p1.exr"), 4, 3, &q).unwrap();
        let mut d = two_rects();
        d.patterns = PatternSet { grid: None, q: [1.0; 3], rect: Vec::new(), files: vec!["p0.exr".into(), "p1.exr".into()] };
        let e = d.load(&s.0).unwrap_err();
        assert!(matches!(&e, InverseError::ImageFilePixel { x: 3, y: 2, channel: 1, .. }), "{e:?}");
    }

    #[test]
    fn a_file_that_is_not_an_image_is_named() {
        let s = Scratch::new("garbage");
        write_two(&s.0);
        std::fs::write(s.0.join("m0.exr"), b"not an image at all").unwrap();
        let e = two_rects().load(&s.0).unwrap_err();
        assert!(matches!(&e, InverseError::ImageFile { path, .. } if path.ends_with("m0.exr")), "{e:?}");
    }
}
