//! The `.tcprt` file: a precomputed transfer saved, so that a later session (or another program)
//! skips the precompute, the only slow step of the method (design/prt.md §4, "io.rs").
//!
//! A transfer is only valid for the surface, the receivers, the basis and the options it was
//! computed with. They are hashed into a [`PrecomputeKey`], stored in the file and compared on
//! load. The samples are not stored: they are a deterministic function of the same inputs
//! ([`super::SurfaceSamples::new`]) and cost milliseconds to make again.
//!
//! Layout (little-endian; `u64` counts):
//!
//! | bytes | what |
//! |---|---|
//! | 8 | magic `TCPRT\r\n\x1a` (a text-mode transfer or a truncation shows) |
//! | 4 | format version ([`VERSION`]) |
//! | 16 | the key |
//! | 4 + 4 + 8 + 4 + 8 + 8 | the options: samples_log2, basis terms K, terms_per_vertex, near_field, near_radius, seed |
//! | 8 | millimetres per scene unit of the surface (informative: the key holds the surface in mm) |
//! | 8 + 8 + 4 + 8 + 8 | receivers V, samples N, K, row offsets (V K + 1), entries E |
//! | 8 × 6 | the precompute's statistics: terms, entries, bytes, dropped mean and max, near radius |
//! | 8 (V K + 1) + E + 2 E + 4 V K | row offsets (u64), gaps (u8), values (i16), quantisation steps (f32) |
//! | 16 | a 128-bit hash of every byte before it |
//!
//! Reading checks every count against the others and the file's length, every row offset, that
//! no row's entries reach past the last sample, and the checksum, so a truncated, corrupt or
//! foreign file is an error naming what is wrong, never a wrong picture.

use std::fmt;
use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Write};
use std::path::{Path, PathBuf};

use glam::DVec3;

use super::basis::NODES;
use super::transfer::{Transfer, TransferStats};
use super::{BasisSize, PrtOptions, RdBasis};

/// The file's first bytes.
pub const MAGIC: [u8; 8] = *b"TCPRT\r\n\x1a";

/// The format version this library writes and reads: 3 since the compression weighs each
/// coefficient by its Haar level (the same layout as 2, other coefficients for the same key;
/// the key hashes the version, so a cache holding version 2 precomputes again).
pub const VERSION: u32 = 3;

/// What went wrong reading or writing a `.tcprt` file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PrecomputeFileError {
    /// The file could not be opened, read or written.
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The file is not a precompute this library can read: another format, another version,
    /// truncated or corrupt.
    #[error("{path}: {reason}")]
    Invalid { path: PathBuf, reason: String },
    /// The file holds the precompute of another surface or other options.
    #[error(
        "{path}: the precompute was made for another surface, scale, basis or options (its key {found}, this object's {wanted}); \
         precompute it again"
    )]
    KeyMismatch { path: PathBuf, found: PrecomputeKey, wanted: PrecomputeKey },
}

/// A 128-bit hash of everything a transfer depends on: the surface (positions in millimetres,
/// triangles), the receivers, the basis table and the options that shape the rows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct PrecomputeKey(pub [u64; 2]);

impl fmt::Display for PrecomputeKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:016x}{:016x}", self.0[0], self.0[1])
    }
}

