#![doc = include_str!("VOXEL_FORMAT.md")]

use std::io::Write;
use std::path::Path;

use glam::DVec3;
use rayon::prelude::*;

use super::error::VolumeError;
use super::field::{Coefficients, MediumField, TetSampling};
use super::per_tet::PerTetMedia;
use crate::input::{BoundedFile, InputError, Limits};
use crate::mesh::TetMesh;

/// The first 8 bytes of a TCVOX1 file.
pub const MAGIC: [u8; 8] = *b"TCVOX1\0\0";
/// Bytes before the voxel data.
pub const HEADER_BYTES: usize = 72;
/// Channels per voxel: σa R, G, B, σ′s R, G, B.
pub const CHANNELS: usize = 6;
/// The largest voxel file [`VoxelGrid::read`] reads, in bytes (4 GiB: about 179 million voxels).
pub const MAX_VOXEL_FILE_BYTES: u64 = 4 << 30;

/// A dense grid of σa and σ′s (`f32`, mm⁻¹) over a box in scene units; see the
/// [module documentation](self) for the geometry, the sampling rule and the file format.
#[derive(Debug, Clone, PartialEq)]
pub struct VoxelGrid {
    dims: [u32; 3],
    origin: DVec3,
    voxel_size: DVec3,
    /// Voxel-major, x fastest: value (voxel n, channel c) at `6n + c`.
    data: Vec<f32>,
}

impl VoxelGrid {
    /// A grid from its values: `data` holds 6 values per voxel, voxel-major with x fastest
    /// (voxel (i, j, k), channel c at `6·(i + nx·(j + ny·k)) + c`), as in the file format.
    ///
    /// # Errors
    /// [`VolumeError::ZeroDimension`], [`VolumeError::TooLarge`],
    /// [`VolumeError::InvalidGeometry`] (origin not finite, voxel size not finite and > 0),
    /// [`VolumeError::LengthMismatch`] unless `data.len() = 6·nx·ny·nz`,
    /// [`VolumeError::InvalidVoxel`] naming the first voxel with an invalid value.
    pub fn new(dims: [u32; 3], origin: DVec3, voxel_size: DVec3, data: Vec<f32>) -> Result<Self, VolumeError> {
        let n = check_shape(dims, origin, voxel_size)?;
        if data.len() != n * CHANNELS {
            return Err(VolumeError::LengthMismatch {
                what: "voxel data (6 values per voxel)",
                expected: n * CHANNELS,
                found: data.len(),
            });
        }
        check_values(dims, &data)?;
        Ok(Self { dims, origin, voxel_size, data })
    }

    /// A grid whose voxel values are `f` at the voxel centres (evaluated in parallel, stored as
    /// `f32`).
    ///
    /// # Errors
    /// Those of [`VoxelGrid::new`]; [`VolumeError::InvalidVoxel`] when `f` gives an invalid
    /// value (or one that overflows `f32`).
    pub fn from_fn(
        dims: [u32; 3],
        origin: DVec3,
        voxel_size: DVec3,
        f: impl Fn(DVec3) -> Coefficients + Sync,
    ) -> Result<Self, VolumeError> {
        let n = check_shape(dims, origin, voxel_size)?;
        let mut data = vec![0.0f32; n * CHANNELS];
        let [nx, ny, _] = dims.map(|d| d as usize);
        data.par_chunks_mut(CHANNELS).enumerate().for_each(|(index, out)| {
            let (i, j, k) = (index % nx, (index / nx) % ny, index / (nx * ny));
            let centre = origin + (DVec3::new(i as f64, j as f64, k as f64) + 0.5) * voxel_size;
            for (o, v) in out.iter_mut().zip(f(centre).to_array()) {
                *o = v as f32;
            }
        });
        check_values(dims, &data)?;
        Ok(Self { dims, origin, voxel_size, data })
    }

