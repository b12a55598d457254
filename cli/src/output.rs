//! Results written out: JSON on standard output with every write error reported (a closed
//! pipe, a full disk behind a redirection), where `println!` would panic; per-vertex radiance
//! as PLY, NumPy or raw f32.

use std::io::Write;
use std::path::Path;

use anyhow::{bail, Context};
use transcut::mesh::TriMesh;

/// Writes `value` as pretty-printed JSON and a newline to standard output, and flushes it.
///
/// # Errors
/// The serialisation or write error, naming standard output.
pub fn print_json(value: &impl serde::Serialize) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    serde_json::to_writer_pretty(&mut out, value)
        .map_err(anyhow::Error::from)
        .and_then(|()| out.write_all(b"\n").map_err(anyhow::Error::from))
        .and_then(|()| out.flush().map_err(anyhow::Error::from))
        .context("writing the JSON report to standard output")
}

/// Writes the header of a NumPy format 1.0 file of little-endian float32 in C order with
/// `shape`: magic, version, header length, the dict, padded to 64 bytes.
///
/// # Errors
/// The write error.
pub fn write_npy_header(out: &mut impl Write, shape: &[usize]) -> std::io::Result<()> {
    let dims: String = shape.iter().map(|d| format!("{d}, ")).collect();
    let dims = if shape.len() == 1 { dims.trim_end() } else { dims.trim_end_matches(", ") };
    let dict = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': ({dims}), }}");
    let mut header = dict.into_bytes();
    let total = 10 + header.len() + 1;
    header.extend(std::iter::repeat_n(b' ', (64 - total % 64) % 64));
    header.push(b'\n');
    out.write_all(b"\x93NUMPY\x01\x00")?;
    out.write_all(&(header.len() as u16).to_le_bytes())?;
    out.write_all(&header)
}

/// Writes `values` as little-endian float32, three per row.
///
/// # Errors
/// The write error.
pub fn write_f32(out: &mut impl Write, values: &[[f64; 3]]) -> std::io::Result<()> {
    for row in values {
        for c in row {
            out.write_all(&(*c as f32).to_le_bytes())?;
        }
    }
    Ok(())
}

/// Writes per-user-vertex radiance in the format the extension names.
pub fn write_radiance(path: &Path, mesh: &TriMesh, radiance: &[[f64; 3]]) -> anyhow::Result<()> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    if !matches!(ext.as_deref(), Some("ply" | "npy" | "raw")) {
        bail!("unknown output format (use .ply, .npy or .raw)");
    }
    transcut::output::write_atomically(path, |out| match ext.as_deref() {
        Some("ply") => write_ply(out, mesh, radiance),
        Some("npy") => {
            write_npy_header(out, &[radiance.len(), 3])?;
            write_f32(out, radiance)
        }
        _ => write_f32(out, radiance),
    })?;
    Ok(())
}

/// The user's mesh as binary PLY: vertices in the user's order with float `red green blue`;
/// faces are the welded triangles written with, for each welded vertex, its first user vertex.
fn write_ply(out: &mut impl Write, mesh: &TriMesh, radiance: &[[f64; 3]]) -> std::io::Result<()> {
    let map = mesh.user_to_internal();
    let mut representative = vec![u32::MAX; mesh.positions().len()];
    for (user, &internal) in map.iter().enumerate().rev() {
        representative[internal as usize] = user as u32;
    }
    writeln!(out, "ply\nformat binary_little_endian 1.0\ncomment libtranscut bake: radiance Lo(x, n), linear RGB")?;
    writeln!(out, "element vertex {}", map.len())?;
    writeln!(out, "property float x\nproperty float y\nproperty float z")?;
    writeln!(out, "property float red\nproperty float green\nproperty float blue")?;
    writeln!(out, "element face {}", mesh.triangles().len())?;
    writeln!(out, "property list uchar uint vertex_indices\nend_header")?;
    for (user, &internal) in map.iter().enumerate() {
        let p = mesh.positions()[internal as usize];
        for c in [p.x, p.y, p.z].into_iter().chain(radiance[user]) {
            out.write_all(&(c as f32).to_le_bytes())?;
        }
    }
    for t in mesh.triangles() {
        out.write_all(&[3u8])?;
        for &v in t {
            out.write_all(&representative[v as usize].to_le_bytes())?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn npy_headers_are_padded_and_name_the_shape() {
        for (shape, text) in [(&[5, 3][..], "(5, 3)"), (&[2, 7, 3][..], "(2, 7, 3)"), (&[4][..], "(4,)")] {
            let mut out = Vec::new();
            write_npy_header(&mut out, shape).unwrap();
            assert_eq!(out.len() % 64, 0);
            assert!(out.starts_with(b"\x93NUMPY\x01\x00") && out.ends_with(b"\n"));
            let header = String::from_utf8_lossy(&out[10..]);
            assert!(header.contains(&format!("'shape': {text}")), "{header}");
        }
    }
}