impl PrecomputeKey {
    /// The key of the transfer from the samples of the surface (`positions` in mm, `triangles`)
    /// to `receivers` (mm) with `options` (its cache excluded: where a transfer is kept does
    /// not change it).
    #[must_use]
    pub fn new(positions: &[DVec3], triangles: &[[u32; 3]], receivers: &[DVec3], options: &PrtOptions) -> Self {
        let mut h = Hash128::new();
        h.words(&[u64::from(VERSION), positions.len() as u64, triangles.len() as u64, receivers.len() as u64]);
        for p in positions.iter().chain(receivers) {
            h.words(&[p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]);
        }
        for t in triangles {
            h.word(u64::from(t[0]) | u64::from(t[1]) << 32);
            h.word(u64::from(t[2]));
        }
        let basis = RdBasis::get(options.basis);
        h.word(basis.terms() as u64);
        for s in basis.singular_values() {
            h.word(s.to_bits());
        }
        for i in 0..NODES {
            for k in 0..basis.terms() {
                h.word(basis.node_value(i, k).to_bits());
            }
        }
        h.words(&[
            u64::from(options.samples_log2),
            options.terms_per_vertex as u64,
            u64::from(options.near_field),
            options.near_radius.to_bits(),
            options.seed,
        ]);
        Self(h.finish())
    }
}

/// What a `.tcprt` file says of itself before its arrays ([`read_header`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PrecomputeHeader {
    pub key: PrecomputeKey,
    /// The options the transfer was computed with (no cache).
    pub options: PrtOptions,
    /// Millimetres per scene unit of the surface it was computed on.
    pub mm_per_unit: f64,
    /// Receiver vertices.
    pub vertices: usize,
    /// Irradiance samples.
    pub samples: usize,
}

/// Writes `transfer` with its `key`, `options` and scale to `path`, through a temporary file
/// beside it renamed into place, so a reader never sees half a file.
///
/// # Errors
/// [`PrecomputeFileError::Io`].
pub fn write(
    path: &Path,
    key: PrecomputeKey,
    options: &PrtOptions,
    mm_per_unit: f64,
    transfer: &Transfer,
) -> Result<(), PrecomputeFileError> {
    let io = |source| PrecomputeFileError::Io { path: path.to_path_buf(), source };
    let name = path.file_name().map_or_else(|| "precompute".into(), |n| n.to_string_lossy().into_owned());
    let temporary = path.with_file_name(format!(".{name}.{}.partial", std::process::id()));
    let result = (|| {
        let mut w = HashingWriter { inner: BufWriter::with_capacity(1 << 20, File::create(&temporary)?), hash: Hash128::new() };
        w.put(&MAGIC)?;
        w.put(&VERSION.to_le_bytes())?;
        w.u64(key.0[0])?;
        w.u64(key.0[1])?;
        w.put(&options.samples_log2.to_le_bytes())?;
        w.put(&(options.basis.terms() as u32).to_le_bytes())?;
        w.u64(options.terms_per_vertex as u64)?;
        w.put(&u32::from(options.near_field).to_le_bytes())?;
        w.u64(options.near_radius.to_bits())?;
        w.u64(options.seed)?;
        w.u64(mm_per_unit.to_bits())?;
        w.u64(transfer.vertices as u64)?;
        w.u64(transfer.samples as u64)?;
        w.put(&(transfer.terms_per_row as u32).to_le_bytes())?;
        w.u64(transfer.row_start.len() as u64)?;
        w.u64(transfer.gaps.len() as u64)?;
        let s = &transfer.stats;
        let stats = [
            s.terms as u64,
            s.entries as u64,
            s.bytes as u64,
            s.dropped_mean.to_bits(),
            s.dropped_max.to_bits(),
            s.near_radius.to_bits(),
        ];
        for x in stats {
            w.u64(x)?;
        }
        for chunk in transfer.row_start.chunks(1 << 14) {
            let bytes: Vec<u8> = chunk.iter().flat_map(|x| x.to_le_bytes()).collect();
            w.put(&bytes)?;
        }
        w.put(&transfer.gaps)?;
        for chunk in transfer.values.chunks(1 << 15) {
            let bytes: Vec<u8> = chunk.iter().flat_map(|x| x.to_le_bytes()).collect();
            w.put(&bytes)?;
        }
        for chunk in transfer.steps.chunks(1 << 15) {
            let bytes: Vec<u8> = chunk.iter().flat_map(|x| x.to_le_bytes()).collect();
            w.put(&bytes)?;
        }
        let [a, b] = w.hash.finish();
        let mut inner = w.inner;
        inner.write_all(&a.to_le_bytes())?;
        inner.write_all(&b.to_le_bytes())?;
        inner.into_inner().map_err(std::io::IntoInnerError::into_error)?.sync_all()?;
        std::fs::rename(&temporary, path)
    })();
    if result.is_err() {
        // The partial file is useless; a failure to remove it changes nothing for the caller.
        let _ = std::fs::remove_file(&temporary);
    }
    result.map_err(io)
}

