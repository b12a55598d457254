//! Every file reader of the core refuses what it cannot bound — a device, a FIFO, a directory,
//! a huge file whose first line is wrong, a file of one endless line — after reading at most a
//! few MiB, with a message of at most 1 KiB.
//!
//! One test function runs every case in turn, so that the bytes this process reads
//! (`rchar` of `/proc/self/io`, Linux) and its peak memory (`VmHWM`) can be measured per case
//! without other tests of the binary reading at the same time.

#![cfg(target_os = "linux")]

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use transcut::input::InputError;
use transcut::light::EquirectMap;
use transcut::mesh::{self, MeshError};
use transcut::volume::{VolumeError, VoxelGrid};

const MIB: u64 = 1 << 20;

fn dir() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("bounded-input");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A sparse file: `head`, then zeros up to `len` bytes (no disk blocks for the zeros).
fn sparse(name: &str, head: &[u8], len: u64) -> PathBuf {
    let path = dir().join(name);
    let mut f = File::create(&path).unwrap();
    f.write_all(head).unwrap();
    f.set_len(len).unwrap();
    path
}

/// A number from a `key: value` line of a /proc file.
fn proc_field(file: &str, key: &str) -> u64 {
    let text = std::fs::read_to_string(file).unwrap();
    let line = text.lines().find(|l| l.starts_with(key)).unwrap_or_else(|| panic!("{key} not in {file}"));
    line[key.len()..].trim_start_matches(':').split_whitespace().next().unwrap().parse().unwrap()
}

/// Runs `f` and checks what it read and kept: at most `max_read` bytes read from files, peak
/// memory not raised by more than 50 MB, and an error message of at most 1 KiB. Returns the
/// message; prints the measurements.
fn bounded<T: std::fmt::Debug, E: std::fmt::Display>(label: &str, max_read: u64, f: impl FnOnce() -> Result<T, E>) -> String {
    let read_before = proc_field("/proc/self/io", "rchar");
    let peak_before = proc_field("/proc/self/status", "VmHWM");
    let start = Instant::now();
    let result = f();
    let ms = start.elapsed().as_secs_f64() * 1e3;
    // The two /proc reads of `proc_field` count too: a few KiB.
    let read = proc_field("/proc/self/io", "rchar") - read_before;
    let peak_kib = proc_field("/proc/self/status", "VmHWM") - peak_before;
    let message = match result {
        Ok(v) => panic!("{label}: accepted: {v:?}"),
        Err(e) => e.to_string(),
    };
    println!("{label}: {ms:.2} ms, read {read} bytes, peak memory +{peak_kib} KiB: {message}");
    assert!(read <= max_read, "{label}: read {read} bytes, more than {max_read}");
    assert!(peak_kib < 50_000, "{label}: peak memory grew by {peak_kib} KiB");
    assert!(message.len() <= 1024, "{label}: message of {} bytes", message.len());
    message
}

