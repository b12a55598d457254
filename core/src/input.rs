//! Bounded reading of input files, and bounded quoting of input in messages.
//!
//! Every reader of the library (meshes, voxel grids, environment maps) and the scene files of
//! the command line open their files through [`BoundedFile`]: only regular files are read (a
//! device such as `/dev/zero` or a FIFO is refused before it is opened, so nothing blocks or
//! streams forever), a file larger than the reader's documented maximum is refused from its
//! metadata, the first [`HEAD_BYTES`] are handed to the reader to check its magic number or first
//! line before anything else is read, and text formats get a line-length cap that is checked as
//! the bytes arrive, so one endless line is refused without holding it.
//!
//! [`quote`] and [`fmt_num`] keep what a message repeats from its input short: a token or line
//! to 80 characters with its total length, a number to at most 17 significant digits.

use std::fmt::Write as _;
use std::fs::File;
use std::io::Read;
use std::path::Path;

/// How many bytes [`BoundedFile::head`] reads for the reader to check before the rest.
pub const HEAD_BYTES: usize = 64 * 1024;

/// How many characters of an input token or line [`quote`] shows.
pub const QUOTE_CHARS: usize = 80;

/// The bounds a reader puts on its input file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// The largest file accepted, in bytes.
    pub max_bytes: u64,
    /// For text formats: the longest line accepted, in bytes without its line end (`\n`,
    /// `\r\n` or `\r`). `None` for binary formats.
    pub max_line: Option<usize>,
}

/// Why an input file was refused or could not be read. The reader's own error names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum InputError {
    /// The operating system could not open or read the file.
    #[error("{0}")]
    Io(#[source] std::io::Error),
    /// The path is a directory, device, FIFO or socket: only regular files are read.
    #[error("it is a {kind}, not a regular file")]
    NotRegularFile {
        /// What it is, e.g. `"character device"`.
        kind: &'static str,
    },
    /// The file is larger than the reader accepts.
    #[error("it is {size} bytes, more than the {max} bytes this reader accepts")]
    TooLarge {
        /// Its size (or as much as was read when it grew while being read).
        size: u64,
        /// The reader's maximum.
        max: u64,
    },
    /// A line of a text file is longer than the reader accepts.
    #[error("line {line} is longer than {max} bytes")]
    LineTooLong {
        /// 1-based line number.
        line: usize,
        /// The reader's maximum line length.
        max: usize,
    },
}

/// An input file opened for bounded reading: see the [module documentation](self).
#[derive(Debug)]
pub struct BoundedFile {
    file: File,
    limits: Limits,
    /// The file's size when it was opened, to reserve for [`read_all`](Self::read_all).
    len_hint: u64,
    /// Everything read so far.
    bytes: Vec<u8>,
    /// The line-length state after `bytes`.
    lines: LineScan,
    /// Whether the end of the file has been reached.
    at_end: bool,
}

impl BoundedFile {
    /// Opens `path` after checking from its metadata that it is a regular file no larger than
    /// `limits.max_bytes`.
    ///
    /// # Errors
    /// [`InputError::NotRegularFile`], [`InputError::TooLarge`], [`InputError::Io`].
    pub fn open(path: &Path, limits: Limits) -> Result<Self, InputError> {
        // Metadata first: opening a FIFO for reading blocks until a writer appears.
        let meta = std::fs::metadata(path).map_err(InputError::Io)?;
        check_metadata(&meta, limits.max_bytes)?;
        let file = File::open(path).map_err(InputError::Io)?;
        // The path may have been replaced between the two calls: check what was opened.
        let opened = file.metadata().map_err(InputError::Io)?;
        check_metadata(&opened, limits.max_bytes)?;
        Ok(Self { file, limits, len_hint: opened.len(), bytes: Vec::new(), lines: LineScan::default(), at_end: false })
    }

    /// The first [`HEAD_BYTES`] of the file (all of it if it is shorter), for the reader to check
    /// its magic number or first line before reading the rest, and whether they are the whole
    /// file.
    ///
    /// # Errors
    /// [`InputError::Io`], and [`InputError::LineTooLong`] when the head already holds a line
    /// longer than the limit.
    pub fn head(&mut self) -> Result<(&[u8], bool), InputError> {
        self.fill(HEAD_BYTES)?;
        if !self.at_end && self.bytes.len() == HEAD_BYTES {
            // One more read tells whether the head is all there is.
            self.fill(HEAD_BYTES + 1)?;
        }
        let all = self.at_end && self.bytes.len() <= HEAD_BYTES;
        Ok((&self.bytes[..self.bytes.len().min(HEAD_BYTES)], all))
    }