/// The header of the file at `path`, without its arrays (and without checking them).
///
/// # Errors
/// [`PrecomputeFileError`].
pub fn read_header(path: &Path) -> Result<PrecomputeHeader, PrecomputeFileError> {
    let mut r = open(path)?;
    r.header()
}

/// The transfer saved at `path`, which must have been made with `key`.
///
/// # Errors
/// [`PrecomputeFileError::KeyMismatch`] for another key; [`PrecomputeFileError::Invalid`] for a
/// file that is not a whole, intact precompute; [`PrecomputeFileError::Io`].
pub fn read(path: &Path, key: PrecomputeKey) -> Result<Transfer, PrecomputeFileError> {
    let mut r = open(path)?;
    let header = r.header()?;
    if header.key != key {
        return Err(PrecomputeFileError::KeyMismatch { path: path.to_path_buf(), found: header.key, wanted: key });
    }
    r.arrays(&header)
}

fn open(path: &Path) -> Result<Reader, PrecomputeFileError> {
    let file = File::open(path).map_err(|source| PrecomputeFileError::Io { path: path.to_path_buf(), source })?;
    let length = file.metadata().map_err(|source| PrecomputeFileError::Io { path: path.to_path_buf(), source })?.len();
    Ok(Reader { inner: BufReader::with_capacity(1 << 20, file), hash: Hash128::new(), path: path.to_path_buf(), length })
}

/// The bytes of the fixed-size part before the arrays.
const HEADER_BYTES: u64 = 8 + 4 + 16 + (4 + 4 + 8 + 4 + 8 + 8) + 8 + (8 + 8 + 4 + 8 + 8) + 6 * 8;

/// A buffered writer that hashes what it writes.
struct HashingWriter<W: Write> {
    inner: W,
    hash: Hash128,
}

impl<W: Write> HashingWriter<W> {
    fn put(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.hash.bytes(bytes);
        self.inner.write_all(bytes)
    }

    fn u64(&mut self, x: u64) -> std::io::Result<()> {
        self.put(&x.to_le_bytes())
    }
}

/// A buffered reader that hashes what it reads and names the file in its errors.
struct Reader {
    inner: BufReader<File>,
    hash: Hash128,
    path: PathBuf,
    length: u64,
}

impl Reader {
    fn invalid(&self, reason: impl Into<String>) -> PrecomputeFileError {
        PrecomputeFileError::Invalid { path: self.path.clone(), reason: reason.into() }
    }