    /// Reads a TCVOX1 file (see the [module documentation](self)).
    ///
    /// The header is checked, and the file's size compared with the size it declares, before
    /// the voxel data is read.
    ///
    /// # Errors
    /// [`VolumeError::Io`] if the file cannot be read; [`VolumeError::Refused`] if it is not a
    /// regular file or is larger than [`MAX_VOXEL_FILE_BYTES`]; otherwise
    /// [`VolumeError::VoxelFile`] naming the file around the error of [`VoxelGrid::from_bytes`].
    pub fn read(path: impl AsRef<Path>) -> Result<Self, VolumeError> {
        let path = path.as_ref();
        let refused = |e: InputError| match e {
            InputError::Io(source) => VolumeError::Io { path: path.to_path_buf(), source },
            source => VolumeError::Refused { path: path.to_path_buf(), source },
        };
        let in_file = |source: VolumeError| VolumeError::VoxelFile { path: path.to_path_buf(), source: Box::new(source) };
        let mut file = BoundedFile::open(path, Limits { max_bytes: MAX_VOXEL_FILE_BYTES, max_line: None }).map_err(refused)?;
        let found = file.len();
        let (head, _) = file.head().map_err(refused)?;
        let expected = declared_len(head).map_err(in_file)?;
        check_len(expected, found).map_err(in_file)?;
        let bytes = file.read_all().map_err(refused)?;
        Self::from_bytes(&bytes).map_err(in_file)
    }

    /// Parses the bytes of a TCVOX1 file.
    ///
    /// # Errors
    /// In this order: [`VolumeError::BadMagic`]; [`VolumeError::Truncated`] (`"header"`) for
    /// fewer than 72 bytes; [`VolumeError::UnsupportedChannels`]; [`VolumeError::ZeroDimension`];
    /// [`VolumeError::TooLarge`]; [`VolumeError::Truncated`] (`"voxel data"`) or
    /// [`VolumeError::TrailingBytes`] unless the length is 72 + 24·nx·ny·nz (both name the
    /// expected and the found byte counts); then the checks of [`VoxelGrid::new`].
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, VolumeError> {
        let expected = declared_len(bytes)?;
        check_len(expected, bytes.len() as u64)?;
        let u32_at = |o: usize| u32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
        let f64_at = |o: usize| {
            let mut b = [0u8; 8];
            b.copy_from_slice(&bytes[o..o + 8]);
            f64::from_le_bytes(b)
        };
        let dims = [u32_at(8), u32_at(12), u32_at(16)];
        let origin = DVec3::new(f64_at(24), f64_at(32), f64_at(40));
        let voxel_size = DVec3::new(f64_at(48), f64_at(56), f64_at(64));
        check_shape(dims, origin, voxel_size)?;
        let data = bytes[HEADER_BYTES..].par_chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
        Self::new(dims, origin, voxel_size, data)
    }

    /// The TCVOX1 bytes of this grid.
    #[must_use]
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(HEADER_BYTES + 4 * self.data.len());
        self.write_header(&mut out);
        for v in &self.data {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out
    }

    /// Writes the grid as a TCVOX1 file, replacing an existing file only once it is written
    /// whole ([`crate::output::write_atomically`]).
    ///
    /// # Errors
    /// [`VolumeError::Io`] naming the file.
    pub fn write(&self, path: impl AsRef<Path>) -> Result<(), VolumeError> {
        let path = path.as_ref();
        let io = |source| VolumeError::Io { path: path.to_path_buf(), source };
        crate::output::write_atomically(path, |file| {
            let mut header = Vec::with_capacity(HEADER_BYTES);
            self.write_header(&mut header);
            file.write_all(&header)?;
            let mut buffer = Vec::with_capacity(1 << 16);
            for chunk in self.data.chunks(1 << 14) {
                buffer.clear();
                for v in chunk {
                    buffer.extend_from_slice(&v.to_le_bytes());
                }
                file.write_all(&buffer)?;
            }
            Ok(())
        })
        .map_err(io)
    }