    /// The file's size in bytes when it was opened.
    #[must_use]
    pub fn len(&self) -> u64 {
        self.len_hint
    }

    /// Whether the file was empty when it was opened.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len_hint == 0
    }

    /// Reads the rest of the file and returns all of it.
    ///
    /// # Errors
    /// [`InputError::Io`], [`InputError::TooLarge`] if the file grew past the limit while being
    /// read, [`InputError::LineTooLong`].
    pub fn read_all(mut self) -> Result<Vec<u8>, InputError> {
        let hint = usize::try_from(self.len_hint).unwrap_or(0);
        self.bytes.reserve(hint.saturating_sub(self.bytes.len()).saturating_add(1));
        self.fill(usize::MAX)?;
        Ok(self.bytes)
    }

    /// Reads until `want` bytes are held or the file ends, checking the size and line limits on
    /// each chunk as it arrives.
    fn fill(&mut self, want: usize) -> Result<(), InputError> {
        const CHUNK: usize = 64 * 1024;
        while !self.at_end && self.bytes.len() < want {
            let start = self.bytes.len();
            let n = CHUNK.min(want - start);
            self.bytes.resize(start + n, 0);
            let got = loop {
                match self.file.read(&mut self.bytes[start..]) {
                    Ok(got) => break got,
                    Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                    Err(e) => {
                        self.bytes.truncate(start);
                        return Err(InputError::Io(e));
                    }
                }
            };
            self.bytes.truncate(start + got);
            if got == 0 {
                self.at_end = true;
            }
            if self.bytes.len() as u64 > self.limits.max_bytes {
                return Err(InputError::TooLarge { size: self.bytes.len() as u64, max: self.limits.max_bytes });
            }
            if let Some(max) = self.limits.max_line {
                self.lines.scan(&self.bytes[start..], max)?;
            }
        }
        Ok(())
    }
}

/// Refuses what is not a regular file, or is larger than `max_bytes`.
fn check_metadata(meta: &std::fs::Metadata, max_bytes: u64) -> Result<(), InputError> {
    if !meta.is_file() {
        return Err(InputError::NotRegularFile { kind: file_kind(&meta.file_type()) });
    }
    if meta.len() > max_bytes {
        return Err(InputError::TooLarge { size: meta.len(), max: max_bytes });
    }
    Ok(())
}

/// A name for a kind of file that is not a regular file.
fn file_kind(ty: &std::fs::FileType) -> &'static str {
    if ty.is_dir() {
        return "directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if ty.is_fifo() {
            return "FIFO";
        }
        if ty.is_char_device() {
            return "character device";
        }
        if ty.is_block_device() {
            return "block device";
        }
        if ty.is_socket() {
            return "socket";
        }
    }
    "special file"
}

/// The line-length check of a byte stream fed in chunks: `\n`, `\r\n` and `\r` end lines.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct LineScan {
    /// 1-based number of the line being read.
    line: usize,
    /// Bytes of that line so far.
    run: usize,
    /// Whether the last byte seen was `\r` (so a `\n` after it ends no further line).
    after_cr: bool,
}

impl Default for LineScan {
    fn default() -> Self {
        Self { line: 1, run: 0, after_cr: false }
    }
}

impl LineScan {
    /// Feeds the next chunk.
    ///
    /// # Errors
    /// [`InputError::LineTooLong`] naming the first line that exceeds `max` bytes.
    fn scan(&mut self, chunk: &[u8], max: usize) -> Result<(), InputError> {
        for &b in chunk {
            match b {
                b'\n' => {
                    if !self.after_cr {
                        self.line += 1;
                    }
                    self.run = 0;
                }
                b'\r' => {
                    self.line += 1;
                    self.run = 0;
                }
                _ => {
                    self.run += 1;
                    if self.run > max {
                        return Err(InputError::LineTooLong { line: self.line, max });
                    }
                }
            }
            self.after_cr = b == b'\r';
        }
        Ok(())
    }
}

/// `text` in single quotes for a message: at most [`QUOTE_CHARS`] characters, control
/// characters escaped (an escape such as `\u{1b}` counts as the characters it takes); a longer
/// text is cut with `…` and its length in bytes is added.
#[must_use]
pub fn quote(text: &str) -> String {
    shorten(text, "'")
}

/// [`quote`] without the quotes, for names a message already sets apart (element and property
/// names, paths of scene files).
#[must_use]
pub fn clip(text: &str) -> String {
    shorten(text, "")
}