    fn take(&mut self, out: &mut [u8]) -> Result<(), PrecomputeFileError> {
        match self.inner.read_exact(out) {
            Ok(()) => {
                self.hash.bytes(out);
                Ok(())
            }
            Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
                Err(self.invalid("the file ends early: it is truncated, or not a precompute"))
            }
            Err(source) => Err(PrecomputeFileError::Io { path: self.path.clone(), source }),
        }
    }

    fn u32(&mut self) -> Result<u32, PrecomputeFileError> {
        let mut b = [0; 4];
        self.take(&mut b)?;
        Ok(u32::from_le_bytes(b))
    }

    fn u64(&mut self) -> Result<u64, PrecomputeFileError> {
        let mut b = [0; 8];
        self.take(&mut b)?;
        Ok(u64::from_le_bytes(b))
    }

    fn count(&mut self, what: &str, at_most: u64) -> Result<usize, PrecomputeFileError> {
        let n = self.u64()?;
        if n > at_most {
            return Err(self.invalid(format!("{what} = {n} is more than the file can hold")));
        }
        usize::try_from(n).map_err(|_| self.invalid(format!("{what} = {n} does not fit in memory here")))
    }

    fn header(&mut self) -> Result<PrecomputeHeader, PrecomputeFileError> {
        if self.length < HEADER_BYTES + 16 {
            return Err(self.invalid(format!("{} bytes: too short for a precompute", self.length)));
        }
        let mut magic = [0; 8];
        self.take(&mut magic)?;
        if magic != MAGIC {
            return Err(self.invalid("not a .tcprt precompute (its first bytes are not TCPRT)"));
        }
        let version = self.u32()?;
        if version != VERSION {
            return Err(self.invalid(format!("format version {version}; this library reads version {VERSION}: precompute again")));
        }
        let key = PrecomputeKey([self.u64()?, self.u64()?]);
        let samples_log2 = self.u32()?;
        let basis = match self.u32()? {
            12 => BasisSize::K12,
            16 => BasisSize::K16,
            k => return Err(self.invalid(format!("a {k}-function basis: this library has 12 and 16"))),
        };
        let terms_per_vertex = self.count("terms_per_vertex", PrtOptions::MAX_TERMS_PER_VERTEX as u64)?;
        let near_field = match self.u32()? {
            0 => false,
            1 => true,
            x => return Err(self.invalid(format!("near_field = {x} is neither 0 nor 1"))),
        };
        let near_radius = f64::from_bits(self.u64()?);
        let seed = self.u64()?;
        let options = PrtOptions { samples_log2, basis, terms_per_vertex, near_field, near_radius, seed, cache: None };
        options.validate().map_err(|e| self.invalid(format!("options: {e}")))?;
        let mm_per_unit = f64::from_bits(self.u64()?);
        if !(mm_per_unit.is_finite() && mm_per_unit > 0.0) {
            return Err(self.invalid(format!("mm_per_unit = {mm_per_unit}")));
        }
        let vertices = self.count("vertices", self.length)?;
        let samples = self.count("samples", 1 << super::samples::MAX_SAMPLES_LOG2)?;
        if samples != 1 << samples_log2 {
            return Err(self.invalid(format!("{samples} samples, but samples_log2 = {samples_log2}")));
        }
        Ok(PrecomputeHeader { key, options, mm_per_unit, vertices, samples })
    }

    fn arrays(&mut self, header: &PrecomputeHeader) -> Result<Transfer, PrecomputeFileError> {
        let k = self.u32()? as usize;
        if k != header.options.basis.terms() {
            return Err(self.invalid(format!("rows of {k} basis functions in a {}-function file", header.options.basis.terms())));
        }
        let rows = header.vertices * k;
        let offsets = self.count("row offsets", self.length / 8)?;
        if offsets != rows + 1 {
            return Err(self.invalid(format!("{offsets} row offsets for {} vertices of {k} rows", header.vertices)));
        }
        let entries = self.count("entries", self.length / 3)?;
        let expected = HEADER_BYTES + 8 * offsets as u64 + 3 * entries as u64 + 4 * rows as u64 + 16;
        if self.length != expected {
            return Err(self.invalid(format!("{} bytes where its counts say {expected}: truncated or corrupt", self.length)));
        }
        let stats = TransferStats {
            terms: self.u64()? as usize,
            entries: self.u64()? as usize,
            bytes: self.u64()? as usize,
            dropped_mean: f64::from_bits(self.u64()?),
            dropped_max: f64::from_bits(self.u64()?),
            near_radius: f64::from_bits(self.u64()?),
        };
        let row_start: Vec<u64> = self.array(offsets, u64::from_le_bytes)?;
        let gaps: Vec<u8> = self.array(entries, u8::from_le_bytes)?;
        let values: Vec<i16> = self.array(entries, i16::from_le_bytes)?;
        let steps: Vec<f32> = self.array(rows, f32::from_le_bytes)?;
        let want = self.hash.finish();
        let mut tail = [0; 16];
        self.inner.read_exact(&mut tail).map_err(|source| PrecomputeFileError::Io { path: self.path.clone(), source })?;
        let found = [u64::from_le_bytes(tail[..8].try_into().unwrap()), u64::from_le_bytes(tail[8..].try_into().unwrap())];
        if found != want {
            return Err(self.invalid("the checksum does not match: the file is corrupt"));
        }
        if row_start[0] != 0 || row_start.windows(2).any(|w| w[1] < w[0]) || row_start[rows] != entries as u64 {
            return Err(self.invalid("the row offsets are not increasing from 0 to the entry count"));
        }
        if let Some(s) = steps.iter().find(|s| !(s.is_finite() && **s > 0.0)) {
            return Err(self.invalid(format!("a quantisation step of {s}")));
        }
        let transfer = Transfer {
            terms_per_row: k,
            vertices: header.vertices,
            samples: header.samples,
            row_start,
            gaps,
            values,
            steps,
            stats,
        };
        if let Some(row) = transfer.row_beyond_samples() {
            return Err(self.invalid(format!("row {row} names a sample beyond the last of {}", header.samples)));
        }
        Ok(transfer)
    }

    /// `n` little-endian values of `N` bytes each.
    fn array<T, const N: usize>(&mut self, n: usize, decode: fn([u8; N]) -> T) -> Result<Vec<T>, PrecomputeFileError> {
        let mut out = Vec::with_capacity(n);
        let mut buffer = vec![0u8; N * (1 << 15).min(n.max(1))];
        let mut left = n;
        while left > 0 {
            let m = left.min(1 << 15);
            self.take(&mut buffer[..m * N])?;
            out.extend(buffer[..m * N].chunks_exact(N).map(|b| decode(b.try_into().expect("chunks of N bytes"))));
            left -= m;
        }
        Ok(out)
    }
}