    fn write_header(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(&MAGIC);
        for d in self.dims {
            out.extend_from_slice(&d.to_le_bytes());
        }
        out.extend_from_slice(&(CHANNELS as u32).to_le_bytes());
        for v in self.origin.to_array().into_iter().chain(self.voxel_size.to_array()) {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }

    /// nx, ny, nz.
    #[must_use]
    pub fn dims(&self) -> [u32; 3] {
        self.dims
    }

    /// Minimum corner of voxel (0, 0, 0), scene units.
    #[must_use]
    pub fn origin(&self) -> DVec3 {
        self.origin
    }

    /// Edge lengths of a voxel, scene units.
    #[must_use]
    pub fn voxel_size(&self) -> DVec3 {
        self.voxel_size
    }

    /// The raw values: 6 per voxel, voxel-major, x fastest.
    #[must_use]
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// Number of voxels nx·ny·nz.
    #[must_use]
    pub fn voxel_count(&self) -> usize {
        self.data.len() / CHANNELS
    }

    /// The box the grid covers: (origin, origin + dims ∘ voxel_size).
    #[must_use]
    pub fn bounds(&self) -> (DVec3, DVec3) {
        let d = DVec3::new(f64::from(self.dims[0]), f64::from(self.dims[1]), f64::from(self.dims[2]));
        (self.origin, self.origin + d * self.voxel_size)
    }

    /// Linear index i + nx·(j + ny·k) of voxel (i, j, k), or `None` outside the grid.
    #[must_use]
    pub fn linear_index(&self, voxel: [u32; 3]) -> Option<usize> {
        if voxel.iter().zip(self.dims).any(|(&v, d)| v >= d) {
            return None;
        }
        let [nx, ny, _] = self.dims.map(|d| d as usize);
        let [i, j, k] = voxel.map(|v| v as usize);
        Some(i + nx * (j + ny * k))
    }

    /// The centre of voxel (i, j, k): origin + (i + ½, j + ½, k + ½) ∘ voxel_size.
    #[must_use]
    pub fn voxel_centre(&self, voxel: [u32; 3]) -> DVec3 {
        let v = DVec3::new(f64::from(voxel[0]), f64::from(voxel[1]), f64::from(voxel[2]));
        self.origin + (v + 0.5) * self.voxel_size
    }

    /// The stored coefficients of voxel (i, j, k), or `None` outside the grid.
    #[must_use]
    pub fn voxel(&self, voxel: [u32; 3]) -> Option<Coefficients> {
        let n = self.linear_index(voxel)?;
        let v = &self.data[CHANNELS * n..CHANNELS * (n + 1)];
        Some(Coefficients::from_array([0, 1, 2, 3, 4, 5].map(|c| f64::from(v[c]))))
    }

    /// The trilinear interpolation between voxel centres at `p` (scene units), clamped to the
    /// border outside the box of voxel centres (see the [module documentation](self)). A NaN
    /// coordinate samples the first voxel layer of its axis.
    #[must_use]
    pub fn sample(&self, p: DVec3) -> Coefficients {
        let u = (p - self.origin) / self.voxel_size - 0.5;
        let [ax, ay, az] = [0, 1, 2].map(|a| axis(u[a], self.dims[a]));
        let [nx, ny, _] = self.dims.map(|d| d as usize);
        let mut sum = [0.0f64; CHANNELS];
        for (k, wz) in [(az.0, 1.0 - az.2), (az.1, az.2)] {
            for (j, wy) in [(ay.0, 1.0 - ay.2), (ay.1, ay.2)] {
                for (i, wx) in [(ax.0, 1.0 - ax.2), (ax.1, ax.2)] {
                    let w = wx * wy * wz;
                    let n = i + nx * (j + ny * k);
                    for (s, &v) in sum.iter_mut().zip(&self.data[CHANNELS * n..CHANNELS * (n + 1)]) {
                        *s += w * f64::from(v);
                    }
                }
            }
        }
        Coefficients::from_array(sum)
    }

    /// The per-tet media of `mesh` (whose positions are in the grid's scene units) sampled
    /// from this grid with `sampling` ([`TetSampling::FivePoint`]: the mean of the samples at
    /// the centroid and the four degree-2 quadrature points), with the object's η and g.
    ///
    /// # Errors
    /// [`VolumeError::InvalidObjectParameter`] for an invalid η or g.
    pub fn per_tet(&self, mesh: &TetMesh, eta: f64, g: f64, sampling: TetSampling) -> Result<PerTetMedia, VolumeError> {
        PerTetMedia::from_field(mesh, self, eta, g, sampling)
    }
}

impl MediumField for VoxelGrid {
    fn coefficients(&self, p: DVec3) -> Coefficients {
        self.sample(p)
    }
}

/// The two voxel indices along one axis and the weight t of the second, for the continuous
/// voxel-centre coordinate `u` clamped to [0, n − 1].
/// The total length in bytes the header at the start of `bytes` declares, after the checks of
/// [`VoxelGrid::from_bytes`] up to [`VolumeError::TooLarge`], in its order.
fn declared_len(bytes: &[u8]) -> Result<u64, VolumeError> {
    let head = &bytes[..bytes.len().min(MAGIC.len())];
    if head != &MAGIC[..head.len()] {
        return Err(VolumeError::BadMagic { found: head.to_vec() });
    }
    if bytes.len() < HEADER_BYTES {
        return Err(VolumeError::Truncated { part: "header", expected: HEADER_BYTES as u64, found: bytes.len() as u64 });
    }
    let u32_at = |o: usize| u32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
    let dims = [u32_at(8), u32_at(12), u32_at(16)];
    let channels = u32_at(20);
    if channels as usize != CHANNELS {
        return Err(VolumeError::UnsupportedChannels { found: channels });
    }
    if dims.contains(&0) {
        return Err(VolumeError::ZeroDimension { dims });
    }
    dims.iter()
        .try_fold(4 * CHANNELS as u64, |acc, &d| acc.checked_mul(u64::from(d)))
        .and_then(|data| data.checked_add(HEADER_BYTES as u64))
        .ok_or(VolumeError::TooLarge { dims, channels })
}

/// [`VolumeError::Truncated`] or [`VolumeError::TrailingBytes`] unless `found == expected`.
fn check_len(expected: u64, found: u64) -> Result<(), VolumeError> {
    if found < expected {
        return Err(VolumeError::Truncated { part: "voxel data", expected, found });
    }
    if found > expected {
        return Err(VolumeError::TrailingBytes { expected, found });
    }
    Ok(())
}

fn axis(u: f64, n: u32) -> (usize, usize, f64) {
    let max = f64::from(n - 1);
    // `u >= 0.0` is false for NaN: NaN samples the first layer.
    let u = if u >= 0.0 { u.min(max) } else { 0.0 };
    if n == 1 {
        return (0, 0, 0.0);
    }
    let i0 = (u.floor() as usize).min(n as usize - 2);
    (i0, i0 + 1, u - i0 as f64)
}

/// Checks dims, origin and voxel size; returns the voxel count.
fn check_shape(dims: [u32; 3], origin: DVec3, voxel_size: DVec3) -> Result<usize, VolumeError> {
    if dims.contains(&0) {
        return Err(VolumeError::ZeroDimension { dims });
    }
    let channels = CHANNELS as u32;
    let n = dims
        .iter()
        .try_fold(CHANNELS, |acc, &d| acc.checked_mul(d as usize))
        .and_then(|values| values.checked_mul(4))
        .ok_or(VolumeError::TooLarge { dims, channels })?
        / (4 * CHANNELS);
    if !origin.is_finite() {
        return Err(VolumeError::InvalidGeometry {
            field: "origin",
            value: origin.to_array(),
            requirement: "must be finite (scene units)",
        });
    }
    if !(voxel_size.is_finite() && voxel_size.min_element() > 0.0) {
        return Err(VolumeError::InvalidGeometry {
            field: "voxel_size",
            value: voxel_size.to_array(),
            requirement: "every edge length must be finite and > 0 (scene units)",
        });
    }
    Ok(n)
}

/// Every value finite and ≥ 0, σa + σ′s > 0 per colour; the first invalid voxel in linear order
/// is reported.
fn check_values(dims: [u32; 3], data: &[f32]) -> Result<(), VolumeError> {
    let first = data
        .par_chunks_exact(CHANNELS)
        .enumerate()
        .filter_map(|(index, v)| voxel_error(v).map(|(channel, value, requirement)| (index, channel, value, requirement)))
        .find_first(|_| true);
    match first {
        None => Ok(()),
        Some((index, channel, value, requirement)) => {
            let [nx, ny, _] = dims.map(|d| d as usize);
            let voxel = [index % nx, (index / nx) % ny, index / (nx * ny)].map(|x| x as u32);
            Err(VolumeError::InvalidVoxel { voxel, index, channel, value, requirement })
        }
    }
}

/// What is wrong with one voxel's six values, if anything: (channel, value, requirement).
fn voxel_error(v: &[f32]) -> Option<(usize, f64, &'static str)> {
    if let Some(c) = v.iter().position(|x| !(x.is_finite() && *x >= 0.0)) {
        return Some((c, f64::from(v[c]), "must be finite and >= 0 (mm^-1)"));
    }
    (0..3).find(|&c| f64::from(v[c]) + f64::from(v[c + 3]) <= 0.0).map(|c| {
        (
            c,
            f64::from(v[c]) + f64::from(v[c + 3]),
            "sigma_a + sigma_s_prime of this colour must be > 0 (the voxel must absorb or scatter)",
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn linear_grid() -> VoxelGrid {
        // Values exactly representable in f32 at the voxel centres.
        VoxelGrid::from_fn([5, 4, 3], DVec3::new(1.0, -2.0, 0.5), DVec3::new(0.5, 0.25, 1.0), |p| {
            let v = 10.0 + p.x + 2.0 * p.y + 0.5 * p.z;
            Coefficients::new([v, 2.0 * v, 0.0], [1.0, v, v + 1.0])
        })
        .unwrap()
    }

    #[test]
    fn header_is_72_bytes_little_endian() {
        let grid = linear_grid();
        let bytes = grid.to_bytes();
        assert_eq!(bytes.len(), 72 + 24 * 60);
        assert_eq!(&bytes[..8], b"TCVOX1\0\0");
        assert_eq!(&bytes[8..24], &[5, 0, 0, 0, 4, 0, 0, 0, 3, 0, 0, 0, 6, 0, 0, 0]);
        assert_eq!(&bytes[24..32], &1.0f64.to_le_bytes());
        assert_eq!(&bytes[64..72], &1.0f64.to_le_bytes());
        // Voxel (1, 0, 0), channel 1 (σa green) is the 8th float.
        let c = grid.voxel_centre([1, 0, 0]);
        let v = 2.0 * (10.0 + c.x + 2.0 * c.y + 0.5 * c.z);
        assert_eq!(&bytes[72 + 4 * 7..72 + 4 * 8], &(v as f32).to_le_bytes());
        assert_eq!(VoxelGrid::from_bytes(&bytes).unwrap(), grid);
    }

    #[test]
    fn trilinear_sampling_reproduces_linear_fields_and_clamps_outside() {
        let grid = linear_grid();
        let f = |p: DVec3| 10.0 + p.x + 2.0 * p.y + 0.5 * p.z;
        let (lo, hi) = grid.bounds();
        let inner_lo = lo + 0.5 * grid.voxel_size();
        let inner_hi = hi - 0.5 * grid.voxel_size();
        for s in 0..=10 {
            let t = DVec3::new(s as f64 / 10.0, (s * 7 % 11) as f64 / 10.0, (s * 3 % 11) as f64 / 10.0).min(DVec3::ONE);
            let p = inner_lo + t * (inner_hi - inner_lo);
            let c = grid.sample(p);
            assert!((c.sigma_a[0] - f(p)).abs() < 1e-12, "{p}");
            assert!((c.sigma_s_prime[2] - f(p) - 1.0).abs() < 1e-12);
        }
        // Outside: the value at the nearest point of the box of centres.
        let p = DVec3::new(-100.0, 0.3 * inner_lo.y + 0.7 * inner_hi.y, 1e9);
        let q = p.clamp(inner_lo, inner_hi);
        assert!((grid.sample(p).sigma_a[0] - f(q)).abs() < 1e-12);
        let nan = grid.sample(DVec3::new(f64::NAN, inner_lo.y, inner_lo.z));
        assert_eq!(nan, grid.voxel([0, 0, 0]).unwrap());
    }

    #[test]
    fn single_voxel_axes_are_constant() {
        let grid = VoxelGrid::new([1, 1, 1], DVec3::ZERO, DVec3::ONE, vec![0.5, 0.25, 0.0, 1.0, 2.0, 3.0]).unwrap();
        let c = grid.sample(DVec3::new(7.0, -3.0, 0.2));
        assert_eq!(c, Coefficients::new([0.5, 0.25, 0.0], [1.0, 2.0, 3.0]));
    }

    #[test]
    fn invalid_grids_are_named() {
        let ok = vec![0.1f32; 6 * 8];
        assert!(matches!(
            VoxelGrid::new([2, 0, 4], DVec3::ZERO, DVec3::ONE, vec![]),
            Err(VolumeError::ZeroDimension { dims: [2, 0, 4] })
        ));
        assert!(matches!(
            VoxelGrid::new([2, 2, 2], DVec3::ZERO, DVec3::new(1.0, 0.0, 1.0), ok.clone()),
            Err(VolumeError::InvalidGeometry { field: "voxel_size", .. })
        ));
        assert!(matches!(
            VoxelGrid::new([2, 2, 2], DVec3::new(f64::NAN, 0.0, 0.0), DVec3::ONE, ok.clone()),
            Err(VolumeError::InvalidGeometry { field: "origin", .. })
        ));
        assert!(matches!(
            VoxelGrid::new([2, 2, 2], DVec3::ZERO, DVec3::ONE, vec![0.1; 47]),
            Err(VolumeError::LengthMismatch { expected: 48, found: 47, .. })
        ));
        let mut bad = ok.clone();
        bad[6 * 5 + 3] = -1.0; // voxel (1, 0, 1), σ′s red
        bad[6 * 6 + 1] = f32::NAN; // later voxel: not reported
        let e = VoxelGrid::new([2, 2, 2], DVec3::ZERO, DVec3::ONE, bad).unwrap_err();
        assert!(
            matches!(e, VolumeError::InvalidVoxel { voxel: [1, 0, 1], index: 5, channel: 3, value, .. } if value == -1.0),
            "{e}"
        );
        let mut empty = ok;
        empty[6 * 2 + 2] = 0.0;
        empty[6 * 2 + 5] = 0.0;
        let e = VoxelGrid::new([2, 2, 2], DVec3::ZERO, DVec3::ONE, empty).unwrap_err();
        assert!(matches!(e, VolumeError::InvalidVoxel { voxel: [0, 1, 0], channel: 2, .. }), "{e}");
        assert!(e.to_string().contains("sigma_a + sigma_s_prime"), "{e}");
        let huge = VoxelGrid::from_bytes(&header([u32::MAX; 3], 6));
        assert!(matches!(huge, Err(VolumeError::TooLarge { .. })));
    }

    fn header(dims: [u32; 3], channels: u32) -> Vec<u8> {
        let mut b = MAGIC.to_vec();
        for d in dims {
            b.extend_from_slice(&d.to_le_bytes());
        }
        b.extend_from_slice(&channels.to_le_bytes());
        for v in [0.0f64, 0.0, 0.0, 1.0, 1.0, 1.0] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b
    }

    #[test]
    fn malformed_bytes_are_named() {
        assert!(matches!(VoxelGrid::from_bytes(b"TCVOX2\0\0rest"), Err(VolumeError::BadMagic { .. })));
        assert!(matches!(VoxelGrid::from_bytes(b"PK"), Err(VolumeError::BadMagic { found }) if found == b"PK"));
        assert!(matches!(
            VoxelGrid::from_bytes(b"TCVOX"),
            Err(VolumeError::Truncated { part: "header", expected: 72, found: 5 })
        ));
        assert!(matches!(VoxelGrid::from_bytes(&header([1, 1, 1], 3)), Err(VolumeError::UnsupportedChannels { found: 3 })));
        assert!(matches!(VoxelGrid::from_bytes(&header([1, 0, 1], 6)), Err(VolumeError::ZeroDimension { .. })));
        let mut b = header([1, 1, 2], 6);
        b.extend_from_slice(&[0u8; 40]);
        assert!(matches!(
            VoxelGrid::from_bytes(&b),
            Err(VolumeError::Truncated { part: "voxel data", expected: 120, found: 112 })
        ));
        b.extend_from_slice(&[0u8; 12]);
        assert!(matches!(VoxelGrid::from_bytes(&b), Err(VolumeError::TrailingBytes { expected: 120, found: 124 })));
    }
}
