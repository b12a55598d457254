//! Writing output files so that a failed write leaves nothing half-written behind.
//!
//! A regular file is written to a temporary file beside it, committed to disk, then renamed over
//! the destination: a failure at any point (a full disk, a closed pipe in the encoder, an error
//! of the caller's own writer) removes the temporary file, and an existing file at the
//! destination keeps its old contents. A destination that is not a regular file (a device such
//! as `/dev/stdout` or `/dev/null`, a FIFO) is written in place: it cannot be replaced, and
//! renaming over it would remove the device. A symbolic link is followed: its target is
//! replaced, the link is kept.

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, ErrorKind};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Writes `path` through `write` (given a buffered writer), replacing it only once every byte
/// is written and committed. An existing regular file keeps its permissions.
///
/// # Errors
/// The first I/O error of creating, writing, committing or renaming, or the one `write`
/// returned; the destination is then as it was, and no temporary file is left.
pub fn write_atomically(path: &Path, write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>) -> io::Result<()> {
    let existing = fs::metadata(path).ok();
    if existing.as_ref().is_some_and(|m| !m.is_file()) {
        if existing.as_ref().is_some_and(fs::Metadata::is_dir) {
            return Err(io::Error::new(ErrorKind::IsADirectory, "the output path is a directory"));
        }
        return write_in_place(path, write);
    }
    // The file a symbolic link points to is the one replaced.
    let target = if fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink()) {
        fs::canonicalize(path)?
    } else {
        path.to_path_buf()
    };
    let temporary = temporary_beside(&target)?;
    let result = (|| {
        let file = OpenOptions::new().write(true).create_new(true).open(&temporary)?;
        if let Some(m) = &existing {
            file.set_permissions(m.permissions())?;
        }
        let mut out = BufWriter::new(file);
        write(&mut out)?;
        let file = out.into_inner().map_err(io::IntoInnerError::into_error)?;
        file.sync_all()?;
        fs::rename(&temporary, &target)
    })();
    if result.is_err() {
        // Best effort: the error to report is the write's, not this one.
        let _ = fs::remove_file(&temporary);
    }
    result
}

/// Writes a destination that cannot be replaced (a device, a FIFO) directly. Committing it is
/// asked for, but a device that cannot be committed is not an error once every byte is written.
fn write_in_place(path: &Path, write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>) -> io::Result<()> {
    let mut out = BufWriter::new(OpenOptions::new().write(true).open(path)?);
    write(&mut out)?;
    let file = out.into_inner().map_err(io::IntoInnerError::into_error)?;
    match file.sync_all() {
        Err(e) if matches!(e.kind(), ErrorKind::InvalidInput | ErrorKind::Unsupported) => Ok(()),
        other => other,
    }
}

/// A name for a temporary file in `target`'s directory (hidden, naming the process and a
/// counter, so that concurrent writers never share one).
fn temporary_beside(target: &Path) -> io::Result<PathBuf> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = target
        .file_name()
        .ok_or_else(|| io::Error::new(ErrorKind::InvalidInput, "the output path names no file"))?
        .to_string_lossy();
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    Ok(target.with_file_name(format!(".{name}.{}.{n}.tmp", std::process::id())))
}

#[cfg(all(test, unix))]
mod tests {
    use std::os::unix::fs::FileTypeExt;

    use std::io::Write;

    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("transcut-output-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// The names in `dir`, sorted.
    fn listing(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> =
            fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into()).collect();
        names.sort();
        names
    }

    fn fail_after(bytes: &'static [u8]) -> impl FnOnce(&mut BufWriter<File>) -> io::Result<()> {
        move |out| {
            out.write_all(bytes)?;
            Err(io::Error::other("the encoder failed"))
        }
    }

    #[test]
    fn a_new_file_appears_only_when_complete() {
        let dir = scratch("new");
        let path = dir.join("out.bin");
        let e = write_atomically(&path, fail_after(b"half")).unwrap_err();
        assert_eq!(e.to_string(), "the encoder failed");
        assert!(listing(&dir).is_empty(), "{:?}", listing(&dir));
        write_atomically(&path, |out| out.write_all(b"whole")).unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"whole");
        assert_eq!(listing(&dir), ["out.bin"]);
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_its_permissions() {
        use std::os::unix::fs::PermissionsExt;
        let dir = scratch("old");
        let path = dir.join("out.bin");
        fs::write(&path, b"old").unwrap();
        fs::set_permissions(&path, fs::Permissions::from_mode(0o640)).unwrap();
        assert!(write_atomically(&path, fail_after(b"new but broken")).is_err());
        assert_eq!(fs::read(&path).unwrap(), b"old");
        assert_eq!(listing(&dir), ["out.bin"]);
        write_atomically(&path, |out| out.write_all(b"new")).unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"new");
        assert_eq!(fs::metadata(&path).unwrap().permissions().mode() & 0o777, 0o640);
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_link_is_kept_and_its_target_replaced() {
        let dir = scratch("link");
        let (target, link) = (dir.join("target.bin"), dir.join("link.bin"));
        fs::write(&target, b"old").unwrap();
        std::os::unix::fs::symlink(&target, &link).unwrap();
        write_atomically(&link, |out| out.write_all(b"new")).unwrap();
        assert!(fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(fs::read(&target).unwrap(), b"new");
        assert_eq!(listing(&dir), ["link.bin", "target.bin"]);
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_device_is_written_in_place_and_a_directory_refused() {
        write_atomically(Path::new("/dev/null"), |out| out.write_all(b"into the void")).unwrap();
        assert!(fs::metadata("/dev/null").unwrap().file_type().is_char_device());
        let dir = scratch("dir");
        let e = write_atomically(&dir, |out| out.write_all(b"x")).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::IsADirectory);
        assert!(write_atomically(Path::new("/nonexistent-dir/out.bin"), |out| out.write_all(b"x")).is_err());
        fs::remove_dir_all(dir).unwrap();
    }
}