/// A streaming 128-bit hash: two independent 64-bit multiply–rotate lanes over little-endian
/// words, each finished by the SplitMix64 mixer with the length. Not cryptographic: it tells a
/// cache's keys apart and catches corrupt bytes, which is all it is for.
#[derive(Debug, Clone)]
struct Hash128 {
    lanes: [u64; 2],
    length: u64,
    /// Bytes not yet a whole word.
    pending: [u8; 8],
    filled: usize,
}

impl Hash128 {
    fn new() -> Self {
        Self { lanes: [0x243F_6A88_85A3_08D3, 0x1319_8A2E_0370_7344], length: 0, pending: [0; 8], filled: 0 }
    }

    fn word(&mut self, w: u64) {
        let [a, b] = &mut self.lanes;
        *a = (*a ^ w).wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(29);
        *b = (*b ^ w.rotate_left(23)).wrapping_mul(0xC2B2_AE3D_27D4_EB4F).rotate_left(31);
        self.length += 8;
    }

    fn words(&mut self, ws: &[u64]) {
        for &w in ws {
            self.word(w);
        }
    }

    fn bytes(&mut self, mut bytes: &[u8]) {
        if self.filled > 0 {
            let n = (8 - self.filled).min(bytes.len());
            self.pending[self.filled..self.filled + n].copy_from_slice(&bytes[..n]);
            self.filled += n;
            bytes = &bytes[n..];
            if self.filled < 8 {
                return;
            }
            self.filled = 0;
            self.word(u64::from_le_bytes(self.pending));
        }
        let mut words = bytes.chunks_exact(8);
        for w in &mut words {
            self.word(u64::from_le_bytes(w.try_into().expect("8 bytes")));
        }
        let rest = words.remainder();
        self.pending[..rest.len()].copy_from_slice(rest);
        self.filled = rest.len();
    }