#[test]
fn readers_refuse_what_they_cannot_bound() {
    // A device: refused from its metadata, nothing read.
    for p in ["/dev/zero", "/dev/urandom"] {
        let m = bounded(p, 64 << 10, || mesh::load(p));
        assert!(m.contains("character device"), "{m}");
        let e = mesh::load_obj(Path::new(p)).unwrap_err();
        assert!(matches!(e, MeshError::Refused { source: InputError::NotRegularFile { kind: "character device" }, .. }), "{e}");
        let e = VoxelGrid::read(p).unwrap_err();
        assert!(matches!(e, VolumeError::Refused { source: InputError::NotRegularFile { .. }, .. }), "{e}");
        bounded("env map on a device", 64 << 10, || EquirectMap::load(p, 1.0));
    }

    // A FIFO: refused unopened (opening it for reading would block: no writer).
    let fifo = dir().join("pipe.obj");
    let _ = std::fs::remove_file(&fifo);
    let made = std::process::Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    let m = bounded("FIFO", 64 << 10, || mesh::load(&fifo));
    assert!(m.contains("FIFO") && m.contains("pipe.obj"), "{m}");
    bounded("FIFO voxels", 64 << 10, || VoxelGrid::read(&fifo));
    bounded("FIFO env map", 64 << 10, || EquirectMap::load(&fifo, 1.0));

    // A directory.
    let m = bounded("directory", 64 << 10, || mesh::load(dir()));
    assert!(m.contains("directory"), "{m}");

    // 256 MiB whose first line is wrong: refused from the head (64 KiB).
    let big = 256 * MIB;
    let path = sparse("bad_first_line.obj", b"1 2 3\n", big);
    let m = bounded("256 MiB OBJ, bad first line", MIB, || mesh::load(&path));
    assert!(m.contains(":1: unexpected '1'"), "{m}");
    let path = sparse("bad_first_line.ply", b"plx\nformat ascii 1.0\n", big);
    let m = bounded("256 MiB PLY, bad first line", MIB, || mesh::load(&path));
    assert!(m.contains("not a PLY file"), "{m}");
    let path = sparse("bad_first_line.mesh", b"solid x\n", big);
    let m = bounded("256 MiB, unknown format", MIB, || mesh::load(&path));
    assert!(m.contains("not an OBJ or PLY file"), "{m}");
    let path = sparse("bad_magic.tcvox", b"TCVOX2\0\0", big);
    let m = bounded("256 MiB voxel file, bad magic", MIB, || VoxelGrid::read(&path));
    assert!(m.contains("not a TCVOX1 voxel file"), "{m}");
    let path = sparse("bad_magic.hdr", b"P6\n", big);
    let m = bounded("256 MiB env map, bad magic", MIB, || EquirectMap::load(&path, 1.0));
    assert!(m.contains("not a Radiance HDR or OpenEXR file"), "{m}");

    // A voxel header whose declared size disagrees with the file's: refused from the metadata.
    let mut header = b"TCVOX1\0\0".to_vec();
    for v in [4u32, 4, 4, 6] {
        header.extend_from_slice(&v.to_le_bytes());
    }
    header.resize(72, 0);
    let path = sparse("wrong_size.tcvox", &header, big);
    let m = bounded("256 MiB voxel file, 4³ header", MIB, || VoxelGrid::read(&path));
    assert!(m.contains(&format!("expected {} bytes in all, found {big}", 72 + 24 * 64)), "{m}");

    // One 1 GiB line (sparse: NUL bytes): refused at the line cap, the line never held.
    let gib = 1024 * MIB;
    let path = sparse("one_line.obj", b"v ", gib);
    let m = bounded("1 GiB line, OBJ", 2 * MIB, || mesh::load(&path));
    assert!(m.ends_with(&format!("line 1 is longer than {} bytes", mesh::MAX_OBJ_LINE_BYTES)), "{m}");
    let path = sparse("one_line.ply", b"ply\n", gib);
    let m = bounded("1 GiB line, PLY header", MIB, || mesh::load(&path));
    assert!(m.contains("the PLY header does not end within the first 65536 bytes"), "{m}");
    let path = sparse("one_line.mesh", b"v ", gib);
    bounded("1 GiB line, unknown extension", 2 * MIB, || mesh::load(&path));

    // A long line that is not the first: the cap names its line.
    let mut text = b"v 0 0 0\r\nv 1 0 0\rv 0 1 0\n".to_vec();
    text.extend(std::iter::repeat_n(b'#', mesh::MAX_OBJ_LINE_BYTES + 1));
    let path = dir().join("long_fourth_line.obj");
    std::fs::write(&path, &text).unwrap();
    let m = bounded("long 4th line", 4 * MIB, || mesh::load(&path));
    assert!(m.contains("line 4 is longer than"), "{m}");
    // At the cap exactly it is read.
    text.pop();
    text.extend_from_slice(b"\nf 1 2 3\n");
    std::fs::write(&path, &text).unwrap();
    assert_eq!(mesh::load(&path).unwrap().triangles().len(), 1);
}
