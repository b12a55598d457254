//! The rendered image, tone mapping, and PNG / OpenEXR output.

use std::io::{Cursor, Write};
use std::path::Path;

use image::{ImageBuffer, ImageFormat, Rgba};

use super::RenderError;

/// A rendered image: linear RGB with the exposure applied, and an alpha matte.
///
/// `rgba` holds `width × height` pixels in rows from top to bottom, each row left to right.
/// RGB is the complete picture (object, ground plane and background), *not* multiplied by alpha;
/// alpha is the filtered coverage of the objects (and of the ground plane when
/// [`AlphaMode::ObjectsAndGround`](super::AlphaMode::ObjectsAndGround) is chosen), in [0, 1].
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Linear RGB and coverage alpha, row-major from the top-left pixel.
    pub rgba: Vec<[f32; 4]>,
}

/// How linear radiance is mapped to display values in [`Image::to_srgb8`] and
/// [`Image::save_png_with`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum ToneMap {
    /// The filmic ACES curve fitted by Narkowicz (2015), per channel: [`aces_fitted`].
    #[default]
    AcesFitted,
    /// No curve: values are clamped to [0, 1].
    Clamp,
}

impl ToneMap {
    /// Applies the curve to one linear value, giving a display-linear value in [0, 1]
    /// (NaN maps to 0).
    #[must_use]
    pub fn apply(self, x: f64) -> f64 {
        match self {
            ToneMap::AcesFitted => aces_fitted(x),
            ToneMap::Clamp => clamp01(x),
        }
    }
}

/// The ACES filmic tone curve as fitted by Krzysztof Narkowicz ("ACES Filmic Tone Mapping Curve",
/// 2015), a rational approximation of the ACES reference rendering and sRGB output transforms:
///
/// f(x) = x (a x + b) / (x (c x + d) + e),  a = 2.51, b = 0.03, c = 2.43, d = 0.59, e = 0.14,
///
/// clamped to [0, 1] (negative and NaN inputs give 0). It has a toe (f′(0) = b/e ≈ 0.21),
/// maps mid-grey 0.18 to about 0.27, and shoulders towards a/c ≈ 1.03, reaching 1 near x ≈ 11.
/// Narkowicz pre-scales by 0.6 to match the ACES exposure; here exposure is left to
/// [`RenderOptions::exposure_ev`](super::RenderOptions::exposure_ev).
#[must_use]
pub fn aces_fitted(x: f64) -> f64 {
    const A: f64 = 2.51;
    const B: f64 = 0.03;
    const C: f64 = 2.43;
    const D: f64 = 0.59;
    const E: f64 = 0.14;
    if x.is_nan() || x <= 0.0 {
        return 0.0;
    }
    clamp01(x * (A * x + B) / (x * (C * x + D) + E))
}

/// The sRGB opto-electronic transfer function (IEC 61966-2-1): display-linear c in [0, 1] to the
/// encoded value
///
/// c′ = 12.92 c for c ≤ 0.0031308,  c′ = 1.055 c^(1/2.4) − 0.055 otherwise.
///
/// Inputs are clamped to [0, 1] first (NaN gives 0).
#[must_use]
pub fn srgb_oetf(c: f64) -> f64 {
    let c = clamp01(c);
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// Clamps to [0, 1], mapping NaN to 0.
fn clamp01(x: f64) -> f64 {
    if x > 0.0 {
        x.min(1.0)
    } else {
        0.0
    }
}

/// Quantises a value in [0, 1] to 8 bits, rounding to nearest.
fn quantise(x: f64) -> u8 {
    // x is in [0, 1] (callers clamp), so the product is in [0, 255.5).
    (clamp01(x) * 255.0 + 0.5).floor() as u8
}

impl Image {
    /// The pixel at column `x`, row `y` (0, 0 top-left), or `None` outside the image.
    #[must_use]
    pub fn pixel(&self, x: u32, y: u32) -> Option<[f32; 4]> {
        (x < self.width && y < self.height).then(|| self.rgba[y as usize * self.width as usize + x as usize])
    }

    /// 8-bit display values, row-major RGBA: each colour channel tone-mapped by `tone` and then
    /// encoded with the sRGB OETF ([`srgb_oetf`]); alpha stays linear (it is coverage) and is
    /// quantised directly. Rounding is to nearest, without dithering.
    #[must_use]
    pub fn to_srgb8(&self, tone: ToneMap) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.rgba.len() * 4);
        for p in &self.rgba {
            for &c in &p[..3] {
                out.push(quantise(srgb_oetf(tone.apply(f64::from(c)))));
            }
            out.push(quantise(f64::from(p[3])));
        }
        out
    }

    /// Writes an 8-bit sRGB PNG with alpha, tone-mapped with the ACES fitted curve
    /// ([`ToneMap::AcesFitted`]).
    ///
    /// # Errors
    /// [`RenderError::Write`] when the file cannot be created or encoded.
    pub fn save_png(&self, path: impl AsRef<Path>) -> Result<(), RenderError> {
        self.save_png_with(path, ToneMap::AcesFitted)
    }

    /// Writes an 8-bit sRGB PNG with alpha using the given tone curve ([`to_srgb8`](Self::to_srgb8)).
    ///
    /// The image is encoded in memory and then written with every write error reported (a
    /// full disk, `/dev/full`): a call that returns `Ok` has handed all bytes to the file.
    ///
    /// # Errors
    /// [`RenderError::Write`] when the file cannot be created, encoded or written.
    pub fn save_png_with(&self, path: impl AsRef<Path>, tone: ToneMap) -> Result<(), RenderError> {
        let path = path.as_ref();
        let buffer: ImageBuffer<Rgba<u8>, Vec<u8>> = ImageBuffer::from_raw(self.width, self.height, self.to_srgb8(tone))
            .expect("to_srgb8 returns width × height × 4 bytes");
        let mut bytes = Cursor::new(Vec::new());
        buffer
            .write_to(&mut bytes, ImageFormat::Png)
            .map_err(|source| RenderError::Write { path: path.to_path_buf(), source })?;
        write_file(path, bytes.get_ref()).map_err(|e| RenderError::Write { path: path.to_path_buf(), source: e.into() })
    }

    /// Writes a linear RGBA 32-bit float OpenEXR file: the image's values as they are (exposure
    /// applied, no tone curve), alpha the coverage matte. Write errors are reported as for
    /// [`save_png_with`](Self::save_png_with).
    ///
    /// # Errors
    /// [`RenderError::Write`] when the file cannot be created, encoded or written.
    pub fn save_exr(&self, path: impl AsRef<Path>) -> Result<(), RenderError> {
        let path = path.as_ref();
        let data: Vec<f32> = self.rgba.iter().flatten().copied().collect();
        let buffer: ImageBuffer<Rgba<f32>, Vec<f32>> =
            ImageBuffer::from_raw(self.width, self.height, data).expect("rgba has width × height pixels");
        let mut bytes = Cursor::new(Vec::new());
        buffer
            .write_to(&mut bytes, ImageFormat::OpenExr)
            .map_err(|source| RenderError::Write { path: path.to_path_buf(), source })?;
        write_file(path, bytes.get_ref()).map_err(|e| RenderError::Write { path: path.to_path_buf(), source: e.into() })
    }
}