/// `text` between `mark`s, cut and escaped as [`quote`] says.
fn shorten(text: &str, mark: &str) -> String {
    let mut out = String::with_capacity(QUOTE_CHARS + 24);
    out.push_str(mark);
    let (mut used, mut cut) = (0, false);
    for c in text.chars() {
        let width = if c.is_control() { c.escape_debug().count() } else { 1 };
        if used + width > QUOTE_CHARS {
            cut = true;
            break;
        }
        used += width;
        if c.is_control() {
            out.extend(c.escape_debug());
        } else {
            out.push(c);
        }
    }
    if cut {
        let _ = write!(out, "…{mark} ({} bytes)", text.len());
    } else {
        out.push_str(mark);
    }
    out
}

/// A number for a message, never longer than 24 characters: the shortest text that reads back
/// as the same `f64` when its magnitude is in [1e-4, 1e15) (or it is 0), else scientific
/// notation (`1e300`, `-2.5e-7`), as `%g` does; `NaN`, `inf` and `-inf` as Rust writes them.
#[must_use]
pub fn fmt_num(x: f64) -> String {
    let a = x.abs();
    if !x.is_finite() || a == 0.0 || (1e-4..1e15).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A vector for a message, `[x, y, z]` with each component as [`fmt_num`] writes it.
#[must_use]
pub fn fmt_vec(v: &[f64]) -> String {
    let parts: Vec<String> = v.iter().map(|&x| fmt_num(x)).collect();
    format!("[{}]", parts.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_scan_counts_every_line_end_once() {
        let mut s = LineScan::default();
        s.scan(b"ab\r\ncd\ref\ngh", 10).unwrap();
        assert_eq!(s, LineScan { line: 4, run: 2, after_cr: false });
        // A CRLF split across two chunks is still one line end.
        let mut s = LineScan::default();
        s.scan(b"ab\r", 10).unwrap();
        s.scan(b"\ncd", 10).unwrap();
        assert_eq!(s.line, 2);
        assert_eq!(s.run, 2);
    }

    #[test]
    fn line_scan_names_the_long_line() {
        let mut s = LineScan::default();
        s.scan(b"1234\n12345\n", 5).unwrap();
        let e = s.scan(b"123456", 5).unwrap_err();
        assert!(matches!(e, InputError::LineTooLong { line: 3, max: 5 }), "{e}");
        assert_eq!(e.to_string(), "line 3 is longer than 5 bytes");
    }

    #[test]
    fn quote_cuts_long_text_and_escapes_controls() {
        assert_eq!(quote("abc"), "'abc'");
        assert_eq!(quote("a\0b"), "'a\\0b'");
        let long = "x".repeat(1000);
        let q = quote(&long);
        assert_eq!(q, format!("'{}…' (1000 bytes)", "x".repeat(80)));
        // Exactly the limit is not cut.
        assert_eq!(quote(&"y".repeat(80)), format!("'{}'", "y".repeat(80)));
        assert_eq!(clip("face"), "face");
        assert_eq!(clip(&"z".repeat(81)), format!("{}… (81 bytes)", "z".repeat(80)));
        // Escapes count as the characters they take: 80 ESC bytes would be 480 characters.
        // 13 escapes of 6 characters fit in 80, the 14th does not.
        let escapes = quote(&"\u{1b}".repeat(80));
        assert_eq!(escapes, format!("'{}…' (80 bytes)", "\\u{1b}".repeat(13)));
        assert!(escapes.chars().count() <= 80 + 16, "{escapes}");
    }

    #[test]
    fn fmt_num_is_short_for_every_magnitude() {
        assert_eq!(fmt_num(1e300), "1e300");
        assert_eq!(fmt_num(-2.5e-7), "-2.5e-7");
        assert_eq!(fmt_num(0.25), "0.25");
        assert_eq!(fmt_num(123456.5), "123456.5");
        assert_eq!(fmt_num(0.0), "0");
        assert_eq!(fmt_num(f64::NAN), "NaN");
        assert_eq!(fmt_num(f64::NEG_INFINITY), "-inf");
        assert_eq!(fmt_num(f64::MAX), "1.7976931348623157e308");
        assert_eq!(fmt_vec(&[1e300, 0.5, -3.0]), "[1e300, 0.5, -3]");
        for x in [f64::MIN_POSITIVE, -f64::MAX, 1.0 / 3.0, 9.999_999_999_999_999e14, 1e15, 1e-4, 9.99e-5] {
            assert!(fmt_num(x).len() <= 24, "{x}: {}", fmt_num(x));
            assert_eq!(fmt_num(x).parse::<f64>().unwrap(), x);
        }
    }
}