    fn finish(&self) -> [u64; 2] {
        let mut lanes = self.lanes;
        if self.filled > 0 {
            let mut last = [0u8; 8];
            last[..self.filled].copy_from_slice(&self.pending[..self.filled]);
            let w = u64::from_le_bytes(last);
            lanes[0] = (lanes[0] ^ w).wrapping_mul(0x9E37_79B9_7F4A_7C15);
            lanes[1] = (lanes[1] ^ w.rotate_left(23)).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
        }
        let length = self.length + self.filled as u64;
        [splitmix(lanes[0] ^ length), splitmix(lanes[1] ^ length.rotate_left(32))]
    }
}

/// The SplitMix64 finaliser (Steele, Lea & Flood 2014).
fn splitmix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::super::samples::SurfaceSamples;
    use super::super::PrtCache;
    use super::*;
    use crate::mesh::icosphere;

    fn transfer(options: &PrtOptions) -> (Transfer, PrecomputeKey) {
        let sphere = icosphere(5.0, 2);
        let samples = SurfaceSamples::new(sphere.positions(), sphere.triangles(), options.samples_log2, options.seed).unwrap();
        let basis = RdBasis::get(options.basis);
        let t =
            Transfer::precompute(sphere.positions(), sphere.positions(), sphere.triangles(), &samples, basis, options, &|_| {
                Ok(())
            })
            .unwrap();
        let key = PrecomputeKey::new(sphere.positions(), sphere.triangles(), sphere.positions(), options);
        (t, key)
    }

    fn options() -> PrtOptions {
        PrtOptions { samples_log2: 8, terms_per_vertex: 100, ..PrtOptions::default() }
    }

    /// What is written is read back bit for bit, header included.
    #[test]
    fn round_trip_is_exact() {
        let dir = tempdir("round_trip");
        let path = dir.join("sphere.tcprt");
        let o = options();
        let (t, key) = transfer(&o);
        write(&path, key, &o, 2.5, &t).unwrap();
        let header = read_header(&path).unwrap();
        assert_eq!(header, PrecomputeHeader { key, options: o.clone(), mm_per_unit: 2.5, vertices: t.vertices, samples: 256 });
        let back = read(&path, key).unwrap();
        assert_eq!(back.row_start, t.row_start);
        assert_eq!((&back.gaps, &back.values), (&t.gaps, &t.values));
        assert_eq!(
            back.steps.iter().map(|s| s.to_bits()).collect::<Vec<_>>(),
            t.steps.iter().map(|s| s.to_bits()).collect::<Vec<_>>()
        );
        assert_eq!(back.stats, t.stats);
        assert_eq!(
            std::fs::metadata(&path).unwrap().len(),
            HEADER_BYTES + 8 * t.row_start.len() as u64 + 3 * t.gaps.len() as u64 + 4 * t.steps.len() as u64 + 16
        );
        std::fs::remove_dir_all(dir).unwrap();
    }

    /// Every input of the transfer changes the key; the cache location does not.
    #[test]
    fn the_key_sees_every_input() {
        let sphere = icosphere(5.0, 1);
        let (p, t) = (sphere.positions(), sphere.triangles());
        let o = options();
        let base = PrecomputeKey::new(p, t, p, &o);
        assert_eq!(base, PrecomputeKey::new(p, t, p, &PrtOptions { cache: Some(PrtCache::Folder("x".into())), ..o.clone() }));
        let mut moved = p.to_vec();
        moved[3].x += 1e-12;
        let mut flipped = t.to_vec();
        flipped[0].swap(1, 2);
        let others = [
            PrecomputeKey::new(&moved, t, p, &o),
            PrecomputeKey::new(p, &flipped, p, &o),
            PrecomputeKey::new(p, t, &p[1..], &o),
            PrecomputeKey::new(p, t, p, &PrtOptions { samples_log2: 9, ..o.clone() }),
            PrecomputeKey::new(p, t, p, &PrtOptions { basis: BasisSize::K12, ..o.clone() }),
            PrecomputeKey::new(p, t, p, &PrtOptions { terms_per_vertex: 101, ..o.clone() }),
            PrecomputeKey::new(p, t, p, &PrtOptions { near_field: false, ..o.clone() }),
            PrecomputeKey::new(p, t, p, &PrtOptions { near_radius: 8.5, ..o.clone() }),
            PrecomputeKey::new(p, t, p, &PrtOptions { seed: 1, ..o.clone() }),
        ];
        for (i, k) in others.iter().enumerate() {
            assert_ne!(*k, base, "input {i} did not change the key");
        }
    }

    /// A file of another key, a truncated file, a flipped byte anywhere and a foreign file are
    /// each refused with an error naming the reason.
    #[test]
    fn damaged_and_foreign_files_are_refused() {
        let dir = tempdir("damaged");
        let path = dir.join("a.tcprt");
        let o = options();
        let (t, key) = transfer(&o);
        write(&path, key, &o, 1.0, &t).unwrap();
        let other = PrecomputeKey([key.0[0] ^ 1, key.0[1]]);
        assert!(matches!(read(&path, other), Err(PrecomputeFileError::KeyMismatch { .. })));
        let bytes = std::fs::read(&path).unwrap();
        let bad = dir.join("bad.tcprt");
        let message = |data: &[u8]| {
            std::fs::write(&bad, data).unwrap();
            match read(&bad, key) {
                Err(PrecomputeFileError::Invalid { reason, .. }) => reason,
                other => panic!("accepted or other error: {other:?}"),
            }
        };
        assert!(message(&bytes[..bytes.len() - 1]).contains("bytes where its counts say"));
        assert!(message(&bytes[..40]).contains("too short"));
        let mut image = b"P6\n16 16\n255\n".to_vec();
        image.resize(14 + 16 * 16 * 3, 0x80);
        assert!(message(&image).contains("not a .tcprt"));
        let mut versioned = bytes.clone();
        versioned[8] = 9;
        assert!(message(&versioned).contains("version 9"));
        // Entries reaching past the last sample, written whole (the checksum matches).
        let mut beyond = t.clone();
        let first = beyond.row_start[1] as usize;
        beyond.gaps[first] = super::super::transfer::ESCAPE;
        beyond.values[first] = 300;
        let far = dir.join("far.tcprt");
        write(&far, key, &o, 1.0, &beyond).unwrap();
        match read(&far, key) {
            Err(PrecomputeFileError::Invalid { reason, .. }) => {
                assert!(reason.contains("row 1 names a sample beyond"), "{reason}")
            }
            other => panic!("accepted or other error: {other:?}"),
        }
        // A flipped bit in the arrays, past every count: only the checksum sees it.
        for at in [HEADER_BYTES as usize + 3, bytes.len() / 2, bytes.len() - 20] {
            let mut flipped = bytes.clone();
            flipped[at] ^= 0x10;
            assert!(message(&flipped).contains("checksum"), "byte {at}");
        }
        std::fs::remove_dir_all(dir).unwrap();
    }

    /// The streaming hash does not depend on how the bytes are split.
    #[test]
    fn hash_is_split_independent() {
        let data: Vec<u8> = (0..1000u32).map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8).collect();
        let mut whole = Hash128::new();
        whole.bytes(&data);
        for split in [1, 3, 7, 8, 9, 500, 999] {
            let mut h = Hash128::new();
            for chunk in data.chunks(split) {
                h.bytes(chunk);
            }
            assert_eq!(h.finish(), whole.finish(), "chunks of {split}");
        }
        let mut shorter = Hash128::new();
        shorter.bytes(&data[..999]);
        assert_ne!(shorter.finish(), whole.finish());
    }

    fn tempdir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("transcut-prt-io-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }
}