/// Writes `bytes` to `path` whole or not at all ([`crate::output::write_atomically`]).
fn write_file(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    crate::output::write_atomically(path, |out| out.write_all(bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aces_curve_values() {
        assert_eq!(aces_fitted(0.0), 0.0);
        assert_eq!(aces_fitted(-1.0), 0.0);
        assert_eq!(aces_fitted(f64::NAN), 0.0);
        let x: f64 = 0.18;
        let expect = x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14);
        assert!((aces_fitted(0.18) - expect).abs() < 1e-15);
        assert!((aces_fitted(0.18) - 0.2669).abs() < 1e-3);
        assert_eq!(aces_fitted(100.0), 1.0);
        // Monotone.
        let mut last = 0.0;
        for i in 1..=1000 {
            let y = aces_fitted(i as f64 * 0.02);
            assert!(y >= last);
            last = y;
        }
    }

    #[test]
    fn srgb_oetf_values() {
        assert_eq!(srgb_oetf(0.0), 0.0);
        assert!((srgb_oetf(1.0) - 1.0).abs() < 1e-15);
        assert!((srgb_oetf(0.001) - 0.01292).abs() < 1e-15);
        // Mid-grey 0.18 encodes to about 0.4614 (118/255).
        assert!((srgb_oetf(0.18) - 0.461_356).abs() < 1e-5);
        // The two pieces meet at the breakpoint.
        let c: f64 = 0.003_130_8;
        assert!((12.92 * c - (1.055 * c.powf(1.0 / 2.4) - 0.055)).abs() < 1e-6);
        assert_eq!(srgb_oetf(2.0), srgb_oetf(1.0));
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_full_device_is_a_write_error() {
        let img = Image { width: 2, height: 2, rgba: vec![[0.5, 0.5, 0.5, 1.0]; 4] };
        for e in [img.save_png("/dev/full").unwrap_err(), img.save_exr("/dev/full").unwrap_err()] {
            let RenderError::Write { path, source: image::ImageError::IoError(io) } = &e else { panic!("{e:?}") };
            assert_eq!(path, Path::new("/dev/full"));
            assert_eq!(io.raw_os_error(), Some(28), "{io}"); // ENOSPC
            assert_eq!(e.to_string().matches("/dev/full").count(), 1, "{e}");
        }
    }

    #[test]
    fn srgb8_encoding() {
        let img = Image { width: 2, height: 1, rgba: vec![[0.18, 0.0, 5.0, 0.5], [1.0, -1.0, f32::NAN, 1.0]] };
        let clamp = img.to_srgb8(ToneMap::Clamp);
        assert_eq!(clamp, vec![118, 0, 255, 128, 255, 0, 0, 255]);
        let aces = img.to_srgb8(ToneMap::AcesFitted);
        assert_eq!(aces[0], quantise(srgb_oetf(aces_fitted(f64::from(0.18f32)))));
        assert_eq!(aces[3], 128);
        assert_eq!(img.pixel(0, 0), Some([0.18, 0.0, 5.0, 0.5]));
        assert!(img.pixel(2, 0).is_none());
    }
}
